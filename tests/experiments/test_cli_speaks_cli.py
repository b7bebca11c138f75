"""The ``pdmkit`` command speaks command line (issue 32, item 4): warnings as one
``pdmkit: warning:`` line each, repeats counted; ``--quiet`` prints nothing on success;
errors name flags (``--fs``), where Python callers are told keywords (``fs=``)."""

from __future__ import annotations

import logging
import re
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pdmkit._entry import main
from pdmkit.ensembles import read_members
from pdmkit.errors import DataError
from pdmkit.experiments._cli import main as cli_main
from pdmkit.experiments._messages import cli_text, cli_warnings

FS = 1000.0
LABEL = ["--label-from-name", r"_([a-z]+)\.csv$"]


def _members(folder: Path, n_per_class: int = 4, header: bool = True) -> Path:
    """Members 'ok' (noise) and 'worn' (noise with impacts), CSV with or without a
    header line (then every file warns that its first line is read as data)."""
    rng = np.random.default_rng(7)
    folder.mkdir(parents=True, exist_ok=True)
    t = np.arange(1024) / FS
    for k in range(n_per_class):
        for state in ("ok", "worn"):
            x = rng.normal(0, 1.0, t.size)
            if state == "worn":
                x[::97] += 12.0
            table = pd.DataFrame({"sec": t, "acc": x, "mic": rng.normal(0, 1, t.size)})
            table.to_csv(folder / f"pump{k:02d}_{state}.csv", index=False, header=header)
    return folder


def _engines(path: Path, n: int) -> Path:
    """``n`` engines run to failure: unit, cycle and two indicators that drift."""
    rng = np.random.default_rng(1)
    rows = []
    for u in range(n):
        life = int(rng.integers(80, 140))
        t = np.arange(1, life + 1)
        s1 = 10 + 3 * (t / life) ** 2 + rng.normal(0, 0.05, t.size)
        s2 = 5 - 2 * (t / life) ** 2 + rng.normal(0, 0.05, t.size)
        rows.append(pd.DataFrame({"unit": u + 1, "cycle": t, "s1": s1, "s2": s2}))
    pd.concat(rows, ignore_index=True).to_csv(path, index=False)
    return path


def _rig(path: Path) -> Path:
    """An input/output record without a header line (2 columns: force, response)."""
    rng = np.random.default_rng(0)
    u = rng.normal(size=2000)
    y = np.zeros_like(u)
    for i in range(2, u.size):  # y[i] = 1.2 y[i-1] - 0.5 y[i-2] + 0.2 u[i-1] + 0.1 u[i-2]
        y[i] = 1.2 * y[i - 1] - 0.5 * y[i - 2] + 0.2 * u[i - 1] + 0.1 * u[i - 2]
    y += 0.01 * rng.normal(size=u.size)
    pd.DataFrame({"u": u, "y": y}).to_csv(path, index=False, header=False)
    return path


def _warning_lines(err: str) -> list[str]:
    """The lines that show a warning: pdmkit's, or Python's ``...Warning: text``."""
    return [line for line in err.splitlines() if re.search(r"warning:|Warning\b", line)]


def _assert_cli_warnings(err: str) -> list[str]:
    """Every line that mentions a warning is one ``pdmkit: warning:`` line, no Python."""
    lines = _warning_lines(err)
    assert lines, err
    for line in lines:
        assert line.startswith("pdmkit: warning: "), line
        assert not re.search(r"\.py:\d+", line), line  # no file:line of source
        assert not re.search(r"\b[A-Z]\w*Warning:", line), line  # no category
    assert not any(line.startswith("  ") for line in err.splitlines())  # no source
    return lines


def test_headerless_members_warn_once_with_a_count(tmp_path, capsys):
    members = _members(tmp_path / "m", header=False)  # 8 files, each warns
    common = ["--members", str(members), "--fs", str(FS), *LABEL, "--signals", "column_1"]
    commands = {
        "features": ["features", *common],
        "classify": ["classify", *common, "--top-k", "2"],
        "rank": ["rank", *common],
    }
    for name, args in commands.items():
        assert main([*args, "--out", str(tmp_path / name)]) == 0, name
        lines = _assert_cli_warnings(capsys.readouterr().err)
        header = [line for line in lines if "csv: the first line (" in line]
        # the first file's warning in full, the 7 others as a count on one line
        assert len(header) == 2, (name, header)
        assert "pump00_ok.csv: the first line" in header[0]
        assert header[1].startswith("pdmkit: warning: (7 more times, for pump"), header
        # the Python-only advice (names=[...] to read_table) is not given at the CLI
        assert "read_table" not in header[0] and "names=" not in header[0]
        assert header[0].endswith("Add a header line to the file")


def test_rul_and_identify_warnings_are_single_lines(tmp_path, capsys):
    train = _engines(tmp_path / "train.csv", 8)  # 2 test units, 6 training for k=10
    args = ["rul", "--train", str(train), "--model", "similarity"]
    assert main([*args, "--out", str(tmp_path / "rul")]) == 0
    lines = _assert_cli_warnings(capsys.readouterr().err)
    assert any("6 training units for k=10" in line for line in lines)
    assert any("the scores come from 2 test unit(s)" in line for line in lines)
    rig = _rig(tmp_path / "rig.csv")
    args = ["identify", str(rig), "--input", "column_0", "--output", "column_1"]
    args += ["--fs", "200", "--structure", "arx", "--order", "na=2,nb=2,nk=1"]
    assert main([*args, "--out", str(tmp_path / "id")]) == 0
    lines = _assert_cli_warnings(capsys.readouterr().err)
    assert any("rig.csv: the first line" in line for line in lines)


def test_a_warning_repeated_in_a_loop_is_told_once_with_its_count(capsys):
    with cli_warnings():
        for _ in range(60):  # the same place, the same text: Python shows it once
            warnings.warn("the fit stopped early", RuntimeWarning, stacklevel=1)
        logging.getLogger("somelib").warning("font %r not found", "STIX")
    err = capsys.readouterr().err.splitlines()
    assert err == [
        "pdmkit: warning: the fit stopped early",
        "pdmkit: warning: font 'STIX' not found",
        "pdmkit: warning: (59 more times) the fit stopped early",
    ]
    # outside the block: Python's own warnings again
    with pytest.warns(RuntimeWarning, match="after"):
        warnings.warn("after", RuntimeWarning, stacklevel=1)


def test_the_error_line_comes_after_the_counts_and_names_the_flag(tmp_path, capsys):
    members = _members(tmp_path / "m", header=False)  # no time column, no --fs
    assert main(["features", "--members", str(members), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[-1].startswith("pdmkit: error: none of the 8 member files states its")
    assert "give --fs" in err[-1] and "fs=" not in err[-1]  # was: pass fs= (--fs)
    assert err[-2].startswith("pdmkit: warning: (7 more times, for pump")
    # a Python caller is still told the keyword
    with pytest.warns(UserWarning), pytest.raises(DataError, match=r"pass fs= \(--fs\)"):
        read_members(members)


def test_a_split_error_names_the_flags(tmp_path, capsys):
    members = _members(tmp_path / "m", n_per_class=2)  # 4 members: 1 test member
    args = ["classify", "--members", str(members), "--time", "sec", *LABEL]
    assert main([*args, "--test-size", "0.2", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "split with --test-size 0.2 give 3 training and 1 test" in err, err
    assert "change --test-size or add members" in err and "test_size" not in err


@pytest.mark.parametrize(
    ("python", "command_line"),
    [
        ("drop it and pass fs= (--fs)", "drop it and give --fs"),
        ("pass resample=HZ (--resample HZ) to", "give --resample HZ to"),
        ("or pass fs (--fs).", "or give --fs."),
        ("hop (--hop) '5' needs frame (--frame LENGTH)", "--hop '5' needs --frame LENGTH"),
        ("an fs column of the labels table (--labels)", None),  # no keyword: kept
        ("split='group' needs groups", "--split group needs groups"),
        ("pass unit=<column telling the units apart>", "give --unit <column telling"),
        ("each unit's rows, split in time", None),  # plain words stay words
        ("folder data/unit=3/part.parquet", None),  # a path is no keyword
        ("orders the rows with time=", "orders the rows with --order"),
        ("`dask scheduler`, or pass workers=N to start", "or give --workers N to start"),
        ("Correct the cells, or pass dtype={'a': str} to read them all as text", "cells"),
        ("no time column 'sec' (time= / --time); it has", "'sec' (--time); it has"),
        ("3 or more samples to fit; pass threshold=", "give --option threshold=VALUE"),
        ("pass pad='edge' (repeat", "give --option pad=edge (repeat"),
        (
            "needs at least 2 - pass prior={'mean': m0, 'var': v0}",
            """give --option prior='{"mean": m0, "var": v0}'""",
        ),
        ("the gamma shape cannot be estimated", None),
    ],
)
def test_cli_text_translates_known_advice_only(python, command_line):
    said = cli_text(python)
    if command_line is None:
        assert said == python
    else:
        assert said.endswith(command_line) or command_line in said, said
        python_keyword = re.sub(r"--option [a-z_]+=", "", said)
        assert not re.search(r"\b[a-z_]+=", python_keyword), said


def _quiet_runs(tmp_path: Path) -> dict[str, list[str]]:
    members = _members(tmp_path / "m")  # headed CSVs: nothing to warn about
    common = ["--members", str(members), "--time", "sec", *LABEL, "--quiet"]
    train = _engines(tmp_path / "train.csv", 40)  # 10 test units, 30 training
    return {
        "features": ["features", *common, "--groups", "stats"],
        "classify": ["classify", *common, "--top-k", "2"],
        "rank": ["rank", *common, "--groups", "stats"],
        "sensors": ["sensors", *common, "--groups", "stats"],
        "rul": ["rul", "--train", str(train), "--model", "similarity", "--quiet"],
    }


def test_quiet_prints_nothing_on_success(tmp_path, capsys):
    for name, args in _quiet_runs(tmp_path).items():
        out = tmp_path / f"out_{name}"
        assert main([*args, "--out", str(out)]) == 0, name
        said = capsys.readouterr()
        assert (said.out, said.err) == ("", ""), name
        assert (out / "summary.json").is_file()  # the work was done
    # without --quiet the same command says what it did
    args = _quiet_runs(tmp_path)["features"]
    args.remove("--quiet")
    assert main([*args, "--out", str(tmp_path / "loud")]) == 0
    assert "pdmkit: wrote" in capsys.readouterr().err


def test_quiet_still_shows_warnings_and_errors(tmp_path, capsys):
    members = _members(tmp_path / "m", header=False)
    args = ["features", "--members", str(members), *LABEL, "--quiet"]
    assert main([*args, "--fs", str(FS), "--out", str(tmp_path / "a")]) == 0
    said = capsys.readouterr()
    assert said.out == ""
    assert [line.split(":")[1] for line in said.err.splitlines()] == [" warning"] * 2
    assert main([*args, "--out", str(tmp_path / "b")]) == 2  # no --fs
    assert capsys.readouterr().err.splitlines()[-1].startswith("pdmkit: error:")


def test_every_command_with_an_output_folder_takes_quiet(tmp_path, capsys):
    from pdmkit.experiments._cli import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    lacking = [
        name
        for name, parser in sub.choices.items()
        if "--out" in parser._option_string_actions
        and "--quiet" not in parser._option_string_actions
    ]
    assert lacking == []
    assert "--quiet" in sub.choices["demo"]._option_string_actions
    assert "--quiet" in sub.choices["study"]._option_string_actions
    # library (in-process) use of the CLI function keeps Python's warnings
    members = _members(tmp_path / "m", n_per_class=1, header=False)
    with pytest.warns(UserWarning, match="holds only numbers"):
        cli_main(["features", "--members", str(members), "--fs", "1000", "--quiet",
                  "--out", str(tmp_path / "o")])  # fmt: skip
