"""Read a layout's row straight from a serialized message, without deserializing it.

Learning wants a few numbers per message; rosbags' deserializer builds the whole message
object first.  For each message type we generate, once, a function that walks the
serialized bytes (ROS 1, or little-endian CDR for ROS 2) and unpacks only the wanted
fields: fixed sizes and alignment paddings are added up at generation time, strings and
sequences are stepped over by their length prefixes.

The walk makes the checks rosbags' deserializer makes (strings are in the buffer, end as
CDR wants and decode as UTF-8; sequence counts fit the buffer and the typestore's maximum;
the message ends where its bytes end).  When one fails, the walk raises :class:`Damaged`
and :func:`row_reader` deserializes that message in full instead, so a damaged message
fails with rosbags' own error, and a message the walk does not understand (big-endian CDR)
is still read.  The generated code holds nothing from the message data nor any name from
the definitions: only sizes and counts (integers), numbered variables and the helpers
below.  It mirrors rosbags' own generated deserializers (``rosbags.serde``), alignment
rules included; tests/learn/test_learn_raw.py compares the two on random messages.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Mapping
from struct import Struct
from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype

from rac.learn.fields import PLACEHOLDER, Layout, finite_mean, row_extractor

Row = tuple[float, ...]
RawReader = Callable[[bytes], Row]

# struct formats as rosbags unpacks them: ROS 1's byte is signed, char unsigned.
_FORMATS = {
    "bool": "?",
    "byte": "b",
    "char": "B",
    "int8": "b",
    "uint8": "B",
    "int16": "h",
    "uint16": "H",
    "int32": "i",
    "uint32": "I",
    "int64": "q",
    "uint64": "Q",
    "float32": "f",
    "float64": "d",
}
_SIZES = {t: Struct("<" + f).size for t, f in _FORMATS.items()}
_DTYPES = {t: "bool" if t == "bool" else "<" + f for t, f in _FORMATS.items()}


class Damaged(ValueError):
    """The bytes fail one of the deserializer's checks, or the walk's own assumptions."""


class _Unsupported(Exception):
    """The type holds something the walk does not handle (float128, octet)."""


def _align(fielddefs: Mapping[str, Any], desc: Any) -> int:
    """The alignment a CDR field starts at (rosbags: that of its first primitive)."""
    nodetype, detail = desc
    if nodetype == Nodetype.BASE:
        return 4 if detail[0] == "string" else _size(detail[0])
    if nodetype == Nodetype.NAME:
        return _align(fielddefs, fielddefs[detail][1][0][1])
    if nodetype == Nodetype.ARRAY:
        return _align(fielddefs, detail[0])
    return 4  # a sequence starts with its uint32 count


def _align_after(fielddefs: Mapping[str, Any], desc: Any) -> int:
    """The alignment rosbags assumes after a CDR field (from its last primitive)."""
    nodetype, detail = desc
    if nodetype == Nodetype.BASE:
        return 1 if detail[0] == "string" else _size(detail[0])
    if nodetype == Nodetype.NAME:
        return _align_after(fielddefs, fielddefs[detail][1][-1][1])
    if nodetype == Nodetype.ARRAY:
        return _align_after(fielddefs, detail[0])
    return min(4, _align_after(fielddefs, detail[0]))


def _size(typ: str) -> int:
    if typ not in _SIZES:
        raise _Unsupported(typ)
    return _SIZES[typ]


class _Walk:
    """Generates the body of one walk.

    The generated code keeps a byte position ``pos``; the generator holds a static offset
    ``k`` still to be added to it and ``known``, a power of two known to divide ``pos``,
    so that paddings are computed at generation time when they can be.
    """

    def __init__(self, fielddefs: Mapping[str, Any], wanted: dict[str, list[str]], cdr: bool):
        self.fielddefs = fielddefs
        self.wanted = wanted  # path -> the variables its value goes to
        self.cdr = cdr
        self.lines: list[str] = []
        self.indent = "    "
        self.k = 0
        self.known = 8  # CDR aligns relative to the start of the payload: pos 0
        self.loops = 0

    def emit(self, line: str) -> None:
        self.lines.append(self.indent + line)

    def at(self) -> str:
        return f"pos + {self.k}" if self.k else "pos"

    def flush(self) -> None:
        if self.k:
            self.emit(f"pos += {self.k}")
            self.known = min(self.known, self.k & -self.k)
            self.k = 0

    def pad(self, alignment: int) -> None:
        if alignment <= 1:
            return
        if self.known >= alignment:
            self.k = (self.k + alignment - 1) & -alignment
            return
        self.flush()
        self.emit(f"pos = (pos + {alignment - 1}) & -{alignment}")
        self.known = alignment

    def advance(self, expr: str, divisor: int) -> None:
        """``pos += expr``, which ``divisor`` divides."""
        self.flush()
        self.emit(f"pos += {expr}")
        self.known = min(self.known, divisor)

    def loop(self, count: str, body: Callable[[], None]) -> None:
        # Each pass may start at another alignment: nothing is known inside or after.
        self.flush()
        self.loops += 1
        self.emit(f"for _{self.loops} in range({count}):")
        outer = self.indent
        self.indent += "    "
        self.known = 1
        body()
        self.flush()
        self.emit("pass")
        self.indent = outer
        self.known = 1

    def string(self) -> None:
        self.flush()
        self.emit("n = U32(raw, pos)[0]")
        if self.cdr:  # a CDR string counts and ends with its NUL
            self.emit("if n < 1 or pos + 4 + n > size or raw[pos + 3 + n] != 0: raise Damaged")
            self.emit("bytes(raw[pos + 4:pos + 3 + n]).decode()")
        else:
            self.emit("if pos + 4 + n > size: raise Damaged")
            self.emit("bytes(raw[pos + 4:pos + 4 + n]).decode()")
        self.advance("4 + n", 1)

    def message(self, typename: str, prefix: str, inside: bool) -> None:
        """One message's fields; ``inside`` a loop nothing is wanted (layouts never look
        into arrays of messages)."""
        fields = self.fielddefs[typename][1]
        aligned = 8  # what rosbags' deserializer of this type assumes at its start
        for i, (name, desc) in enumerate(fields):
            if name == PLACEHOLDER and not self.cdr:
                continue  # ROS 1 writes nothing for it; CDR writes a uint8
            aligned = self.field(desc, prefix + name, inside)
            if self.cdr and i + 1 < len(fields):
                following = _align(self.fielddefs, fields[i + 1][1])
                if aligned < following:
                    self.pad(following)
                    aligned = following

    def field(self, desc: Any, path: str, inside: bool) -> int:
        """Walks one field; returns the alignment rosbags assumes after it."""
        nodetype, detail = desc
        if nodetype == Nodetype.NAME:
            self.message(detail, path + ".", inside)
            return _align_after(self.fielddefs, desc)
        if nodetype == Nodetype.BASE:
            if detail[0] == "string":
                self.string()
                return 1
            return self.scalar(detail[0], path, inside)
        (inner_type, inner), count = detail
        if nodetype == Nodetype.ARRAY:
            if not isinstance(count, int):
                raise _Unsupported(count)
            return self.array(inner_type, inner, path, count, inside)
        return self.sequence(inner_type, inner, path, inside)

    def scalar(self, typ: str, path: str, inside: bool) -> int:
        width = _size(typ)
        targets = None if inside else self.wanted.get(path)
        if targets:
            self.emit(f"{' = '.join(targets)} = S_{typ}(raw, {self.at()})[0]")
        self.k += width
        return width

    def array(self, inner_type: Any, inner: Any, path: str, count: int, inside: bool) -> int:
        if inner_type == Nodetype.NAME:
            before = _align(self.fielddefs, (inner_type, inner))
            after = _align_after(self.fielddefs, (inner_type, inner))

            def element() -> None:
                if self.cdr and before > after:
                    self.pad(before)
                self.message(inner, "", True)

            self.loop(str(count), element)
            return after
        if inner[0] == "string":
            for i in range(count):
                if self.cdr and i:
                    self.pad(4)
                self.string()
            return 1
        width = _size(inner[0])
        targets = None if inside else self.wanted.get(path)
        if targets:
            read = f"frombuffer(raw, D_{inner[0]}, {count}, {self.at()})"
            self.emit(f"{' = '.join(targets)} = {read}")
        self.k += width * count
        return width

    def sequence(self, inner_type: Any, inner: Any, path: str, inside: bool) -> int:
        if inner_type == Nodetype.BASE and inner[0] == "string":
            least = 5 if self.cdr else 4
        elif inner_type == Nodetype.BASE:
            least = _size(inner[0])
        else:
            least = 1 if self.cdr else 0
        self.flush()
        self.emit("count = U32(raw, pos)[0]")
        self.emit("pos += 4")
        self.emit(f"if pos + count * {least} > size or count > MAXSEQ: raise Damaged")
        self.known = min(self.known, 4)
        if inner_type == Nodetype.NAME:
            before = _align(self.fielddefs, (inner_type, inner))

            def element() -> None:
                if self.cdr:
                    self.pad(before)
                self.message(inner, "", True)

            self.loop("count", element)
            return min(4, _align_after(self.fielddefs, (inner_type, inner)))
        if inner[0] == "string":

            def string() -> None:
                if self.cdr:
                    self.pad(4)
                self.string()

            self.loop("count", string)
            return 1
        width = least
        if self.cdr and width > 4:  # rosbags pads before a non-empty one only
            self.emit(f"if count: pos = (pos + {width - 1}) & -{width}")
        targets = None if inside else self.wanted.get(path)
        if targets:
            self.emit(f"{' = '.join(targets)} = frombuffer(raw, D_{inner[0]}, count, pos)")
        self.advance(f"{width} * count", min(width, 4))
        return min(4, width)


def raw_row_reader(
    fielddefs: Mapping[str, Any], typename: str, layout: Layout, *, cdr: bool, max_sequence: int
) -> RawReader | None:
    """A function reading ``layout``'s row (as :func:`rac.learn.fields.row_extractor` reads
    it from the deserialized message) from a serialized ``typename`` message; it raises
    :class:`Damaged` (a ValueError) or struct.error when the bytes are not what it expects.
    None when the type holds something the walk does not handle."""
    wanted: dict[str, list[str]] = {}
    for i, p in enumerate(layout.scalars):
        wanted.setdefault(p, []).append(f"s{i}")
    for i, p in enumerate(layout.arrays):
        wanted.setdefault(p, []).append(f"a{i}")
    row = [f"float(s{i})" for i in range(len(layout.scalars))]
    row += [f"mean(a{i})" for i in range(len(layout.arrays))]
    if layout.quaternion is not None:
        prefix = f"{layout.quaternion}." if layout.quaternion else ""
        for c in "xyzw":
            wanted.setdefault(prefix + c, []).append(f"q{c}")
            row.append(f"float(q{c})")
    walk = _Walk(fielddefs, wanted, cdr)
    try:
        walk.message(typename, "", False)
    except (_Unsupported, KeyError, IndexError):  # unknown or empty types: the full way
        return None
    walk.flush()
    if cdr:
        # Little-endian CDR only; rosbags allows up to 3 bytes of padding after the end.
        head = [
            "    if raw[:2] != b'\\x00\\x01': raise Damaged",
            "    raw = memoryview(raw)[4:]",
        ]
        end = "    if pos > size or pos + 3 < size: raise Damaged"
    else:
        head = []
        end = "    if pos != size: raise Damaged"
    source = "\n".join(
        [
            "def walk(raw):",
            *head,
            "    size = len(raw)",
            "    pos = 0",
            *walk.lines,
            end,
            f"    return ({', '.join(row)}{',' if len(row) == 1 else ''})",
        ]
    )
    namespace: dict[str, Any] = {
        "Damaged": Damaged,
        "U32": Struct("<I").unpack_from,
        "MAXSEQ": max_sequence,
        "frombuffer": np.frombuffer,
        "mean": finite_mean,
    }
    namespace |= {f"S_{t}": Struct("<" + f).unpack_from for t, f in _FORMATS.items()}
    namespace |= {f"D_{t}": np.dtype(d) for t, d in _DTYPES.items()}
    exec(source, namespace)  # generated from the type definition only (see above)
    reader: RawReader = namespace["walk"]
    return reader


def row_reader(
    typestore: Any, typename: str, layout: Layout, *, cdr: bool, deserialize: Any = None
) -> RawReader:
    """Reads ``layout``'s row from one serialized message: by walking its bytes when the
    type allows, and by deserializing it in full (``deserialize``, the typestore's by
    default) for any message the walk rejects, so that errors are rosbags' own."""
    if deserialize is None:
        deserialize = typestore.deserialize_cdr if cdr else typestore.deserialize_ros1
    full_row = row_extractor(layout)

    def full(raw: bytes) -> Row:
        return full_row(deserialize(raw, typename))

    walk = raw_row_reader(
        typestore.fielddefs,
        typename,
        layout,
        cdr=cdr,
        max_sequence=getattr(typestore, "max_sequence_length", 2**32 - 1),  # rosbags < 0.11
    )
    if walk is None:
        return full
    fast = walk

    def read(raw: bytes) -> Row:
        try:
            return fast(raw)
        except (ValueError, IndexError, struct.error):
            return full(raw)

    return read
