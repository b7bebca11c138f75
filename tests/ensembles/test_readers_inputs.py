"""Inputs as they come: whitespace-delimited text, time columns named otherwise, labels
from file names or a labels table (issue 15, "inputs as they come")."""

from __future__ import annotations

import gzip
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pdmkit.ensembles import read_members, read_table
from pdmkit.errors import DataError, DataWarning

# ---------------------------------------------------------------- whitespace text


@pytest.mark.real_data
def test_raw_cmapss_text_reads_as_26_numeric_columns_with_generated_names(require_data):
    """NASA's test_FD003.txt is pristine: numbers split by spaces, two trailing spaces
    on every line, no header. Today's reader saw one text column."""
    path = require_data("cmapss_fd001") / "test_FD003.txt"
    with pytest.warns(DataWarning, match=r"column_0 \.\.\. column_25"):
        table = read_table(path)
    reference = np.loadtxt(path)  # numpy's own whitespace parser
    assert table.shape == reference.shape == (reference.shape[0], 26)
    assert list(table.columns) == [f"column_{k}" for k in range(26)]
    np.testing.assert_array_equal(table.to_numpy(dtype=float), reference)
    # unit and cycle as the NASA readme describes them: 100 engines, cycles from 1
    assert table["column_0"].nunique() == 100
    assert (table.groupby("column_0")["column_1"].min() == 1).all()


@pytest.mark.real_data
def test_cmapss_text_with_a_header_drops_the_names_its_rows_lack(require_data):
    """The copy of train_FD001.txt here carries a header of 31 names over 26 values."""
    path = require_data("cmapss_fd001") / "train_FD001.txt"
    with pytest.warns(DataWarning, match=r"names 31 columns but the rows hold 26"):
        table = read_table(path)
    reference = np.loadtxt(path, skiprows=1)
    assert list(table.columns[:3]) == ["unit_number", "time", "opt_set1"]
    assert table.shape == reference.shape
    np.testing.assert_array_equal(table.to_numpy(dtype=float), reference)


def test_whitespace_text_with_tabs_leading_spaces_and_compression(tmp_path: Path):
    text = "  time   flow\tpressure \n 0.0  1.5\t 2.0\n 0.1   1.7\t2.5  \n\n"
    plain = tmp_path / "rig.txt"
    plain.write_text(text)
    packed = tmp_path / "rig.txt.gz"
    packed.write_bytes(gzip.compress(text.encode()))
    expected = pd.DataFrame(
        {"time": [0.0, 0.1], "flow": [1.5, 1.7], "pressure": [2.0, 2.5]}
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a header line: nothing to warn about
        pd.testing.assert_frame_equal(read_table(plain), expected)
        pd.testing.assert_frame_equal(read_table(packed), expected)


def test_comma_files_and_one_column_files_are_not_taken_for_whitespace(tmp_path: Path):
    csv = tmp_path / "labels.csv"
    csv.write_text("name,fault\npump a,inner race\npump b,ok\n")
    assert read_table(csv)["fault"].tolist() == ["inner race", "ok"]
    one = tmp_path / "one.txt"
    one.write_text("flow\n1.0\n2.0\n")
    assert read_table(one)["flow"].tolist() == [1.0, 2.0]
    # an explicit separator is the user's word
    spaced = tmp_path / "spaced.txt"
    spaced.write_text("a b\n1 2\n")
    assert read_table(spaced, sep=",").columns.tolist() == ["a b"]


def test_whitespace_text_keeps_the_size_ceiling(tmp_path: Path, monkeypatch):
    path = tmp_path / "big.txt"
    path.write_text("1 2 3\n" * 2000)  # 12 000 bytes
    monkeypatch.setenv("PDMKIT_MAX_MEMBER_BYTES", "4096")
    with pytest.raises(DataError, match="more than the 4 KiB"):
        read_table(path)
    gz = tmp_path / "big.txt.gz"  # compressed: the decompressed text counts
    gz.write_bytes(gzip.compress(b"1 2 3\n" * 2000))
    with pytest.raises(DataError, match="decompresses to at least"):
        read_table(gz)


def test_whitespace_text_cell_errors_name_the_line(tmp_path: Path):
    path = tmp_path / "log.txt"
    path.write_text("t v\n0.0 1.0\n0.1 x\n0.2 1.2\n")
    with pytest.raises(DataError, match=r"column 'v' mixes.*line 3: 'x'"):
        read_table(path)


# ---------------------------------------------------------------- members


def _member(path: Path, time_name: str = "time", n: int = 200, fs: float = 100.0):
    t = np.arange(n) / fs
    frame = pd.DataFrame({time_name: t, "vib": np.sin(2 * np.pi * 5 * t)})
    frame.to_csv(path, index=False)


def test_members_with_a_time_column_named_otherwise(tmp_path: Path):
    for name in ("a.csv", "b.csv"):
        _member(tmp_path / name, time_name="Zeit_s", fs=250.0)
    ens = read_members(tmp_path, time="Zeit_s")
    assert ens.fs["vib"] == pytest.approx(250.0)
    assert ens.signal_names == ["vib"]  # the time column is no signal
    with pytest.raises(DataError, match=r"a\.csv: no time column 'zeit_s'.*'Zeit_s'"):
        read_members(tmp_path, time="zeit_s")


def test_whitespace_member_files_read_with_their_time(tmp_path: Path):
    for name in ("r1.txt", "r2.txt"):
        rows = "\n".join(f" {k / 50:.3f}   {np.sin(k):.5f}" for k in range(100))
        (tmp_path / name).write_text("  sec   acc\n" + rows + "\n")
    ens = read_members(tmp_path, time="sec")
    assert ens.fs["acc"] == pytest.approx(50.0)
    assert len(ens.signal("acc")[0]) == 100


def test_label_from_name_one_group_and_named_groups(tmp_path: Path):
    for name in ("1797_IR_7.csv", "1797_OR_21.csv", "1772_IR_14.csv"):
        _member(tmp_path / name)
    ens = read_members(tmp_path, label_from_name=r"^\d+_([A-Z]+)_")
    assert dict(zip(ens.member_ids, ens.conditions["label"], strict=True)) == {
        "1772_IR_14": "IR",
        "1797_IR_7": "IR",
        "1797_OR_21": "OR",
    }
    ens = read_members(tmp_path, label_from_name=r"^(?P<rpm>\d+)_(?P<fault>[A-Z]+)_")
    assert sorted(ens.conditions.columns) == ["fault", "rpm"]
    assert sorted(ens.conditions["rpm"]) == ["1772", "1797", "1797"]


def test_label_from_name_mismatch_and_bad_expressions(tmp_path: Path):
    _member(tmp_path / "run_IR.csv")
    _member(tmp_path / "notes.csv")
    with pytest.raises(DataError, match=r"notes\.csv: its name does not match"):
        read_members(tmp_path, label_from_name=r"_([A-Z]+)\.csv")
    ens, errors = read_members(
        tmp_path, label_from_name=r"_([A-Z]+)\.csv", on_error="skip", return_errors=True
    )
    assert ens.member_ids.tolist() == ["run_IR"]
    assert errors["member"].tolist() == ["notes"]
    with pytest.raises(DataError, match="is not a regular expression"):
        read_members(tmp_path, label_from_name="(unclosed")
    with pytest.raises(DataError, match="has 2 groups; it needs one group"):
        read_members(tmp_path, label_from_name=r"(\w+)_(\w+)")


def test_labels_table_by_file_name_or_member_id(tmp_path: Path):
    members = tmp_path / "m"
    members.mkdir()
    for name in ("a.csv", "b.csv", "c.csv"):
        _member(members / name)
    labels = tmp_path / "labels.csv"
    labels.write_text("File,fault,load_kN\na.csv,ok,1.5\nb,inner,2.0\nc.csv,outer,2.5\n")
    ens = read_members(members, labels=labels)
    got = ens.conditions.set_index(ens.member_ids)
    assert got.loc["b", "fault"] == "inner"
    assert got["load_kN"].tolist() == [1.5, 2.0, 2.5]


def test_labels_table_problems_are_named(tmp_path: Path):
    members = tmp_path / "m"
    members.mkdir()
    for name in ("a.csv", "b.csv"):
        _member(members / name)
    table = tmp_path / "labels.csv"
    table.write_text("file,fault\na.csv,ok\nzz.csv,inner\n")
    with pytest.raises(DataError, match=r"b\.csv is not listed in labels table"):
        read_members(members, labels=table)
    with pytest.warns(DataWarning, match=r"1 row\(s\) name no member file read.*zz"):
        ens, errors = read_members(
            members, labels=table, on_error="skip", return_errors=True
        )
    assert ens.member_ids.tolist() == ["a"] and errors["member"].tolist() == ["b"]
    table.write_text("fault\nok\n")
    with pytest.raises(DataError, match="no column names the member files"):
        read_members(members, labels=table)
    table.write_text("file,fault\na.csv,ok\na,inner\nb.csv,ok\n")
    with pytest.raises(DataError, match=r"\['a'\] are listed more than once"):
        read_members(members, labels=table)


def test_a_label_given_twice_differently_is_an_error(tmp_path: Path):
    t = np.arange(100) / 50.0
    pd.DataFrame({"time": t, "vib": t, "label": "ok"}).to_csv(
        tmp_path / "x_IR.csv", index=False
    )
    with pytest.raises(DataError, match="'label' is 'ok' in the file but 'IR'"):
        read_members(tmp_path, label_from_name=r"_([A-Z]+)\.csv")
    # the same value twice is no clash
    same = tmp_path / "same"
    same.mkdir()
    pd.DataFrame({"time": t, "vib": t, "label": "ok"}).to_csv(
        same / "y_ok.csv", index=False
    )
    ens = read_members(same, label_from_name=r"_([a-z]+)\.csv")
    assert ens.conditions["label"].tolist() == ["ok"]


@pytest.mark.real_data
def test_cwru_members_take_their_fault_from_the_file_name(require_data):
    folder = require_data("cwru_bearing")
    ens = read_members(folder, fs=12_000.0, label_from_name=r"^\d+_([A-Za-z]+)")
    labels = dict(zip(ens.member_ids, ens.conditions["label"], strict=True))
    assert labels == {
        "1797_B_7_DE12": "B",
        "1797_IR_21_DE12": "IR",
        "1797_IR_7_DE12": "IR",
        "1797_Normal": "Normal",
        "1797_OR@6_7_DE12": "OR",
    }
