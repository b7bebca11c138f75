"""The on-disk ensemble: a directory of Parquet files plus a small JSON manifest.

Layout of a dataset directory::

    ens/
      _pdmkit_ensemble.json     format, format_version, signals, fs, conditions,
                                n_members, files (name and member count of each part)
      part-00000.parquet        one row per member: "member" (string), the condition
      part-00001.parquet        columns, one list<float64> column per signal (null where
      ...                       the member lacks it)

Each part file holds ``members_per_file`` members, split into row groups of at most
~4 M samples so that a reader holds one row group at a time.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit._atomic import atomic_dir
from pdmkit._checks import check_int
from pdmkit.ensembles._limits import _one_line, check_declared_sizes
from pdmkit.ensembles._signals import MEMBER, SignalList, _names_list
from pdmkit.errors import DataError, DataNotFoundError

__all__ = [
    "read_manifest",
    "read_parts",
    "url_filesystem",
    "write_parquet",
    "write_parquet_batches",
]

FORMAT = "pdmkit.ensemble"
FORMAT_VERSION = 1
MANIFEST = "_pdmkit_ensemble.json"
# samples per row group (32 MiB of float64): a reader holds about one row group, and
# reading a run of members wastes at most one row group's decoding on either side
_GROUP_VALUES = 1 << 22
_INT32_MAX = (1 << 31) - 1


# --------------------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------------------


def _list_array(xs: SignalList) -> Any:
    """A pyarrow ``list<float64>`` array from per-member arrays (None -> null)."""
    import pyarrow as pa

    lengths = np.fromiter((0 if x is None else len(x) for x in xs), np.int64, len(xs))
    total = int(lengths.sum())
    if total > _INT32_MAX:
        raise DataError(
            f"a row group of {len(xs)} member(s) holds {total} samples, more than a "
            "Parquet list column can take; split the longest members with frames()"
        )
    offsets = np.zeros(len(xs) + 1, dtype=np.int32)
    np.cumsum(lengths, out=offsets[1:])
    present = [x for x in xs if x is not None]
    values = np.concatenate(present) if present else np.empty(0, dtype=np.float64)
    mask = np.fromiter((x is None for x in xs), bool, len(xs))
    return pa.ListArray.from_arrays(
        pa.array(offsets), pa.array(values, type=pa.float64()), mask=pa.array(mask)
    )


def _row_groups(
    signals: Mapping[str, SignalList], start: int, stop: int
) -> list[tuple[int, int]]:
    """Split members ``start:stop`` into runs of at most ~_GROUP_VALUES samples."""
    sizes = np.zeros(stop - start, dtype=np.int64)
    for xs in signals.values():
        sizes += np.fromiter(
            (0 if x is None else len(x) for x in xs[start:stop]), np.int64, stop - start
        )
    groups, first, acc = [], start, 0
    for i, size in enumerate(sizes, start=start):
        if acc and acc + size > _GROUP_VALUES:
            groups.append((first, i))
            first, acc = i, 0
        acc += int(size)
    groups.append((first, stop))
    return groups


def _write_part(
    file: Path, signals: Mapping[str, SignalList], conditions: Any, start: int, stop: int
) -> None:
    """Write members ``start:stop`` to one Parquet file (row group by row group).

    ``signals`` maps each signal to its per-member arrays, ``conditions`` is the
    pyarrow table of the member ids and condition columns.
    """
    import pyarrow.parquet as pq

    writer = None
    try:
        for a, b in _row_groups(signals, start, stop):
            table = conditions.slice(a, b - a)
            for s, xs in signals.items():
                table = table.append_column(s, _list_array(xs[a:b]))
            if writer is None:
                writer = pq.ParquetWriter(file, table.schema)
            writer.write_table(table)
    finally:
        if writer is not None:
            writer.close()


def _conditions_table(conditions: pd.DataFrame) -> Any:
    """The member ids and condition columns as a pyarrow table (DataError on a bad one)."""
    import pyarrow as pa

    frame = conditions.reset_index()
    try:
        return pa.Table.from_pandas(frame, preserve_index=False)
    except (pa.ArrowException, TypeError, ValueError) as exc:
        # name the offending column
        for c in frame.columns:
            try:
                pa.Table.from_pandas(frame[[c]], preserve_index=False)
            except (pa.ArrowException, TypeError, ValueError) as col_exc:
                raise DataError(
                    f"condition column {c!r} cannot be stored in Parquet ({col_exc}); "
                    "give it one type (numbers, strings, booleans, timestamps)"
                ) from None
        raise DataError(f"the conditions cannot be stored in Parquet ({exc})") from None


def _check_target(path: Path) -> None:
    if not path.exists():
        return
    if not path.is_dir():
        raise DataError(
            f"{path} exists and is a file; refusing to replace it with an ensemble "
            "directory. Choose another path."
        )
    entries = sorted(p.name for p in path.iterdir())
    if entries and MANIFEST not in entries:
        raise DataError(
            f"{path} exists and is not a pdmkit ensemble (it holds {_names_list(entries)}, "
            f"no {MANIFEST}); refusing to replace it. Choose another path or remove it."
        )


def write_parquet(
    ens: Any, path: str | os.PathLike, *, members_per_file: int = 256
) -> Path:
    """Write the Ensemble ``ens`` as a pdmkit Parquet dataset (:meth:`Ensemble.to_parquet`).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from pdmkit.ensembles import Ensemble
    >>> ens = Ensemble({"x": np.ones((3, 4))}, fs=2.0)
    >>> path = write_parquet(ens, pathlib.Path(tempfile.mkdtemp()) / "ens")
    >>> read_manifest(path)["n_members"]
    3
    """
    if not hasattr(ens, "_signals"):  # duck-typed: doctests may load a module twice
        raise DataError(f"write_parquet takes an Ensemble; got {type(ens).__name__}")
    per_file = check_int(members_per_file, "members_per_file")
    path = Path(path)
    _check_target(path)
    conditions = _conditions_table(ens._conditions)
    n = len(ens)
    files = []
    with atomic_dir(path) as tmp:
        # at least one file, so that an empty ensemble keeps its column types
        for k, start in enumerate(range(0, max(n, 1), per_file)):
            stop = min(start + per_file, n)
            name = f"part-{k:05d}.parquet"
            _write_part(tmp / name, ens._signals, conditions, start, stop)
            files.append({"name": name, "n_members": stop - start})
        manifest = {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "member_column": MEMBER,
            "signals": ens.signal_names,
            "fs": ens.fs,
            "conditions": [str(c) for c in ens._conditions.columns],
            "n_members": n,
            "files": files,
        }
        (tmp / MANIFEST).write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
    return path


def write_parquet_batches(batches: Iterable[Any], path: str | os.PathLike) -> Path:
    """Write ensembles arriving one batch at a time as one pdmkit Parquet dataset.

    Each batch becomes one part file as soon as it arrives, so an ensemble larger than
    memory (a long simulation sweep, a fleet's recordings) can be written while it is
    produced. All batches must have the same signals, sampling rates and condition
    columns; member ids must be unique across batches. The dataset appears at ``path``
    only when complete.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from pdmkit.ensembles import Ensemble
    >>> batches = (Ensemble({"x": np.ones((2, 3))}, fs=1.0, member_ids=[f"b{k}a", f"b{k}b"])
    ...            for k in range(3))
    >>> path = write_parquet_batches(batches, pathlib.Path(tempfile.mkdtemp()) / "ens")
    >>> read_manifest(path)["n_members"], len(read_manifest(path)["files"])
    (6, 3)
    """
    path = Path(path)
    _check_target(path)
    files: list[dict[str, Any]] = []
    first: Any = None
    seen: set[str] = set()
    n = 0
    with atomic_dir(path) as tmp:
        for k, batch in enumerate(batches):
            if not hasattr(batch, "_signals"):
                raise DataError(
                    f"batch {k} is a {type(batch).__name__}; expected an Ensemble"
                )
            if first is None:
                first = batch
            elif (
                batch.signal_names != first.signal_names
                or batch.fs != first.fs
                or list(batch._conditions.columns) != list(first._conditions.columns)
            ):
                raise DataError(
                    f"batch {k} has signals {batch.signal_names} at {batch.fs} and "
                    f"conditions {list(batch._conditions.columns)}; the first batch has "
                    f"{first.signal_names} at {first.fs} and "
                    f"{list(first._conditions.columns)}. Every batch must match"
                )
            ids = set(map(str, batch.member_ids))
            repeated = ids & seen
            if repeated:
                raise DataError(
                    f"batch {k} repeats member ids {_names_list(sorted(repeated))}; "
                    "member ids must be unique across batches"
                )
            seen |= ids
            name = f"part-{k:05d}.parquet"
            _write_part(
                tmp / name,
                batch._signals,
                _conditions_table(batch._conditions),
                0,
                len(batch),
            )
            files.append({"name": name, "n_members": len(batch)})
            n += len(batch)
        if first is None:
            raise DataError("write_parquet_batches got no batches; nothing to write")
        manifest = {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "member_column": MEMBER,
            "signals": first.signal_names,
            "fs": first.fs,
            "conditions": [str(c) for c in first._conditions.columns],
            "n_members": n,
            "files": files,
        }
        (tmp / MANIFEST).write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
    return path


# --------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------


def _quiet_stderr() -> Any:
    """Silence file descriptor 2 for the duration of a ``with`` block.

    C libraries print there: libhdfs lists every libjvm it did not find.
    """
    import contextlib
    import sys
    import tempfile

    @contextlib.contextmanager
    def quiet():
        try:
            sys.stderr.flush()
            saved = os.dup(2)
        except (OSError, ValueError):  # no real descriptor 2: nothing to silence
            yield
            return
        try:
            with tempfile.TemporaryFile() as sink:
                os.dup2(sink.fileno(), 2)
                try:
                    yield
                finally:
                    os.dup2(saved, 2)
        finally:
            os.close(saved)

    return quiet()


def url_filesystem(url: str) -> tuple[Any, str]:
    """The fsspec filesystem of ``url`` and the path on it.

    Raises a one-line :class:`~pdmkit.errors.DataError` naming the URL and the package
    to install when the URL's protocol is unknown or its backend is not installed (or
    cannot start), instead of fsspec's ImportError / ValueError / OSError.

    Parameters
    ----------
    url : str
        An fsspec URL (``file:///data/ens``, ``s3://bucket/ens``, ...).

    Returns
    -------
    (fsspec.AbstractFileSystem, str)

    Raises
    ------
    pdmkit.errors.DataError
        Unknown protocol, or its backend package is missing.

    Examples
    --------
    >>> url_filesystem("file:///tmp")[1]
    '/tmp'
    >>> url_filesystem("nosuch://bucket/ens")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: nosuch://bucket/ens: no filesystem is known for the protocol 'nosuch'...
    """  # noqa: E501
    import re

    try:
        import fsspec
        from fsspec.registry import known_implementations
    except ImportError:
        raise DataError(
            f"{url}: reading a URL needs the package fsspec (pip install fsspec); or "
            "give a local path"
        ) from None
    protocol = url.split("://", 1)[0].split("::")[-1]
    known = known_implementations.get(protocol, {})
    package = str(known.get("class", "")).split(".")[0]
    needs = str(known.get("err", "")).rstrip(".")
    if package and package != "fsspec":
        install = f"pip install {package}"
    else:  # a backend of fsspec itself that needs other packages
        names = re.findall(r'"([A-Za-z0-9_.\-\[\]]+)"', needs)
        install = f"pip install {' '.join(names)}" if names else ""
    try:
        with _quiet_stderr():
            return fsspec.core.url_to_fs(url)
    except ImportError as exc:
        what = needs or str(exc)
        raise DataError(
            f"{url}: the {protocol}:// filesystem is not installed ({what}); "
            f"{install + ', or ' if install else ''}copy the data to a local directory "
            "and give its path"
        ) from None
    except ValueError as exc:
        if "Protocol not known" not in str(exc):
            raise DataError(
                f"{url} is not a valid URL ({_one_line(exc)}); check its spelling"
            ) from None
        raise DataError(
            f"{url}: no filesystem is known for the protocol {protocol!r}; check the "
            "URL's spelling (file://, s3://, gcs://, abfs://, http://, ...) or give a "
            "local path"
        ) from None
    except (OSError, RuntimeError, TypeError) as exc:
        hint = f" ({needs})" if needs else ""
        found = (str(exc).strip().splitlines() or [""])[0]
        raise DataError(
            f"{url}: the {protocol}:// filesystem cannot start{hint}: "
            f"{type(exc).__name__}: {found}; install what it needs"
            f"{' (' + install + ')' if install else ''}, or copy the data to a local "
            "directory and give its path"
        ) from None


def read_manifest(path: str | os.PathLike) -> dict[str, Any]:
    """Read and check the manifest of a pdmkit Parquet dataset.

    Raises
    ------
    pdmkit.errors.DataNotFoundError
        The path does not exist.
    pdmkit.errors.DataError
        The path is not a pdmkit ensemble directory (the message says what it found).

    Examples
    --------
    >>> import tempfile
    >>> read_manifest(tempfile.mkdtemp())  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    pdmkit.errors.DataError: ... is not a pdmkit ensemble: the directory is empty...
    """
    path = Path(path)
    if not path.exists():
        raise DataNotFoundError(
            f"{path} does not exist; expected a pdmkit ensemble directory"
        )
    what = (
        f"expected a directory with {MANIFEST} and part-*.parquet files "
        "(written by Ensemble.to_parquet)"
    )
    if not path.is_dir():
        hint = " (read a single Parquet table with read_table)" if path.suffix else ""
        raise DataError(f"{path} is not a pdmkit ensemble: it is a file; {what}{hint}")
    file = path / MANIFEST
    if not file.is_file():
        entries = sorted(p.name for p in path.iterdir())
        found = f"it holds {_names_list(entries)}" if entries else "the directory is empty"
        raise DataError(f"{path} is not a pdmkit ensemble: {found}; {what}")
    try:
        manifest = json.loads(file.read_text(encoding="utf-8"))
    except (ValueError, UnicodeDecodeError) as exc:
        raise DataError(
            f"{file} is not valid JSON ({exc}); the dataset is damaged"
        ) from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise DataError(f"{file} is not a pdmkit ensemble manifest (no format {FORMAT!r})")
    version = manifest.get("format_version")
    if not isinstance(version, int) or version > FORMAT_VERSION:
        raise DataError(
            f"{file} has format_version {version!r}; this pdmkit reads up to "
            f"{FORMAT_VERSION}. Upgrade pdmkit."
        )
    needed = ("signals", "fs", "conditions", "n_members", "files")
    missing = [k for k in needed if k not in manifest]
    if missing:
        raise DataError(f"{file} lacks the entries {missing}; the dataset is damaged")
    for entry in manifest["files"]:
        if not (path / entry["name"]).is_file():
            raise DataError(
                f"{path} is incomplete: the manifest lists {entry['name']!r}, which is "
                "missing; write the dataset again"
            )
    return manifest


def _pick(requested: Any, available: Sequence[str], what: str, path: Path) -> list[str]:
    if requested is None:
        return list(available)
    names = [requested] if isinstance(requested, str) else list(requested)
    unknown = [s for s in names if s not in available]
    if unknown:
        raise DataError(
            f"the ensemble at {path} has no {what} {_names_list(unknown)}; it has "
            f"{_names_list(list(available), 20) or 'none'}"
        )
    return names


def _lists_to_arrays(column: Any) -> tuple[SignalList, bool]:
    """Per-member float64 arrays (read-only, zero-copy where possible) of a list column."""
    out: SignalList = []
    finite = True
    for chunk in column.chunks:
        offsets = chunk.offsets.to_numpy()
        values = chunk.values.to_numpy(zero_copy_only=False)
        if values.dtype != np.float64:
            values = values.astype(np.float64)
        if values.flags.writeable:
            values.flags.writeable = False
        if offsets.size > 1:
            finite &= bool(np.isfinite(values[offsets[0] : offsets[-1]]).all())
        valid = chunk.is_valid().to_numpy(zero_copy_only=False)
        out.extend(
            values[a:b] if ok else None
            for a, b, ok in zip(offsets[:-1], offsets[1:], valid, strict=True)
        )
    return out, finite


def read_parts(
    path: str | os.PathLike,
    signals: str | Sequence[str] | None = None,
    columns: Sequence[str] | None = None,
) -> tuple[dict[str, Any], list[str], list[str], Iterator[tuple[Any, Path]]]:
    """A dataset's manifest, the signals and columns chosen, and its part files' tables.

    The manifest is read and the names checked at once; the part files are read one
    at a time as the last item, an iterator of ``(pyarrow table, file)``, is consumed
    (their declared sizes checked first). The reading of
    :meth:`Ensemble.from_parquet`, which builds the ensemble from the tables.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from pdmkit.ensembles import Ensemble
    >>> path = Ensemble({"x": np.ones((2, 3))}, fs=1.0).to_parquet(
    ...     pathlib.Path(tempfile.mkdtemp()) / "ens"
    ... )
    >>> manifest, signals, columns, tables = read_parts(path)
    >>> signals, [table.num_rows for table, _ in tables]
    (['x'], [2])
    """
    path = Path(path)
    manifest = read_manifest(path)
    sigs = _pick(signals, manifest["signals"], "signal(s)", path)
    cols = _pick(columns, manifest["conditions"], "condition column(s)", path)
    return manifest, sigs, cols, _part_tables(path, manifest, [MEMBER, *cols, *sigs])


def _part_tables(
    path: Path, manifest: dict[str, Any], columns: list[str]
) -> Iterator[tuple[Any, Path]]:
    """Each part file's ``columns`` as a pyarrow table, with the file, one at a time."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    for entry in manifest["files"]:
        file = path / entry["name"]
        try:
            check_declared_sizes(
                pq.read_metadata(file), str(file), columns=columns, per_row_group=True
            )
            table = pq.read_table(file, columns=columns)
        except (pa.ArrowException, OSError) as exc:
            raise DataError(
                f"cannot read {file} ({_one_line(exc)}); the dataset is damaged"
            ) from None
        yield table, file
