"""The CLI on inputs as they come, and how it feels (issue 15): labels from member file
names or a labels table, --time, --bearing, rank's prognostic methods, classify
--split time, progress bars that --quiet silences."""

from __future__ import annotations

import io
import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pdmkit.experiments._cli import main


def _members(folder: Path, rng, n_per_class: int = 8, fs: float = 1000.0) -> None:
    """CSV members without a label column: 'ok' quiet, 'worn' with impacts."""
    folder.mkdir(parents=True, exist_ok=True)
    t = np.arange(2000) / fs
    for k in range(n_per_class):
        for state in ("ok", "worn"):
            x = rng.normal(0, 1.0, t.size)
            if state == "worn":
                x[::97] += 12.0  # impacts: kurtosis and peak rise
            pd.DataFrame({"sec": t, "acc": x}).to_csv(
                folder / f"pump{k:02d}_{state}.csv", index=False
            )


def _cli(*parts: list[str]) -> int:
    """``main`` with the argument lists joined."""
    return main([arg for part in parts for arg in part])


def _summary(path: Path) -> dict:
    return json.loads(path.read_text())


def test_classify_members_labelled_by_their_file_names(tmp_path, rng):
    _members(tmp_path / "m", rng)
    code = main(
        [
            "classify",
            "--members",
            str(tmp_path / "m"),
            "--time",
            "sec",
            "--label-from-name",
            r"_([a-z]+)\.csv$",
            "--top-k",
            "2",
            "--out",
            str(tmp_path / "out"),
            "--json",
            str(tmp_path / "c.json"),
        ]
    )
    assert code == 0
    summary = _summary(tmp_path / "c.json")
    assert summary["label"] == "label" and summary["labels"] == ["ok", "worn"]
    assert summary["n_train"] + summary["n_test"] == 16
    assert summary["accuracy"] == 1.0  # impacts are unmistakable


def test_classify_members_labelled_by_a_table(tmp_path, rng):
    _members(tmp_path / "m", rng)
    files = sorted(p.name for p in (tmp_path / "m").iterdir())
    pd.DataFrame(
        {"file": files, "state": [f.split("_")[1][:-4] for f in files], "line": 3}
    ).to_csv(tmp_path / "labels.csv", index=False)
    code = main(
        [
            "classify",
            "--members",
            str(tmp_path / "m"),
            "--time",
            "sec",
            "--labels",
            str(tmp_path / "labels.csv"),
            "--label",
            "state",
            "--out",
            str(tmp_path / "out"),
            "--json",
            str(tmp_path / "c.json"),
        ]
    )
    assert code == 0
    assert _summary(tmp_path / "c.json")["labels"] == ["ok", "worn"]


def test_member_options_without_members_are_refused(tmp_path, rng, capsys):
    table = pd.DataFrame({"a/stats/RMS": rng.normal(size=8), "fault": list("xyxyxyxy")})
    table.to_parquet(tmp_path / "f.parquet")
    code = _cli(
        ["classify", "--features", str(tmp_path / "f.parquet"), "--label", "fault"],
        ["--label-from-name", "(x)", "--out", str(tmp_path / "o")],
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert "--label-from-name applies to --members files" in err[0]


def test_a_wrong_time_column_names_the_file(tmp_path, rng, capsys):
    _members(tmp_path / "m", rng, n_per_class=2)
    code = _cli(
        ["features", "--members", str(tmp_path / "m"), "--time", "secs", "--strict"],
        ["--out", str(tmp_path / "o")],
    )
    err = capsys.readouterr().err
    assert code == 2
    assert "no time column 'secs'" in err and "did you mean 'sec'" in err


# ---------------------------------------------------------------- --bearing


@pytest.mark.real_data
def test_cwru_members_with_bearing_6205_show_their_defect_line(require_data, tmp_path):
    folder = require_data("cwru_bearing")
    files = ["1797_IR_7_DE12.npz", "1797_IR_21_DE12.npz", "1797_OR@6_7_DE12.npz"]
    code = _cli(
        ["features", "--members", *[str(folder / f) for f in files], "--fs", "12000"],
        ["--label-from-name", r"^\d+_([A-Za-z]+)", "--signals", "DE"],
        ["--bearing", "6205", "--shaft-hz", str(1797 / 60), "--batch-size", "1"],
        ["--groups", "envelope", "--out", str(tmp_path / "o")],
    )
    assert code == 0
    table = pd.read_parquet(tmp_path / "o" / "features.parquet")
    lines = ["BPFO_1", "BPFI_1", "BSFx2_1", "FTF_1"]
    strongest = table[[f"DE/envelope/{k}" for k in lines]].to_numpy().argmax(axis=1)
    found = dict(zip(table["label"], [lines[i] for i in strongest], strict=False))
    # inner-race faults ring at BPFI (162 Hz), the outer-race fault at BPFO (107 Hz)
    assert found == {"IR": "BPFI_1", "OR": "BPFO_1"}
    assert [lines[i] for i in strongest] == ["BPFI_1", "BPFI_1", "BPFO_1"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--bearing", "6205"], "--bearing needs --shaft-hz"),
        (["--shaft-hz", "29.95"], "--shaft-hz needs --bearing"),
        (
            ["--bearing", "n_balls=9,ball_d=7.94,pitch_d=39mm", "--shaft-hz", "30"],
            "no unit",
        ),
        (["--bearing", "6205", "--shaft-hz", "-3"], "positive shaft speed"),
        (["--bearing", "6205", "--shaft-hz", "30", "--groups", "stats"], "add envelope"),
        (["--groups", "envelope"], "pass --bearing"),
    ],
)
def test_bearing_mistakes_are_one_line(tmp_path, rng, capsys, args, message):
    _members(tmp_path / "m", rng, n_per_class=1)
    code = _cli(
        ["features", "--members", str(tmp_path / "m"), "--time", "sec", *args],
        ["--out", str(tmp_path / "o")],
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and message in err[0], err


# ---------------------------------------------------------------- rank


@pytest.mark.real_data
def test_rank_monotonicity_of_the_ims_run_to_failure(require_data, tmp_path):
    path = require_data("ims_bearing_features") / "merged_dataset_BearingTest_2.csv"
    code = _cli(
        ["rank", "--features", str(path), "--method", "monotonicity", "--window", "50"],
        ["--out", str(tmp_path / "o"), "--json", str(tmp_path / "r.json")],
    )
    assert code == 0
    summary = _summary(tmp_path / "r.json")
    # bearing 1 failed (outer race) at the end of IMS test 2
    assert summary["ranking"][0]["feature"] == "Bearing 1"
    assert summary["time"] == "Unnamed: 0" and summary["n_units"] == 1
    assert (tmp_path / "o" / "ranking.parquet").exists()


def test_rank_trendability_over_units(tmp_path, rng):
    rows = []
    for u, length in enumerate((50, 80, 65)):
        life = np.linspace(0, 1, length)
        rows.append(
            pd.DataFrame(
                {
                    "engine": u,
                    "cycle": np.arange(length),
                    "s/stats/Wear": life**2 + rng.normal(0, 0.01, length),
                    "s/stats/Noise": rng.normal(size=length),
                }
            )
        )
    pd.concat(rows).to_parquet(tmp_path / "runs.parquet")
    code = _cli(
        ["rank", "--features", str(tmp_path / "runs.parquet"), "--method"],
        ["trendability", "--unit", "engine", "--time", "cycle"],
        ["--out", str(tmp_path / "o"), "--json", str(tmp_path / "r.json")],
    )
    assert code == 0
    summary = _summary(tmp_path / "r.json")
    assert summary["unit"] == "engine" and summary["n_units"] == 3
    ranked = {r["feature"]: r["score"] for r in summary["ranking"]}
    assert ranked["s/stats/Wear"] > 0.95 > 0.5 > ranked["s/stats/Noise"]


def test_rank_prognostic_options_with_a_class_method_are_refused(tmp_path, rng, capsys):
    table = pd.DataFrame({"a/stats/RMS": rng.normal(size=8), "fault": list("xyxyxyxy")})
    table.to_parquet(tmp_path / "f.parquet")
    code = _cli(
        ["rank", "--features", str(tmp_path / "f.parquet"), "--label", "fault"],
        ["--unit", "engine", "--out", str(tmp_path / "o")],
    )
    assert code == 2
    assert "--unit is for the prognostic methods" in capsys.readouterr().err


# ---------------------------------------------------------------- classify --split time


def _weekly_table(path: Path, rng) -> pd.DataFrame:
    """A state that holds for a week and a sensor offset that every weekly
    recalibration moves: within a week the offset names the week, and so its state.
    A random split puts members of one week on both sides and scores perfectly; a
    classifier trained on the early weeks meets offsets it never saw."""
    weeks, per_week = 40, 12
    state = rng.choice(["ok", "worn"], weeks)
    offset = rng.permutation(weeks).astype(float)
    rows = []
    for w in range(weeks):
        for k in range(per_week):
            when = pd.Timestamp("2024-01-01") + pd.Timedelta(hours=24 * 7 * w + 12 * k)
            rows.append(
                {
                    "v/stats/Offset": offset[w] + rng.normal(0, 0.05),
                    "state": state[w],
                    "when": str(when),
                }
            )
    table = pd.DataFrame(rows).sample(frac=1.0, random_state=1)  # rows unordered
    table.to_csv(path, index=False)
    return table


def test_classify_split_time_trains_on_the_past(tmp_path, rng, capsys):
    table = _weekly_table(tmp_path / "f.csv", rng)
    common = ["--features", str(tmp_path / "f.csv"), "--label", "state", "--top-k", "1"]
    random_args = ["--out", str(tmp_path / "a"), "--json", str(tmp_path / "a.json")]
    assert _cli(["classify", *common], random_args) == 0
    code = _cli(
        ["classify", *common, "--split", "time", "--time", "when"],
        ["--out", str(tmp_path / "b"), "--json", str(tmp_path / "b.json")],
    )
    assert code == 0
    random_split, time_split = _summary(tmp_path / "a.json"), _summary(tmp_path / "b.json")
    assert random_split["split"]["kind"] == "random" and random_split["order"] is None
    assert time_split["split"]["kind"] == "time" and time_split["order"] == "when"
    assert (time_split["n_train"], time_split["n_test"]) == (360, 120)
    # the split falls where the sorted stamps say: the 360th earliest trains
    stamps = sorted(table["when"])
    note = time_split["notes"][0]
    assert f"up to when='{stamps[359]}'" in note and f"from when='{stamps[360]}'" in note
    assert "time split by 'when'" in capsys.readouterr().err
    # the leak through the weekly offset: perfect at random, near chance in time
    assert random_split["accuracy"] == 1.0
    assert time_split["accuracy"] < 0.75


def test_classify_split_time_refuses_a_past_of_one_class(tmp_path, capsys):
    table = pd.DataFrame(
        {
            "v/stats/RMS": np.arange(20.0),
            "state": ["ok"] * 15 + ["worn"] * 5,
            "cycle": np.arange(20),
        }
    )
    table.to_parquet(tmp_path / "f.parquet")
    code = _cli(
        ["classify", "--features", str(tmp_path / "f.parquet"), "--label", "state"],
        ["--split", "time", "--out", str(tmp_path / "o")],
    )
    err = capsys.readouterr().err
    assert code == 2
    assert "the 15 earliest members (by 'cycle') hold only class ['ok']" in err


# ---------------------------------------------------------------- progress


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def _stderr_on_a_terminal(monkeypatch) -> io.StringIO:
    term = _Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    return term


def test_progress_bars_on_a_terminal_and_quiet_silences_them(tmp_path, rng, monkeypatch):
    _members(tmp_path / "m", rng, n_per_class=6)
    args = ["classify", "--members", str(tmp_path / "m"), "--time", "sec"]
    args += ["--label-from-name", r"_([a-z]+)\.csv$", "--out", str(tmp_path / "o")]
    term = _stderr_on_a_terminal(monkeypatch)
    assert main(args) == 0
    shown = term.getvalue()
    for step in ("reading members", "features", "cv folds"):
        assert f"{step}:" in shown, step
    term = _stderr_on_a_terminal(monkeypatch)
    assert main([*args, "--quiet"]) == 0
    quiet = term.getvalue()
    assert "cv folds" not in quiet and "reading members" not in quiet
    assert quiet == ""  # --quiet: nothing at all on success


def test_no_progress_bars_off_a_terminal(tmp_path, rng, capsys):
    _members(tmp_path / "m", rng, n_per_class=3)
    assert (
        _cli(
            ["sensors", "--members", str(tmp_path / "m"), "--time", "sec"],
            ["--label-from-name", r"_([a-z]+)\.csv$", "--out", str(tmp_path / "o")],
        )
        == 0
    )
    err = capsys.readouterr().err
    assert "sensors:" not in err and "cv folds" not in err and "\r" not in err
