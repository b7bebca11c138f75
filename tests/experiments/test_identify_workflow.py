"""run_identify: a recording of a known system -> summary.json + report.html, atomically."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy import signal

from pdmkit.errors import DataError, ModelError
from pdmkit.experiments._identify import IDENTIFY_STRUCTURES, parse_order, run_identify

FS = 500.0
FN, ZETA = 40.0, 0.03  # the resonance built into the recording


@pytest.fixture
def recording(tmp_path):
    wn = 2 * np.pi * FN
    num_d, den_d, _ = signal.cont2discrete(
        ([wn**2], [1.0, 2 * ZETA * wn, wn**2]), 1 / FS, method="zoh"
    )
    rng = np.random.default_rng(0)
    u = rng.normal(size=6000)
    y = signal.lfilter(np.ravel(num_d), np.ravel(den_d), u)
    y = y + 0.05 * np.std(y) * rng.normal(size=y.size)
    path = tmp_path / "rig.csv"
    pd.DataFrame({"time": np.arange(u.size) / FS, "F": u, "acc": y}).to_csv(
        path, index=False
    )
    return path


@pytest.mark.parametrize("structure", ["oe", "n4sid"])
def test_run_identify_writes_summary_and_report(recording, tmp_path, structure):
    order = {"nb": 2, "nf": 2, "nk": 1} if structure == "oe" else 2
    out = tmp_path / "out"
    js = tmp_path / "extra" / "summary.json"
    summary = run_identify(
        recording,
        input="F",
        output="acc",
        structure=structure,
        order=order,
        out_dir=out,
        json_path=js,
    )
    on_disk = json.loads((out / "summary.json").read_text())
    assert on_disk == json.loads(js.read_text()) == summary
    for key in (
        "structure",
        "order",
        "poles",
        "natural_frequencies_hz",
        "damping",
        "fit_percent",
    ):
        assert key in on_disk
    assert on_disk["structure"] == structure
    assert on_disk["fs"] == pytest.approx(FS)
    assert on_disk["natural_frequencies_hz"][0] == pytest.approx(FN, rel=0.01)
    assert on_disk["damping"][0] == pytest.approx(ZETA, rel=0.1)
    assert on_disk["fit_percent"] == pytest.approx(95.0, abs=1.5)  # 5 % output noise
    html = (out / "report.html").read_text()
    assert html.count("data:image/png;base64,") == 3  # pole map, FRF, simulation
    assert "H1 estimate" in html


def test_run_identify_selects_order_and_handles_ar(recording, tmp_path):
    s = run_identify(
        recording,
        input="F",
        output="acc",
        structure="ar",
        order=None,
        out_dir=tmp_path / "ar",
        criterion="bic",
    )
    assert s["structure"] == "ar" and s["order"]["na"] >= 2


def test_bad_input_writes_nothing(recording, tmp_path):
    out = tmp_path / "out"
    with pytest.raises(DataError, match="no input column 'force'"):
        run_identify(recording, input="force", output="acc", out_dir=out)
    assert not out.exists()
    table = pd.read_csv(recording)
    table.loc[10, "acc"] = np.nan
    bad = tmp_path / "bad.csv"
    table.to_csv(bad, index=False)
    with pytest.raises(DataError, match="row 10"):
        run_identify(bad, input="F", output="acc", out_dir=out)
    with pytest.raises(ModelError, match="structure must be one of"):
        run_identify(recording, input="F", output="acc", structure="hx", out_dir=out)
    assert not out.exists()


def test_parse_order_and_dispatch():
    assert parse_order("na=4,nb=3,nk=1") == {"na": 4, "nb": 3, "nk": 1}
    assert parse_order(" 6 ") == 6
    with pytest.raises(ModelError, match="key=integer"):
        parse_order("na=four")
    assert {"ar", "arx", "armax", "oe", "bj", "n4sid"} <= set(IDENTIFY_STRUCTURES)
