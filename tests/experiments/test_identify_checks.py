"""``pdmkit identify`` checks itself (issue 15), workflow and CLI layer.

Each test failed on the code before the change: ``.mat``/``.npz`` refused, no
``--band``/``--decimate``, no note when the order search hit its edge, cancelled or
real poles listed as modes, a negative fit or an unstable model without a warning, the
FRF figure on a linear axis with the phases on different branches and no coherence, a
NaN mode frequency crashing the CLI's formatting.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy import io as sio
from scipy import signal

from pdmkit.experiments._cli import main
from pdmkit.experiments._identify import IDENTIFY_STRUCTURES, run_identify
from pdmkit.models.ident import IdentifiedModel


def zoh_modes(modes, fs):
    num_c, den_c = np.zeros(1), np.ones(1)
    for fn, zeta in modes:
        wn = 2 * np.pi * fn
        d = np.array([1.0, 2 * zeta * wn, wn**2])
        num_c = np.polyadd(np.polymul(num_c, d), wn**2 * den_c)
        den_c = np.polymul(den_c, d)
    num_d, den_d, _ = signal.cont2discrete((num_c, den_c), 1 / fs, method="zoh")
    return np.ravel(num_d), np.ravel(den_d)


def write_csv(folder, name, u, y, fs):
    path = folder / name
    t = np.arange(len(y)) / fs
    pd.DataFrame({"time": t, "u": u, "y": y}).to_csv(path, index=False)
    return path


def nearest_rel_err(found, target):
    found = np.asarray(found, dtype=float)
    return float(np.min(np.abs(found - target)) / target)


MODES = [(5.0, 0.02), (9.0, 0.03)]


@pytest.fixture(scope="module")
def fast_record():
    """Two low modes (5 and 9 Hz) sampled at 400 Hz, far below Nyquist, and a 120 Hz
    mode outside the 2-15 Hz band; white output noise."""
    fs = 400.0
    num, den = zoh_modes([*MODES, (120.0, 0.02)], fs)
    rng = np.random.default_rng(0)
    u = rng.normal(size=40000)
    y0 = signal.lfilter(num, den, u)
    y = y0 + 0.02 * np.std(y0) * rng.normal(size=y0.size)
    return u, y, fs


# ------------------------------------------------------------------ .mat / .npz
def test_mat_file_with_a_2d_variable_and_band(tmp_path, fast_record):
    u, y, fs = fast_record
    acc = np.vstack([np.zeros_like(y) + 1e-3 * np.arange(y.size), y, -y])  # 3 channels
    path = tmp_path / "gvt.mat"
    sio.savemat(path, {"Force": u[:, None], "Acceleration": acc, "Fs": fs})
    out = tmp_path / "out"
    rc = main(
        [
            "identify",
            str(path),
            "--input",
            "Force",
            "--output",
            "Acceleration2",
            "--band",
            "2,15",
            "--structure",
            "oe",
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["fs"] < fs and s["decimation"]["automatic"] is True  # far below Nyquist
    assert s["decimation"]["factor"] >= 2
    for f_true, _ in MODES:
        assert nearest_rel_err(s["natural_frequencies_hz"], f_true) < 0.01
    assert all(2 <= f <= 15 for f in s["natural_frequencies_hz"])
    assert s["fit_percent"] > 80
    assert s["band"]["band_hz"] == [2.0, 15.0]


def test_npz_file_names_a_missing_variable(tmp_path, fast_record):
    u, y, fs = fast_record
    path = tmp_path / "rig.npz"
    np.savez(path, F=u[:4000], acc=y[:4000], fs=fs)
    with pytest.raises(Exception, match=r"no output variable 'acceleration'.*'acc'"):
        run_identify(path, input="F", output="acceleration", out_dir=tmp_path / "o")
    s = run_identify(
        path, input="F", output="acc", out_dir=tmp_path / "o", order=6, decimate=1
    )
    assert s["fs"] == fs and "decimation" not in s


# ------------------------------------------------------------------ band, decimation
def test_decimate_and_band_focus_the_modes(tmp_path, fast_record):
    u, y, fs = fast_record
    path = tmp_path / "rig.csv"
    pd.DataFrame({"time": np.arange(u.size) / fs, "F": u, "acc": y}).to_csv(
        path, index=False
    )
    s = run_identify(
        path,
        input="F",
        output="acc",
        structure="oe",
        out_dir=tmp_path / "o",
        band="2,15",
        decimate=4,
    )
    assert s["decimation"] == {**s["decimation"], "factor": 4, "automatic": False}
    assert s["fs"] == pytest.approx(fs / 4)
    kept = s["natural_frequencies_hz"]
    assert all(2 <= f <= 15 for f in kept)
    for f_true, _ in MODES:
        assert nearest_rel_err(kept, f_true) < 0.01
    # without the band the full-band model sees the 120 Hz mode too
    s_full = run_identify(
        path, input="F", output="acc", structure="oe", out_dir=tmp_path / "o2", order=6
    )
    assert nearest_rel_err(s_full["natural_frequencies_hz"], 120.0) < 0.01
    assert "decimation" not in s_full


def test_band_above_nyquist_is_refused(tmp_path, fast_record):
    u, y, fs = fast_record
    path = tmp_path / "rig.npz"
    np.savez(path, F=u[:4000], acc=y[:4000], fs=fs)
    with pytest.raises(Exception, match="below the Nyquist frequency 200 Hz"):
        run_identify(path, input="F", output="acc", out_dir=tmp_path / "o", band="10,250")
    with pytest.raises(Exception, match="--band needs 0 <= F1 < F2"):
        run_identify(path, input="F", output="acc", out_dir=tmp_path / "o", band="9,3")


# ------------------------------------------------------------------ order edge, modes
def test_summary_says_the_order_search_was_extended(tmp_path):
    fs = 1000.0
    modes = [(40, 0.02), (90, 0.03), (150, 0.02), (210, 0.03), (280, 0.02), (350, 0.03)]
    num, den = zoh_modes(modes, fs)
    rng = np.random.default_rng(0)
    u = rng.normal(size=6000)
    y = signal.lfilter(num, den, u) + signal.lfilter([0.05], den, rng.normal(size=6000))
    path = write_csv(tmp_path, "six.csv", u, y, fs)
    s = run_identify(path, input="u", output="y", out_dir=tmp_path / "o", criterion="bic")
    assert s["order"]["na"] == 12
    assert s["order_search"]["extended"] is True
    assert "extended to 1..20" in s["order_search"]["note"]
    for f_true, _ in modes:
        assert nearest_rel_err(s["natural_frequencies_hz"], f_true) < 0.01


def test_real_poles_are_listed_apart_with_their_reason(tmp_path):
    # a first-order lag and one resonance: the lag's real pole is not a mode
    fs = 100.0
    b1, a1 = zoh_modes([(7.0, 0.05)], fs)
    rng = np.random.default_rng(4)
    u = rng.normal(size=5000)
    y = signal.lfilter(b1, a1, u) + signal.lfilter([0, 0.1], [1, -0.95], u)
    path = write_csv(tmp_path, "lag.csv", u, y, fs)
    s = run_identify(
        path, input="u", output="y", out_dir=tmp_path / "o", structure="oe", order=3
    )
    assert len(s["natural_frequencies_hz"]) == 1
    assert abs(s["natural_frequencies_hz"][0] - 7.0) < 0.01
    reasons = [p["reason"] for p in s["not_modes"]]
    assert reasons == ["real pole (no oscillation)"]
    lag = s["not_modes"][0]["pole"]
    assert lag[0] == pytest.approx(0.95, abs=1e-3) and lag[1] == 0.0


# ------------------------------------------------------------------ negative fit, unstable
def test_negative_fit_warns_and_names_an_alternative_that_fits(tmp_path):
    # a 10 Hz resonance under a large slow drift: ARX(2,2) takes the drift for
    # dynamics and simulates worse than the mean; OE (from an ARX start) does not
    fs = 100.0
    num, den = zoh_modes([(10.0, 0.02)], fs)
    rng = np.random.default_rng(1)
    u = rng.normal(size=3000) + np.sin(np.arange(3000) / 300)
    y0 = signal.lfilter(num, den, u)
    v = signal.lfilter([1], [1, -0.995], rng.normal(size=3000))
    y = y0 + 3 * np.std(y0) / np.std(v) * v
    path = write_csv(tmp_path, "drift.csv", u, y, fs)
    out = tmp_path / "o"
    s = run_identify(path, input="u", output="y", out_dir=out, order="na=2,nb=2")
    assert s["fit_percent"] < 0
    on_disk = json.loads((out / "summary.json").read_text())
    text = " ".join(on_disk["warnings"])
    assert "worse than the output's mean" in text
    alt = on_disk["alternative"]
    assert alt is not None and alt["fit_percent"] > 0
    assert alt["options"] in text


def test_unstable_model_warns_with_a_stable_alternative():
    from pdmkit.experiments._identify import _check_model

    fs = 100.0
    num, den = zoh_modes([(10.0, 0.05)], fs)
    rng = np.random.default_rng(5)
    u = rng.normal(size=3000)
    y = signal.lfilter(num, den, u) + 0.01 * rng.normal(size=3000)
    bad = IdentifiedModel(
        "arx",
        fs,
        {"na": 2, "nb": 1, "nk": 1},
        A=np.real(np.poly([1.02 * np.exp(0.3j), 1.02 * np.exp(-0.3j)])),
        B=np.r_[0.0, 0.1],
    )
    with np.errstate(all="ignore"):
        bad.fit_percent = bad.compare(u, y)
    summary = {"fit_percent": bad.fit_percent}
    found = _check_model(bad, summary, u, y, fs, "arx")
    assert len(found) == 1 and "unstable" in found[0]
    assert summary["alternative"]["fit_percent"] > 90
    assert summary["alternative"]["structure"] in ("oe", "n4sid")


# ------------------------------------------------------------------ FRF figure
def test_frf_figure_log_axis_coherence_and_one_phase_branch(fast_record):
    from pdmkit.experiments._identify_report import _frf_figure
    from pdmkit.models.ident import oe

    u, y, fs = fast_record
    num, den = zoh_modes([*MODES, (120.0, 0.02)], fs)
    m = oe(u[:20000], y[:20000], 6, 6, 1, fs=fs)
    fig, cmp = _frf_figure(m, u, y, fs, (2.0, 15.0))
    axes = fig.axes
    assert len(axes) == 3
    assert all(ax.get_xscale() == "log" for ax in axes)
    assert axes[2].get_ylabel() == "coherence"
    lo, hi = axes[0].get_xlim()
    assert lo >= 2.0 and hi <= 15.0
    # same branch: within a few degrees at the first band frequency (not 360 k off)
    assert abs(cmp["phase_model_deg"][0] - cmp["phase_data_deg"][0]) < 10
    true = signal.freqz(num, den, worN=cmp["freq"], fs=fs)[1]
    np.testing.assert_allclose(np.abs(cmp["G"]), np.abs(true), rtol=0.05)


# ------------------------------------------------------------------ formatting
def test_cli_prints_a_missing_mode_frequency_and_fit(tmp_path, monkeypatch, capsys):
    # a model whose mode frequency and fit are undefined (NaN -> None in the JSON)
    # crashed the CLI with "unsupported format string passed to NoneType.__format__"
    class Undefined:
        def simulate(self, u):
            return np.full(len(u), np.nan)

        def to_dict(self):
            return {
                "structure": "stub",
                "order": {},
                "poles": [],
                "natural_frequencies_hz": [float("nan"), 3.0],
                "damping": [float("nan"), 0.1],
                "fit_percent": float("nan"),
            }

    monkeypatch.setitem(IDENTIFY_STRUCTURES, "stub", lambda *a: Undefined())
    rng = np.random.default_rng(0)
    path = write_csv(tmp_path, "x.csv", rng.normal(size=500), rng.normal(size=500), 10.0)
    args = ["identify", str(path), "--input", "u", "--output", "y"]
    rc = main([*args, "--structure", "stub", "--out", str(tmp_path / "o")])
    assert rc == 0
    err = capsys.readouterr().err
    assert "modes ? Hz, 3 Hz" in err and "fit undefined" in err
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["natural_frequencies_hz"] == [None, 3.0]
    assert any("worse than the output's mean" in w for w in summary["warnings"])


# ------------------------------------------------------------------ real data
def test_f16_gvt_modes_in_band(require_data, tmp_path):
    folder = require_data("f16_gvt")
    s = run_identify(
        folder / "F16Data_FullMSine_Level1.mat",
        input="Force",
        output="Acceleration2",
        band="2,15",
        out_dir=tmp_path / "f16",
    )
    assert s["fit_percent"] > 0
    for target in (5.2, 6.6, 7.3, 9.2):
        assert nearest_rel_err(s["natural_frequencies_hz"], target) < 0.03
    assert s["decimation"]["automatic"] is True


def test_daisy_robot_arm_resonances(require_data, tmp_path):
    folder = require_data("daisy")
    path = folder / "robot-arm.csv"
    cols = pd.read_csv(path, nrows=1).columns
    names = ("u", "y") if list(cols) == ["u", "y"] else ("column_0", "column_1")
    s = run_identify(
        path, input=names[0], output=names[1], fs=1.0, out_dir=tmp_path / "robot"
    )
    for target in (0.058, 0.126, 0.34):
        assert nearest_rel_err(s["natural_frequencies_hz"], target) < 0.05
    assert not any(p["reason"] == "cancelled by a zero" for p in s["not_modes"])
    freqs = [m["frequency_hz"] for m in s["modes"]]
    assert freqs == s["natural_frequencies_hz"]
