"""Ordinary mistakes on the command line: one line on stderr, exit status 2, no work.

Each case comes from the independent review of the CLI (issue 12, "Tracebacks on
ordinary mistakes" and "Silent wrong answers"); before the fix each one printed a
traceback or exited 0.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
import scipy.signal

from pdmkit.experiments._cli import main

FS = 1000.0


def _error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert err, "nothing on stderr"
    assert "Traceback" not in "\n".join(err)
    return err[-1]


@pytest.fixture(scope="module")
def members(tmp_path_factory):
    """Four small CSV recordings with a fault label."""
    folder = tmp_path_factory.mktemp("members")
    rng = np.random.default_rng(0)
    for i in range(4):
        t = np.arange(2048) / FS
        x = np.sin(2 * np.pi * (50 + 20 * i) * t) + 0.1 * rng.normal(size=t.size)
        pd.DataFrame({"time": t, "vib": x, "fault": ["ok", "ir"][i % 2]}).to_csv(
            folder / f"m{i}.csv", index=False
        )
    return sorted(str(p) for p in folder.glob("*.csv"))


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    """An input/output record of a second-order system."""
    folder = tmp_path_factory.mktemp("record")
    rng = np.random.default_rng(1)
    u = rng.normal(size=1500)
    y = scipy.signal.lfilter([0, 0.5], [1, -1.5, 0.7], u) + 0.01 * rng.normal(size=u.size)
    t = np.arange(u.size) / 100
    paths = {}
    for name, frame in {
        "ok": pd.DataFrame({"time": t, "u": u, "y": y}),
        "five": pd.DataFrame({"time": t[:5], "u": u[:5], "y": y[:5]}),
        "huge": pd.DataFrame({"time": t, "u": u, "y": y * 1e300}),
        "flat": pd.DataFrame({"time": t, "u": u, "y": np.ones_like(y)}),
    }.items():
        paths[name] = folder / f"{name}.csv"
        frame.to_csv(paths[name], index=False)
    return paths


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--groups", "statz"], "unknown feature group(s) ['statz']"),
        (["--option", "nperseg=abc"], "nperseg must be an integer >= 1, got 'abc'"),
        (["--option", "nperseg=-5"], "nperseg must be an integer >= 1, got -5"),
        (["--option", "npersge=64"], "did you mean 'nperseg'"),
        (["--groups", "stats", "--option", "nperseg=64"], "not in groups=['stats']"),
    ],
)
def test_bad_feature_options_are_one_line(members, tmp_path, capsys, extra, words):
    out = tmp_path / "out"
    code = main(["features", "--members", *members, "--out", str(out), *extra])
    assert code == 2
    line = _error_line(capsys)
    assert words in line
    assert not (out / "features.parquet").exists()


@pytest.mark.parametrize("command", ["features", "rank", "classify", "sensors"])
def test_an_unknown_label_is_refused_before_any_work(members, tmp_path, capsys, command):
    out = tmp_path / "out"
    code = main([command, "--members", *members, "--label", "faul", "--out", str(out)])
    assert code == 2
    line = _error_line(capsys)
    assert "--label 'faul'" in line and "did you mean 'fault'" in line
    assert "extracting" not in capsys.readouterr().err


@pytest.mark.real_data
def test_a_dataset_profile_s_options_follow_the_groups_chosen(require_data, tmp_path):
    """`pdmkit features --dataset cwru --groups stats` (a documented use) works."""
    require_data("cwru_bearing")
    out = tmp_path / "out"
    assert (
        main(["features", "--dataset", "cwru", "--groups", "stats", "--out", str(out)]) == 0
    )
    table = pd.read_parquet(out / "features.parquet")
    groups = {c.split("/")[1] for c in table.columns if "/" in c}
    assert groups == {"stats"}


@pytest.mark.parametrize(
    ("name", "args", "words"),
    [
        ("ok", ["--input", "u", "--output", "u"], "--input and --output both name 'u'"),
        ("five", ["--input", "u", "--output", "y"], "5 samples"),
        ("huge", ["--input", "u", "--output", "y"], "overflow"),
        ("flat", ["--input", "u", "--output", "y"], "is constant"),
    ],
)
def test_identify_refuses_records_it_cannot_identify(
    record, tmp_path, capsys, name, args, words
):
    out = tmp_path / "out"
    code = main(["identify", str(record[name]), *args, "--out", str(out)])
    assert code == 2
    assert words in _error_line(capsys)
    assert not (out / "summary.json").exists()


@pytest.mark.parametrize(
    ("flag", "value"), [("--top-k", "0"), ("--test-size", "1.5"), ("--test-size", "x")]
)
def test_classifier_settings_out_of_range_are_usage_errors(
    members, tmp_path, capsys, flag, value
):
    """Red-team finding: these ended in a ValueError traceback (exit 1)."""
    with pytest.raises(SystemExit) as exc:
        main(["classify", "--members", *members, "--label", "fault", flag, value])
    assert exc.value.code == 2
    assert f"argument {flag}" in capsys.readouterr().err


def test_a_text_time_column_in_rul_tables_is_one_line(tmp_path, capsys):
    rows = [
        pd.DataFrame({"unit": u, "cycle": [f"c{i}" for i in range(30)], "hi": 0.02})
        for u in range(6)
    ]
    pd.concat(rows).to_csv(tmp_path / "train.csv", index=False)
    code = main(
        ["rul", "--train", str(tmp_path / "train.csv"), "--out", str(tmp_path / "o")]
    )
    assert code == 2
    assert "time column 'cycle' must hold numbers" in _error_line(capsys)


def test_a_history_beyond_float_range_is_refused_not_answered(tmp_path, capsys):
    """Red-team finding: values of ±1e308 gave 'RUL 125.0 (125.0 to 125.0)', exit 0."""
    from pdmkit import save_model
    from pdmkit.rul import LinearDegradationModel

    t = np.arange(40.0)
    train = pd.DataFrame(
        {
            "unit": np.repeat([1, 2, 3], 40),
            "time": np.tile(t, 3),
            "hi": np.tile(0.02 * t, 3),
        }
    )
    path = save_model(
        LinearDegradationModel(threshold=1.0).fit(train), tmp_path / "m.pdmkit"
    )
    pd.DataFrame({"time": [0.0, 1.0], "hi": [0.0, 1e308]}).to_csv(
        tmp_path / "h.csv", index=False
    )
    code = main(["rul", "--trained", str(path), "--history", str(tmp_path / "h.csv")])
    assert code == 2
    assert "column 'hi' holds 1e+308" in _error_line(capsys)


def test_classify_members_leaves_out_bad_and_unlabelled_files_and_says_so(
    members, tmp_path, capsys
):
    """Red-team finding: one member without the label (or unreadable) stopped
    `classify --members` for all the others."""
    t = np.arange(2048) / FS
    pd.DataFrame({"time": t, "vib": np.sin(2 * np.pi * 60 * t)}).to_csv(
        tmp_path / "nolabel.csv", index=False
    )
    (tmp_path / "broken.csv").write_text("time,vib\n0,1\n0,2\n")  # time repeats
    out = tmp_path / "out"
    files = [*members, str(tmp_path / "nolabel.csv"), str(tmp_path / "broken.csv")]
    code = main(
        [
            "classify",
            "--members",
            *files,
            "--label",
            "fault",
            "--out",
            str(out),
            "--test-size",
            "0.5",
        ]
    )
    assert code == 0
    said = " ".join(json.loads((out / "summary.json").read_text())["warnings"])
    assert "broken.csv" in said and "'nolabel'" in said


# --------------------------------------------------------------------------- red team 2
def test_a_signal_only_some_members_have_does_not_poison_the_others(
    members, tmp_path, capsys
):
    """Red-team finding: one member with an extra column gave every other member NaN
    features for it, and `classify` refused them all (exit 2)."""
    t = np.arange(2048) / FS
    rng = np.random.default_rng(5)
    extra = pd.DataFrame(
        {
            "time": t,
            "vib": np.sin(2 * np.pi * 60 * t) + 0.1 * rng.normal(size=t.size),
            "extra": rng.normal(size=t.size),
            "fault": "ok",
        }
    )
    extra.to_csv(tmp_path / "wide.csv", index=False)
    for command in ("classify", "rank"):
        out = tmp_path / command
        argv = [command, "--members", *members, str(tmp_path / "wide.csv")]
        argv += ["--label", "fault", "--out", str(out)]
        if command == "classify":
            argv += ["--test-size", "0.5"]
        assert main(argv) == 0, capsys.readouterr().err
        summary = json.loads(next(out.glob("*.json")).read_text())
        (said,) = [w for w in summary["warnings"] if "'extra'" in w]
        assert "signal 'extra' is missing from 4 of 5 members (m0, m1, m2, ...)" in said
        assert "its indicators are left out" in said
        if command == "classify":
            assert summary["features"] and not any(
                f.startswith("extra/") for f in summary["features"]
            )
        else:
            ranked = pd.read_parquet(out / "ranking.parquet")
            assert not ranked["feature"].str.startswith("extra/").any()
            assert np.isfinite(ranked.select_dtypes("number").to_numpy()).all()


def test_a_member_with_a_repeated_column_is_left_out_not_renamed(members, tmp_path, capsys):
    t = np.arange(2048) / FS
    noise = np.random.default_rng(6).normal(size=t.size)
    rows = "\n".join(
        f"{x},{np.sin(2 * np.pi * 60 * x) + 0.1 * e},{np.cos(x)},ok"
        for x, e in zip(t, noise, strict=True)
    )
    (tmp_path / "dup.csv").write_text(f"time,vib,vib,fault\n{rows}\n")
    out = tmp_path / "out"
    argv = ["features", "--members", *members, str(tmp_path / "dup.csv")]
    assert main([*argv, "--out", str(out)]) == 3  # finished, a member left out
    table = pd.read_parquet(out / "features.parquet")
    assert not any(c.startswith("vib.1/") for c in table.columns)
    assert np.isfinite(table.filter(like="vib/").to_numpy()).all()
    (error,) = pd.read_parquet(out / "errors.parquet")["error"]
    assert "dup.csv: the header names column 'vib' 2 times" in error


@pytest.mark.parametrize(
    ("argv", "prog", "words"),
    [
        (["features", "--members", "m.csv", "--foo"], "pdmkit features", "--foo"),
        (["features", "--members", "m.csv", "--jsn", "x"], "pdmkit features", "'--json'"),
        (["classify", "--members", "m.csv", "--model", "knm"], "pdmkit classify", "'knn'"),
        (["identify", "x.csv"], "pdmkit identify", "--input, --output"),
        (["features", "--members"], "pdmkit features", "argument --members"),
        (["features"], "pdmkit features", "--dataset --ensemble --members"),
        (["featurs"], "pdmkit", "'features'"),
        ([], "pdmkit", "COMMAND"),
    ],
)
def test_usage_errors_are_one_line_naming_the_argument(capsys, argv, prog, words):
    """Red-team finding: argparse printed its multi-line usage block before the error."""
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    (line,) = captured.err.splitlines()
    assert line.startswith(f"{prog}: error: ") and words in line
    assert line.endswith(f"(see {prog} --help)")


def test_help_is_still_the_usage_block(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["features", "--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    assert text.startswith("usage: pdmkit features [-h]") and "--members FILE" in text


@pytest.mark.parametrize("inside", [".pdmkit/run.json", ".pdmkit/lock", ".pdmkit"])
def test_json_inside_pdmkit_s_own_folder_is_refused(members, tmp_path, capsys, inside):
    """Red-team finding: `--json OUT/.pdmkit/run.json` was accepted (the summary then
    replaced the run manifest)."""
    out = tmp_path / "out"
    argv = ["rank", "--members", *members, "--label", "fault", "--out", str(out)]
    assert main([*argv, "--json", str(out / inside)]) == 2
    line = _error_line(capsys)
    assert f"--json {out / inside} is inside {out / '.pdmkit'}, pdmkit's own" in line
    assert f"e.g. {out / 'summary.json'}" in line
    assert not (out / "summary.json").exists()
    # another output folder's .pdmkit is pdmkit's too
    (tmp_path / "other" / ".pdmkit").mkdir(parents=True)
    js = tmp_path / "other" / ".pdmkit" / "x.json"
    assert main([*argv, "--json", str(js)]) == 2
    assert "pdmkit's own folder" in _error_line(capsys)
    assert not js.exists()
