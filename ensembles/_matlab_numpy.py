"""MATLAB ``.mat`` (v4, v5/v7, v7.3) and NumPy ``.npz`` files, read within size limits.

MATLAB's numeric, logical, char, struct and cell arrays of v4-v7 files are read by
scipy; its objects (tables, timetables, strings, categoricals, datetimes, durations)
by ``mat-io`` (``_matlab_tables.py``); v7.3 (HDF5) files by h5py
(``_matlab_hdf5.py``).

Recordings are untrusted input. Every reader

- raises :class:`pdmkit.errors.DataNotFoundError` for a missing file and
  :class:`pdmkit.errors.DataError` for one it cannot read, with the path (and the array,
  variable or column) in a one-line message; never a bare ``KeyError``,
  ``zipfile.BadZipFile``, ``zlib.error`` or pickle error;
- checks the sizes a file *declares* before reading it, against
  :func:`pdmkit._config.max_bytes` ``("member")`` (1 GiB by default,
  ``$PDMKIT_MAX_MEMBER_BYTES``), so a small file that declares (or decompresses to) a
  huge array is refused before anything is allocated;
- walks the element tree of every cell, struct and object variable before a decoder
  allocates from what it declares (``_matlab_v5.py``);
- never unpickles anything, never runs code a file holds.
"""

from __future__ import annotations

import contextlib
import math
import os
import struct
import zipfile
import zlib
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np

from pdmkit._checks import npy_declared
from pdmkit._config import max_bytes
from pdmkit.ensembles._limits import _one_line, _size, _too_big, _why
from pdmkit.ensembles._matlab_hdf5 import read_mat73
from pdmkit.ensembles._matlab_tables import read_mat_objects
from pdmkit.ensembles._matlab_v5 import Damaged, MatVariable, TooBig, walk_mat5
from pdmkit.ensembles._table_files import _DECOMPRESS_ERRORS, _existing_file
from pdmkit.errors import DataError

__all__ = ["read_mat", "read_npz"]


def _is_hdf5_mat(path: Path) -> bool:
    """A v7.3 file: MATLAB's header says so (version 0x0200), or HDF5 follows it."""
    with path.open("rb") as f:
        head = f.read(520)
    version = head[124:128] in (b"\x00\x02IM", b"\x02\x00MI")
    return (
        head.startswith(b"MATLAB 7.3") or version or head[512:520] == b"\x89HDF\r\n\x1a\n"
    )


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
        if flags & 0xFF == _MAT_OPAQUE:  # name, type system, class: no dims
            return element().decode("latin-1"), (), 0, flags
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
#: The array class of a MATLAB object (table, string, ...): its data is elsewhere.
_MAT_OPAQUE = 17


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


def _check_mat_sizes(path: Path, limit: int) -> tuple[set[str], list[MatVariable]]:
    """Refuse a .mat file whose variables declare or decompress to more than ``limit``.

    Walks the top-level elements of a v5 file without scipy: a compressed variable is
    inflated and counted (never kept), so one that decompresses to gigabytes costs
    only time, bounded by the ceiling; the element tree of every cell, struct and
    object variable, and of the subsystem that holds MATLAB objects, is walked too
    (:func:`~pdmkit.ensembles._matlab_v5.walk_mat5`). v4 files (never compressed) are
    checked from the shapes scipy's ``whosmat`` lists. Returns the names of the
    logical variables, and what the file holds (empty for a v4 file).
    """
    logical: set[str] = set()
    listing: list[MatVariable] = []
    size = path.stat().st_size
    with path.open("rb") as f:
        head = f.read(128)
        endian = {b"IM": "<", b"MI": ">"}.get(head[126:128])
        if len(head) < 128 or endian is None:
            _check_mat4_sizes(path, limit)
            return logical, listing
        (subsystem,) = struct.unpack(endian + "Q", head[116:124])
        deferred: DataError | None = None  # a bad subsystem matters to objects only
        spent = [0]  # what the arrays declare, all of them (walk_mat5)
        pos, total, k = 128, 0, 0
        while pos + 8 <= size:
            f.seek(pos)
            mdtype, n = struct.unpack(endian + "II", f.read(8))
            if mdtype >> 16 or mdtype not in (_MI_MATRIX, _MI_COMPRESSED):
                break  # damaged: loadmat says so
            budget = limit - total
            if mdtype == _MI_COMPRESSED:
                verb = "decompresses to at least"
                used, header = _inflated_size(f, n, budget, path, endian, k, logical)
            else:
                content, used, verb = f.read(min(n, 4096)), n, "holds"
                header = _check_mat5_header(path, content, endian, k, logical)
            if used > budget:
                name = f"variable {header}"
                if used > limit:
                    raise _too_big(f"{path}: {name}", used, limit, verb)
                raise _too_big(f"{path}: its variables together", total + used, limit, verb)
            total += used
            try:
                element = (pos, mdtype, n)
                listing.append(_walked(path, f, element, endian, header, subsystem, spent))
            except DataError as exc:
                if pos != subsystem:
                    raise
                deferred = exc
            pos += 8 + n
            k += 1
    if any(v.is_object for v in listing):
        if deferred is not None:
            raise deferred
        if subsystem not in [v.offset for v in listing]:
            raise DataError(
                f"cannot read {path} as a MATLAB file: it holds MATLAB objects but its "
                f"header places their data at byte {subsystem}, where no variable "
                "starts; the file is damaged"
            )
    return logical, listing


def _walked(
    path: Path,
    f: IO[bytes],
    element: tuple,
    endian: str,
    header: str,
    subsystem: int,
    spent: list[int],
) -> MatVariable:
    """The top-level element ``(pos, mdtype, n)`` walked: what it is, or a DataError."""
    pos, mdtype, n = element
    name = (
        "the data of its objects (subsystem)" if pos == subsystem else f"variable {header}"
    )
    limit = max_bytes("member")
    try:
        return walk_mat5(f, pos, mdtype, n, endian, limit, pos == subsystem, spent)
    except TooBig as exc:
        what, found = exc.args
        raise _too_big(f"{path}: {name} (a {what} inside it)", found, limit) from None
    except (Damaged, zlib.error) as exc:
        raise DataError(
            f"cannot read {path} as a MATLAB file ({name}: {_one_line(exc)}); the file "
            "is damaged or not a .mat file"
        ) from None


def _check_mat4_sizes(path: Path, limit: int) -> None:
    """Refuse a v4 variable whose shape (as ``whosmat`` lists it) is over ``limit``.

    A file ``whosmat`` cannot list is left to ``loadmat``, which says what is wrong.
    """
    from scipy.io import whosmat

    try:  # a v4 file, or not a .mat: loadmat says what is wrong
        listed = whosmat(path)
    except Exception:  # loadmat says what is wrong with it
        return
    for name, shape, kind in listed:
        declared = math.prod(shape) * _MAT4_WIDTH.get(kind, 8)
        if declared > limit:
            raise _too_big(
                f"{path}: variable {name!r} ({kind} of shape {shape})",
                declared,
                limit,
            )


def _inflated_size(
    f: Any, n: int, budget: int, path: Path, endian: str, k: int, logical: set[str]
) -> tuple[int, str]:
    """Bytes the compressed element at ``f`` inflates to, counted, never kept.

    Stops once past ``budget``; returns the count and the variable's name (its header
    checked on the way, a logical one added to ``logical``). Damaged data is a DataError.
    """
    used, content, header = 0, b"", None
    try:
        for out in _inflated(f, n):  # counted, never kept
            used += len(out)
            if header is None:
                content += out[: 4096 - len(content)]
                if len(content) >= 4096:  # the miMATRIX tag, then its header
                    header = _check_mat5_header(path, content[8:], endian, k, logical)
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
    return used, header


def read_mat(path: str | os.PathLike) -> dict[str, Any]:
    """Read the variables of a MATLAB ``.mat`` file (v4, v5/v7 and v7.3).

    Wraps :func:`scipy.io.loadmat` with ``simplify_cells=True``: singleton dimensions
    are squeezed (a ``(n, 1)`` column becomes a 1-D array, a ``1x1`` value a scalar),
    structs become dicts; the ``__header__``, ``__version__`` and ``__globals__`` entries
    are left out. A logical (true/false) variable is a numpy ``bool`` array (scipy
    alone reads it as ``uint8``).

    MATLAB objects, which scipy cannot read, are read with the ``mat-io`` package: a
    ``table`` becomes a :class:`pandas.DataFrame` (``attrs["matlab_class"]``
    ``"table"``), a ``timetable`` a DataFrame indexed by its row times
    (``attrs["sample_rate"]`` when it was made with one), a ``string`` a ``str`` (or
    an object array of them), a ``categorical`` a ``str`` (or a
    :class:`pandas.Categorical`), a ``datetime`` / ``duration`` a pandas
    ``Timestamp`` / ``Timedelta`` (or a ``datetime64`` / ``timedelta64`` array); an
    object of another class is an ``UnreadObject`` that names its class. A v7.3
    (HDF5) file is read with h5py in the same forms: numeric, logical, char, struct and
    cell variables (an object in it is an ``UnreadObject``: re-save it with ``-v7``).

    Sizes are checked before anything is decoded, against ``max_bytes("member")``
    (1 GiB by default, ``$PDMKIT_MAX_MEMBER_BYTES``): the shape and class each variable
    declares, the size each compressed variable decompresses to (counted, not kept),
    the sum over the variables, and every array nested in a cell, struct or object
    (v7.3: every HDF5 dataset, and what references read).

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    dict
        Variable name -> numpy array (or scalar, str, dict, DataFrame, ...).

    Raises
    ------
    pdmkit.errors.DataNotFoundError
        The file does not exist.
    pdmkit.errors.DataError
        A damaged / non-MATLAB file, one without variables, a variable (or the
        variables together, or an array nested in one) larger than the ceiling, an
        HDF5 file with links to other files or references that do not resolve.

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
    return _read_mat(path)[0]


def _read_mat(path: str | os.PathLike) -> tuple[dict[str, Any], list[MatVariable]]:
    """:func:`read_mat`'s variables, and the listing of what the file holds.

    The listing (name, MATLAB class, dimensions of each variable) is empty for a v4
    file.
    """
    path = _existing_file(path, "a MATLAB .mat file")
    limit = max_bytes("member")
    if _is_hdf5_mat(path):
        return read_mat73(path, limit)
    logical, listing = _check_mat_sizes(path, limit)
    objects = {v.name: v.classname for v in listing if v.is_object}
    plain = [v.name for v in listing if not v.is_object and v.name]
    data = _loadmat(path, plain if objects else None) if plain or not objects else {}
    if objects:
        data.update(read_mat_objects(path, list(objects), objects, limit))
        order = {v.name: i for i, v in enumerate(listing)}
        data = dict(sorted(data.items(), key=lambda kv: order.get(kv[0], len(order))))
    if not data:
        raise DataError(f"{path} holds no variables")
    for name in logical & data.keys():
        value = data[name]
        if isinstance(value, np.ndarray | np.generic) and value.dtype.kind in "iu":
            data[name] = np.asarray(value).astype(bool)
        elif isinstance(value, int):  # a 1x1 logical, squeezed to a scalar
            data[name] = bool(value)
    return data, [v for v in listing if v.name]  # the subsystem has no name


def _loadmat(path: Path, names: list[str] | None) -> dict[str, Any]:
    """``scipy.io.loadmat(path, simplify_cells=True)`` (of ``names``), errors one-lined."""
    from scipy.io import loadmat
    from scipy.io.matlab import MatReadError

    try:
        raw = loadmat(path, simplify_cells=True, variable_names=names)
    except NotImplementedError:
        raise DataError(
            f"{path} is a MATLAB v7.3 (HDF5) file without the MATLAB header pdmkit "
            "recognises; re-save it in MATLAB with save(..., '-v7.3') or '-v7'"
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
        UnboundLocalError,  # scipy's reader meets a class it has no branch for
        AttributeError,
        RecursionError,
    ) as exc:
        raise DataError(
            f"cannot read {path} as a MATLAB file ({_why(exc)}); the file "
            "is damaged or not a .mat file"
        ) from None
    return {k: v for k, v in raw.items() if not k.startswith("__")}


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
