"""Property tests of the readers: any input gives a table or a clear DataError."""

from __future__ import annotations

import io
import re

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.io import savemat

from pdmkit.ensembles import read_mat, read_npz, read_table
from pdmkit.ensembles._member_files import read_members
from pdmkit.errors import DataError

FUZZ = settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)

names = st.text(
    alphabet=st.characters(codec="utf-8", exclude_characters="\x00\r\n,\"'"),
    min_size=1,
    max_size=8,
).filter(lambda s: s.strip() == s and not s.startswith("Unnamed"))
cells = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.integers(-(10**6), 10**6),
    st.text(alphabet="abcxyzé ;", max_size=5),
    st.none(),
)


@st.composite
def frames(draw):
    cols = draw(st.lists(names, min_size=1, max_size=5, unique=True))
    n = draw(st.integers(0, 12))
    data = {c: draw(st.lists(cells, min_size=n, max_size=n)) for c in cols}
    return pd.DataFrame(data)


def _write(tmp_path, name, data: bytes):
    path = tmp_path / name
    path.write_bytes(data)
    return path


def _reads_or_data_error(func, path):
    try:
        return func(path)
    except DataError as exc:
        assert str(path) in str(exc) or path.name in str(exc)
        return None


@FUZZ
@given(frame=frames(), encoding=st.sampled_from(["utf-8", "latin-1", "utf-16", "cp1252"]))
def test_csv_of_any_shape_and_encoding(tmp_path, frame, encoding):
    text = frame.to_csv(index=False)
    try:
        data = text.encode(encoding)
    except UnicodeEncodeError:
        data = text.encode("utf-8")
    path = _write(tmp_path, "t.csv", data)
    table = _reads_or_data_error(read_table, path)
    if table is not None:
        assert len(table) > 0  # an empty table is a DataError, never an empty frame
    if encoding == "utf-8":
        # a first line of numbers only is data, not a header: one more row
        headerless = _numbers_only(frame.columns)
        rows = _rows_a_csv_can_hold(frame) + headerless
        if rows and _mixes_numbers_and_text(frame, headerless):
            assert table is None  # a column of numbers with a text cell is refused
        elif rows:
            assert table is not None and len(table) == rows
        else:
            assert table is None


#: A number as a CSV cell holds it (the strategy's text cells hold no digits).
_NUMBER = re.compile(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?")


def _numbers_only(names) -> bool:
    """Whether the header line holds numbers only (and is not pandas' own 0,1,...)."""
    names = [str(n) for n in names]
    return all(_NUMBER.fullmatch(n) for n in names) and names != [
        str(i) for i in range(len(names))
    ]


def _mixes_numbers_and_text(frame: pd.DataFrame, headerless: bool) -> bool:
    """Whether a column's CSV cells hold numbers and (non-blank) text together."""
    for name in frame.columns:
        cells = frame[name].tolist() + ([name] if headerless else [])
        numbers = [
            isinstance(v, int | float) or _NUMBER.fullmatch(str(v))
            for v in cells
            if not _blank(v)
        ]
        if any(numbers) and not all(numbers):
            return True
    return False


def _blank(value) -> bool:
    return (
        value is None
        or (isinstance(value, str) and not value.strip())
        or (isinstance(value, float) and np.isnan(value))
    )


def _rows_a_csv_can_hold(frame: pd.DataFrame) -> int:
    """Rows of ``frame`` its CSV text keeps: in a one-column file an empty value is an
    empty line, and empty lines after the last value are not rows (read_table keeps
    the ones between values as missing values)."""
    if frame.shape[1] != 1:
        return len(frame)
    filled = [i for i, v in enumerate(frame.iloc[:, 0].tolist()) if not _blank(v)]
    return filled[-1] + 1 if filled else 0


@FUZZ
@given(data=st.binary(max_size=300))
def test_random_bytes_as_any_format(tmp_path, data):
    for name, func in (
        ("r.csv", read_table),
        ("r.parquet", read_table),
        ("r.mat", read_mat),
        ("r.npz", read_npz),
    ):
        _reads_or_data_error(func, _write(tmp_path, name, data))


@FUZZ
@given(frame=frames(), cut=st.floats(0.0, 0.99))
def test_parquet_round_trip_and_truncation(tmp_path, frame, cut):
    frame = frame.astype(str) if len(frame.columns) else frame
    buffer = io.BytesIO()
    frame.to_parquet(buffer)
    raw = buffer.getvalue()
    whole = _reads_or_data_error(read_table, _write(tmp_path, "w.parquet", raw))
    if len(frame):
        pd.testing.assert_frame_equal(whole, frame.reset_index(drop=True))
    else:
        assert whole is None
    with pytest.raises(DataError, match=r"t\.parquet"):
        read_table(_write(tmp_path, "t.parquet", raw[: int(cut * len(raw))]))


@FUZZ
@given(
    variables=st.dictionaries(
        st.from_regex(r"[a-z][a-z0-9_]{0,6}", fullmatch=True),
        arrays(
            np.float64,
            st.tuples(st.integers(1, 5), st.integers(1, 5)),
            elements=st.floats(-1e6, 1e6),
        ),
        min_size=1,
        max_size=4,
    ),
    cut=st.floats(0.0, 0.99),
)
def test_mat_round_trip_and_truncation(tmp_path, variables, cut):
    buffer = io.BytesIO()
    savemat(buffer, variables)
    raw = buffer.getvalue()
    data = read_mat(_write(tmp_path, "w.mat", raw))
    assert sorted(data) == sorted(variables)
    for k, v in variables.items():
        np.testing.assert_array_equal(np.asarray(data[k]).reshape(v.shape), v)
    _reads_or_data_error(read_mat, _write(tmp_path, "t.mat", raw[: int(cut * len(raw))]))


def test_empty_files_are_clear_data_errors(tmp_path):
    for name, func, match in (
        ("e.csv", read_table, "is empty"),
        ("e.parquet", read_table, "cannot read"),
        ("e.mat", read_mat, "cannot read"),
        ("e.npz", read_npz, "cannot read"),
    ):
        with pytest.raises(DataError, match=match):
            func(_write(tmp_path, name, b""))


@FUZZ
@given(blobs=st.lists(st.binary(max_size=200), min_size=1, max_size=4))
def test_member_folders_of_garbage_never_crash(tmp_path, blobs):
    folder = tmp_path / "members"
    folder.mkdir(exist_ok=True)
    for old in folder.iterdir():
        old.unlink()
    for i, blob in enumerate(blobs):
        (folder / f"m{i}{['.csv', '.mat', '.npz', '.parquet'][i % 4]}").write_bytes(blob)
    try:
        _, errors = read_members(folder, fs=100.0, on_error="skip", return_errors=True)
    except DataError as exc:
        assert "no member could be read" in str(exc) or "sampling rate" in str(exc)
    else:
        assert set(errors.columns) == {"member", "signal", "source", "error"}
