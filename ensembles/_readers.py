"""Readers for the file formats recordings come in: CSV / Parquet tables, MATLAB, NumPy.

Every reader raises :class:`pdmkit.errors.DataNotFoundError` for a missing file and
:class:`pdmkit.errors.DataError` for one it cannot read, with the path in the message;
never a bare ``KeyError``, ``zipfile.BadZipFile`` or pickle error.
"""

from __future__ import annotations

import os
import pickle
import re
import struct
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit.errors import DataError, DataNotFoundError

__all__ = ["read_mat", "read_members", "read_npz", "read_table"]

_CSV = (".csv", ".tsv", ".txt")
_COMPRESSED = (".gz", ".bz2", ".zip", ".xz", ".zst")
_PARQUET = (".parquet", ".pq")


def _existing_file(path: str | os.PathLike, what: str) -> Path:
    path = Path(path)
    if not path.exists():
        raise DataNotFoundError(f"{path} does not exist; expected {what}")
    if not path.is_file():
        raise DataError(f"{path} is a directory; expected {what}")
    return path


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


def read_table(path: str | os.PathLike, **options: Any) -> pd.DataFrame:
    """Read a CSV or Parquet table into a DataFrame.

    CSV (``.csv``, ``.tsv`` tab-separated, ``.txt``; optionally ``.gz``/``.bz2``/...
    compressed) goes through :func:`pandas.read_csv`, Parquet (``.parquet``, ``.pq``)
    through :func:`pandas.read_parquet`. Columns named ``Unnamed: k`` that hold nothing
    (left by a delimiter at the end of every line) are dropped. In a one-column CSV an
    empty line between values is a missing value (NaN), not a skipped line, so the
    samples after it keep their positions; empty lines (and missing values) after the
    last value are not rows.

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
        Unknown extension, a binary or damaged file, or a table without rows (the
        message names the file).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "run.csv"
    >>> _ = path.write_text("time,flow,\\n0.0,1.5,\\n0.1,1.7,\\n")
    >>> read_table(path)
       time  flow
    0   0.0   1.5
    1   0.1   1.7
    """
    import pyarrow as pa

    path = _existing_file(path, "a CSV or Parquet table")
    kind, compression = _table_kind(path)
    if kind == "csv" and not compression:
        with path.open("rb") as f:
            head = f.read(1 << 16)
        if b"\x00" in head:
            raise DataError(
                f"{path} is not a text CSV file (it holds NUL bytes); check the file or "
                "its extension"
            )
        if path.suffix.lower() == ".tsv":
            options.setdefault("sep", "\t")
    try:
        if kind == "csv":
            table = pd.read_csv(path, **options)
        else:
            table = pd.read_parquet(path, **options)
    except pd.errors.EmptyDataError:
        raise DataError(
            f"{path} is empty; expected a table with a header and rows"
        ) from None
    except UnicodeDecodeError as exc:
        raise DataError(
            f"cannot read {path} as CSV: it is not UTF-8 text ({exc}); pass the encoding, "
            "e.g. read_table(path, encoding='latin-1')"
        ) from None
    except (ValueError, OSError, pa.ArrowException, EOFError) as exc:
        raise DataError(
            f"cannot read {path} as {kind.upper()} ({type(exc).__name__}: {exc}); the file "
            "is damaged or not what its extension says"
        ) from None
    table = _drop_trailing_empty(table)
    if kind == "csv":
        table = _single_column_blanks(path, table, options, bool(compression))
    if len(table) == 0:
        raise DataError(
            f"{path} holds no rows (columns: {list(table.columns)}); expected a table "
            "with data"
        )
    return table


def _is_hdf5_mat(path: Path) -> bool:
    with path.open("rb") as f:
        head = f.read(520)
    return head.startswith(b"MATLAB 7.3") or head[512:520] == b"\x89HDF\r\n\x1a\n"


def read_mat(path: str | os.PathLike) -> dict[str, Any]:
    """Read the variables of a MATLAB ``.mat`` file (v4 to v7).

    Wraps :func:`scipy.io.loadmat` with ``simplify_cells=True``: singleton dimensions
    are squeezed (a ``(n, 1)`` column becomes a 1-D array, a ``1x1`` value a scalar),
    structs become dicts; the ``__header__``, ``__version__`` and ``__globals__`` entries
    are left out.

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
        A v7.3 (HDF5) file, which scipy cannot read (the message says so), or a damaged
        / non-MATLAB file, or one without variables.

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
            f"cannot read {path} as a MATLAB file ({type(exc).__name__}: {exc}); the file "
            "is damaged or not a .mat file"
        ) from None
    data = {k: v for k, v in raw.items() if not k.startswith("__")}
    if not data:
        raise DataError(f"{path} holds no variables")
    return data


def _npz_member(archive: Any, key: str, path: Path, errors: tuple) -> np.ndarray:
    try:
        return archive[key]
    except ValueError as exc:
        if "pickle" in str(exc):
            raise DataError(
                f"array {key!r} in {path} holds Python objects (pickled data); pdmkit "
                "reads numeric arrays only (allow_pickle=False). Re-save it with a "
                "numeric dtype"
            ) from None
        raise DataError(f"cannot read array {key!r} of {path} ({exc})") from None
    except errors as exc:
        raise DataError(
            f"cannot read array {key!r} of {path} ({type(exc).__name__}: {exc}); "
            "the archive is damaged"
        ) from None


def read_npz(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Read all arrays of a NumPy ``.npz`` archive, refusing pickled objects.

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
        A damaged or non-npz file, an archive without arrays, or an array of Python
        objects (``allow_pickle=False``: loading pickles can run arbitrary code).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "rec.npz"
    >>> np.savez(path, DE=np.zeros((4, 1)), FE=np.ones((4, 1)))
    >>> {k: v.shape for k, v in read_npz(path).items()}
    {'DE': (4, 1), 'FE': (4, 1)}
    """
    path = _existing_file(path, "a NumPy .npz archive")
    errors = (
        ValueError,
        OSError,
        EOFError,
        zipfile.BadZipFile,
        zlib.error,
        pickle.UnpicklingError,
        KeyError,
    )
    out: dict[str, np.ndarray] = {}
    # open the file here: numpy leaves its own handle open when the archive is broken
    with path.open("rb") as handle:
        try:
            loaded = np.load(handle, allow_pickle=False)
        except errors as exc:
            raise DataError(
                f"cannot read {path} as a NumPy .npz archive ({type(exc).__name__}: "
                f"{exc}); the file is damaged or not an .npz"
            ) from None
        if not isinstance(loaded, np.lib.npyio.NpzFile):
            raise DataError(
                f"{path} is a single .npy array, not an .npz archive; read it with "
                "numpy.load"
            )
        with loaded:
            for key in loaded.files:
                out[key] = _npz_member(loaded, key, path, errors)
    if not out:
        raise DataError(f"{path} holds no arrays")
    return out


# --------------------------------------------------------------------------- members
#: Names of a sampling-rate scalar in a .mat / .npz member file.
_FS_NAMES = ("fs", "Fs", "FS", "sampling_rate", "sample_rate")
#: Names of a time column in a CSV / Parquet member file.
_TIME_NAMES = ("time", "t", "Time", "TIME")
_MEMBER_ERRORS = ("member", "signal", "source", "error")


def _member_arrays(path: Path) -> tuple[dict[str, np.ndarray], float | None, dict]:
    """(signals, sampling rate or None, condition values) of one member file."""
    suffix = path.suffix.lower()
    if suffix in (".mat", ".npz"):
        data = read_mat(path) if suffix == ".mat" else read_npz(path)
        signals, fs, conditions = {}, None, {}
        for key, value in data.items():
            arr = np.asarray(value)
            if key in _FS_NAMES and arr.size == 1 and arr.dtype.kind in "iuf":
                fs = float(arr.reshape(-1)[0])
            elif arr.dtype.kind in "iuf" and arr.ndim >= 1 and arr.size > 1:
                if arr.ndim > 1 and sorted(arr.shape)[-2] != 1:
                    raise DataError(
                        f"{path}: variable {key!r} has shape {arr.shape}; a member "
                        "file holds 1-D signals (or n x 1 columns)"
                    )
                signals[key] = arr.reshape(-1).astype(np.float64)
            elif arr.size == 1 and arr.dtype.kind in "USiufb":
                conditions[key] = arr.reshape(-1)[0].item()
        return signals, fs, conditions
    table = read_table(path)
    fs = None
    time = next((c for c in _TIME_NAMES if c in table.columns), None)
    if time is not None:
        t = pd.to_numeric(table.pop(time), errors="coerce").to_numpy(dtype=float)
        dt = np.diff(t)
        if len(dt) and np.isfinite(dt).all() and (dt > 0).all():
            fs = 1.0 / float(np.median(dt))
    signals, conditions = {}, {}
    for c in table.columns:
        column = table[c]
        if pd.api.types.is_numeric_dtype(column) and not pd.api.types.is_bool_dtype(column):
            signals[str(c)] = column.to_numpy(dtype=np.float64)
        elif column.nunique(dropna=False) == 1:
            conditions[str(c)] = column.iloc[0]
        else:
            raise DataError(
                f"{path}: column {c!r} holds text that changes from row to row; a member "
                "file holds numeric signal columns, a time column and constant labels"
            )
    return signals, fs, conditions


def read_members(
    files: Any,
    *,
    fs: float | None = None,
    signals: Any = None,
    on_error: str = "raise",
    return_errors: bool = False,
):
    """Build an ensemble from member files: one recording per file.

    A member file is a CSV / Parquet table (numeric columns are signals, a ``time``
    column gives the sampling rate, constant text columns are condition variables such
    as the label), or a ``.mat`` / ``.npz`` file (numeric vectors are signals, a scalar
    ``fs`` gives the sampling rate, other scalars are conditions). The member id is the
    file name without its extension.

    With ``on_error="skip"`` a file that cannot be read, a member lacking a signal
    named in ``signals``, a signal with NaN or inf samples, or a sampling rate that
    differs from ``fs`` (default: the most common rate of the files) leaves that member
    out and adds a row to the errors table; the other members are read.

    Parameters
    ----------
    files : path, glob pattern or sequence of them
        Member files; a directory stands for all the files in it.
    fs : float, optional
        Expected sampling rate in Hz (required when no file states its own).
    signals : sequence of str, optional
        Signals every member must have (default: all found; a member lacking one gets
        None there).
    on_error : {"raise", "skip"}, default "raise"
    return_errors : bool, default False
        Also return the errors table (columns ``member``, ``signal``, ``source``,
        ``error``).

    Returns
    -------
    Ensemble, or (Ensemble, DataFrame) with ``return_errors``

    Raises
    ------
    pdmkit.errors.DataError
        With ``on_error="raise"``: the first bad file (the message names it and says
        what was expected and found). Always: no file matched, or no member was left.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> t = np.arange(100) / 50.0
    >>> pd.DataFrame({"time": t, "vib": np.sin(t), "fault": "ir"}).to_csv(
    ...     d / "a.csv", index=False)
    >>> pd.DataFrame({"time": t / 2, "vib": np.cos(t), "fault": "ok"}).to_csv(
    ...     d / "b.csv", index=False)
    >>> _ = (d / "c.csv").write_bytes(b"\\x00\\x01garbage")
    >>> ens, errors = read_members(d, fs=50.0, on_error="skip", return_errors=True)
    >>> ens.member_ids.tolist(), ens.conditions["fault"].tolist()
    (['a'], ['ir'])
    >>> errors["member"].tolist()
    ['b', 'c']
    >>> print(errors["error"].iloc[0])
    b.csv is sampled at 100 Hz; expected 50 Hz (fs as given); member skipped
    """
    import glob

    from pdmkit.ensembles._ensemble import Ensemble

    if on_error not in ("raise", "skip"):
        raise ValueError(f"on_error must be 'raise' or 'skip'; got {on_error!r}")
    patterns = [files] if isinstance(files, str | os.PathLike) else list(files)
    paths: list[Path] = []
    for p in patterns:
        p = Path(p)
        if p.is_dir():
            paths += sorted(q for q in p.iterdir() if q.is_file() and not q.name[0] == ".")
        elif any(ch in str(p) for ch in "*?["):
            paths += sorted(Path(q) for q in glob.glob(str(p)) if Path(q).is_file())
        else:
            paths.append(p)
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
    for path in paths:
        member = path.name.split(".")[0]
        try:
            arrays, rate, conds = _member_arrays(path)
        except DataError as exc:
            fail(member, None, path, str(exc))
            continue
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
        kept.append((member, arrays, conds))
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
