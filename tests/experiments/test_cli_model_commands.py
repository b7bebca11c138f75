"""`pdmkit identify` and `pdmkit mismatch` from the command line (issue 4 and 5 CLIs)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy import signal

from pdmkit.experiments._cli import main

FS = 200.0


def _cli(*args) -> int:
    return main([str(a) for a in args])


def _two_mode_record(tmp_path, n=6000, seed=0):
    """A record of a known discrete system: modes at 12 Hz (zeta 0.05) and 40 Hz."""
    rng = np.random.default_rng(seed)
    poles = []
    for fn, zeta in ((12.0, 0.05), (40.0, 0.03)):
        wn = 2 * np.pi * fn
        s = -zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)
        poles += [np.exp(s / FS), np.exp(np.conj(s) / FS)]
    den = np.real(np.poly(poles))
    u = rng.normal(size=n)
    y = signal.lfilter([0.0, 0.2, 0.1], den, u)
    y += 0.01 * np.std(y) * rng.normal(size=n)
    path = tmp_path / "rig.csv"
    pd.DataFrame({"time": np.arange(n) / FS, "force": u, "accel": y}).to_csv(
        path, index=False
    )
    return path


def test_identify_oe_reports_the_true_modes(tmp_path, capsys):
    data = _two_mode_record(tmp_path)
    out = tmp_path / "out"
    code = main(
        [
            "identify",
            str(data),
            "--input",
            "force",
            "--output",
            "accel",
            "--structure",
            "oe",  # output error: unbiased under white measurement noise (ARX is not)
            "--order",
            "nb=3,nf=4,nk=0",
            "--out",
            str(out),
            "--json",
            str(tmp_path / "id.json"),
        ]
    )
    assert code == 0
    summary = json.loads((tmp_path / "id.json").read_text())
    for key in ("structure", "order", "poles", "natural_frequencies_hz", "damping"):
        assert key in summary
    np.testing.assert_allclose(summary["natural_frequencies_hz"], [12.0, 40.0], rtol=0.01)
    np.testing.assert_allclose(summary["damping"], [0.05, 0.03], rtol=0.1)
    assert summary["fit_percent"] > 95.0
    assert (out / "report.html").stat().st_size > 10_000
    assert "fit" in capsys.readouterr().err


def test_identify_hw_recovers_a_dead_zone(tmp_path):
    rng = np.random.default_rng(3)
    u = np.repeat(rng.uniform(-1, 1, 300), 10)
    dz = np.where(u > 0.3, u - 0.3, np.where(u < -0.3, u + 0.3, 0.0))
    y = signal.lfilter([0.0, 0.4], [1.0, -0.6], dz) + 0.002 * rng.normal(size=u.size)
    path = tmp_path / "valve.csv"
    pd.DataFrame({"cmd": u, "flow": y}).to_csv(path, index=False)
    code = _cli(
        "identify", path, "--input", "cmd", "--output", "flow", "--fs", 100,
        "--structure", "hw", "--order", "nb=1,nf=1,nk=1", "--out", tmp_path / "o",
    )  # fmt: skip
    assert code == 0
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    coef = summary["coefficients"]
    lower = next(v for k, v in coef.items() if "lower" in k.lower())
    upper = next(v for k, v in coef.items() if "upper" in k.lower())
    assert lower == pytest.approx(-0.3, rel=0.1) and upper == pytest.approx(0.3, rel=0.1)
    # the linear block's pole, as [real, imaginary] like the linear structures give it
    assert summary["poles"][0] == pytest.approx([0.6, 0.0], abs=0.02)


def test_identify_fractional_gives_the_issue_keys(tmp_path):
    from pdmkit.models import FractionalTF

    dt = 0.01
    true = FractionalTF.seed004(a=0.05, alpha=1.5, b=0.2, beta=0.5, c=1.0)
    rng = np.random.default_rng(2)
    u = rng.normal(size=3000)
    y = true.simulate(u, dt)
    y = y + 0.02 * np.std(y) * rng.normal(size=y.size)
    path = tmp_path / "frac.csv"
    pd.DataFrame({"time": np.arange(u.size) * dt, "u": u, "y": y}).to_csv(path, index=False)
    out = tmp_path / "o"
    code = _cli(
        "identify", path, "--input", "u", "--output", "y", "--structure", "fractional",
        "--out", out,
    )  # fmt: skip
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert {"alpha", "beta", "a", "b", "c", "fit_percent"} <= set(summary)
    assert summary["alpha"] == pytest.approx(1.5, abs=0.05)
    assert summary["beta"] == pytest.approx(0.5, abs=0.05)


def test_identify_missing_column_is_a_clear_error(tmp_path, capsys):
    data = _two_mode_record(tmp_path, n=500)
    out = tmp_path / "never"
    code = _cli("identify", data, "--input", "forse", "--output", "accel", "--out", out)
    assert code == 2
    err = capsys.readouterr().err
    assert "forse" in err and "rig.csv" in err
    assert not out.exists()


@pytest.mark.slow
def test_mismatch_cli_names_the_hidden_friction(tmp_path, capsys):
    from pdmkit.models import generate_concealed_case

    case = generate_concealed_case("coulomb_friction", 0.3, seed=4, n_samples=800)
    paths = case.write(tmp_path)
    out = tmp_path / "out"
    code = _cli(
        "mismatch",
        paths["model"],
        paths["data"],
        # the command's plumbing is the point: discovery between two rival effects
        # (the whole library is tested in tests/models)
        "--effects",
        "coulomb_friction,bias_force",
        "--out",
        out,
        "--json",
        tmp_path / "m.json",
    )
    assert code == 0
    summary = json.loads((tmp_path / "m.json").read_text())
    assert summary["verdict"]["effect"] == "coulomb_friction"
    assert summary["verdict"]["target"] == case.target
    assert summary["fit"]["rmse_augmented"] < 0.5 * summary["fit"]["rmse_nominal"]
    assert "verdict:" in capsys.readouterr().err


def test_features_cli_model_group_with_a_named_input_signal(tmp_path):
    from pdmkit.ensembles import Ensemble

    rng = np.random.default_rng(5)
    n, forces, accels = 4000, [], []
    for fn in (15.0, 30.0, 45.0):
        wn = 2 * np.pi * fn
        s = -0.03 * wn + 1j * wn * np.sqrt(1 - 0.03**2)
        den = np.real(np.poly([np.exp(s / FS), np.exp(np.conj(s) / FS)]))
        u = rng.normal(size=n)
        forces.append(u)
        accels.append(signal.lfilter([0.0, 1.0], den, u))
    ens = Ensemble({"Force": np.array(forces), "Accel": np.array(accels)}, fs=FS)
    ens.to_parquet(tmp_path / "rig")
    out = tmp_path / "feat"
    code = _cli(
        "features", "--ensemble", tmp_path / "rig", "--signals", "Accel",
        "--groups", "frf", "ar", "--option", "frf_input=Force",
        "--option", "frf_nperseg=512", "--option", "ar_order=2", "--out", out,
    )  # fmt: skip
    assert code == 0
    table = pd.read_parquet(out / "features.parquet")
    np.testing.assert_allclose(table["Accel/frf/PeakFreq"], [15, 30, 45], atol=0.5)
    np.testing.assert_allclose(table["Accel/ar/Freq1"], [15, 30, 45], rtol=0.01)
    assert _cli("features", "--ensemble", tmp_path / "rig", "--option", "nokey") == 2


def test_identify_hw_with_complex_poles_writes_json(tmp_path):
    rng = np.random.default_rng(8)
    u = np.repeat(rng.uniform(-1, 1, 200), 8)
    y = signal.lfilter(
        [0.0, 0.2], [1.0, -1.2, 0.5], np.clip(u, -0.6, 0.6)
    )  # poles 0.6±0.37j
    path = tmp_path / "osc.csv"
    pd.DataFrame({"u": u, "y": y}).to_csv(path, index=False)
    out = tmp_path / "o"
    args = ["--fs", 50, "--structure", "hw", "--order", "nb=1,nf=2,nk=1", "--out", out]
    assert _cli("identify", path, "--input", "u", "--output", "y", *args) == 0
    poles = json.loads((out / "summary.json").read_text())["poles"]
    assert len(poles) == 2 and all(len(p) == 2 for p in poles)
