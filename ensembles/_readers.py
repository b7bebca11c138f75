"""Readers for the file formats recordings come in: CSV / Parquet tables, MATLAB, NumPy.

Recordings are untrusted input. Every reader

- raises :class:`pdmkit.errors.DataNotFoundError` for a missing file and
  :class:`pdmkit.errors.DataError` for one it cannot read, with the path (and the array,
  variable or column) in a one-line message; never a bare ``KeyError``,
  ``zipfile.BadZipFile``, ``zlib.error`` or pickle error;
- checks the sizes a file *declares* before reading it, against
  :func:`pdmkit._config.max_bytes` ``("member")`` (1 GiB by default,
  ``$PDMKIT_MAX_MEMBER_BYTES``): the ``.npy`` header of every ``.npz`` array and its zip
  entry size, the variable shapes of a ``.mat`` file and the decompressed size of each
  of its compressed variables, the column-chunk sizes of a Parquet file, the
  decompressed text of a CSV file. A small file that declares (or decompresses to) a
  huge array is refused before anything is allocated;
- never unpickles anything.
"""

from __future__ import annotations

import bz2
import contextlib
import gzip
import lzma
import math
import os
import re
import struct
import warnings
import zipfile
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np
import pandas as pd

from pdmkit._checks import npy_declared, parse_timestamps
from pdmkit._config import max_bytes
from pdmkit._progress import progress as _progress_bar
from pdmkit.ensembles._ensemble import Ensemble
from pdmkit.ensembles._limits import _one_line, _size, _too_big, _why, check_declared_sizes
from pdmkit.errors import DataError, DataNotFoundError, DataWarning, did_you_mean

__all__ = ["read_mat", "read_members", "read_npz", "read_table"]

_CSV = (".csv", ".tsv", ".txt")
_COMPRESSED = (".gz", ".bz2", ".zip", ".xz", ".zst")
_PARQUET = (".parquet", ".pq")
#: Errors a damaged compressed stream raises while it is read.
_DECOMPRESS_ERRORS = (
    OSError,  # gzip.BadGzipFile
    EOFError,
    zlib.error,
    lzma.LZMAError,
    zipfile.BadZipFile,
    ValueError,
    struct.error,
)


def _existing_file(path: str | os.PathLike, what: str) -> Path:
    path = Path(path)
    if not path.exists():
        raise DataNotFoundError(f"{path} does not exist; expected {what}")
    if not path.is_file():
        raise DataError(
            f"{path} is a folder, not a file; expected {what}. Name a file, or the "
            f"files inside that folder (e.g. {path / '*'})"
        )
    return path


# --------------------------------------------------------------------------- tables
def _table_kind(path: Path) -> tuple[str, str]:
    """('csv' | 'parquet', compression suffix or '')."""
    suffixes = [s.lower() for s in path.suffixes]
    compression = ""
    if suffixes and suffixes[-1] in _COMPRESSED:
        compression = suffixes.pop()
    last = suffixes[-1] if suffixes else ""
    if last in _CSV:
        return "csv", compression
    if last in _PARQUET and not compression:
        return "parquet", ""
    raise DataError(
        f"{path}: unknown table format {''.join(path.suffixes) or '(no extension)'!r}; "
        f"read_table takes {', '.join(_CSV + _PARQUET)} (CSV optionally compressed "
        f"{', '.join(_COMPRESSED)}). Rename the file or read it with pandas directly."
    )


@contextlib.contextmanager
def _open_text_bytes(path: Path, compression: str) -> Iterator[IO[bytes]]:
    """The bytes of a (possibly compressed) text file, decompressed as they are read."""
    if not compression:
        with path.open("rb") as f:
            yield f
    elif compression == ".gz":
        with gzip.open(path, "rb") as f:
            yield f
    elif compression == ".bz2":
        with bz2.open(path, "rb") as f:
            yield f
    elif compression == ".xz":
        with lzma.open(path, "rb") as f:
            yield f
    elif compression == ".zip":
        with zipfile.ZipFile(path) as archive:
            entries = [i for i in archive.infolist() if not i.is_dir()]
            if len(entries) != 1:
                raise DataError(
                    f"{path} holds {len(entries)} files; a zipped table holds exactly "
                    "one. Unzip it and read the table you mean"
                )
            with archive.open(entries[0]) as f:
                yield f
    else:  # .zst
        try:
            import zstandard
        except ImportError:
            raise DataError(
                f"{path} is zstd-compressed; reading it needs the package zstandard "
                "(pip install zstandard), or decompress it first"
            ) from None
        with path.open("rb") as raw, zstandard.ZstdDecompressor().stream_reader(raw) as f:
            yield f


def _text_bytes(path: Path, compression: str, limit: int) -> int:
    """Bytes of text in the file after decompression, counted up to ``limit + 1``."""
    if not compression:
        return path.stat().st_size
    total = 0
    try:
        with _open_text_bytes(path, compression) as f:
            while total <= limit:
                chunk = f.read(1 << 20)
                if not chunk:
                    break
                total += len(chunk)
    except _DECOMPRESS_ERRORS as exc:
        raise DataError(
            f"cannot decompress {path} ({_why(exc)}); the file is damaged "
            f"or not {compression[1:]}-compressed"
        ) from None
    return total


def _first_line(path: Path, compression: str) -> str:
    """The first non-blank line of a text file (for messages; at most 60 characters)."""
    try:
        with _open_text_bytes(path, compression) as f:
            for raw in f:
                line = raw.decode("utf-8", "replace").strip()
                if line:
                    return line if len(line) <= 60 else line[:57] + "..."
    except (DataError, *_DECOMPRESS_ERRORS):
        pass
    return ""


def _csv_line(
    path: Path, compression: str, row: int, header_lines: int, blanks: bool
) -> int:
    """The line number (from 1, as an editor shows it) of data row ``row`` (from 0).

    pandas skips blank lines (``blanks=False``) except where a one-column file keeps
    them as missing values (``blanks=True``). Falls back to counting without blank
    lines when the file cannot be scanned.
    """
    wanted = header_lines + row + 1
    seen = 0
    try:
        with _open_text_bytes(path, compression) as f:
            for number, raw in enumerate(f, start=1):
                if raw.strip() or (blanks and seen >= header_lines):
                    seen += 1
                    if seen == wanted:
                        return number
    except (DataError, *_DECOMPRESS_ERRORS):
        pass
    return wanted


#: The name pandas gives the k-th repeat of a CSV header's column name (``vib.1``).
_MANGLED = re.compile(r"(.+)\.[1-9][0-9]*")
#: The pandas CSV options that say where the header line is and how it is split.
_HEADER_OPTIONS = (
    "sep",
    "delimiter",
    "skiprows",
    "skip_blank_lines",
    "comment",
    "encoding",
    "encoding_errors",
    "quotechar",
    "quoting",
    "doublequote",
    "escapechar",
    "skipinitialspace",
    "lineterminator",
    "dialect",
    "engine",
)


def _duplicated_header(path: Path, table: pd.DataFrame, options: dict) -> None:
    """Refuse a CSV header that names two columns alike.

    pandas renames the repeat (``vib``, ``vib`` becomes ``vib``, ``vib.1``), so the
    second column would be read as a signal the file does not name. Checked only when
    a column looks renamed; the header line is then read again as it is written.
    """
    header = options.get("header", "infer")
    if options.get("names") is not None or isinstance(header, bool):
        return
    if header != "infer" and not isinstance(header, int):
        return  # None (no header) or several header lines
    names = {str(c) for c in table.columns}
    suspects = [
        c for c in map(str, table.columns) if (m := _MANGLED.fullmatch(c)) and m[1] in names
    ]
    if not suspects:
        return
    row = 0 if header == "infer" else header
    kept = {k: v for k, v in options.items() if k in _HEADER_OPTIONS}
    raw = pd.read_csv(path, **kept, header=None, nrows=row + 1, dtype=str)
    seen: dict[str, list[int]] = {}
    for k, name in enumerate(raw.iloc[row].tolist(), start=1):
        if isinstance(name, str):  # an empty name is NaN: pandas' 'Unnamed: k'
            seen.setdefault(name, []).append(k)
    repeated = next((n for n, where in seen.items() if len(where) > 1), None)
    if repeated is None:
        return
    where = seen[repeated]
    raise DataError(
        f"{path}: the header names column {repeated!r} {len(where)} times (columns "
        f"{', '.join(map(str, where))}); pandas would rename the repeat to "
        f"{repeated + '.1'!r}, a signal the file does not name. Give each column its "
        "own name, or remove the repeated column"
    )


def _drop_trailing_empty(table: pd.DataFrame) -> pd.DataFrame:
    """Drop all-empty ``Unnamed: k`` columns that a trailing delimiter leaves."""
    empty = [
        c
        for c in table.columns
        if isinstance(c, str) and c.startswith("Unnamed: ") and table[c].isna().all()
    ]
    return table.drop(columns=empty) if empty else table


def _single_column_blanks(
    path: Path, table: pd.DataFrame, options: dict, compressed: bool
) -> pd.DataFrame:
    """A one-column CSV keeps its empty values.

    pandas skips blank lines, and in a one-column file an empty (or whitespace-only)
    value *is* a blank line: skipping it would shift every later sample. Blank lines
    between values become missing values; blank lines after the last value end the
    file (as an editor's trailing newlines do) and are not rows.
    """
    if table.shape[1] != 1 or "skip_blank_lines" in options:
        return table
    interior_blank = compressed or re.search(  # no second parse for most files
        rb"\n[ \t]*\r?\n", path.read_bytes().rstrip()
    )
    if interior_blank:
        full = _drop_trailing_empty(pd.read_csv(path, skip_blank_lines=False, **options))
        if full.shape[1] == 1:
            col = full.iloc[:, 0]
            if not pd.api.types.is_numeric_dtype(col):  # whitespace-only is empty
                col = col.mask(col.map(lambda v: isinstance(v, str) and not v.strip()))
            if pd.api.types.is_numeric_dtype(table.iloc[:, 0]):
                col = pd.to_numeric(col)
            table = col.to_frame(name=table.columns[0])
    # missing values after the last one present were blank lines at the end
    present = np.flatnonzero(table.iloc[:, 0].notna().to_numpy())
    end = present[-1] + 1 if present.size else 0
    return table if end == len(table) else table.iloc[:end].reset_index(drop=True)


#: A number as a CSV cell writes it (what a header-less file's first line holds).
_NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def _headerless(columns: pd.Index) -> bool:
    """True when every column name pandas took from the first line is a number.

    pandas' own header of a frame without column names (``0,1,...,n-1``, as
    ``DataFrame(array).to_csv()`` writes it) is a header, not data.
    """
    names = [str(c) for c in columns]
    given = [n for n in names if not n.startswith("Unnamed: ")]
    if not given or not all(_NUMBER.fullmatch(n.strip()) for n in given):
        return False
    return names != [str(i) for i in range(len(names))]


def _reread_headerless(
    path: Path, table: pd.DataFrame, options: dict, compression: str
) -> tuple[pd.DataFrame, dict]:
    """Read a CSV whose first line is data again, with generated column names."""
    names, k = [], 0
    for c in table.columns:
        if isinstance(c, str) and c.startswith("Unnamed: ") and table[c].isna().all():
            names.append(c)  # a trailing delimiter's empty column, dropped below
        else:
            names.append(f"column_{k}")
            k += 1
    shown = ", ".join(names[:k]) if k <= 3 else f"column_0 ... column_{k - 1}"
    warnings.warn(
        f"{path}: the first line ({_first_line(path, compression)!r}) holds only numbers, "
        f"so it is read as data, not as column names; the {k} column(s) are named "
        f"{shown}. Add a header line to the file, or pass names=[...] to read_table "
        "(header=0 if that line is a header)",
        DataWarning,
        stacklevel=5,
    )
    options = {**options, "header": None, "names": names}
    return pd.read_csv(path, **options), options


def _mixed_columns(
    path: Path, table: pd.DataFrame, options: dict, where: Callable[[int], str]
) -> None:
    """Refuse a column that holds numbers in some cells and text in others.

    A column of text only is a label / condition column and stays; a column pandas
    could not parse as numbers because a few cells are text would silently turn a
    sensor into a label (or be dropped).
    """
    dtype, converters = options.get("dtype"), options.get("converters") or {}
    for c in table.columns:
        col = table[c]
        if (
            pd.api.types.is_numeric_dtype(col)
            or pd.api.types.is_bool_dtype(col)
            or pd.api.types.is_datetime64_any_dtype(col)
            or c in converters
            or (dtype is not None and (not isinstance(dtype, dict) or c in dtype))
        ):
            continue
        cells = col.astype("string").str.strip()
        filled = cells.notna() & cells.ne("")
        number = filled & pd.to_numeric(cells.where(filled), errors="coerce").notna()
        text = filled & ~number
        n_number, n_text = int(number.sum()), int(text.sum())
        if not (n_number and n_text):
            continue
        odd = text if n_text <= n_number else number
        row = int(np.flatnonzero(odd.to_numpy(dtype=bool))[0])
        value = str(col.iloc[row])
        value = value if len(value) <= 40 else value[:37] + "..."
        if n_text <= n_number:
            raise DataError(
                f"{path}: column {c!r} mixes numbers and text: {n_number} cell(s) are "
                f"numbers, {n_text} not (the first at {where(row)}: {value!r}); a sensor "
                "column holds numbers only. Correct that cell, leave it empty for a "
                f"missing value, or pass na_values=[{value!r}] if it marks one"
            )
        raise DataError(
            f"{path}: column {c!r} mixes text and numbers: {n_text} cell(s) are text, "
            f"{n_number} are numbers (the first at {where(row)}: {value!r}); a label "
            "column holds text only and a sensor column numbers only. Correct the cells, "
            f"or pass dtype={{{c!r}: str}} to read them all as text"
        )


def _header_lines(options: dict) -> int:
    """Lines above the first data row (for line numbers in messages)."""
    header = options.get("header", "infer")
    skip = options.get("skiprows")
    lines = skip if isinstance(skip, int) else 0  # a list or callable: not counted
    if header is None or (header == "infer" and options.get("names") is not None):
        return lines
    return lines + (int(header) + 1 if isinstance(header, int) else 1)


#: Options that say how a CSV line is split (when given, no delimiter is guessed).
_SEP_OPTIONS = {"sep", "delimiter", "delim_whitespace", "dialect"}
#: Bytes read from the top of a text table to tell how its lines are split.
_SNIFF_BYTES = 1 << 16
#: Data lines looked at to tell how a text table's lines are split.
_SNIFF_LINES = 20


def _whitespace_delimited(path: Path, compression: str) -> bool:
    """True when the lines of a text table are split by runs of spaces (or tabs).

    Raw C-MAPSS files and many rig loggers write numbers separated by one or more
    spaces, often with spaces at the start or end of a line: no comma, semicolon or
    tab-pair (an empty tab-separated field) in the first lines, and at least two fields
    on every one of them, as many on each data line (the first line may be a header
    with more names). Reads at most the first 64 KiB.
    """
    try:
        with _open_text_bytes(path, compression) as f:
            head = f.read(_SNIFF_BYTES)
    except (DataError, *_DECOMPRESS_ERRORS):
        return False
    text = head.decode("utf-8", "replace")
    lines = text.splitlines()
    if len(head) == _SNIFF_BYTES and len(lines) > 1:
        lines = lines[:-1]  # the last line may be cut off
    lines = [ln for ln in lines if ln.strip()][: _SNIFF_LINES + 1]
    if (
        not lines
        or any(ch in ln for ln in lines for ch in ",;")
        or any("\t\t" in ln for ln in lines)
    ):
        return False
    counts = [len(ln.split()) for ln in lines]
    if min(counts) < 2:
        return False
    data = counts[1:] or counts
    return len(set(data)) == 1 and counts[0] >= data[0]


def _short_rows(path: Path, table: pd.DataFrame, options: dict) -> pd.DataFrame:
    """Drop the empty columns a whitespace table's header names beyond its rows.

    The header line of a whitespace-delimited file can name more columns than its
    rows hold (the C-MAPSS ``train_FD001.txt`` here names 31, its rows hold 26); the
    last names are then empty columns. They are dropped with a DataWarning that names
    them.
    """
    if options.get("header", "infer") is None or options.get("names") is not None:
        return table
    empty = []
    for c in reversed(table.columns):
        if table[c].isna().all():
            empty.append(c)
        else:
            break
    if not empty or len(empty) == table.shape[1]:
        return table
    empty.reverse()
    shown = ", ".join(map(str, empty)) if len(empty) <= 3 else f"{empty[0]} ... {empty[-1]}"
    warnings.warn(
        f"{path}: the header line names {table.shape[1]} columns but the rows hold "
        f"{table.shape[1] - len(empty)}; the last {len(empty)} ({shown}) are empty and "
        "left out. Correct the header line, or pass names=[...] to read_table",
        DataWarning,
        stacklevel=5,
    )
    return table.drop(columns=empty)


def _read_csv(
    path: Path, compression: str, options: dict
) -> tuple[pd.DataFrame, Callable[[int], str]]:
    limit = max_bytes("member")
    size = _text_bytes(path, compression, limit)
    if size > limit:
        verb = "holds" if not compression else "decompresses to at least"
        raise _too_big(f"{path}: the CSV text", size, limit, verb)
    if not compression:
        with path.open("rb") as f:
            head = f.read(1 << 16)
        if b"\x00" in head:
            raise DataError(
                f"{path} is not a text CSV file (it holds NUL bytes); check the file or "
                "its extension"
            )
    if (path.suffixes[-2] if compression else path.suffix).lower() == ".tsv":
        options.setdefault("sep", "\t")
    elif not _SEP_OPTIONS & options.keys() and _whitespace_delimited(path, compression):
        options["sep"] = r"\s+"
    table = pd.read_csv(path, **options)
    if options.get("sep") == r"\s+":
        table = _short_rows(path, table, options)
    if "header" not in options and "names" not in options and _headerless(table.columns):
        table, options = _reread_headerless(path, table, options, compression)
    _duplicated_header(path, table, options)
    table = _drop_trailing_empty(table)
    table = _single_column_blanks(path, table, options, bool(compression))
    header_lines = _header_lines(options)
    blanks = table.shape[1] == 1 and "skip_blank_lines" not in options

    def where(row: int) -> str:
        return f"line {_csv_line(path, compression, row, header_lines, blanks)}"

    if len(table):
        _mixed_columns(path, table, options, where)
    return table, where


def _string_bytes(file: Any, names: list[str]) -> dict[str, int]:
    """Bytes the text columns ``names`` of a Parquet file take once decoded.

    Read dictionary-encoded (the dictionary and one index per row), so a file that
    repeats one long string on every row cannot make this allocate its decoded size.
    """
    import pyarrow.compute as pc
    import pyarrow.parquet as pq

    table = pq.read_table(file, columns=names, read_dictionary=names)
    out = {}
    for name in names:
        total = 0
        for chunk in table.column(name).chunks:
            lengths = pc.fill_null(pc.binary_length(chunk.dictionary), 0)
            lengths = lengths.to_numpy(zero_copy_only=False).astype(np.int64)
            index = pc.fill_null(chunk.indices, 0).to_numpy(zero_copy_only=False)
            if lengths.size:
                total += int(lengths[index].sum())
        out[name] = total
    return out


def _check_parquet_table(path: Path, columns: Any) -> None:
    """Refuse a Parquet table whose declared (or decoded text) size is over the ceiling."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    limit = max_bytes("member")
    with pq.ParquetFile(path) as reader:
        wanted = None if columns is None else [str(c) for c in columns]
        sizes = check_declared_sizes(reader.metadata, str(path), columns=wanted)
        text = [
            f.name
            for f in reader.schema_arrow
            if (wanted is None or f.name in wanted)
            and (pa.types.is_string(f.type) or pa.types.is_large_string(f.type))
        ]
    if text:
        for name, n in _string_bytes(path, text).items():
            sizes[name] = n + sizes.get(name, 0)
            if n > limit:
                raise _too_big(f"{path}: text column {name!r}", n, limit, "decodes to")
    total = sum(sizes.values())
    if total > limit:
        raise _too_big(f"{path}: its {len(sizes)} column(s) together", total, limit)


def _read_table(
    path: str | os.PathLike, options: dict
) -> tuple[pd.DataFrame, Callable[[int], str]]:
    """``(table, where)``: ``where(row)`` says where data row ``row`` is in the file."""
    import pyarrow as pa

    path = _existing_file(path, "a CSV or Parquet table")
    kind, compression = _table_kind(path)
    options = dict(options)
    try:
        if kind == "csv":
            table, where = _read_csv(path, compression, options)
        else:
            _check_parquet_table(path, options.get("columns"))
            table = pd.read_parquet(path, **options)

            def where(row: int) -> str:
                return f"row {row + 1}"

    except pd.errors.EmptyDataError:
        raise DataError(
            f"{path} is empty; expected a table with a header and rows"
        ) from None
    except UnicodeDecodeError as exc:
        raise DataError(
            f"cannot read {path} as CSV: it is not UTF-8 text ({_one_line(exc)}); pass "
            "the encoding, e.g. read_table(path, encoding='latin-1')"
        ) from None
    except DataError:
        raise
    except (ValueError, OSError, pa.ArrowException, EOFError, *_DECOMPRESS_ERRORS) as exc:
        raise DataError(
            f"cannot read {path} as {kind.upper()} ({_why(exc)}); the file "
            "is damaged or not what its extension says"
        ) from None
    if len(table) == 0:
        raise DataError(
            f"{path} holds no rows (columns: {list(table.columns)}); expected a table "
            "with data"
        )
    return table, where


def read_table(path: str | os.PathLike, **options: Any) -> pd.DataFrame:
    r"""Read a CSV or Parquet table into a DataFrame.

    CSV (``.csv``, ``.tsv`` tab-separated, ``.txt``; optionally ``.gz``/``.bz2``/...
    compressed) goes through :func:`pandas.read_csv`, Parquet (``.parquet``, ``.pq``)
    through :func:`pandas.read_parquet`. Columns named ``Unnamed: k`` that hold nothing
    (left by a delimiter at the end of every line) are dropped. In a one-column CSV an
    empty line between values is a missing value (NaN), not a skipped line, so the
    samples after it keep their positions; empty lines (and missing values) after the
    last value are not rows.

    A text table whose lines are split by runs of spaces (or tabs) instead of commas,
    as raw C-MAPSS files (``train_FD001.txt``) and many rig loggers write them, is read
    with ``sep=r"\s+"``: told from the first lines (no comma or semicolon, the same
    number of fields, at least two, on every data line). When its header line names
    more columns than the rows hold, the empty columns at the end are dropped with a
    :class:`pdmkit.errors.DataWarning` naming them. Pass ``sep=`` to decide yourself.

    The file is untrusted input:

    - A CSV without a header line (every name pandas would take from the first line is
      a number, as in PRONOSTIA's ``acc_*.csv`` snapshots) is read with that line as
      data and the columns named ``column_0``, ``column_1``, ...; a
      :class:`pdmkit.errors.DataWarning` names the file. A first line ``0,1,...,n-1``
      (pandas' own header of unnamed columns) stays a header. Pass ``names=`` or
      ``header=`` to decide yourself.
    - A CSV column in which some non-empty cells are numbers and others are not is a
      :class:`pdmkit.errors.DataError` naming the column and the first odd cell with its
      line number (a column of text only is a label column and stays). Pass
      ``na_values=`` for a marker of missing values, or ``dtype=`` to read a column as
      text.
    - A CSV header that names two columns alike is a :class:`pdmkit.errors.DataError`
      naming the column (pandas would read the repeat as ``name.1``, a column the file
      does not name).
    - Sizes are checked before reading, against ``max_bytes("member")`` (1 GiB by
      default, ``$PDMKIT_MAX_MEMBER_BYTES``): the text of a CSV after decompression; the
      decompressed size each column of a Parquet file declares (and the decoded size of
      its text columns), and their sum.

    Parameters
    ----------
    path : str or path-like
        The file.
    **options
        Passed on to the pandas reader (e.g. ``sep=";"``, ``columns=[...]``).

    Returns
    -------
    pandas.DataFrame

    Raises
    ------
    pdmkit.errors.DataNotFoundError
        The file does not exist.
    pdmkit.errors.DataError
        Unknown extension, a binary or damaged file, a table without rows, a column
        mixing numbers and text, a column name repeated in the header, or a file larger
        than the ceiling (the message names the file, and the column where there is
        one).

    Warns
    -----
    pdmkit.errors.DataWarning
        A CSV without a header line was given generated column names; a whitespace
        table's header named columns its rows do not hold.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "run.csv"
    >>> _ = path.write_text("time,flow,\n0.0,1.5,\n0.1,1.7,\n")
    >>> read_table(path)
       time  flow
    0   0.0   1.5
    1   0.1   1.7
    >>> _ = path.write_text("time,flow\n0.0,1.5\n0.1,err\n0.2,1.6\n")
    >>> read_table(path)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: ...run.csv: column 'flow' mixes numbers and text: 2 cell(s) are numbers, 1 not (the first at line 3: 'err'); ...

    Numbers separated by spaces, without a header (a raw C-MAPSS file):

    >>> import warnings
    >>> raw = path.with_name("train.txt")
    >>> _ = raw.write_text("1 1 -0.0007  518.67 \n1 2  0.0019  518.67 \n")
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     table = read_table(raw)
    >>> table.shape, list(table.columns[:2]), caught[0].category.__name__
    ((2, 4), ['column_0', 'column_1'], 'DataWarning')
    """  # noqa: E501
    return _read_table(path, options)[0]


# --------------------------------------------------------------------------- MATLAB
def _is_hdf5_mat(path: Path) -> bool:
    with path.open("rb") as f:
        head = f.read(520)
    return head.startswith(b"MATLAB 7.3") or head[512:520] == b"\x89HDF\r\n\x1a\n"


_MI_MATRIX, _MI_COMPRESSED = 14, 15
#: Bytes per element of the numeric MATLAB classes (mxCHAR: numpy's 4-byte unicode).
_MAT_WIDTH = {4: 4, 6: 8, 7: 4, 8: 1, 9: 1, 10: 2, 11: 2, 12: 4, 13: 4, 14: 8, 15: 8}
#: Bytes per element of the classes scipy's whosmat names (v4 files).
_MAT4_WIDTH = {
    "double": 8,
    "single": 4,
    "int32": 4,
    "int16": 2,
    "uint16": 2,
    "uint8": 1,
    "char": 4,
}


def _mat5_header(
    content: bytes, endian: str
) -> tuple[str, tuple[int, ...], int, int] | None:
    """``(name, dims, declared bytes, array flags)`` of a miMATRIX element, or None."""
    pos = 0

    def element() -> bytes:
        nonlocal pos
        mdtype, n = struct.unpack_from(endian + "II", content, pos)
        if mdtype >> 16:  # small element: size in the upper half, data in the tag
            n = mdtype >> 16
            data, pos = content[pos + 4 : pos + 4 + n], pos + 8
        else:
            data, pos = content[pos + 8 : pos + 8 + n], pos + 8 + n + (-n % 8)
        return data

    try:
        flags = struct.unpack_from(endian + "I", element())[0]
        raw = element()
        dims = struct.unpack(endian + f"{len(raw) // 4}i", raw[: len(raw) // 4 * 4])
        name = element().decode("latin-1")
    except struct.error:
        return None
    if any(d < 0 for d in dims):
        return None
    width = _MAT_WIDTH.get(flags & 0xFF, 0) * (2 if flags >> 11 & 1 else 1)
    return name, dims, math.prod(dims) * width, flags


#: The array flag of a MATLAB logical (true/false) array, stored as uint8.
_MAT_LOGICAL = 1 << 9


def _check_mat5_header(
    path: Path, content: bytes, endian: str, k: int, logical: set[str]
) -> str:
    """The name (for messages) of variable ``k``; refuses a declared size over the limit.

    Adds the name to ``logical`` when the variable is a logical array (which scipy
    reads as uint8).
    """
    header = _mat5_header(content, endian)
    if header is None:
        return f"#{k + 1}"
    name, dims, declared, flags = header
    limit = max_bytes("member")
    if declared > limit:
        raise _too_big(f"{path}: variable {name!r} (shape {dims})", declared, limit)
    if flags & _MAT_LOGICAL:
        logical.add(name)
    return repr(name)


def _inflated(f: IO[bytes], n: int) -> Iterator[bytes]:
    """The zlib stream in the next ``n`` bytes of ``f``, decompressed a MiB at a time."""
    inflate = zlib.decompressobj()
    left = n
    while left > 0 and not inflate.eof:
        # small reads first: the header is decoded before damage further on stops it
        data = f.read(min(left, 256 if n - left < 4096 else 1 << 16))
        if not data:
            return
        left -= len(data)
        while True:
            out = inflate.decompress(data, 1 << 20)
            if out:
                yield out
            data = inflate.unconsumed_tail
            if not data and len(out) < 1 << 20:
                break


def _check_mat_sizes(path: Path, limit: int) -> set[str]:
    """Refuse a .mat file whose variables declare or decompress to more than ``limit``.

    Walks the top-level elements of a v5 file without scipy: a compressed variable is
    inflated and counted (never kept), so one that decompresses to gigabytes costs
    only time, bounded by the ceiling. v4 files (never compressed) are checked from the
    shapes scipy's ``whosmat`` lists. Returns the names of the logical variables.
    """
    logical: set[str] = set()
    size = path.stat().st_size
    with path.open("rb") as f:
        head = f.read(128)
        endian = {b"IM": "<", b"MI": ">"}.get(head[126:128])
        if len(head) < 128 or endian is None:
            from scipy.io import whosmat

            try:  # a v4 file, or not a .mat: loadmat says what is wrong
                listed = whosmat(path)
            except Exception:  # loadmat says what is wrong with it
                return logical
            for name, shape, kind in listed:
                declared = math.prod(shape) * _MAT4_WIDTH.get(kind, 8)
                if declared > limit:
                    raise _too_big(
                        f"{path}: variable {name!r} ({kind} of shape {shape})",
                        declared,
                        limit,
                    )
            return logical
        pos, total, k = 128, 0, 0
        while pos + 8 <= size:
            f.seek(pos)
            mdtype, n = struct.unpack(endian + "II", f.read(8))
            if mdtype >> 16 or mdtype not in (_MI_MATRIX, _MI_COMPRESSED):
                return logical  # damaged: loadmat says so
            budget = limit - total
            if mdtype == _MI_COMPRESSED:
                verb, used, content, header = "decompresses to at least", 0, b"", None
                try:
                    for out in _inflated(f, n):  # counted, never kept
                        used += len(out)
                        if header is None:
                            content += out[: 4096 - len(content)]
                            if len(content) >= 4096:  # the miMATRIX tag, then its header
                                header = _check_mat5_header(
                                    path, content[8:], endian, k, logical
                                )
                        if used > budget:
                            break
                except zlib.error as exc:
                    partial = _mat5_header(content[8:], endian)
                    name = header or (repr(partial[0]) if partial else f"#{k + 1}")
                    raise DataError(
                        f"{path}: variable {name} is damaged: its compressed data does "
                        f"not decompress (zlib.error: {_one_line(exc)}); re-save or "
                        "re-copy the file"
                    ) from None
                if header is None:
                    header = _check_mat5_header(path, content[8:], endian, k, logical)
            else:
                content, used, verb = f.read(min(n, 4096)), n, "holds"
                header = _check_mat5_header(path, content, endian, k, logical)
            if used > budget:
                name = f"variable {header}"
                if used > limit:
                    raise _too_big(f"{path}: {name}", used, limit, verb)
                raise _too_big(f"{path}: its variables together", total + used, limit, verb)
            total += used
            pos += 8 + n
            k += 1
    return logical


def read_mat(path: str | os.PathLike) -> dict[str, Any]:
    """Read the variables of a MATLAB ``.mat`` file (v4 to v7).

    Wraps :func:`scipy.io.loadmat` with ``simplify_cells=True``: singleton dimensions
    are squeezed (a ``(n, 1)`` column becomes a 1-D array, a ``1x1`` value a scalar),
    structs become dicts; the ``__header__``, ``__version__`` and ``__globals__`` entries
    are left out. A logical (true/false) variable is a numpy ``bool`` array (scipy
    alone reads it as ``uint8``).

    Sizes are checked before scipy reads anything, against ``max_bytes("member")``
    (1 GiB by default, ``$PDMKIT_MAX_MEMBER_BYTES``): the shape and class each variable
    declares, the size each compressed variable decompresses to (counted, not kept),
    and the sum over the variables.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    dict
        Variable name -> numpy array (or scalar, dict, ...).

    Raises
    ------
    pdmkit.errors.DataNotFoundError
        The file does not exist.
    pdmkit.errors.DataError
        A v7.3 (HDF5) file, which scipy cannot read (the message says so), a damaged
        / non-MATLAB file, one without variables, or a variable (or the variables
        together) larger than the ceiling.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from scipy.io import savemat
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "rig.mat"
    >>> savemat(path, {"u": np.arange(3.0).reshape(3, 1), "Ts": 4.0})
    >>> data = read_mat(path)
    >>> sorted(data), data["u"].shape, float(data["Ts"])
    (['Ts', 'u'], (3,), 4.0)
    """
    from scipy.io import loadmat
    from scipy.io.matlab import MatReadError

    path = _existing_file(path, "a MATLAB .mat file")
    if _is_hdf5_mat(path):
        raise DataError(
            f"{path} is a MATLAB v7.3 (HDF5) file, which scipy.io.loadmat cannot read; "
            "re-save it in MATLAB with save(..., '-v7'), or read it with h5py"
        )
    logical = _check_mat_sizes(path, max_bytes("member"))
    try:
        raw = loadmat(path, simplify_cells=True)
    except NotImplementedError:
        raise DataError(
            f"{path} is a MATLAB v7.3 (HDF5) file, which scipy.io.loadmat cannot read; "
            "re-save it in MATLAB with save(..., '-v7'), or read it with h5py"
        ) from None
    except (
        MatReadError,
        ValueError,
        TypeError,
        OSError,
        EOFError,
        zlib.error,
        IndexError,  # scipy indexes short headers unchecked
        KeyError,
        struct.error,
        OverflowError,
        MemoryError,  # a damaged header can claim a huge array
    ) as exc:
        raise DataError(
            f"cannot read {path} as a MATLAB file ({_why(exc)}); the file "
            "is damaged or not a .mat file"
        ) from None
    data = {k: v for k, v in raw.items() if not k.startswith("__")}
    if not data:
        raise DataError(f"{path} holds no variables")
    for name in logical & data.keys():
        value = data[name]
        if isinstance(value, np.ndarray | np.generic) and value.dtype.kind in "iu":
            data[name] = np.asarray(value).astype(bool)
        elif isinstance(value, int):  # a 1x1 logical, squeezed to a scalar
            data[name] = bool(value)
    return data


# --------------------------------------------------------------------------- NumPy
_ZIP_ERRORS = (*_DECOMPRESS_ERRORS, NotImplementedError, RuntimeError)  # method, password


@contextlib.contextmanager
def _npz_entry(path: Path, key: str, failure: str) -> Iterator[None]:
    """Turn the errors of reading one ``.npz`` entry into a one-line DataError."""
    try:
        yield
    except zlib.error as exc:
        raise DataError(
            f"{path}: array {key!r} is damaged: its compressed data does not decompress "
            f"(zlib.error: {_one_line(exc)}); re-save or re-copy the archive"
        ) from None
    except _ZIP_ERRORS as exc:
        raise DataError(
            f"{path}: array {key!r} {failure} ({_why(exc)}); the archive is damaged or "
            "was not written by numpy.savez: re-save or re-copy it"
        ) from None


def _npy_header(
    archive: zipfile.ZipFile, info: zipfile.ZipInfo, path: Path, key: str
) -> tuple[tuple[int, ...], np.dtype, int]:
    """``(shape, dtype, header length)`` an ``.npy`` entry declares; its data unread."""
    with _npz_entry(path, key, "has no valid .npy header"), archive.open(info) as f:
        return npy_declared(f)


def _npz_array(archive: zipfile.ZipFile, info: zipfile.ZipInfo, path: Path, key: str):
    with _npz_entry(path, key, "cannot be read"), archive.open(info) as f:
        return np.lib.format.read_array(f, allow_pickle=False)


def read_npz(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Read all arrays of a NumPy ``.npz`` archive, refusing pickled objects.

    Before any array is read, the ``.npy`` header of every entry is read (a few hundred
    bytes) and the size it declares (shape x item size) is checked: against
    ``max_bytes("member")`` (1 GiB by default, ``$PDMKIT_MAX_MEMBER_BYTES``), for each
    array and for their sum, and against the size of the zip entry. An archive of a few
    MB whose entry inflates to gigabytes is refused without allocating them.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    dict of str to numpy.ndarray
        Every array, loaded into memory (the archive is closed again).

    Raises
    ------
    pdmkit.errors.DataNotFoundError
        The file does not exist.
    pdmkit.errors.DataError
        A damaged or non-npz file (a corrupt compressed entry names the array), an
        archive without arrays or with an entry that is no ``.npy`` array, an array of
        Python objects (``allow_pickle=False``: loading pickles can run arbitrary code),
        or an array (or the arrays together) larger than the ceiling.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "rec.npz"
    >>> np.savez(path, DE=np.zeros((4, 1)), FE=np.ones((4, 1)))
    >>> {k: v.shape for k, v in read_npz(path).items()}
    {'DE': (4, 1), 'FE': (4, 1)}
    """
    path = _existing_file(path, "a NumPy .npz archive")
    limit = max_bytes("member")
    out: dict[str, np.ndarray] = {}
    with path.open("rb") as handle:
        if handle.read(6) == b"\x93NUMPY":
            raise DataError(
                f"{path} is a single .npy array, not an .npz archive; read it with "
                "numpy.load"
            )
        handle.seek(0)
        try:
            archive = zipfile.ZipFile(handle)
        except _ZIP_ERRORS as exc:
            raise DataError(
                f"cannot read {path} as a NumPy .npz archive ({type(exc).__name__}: "
                f"{_one_line(exc)}); the file is damaged or not an .npz"
            ) from None
        with archive:
            entries, total = [], 0
            for info in archive.infolist():
                if info.is_dir():
                    continue
                if not info.filename.endswith(".npy"):
                    raise DataError(
                        f"{path}: entry {info.filename!r} is not a .npy array; an .npz "
                        "archive (numpy.savez) holds .npy entries only. Re-save it with "
                        "numpy.savez"
                    )
                key = info.filename[: -len(".npy")]
                shape, dtype, header = _npy_header(archive, info, path, key)
                if dtype.hasobject:
                    raise DataError(
                        f"array {key!r} in {path} holds Python objects (pickled data); "
                        "pdmkit reads numeric arrays only (allow_pickle=False). Re-save "
                        "it with a numeric dtype"
                    )
                declared = math.prod(shape) * dtype.itemsize
                what = f"{path}: array {key!r} ({dtype} of shape {shape})"
                if declared > limit:
                    raise _too_big(what, declared, limit)
                if info.file_size < header + declared:
                    raise DataError(
                        f"{what} declares {_size(declared)} of data, but its zip entry "
                        f"holds {_size(max(info.file_size - header, 0))}; the archive is "
                        "damaged (truncated?). Re-save or re-copy it"
                    )
                total += declared
                entries.append((key, info))
            if total > limit:
                raise _too_big(f"{path}: its {len(entries)} arrays together", total, limit)
            for key, info in entries:
                out[key] = _npz_array(archive, info, path, key)
    if not out:
        raise DataError(f"{path} holds no arrays")
    return out


# --------------------------------------------------------------------------- members
def _member_like(path: Path) -> bool:
    """True when ``path`` is named like a member file (``x.csv``, ``x.mat``, ...)."""
    suffixes = [s.lower() for s in path.suffixes]
    if suffixes and suffixes[-1] in _COMPRESSED:
        suffixes.pop()
    return bool(suffixes) and suffixes[-1] in (*_CSV, *_PARQUET, ".mat", ".npz")


#: Names of a sampling-rate scalar in a .mat / .npz member file.
_FS_NAMES = ("fs", "Fs", "FS", "sampling_rate", "sample_rate")
#: Names of a time column in a CSV / Parquet member file.
_TIME_NAMES = ("time", "t", "Time", "TIME")
_MEMBER_ERRORS = ("member", "signal", "source", "error")
#: How far a time step may differ from the median step: 1 % of it, or one unit of the
#: last decimal the time stamps are written with when that is more and at most half a
#: step (stamps rounded to microseconds at 25.6 kHz step 39 or 40 us).
_TIME_JITTER = 0.01


def _stamp_resolution(t: np.ndarray) -> float:
    """The decimal step time stamps were written with (``1e-6`` for ``0.000039``), or 0."""
    for d in range(10):
        scaled = t * 10.0**d
        if np.allclose(scaled, np.round(scaled), rtol=1e-12, atol=1e-6):
            return 10.0**-d
    return 0.0


def _time_rate(path: Path, column: pd.Series, where: Callable[[int], str]) -> float | None:
    """The sampling rate a time column states, after checking it increases uniformly.

    Numbers are seconds; text is parsed as timestamps. A missing, repeated, decreasing
    or uneven time stamp is a DataError naming the file and the first bad row.
    """
    name = column.name
    if pd.api.types.is_datetime64_any_dtype(column):
        stamps = column
    elif pd.api.types.is_numeric_dtype(column) and not pd.api.types.is_bool_dtype(column):
        stamps = None
    else:
        stamps = parse_timestamps(column)
        if stamps.isna().all():
            raise DataError(
                f"{path}: time column {name!r} holds {str(column.iloc[0])!r} at "
                f"{where(0)}; expected seconds (numbers) or timestamps. Rename the "
                "column if it is no time, or drop it and pass fs= (--fs)"
            )
    if stamps is None:
        t = column.to_numpy(dtype=float)
    else:
        t = (stamps - stamps.dropna().iloc[0]).dt.total_seconds().to_numpy(dtype=float)

    def shown(i: int) -> str:
        return f"{t[i]:g} s" if stamps is None else repr(str(column.iloc[i]))

    missing = np.flatnonzero(~np.isfinite(t))
    if missing.size:
        k = int(missing[0])
        raise DataError(
            f"{path}: time column {name!r} has no valid time at {where(k)} (found "
            f"{str(column.iloc[k])!r}); every row needs its time stamp. Fill it in, or "
            "drop the time column and pass fs= (--fs)"
        )
    if len(t) < 2:
        return None
    dt = np.diff(t)
    back = np.flatnonzero(dt <= 0)
    if back.size:
        k = int(back[0]) + 1
        verb = "repeats" if dt[k - 1] == 0 else "goes back"
        raise DataError(
            f"{path}: time {verb} at {where(k)}: {shown(k)} after {shown(k - 1)} on the "
            "row before; time must increase from row to row. Remove the repeated rows or "
            "sort them, or drop the time column and pass fs= (--fs)"
        )
    step = float(np.median(dt))
    tol = _TIME_JITTER * step
    quantum = _stamp_resolution(t)
    if quantum <= step / 2:  # stamps rounded to a finer decimal than the step
        tol = max(tol, 1.001 * quantum)
    uneven = np.flatnonzero(np.abs(dt - step) > tol)
    if uneven.size:
        k = int(uneven[0]) + 1
        raise DataError(
            f"{path}: time is not uniform at {where(k)}: {shown(k)} is {dt[k - 1]:g} s "
            f"after the row before, the median step is {step:g} s (steps may differ by "
            f"{100 * tol / step:.2g} % of it); a member is one uniformly sampled "
            "recording. Resample it to a uniform grid or split it at the gap, or drop the "
            "time column and pass fs= (--fs)"
        )
    return (len(t) - 1) / float(t[-1] - t[0])


#: Most signals one member file may hold (``$PDMKIT_MAX_SIGNALS``): every signal costs
#: a full set of indicators, so a 35 KB CSV of 2000 three-sample columns cost a minute
#: and a gigabyte before this bound.
MAX_SIGNALS = 1024


def _member_arrays(
    path: Path, notes: list, time: str | None = None
) -> tuple[dict, float | None, dict]:
    """(signals, sampling rate or None, condition values) of one member file.

    What was read other than as written (a boolean signal, a variable skipped) is
    appended to ``notes`` as ``("variable" or "column", its name, what was done)``.
    ``time`` names the time column (or variable); default one of :data:`_TIME_NAMES`.
    """
    signals, fs, conditions = _member_contents(path, notes, time)
    limit = int(os.environ.get("PDMKIT_MAX_SIGNALS", MAX_SIGNALS))
    if len(signals) > limit:
        raise DataError(
            f"{path}: {len(signals)} signal columns, more than the {limit} a member may "
            "hold; is it a table of members or features rather than one recording? "
            "(raise $PDMKIT_MAX_SIGNALS if it really is one)"
        )
    return signals, fs, conditions


#: What a member's variable that is not read is, and why (for the DataWarning).
_NOT_READ = (
    "not a signal (a numeric vector) or a condition (a scalar); skipped. Save what it "
    "holds as numeric variables to read it"
)
#: What a true/false signal became.
_READ_AS_01 = (
    "holds true/false values; read as a signal of 0.0 and 1.0. Save it as numbers if "
    "that is what it means (or as one scalar if it is a condition)"
)


def _unread_variable(value: Any, arr: np.ndarray | None) -> str | None:
    """Why a .mat / .npz variable is neither a signal nor a condition (None: it is one)."""
    if isinstance(value, dict):
        return f"is a MATLAB struct (fields {sorted(value)[:5]}), {_NOT_READ}"
    if arr is None:
        return f"is a {type(value).__name__} object, {_NOT_READ}"
    kind = arr.dtype.kind
    if kind == "O":
        return f"is a MATLAB cell or struct array (shape {arr.shape}), {_NOT_READ}"
    if kind == "V":
        return f"is a structured (record) array {arr.dtype}, {_NOT_READ}"
    if arr.size == 0:
        return f"is empty ({arr.dtype} of shape {arr.shape}), {_NOT_READ}"
    if arr.size == 1 and kind in "USiufb":
        return None  # a condition
    if kind in "iufb" and arr.ndim >= 1:
        return None  # a signal
    return f"holds {arr.dtype} values of shape {arr.shape}, {_NOT_READ}"


def _no_time_column(path: Path, time: str, names: list, what: str) -> DataError:
    return DataError(
        f"{path}: no time {what} {time!r} (time= / --time); it has {names[:12]}"
        f"{did_you_mean(time, names)}. Name its time {what}, or leave time out and "
        "pass fs= (--fs)"
    )


def _member_contents(
    path: Path, notes: list, time: str | None = None
) -> tuple[dict, float | None, dict]:
    suffix = path.suffix.lower()
    if suffix in (".mat", ".npz"):
        data = read_mat(path) if suffix == ".mat" else read_npz(path)
        signals, fs, conditions = {}, None, {}
        limit = max_bytes("member")
        if time is not None:
            if time not in data:
                raise _no_time_column(path, time, [str(k) for k in data], "variable")
            stamps = np.asarray(data.pop(time))
            if stamps.dtype.kind not in "iuf" or stamps.size < 2:
                raise DataError(
                    f"{path}: time variable {time!r} holds {stamps.dtype} of shape "
                    f"{stamps.shape}; expected a vector of times in seconds"
                )
            fs = _time_rate(
                path, pd.Series(stamps.reshape(-1), name=time), lambda k: f"sample {k}"
            )
        for key, value in data.items():
            numeric = isinstance(value, np.ndarray | np.generic | bool | int | float | str)
            arr = np.asarray(value) if numeric or isinstance(value, complex) else None
            if arr is not None and arr.dtype.kind == "c":
                raise DataError(
                    f"{path}: variable {key!r} holds complex values ({arr.dtype} of shape "
                    f"{arr.shape}); pdmkit reads real signals. Store the real and "
                    f"imaginary parts as two signals (e.g. {key}_re and {key}_im)"
                )
            if key in _FS_NAMES:
                rate = (
                    float(arr.reshape(-1)[0])
                    if arr is not None and arr.size == 1 and arr.dtype.kind in "iuf"
                    else None
                )
                if rate is None or not math.isfinite(rate) or rate <= 0:
                    found = (
                        f"{arr.dtype} of shape {arr.shape}"
                        if arr is not None
                        else type(value).__name__
                    )
                    raise DataError(
                        f"{path}: variable {key!r} should be the sampling rate (one "
                        f"positive number, Hz); it holds {found}"
                        + (f" = {rate:g}" if rate is not None else "")
                    )
                fs = rate
                continue
            why = _unread_variable(value, arr)
            if why is not None:
                notes.append(("variable", key, why))
            elif arr.size == 1:
                conditions[key] = arr.reshape(-1)[0].item()
            else:
                if arr.ndim > 1 and sorted(arr.shape)[-2] != 1:
                    raise DataError(
                        f"{path}: variable {key!r} has shape {arr.shape}; a member "
                        "file holds 1-D signals (or n x 1 columns)"
                    )
                if arr.size * 8 > limit:  # as float64, before the copy is made
                    raise _too_big(
                        f"{path}: signal {key!r} ({arr.size} samples as float64)",
                        arr.size * 8,
                        limit,
                        "takes",
                    )
                if arr.dtype.kind == "b":
                    notes.append(("variable", key, _READ_AS_01))
                signals[key] = arr.reshape(-1).astype(np.float64)
        return signals, fs, conditions
    table, where = _read_table(path, {})
    fs = None
    if time is not None and time not in table.columns:
        raise _no_time_column(path, time, [str(c) for c in table.columns], "column")
    if time is None:
        time = next((c for c in _TIME_NAMES if c in table.columns), None)
    if time is not None:
        fs = _time_rate(path, table.pop(time), where)
    signals, conditions = {}, {}
    for c in table.columns:
        column = table[c]
        if pd.api.types.is_numeric_dtype(column) and not pd.api.types.is_bool_dtype(column):
            signals[str(c)] = column.to_numpy(dtype=np.float64)
        elif column.nunique(dropna=False) == 1:
            conditions[str(c)] = column.iloc[0]
        elif pd.api.types.is_bool_dtype(column):
            notes.append(("column", str(c), _READ_AS_01))
            signals[str(c)] = column.to_numpy(dtype=np.float64)
        else:
            raise DataError(
                f"{path}: column {c!r} holds text that changes from row to row; a member "
                "file holds numeric signal columns, a time column and constant labels"
            )
    return signals, fs, conditions


def _without_clashes(kept: list, fail) -> list:
    """Skip the members where a name is a signal while most members hold it as a label.

    Or the reverse (a label where most members hold a signal): one odd file must not stop
    the others being read.
    """
    from collections import Counter

    as_signal = Counter(s for _, _, a, _ in kept for s in a)
    as_label = Counter(c for _, _, _, cd in kept for c in cd)
    clash = {n for n in as_label if n in as_signal}
    if not clash:
        return kept
    out = []
    for member, path, arrays, conds in kept:
        odd = next(
            (
                n
                for n in sorted(clash)
                if (n in conds and as_signal[n] >= as_label[n])
                or (n in arrays and as_label[n] > as_signal[n])
            ),
            None,
        )
        if odd is None:
            out.append((member, path, arrays, conds))
            continue
        here, there = ("a label", "a signal") if odd in conds else ("a signal", "a label")
        others = as_signal[odd] if odd in conds else as_label[odd]
        fail(
            member,
            odd,
            path,
            f"{path.name}: {odd!r} is {here} here but {there} in {others} other "
            "member file(s)",
        )
    return out


class _NameConditions:
    """Condition values a member gets from its file name.

    A regular expression's groups (``label_from_name``) and a labels table's row
    (``labels``).
    """

    _KEYS = ("file", "member", "name", "filename", "path")

    def __init__(self, label_from_name: Any, labels: Any) -> None:
        self.pattern = self._pattern(label_from_name)
        self.table, self.source = self._table(labels)
        self.used: set = set()

    @staticmethod
    def _pattern(regex: Any) -> re.Pattern | None:
        if regex is None:
            return None
        try:
            pattern = re.compile(regex)
        except (re.error, TypeError) as exc:
            raise DataError(
                f"label_from_name (--label-from-name) {regex!r} is not a regular "
                f"expression ({_why(exc)})"
            ) from None
        if not pattern.groupindex and pattern.groups != 1:
            raise DataError(
                f"label_from_name (--label-from-name) {pattern.pattern!r} has "
                f"{pattern.groups} groups; it needs one group (...) for the label, or "
                r"named groups (?P<label>...) (?P<load>\d+) for condition columns, "
                r"e.g. '^\d+_([A-Za-z]+)'"
            )
        return pattern

    def _table(self, labels: Any) -> tuple[dict | None, str]:
        if labels is None:
            return None, ""
        if isinstance(labels, pd.DataFrame):
            table, source = labels, "the labels table"
        else:
            table, source = read_table(labels), f"labels table {labels}"
        lower = {str(c).lower(): c for c in table.columns}
        key = next((lower[k] for k in self._KEYS if k in lower), None)
        if key is None:
            raise DataError(
                f"{source}: no column names the member files; expected one of "
                f"{list(self._KEYS)} (the file name, e.g. a.csv, or its member id a), "
                f"found {[str(c) for c in table.columns]}"
            )
        if table.shape[1] < 2:
            raise DataError(
                f"{source}: only the column {key!r}; add the label / condition columns "
                "beside it (e.g. file,fault)"
            )
        # keyed by member id: "a.csv" and "a" name the same member
        names = table[key].astype(str).map(lambda v: Path(v.strip()).name.split(".")[0])
        dup = names[names.duplicated()].unique().tolist()
        if dup:
            raise DataError(
                f"{source}: member file(s) {dup[:5]} are listed more than once; give "
                "each member one row"
            )
        rows = table.drop(columns=[key]).to_dict(orient="records")
        out = {}
        for name, row in zip(names, rows, strict=True):
            out[name] = {str(k): v for k, v in row.items()}
        return out, source

    def conditions(self, path: Path) -> dict:
        """The conditions ``path``'s name gives; DataError when it gives none."""
        extra: dict = {}
        if self.pattern is not None:
            match = self.pattern.search(path.name)
            if match is None:
                raise DataError(
                    f"{path.name}: its name does not match label_from_name "
                    f"(--label-from-name) {self.pattern.pattern!r}, so it has no label; "
                    "rename the file or widen the expression"
                )
            found = match.groupdict() if self.pattern.groupindex else {"label": match[1]}
            # a group that took no part in the match gives no value
            extra.update({k: v for k, v in found.items() if v is not None})
        if self.table is not None:
            key = stem = path.name.split(".")[0]
            if key not in self.table:
                raise DataError(
                    f"{path.name} is not listed in {self.source}; add a row for it "
                    f"(by file name {path.name!r} or member id {stem!r})"
                    f"{did_you_mean(path.name, self.table)}"
                )
            self.used.add(key)
            for name, value in self.table[key].items():
                if name in extra and str(extra[name]) != str(value):
                    raise DataError(
                        f"{path.name}: condition {name!r} is {extra[name]!r} by its name "
                        f"(label_from_name) but {value!r} in {self.source}; keep one"
                    )
                extra[name] = value
        return extra

    @staticmethod
    def merge(path: Path, conditions: dict, extra: dict) -> dict:
        """The file's own ``conditions`` and ``extra``; a clash is a DataError."""
        for name, value in extra.items():
            own = conditions.get(name)
            if own is not None and str(own) != str(value):
                raise DataError(
                    f"{path.name}: condition {name!r} is {own!r} in the file but "
                    f"{value!r} from its name or the labels table; keep one"
                )
        return {**conditions, **extra}

    def warn_unused(self) -> None:
        """A DataWarning for labels-table rows that name no member file read."""
        if self.table is None:
            return
        unused = [k for k in self.table if k not in self.used]
        if unused:
            warnings.warn(
                f"{self.source}: {len(unused)} row(s) name no member file read: "
                f"{unused[:5]}{' ...' if len(unused) > 5 else ''}; check the names",
                DataWarning,
                stacklevel=3,
            )


def read_members(
    files: Any,
    *,
    fs: float | None = None,
    signals: Any = None,
    time: str | None = None,
    label_from_name: Any = None,
    labels: Any = None,
    on_error: str = "raise",
    return_errors: bool = False,
    progress: bool | None = None,
):
    r"""Build an ensemble from member files: one recording per file.

    A member file is a CSV / Parquet table (numeric columns are signals, a ``time``
    column gives the sampling rate, constant text columns are condition variables such
    as the label), or a ``.mat`` / ``.npz`` file (numeric vectors are signals, a scalar
    ``fs`` gives the sampling rate, other scalars are conditions). The member id is the
    file name without its extension.

    Member files are untrusted input, read by :func:`read_table`, :func:`read_mat` and
    :func:`read_npz` with their checks (sizes declared before reading against
    ``max_bytes("member")``, header-less CSV files, columns mixing numbers and text),
    plus:

    - a time column must increase uniformly: a missing, repeated or decreasing time
      stamp, or a step that differs from the median step by more than 1 % of it (or by
      more than one unit of the last decimal the stamps are written with, when that is
      larger: stamps rounded to microseconds stay uniform at 25.6 kHz), is an error
      naming the file and the line. The rate is the number of steps over the span;
    - a signal must fit the ceiling as float64 samples;
    - a complex variable of a ``.mat`` / ``.npz`` file is an error naming it (store the
      real and imaginary parts as two signals); a true/false vector (or CSV column) is
      read as a signal of 0.0 and 1.0, and a variable that is neither a numeric vector
      nor a scalar (a MATLAB struct or cell array, text, an empty or structured array)
      is skipped: a :class:`pdmkit.errors.DataWarning` names each, once for all the
      files that hold it;
    - in a folder (or a glob pattern's matches), a sub-folder named like a member file
      (``x.csv/``) is that member's error; other sub-folders are not read, and a
      DataWarning names them.

    With ``on_error="skip"`` a file that cannot be read or fails a check, a member
    lacking a signal named in ``signals``, a signal with NaN or inf samples, or a
    sampling rate that differs from ``fs`` (default: the most common rate of the files)
    leaves that member out and adds a row to the errors table (with the reason); the
    other members are read as if the bad file were not there.

    Parameters
    ----------
    files : path, glob pattern or sequence of them
        Member files; a directory stands for all the files in it.
    fs : float, optional
        Expected sampling rate in Hz (required when no file states its own).
    signals : sequence of str, optional
        Signals every member must have (default: all found; a member lacking one gets
        None there).
    time : str, optional
        The time column of CSV / Parquet members (or time variable of ``.mat`` /
        ``.npz`` members, in seconds) when it is not named ``time``, ``t``, ``Time``
        or ``TIME``; a member without it is an error naming the file.
    label_from_name : str or re.Pattern, optional
        A regular expression searched in each member's file name: its one group
        becomes the condition ``label``, or its named groups (``(?P<fault>...)``)
        conditions of their names, so a label need not be repeated on every row of a
        member file. A file whose name does not match is an error naming it.
    labels : path or DataFrame, optional
        A table (CSV / Parquet, read by :func:`read_table`) with a column ``file``
        (or ``member``, ``name``, ``filename``, ``path``) naming each member file
        (``a.csv``) or member id (``a``), and condition columns beside it. A member
        file the table does not list is an error naming it; rows naming no file read
        give a DataWarning. A condition given twice with different values (in the
        file, by its name, in the table) is an error.
    on_error : {"raise", "skip"}, default "raise"
    return_errors : bool, default False
        Also return the errors table (columns ``member``, ``signal``, ``source``,
        ``error``).
    progress : bool, optional
        A progress bar over the files; default only when stderr is a terminal.

    Returns
    -------
    Ensemble, or (Ensemble, DataFrame) with ``return_errors``

    Raises
    ------
    pdmkit.errors.DataError
        With ``on_error="raise"``: the first bad file (the message names it and says
        what was expected and found). Always: no file matched, or no member was left.

    Warns
    -----
    pdmkit.errors.DataWarning
        A variable or column read as 0/1 or skipped, or a sub-folder not read.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> t = np.arange(100) / 50.0
    >>> pd.DataFrame({"time": t, "vib": np.sin(t), "fault": "ir"}).to_csv(
    ...     d / "a.csv", index=False)
    >>> pd.DataFrame({"time": t / 2, "vib": np.cos(t), "fault": "ok"}).to_csv(
    ...     d / "b.csv", index=False)
    >>> _ = (d / "c.csv").write_bytes(b"\x00\x01garbage")
    >>> ens, errors = read_members(d, fs=50.0, on_error="skip", return_errors=True)
    >>> ens.member_ids.tolist(), ens.conditions["fault"].tolist()
    (['a'], ['ir'])
    >>> errors["member"].tolist()
    ['b', 'c']
    >>> print(errors["error"].iloc[0])
    b.csv is sampled at 100 Hz; expected 50 Hz (fs as given); member skipped

    The label from the file names, and a time column named otherwise:

    >>> e = pathlib.Path(tempfile.mkdtemp())
    >>> for name in ("run1_IR.csv", "run2_OR.csv"):
    ...     pd.DataFrame({"sec": t, "vib": np.sin(t)}).to_csv(e / name, index=False)
    >>> ens = read_members(e, time="sec", label_from_name=r"_([A-Z]+)[.]csv")
    >>> ens.conditions["label"].tolist(), ens.fs["vib"]
    (['IR', 'OR'], 50.0)
    """
    import glob

    if on_error not in ("raise", "skip"):
        raise ValueError(f"on_error must be 'raise' or 'skip'; got {on_error!r}")
    patterns = [files] if isinstance(files, str | os.PathLike) else list(files)
    paths: list[Path] = []
    folders: list[Path] = []  # sub-folders not named like a member file: not read
    for p in patterns:
        p = Path(p)
        if p.is_dir():
            found = sorted(q for q in p.iterdir() if not q.name[0] == ".")
        elif any(ch in str(p) for ch in "*?["):
            found = sorted(Path(q) for q in glob.glob(str(p)))
        else:
            paths.append(p)  # a folder named here is the member's error
            continue
        for q in found:
            if q.is_file() or _member_like(q):  # a folder 'x.csv' is the member's error
                paths.append(q)
            elif q.is_dir():
                folders.append(q)
    if folders:
        shown = ", ".join(str(q) for q in folders[:3])
        more = f" and {len(folders) - 3} more" if len(folders) > 3 else ""
        warnings.warn(
            f"{len(folders)} sub-folder(s) not read as members: {shown}{more}; a member "
            "is one file, and only the files directly in a folder are read. Name the "
            f"files inside a sub-folder to read them too (e.g. {folders[0] / '*'})",
            DataWarning,
            stacklevel=2,
        )
    if not paths:
        raise DataNotFoundError(f"no member files match {[str(p) for p in patterns]}")
    wanted = (
        None
        if signals is None
        else [signals]
        if isinstance(signals, str)
        else list(signals)
    )
    errors: list[dict] = []

    def fail(member: str, signal: Any, path: Path, message: str) -> None:
        if on_error == "raise":
            raise DataError(message)
        errors.append(
            {
                "member": member,
                "signal": signal,
                "source": str(path),
                "error": f"{message}; member skipped",
            }
        )

    read: list[tuple[str, Path, dict, float | None, dict]] = []
    noted: dict[tuple[str, str, str], list[Path]] = {}

    named = _NameConditions(label_from_name, labels)
    for path in _progress_bar(paths, desc="reading members", enable=progress):
        member = path.name.split(".")[0]
        notes: list[tuple[str, str, str]] = []
        try:
            extra = named.conditions(path)
            arrays, rate, conds = _member_arrays(path, notes, time)
            conds = named.merge(path, conds, extra)
        except DataError as exc:
            fail(member, None, path, str(exc))
            continue
        for note in notes:
            noted.setdefault(note, []).append(path)
        if not arrays:
            fail(member, None, path, f"{path.name} holds no numeric signal")
            continue
        missing = [s for s in wanted or () if s not in arrays]
        if missing:
            fail(
                member,
                missing[0],
                path,
                f"{path.name} lacks signal(s) {missing}; it has {sorted(arrays)}",
            )
            continue
        bad = [s for s, x in arrays.items() if not np.isfinite(x).all()]
        if bad:
            x = arrays[bad[0]]
            fail(
                member,
                bad[0],
                path,
                f"signal {bad[0]!r} of {path.name} holds {int((~np.isfinite(x)).sum())} "
                f"NaN/inf value(s) (first at sample {int(np.argmax(~np.isfinite(x)))})",
            )
            continue
        read.append((member, path, arrays, rate, conds))

    named.warn_unused()
    for (what, name, done), where in noted.items():
        files = (
            str(where[0])
            if len(where) == 1
            else f"{len(where)} member files ({', '.join(p.name for p in where[:3])}"
            + (", ...)" if len(where) > 3 else ")")
        )
        warnings.warn(f"{files}: {what} {name!r} {done}", DataWarning, stacklevel=2)
    rates = [r for _, _, _, r, _ in read if r is not None]
    expected, whose = fs, "fs as given"
    if expected is None and rates:
        values, counts = np.unique(np.round(rates, 6), return_counts=True)
        expected, whose = (
            float(values[np.argmax(counts)]),
            "the most common rate of the files",
        )
    if expected is None and read:
        raise DataError(
            f"none of the {len(read)} member files states its sampling rate (no time "
            "column, no fs variable); pass fs="
        )
    kept = []
    for member, path, arrays, rate, conds in read:
        if rate is not None and abs(rate - expected) > 1e-3 * expected:
            fail(
                member,
                None,
                path,
                f"{path.name} is sampled at {rate:g} Hz; expected {expected:g} Hz "
                f"({whose})",
            )
            continue
        kept.append((member, path, arrays, conds))
    kept = _without_clashes(kept, fail)
    kept = [(m, a, c) for m, _, a, c in kept]
    if not kept:
        first = f"; e.g. {errors[0]['error']}" if errors else ""
        raise DataError(f"no member could be read from {len(paths)} file(s){first}")
    names = wanted or list(dict.fromkeys(s for _, a, _ in kept for s in a))
    ids = [m for m, _, _ in kept]
    if len(set(ids)) != len(ids):
        dup = sorted({m for m in ids if ids.count(m) > 1})
        raise DataError(f"member files share the names {dup[:5]}; rename them")
    ens = Ensemble(
        {s: [a.get(s) for _, a, _ in kept] for s in names},
        fs=expected,
        conditions=pd.DataFrame([c for _, _, c in kept]) if kept else None,
        member_ids=ids,
    )
    order = {str(p): i for i, p in enumerate(paths)}
    errors.sort(key=lambda e: order.get(e["source"], -1))
    table = pd.DataFrame(errors, columns=list(_MEMBER_ERRORS))
    return (ens, table) if return_errors else ens
