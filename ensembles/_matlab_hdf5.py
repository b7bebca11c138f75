"""MATLAB v7.3 ``.mat`` files (HDF5 with a 512-byte MATLAB header), read with h5py.

MATLAB writes each variable as an HDF5 dataset (or a group, for a struct) at the root,
its class in the attribute ``MATLAB_class``, its dimensions reversed (HDF5 stores
row-major); a cell array is a dataset of object references into the group ``#refs#``;
an empty array stores its dimensions (attribute ``MATLAB_empty``). Read here:
numeric and logical arrays, char text, structs (of anything read here), cell arrays;
a MATLAB object (a table, a string, ...) saved in a v7.3 file is named as not read.

The file is untrusted. Before any variable is read, every dataset in it is checked:
its declared size and chunk size against the ceiling, and all of them together; a
dataset stored in other files (external storage, virtual datasets), a soft or
external link, a variable-length dataset, or a compression filter HDF5 would load as
a plugin is refused. While reading, every array read counts against the same ceiling,
so references to one array from many cells cannot multiply it; references nest at
most :data:`MAX_DEPTH` deep and must resolve to an object of the same file.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from pdmkit.ensembles._limits import _too_big, _why
from pdmkit.ensembles._matlab_tables import UnreadObject
from pdmkit.ensembles._matlab_v5 import MatVariable
from pdmkit.errors import DataError

__all__ = ["read_mat73"]

#: MATLAB's numeric classes (and logical) as v7.3 files name them.
_NUMERIC = (
    "double",
    "single",
    "int8",
    "uint8",
    "int16",
    "uint16",
    "int32",
    "uint32",
    "int64",
    "uint64",
    "logical",
)
#: HDF5's own filters: deflate, shuffle, fletcher32, szip, nbit, scale-offset.
_BUILTIN_FILTERS = (1, 2, 3, 4, 5, 6)
#: Deepest nesting of structs and cells followed.
MAX_DEPTH = 64
_INTERNAL = ("#refs#", "#subsystem#")
_AGAIN = (
    "re-save it in MATLAB (save(file, '-v7.3')), or with save(file, '-v7') when its "
    "variables are under 2 GB"
)


def _h5py():
    try:
        import h5py
    except ImportError:
        raise DataError(
            "reading MATLAB v7.3 (HDF5) .mat files needs the h5py package: pip install "
            "h5py; or re-save the file in MATLAB with save(file, '-v7')"
        ) from None
    return h5py


def _attr(obj: Any, name: str) -> Any:
    """A small fixed-size attribute's value, or None.

    Variable-length attributes (MATLAB writes one, a struct's field order, which is
    not needed) and large ones are never read: decoding a damaged one can make HDF5
    loop or allocate without bound.
    """
    if name not in obj.attrs:
        return None
    aid = obj.attrs.get_id(name)
    if aid.dtype.kind == "O" or aid.get_storage_size() > 4096:
        return None
    return obj.attrs[name]


def _text(value: Any) -> str:
    if isinstance(value, bytes | np.bytes_):
        return value.decode("latin-1")
    return str(value) if value is not None else ""


def _check_file(h5py: Any, f: Any, path: Path, limit: int) -> None:
    """Refuse what cannot be read safely, before any variable is read (see module)."""
    links: list[tuple[str, Any]] = []
    f.id.links.visit(lambda name, info: links.append((name, info.type)), info=True)
    for name, kind in links:  # checked outside the callback: HDF5 cannot raise there
        if kind != h5py.h5l.TYPE_HARD:
            raise DataError(
                f"{path}: {name.decode('utf-8', 'replace')!r} is a soft or external HDF5 "
                f"link, which MATLAB never writes and pdmkit does not follow; {_AGAIN}"
            )
    datasets: list[tuple[str, Any]] = []
    f.visititems(
        lambda name, obj: (
            datasets.append((name, obj)) if isinstance(obj, h5py.Dataset) else None
        )
    )
    total = 0
    for name, obj in datasets:
        total += _check_dataset(h5py, obj, f"{path}: HDF5 dataset {name!r}", limit)
    if total > limit:
        raise _too_big(f"{path}: its datasets together", total, limit)


def _check_dataset(h5py: Any, obj: Any, where: str, limit: int) -> int:
    """The bytes a dataset declares, after refusing what cannot be read safely."""
    plist = obj.id.get_create_plist()
    if obj.is_virtual or plist.get_external_count():
        raise DataError(
            f"{where} keeps its data in other files (a virtual or external dataset), "
            f"which pdmkit does not follow; {_AGAIN}"
        )
    filters = [plist.get_filter(i)[0] for i in range(plist.get_nfilters())]
    odd = [i for i in filters if i not in _BUILTIN_FILTERS]
    if odd:
        raise DataError(
            f"{where} is compressed with HDF5 filter {odd[0]}, which needs a plugin; "
            f"pdmkit reads HDF5's own compression (zlib) only. {_AGAIN}"
        )
    is_ref = h5py.check_dtype(ref=obj.dtype)
    if obj.dtype.kind == "O" and is_ref is not h5py.Reference:
        raise DataError(
            f"{where} holds variable-length data or region references, which MATLAB "
            f"never writes; {_AGAIN}"
        )
    declared = obj.size * obj.dtype.itemsize
    chunk = math.prod(obj.chunks) * obj.dtype.itemsize if obj.chunks else 0
    if max(declared, chunk) > limit:
        raise _too_big(f"{where} (shape {obj.shape})", max(declared, chunk), limit)
    return declared


class _Reader:
    """Reads variables of an open, checked v7.3 file; counts what it reads."""

    def __init__(self, h5py: Any, f: Any, path: Path, limit: int) -> None:
        self.h5py, self.f, self.path, self.limit = h5py, f, path, limit
        self.used = 0

    def _read(self, obj: Any, where: str) -> np.ndarray:
        """A dataset's data, counted against the ceiling."""
        size = obj.size * obj.dtype.itemsize
        if self.used + size > self.limit:
            raise _too_big(
                f"{where}: what its references point to", self.used + size, self.limit
            )
        self.used += size
        return obj[()]

    def value(self, obj: Any, where: str, depth: int = 0) -> Any:
        """One MATLAB value (dataset or group) in the forms ``read_mat`` returns."""
        if depth > MAX_DEPTH:
            raise DataError(f"{where}: structs and cells nest deeper than {MAX_DEPTH}")
        cls = _text(_attr(obj, "MATLAB_class"))
        if "MATLAB_object_decode" in obj.attrs and cls not in ("struct", "cell"):
            return UnreadObject(cls or "opaque", "saved in a v7.3 file; " + _OBJECTS)
        if "MATLAB_sparse" in obj.attrs:
            return UnreadObject("sparse", "pdmkit reads dense arrays")
        if isinstance(obj, self.h5py.Group):
            return self._struct(obj, where, depth)
        if not isinstance(obj, self.h5py.Dataset):
            raise DataError(
                f"{where} is an HDF5 {type(obj).__name__}, which MATLAB never writes"
            )
        empty = _attr(obj, "MATLAB_empty")
        if empty is not None and np.asarray(empty).any():
            return self._empty(obj, cls, where)
        if cls == "cell":
            return self._cell(obj, where, depth)
        if cls == "char":
            return self._char(self._read(obj, where))
        if cls in _NUMERIC:
            return self._numeric(self._read(obj, where), cls)
        return UnreadObject(cls or "unknown", "pdmkit does not read this MATLAB class")

    def _empty(self, obj: Any, cls: str, where: str) -> Any:
        dims = np.asarray(self._read(obj, where)).reshape(-1) if obj.size <= 32 else None
        if dims is None or dims.size == 0 or np.prod(dims.astype(float)) != 0:
            raise DataError(
                f"{where}: an empty array declares the dimensions {dims}; damaged"
            )
        if cls == "char":
            return ""
        if cls in ("cell", "struct"):
            return [] if cls == "cell" else {}
        dtype = bool if cls == "logical" else (cls if cls in _NUMERIC else float)
        return np.squeeze(np.empty(tuple(int(d) for d in dims), dtype=dtype))

    @staticmethod
    def _numeric(arr: np.ndarray, cls: str) -> Any:
        if arr.dtype.names and {"real", "imag"} <= set(arr.dtype.names):
            arr = arr["real"] + 1j * arr["imag"]
        if cls == "logical":
            arr = arr.astype(bool)
        squeezed = np.squeeze(arr.T)
        return squeezed.item() if squeezed.ndim == 0 else squeezed

    @staticmethod
    def _char(arr: np.ndarray) -> Any:
        """UTF-16 code units, rows of a MATLAB char matrix, as ``str`` (one row)."""
        rows = np.atleast_2d(np.asarray(arr, dtype=np.uint16).T)
        text = [r.astype("<u2").tobytes().decode("utf-16-le", "replace") for r in rows]
        return text[0] if len(text) == 1 else np.array(text, dtype=object)

    def _deref(self, ref: Any, where: str) -> Any:
        try:
            if not ref:
                raise ValueError("a null reference")
            return self.f[ref]
        except (ValueError, KeyError, TypeError, RuntimeError, OSError) as exc:
            raise DataError(
                f"{where} holds an HDF5 object reference that cannot be resolved "
                f"({_why(exc)}); the file is damaged or was not written by MATLAB: "
                f"{_AGAIN}"
            ) from None

    def _cell(self, obj: Any, where: str, depth: int) -> np.ndarray:
        refs = self._read(obj, where)
        items = [
            self.value(self._deref(r, where), f"{where}{{{k + 1}}}", depth + 1)
            for k, r in enumerate(np.asarray(refs).T.ravel("F"))
        ]
        out = np.empty(len(items), dtype=object)
        out[:] = items
        return out

    def _struct(self, group: Any, where: str, depth: int) -> Any:
        names = list(group.keys())  # MATLAB_fields' order is not read (see _attr)
        fields = {n: group[n] for n in names}
        scalar = any(
            isinstance(o, self.h5py.Group) or "MATLAB_class" in o.attrs
            for o in fields.values()
        )
        if scalar or not fields:
            return {n: self.value(o, f"{where}.{n}", depth + 1) for n, o in fields.items()}
        refs = {
            n: np.asarray(self._read(o, f"{where}.{n}")).T.ravel("F")
            for n, o in fields.items()
        }
        count = min(len(r) for r in refs.values())
        rows = [
            {
                n: self.value(
                    self._deref(r[k], f"{where}.{n}"), f"{where}({k + 1}).{n}", depth + 1
                )
                for n, r in refs.items()
            }
            for k in range(count)
        ]
        return rows[0] if len(rows) == 1 else rows


_OBJECTS = (
    "pdmkit reads MATLAB tables, timetables, strings and categoricals from v7 files: "
    "re-save it with save(file, 'name', '-v7'), or save its contents as numeric arrays"
)


def _dims(obj: Any, h5py: Any) -> tuple[int, ...]:
    objects = "MATLAB_empty" in obj.attrs or "MATLAB_object_decode" in obj.attrs
    if isinstance(obj, h5py.Dataset) and not objects:  # an object's shape is its metadata
        return tuple(reversed(obj.shape))
    return ()


def read_mat73(path: str | os.PathLike, limit: int) -> tuple[dict[str, Any], list]:
    """Read the variables of a MATLAB v7.3 (HDF5) file, and list them.

    Parameters
    ----------
    path : path-like
        An existing file (``read_mat`` checks that).
    limit : int
        The ceiling on the bytes read (``max_bytes("member")``).

    Returns
    -------
    (dict, list of MatVariable)
        Name -> value in the forms of ``read_mat`` (a ``1x1`` array a Python number,
        a struct a dict, a cell an object array, text a ``str``); and what the file
        holds (name, MATLAB class, dimensions), in the file's order.

    Examples
    --------
    >>> import tempfile, pathlib, h5py
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "v73.mat"
    >>> with h5py.File(path, "w", userblock_size=512) as f:
    ...     f["u"] = np.arange(3.0).reshape(3, 1)
    ...     f["u"].attrs["MATLAB_class"] = np.bytes_("double")
    >>> data, listing = read_mat73(path, 1 << 20)
    >>> data["u"].tolist(), listing[0].describe()
    ([0.0, 1.0, 2.0], "'u' (double 1x3)")
    """
    h5py = _h5py()
    path = Path(path)
    try:
        f = h5py.File(path, "r")
    except (OSError, ValueError) as exc:
        raise DataError(
            f"cannot read {path} as a MATLAB v7.3 (HDF5) file ({_why(exc)}); the file "
            "is damaged or not a .mat file"
        ) from None
    data: dict[str, Any] = {}
    listing: list[MatVariable] = []
    with f:
        try:
            _check_file(h5py, f, path, limit)
            reader = _Reader(h5py, f, path, limit)
            for name in f:
                if name in _INTERNAL:
                    continue
                obj = f[name]
                cls = _text(_attr(obj, "MATLAB_class")) or "unknown"
                listing.append(MatVariable(name, 0, cls, _dims(obj, h5py)))
                data[name] = reader.value(obj, f"{path}: variable {name!r}")
        except DataError:
            raise
        except (
            OSError,
            ValueError,
            KeyError,
            TypeError,
            RuntimeError,
            AttributeError,
        ) as exc:
            raise DataError(
                f"cannot read {path} as a MATLAB v7.3 file ({_why(exc)}); the file is "
                "damaged or not a .mat file"
            ) from None
    if not listing:
        raise DataError(f"{path} holds no variables")
    return data, listing
