"""Tables in text (CSV / TSV / whitespace, compressed too) and Parquet: :func:`read_table`.

Recordings are untrusted input. Every reader

- raises :class:`pdmkit.errors.DataNotFoundError` for a missing file and
  :class:`pdmkit.errors.DataError` for one it cannot read, with the path (and the array,
  variable or column) in a one-line message; never a bare ``KeyError``,
  ``zipfile.BadZipFile``, ``zlib.error`` or pickle error;
- checks the sizes a file *declares* before reading it, against
  :func:`pdmkit._config.max_bytes` ``("member")`` (1 GiB by default,
  ``$PDMKIT_MAX_MEMBER_BYTES``), so a small file that declares (or decompresses to) a
  huge array is refused before anything is allocated;
- never unpickles anything.
"""

from __future__ import annotations

import bz2
import contextlib
import gzip
import lzma
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

from pdmkit._config import max_bytes
from pdmkit.ensembles._limits import _one_line, _too_big, _why, check_declared_sizes
from pdmkit.errors import DataError, DataNotFoundError, DataWarning

__all__ = ["read_table"]

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
