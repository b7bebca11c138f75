"""``pdmkit rul`` on a user's own tables (issue 15): no silent cap, the user's time
unit, honest intervals, warnings for what the data cannot support, --unit/--time,
and ``--model boosting``."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from pdmkit.experiments._cli import main
from pdmkit.experiments._rul import CAP_CONVENTIONS
from pdmkit.experiments._rul_checks import resolve_cap
from pdmkit.experiments._rul_models import _trajectory_plot


def _units(n, seed, *, cut, hours=True, shift=0.0, shutdown=False):
    """Bearings in hours: lives 300-600 h, a reading every 5 h, RUL far above 125."""
    rng = np.random.default_rng(seed)
    rows = []
    for u in range(n):
        life = float(rng.integers(60, 120) * 5)
        t = np.arange(0.0, life + 1, 5.0)
        frac = t / life
        vib = 0.05 + 0.3 * frac**3 + rng.normal(0, 0.004, t.size) + shift
        temp = 40 + 15 * frac**2 + rng.normal(0, 0.3, t.size) + 20 * shift
        if shutdown:
            vib[-2:], temp[-2:] = 0.0005, 0.01
        part = pd.DataFrame(
            {"bearing": f"b{seed}-{u}", "hours": t, "vib": vib, "temp": temp}
        )
        if cut:
            keep = int(rng.integers(5, t.size - 3))
            part = part.iloc[:keep].assign(rul_true_final=life - t[keep - 1])
        rows.append(part)
    table = pd.concat(rows, ignore_index=True)
    if not hours:
        table = table.rename(columns={"bearing": "unit", "hours": "time"})
    return table


def _write(tmp_path, name, table):
    path = tmp_path / name
    table.to_csv(path, index=False)
    return str(path)


def _run(tmp_path, capsys, *args, name="out"):
    out = tmp_path / name
    code = main(["rul", *args, "--out", str(out)])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    return json.loads((out / "summary.json").read_text()), captured.err, out


@pytest.fixture
def tables(tmp_path):
    train = _write(tmp_path, "train.csv", _units(12, 1, cut=False))
    test = _write(tmp_path, "test.csv", _units(6, 2, cut=True))
    return train, test


def test_own_tables_get_no_cap_and_are_scored_in_their_units(tmp_path, capsys, tables):
    train, test = tables
    args = ["--train", train, "--test", test, "--unit", "bearing", "--time", "hours"]
    summary, err, out = _run(tmp_path, capsys, *args, "--model", "boosting")
    assert summary["rul_cap"] is None and summary["rul_cap_source"] == "none"
    assert summary["time_unit"] == "h"
    pred = pd.read_parquet(out / "predictions.parquet")
    assert pred["rul_true"].max() > 125  # the C-MAPSS cap would have cut these
    assert pred["rul"].max() > 125
    rmse = float(np.sqrt(np.mean((pred["rul"] - pred["rul_true"]) ** 2)))
    assert summary["rmse"] == pytest.approx(rmse)  # against the true, uncapped RUL
    assert "no RUL cap" in err and f"RMSE {summary['rmse']:.2f} h" in err
    assert "time unit h" in err


def test_asked_cap_is_applied_and_said(tmp_path, capsys, tables):
    train, test = tables
    summary, err, out = _run(
        tmp_path,
        capsys,
        "--train",
        train,
        "--test",
        test,
        "--unit",
        "bearing",
        "--time",
        "hours",
        "--rul-cap",
        "100",
        "--model",
        "boosting",
    )
    assert summary["rul_cap"] == 100 and summary["rul_cap_source"] == "asked"
    pred = pd.read_parquet(out / "predictions.parquet")
    assert pred["rul"].max() <= 100
    assert "RUL cap 100 h (asked)" in err
    assert any("upper bounds sit at the RUL cap 100" in w for w in summary["warnings"])


def test_cmapss_keeps_its_literature_cap_and_says_so():
    cap, source = resolve_cap("convention", "cmapss-fd001")
    assert cap == 125 == CAP_CONVENTIONS["cmapss-fd001"][0]
    assert source.startswith("dataset convention") and "C-MAPSS" in source
    assert resolve_cap("convention", None) == (None, "none")
    assert resolve_cap(None, "cmapss-fd001") == (None, "none")


def test_time_unit_defaults_and_flag(tmp_path, capsys):
    plain = _units(8, 3, cut=False, hours=False)  # unit, time
    path = _write(tmp_path, "plain.csv", plain)
    summary, err, _ = _run(tmp_path, capsys, "--train", path, name="a")
    assert summary["time_unit"] == "s"
    path = _write(tmp_path, "cycles.csv", plain.rename(columns={"time": "cycle"}))
    summary, err, _ = _run(tmp_path, capsys, "--train", path, name="b")
    assert summary["time_unit"] == "cycles"
    summary, err, _ = _run(
        tmp_path, capsys, "--train", path, "--time-unit", "min", name="c"
    )
    assert summary["time_unit"] == "min" and "RMSE" in err and " min," in err
    stamped = plain.assign(
        time=pd.Timestamp("2004-02-12 10:32:39") + pd.to_timedelta(plain["time"], "h")
    )
    path = _write(tmp_path, "stamped.csv", stamped)
    summary, err, _ = _run(tmp_path, capsys, "--train", path, name="d")
    assert summary["time_unit"] == "s" and "seconds since" in err


def test_figures_carry_the_time_unit():
    table = pd.DataFrame(
        {
            "unit": 1,
            "time": [1.0, 2.0],
            "rul": [3.0, 2.0],
            "rul_true": [3.0, 2.0],
            "life": 4.0,
            "last_half": [False, True],
        }
    )
    ax = _trajectory_plot(table, [1], time_unit="h")
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("time (h)", "RUL (h)")


def test_unit_and_time_flags_name_the_columns(tmp_path, capsys, tables):
    train, test = tables
    assert (
        main(["rul", "--train", train, "--test", test, "--out", str(tmp_path / "x")]) == 2
    )  # no unit column: refused in one line
    assert "unit" in capsys.readouterr().err
    summary, _, out = _run(
        tmp_path,
        capsys,
        "--train",
        train,
        "--test",
        test,
        "--unit",
        "bearing",
        "--time",
        "hours",
    )
    assert summary["n_units"] == 6
    model = out / "model.pdmkit"
    history = _write(
        tmp_path, "hist.csv", _units(2, 5, cut=True).drop(columns="rul_true_final")
    )
    assert (
        main(
            [
                "rul",
                "--trained",
                str(model),
                "--history",
                history,
                "--unit",
                "bearing",
                "--time",
                "hours",
            ]
        )
        == 0
    )
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == 2 and all(" h: " in line for line in lines)


def test_small_samples_are_warned(tmp_path, capsys):
    train = _write(tmp_path, "three.csv", _units(3, 6, cut=False, hours=False))
    test = _write(tmp_path, "one.csv", _units(1, 7, cut=True, hours=False))
    summary, err, out = _run(
        tmp_path, capsys, "--train", train, "--test", test, "--calibrate", name="sim"
    )
    text = " ".join(summary["warnings"])
    assert "3 training units for k=10" in text
    assert "5-fold calibration on 3 training units" in text
    assert "1 test unit(s)" in text
    assert "warning(s), listed in summary.json" in err
    report = (out / "report.html").read_text()
    assert "Warnings" in report and "3 training units for k=10" in report
    summary, _, _ = _run(
        tmp_path,
        capsys,
        "--train",
        train,
        "--test",
        test,
        "--model",
        "neural",
        "--option",
        "epochs=1",
        "--option",
        "hidden=4",
        name="nn",
    )
    assert any(
        "learned model (neural) on 3 training units" in w for w in summary["warnings"]
    )


def test_out_of_distribution_units_and_shutdown_endings_are_warned(tmp_path, capsys):
    train = _write(tmp_path, "train.csv", _units(12, 8, cut=False, shutdown=True))
    near = _units(4, 9, cut=True)
    far = _units(3, 10, cut=True, shift=0.5)
    test = _write(tmp_path, "test.csv", pd.concat([near, far]))
    summary, _, out = _run(
        tmp_path,
        capsys,
        "--train",
        train,
        "--test",
        test,
        "--unit",
        "bearing",
        "--time",
        "hours",
        "--model",
        "boosting",
    )
    pred = pd.read_parquet(out / "predictions.parquet").set_index("unit")
    assert (pred.loc[far["bearing"].unique(), "ood_score"] > 1).all()
    assert (pred.loc[near["bearing"].unique(), "ood_score"] < 1).all()
    assert summary["ood"]["n_outside"] == 3
    text = " ".join(summary["warnings"])
    assert "3 of 7 test units lie outside the training data" in text
    assert "12 training unit(s) end in rows that look like a shut-down" in text


def test_no_zero_to_zero_interval_when_the_indicator_has_not_moved(tmp_path, capsys):
    t = np.arange(0.0, 60.0)
    rng = np.random.default_rng(11)
    train = pd.concat(
        [
            pd.DataFrame({"unit": u, "time": t, "hi": r * t + rng.normal(0, 0.02, 60)})
            for u, r in enumerate([0.02, 0.025, 0.03, 0.022, 0.027])
        ]
    )
    path = _write(tmp_path, "train.csv", train)
    out = tmp_path / "w"
    assert main(["rul", "--train", path, "--model", "wiener", "--out", str(out)]) == 0
    # far beyond the failing level from its first row, and not moving
    history = pd.DataFrame({"unit": "stuck", "time": t[:15], "hi": 4.0})
    hist = _write(tmp_path, "hist.csv", history)
    capsys.readouterr()
    assert (
        main(
            [
                "rul",
                "--trained",
                str(out / "model.pdmkit"),
                "--history",
                hist,
                "--json",
                str(tmp_path / "a.json"),
            ]
        )
        == 0
    )
    line = capsys.readouterr().out
    assert "RUL 0.0" not in line and "no RUL estimate" in line
    answer = json.loads((tmp_path / "a.json").read_text())
    assert answer["time_unit"] == "s"
    assert any("no estimate" in w for w in answer["warnings"])


def test_boosting_on_the_cli(tmp_path, capsys):
    train = _write(tmp_path, "train.csv", _units(16, 12, cut=False, hours=False))
    test = _write(tmp_path, "test.csv", _units(8, 13, cut=True, hours=False))
    summary, _, out = _run(
        tmp_path,
        capsys,
        "--train",
        train,
        "--test",
        test,
        "--model",
        "boosting",
        "--time-unit",
        "h",
    )
    assert summary["model"] == "boosting"
    assert summary["estimator"].startswith("BoostingRULModel")
    pred = pd.read_parquet(out / "predictions.parquet")
    # better than the best constant guess (the mean true RUL)
    assert summary["rmse"] < pred["rul_true"].std(ddof=0)
    assert (pred["lower"] <= pred["rul"]).all() and (pred["rul"] <= pred["upper"]).all()


@pytest.mark.real_data
def test_cmapss_run_states_its_conventional_cap(require_data, tmp_path, capsys):
    require_data("cmapss_fd001")
    summary, err, _ = _run(tmp_path, capsys, "--model", "boosting")
    assert summary["rul_cap"] == 125 and summary["time_unit"] == "cycles"
    assert summary["rul_cap_source"].startswith("dataset convention")
    assert "RUL cap 125 cycles (the C-MAPSS literature's convention" in err
    assert summary["ood"]["n_outside"] == 0  # FD001's own test engines
