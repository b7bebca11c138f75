"""The `pdmkit` command: the real CWRU workflow, summaries, errors that name the problem."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from pdmkit.experiments._cli import main


@pytest.mark.real_data
@pytest.mark.slow
def test_classify_cwru_reaches_the_issue_accuracy(require_data, tmp_path):
    require_data("cwru_bearing")
    out = tmp_path / "cls"
    assert (
        main(
            [
                "classify",
                "--dataset",
                "cwru",
                "--json",
                str(tmp_path / "c.json"),
                "--out",
                str(out),
            ]
        )
        == 0
    )
    summary = json.loads((tmp_path / "c.json").read_text())
    for key in (
        "accuracy",
        "model",
        "features",
        "labels",
        "confusion",
        "n_train",
        "n_test",
    ):
        assert key in summary
    # issue 2: drive end, top-5 Kruskal-Wallis indicators, kNN, held out >= 0.99
    assert summary["model"] == "knn"
    assert len(summary["features"]) == 5
    assert all(f.startswith("DE/") for f in summary["features"])
    assert summary["labels"] == ["B_007", "IR_007", "IR_021", "OR_007", "normal"]
    confusion = np.array(summary["confusion"])
    assert confusion.sum() == summary["n_test"]
    assert np.trace(confusion) / confusion.sum() == pytest.approx(summary["accuracy"])
    assert summary["accuracy"] >= 0.99
    html = (out / "report.html").read_text()
    assert "data:image/png;base64," in html


@pytest.mark.real_data
@pytest.mark.slow
def test_sensors_cwru_compares_three_accelerometers(require_data, tmp_path):
    require_data("cwru_bearing")
    assert (
        main(
            [
                "sensors",
                "--dataset",
                "cwru",
                "--json",
                str(tmp_path / "s.json"),
                "--out",
                str(tmp_path / "s"),
            ]
        )
        == 0
    )
    rows = {
        r["sensor"]: r for r in json.loads((tmp_path / "s.json").read_text())["sensors"]
    }
    assert set(rows) == {"DE", "FE", "BA"}
    # the normal record has no base accelerometer: its 29 frames leave BA's row
    assert rows["BA"]["n_excluded"] == 29 and "normal" in rows["BA"]["note"]
    assert rows["DE"]["n_excluded"] == 0
    report = (tmp_path / "s" / "report.html").read_text()
    assert "BA:" in report and "excluded" in report


def _toy_features(path, rng):
    y = np.repeat(["a", "b", "c"], 30)
    table = pd.DataFrame(
        {
            "acc/stats/RMS": rng.normal(size=90) + (y == "b") * 4.0,
            "acc/stats/Kurtosis": rng.normal(size=90) + (y == "c") * 4.0,
            "mic/stats/RMS": rng.normal(size=90),
            "fault": y,
        }
    )
    table.to_parquet(path)
    return table


def test_classify_from_a_feature_table(tmp_path, rng):
    _toy_features(tmp_path / "f.parquet", rng)
    code = main(
        [
            "classify",
            "--features",
            str(tmp_path / "f.parquet"),
            "--label",
            "fault",
            "--top-k",
            "2",
            "--json",
            str(tmp_path / "o.json"),
            "--out",
            str(tmp_path),
        ]
    )
    assert code == 0
    summary = json.loads((tmp_path / "o.json").read_text())
    assert sorted(summary["features"]) == ["acc/stats/Kurtosis", "acc/stats/RMS"]
    assert summary["accuracy"] > 0.9


def test_sensors_default_to_one_per_signal(tmp_path, rng):
    _toy_features(tmp_path / "f.parquet", rng)
    assert (
        main(
            [
                "sensors",
                "--features",
                str(tmp_path / "f.parquet"),
                "--label",
                "fault",
                "--json",
                str(tmp_path / "o.json"),
                "--out",
                str(tmp_path),
            ]
        )
        == 0
    )
    rows = {
        r["sensor"]: r for r in json.loads((tmp_path / "o.json").read_text())["sensors"]
    }
    assert set(rows) == {"acc", "mic"}
    assert rows["acc"]["accuracy"] > rows["mic"]["accuracy"] + 0.3


def test_missing_label_is_a_clear_error(tmp_path, rng, capsys):
    _toy_features(tmp_path / "f.parquet", rng)
    code = main(
        [
            "classify",
            "--features",
            str(tmp_path / "f.parquet"),
            "--label",
            "nope",
            "--out",
            str(tmp_path),
        ]
    )
    assert code == 2
    err = capsys.readouterr().err
    assert "'nope'" in err and "fault" in err


def test_unknown_dataset_lists_the_known_ones(tmp_path, capsys):
    assert main(["classify", "--dataset", "nope", "--out", str(tmp_path)]) == 2
    assert "cwru" in capsys.readouterr().err


def test_unreadable_feature_file_keeps_earlier_results(tmp_path, rng, capsys):
    _toy_features(tmp_path / "f.parquet", rng)
    args = [
        "classify",
        "--features",
        str(tmp_path / "f.parquet"),
        "--label",
        "fault",
        "--out",
        str(tmp_path / "out"),
    ]
    assert main(args) == 0
    before = (tmp_path / "out" / "summary.json").read_text()
    (tmp_path / "bad.parquet").write_bytes(b"not parquet at all")
    args[2] = str(tmp_path / "bad.parquet")
    assert main(args) == 2
    assert "bad.parquet" in capsys.readouterr().err
    assert (tmp_path / "out" / "summary.json").read_text() == before


@pytest.mark.real_data
def test_rul_cmapss_similarity_meets_the_issue_bound(require_data, tmp_path):
    require_data("cmapss_fd001")
    path = tmp_path / "summary.json"
    assert (
        main(
            [
                "rul",
                "--model",
                "pairwise",
                "--json",
                str(path),
                "--out",
                str(tmp_path / "rul"),
            ]
        )
        == 0
    )
    summary = json.loads(path.read_text())
    for key in ("model", "rmse", "mae", "phm08_score", "n_units", "coverage"):
        assert key in summary
    assert summary["n_units"] == 100
    assert summary["rmse"] <= 20.0  # issue 6: best similarity model on FD001


def test_every_option_of_every_command_says_what_it_does():
    """Issue 16: every flag with help text; a flag means one thing across commands."""
    import argparse

    from pdmkit.experiments._cli import build_parser

    subparsers = next(
        a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)
    )
    meanings: dict[str, set] = {}
    for command, parser in subparsers.choices.items():
        for action in parser._actions:
            if action.dest == "help":
                continue
            assert action.help, f"pdmkit {command} {action.option_strings}: no help"
            name = getattr(action.type, "__name__", "")
            numeric = action.type in (int, float) or any(
                w in name for w in ("number", "integer", "seconds")
            )
            for flag in action.option_strings:
                meanings.setdefault(flag, set()).add("number" if numeric else "text")
    # one flag, one kind of value: --members is always files, --features a table
    assert all(len(kinds) == 1 for kinds in meanings.values()), {
        f: k for f, k in meanings.items() if len(k) > 1
    }
