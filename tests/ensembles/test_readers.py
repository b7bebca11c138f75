"""Readers: CSV / Parquet tables, MATLAB files, NumPy archives; and from_frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.io import savemat

from pdmkit.ensembles import from_frame, read_mat, read_npz, read_table
from pdmkit.errors import DataError, DataNotFoundError

GARBAGE = np.random.default_rng(7).bytes(2048)


# ---------------------------------------------------------------- read_table


def test_read_table_csv_and_parquet_agree(tmp_path: Path) -> None:
    frame = pd.DataFrame(
        {"t": [0.0, 0.1, 0.2], "flow": [1.0, 2.0, 3.0], "tag": list("abc")}
    )
    frame.to_csv(tmp_path / "a.csv", index=False)
    frame.to_parquet(tmp_path / "a.parquet")
    frame.to_csv(tmp_path / "a.tsv", sep="\t", index=False)
    frame.to_csv(tmp_path / "a.csv.gz", index=False)
    for name in ("a.csv", "a.parquet", "a.tsv", "a.csv.gz"):
        pd.testing.assert_frame_equal(read_table(tmp_path / name), frame)


def test_read_table_drops_the_empty_column_of_a_trailing_delimiter(tmp_path: Path) -> None:
    (tmp_path / "t.csv").write_text('"V1","V2",\n0.5,0.25,\n1.5,1.25,\n')
    table = read_table(tmp_path / "t.csv")
    assert table.columns.tolist() == ["V1", "V2"]
    assert table["V2"].tolist() == [0.25, 1.25]


def test_one_column_csv_keeps_empty_values_in_place(tmp_path: Path) -> None:
    # pandas skips blank lines; in a one-column recording they are missing samples,
    # and skipping them would shift every later sample (a lost time alignment)
    path = tmp_path / "flow.csv"
    path.write_text("flow\n1.5\n\n1.7\n   \n1.9\n\n\n")
    table = read_table(path)
    np.testing.assert_array_equal(table["flow"], [1.5, np.nan, 1.7, np.nan, 1.9])
    # with two columns an empty line is no row at all, as pandas reads it
    path.write_text("t,flow\n0,1.5\n\n1,1.7\n")
    assert read_table(path)["flow"].tolist() == [1.5, 1.7]


@pytest.mark.parametrize("name", ["bad.csv", "bad.parquet"])
def test_read_table_garbage_names_the_file(tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    path.write_bytes(GARBAGE)
    with pytest.raises(DataError, match=name):
        read_table(path)


def test_read_table_empty_or_header_only_csv(tmp_path: Path) -> None:
    (tmp_path / "empty.csv").write_text("")
    with pytest.raises(DataError, match=r"empty\.csv is empty"):
        read_table(tmp_path / "empty.csv")
    (tmp_path / "head.csv").write_text("a,b\n")
    with pytest.raises(DataError, match=r"head\.csv holds no rows"):
        read_table(tmp_path / "head.csv")


def test_read_table_unknown_extension_and_missing_file(tmp_path: Path) -> None:
    (tmp_path / "data.xlsx").write_bytes(b"PK")
    with pytest.raises(DataError, match=r"data\.xlsx.*unknown table format"):
        read_table(tmp_path / "data.xlsx")
    with pytest.raises(DataNotFoundError, match=r"nothere.csv"):
        read_table(tmp_path / "nothere.csv")
    with pytest.raises(DataError, match="is a folder, not a file"):
        read_table(tmp_path)


# ---------------------------------------------------------------- read_mat


def test_read_mat_squeezes_and_skips_header_keys(tmp_path: Path) -> None:
    path = tmp_path / "rig.mat"
    savemat(path, {"u": np.arange(5.0).reshape(5, 1), "y": np.ones((1, 5)), "Ts": 4})
    data = read_mat(path)
    assert sorted(data) == ["Ts", "u", "y"]
    assert data["u"].shape == (5,) and data["y"].shape == (5,)
    np.testing.assert_array_equal(data["u"], np.arange(5.0))
    assert float(data["Ts"]) == 4.0


def test_read_mat_damaged_v73_hdf5_is_named(tmp_path: Path) -> None:
    """v7.3 files are read with h5py (tests/ensembles/test_matlab_members.py); a
    damaged one is a one-line DataError that says what it was read as."""
    path = tmp_path / "new.mat"
    header = (
        b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5"
    )
    path.write_bytes(header.ljust(512, b" ") + b"\x89HDF\r\n\x1a\n" + bytes(100))
    with pytest.raises(DataError, match=r"new\.mat as a MATLAB v7\.3 \(HDF5\) file") as exc:
        read_mat(path)
    assert "\n" not in str(exc.value) and "damaged" in str(exc.value)


def test_read_mat_garbage_and_missing(tmp_path: Path) -> None:
    path = tmp_path / "junk.mat"
    path.write_bytes(GARBAGE)
    with pytest.raises(DataError, match=r"junk\.mat"):
        read_mat(path)
    with pytest.raises(DataNotFoundError, match=r"gone\.mat"):
        read_mat(tmp_path / "gone.mat")


# ---------------------------------------------------------------- read_npz


def test_read_npz_returns_all_arrays(tmp_path: Path) -> None:
    path = tmp_path / "rec.npz"
    np.savez_compressed(path, DE=np.arange(6.0).reshape(6, 1), FE=np.zeros(3))
    data = read_npz(path)
    assert sorted(data) == ["DE", "FE"]
    np.testing.assert_array_equal(data["DE"].ravel(), np.arange(6.0))


def test_read_npz_refuses_object_arrays(tmp_path: Path) -> None:
    path = tmp_path / "pickled.npz"
    np.savez(path, ok=np.zeros(2), bad=np.array([{"a": 1}, None], dtype=object))
    with pytest.raises(DataError, match=r"'bad' in .*pickled\.npz holds Python objects"):
        read_npz(path)


@pytest.mark.parametrize(
    "content",
    [GARBAGE, b"PK\x03\x04" + GARBAGE[:200], b""],
    ids=["random-bytes", "broken-zip", "empty"],
)
def test_read_npz_garbage_names_the_file(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "broken.npz"
    path.write_bytes(content)
    with pytest.raises(DataError, match=r"broken\.npz"):
        read_npz(path)


def test_read_npz_single_array_and_missing(tmp_path: Path) -> None:
    np.save(tmp_path / "one.npy", np.zeros(3))
    with pytest.raises(DataError, match=r"single .npy array"):
        read_npz(tmp_path / "one.npy")
    with pytest.raises(DataNotFoundError):
        read_npz(tmp_path / "missing.npz")


# ---------------------------------------------------------------- from_frame


@pytest.fixture
def runs() -> pd.DataFrame:
    return pd.DataFrame(
        {
            "unit": [3, 3, 3, 3, 1, 1, 1, 3],
            "p": np.arange(8.0),
            "q": np.arange(8.0) * 10,
            "state": ["ok", "ok", "ok", "ok", "bad", "bad", "bad", "ok"],
        }
    )


def test_from_frame_one_member_per_member_column_value(runs: pd.DataFrame) -> None:
    ens = from_frame(
        runs, signal_columns=["p", "q"], fs=2.0, member_column="unit", label_columns="state"
    )
    assert ens.member_ids.tolist() == ["3", "1"]  # order of first appearance
    np.testing.assert_array_equal(ens.signal("p")[0], [0.0, 1.0, 2.0, 3.0, 7.0])
    np.testing.assert_array_equal(ens.signal("q")[1], [40.0, 50.0, 60.0])
    assert ens.conditions["state"].tolist() == ["ok", "bad"]
    assert ens.fs == {"p": 2.0, "q": 2.0}


def test_from_frame_frames_of_one_recording_with_per_frame_labels() -> None:
    table = pd.DataFrame({"x": np.arange(10.0), "mode": ["a"] * 4 + ["b"] * 6})
    ens = from_frame(
        table, signal_columns="x", fs=1.0, frame_length=2, label_columns="mode"
    )
    assert len(ens) == 5
    assert ens.conditions["mode"].tolist() == ["a", "a", "b", "b", "b"]
    np.testing.assert_array_equal(ens.signal("x")[3], [6.0, 7.0])
    with pytest.raises(DataError, match="'mode' changes within frame"):
        from_frame(table, signal_columns="x", fs=1.0, frame_length=3, label_columns="mode")


def test_from_frame_members_then_frames(runs: pd.DataFrame) -> None:
    ens = from_frame(
        runs,
        signal_columns="p",
        fs=1.0,
        member_column="unit",
        frame_length=2,
        label_columns=["state"],
    )
    assert ens.member_ids.tolist() == ["3/f0000", "3/f0001", "1/f0000"]
    np.testing.assert_array_equal(ens.signal("p")[1], [2.0, 3.0])
    assert ens.conditions["state"].tolist() == ["ok", "ok", "bad"]


def test_from_frame_errors(runs: pd.DataFrame) -> None:
    with pytest.raises(DataError, match=r"'nope'.*not in the table"):
        from_frame(runs, signal_columns="nope", fs=1.0)
    with pytest.raises(DataError, match="'state' is not numeric"):
        from_frame(runs, signal_columns="state", fs=1.0)
    with pytest.raises(DataError, match="'state' changes within member"):
        from_frame(runs, signal_columns="p", fs=1.0, label_columns="state")
    bad = runs.assign(p=runs["p"].where(runs.index != 5))
    with pytest.raises(DataError, match=r"signal 'p' of member '1' holds 1 non-finite"):
        from_frame(bad, signal_columns="p", fs=1.0, member_column="unit")
