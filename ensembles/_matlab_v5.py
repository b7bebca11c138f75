"""The element tree of a MATLAB v5 / v7 ``.mat`` file, walked before anything decodes it.

A v5 file is a sequence of (possibly zlib-compressed) ``miMATRIX`` elements; a cell or
struct array nests further elements, and MATLAB objects (tables, timetables, strings,
categoricals: MCOS "opaque" objects) keep their contents in the file's *subsystem*, a
``uint8`` variable that is itself a small MAT stream. The decoders (scipy, ``mat-io``)
size their arrays from what an element *declares*: a cell array of ``2**31`` cells is
``numpy.empty`` of that many objects before the first cell is read, and a nesting
thousands of levels deep recurses in C. :func:`walk_mat5` reads every tag and header
of a variable (inflating a compressed one a MiB at a time, keeping nothing) and
refuses, before any decoder runs:

- a numeric or text array that declares more than ``limit`` bytes;
- a cell or struct array that declares more elements than its bytes can hold (each
  element takes at least an 8-byte tag), or an empty struct array over ``limit``;
- an object array whose metadata declares more objects than it lists;
- a tag that declares more bytes than its enclosing element holds, a truncated or
  undecompressable element, or nesting deeper than :data:`MAX_DEPTH`.

It also lists what the file holds (name, MATLAB class, dimensions) for messages.
"""

from __future__ import annotations

import math
import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass
from typing import IO

__all__ = ["MatVariable", "walk_mat5"]

_MI_UINT32, _MI_MATRIX, _MI_COMPRESSED = 6, 14, 15
#: MATLAB array classes by their number in the array flags.
CLASS_NAMES = {
    1: "cell",
    2: "struct",
    3: "object",
    4: "char",
    5: "sparse",
    6: "double",
    7: "single",
    8: "int8",
    9: "uint8",
    10: "int16",
    11: "uint16",
    12: "int32",
    13: "uint32",
    14: "int64",
    15: "uint64",
    16: "function_handle",
    17: "opaque",
}
_CELL, _STRUCT, _OBJECT, _CHAR, _SPARSE, _FUNCTION, _OPAQUE = 1, 2, 3, 4, 5, 16, 17
_UINT8, _UINT32 = 9, 13
_LOGICAL, _COMPLEX = 1 << 9, 1 << 11  # array flags
#: Data types of data elements that the decoders turn into arrays (miINT8 ... miUINT64,
#: miUTF8/16/32). scipy and mat-io index a table of dtypes by the type a file states,
#: unchecked: any other type reads past the table (a segmentation fault).
_DATA_TYPES = frozenset((1, 2, 3, 4, 5, 6, 7, 9, 12, 13, 16, 17, 18))
#: Bytes per element once decoded (char: numpy's 4-byte unicode).
_WIDTH = {4: 4, 6: 8, 7: 4, 8: 1, 9: 1, 10: 2, 11: 2, 12: 4, 13: 4, 14: 8, 15: 8}
#: Deepest nesting of cells, structs and objects read (MATLAB files nest a few levels).
MAX_DEPTH = 64
#: Largest header field (a name, the dimensions, a struct's field names) read.
_FIELD_CAP = 1 << 20


class Damaged(Exception):
    """The element tree is inconsistent (the message says where and how)."""


class TooBig(Exception):
    """An array declares more than the ceiling: ``(what, bytes)``."""


@dataclass
class MatVariable:
    """One top-level variable: its name, MATLAB class and dimensions.

    ``classname`` is the class of a MATLAB object (``"table"``, ``"string"``, ...),
    else the array class (``"double"``, ``"cell"``, ``"logical"``, ...).

    Examples
    --------
    >>> MatVariable("data", 17, "table", (1, 1)).describe()
    "'data' (table 1x1)"
    """

    name: str
    mclass: int
    classname: str
    dims: tuple[int, ...] = ()
    logical: bool = False
    offset: int = 0

    @property
    def is_object(self) -> bool:
        """True for a MATLAB object that only ``mat-io`` decodes (an opaque class)."""
        return self.mclass == _OPAQUE

    def describe(self, note: str = "") -> str:
        """``"'name' (class AxB)"`` for messages, ``"'name' (class AxB: note)"``."""
        size = "x".join(str(d) for d in self.dims)
        note = f": {note}" if note else ""
        return f"{self.name!r} ({self.classname}{' ' + size if size else ''}{note})"


class _Reader:
    """Sequential reads of a byte stream that arrives in chunks; counts its position."""

    def __init__(self, chunks: Iterator[bytes]) -> None:
        self._chunks = chunks
        self._buf = b""
        self._at = 0
        self.pos = 0

    def _fill(self, n: int) -> None:
        while len(self._buf) - self._at < n:
            more = next(self._chunks, None)
            if more is None:
                raise Damaged("the data ends early (truncated?)")
            self._buf = self._buf[self._at :] + more
            self._at = 0

    def read(self, n: int) -> bytes:
        """The next ``n`` bytes (small reads: headers)."""
        self._fill(n)
        out = self._buf[self._at : self._at + n]
        self._at += n
        self.pos += n
        return out

    def chunks(self, n: int) -> Iterator[bytes]:
        """The next ``n`` bytes, in the pieces they arrive in."""
        while n > 0:
            if self._at >= len(self._buf):
                more = next(self._chunks, None)
                if more is None:
                    raise Damaged("the data ends early (truncated?)")
                self._buf, self._at = more, 0
            piece = self._buf[self._at : self._at + n]
            self._at += len(piece)
            self.pos += len(piece)
            n -= len(piece)
            yield piece

    def skip(self, n: int) -> None:
        """Pass over the next ``n`` bytes."""
        for _ in self.chunks(n):
            pass


def inflated(chunks: Iterator[bytes]) -> Iterator[bytes]:
    """The zlib stream in ``chunks``, decompressed a MiB at a time."""
    inflate = zlib.decompressobj()
    for data in chunks:
        while data and not inflate.eof:
            out = inflate.decompress(data, 1 << 20)
            if out:
                yield out
            data = inflate.unconsumed_tail
        if inflate.eof:
            return
    while not inflate.eof:  # what is left in the window
        out = inflate.decompress(b"", 1 << 20)
        if not out:
            return
        yield out


class _Walk:
    """The checks of one file: byte order, ceiling, names for messages."""

    def __init__(
        self, endian: str, limit: int, spent: list[int], objects: bool = False
    ) -> None:
        self.endian = endian
        self.limit = limit
        #: what the arrays walked so far declare (one number shared by a file's walks)
        self.spent = spent
        #: inside the subsystem, where any uint32 column may be an object's metadata
        self.objects = objects

    def allocate(self, what: str, n: int) -> None:
        """Count ``n`` bytes a decoder allocates for an array; refuse past the ceiling.

        Counted: what each array declares (numbers, text as strings, a slot per cell
        and struct field), not only the bytes stored (MATLAB stores doubles that fit
        as bytes; an empty char array of n rows decodes to n strings).
        """
        if n > self.limit:
            raise TooBig(what, n)
        self.spent[0] += n
        if self.spent[0] > self.limit:
            raise TooBig(f"{what}, with the arrays before it,", self.spent[0])

    def sub(
        self, r: _Reader, end: int, keep: bool = True, check: bool = True
    ) -> tuple[int, bytes]:
        """``(data type, data)`` of the next sub-element (data only when ``keep``).

        ``check``: its data type must be one of :data:`_DATA_TYPES`.
        """
        if end - r.pos < 8:
            raise Damaged("an element ends inside a tag")
        tag = r.read(8)
        mdtype, n = struct.unpack(self.endian + "II", tag)
        small = bool(mdtype >> 16)  # small data element: the data is in the tag
        if small:
            n, mdtype = mdtype >> 16, mdtype & 0xFFFF
        if check and mdtype not in _DATA_TYPES:
            raise Damaged(
                f"a data element has data type {mdtype}, which MATLAB never writes"
            )
        if small:
            if n > 4:
                raise Damaged(f"a small data element declares {n} bytes (at most 4)")
            return mdtype, tag[4 : 4 + n]
        padded = n + (-n % 8)  # the decoders skip the padding, wherever it ends
        if padded > end - r.pos:
            raise Damaged(f"a field declares {n} bytes where {end - r.pos} are left")
        if not keep:
            r.skip(padded)
            return mdtype, b""
        if n > _FIELD_CAP:
            raise Damaged(f"a header field declares {n} bytes")
        data = r.read(n)
        r.skip(padded - n)
        return mdtype, data

    def text(self, r: _Reader, end: int) -> str:
        return self.sub(r, end)[1].decode("latin-1").rstrip("\x00")

    def ints(self, data: bytes) -> tuple[int, ...]:
        return struct.unpack(self.endian + f"{len(data) // 4}i", data[: len(data) // 4 * 4])

    def child(self, r: _Reader, end: int, depth: int, opaque: str = "") -> tuple[int, ...]:
        """Walk the nested ``miMATRIX`` element at ``r``; its dims (an object's count)."""
        if end - r.pos < 8:
            raise Damaged("an element ends inside a tag")
        mdtype, n = struct.unpack(self.endian + "II", r.read(8))
        if mdtype != _MI_MATRIX:
            raise Damaged(f"a nested element has data type {mdtype}, not a matrix")
        if n > end - r.pos:
            raise Damaged(f"a nested array declares {n} bytes where {end - r.pos} are left")
        return self.matrix(r, n, depth, opaque=opaque).dims

    def matrix(
        self,
        r: _Reader,
        n: int,
        depth: int,
        *,
        top: bool = False,
        subsystem: bool = False,
        opaque: str = "",
    ) -> MatVariable:
        """Walk the ``n`` bytes of a matrix's content at ``r`` (after its tag).

        At the top level a numeric array's data is not read (``top``); ``subsystem``
        walks the nested MAT stream of the file's subsystem; ``opaque`` marks the
        metadata of an MCOS object (its object count is checked).
        """
        end = r.pos + n
        if n == 0:
            return MatVariable("", 0, "empty")
        if depth > MAX_DEPTH:
            raise Damaged(f"arrays nest deeper than {MAX_DEPTH} levels")
        if end - r.pos < 16:
            raise Damaged("an array ends inside its array flags")
        _, size, word = struct.unpack(self.endian + "III", r.read(12))
        r.skip(4)
        if size != 8:  # the decoders read 8 bytes of flags, whatever the tag says
            raise Damaged(f"an array's flags declare {size & 0xFFFF} bytes, not 8")
        mclass = word & 0xFF
        if mclass not in CLASS_NAMES:
            raise Damaged(f"an array has class {mclass}, which MATLAB never writes")
        if mclass == _OPAQUE:
            name, system, classname = (self.text(r, end) for _ in range(3))
            dims = self.child(r, end, depth + 1, opaque=system)
            var = MatVariable(name, mclass, classname, dims)
        else:
            var = self._array(r, end, depth, mclass, word, top, subsystem, opaque)
        if top and not subsystem and mclass not in (_CELL, _STRUCT, _OBJECT, _OPAQUE):
            return var  # the data of a top-level array: counted elsewhere, not read
        if not top and r.pos != end:
            # the decoders read a nested array's fields, not its declared size: the
            # next array starts where they end. Both must agree, or they would decode
            # other bytes than the ones checked here.
            raise Damaged(f"an array's fields take {r.pos - end + n} of its {n} bytes")
        return var

    def _array(
        self,
        r: _Reader,
        end: int,
        depth: int,
        mclass: int,
        word: int,
        top: bool,
        subsystem: bool,
        opaque: str,
    ) -> MatVariable:
        """The header (and nested elements) of a non-opaque array."""
        mdtype, raw = self.sub(r, end)
        dims = self.ints(raw)
        if (
            mdtype not in (5, 6)
            or len(raw) % 4
            or not 2 <= len(dims) <= 32
            or min(dims) < 0
        ):
            # MATLAB writes 2 to 32 int32 dimensions; scipy crashes on fewer
            raise Damaged(
                f"an array declares the dimensions {dims[:8]} (data type {mdtype})"
            )
        name = self.text(r, end)
        classname = self.text(r, end) if mclass == _OBJECT else ""
        logical = bool(word >> 9 & 1)
        kind = "logical" if logical else CLASS_NAMES.get(mclass, f"class {mclass}")
        var = MatVariable(name, mclass, classname or kind, tuple(dims), logical)
        count = math.prod(dims)
        if mclass in _WIDTH or mclass == _SPARSE:
            complex_ = bool(word >> 11 & 1)
            declared = count * _WIDTH.get(mclass, 0) * (2 if complex_ else 1)
            if mclass == _CHAR:  # decoded as strings, one per row: none empty
                declared = math.prod(dims[:-1]) * max(dims[-1], 1) * _WIDTH[_CHAR]
            self.allocate(f"{kind} array of shape {tuple(dims)}", declared)
            metadata = mclass == _UINT32 and (opaque == "MCOS" or self.objects)
            if (metadata or (subsystem and mclass == _UINT8)) and word & _COMPLEX:
                raise Damaged("an object's metadata (or the subsystem) is flagged complex")
            if metadata:  # mat-io makes an object array of the count it declares
                var.dims = self._object_count(r, end) or var.dims
            elif subsystem and mclass == _UINT8:
                self._subsystem(r, end, depth)
            else:
                needed = (3 if mclass == _SPARSE else 1) + complex_
                self._data_types(r, end, needed, top and not complex_ and mclass != _SPARSE)
        elif mclass == _CELL:
            self.allocate(f"cell array of shape {tuple(dims)}", count * 8)
            self._elements(r, end, depth, count, "cell")
        elif mclass in (_STRUCT, _OBJECT):
            length = self.ints(self.sub(r, end)[1])
            names = self.sub(r, end)[1]
            if len(length) != 1 or length[0] < 0 or (length[0] == 0 and names):
                raise Damaged(f"a struct declares field names of length {length[:2]}")
            fields = len(names) // length[0] if length[0] else 0
            self.allocate(
                f"struct array of shape {tuple(dims)}", count * max(fields, 1) * 8
            )
            self._elements(r, end, depth, count * fields, "struct field")
        elif mclass == _FUNCTION:
            if end > r.pos:
                self.child(r, end, depth + 1)
            else:
                self.allocate(f"function handle array of shape {tuple(dims)}", count * 8)
        return var

    def _data_types(self, r: _Reader, end: int, needed: int, first_only: bool) -> None:
        """Check an array's ``needed`` data elements: inside it, of a data type.

        The decoders read that many data elements whether or not the array holds them
        (into the next array's bytes). ``first_only``: the tag of the first only, its
        data not read (the data of a real top-level array, which may be large, is read
        once, by the decoder).
        """
        for _ in range(1 if first_only else needed):
            if end - r.pos < 8:
                raise Damaged("an array holds fewer data elements than its class needs")
            if not first_only:
                self.sub(r, end, keep=False)
                continue
            mdtype, n = struct.unpack(self.endian + "II", r.read(8))
            if mdtype >> 16:
                mdtype, n = mdtype & 0xFFFF, 0
            if mdtype not in _DATA_TYPES or n > end - r.pos:
                raise Damaged(
                    f"an array's data element (type {mdtype}, {n} bytes) is damaged"
                )

    def _elements(self, r: _Reader, end: int, depth: int, count: int, what: str) -> None:
        """Walk ``count`` nested elements; each takes at least an 8-byte tag."""
        if count * 8 > end - r.pos:
            raise Damaged(
                f"a {what} array declares {count} elements but holds {end - r.pos} bytes"
            )
        for _ in range(count):
            self.child(r, end, depth + 1)

    def _object_count(self, r: _Reader, end: int) -> tuple[int, ...]:
        """The dims an object's metadata declares, checked against the ids it lists.

        The metadata is ``[0xDD000000, ndims, dims..., object ids..., class id]``.
        """
        if end - r.pos < 8:
            raise Damaged("an array holds fewer data elements than its class needs")
        mdtype, n = struct.unpack(self.endian + "II", r.read(8))
        if mdtype >> 16:  # a small element: one value, no metadata
            if mdtype & 0xFFFF not in _DATA_TYPES or mdtype >> 16 > 4:
                raise Damaged(f"a data element has data type {mdtype & 0xFFFF}")
            return ()
        padded = n + (-n % 8)
        if mdtype not in _DATA_TYPES or padded > end - r.pos:
            raise Damaged(f"a data element (type {mdtype}, {n} bytes) is damaged")
        head = r.read(min(n, 136))
        r.skip(padded - len(head))
        if mdtype != _MI_UINT32:
            return ()
        values = struct.unpack(
            self.endian + f"{len(head) // 4}I", head[: len(head) // 4 * 4]
        )
        if len(values) < 2 or values[0] != 0xDD000000:  # MCOS metadata starts so
            return ()
        if values[1] > 32 or len(values) < 2 + values[1]:
            raise Damaged(f"an object's metadata declares {values[1]} dimensions")
        dims = values[2 : 2 + values[1]]
        listed = n // 4 - 3 - values[1]
        if math.prod(dims) > max(listed, 0) and listed > 0:
            raise Damaged(
                f"an object array declares {math.prod(dims)} objects but lists {listed}"
            )
        return tuple(dims)

    def _subsystem(self, r: _Reader, end: int, depth: int) -> None:
        """Walk the MAT stream the subsystem's ``uint8`` data holds."""
        if end - r.pos < 8:
            raise Damaged("the subsystem holds no data")
        mdtype, n = struct.unpack(self.endian + "II", r.read(8))
        if mdtype >> 16 or n > end - r.pos or mdtype not in _DATA_TYPES:
            raise Damaged("the subsystem's data is damaged")
        inner = _Reader(r.chunks(n))
        head = inner.read(8)
        endian = {b"IM": "<", b"MI": ">"}.get(head[2:4])
        if endian is None:
            raise Damaged("the subsystem has no byte-order mark")
        walk = _Walk(endian, self.limit, self.spent, objects=True)
        while n - inner.pos >= 8:
            tag, size = struct.unpack(endian + "II", inner.read(8))
            if size > n - inner.pos:
                raise Damaged(f"a subsystem element declares {size} bytes")
            if tag == _MI_COMPRESSED:
                start = inner.pos
                packed = _Reader(inflated(inner.chunks(size)))
                tag, inner_size = struct.unpack(endian + "II", packed.read(8))
                if tag != _MI_MATRIX:
                    raise Damaged("a compressed subsystem element holds no matrix")
                walk.matrix(packed, inner_size, depth + 1)
                inner.skip(start + size - inner.pos)
            elif tag == _MI_MATRIX:
                walk.matrix(inner, size, depth + 1)
            else:
                raise Damaged(f"the subsystem holds an element of data type {tag}")
        inner.skip(n - inner.pos)


def _file_chunks(f: IO[bytes], n: int) -> Iterator[bytes]:
    """The next ``n`` bytes of ``f``, a MiB at a time."""
    while n > 0:
        data = f.read(min(n, 1 << 20))
        if not data:
            return
        n -= len(data)
        yield data


def walk_mat5(
    f: IO[bytes],
    pos: int,
    mdtype: int,
    n: int,
    endian: str,
    limit: int,
    subsystem: bool,
    spent: list[int] | None = None,
) -> MatVariable:
    """Check the top-level element at ``pos`` of ``f`` (tag ``mdtype``, ``n`` bytes).

    A compressed element is inflated as it is walked (nothing kept); the data of a
    numeric top-level array is not read (its size is counted by the caller). The
    element holding the subsystem (``subsystem``) is walked into. ``spent[0]`` counts
    what the arrays declare across the walks of one file (all of them together must
    stay within ``limit``).

    Raises
    ------
    Damaged
        The element tree is inconsistent (the message says how).
    TooBig
        ``(what, declared bytes)`` of an array over ``limit``.
    zlib.error
        The compressed data does not decompress.

    Examples
    --------
    >>> import io
    >>> from scipy.io import savemat
    >>> buffer = io.BytesIO()
    >>> savemat(buffer, {"c": [[1.0, 2.0]]})
    >>> _ = buffer.seek(128)
    >>> mdtype, n = struct.unpack("<II", buffer.read(8))
    >>> walk_mat5(buffer, 128, mdtype, n, "<", 1 << 20, False).describe()
    "'c' (double 1x2)"
    """
    f.seek(pos + 8)
    chunks = _file_chunks(f, n)
    if mdtype == _MI_COMPRESSED:
        r = _Reader(inflated(chunks))
        mdtype, n = struct.unpack(endian + "II", r.read(8))
    else:
        r = _Reader(chunks)
    if mdtype != _MI_MATRIX:
        raise Damaged(f"a variable has data type {mdtype}, not a matrix")
    walk = _Walk(endian, limit, spent if spent is not None else [0])
    var = walk.matrix(r, n, 0, top=True, subsystem=subsystem)
    var.offset = pos
    return var
