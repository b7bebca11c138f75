"""Input/output records from tables and MATLAB / NumPy files, for identification.

:func:`read_record` takes two columns (or variables) and a sampling rate from a CSV,
Parquet, ``.mat`` or ``.npz`` file, whatever the file calls them.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from pdmkit._checks import check_fs, check_magnitude, uniform_step
from pdmkit.ensembles import read_mat, read_npz, read_table
from pdmkit.errors import DataError

__all__ = ["read_record"]


# --------------------------------------------------------------------------- reading
def _numeric(x, path, name: str, role: str) -> np.ndarray:
    if isinstance(x, pd.Series):
        x = pd.to_numeric(x, errors="coerce").to_numpy(dtype=float)
    try:
        x = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise DataError(
            f"{path}: {role} {name!r} is not numeric (found {type(x).__name__})."
        ) from None
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        raise DataError(
            f"{path}: {role} {name!r} has {bad.size} missing or non-numeric value(s), "
            f"the first in row {int(bad[0])}; clean or interpolate them."
        )
    check_magnitude(x, f"{path}: {role} {name!r}")
    if role in ("input", "output") and x.size and np.ptp(x) == 0:
        raise DataError(
            f"{path}: {role} column {name!r} is constant ({x[0]:g}); there is nothing "
            "to identify from it."
        )
    return x


def _column(table: pd.DataFrame, name: str, path, role: str) -> np.ndarray:
    if name not in table.columns:
        raise DataError(
            f"{path}: no {role} column {name!r}; the table has {list(table.columns)}."
        )
    return _numeric(table[name], path, name, role)


def _signals(data: dict) -> dict[str, tuple]:
    """Names of the 1-D signals in a ``.mat``/``.npz`` dict -> (variable, channel)."""
    out: dict[str, tuple] = {}
    for key, val in data.items():
        arr = np.asarray(val) if not isinstance(val, dict) else None
        if arr is None or arr.dtype.kind not in "biuf" or arr.size < 2:
            continue
        arr = np.squeeze(arr)
        if arr.ndim == 1:
            out[key] = (key, None)
        elif arr.ndim == 2:
            for i in range(min(arr.shape)):
                out[f"{key}{i + 1}"] = (key, i)
                out[f"{key}[{i}]"] = (key, i)
    return out


def _variable(data: dict, name: str, path, role: str) -> np.ndarray:
    """One signal of a ``.mat``/``.npz`` file.

    Named ``Name``, or ``Name2`` (1-based) or ``Name[1]`` (0-based) for a row/column of a
    2-D variable.
    """
    names = _signals(data)
    if name not in names:
        shown = [k for k in names if "[" not in k]
        multi = [
            f"{k} ({min(np.shape(np.squeeze(v)))} channels: {k}1..)"
            for k, v in data.items()
            if not isinstance(v, dict) and np.ndim(np.squeeze(np.asarray(v))) == 2
        ]
        hint = f"; 2-D variables: {', '.join(multi)}" if multi else ""
        raise DataError(f"{path}: no {role} variable {name!r}; the file has {shown}{hint}.")
    key, ch = names[name]
    arr = np.squeeze(np.asarray(data[key]))
    if ch is not None:
        arr = arr[ch] if arr.shape[0] <= arr.shape[1] else arr[:, ch]
    return _numeric(arr, path, name, role)


def _file_rate(data: dict, path) -> float | None:
    for key in ("fs", "Fs", "FS", "fsamp"):
        if key in data and np.size(data[key]) == 1:
            return check_fs(float(np.squeeze(data[key])), f"{path}: {key}")
    for key in ("Ts", "ts", "dt", "Ts_s"):
        if key in data and np.size(data[key]) == 1:
            return 1.0 / check_fs(float(np.squeeze(data[key])), f"{path}: {key}")
    for key in ("time", "t"):
        if key in data and np.size(data[key]) > 1:
            t = _numeric(np.ravel(data[key]), path, key, "time")
            return 1.0 / uniform_step(t, str(path))
    return None


def read_record(
    path: str | os.PathLike, input: str | None, output: str, fs: float | None = None
) -> tuple[np.ndarray | None, np.ndarray, float]:
    """Input, output and sampling rate from a CSV/Parquet table or a ``.mat``/``.npz``.

    Tables go through :func:`pdmkit.ensembles.read_table`, MATLAB and NumPy files
    through :func:`~pdmkit.ensembles.read_mat` / :func:`~pdmkit.ensembles.read_npz`.
    In a ``.mat``/``.npz`` file a row (or column) of a 2-D variable is a signal of
    its own, named ``Name1``, ``Name2``, ... (1-based, as the F-16 benchmark names
    its accelerometers) or ``Name[0]``, ... (0-based). The sampling rate is ``fs``
    when given, else the file's ``fs``/``Fs`` (or ``1/Ts``) variable, else its
    uniform ``time`` column or variable.

    Parameters
    ----------
    path : path
    input : str or None
        Input signal name (None: no input, an AR model).
    output : str
    fs : float, optional

    Returns
    -------
    (u, y, fs)

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import numpy as np
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "rig.npz"
    >>> np.savez(path, force=np.arange(8.0), acc=np.arange(16.0).reshape(2, 8), fs=50.0)
    >>> u, y, rate = read_record(path, "force", "acc2")
    >>> y[:3], rate
    (array([ 8.,  9., 10.]), 50.0)
    """
    suffix = Path(path).suffix.lower()
    if suffix in (".mat", ".npz"):
        data = read_mat(path) if suffix == ".mat" else read_npz(path)
        y = _variable(data, output, path, "output")
        u = None if input is None else _variable(data, input, path, "input")
        rate = check_fs(fs) if fs is not None else _file_rate(data, path)
        if rate is None:
            raise DataError(
                f"{path}: no sampling rate: the file has no fs/Fs, Ts or time "
                f"variable (it has {sorted(data)}); pass --fs."
            )
    else:
        table = read_table(path)
        if len(table) == 0:
            raise DataError(f"{path}: the table has no rows.")
        rate = _sampling_rate(table, fs, path)
        y = _column(table, output, path, "output")
        u = None if input is None else _column(table, input, path, "input")
    if u is not None and u.shape != y.shape:
        raise DataError(
            f"{path}: input {input!r} has {u.size} samples but output {output!r} "
            f"{y.size}; they must be one record."
        )
    return u, y, rate


def _sampling_rate(table: pd.DataFrame, fs, path) -> float:
    if fs is not None:
        return check_fs(fs)
    if "time" not in table.columns:
        raise DataError(
            f"{path}: no 'time' column to take the sampling rate from; add one (s) or "
            "pass fs (--fs)."
        )
    return 1.0 / uniform_step(_column(table, "time", path, "time"), str(path))
