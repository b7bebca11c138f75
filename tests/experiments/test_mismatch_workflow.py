"""The mismatch workflow: files in, JSON summary + HTML report out, nothing on errors."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from pdmkit.errors import DataError, ModelError
from pdmkit.experiments._mismatch import run_mismatch
from pdmkit.models.mismatch._cases import generate_concealed_case

ISSUE_KEYS = {"verdict", "located", "candidates", "fit"}


@pytest.fixture(scope="module")
def offset_case(tmp_path_factory):
    folder = tmp_path_factory.mktemp("case")
    case = generate_concealed_case("sensor_offset", 0.3, seed=2, target="x", n_samples=900)
    return case, case.write(folder)


def test_run_writes_json_and_report_with_the_issue_keys(offset_case, tmp_path):
    case, paths = offset_case
    out = tmp_path / "out"
    summary = run_mismatch(
        paths["model"],
        paths["data"],
        out_dir=out,
        json_path=tmp_path / "summary.json",
        effects=["sensor_offset", "sensor_gain", "coulomb_friction"],
    )
    on_disk = json.loads((tmp_path / "summary.json").read_text())
    assert on_disk == json.loads((out / "summary.json").read_text())
    assert ISSUE_KEYS <= set(on_disk)
    v = on_disk["verdict"]
    assert set(v) >= {"effect", "target", "physics", "params"}
    assert (v["effect"], v["target"]) == ("sensor_offset", "x")
    assert v["params"]["offset"] == pytest.approx(case.params["offset"], rel=0.05)
    assert all(set(w) == {"start", "end", "share"} for w in on_disk["located"])
    shares = [w["share"] for w in on_disk["located"]]
    assert shares == sorted(shares, reverse=True)
    for c in on_disk["candidates"]:
        assert {"effect", "target", "rmse_validation", "improvement", "criterion"} <= set(c)
    assert on_disk["candidates"][0]["effect"] == "sensor_offset"
    fit = on_disk["fit"]
    assert fit["rmse_augmented"] < 0.5 * fit["rmse_nominal"]
    # the validation part is the last third: recompute the nominal-free truth there
    html = (out / "report.html").read_text()
    assert "Ranked candidates" in html and html.count("data:image/png;base64") >= 2
    assert v["physics"].split(":")[0] in html
    cands = pd.read_csv(out / "candidates.csv")
    assert cands["effect"].iloc[0] == "sensor_offset"
    assert summary == on_disk


def test_separate_validation_recording(offset_case, tmp_path):
    _, paths = offset_case
    data = pd.read_csv(paths["data"])
    n = len(data)
    first, second = data.iloc[: n // 2].copy(), data.iloc[n // 2 :].copy()
    first.to_csv(tmp_path / "a.csv", index=False)
    second.to_parquet(tmp_path / "b.parquet", index=False)
    summary = run_mismatch(
        paths["model"],
        tmp_path / "a.csv",
        validation_path=tmp_path / "b.parquet",
        out_dir=tmp_path / "o",
        effects=["sensor_offset", "sensor_gain"],
    )
    assert summary["fit"]["validation"] == "separate recording"
    assert summary["verdict"]["effect"] == "sensor_offset"


def _bad_data(paths, tmp_path, how):
    data = pd.read_csv(paths["data"])
    if how == "missing":
        data = data.drop(columns="F")
    elif how == "nan":
        data.loc[123, "x"] = np.nan
    elif how == "time":
        data.loc[200:, "time"] += 0.013
    p = tmp_path / f"bad_{how}.csv"
    data.to_csv(p, index=False)
    return p


@pytest.mark.parametrize(
    ("how", "match"),
    [
        ("missing", r"missing column\(s\) \['F'\]"),
        ("nan", r"column 'x' has 1 missing .* row 123"),
        ("time", r"time must be uniform; row 200"),
    ],
)
def test_bad_data_leaves_nothing_behind(offset_case, tmp_path, how, match):
    _, paths = offset_case
    bad = _bad_data(paths, tmp_path, how)
    out = tmp_path / "out"
    with pytest.raises(DataError, match=match) as err:
        run_mismatch(paths["model"], bad, out_dir=out, json_path=tmp_path / "s.json")
    assert str(bad) in str(err.value)
    assert not out.exists() and not (tmp_path / "s.json").exists()


def test_bad_model_leaves_existing_results_untouched(offset_case, tmp_path):
    _, paths = offset_case
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.html").write_text("old report")
    broken = tmp_path / "broken.py"
    broken.write_text(paths["model"].read_text().replace("STATES =", "STATS ="))
    with pytest.raises(ModelError, match=r"broken.py: missing STATES"):
        run_mismatch(broken, paths["data"], out_dir=out)
    assert (out / "report.html").read_text() == "old report"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["broken.py", "out"]
    with pytest.raises(DataError, match=r"not found|does not exist|No such"):
        run_mismatch(paths["model"], tmp_path / "nope.csv", out_dir=out)
