"""Size ceilings on what pdmkit reads from a user's file: the sizes, the refusals.

Every reader checks what a file *declares* (array headers, ``.mat`` variable shapes,
Parquet footers) against ``pdmkit._config.max_bytes`` before it decodes anything, so a
small file cannot make pdmkit allocate gigabytes.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from pdmkit._config import _LIMIT_ENV, max_bytes
from pdmkit.errors import DataError

__all__ = ["check_declared_sizes", "declared_sizes"]


def _size(n: int) -> str:
    """``n`` bytes for a message: ``'2 GiB'``, ``'3.5 MiB'``, ``'512 bytes'``."""
    for unit, scale in (("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n} bytes"


def _one_line(exc: BaseException) -> str:
    """An exception's text on one line (pandas' parser errors end in a newline)."""
    return " ".join(str(exc).split())


def _why(exc: BaseException) -> str:
    """``'Type: text'`` of an exception, on one line."""
    return f"{type(exc).__name__}: {_one_line(exc)}"


def _too_big(what: str, found: int, limit: int, verb: str = "declares") -> DataError:
    """The one-line refusal of an array (or file) larger than the member ceiling."""
    return DataError(
        f"{what} {verb} {_size(found)} decompressed, more than the {_size(limit)} pdmkit "
        "reads from one member file; refused before reading it. If the file is genuine, "
        f"raise the ceiling: {_LIMIT_ENV['member']}={found}"
    )


# --------------------------------------------------------------------------- Parquet
#: Bytes one value of each Parquet physical type takes once decoded (at most: pandas
#: widens 32-bit numbers to 64 bits); text adds its own bytes to the offsets.
_DECODED_WIDTH = {"BOOLEAN": 1, "INT32": 8, "INT64": 8, "INT96": 12, "FLOAT": 8}


def declared_sizes(metadata: Any, columns: Sequence[str] | None = None) -> dict[str, list]:
    """Decompressed bytes each row group of each top-level column declares.

    Read from the file's footer only: per column chunk the larger of its uncompressed
    size and its value count times the decoded width of its type. A file can declare
    less than it holds only by lying about its own page sizes, which pyarrow checks
    while decoding.

    Parameters
    ----------
    metadata : pyarrow.parquet.FileMetaData
    columns : sequence of str, optional
        Top-level columns to count (default: all).

    Returns
    -------
    dict of str to list of int
        Column name -> bytes per row group.

    Examples
    --------
    >>> import io, numpy as np, pyarrow as pa, pyarrow.parquet as pq
    >>> buffer = io.BytesIO()
    >>> pq.write_table(pa.table({"x": np.zeros(1000)}), buffer)
    >>> declared_sizes(pq.read_metadata(io.BytesIO(buffer.getvalue())))["x"][0] >= 8000
    True
    """
    fields = [f.name for f in metadata.schema.to_arrow_schema()]
    out: dict[str, list] = {}
    for g in range(metadata.num_row_groups):
        group = metadata.row_group(g)
        for i in range(group.num_columns):
            chunk = group.column(i)
            leaf = chunk.path_in_schema
            name = max(
                (f for f in fields if leaf == f or leaf.startswith(f + ".")),
                key=len,
                default=leaf.split(".")[0],
            )
            if columns is not None and name not in columns:
                continue
            kind = chunk.physical_type
            if kind == "FIXED_LEN_BYTE_ARRAY":
                width = metadata.schema.column(i).length or 8
            else:
                width = _DECODED_WIDTH.get(kind, 8)  # DOUBLE, and text offsets
            size = max(int(chunk.total_uncompressed_size), int(chunk.num_values) * width)
            out.setdefault(name, [0] * metadata.num_row_groups)[g] += size
    return out


def check_declared_sizes(
    metadata: Any,
    where: str,
    *,
    columns: Sequence[str] | None = None,
    per_row_group: bool = False,
) -> dict[str, int]:
    """Refuse a Parquet file whose columns declare more than ``max_bytes("member")``.

    Parameters
    ----------
    metadata : pyarrow.parquet.FileMetaData
    where : str
        The file, for the message.
    columns : sequence of str, optional
        Top-level columns that will be read (default: all).
    per_row_group : bool, default False
        Check each row group of each column (an ensemble part file, read a row group
        at a time, whose members are rows) instead of each whole column (a table).

    Returns
    -------
    dict of str to int
        Column name -> declared bytes (all row groups).

    Raises
    ------
    pdmkit.errors.DataError
        A column (or one of its row groups) declares more than the ceiling.

    Examples
    --------
    >>> import io, numpy as np, pyarrow as pa, pyarrow.parquet as pq
    >>> buffer = io.BytesIO()
    >>> pq.write_table(pa.table({"x": np.zeros(10)}), buffer)
    >>> meta = pq.read_metadata(io.BytesIO(buffer.getvalue()))
    >>> check_declared_sizes(meta, "x.parquet")["x"] >= 80
    True
    """
    limit = max_bytes("member")
    sizes = declared_sizes(metadata, columns)
    for name, groups in sizes.items():
        if per_row_group:
            for g, n in enumerate(groups):
                if n > limit:
                    raise _too_big(f"{where}: row group {g} of column {name!r}", n, limit)
        elif sum(groups) > limit:
            raise _too_big(f"{where}: column {name!r}", sum(groups), limit)
    return {name: sum(groups) for name, groups in sizes.items()}
