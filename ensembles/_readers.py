"""Readers for the file formats recordings come in: CSV / Parquet tables, MATLAB, NumPy.

Every reader raises :class:`pdmkit.errors.DataNotFoundError` for a missing file and
:class:`pdmkit.errors.DataError` for one it cannot read, with the path in the message;
never a bare ``KeyError``, ``zipfile.BadZipFile`` or pickle error.
"""

from __future__ import annotations

import os
import pickle
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pdmkit.errors import DataError, DataNotFoundError

__all__ = ["read_mat", "read_npz", "read_table"]

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


def read_table(path: str | os.PathLike, **options: Any) -> pd.DataFrame:
    """Read a CSV or Parquet table into a DataFrame.

    CSV (``.csv``, ``.tsv`` tab-separated, ``.txt``; optionally ``.gz``/``.bz2``/...
    compressed) goes through :func:`pandas.read_csv`, Parquet (``.parquet``, ``.pq``)
    through :func:`pandas.read_parquet`. Columns named ``Unnamed: k`` that hold nothing
    (left by a delimiter at the end of every line) are dropped.

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
    except (MatReadError, ValueError, TypeError, OSError, EOFError, zlib.error) as exc:
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
