"""MATLAB objects in ``.mat`` files: tables, timetables, strings, categoricals, times.

MATLAB saves these classes as MCOS objects ("opaque" arrays whose contents live in the
file's subsystem); ``scipy.io.loadmat`` cannot read them. The file is parsed by the
field's reader, the ``mat-io`` package (import ``matio``), with ``raw_data=True``: it
returns each object's saved properties and converts nothing. The conversion is done
here, checked against the ceiling and against the data actually present (``mat-io``'s
own converters build a timetable's row times from the row count it declares):

- ``table`` -> :class:`pandas.DataFrame` (``attrs["matlab_class"] == "table"``), its
  variables as columns (an ``n x k`` variable split into ``name_1`` ... ``name_k``),
  MATLAB's original variable names (``Settings.Load``);
- ``timetable`` -> a DataFrame indexed by its row times (``TimedeltaIndex`` for
  durations, ``DatetimeIndex`` for datetimes), ``attrs["sample_rate"]`` when it was
  made with a sample rate or time step;
- ``string`` -> ``str`` (one) or an object array of ``str`` (``None`` for
  ``<missing>``); ``categorical`` -> ``str`` (one) or :class:`pandas.Categorical`;
  ``duration`` / ``datetime`` -> ``pandas.Timedelta`` / ``Timestamp`` (one) or
  ``timedelta64[ns]`` / ``datetime64[ns]`` arrays;
- any other class -> :class:`UnreadObject`, which names it.

Nothing in a file runs code: ``mat-io`` decodes data only and never unpickles.
"""

from __future__ import annotations

import math
import os
import warnings
from typing import Any

import numpy as np
import pandas as pd

from pdmkit.ensembles._limits import _why
from pdmkit.errors import DataError

__all__ = ["UnreadObject", "read_mat_objects"]

#: The MATLAB classes converted here.
READ_CLASSES = ("table", "timetable", "string", "categorical", "datetime", "duration")
#: Deepest nesting of objects in objects followed (tables of timetables nest two).
_MAX_DEPTH = 32
#: mat-io's raw types that hold no data pdmkit reads, by their Python class name.
_OPAQUE_TYPES = ("MatlabOpaque",)
_OTHER_TYPES = {
    "MatlabFunction": "function_handle",
    "MatlabObject": "object",
    "MatlabContainerMap": "containers.Map",
    "MatlabEnumerationArray": "enumeration",
}


class UnreadObject:
    """A MATLAB object of a class pdmkit does not read; it names the class and why.

    Examples
    --------
    >>> UnreadObject("containers.Map")
    <MATLAB containers.Map object: not read>
    """

    def __init__(self, classname: str, why: str = "") -> None:
        self.classname = str(classname)
        self.why = why

    def __repr__(self) -> str:
        return f"<MATLAB {self.classname} object: not read{self.why and ': ' + self.why}>"


def _matio():
    """The ``matio`` module (package ``mat-io``), or a DataError saying to install it.

    Importing it sets pandas' ``future.infer_string`` option (deprecated in pandas 3,
    where it is the default; a change of behaviour in pandas 2): the option is put
    back as it was, and the deprecation warning is not shown.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            before = pd.get_option("future.infer_string")
        except (KeyError, pd.errors.OptionError):
            before = None
        try:
            import matio
        except ImportError:
            raise DataError(
                "reading MATLAB tables, timetables, strings and categoricals needs the "
                "mat-io package: pip install mat-io"
            ) from None
        if before is not None:
            pd.set_option("future.infer_string", before)
    return matio


def read_mat_objects(
    path: str | os.PathLike, names: list[str], classes: dict[str, str], limit: int
) -> dict[str, Any]:
    """Read and convert the object variables ``names`` of a checked v5 / v7.3 file.

    ``classes`` maps each name to its MATLAB class (for messages); the file's sizes
    must have been checked already. A variable ``mat-io`` could not decode comes back
    as an :class:`UnreadObject` saying so.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> matio = _matio()  # imported without its pandas option warning
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "t.mat"
    >>> matio.save_to_mat(path, {"t": pd.DataFrame({"x": [1.0, 2.0]})}, version="v7")
    >>> read_mat_objects(path, ["t"], {"t": "table"}, 1 << 20)["t"]["x"].tolist()
    [1.0, 2.0]
    """
    matio = _matio()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            raw = matio.load_from_mat(path, variable_names=list(names), raw_data=True)
        except (RecursionError, MemoryError) as exc:
            raise DataError(
                f"cannot read {path} as a MATLAB file ({_why(exc)}); the file is "
                "damaged or not a .mat file"
            ) from None
        except Exception as exc:  # mat-io raises what its parser meets
            raise DataError(
                f"cannot read the MATLAB objects of {path} ({_why(exc)}); the file is "
                "damaged, or saved by a MATLAB release mat-io does not read: re-save "
                "the variables as numeric arrays"
            ) from None
    trouble = "; ".join(" ".join(str(w.message).split()) for w in caught)[:300]
    out = {}
    for name in names:
        value = raw.get(name)
        if not _is_object(value):
            why = f"mat-io could not decode it ({trouble or 'no data'})"
            out[name] = UnreadObject(classes.get(name, "opaque"), why)
            continue
        out[name] = convert(value, f"{path}: variable {name!r}", limit)
    return out


def _is_object(value: Any) -> bool:
    name = type(value).__name__
    return name in _OPAQUE_TYPES or name == "MatlabOpaqueArray" or name in _OTHER_TYPES


def convert(value: Any, where: str, limit: int, depth: int = 0) -> Any:
    """A value mat-io read in raw mode, as plain Python / numpy / pandas values.

    Structs become dicts (a struct array a list of dicts), cells object arrays,
    numeric arrays are squeezed (a ``1x1`` one a Python number), char arrays ``str``:
    the forms of ``scipy.io.loadmat(..., simplify_cells=True)``.
    """
    if depth > _MAX_DEPTH:
        raise DataError(f"{where}: objects nest deeper than {_MAX_DEPTH} levels; damaged")
    kind = type(value).__name__
    if kind in _OPAQUE_TYPES:
        return _object(value, where, limit, depth)
    if kind == "MatlabOpaqueArray":
        items = [_object(v, where, limit, depth) for v in np.asarray(value).ravel("F")]
        return items[0] if len(items) == 1 else _objects(items)
    if kind in _OTHER_TYPES:
        return UnreadObject(getattr(value, "classname", None) or _OTHER_TYPES[kind])
    if kind == "MatlabCanonicalEmpty" or kind == "EmptyMatStruct":
        return {} if kind == "EmptyMatStruct" else np.empty(0)
    if not isinstance(value, np.ndarray):
        return value  # sparse matrices, and what else mat-io returns as is
    if value.dtype.names:
        rows = [
            {f: convert(r[f], where, limit, depth + 1) for f in value.dtype.names}
            for r in value.ravel("F")
        ]
        return rows[0] if len(rows) == 1 else rows
    if value.dtype.kind == "O":
        return _objects([convert(v, where, limit, depth + 1) for v in value.ravel("F")])
    if value.dtype.kind in "UST":
        text = [str(s) for s in value.ravel()]
        return (text[0] if text else "") if value.size <= 1 else np.array(text, object)
    squeezed = np.squeeze(value)
    return squeezed.item() if squeezed.ndim == 0 else squeezed


def _objects(items: list) -> np.ndarray:
    out = np.empty(len(items), dtype=object)
    out[:] = items
    return out


def _object(value: Any, where: str, limit: int, depth: int) -> Any:
    """One MCOS object (mat-io's ``MatlabOpaque``) converted, or an UnreadObject."""
    classname = str(getattr(value, "classname", "") or "opaque")
    props = getattr(value, "properties", None)
    if classname not in READ_CLASSES:
        return UnreadObject(classname)
    if not isinstance(props, dict):
        return UnreadObject(classname, "its properties could not be decoded")
    where = f"{where} ({classname})"
    try:
        if classname == "table":
            return _table(props, where, limit, depth)
        if classname == "timetable":
            return _timetable(props, where, limit, depth)
        if classname == "string":
            return _string(props, where)
        if classname == "categorical":
            return _categorical(props, where)
        times = _duration(props) if classname == "duration" else _datetime(props)
        return _one_or_array(times)
    except DataError:
        raise
    except (KeyError, IndexError, TypeError, ValueError, AttributeError) as exc:
        raise DataError(
            f"{where} is damaged or saved by a MATLAB release pdmkit does not read "
            f"({_why(exc)}); re-save it, or save its contents as numeric arrays"
        ) from None


def _scalar(value: Any) -> float:
    return float(np.asarray(value, dtype=float).reshape(-1)[0])


def _field(record: Any, name: str, default: Any = None) -> Any:
    """Field ``name`` of a 1x1 struct (a numpy record array), or ``default``."""
    if isinstance(record, np.ndarray) and record.dtype.names and name in record.dtype.names:
        return record.reshape(-1)[0][name]
    return default


def _flag(record: Any, name: str) -> bool:
    value = _field(record, name)
    return (
        value is not None and np.asarray(value).size > 0 and bool(np.asarray(value).all())
    )


def _names(cells: Any) -> list[str]:
    """The strings of a cell array of char vectors."""
    return [
        "".join(str(s) for s in np.asarray(c).ravel()) for c in np.asarray(cells).ravel("F")
    ]


def _count(value: Any, what: str, where: str, limit: int) -> int:
    n = _scalar(value)
    if not (math.isfinite(n) and n >= 0 and n == int(n)) or n * 8 > limit:
        raise DataError(f"{where} declares {n:g} {what}; damaged")
    return int(n)


def _columns(
    names: list[str], data: Any, nrows: int, where: str, limit: int, depth: int
) -> dict[str, Any]:
    """The columns of a table's variables (``data``: a 1 x nvars cell), ``nrows`` long."""
    cells = np.asarray(data, dtype=object).ravel("F")
    if len(cells) != len(names):
        raise DataError(f"{where} names {len(names)} variables but holds {len(cells)}")
    out: dict[str, Any] = {}
    for name, raw in zip(names, cells, strict=True):
        if isinstance(raw, np.ndarray) and raw.dtype.kind == "O" and not raw.dtype.names:
            cols = raw.reshape(raw.shape[0] if raw.ndim else 1, -1)  # a cell: a value a row
            parts = {
                name if cols.shape[1] == 1 else f"{name}_{j + 1}": _objects(
                    [convert(v, where, limit, depth + 1) for v in cols[:, j]]
                )
                for j in range(cols.shape[1])
            }
        else:
            parts = _split(name, convert(raw, where, limit, depth + 1), raw, nrows)
        for key, values in parts.items():
            if len(values) != nrows:
                raise DataError(
                    f"{where}: variable {key!r} has {len(values)} rows, the table {nrows}"
                )
            out[_unique(key, out)] = values
    return out


def _split(name: str, value: Any, raw: Any, nrows: int) -> dict[str, Any]:
    """A table variable as columns: ``name``, or ``name_1`` ... for ``n x k`` arrays."""
    if isinstance(value, pd.DataFrame):  # a table in a table: its variables
        return {f"{name}_{c}": value[c].to_numpy() for c in value.columns}
    if isinstance(value, pd.Categorical):
        return {name: value}
    if isinstance(value, list) and len(value) == nrows:  # a struct array: a row each
        return {name: _objects(value)}
    if isinstance(value, UnreadObject | dict | list):  # the same in every row
        return {name: _objects([value] * nrows)}
    plain = isinstance(raw, np.ndarray) and raw.dtype.kind in "biufcUS"
    arr = raw if plain else np.asarray(value)  # numbers: rows x columns, unsqueezed
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim == 2 and arr.shape[1] > 1:
        return {f"{name}_{j + 1}": arr[:, j] for j in range(arr.shape[1])}
    return {name: arr.reshape(len(arr), -1)[:, 0] if arr.ndim > 1 else arr}


def _unique(key: str, taken: dict) -> str:
    k, name = 1, key
    while name in taken:
        name, k = f"{key}_{k}", k + 1
    return name


def _table(props: dict, where: str, limit: int, depth: int) -> pd.DataFrame:
    """A MATLAB table as a DataFrame."""
    attrs = props.get("props")
    nrows = _count(props["nrows"], "rows", where, limit)
    if _flag(attrs, "useVariableNames2048"):
        names = _names(_field(attrs, "VariableNames2048"))
    elif _flag(attrs, "useVariableNamesOriginal"):
        names = _names(_field(attrs, "VariableNamesOriginal"))
    else:
        names = _names(props["varnames"])
    columns = _columns(names, props["data"], nrows, where, limit, depth)
    rownames = props.get("rownames")
    index: pd.Index = pd.RangeIndex(nrows)
    if isinstance(rownames, np.ndarray) and rownames.size == nrows and nrows:
        index = pd.Index(_names(rownames))
    frame = pd.DataFrame(
        {k: pd.Series(v, index=index) for k, v in columns.items()}, index=index
    )
    frame.attrs["matlab_class"] = "table"
    return frame


def _timetable(props: dict, where: str, limit: int, depth: int) -> pd.DataFrame:
    """A MATLAB timetable as a DataFrame indexed by its row times."""
    tt = props.get("any")
    if _scalar(_field(tt, "minCompatibleVersion", 0)) > 7:
        raise DataError(
            f"{where} was saved by a newer MATLAB release than pdmkit reads (timetable "
            f"version {_scalar(_field(tt, 'versionSavedFrom', 0)):g}); re-save it with "
            "save(..., '-v7') from a release of 2025 or older"
        )
    nrows = _count(_field(tt, "numRows"), "rows", where, limit)
    if _flag(tt, "useVarNames2048"):
        names = _names(_field(tt, "varNames2048"))
    elif _flag(tt, "useVarNamesOrig"):
        names = _names(_field(tt, "varNamesOrig"))
    else:
        names = _names(_field(tt, "varNames"))
    columns = _columns(names, _field(tt, "data"), nrows, where, limit, depth)
    times, rate = _row_times(_field(tt, "rowTimes"), nrows, where, limit, depth)
    dims = _names(_field(tt, "dimNames", np.array([["Time"]], dtype=object)))
    times.name = dims[0] if dims else "Time"
    frame = pd.DataFrame(
        {k: pd.Series(v, index=times) for k, v in columns.items()}, index=times
    )
    frame.attrs["matlab_class"] = "timetable"
    if rate is not None:
        frame.attrs["sample_rate"] = rate
    return frame


def _row_times(
    raw: Any, nrows: int, where: str, limit: int, depth: int
) -> tuple[pd.Index, float | None]:
    """A timetable's row times, and its sample rate when it was made with one."""
    if type(raw).__name__ in _OPAQUE_TYPES:
        times = _times(raw, where).reshape(-1)
        if times.size != nrows:
            raise DataError(f"{where} has {times.size} row times for {nrows} rows")
        return pd.Index(times), None
    origin = _times(_field(raw, "origin"), where).reshape(-1)
    if origin.size != 1:
        raise DataError(f"{where}: its first row time is no single time; damaged")
    if _flag(raw, "specifiedAsRate"):
        rate = _scalar(_field(raw, "sampleRate"))
        if not (math.isfinite(rate) and rate > 0):
            raise DataError(f"{where} declares the sample rate {rate:g} Hz; damaged")
        step_ns = 1e9 / rate
    else:
        step = _times(_field(raw, "stepSize"), where, "a fixed duration").reshape(-1)
        if step.size != 1 or step.dtype.kind != "m" or not step[0] > np.timedelta64(0):
            raise DataError(f"{where}: its time step is not one positive duration")
        step_ns = float(step[0].astype(np.int64))
        rate = 1e9 / step_ns
    offsets = (
        np.round(np.arange(nrows) * step_ns).astype(np.int64).astype("timedelta64[ns]")
    )
    return pd.Index(origin[0] + offsets), rate


def _times(raw: Any, where: str, what: str = "times") -> np.ndarray:
    """A duration or datetime object's values as timedelta64 / datetime64 [ns]."""
    classname = getattr(raw, "classname", None)
    props = getattr(raw, "properties", None)
    if classname in ("duration", "datetime") and isinstance(props, dict):
        return _duration(props) if classname == "duration" else _datetime(props)
    raise DataError(
        f"{where}: its row times are {classname or type(raw).__name__}, not {what}; "
        "pdmkit reads timetables with durations or datetimes as row times, or a "
        "sample rate or time step of a fixed duration (not calendar months or days)"
    )


def _string(props: dict, where: str) -> Any:
    """A MATLAB string array: ``[version, ndims, dims..., char counts..., UTF-16]``."""
    data = props.get("any")
    if not isinstance(data, np.ndarray) or data.size == 0:
        return np.empty(0, dtype=object)
    v = data.reshape(-1)
    if int(v[0]) != 1:
        raise DataError(f"{where} was saved in a string format pdmkit does not read")
    ndims = int(v[1])
    dims = [int(d) for d in v[2 : 2 + ndims]]
    count = math.prod(dims)
    if ndims > 32 or 2 + ndims + count > v.size:
        raise DataError(f"{where} declares {count} strings in {v.size * 8} bytes; damaged")
    lengths = v[2 + ndims : 2 + ndims + count]
    text = v[2 + ndims + count :].tobytes()
    codec = "utf-16-be" if data.dtype.byteorder == ">" else "utf-16-le"
    out, pos = [], 0
    for n in lengths:
        if int(n) == 0xFFFFFFFFFFFFFFFF:  # <missing>
            out.append(None)
            continue
        if pos + 2 * int(n) > len(text):
            raise DataError(f"{where}: its text ends early; damaged")
        out.append(text[pos : pos + 2 * int(n)].decode(codec, errors="replace"))
        pos += 2 * int(n)
    return out[0] if count == 1 else _objects(out)


def _categorical(props: dict, where: str) -> Any:
    """A MATLAB categorical: category names and 1-based codes (0: undefined)."""
    names = _names(props["categoryNames"])
    codes = np.asarray(props["codes"]).astype(np.int64).ravel("F") - 1
    if codes.size and int(codes.max()) >= len(names):
        raise DataError(f"{where} has codes past its {len(names)} categories; damaged")
    if codes.size == 1:
        return names[int(codes[0])] if codes[0] >= 0 else None
    ordered = bool(np.asarray(props.get("isOrdinal", False)).all())
    return pd.Categorical.from_codes(codes, categories=names, ordered=ordered)


def _duration(props: dict) -> np.ndarray:
    """Milliseconds (``millis``) as ``timedelta64[ns]``; NaN and overflow as NaT."""
    millis = np.asarray(props["millis"], dtype=float)
    ns = millis * 1e6
    ok = np.isfinite(ns) & (np.abs(ns) < 2.0**62)
    out = np.where(ok, np.round(np.where(ok, ns, 0)), 0).astype(np.int64)
    out = out.astype("timedelta64[ns]")
    out[~ok] = np.timedelta64("NaT")
    return out


def _datetime(props: dict) -> np.ndarray:
    """Milliseconds since 1970 (``data``; complex: a double-double) as datetime64[ns]."""
    data = np.asarray(props["data"])
    real = data.real.astype(float)
    frac = data.imag.astype(float) if np.iscomplexobj(data) else 0.0
    ns = real * 1e6 + np.asarray(frac) * 1e6
    ok = np.isfinite(ns) & (np.abs(ns) < 2.0**62)
    out = np.where(ok, np.round(np.where(ok, ns, 0)), 0).astype(np.int64)
    out = out.astype("datetime64[ns]")
    out[~ok] = np.datetime64("NaT")
    return out


def _one_or_array(times: np.ndarray) -> Any:
    """One time as a pandas scalar, several as a squeezed array."""
    if times.size == 1:
        value = times.reshape(-1)[0]
        return pd.Timedelta(value) if times.dtype.kind == "m" else pd.Timestamp(value)
    return np.squeeze(times)
