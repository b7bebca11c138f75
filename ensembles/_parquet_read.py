"""Ensembles read back from a pdmkit Parquet dataset: whole, or streamed in batches.

The dataset's layout and its low-level reading are :mod:`pdmkit.ensembles._parquet`'s;
here the tables become :class:`~pdmkit.ensembles.Ensemble` objects.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from pdmkit._checks import check_int
from pdmkit.ensembles._ensemble import Ensemble, _table_to_ensemble
from pdmkit.ensembles._limits import _one_line, check_declared_sizes
from pdmkit.ensembles._parquet import _pick, read_manifest
from pdmkit.ensembles._signals import MEMBER
from pdmkit.errors import DataError

__all__ = ["iter_parquet", "read_parquet"]


def read_parquet(
    path: str | os.PathLike,
    *,
    signals: str | Sequence[str] | None = None,
    columns: Sequence[str] | None = None,
) -> Ensemble:
    """Read a whole pdmkit Parquet dataset; :meth:`Ensemble.from_parquet` as a function.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> import numpy as np
    >>> path = Ensemble({"x": np.ones((2, 3))}, fs=1.0).to_parquet(
    ...     pathlib.Path(tempfile.mkdtemp()) / "ens"
    ... )
    >>> len(read_parquet(path))
    2
    """
    return Ensemble.from_parquet(path, signals=signals, columns=columns)


def iter_parquet(
    path: str | os.PathLike,
    batch_size: int = 256,
    signals: str | Sequence[str] | None = None,
    columns: Sequence[str] | None = None,
) -> Iterator[Ensemble]:
    """Stream a pdmkit Parquet dataset as ensembles of ``batch_size`` members.

    Files are read one row group at a time (pyarrow ``iter_batches``), so memory stays
    bounded by about one row group plus one batch, however large the dataset. Every
    batch except the last has exactly ``batch_size`` members; the batches, in order,
    hold the members of the dataset in the order they were written.

    Parameters
    ----------
    path : str or path-like
        A directory written by :meth:`Ensemble.to_parquet`.
    batch_size : int, default 256
        Members per batch.
    signals : str or sequence of str, optional
        Signals to read (default: all).
    columns : sequence of str, optional
        Condition columns to read (default: all).

    Yields
    ------
    Ensemble

    Raises
    ------
    pdmkit.errors.DataError
        The directory is not a pdmkit ensemble (the message says what it found), or it
        lacks a requested signal or column.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> import numpy as np
    >>> from pdmkit.ensembles import Ensemble, iter_parquet
    >>> ens = Ensemble({"x": np.arange(10.0).reshape(5, 2)}, fs=1.0)
    >>> path = ens.to_parquet(pathlib.Path(tempfile.mkdtemp()) / "ens", members_per_file=2)
    >>> [len(b) for b in iter_parquet(path, batch_size=3)]
    [3, 2]
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    size = check_int(batch_size, "batch_size")
    path = Path(path)
    manifest = read_manifest(path)
    sigs = _pick(signals, manifest["signals"], "signal(s)", path)
    cols = _pick(columns, manifest["conditions"], "condition column(s)", path)
    buffer: list[Any] = []
    buffered = 0
    for entry in manifest["files"]:
        file = path / entry["name"]
        try:
            reader = pq.ParquetFile(file)
            check_declared_sizes(
                reader.metadata,
                str(file),
                columns=[MEMBER, *cols, *sigs],
                per_row_group=True,
            )
            batches = reader.iter_batches(batch_size=size, columns=[MEMBER, *cols, *sigs])
            for batch in batches:
                if batch.num_rows == 0:
                    continue
                buffer.append(batch)
                buffered += batch.num_rows
                while buffered >= size:
                    table = pa.Table.from_batches(buffer)
                    yield _table_to_ensemble(
                        table.slice(0, size), manifest, sigs, cols, str(file)
                    )
                    rest = table.slice(size)
                    buffer, buffered = rest.to_batches(), rest.num_rows
        except (pa.ArrowException, OSError) as exc:
            raise DataError(
                f"cannot read {file} ({_one_line(exc)}); the dataset is damaged"
            ) from None
    if buffered:
        table = pa.Table.from_batches(buffer)
        yield _table_to_ensemble(table, manifest, sigs, cols, str(path))
