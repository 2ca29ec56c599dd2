"""Bulk decoding of ROS messages (CDR for ROS 2, the ROS 1 wire format) into channels.

A reference decoder turns every message into a Python object: about 0.1 M messages/s.
Most sensor topics, though, have a *fixed layout*: given the first message, every numeric
field sits at the same byte offset in every message (all-numeric types such as
``sensor_msgs/Imu`` or ``std_msgs/Float64``, and types whose strings and variable arrays
keep their lengths over a run, such as a ``Float64MultiArray`` of 16 values or a
``JointState`` of 6 joints).

:class:`RosBatchDecoder` walks the message definition over one template message to
compute a :class:`Layout`: the offset and type of every numeric leaf (with CDR alignment,
relative to the 4-byte encapsulation header) and the offset of every length prefix
(strings, sequences). Every message of the same size whose length prefixes equal the
template's has, by induction over the fields, exactly the template's layout; this is
checked for *every* message with a few vectorized comparisons. The matching messages are
gathered into one ``(n, size)`` byte matrix and each leaf is read as a strided numpy view:
a whole column per field, no Python per message. Messages that do not match start a new
layout (up to :data:`MAX_LAYOUTS`); anything left (or undecodable by the walker) goes to
the reference decoder of rosbags, flattened by the same naming rules, so both paths give
the same channels and the same values.

Naming: ``{field}.{subfield}``, arrays ``{field}[i]``; strings are skipped, and so are
arrays of 8-bit integers (``uint8[]``, ``byte[]``, ``char[]``, ``int8[]``: images, point
clouds and other binary blobs); ``std_msgs/Header`` fields are not channels, the
top-level header's stamp is the message's header time.
"""

from __future__ import annotations

import re
import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
from rosbags.interfaces import Nodetype
from rosbags.serde import SerdeError
from rosbags.typesys.base import normalize_fieldname
from rosbags.typesys.store import Typestore

from analyzer.readers._common import (
    BY_NAME_ORDERS,
    NO_STAMP,
    ByteArray,
    ColumnAccumulator,
    Decoded,
    FloatArray,
    IntArray,
    LabelEnds,
    LabelRows,
    Relabel,
    field_view,
    gather_rows,
    merge_parts,
)
from analyzer.readers.base import DAMAGE

Encoding = Literal["cdr", "ros1"]
FieldDesc = tuple[Any, ...]
"""A rosbags field descriptor: ``(Nodetype, details)``."""

MESSAGE_DAMAGE: tuple[type[Exception], ...] = (SerdeError, *DAMAGE)
"""What rosbags' reference decoder raises on a message its definition does not decode
(its own ``SerdeError``; a short buffer's ``struct.error``, bytes that are not UTF-8):
the message is counted as undecodable. Anything else is a bug, and raised."""

_NOT_THIS_STORE: tuple[type[Exception], ...] = (*MESSAGE_DAMAGE, KeyError)
"""A message a candidate definition does not decode, or a type (or nested type) the
candidate store lacks (``KeyError``): try the next store."""

MAX_LAYOUTS = 32
"""Distinct layouts kept per topic before the rest of a batch goes to the reference decoder."""

HEADER_TYPE = "std_msgs/msg/Header"
FILLER_FIELD = "structure_needs_at_least_one_member"
"""The dummy byte ROS 2 adds to empty messages: not a channel."""

NUMERIC: dict[str, str] = {
    "bool": "u1",
    "byte": "i1",
    "char": "u1",
    "int8": "i1",
    "uint8": "u1",
    "int16": "i2",
    "uint16": "u2",
    "int32": "i4",
    "uint32": "u4",
    "int64": "i8",
    "uint64": "u8",
    "float32": "f4",
    "float64": "f8",
}
"""ROS base types that become channels, with their numpy type (rosbags' conventions:
``byte`` is signed, ``char`` unsigned)."""

BLOB_TYPES = frozenset({"byte", "char", "int8", "uint8"})
"""Arrays of these types are binary data, not measurements: skipped."""

STRING_TYPES = frozenset({"string"})
_ELEMENT_END = re.compile(r"\]\.")
"""Where an array's element ends in a leaf's name (``transforms[0].`` in
``transforms[0].transform.translation.x``)."""
LABELLED_ELEMENTS = 16
"""The elements of an array whose names (:data:`IDENTITY_FIELDS`) are compared between
messages: the first 16 (a TFMessage's transforms, a DiagnosticArray's statuses); the
names of an array of thousands would cost more to compare than the message to read."""


def _early(element: str) -> bool:
    """Whether every index in ``element`` (``transforms[3]``, ``a[0].b[2]``) is one of
    the first :data:`LABELLED_ELEMENTS`."""
    return all(int(part.partition("]")[0]) < LABELLED_ELEMENTS for part in element.split("[")[1:])


LABEL_CACHE = 100_000
"""Label strings a decoder keeps read (by field and hash) before it starts over."""
LABEL_KINDS = 9
"""Contents of a string array a batch reports at most (:attr:`Decoded.label_ends`)."""
IDENTITY_FIELDS = frozenset({"name", "frame_id", "child_frame_id", "id", "hardware_id"})
"""Strings of an array's element that say what its numbers measure (a frame, a joint, a
device), unlike a status text: when one changes between messages, the element's index no
longer follows one quantity (:class:`_Label`)."""


class LayoutError(Exception):
    """The walker cannot lay out a message (unsupported type or inconsistent bytes)."""


@dataclass(frozen=True, slots=True)
class _Run:
    """Consecutive leaves of one base type, ``stride`` bytes apart (an array, or one leaf)."""

    kind: str
    offset: int
    count: int
    first: int  # index into Layout.names


@dataclass(frozen=True, slots=True)
class _Label:
    """A string array beside numeric arrays (``JointState.name`` beside ``position``):
    its bytes ``[start, end)`` in the message, its length and the numeric arrays of the
    same message level (``siblings``), whose index follows it."""

    field: str
    start: int
    end: int
    count: int
    siblings: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class Layout:
    """Byte layout of the messages of one topic that share a template's lengths."""

    size: int
    names: tuple[str, ...]
    runs: tuple[_Run, ...]
    check_offsets: IntArray
    check_values: IntArray
    stamp: tuple[int, int] | None
    endian: str
    labels: tuple[_Label, ...] = ()
    cdr: bool = True

    def matches(self, rows: ByteArray) -> npt.NDArray[np.bool_]:
        """Which rows (messages of ``size`` bytes) have the template's length prefixes."""
        ok = np.ones(rows.shape[0], dtype=bool)
        for offset, expected in zip(
            self.check_offsets.tolist(), self.check_values.tolist(), strict=True
        ):
            ok &= field_view(rows, offset, self.endian + "u4") == expected
        return ok

    def extract(self, rows: ByteArray) -> dict[str, FloatArray]:
        """Every numeric leaf of ``rows`` as a float64 column (one strided read per run)."""
        n = rows.shape[0]
        out: dict[str, FloatArray] = {}
        for run in self.runs:
            dtype = np.dtype(self.endian + NUMERIC[run.kind])
            view = np.ndarray(
                shape=(run.count, n),
                dtype=dtype,
                buffer=rows,
                offset=run.offset,
                strides=(dtype.itemsize, self.size),
            )
            values = (view != 0) if run.kind == "bool" else view
            block = values.astype(np.float64)
            for j in range(run.count):
                out[self.names[run.first + j]] = block[j]
        return out

    def leaves(self) -> dict[str, tuple[int, str]]:
        """Byte offset and ROS base type of every numeric leaf, by name."""
        out: dict[str, tuple[int, str]] = {}
        for run in self.runs:
            width = np.dtype(NUMERIC[run.kind]).itemsize
            for j in range(run.count):
                out[self.names[run.first + j]] = (run.offset + j * width, run.kind)
        return out

    def stamps(self, rows: ByteArray) -> IntArray | None:
        """Header stamps (``sec * 1e9 + nanosec``) of ``rows``, if the type has a header."""
        if self.stamp is None:
            return None
        sec_off, nsec_off = self.stamp
        sec = field_view(rows, sec_off, self.endian + "i4").astype(np.int64)
        return sec * 1_000_000_000 + field_view(rows, nsec_off, self.endian + "u4")

    def label_hashes(self, rows: ByteArray, label: _Label) -> npt.NDArray[np.uint64]:
        """A 64-bit hash of the bytes of ``label`` in every row (equal bytes, equal hash):
        the rows viewed as 8-byte words, a polynomial in a large odd constant mod 2**64."""
        width = label.end - label.start
        words = (width + 7) // 8
        block = np.zeros((rows.shape[0], words * 8), dtype=np.uint8)
        block[:, :width] = rows[:, label.start : label.end]
        hashes: npt.NDArray[np.uint64] = block.view("<u8") @ _powers(words)  # (wraps)
        return hashes ^ np.uint64(width)

    def label_names(self, data: bytes, label: _Label) -> tuple[str, ...]:
        """The strings of ``label`` in one message's bytes ``data`` (Python: called at
        the few messages where the label changes)."""
        u32 = struct.Struct(self.endian + "I").unpack_from
        out: list[str] = []
        pos = label.start
        for _ in range(label.count):
            if self.cdr:
                pos = (pos + 3) & -4  # (the label starts aligned, relative and absolute)
            size = int(u32(data, pos)[0])
            text = data[pos + 4 : pos + 4 + size]
            pos += 4 + size
            if self.cdr and text.endswith(b"\0"):
                text = text[:-1]
            out.append(text.decode("utf-8", "replace"))
        return tuple(out)


_HASH_BASE = 0x9E3779B97F4A7C15
_POWERS: dict[int, npt.NDArray[np.uint64]] = {}


def _powers(words: int) -> npt.NDArray[np.uint64]:
    """``_HASH_BASE ** (j + 1) mod 2**64`` for ``j < words`` (cached)."""
    found = _POWERS.get(words)
    if found is None:
        values, power = [], 1
        for _ in range(words):
            power = (power * _HASH_BASE) % (1 << 64)
            values.append(power)
        found = _POWERS[words] = np.asarray(values, dtype=np.uint64)
    return found


class _Walker:
    """Walks a message definition over one serialized message, collecting the layout."""

    def __init__(self, store: Typestore, data: bytes, encoding: Encoding) -> None:
        self.store = store
        self.data = data
        self.cdr = encoding == "cdr"
        self.base = 4 if self.cdr else 0
        self.pos = self.base
        self.little = True
        if self.cdr:
            if len(data) < 4 or data[0] != 0 or data[1] not in (0, 1):
                raise LayoutError("not a CDR message (bad encapsulation header)")
            self.little = data[1] == 1
        self.endian = "<" if self.little else ">"
        self.u32 = struct.Struct(self.endian + "I").unpack_from
        self.names: list[str] = []
        self.offsets: list[int] = []
        self.kinds: list[str] = []
        self.checks: list[tuple[int, int]] = []
        self.stamp: tuple[int, int] | None = None
        self.labels: list[tuple[str, int, int, int]] = []

    def layout(self, msgtype: str) -> Layout:
        self.message(msgtype, "", skip=False, top=True)
        end = len(self.data)
        slack = end - self.pos
        if slack < 0 or slack > (3 if self.cdr else 0):
            raise LayoutError(f"definition does not match the message size ({self.pos} != {end})")
        checks = list(self.checks)
        if self.cdr:
            # the encapsulation header itself: byte order and options must match too
            checks.insert(0, (0, int(self.u32(self.data, 0)[0])))
        runs: list[_Run] = []
        for i, (offset, kind) in enumerate(zip(self.offsets, self.kinds, strict=True)):
            last = runs[-1] if runs else None
            width = np.dtype(NUMERIC[kind]).itemsize
            if (
                last is not None
                and last.kind == kind
                and offset == last.offset + last.count * width
            ):
                runs[-1] = _Run(kind, last.offset, last.count + 1, last.first)
            else:
                runs.append(_Run(kind, offset, 1, i))
        return Layout(
            size=end,
            names=tuple(self.names),
            runs=tuple(runs),
            check_offsets=np.asarray([c[0] for c in checks], dtype=np.int64),
            check_values=np.asarray([c[1] for c in checks], dtype=np.int64),
            stamp=self.stamp,
            endian=self.endian,
            labels=self._labels(),
            cdr=self.cdr,
        )

    def _labels(self) -> tuple[_Label, ...]:
        """The string arrays that have numeric arrays beside them (same message level),
        and the strings of an array's elements that have numbers in the same element
        (``transforms[0].child_frame_id`` beside ``transforms[0].transform...``; their
        one sibling is the element, ``transforms[0]``)."""
        out = []
        elements: set[str] | None = None  # the elements that hold numbers (built once)
        for field, start, end, count in self.labels:
            if "]." in field:
                if field.rpartition(".")[2] not in IDENTITY_FIELDS:
                    continue  # (a string array in an element: a text, not a name)
                if elements is None:
                    elements = {
                        name[: m.start() + 1]
                        for name in self.names
                        for m in _ELEMENT_END.finditer(name)
                    }
                element = field[: field.rindex("].") + 1]
                if element in elements and _early(element):
                    out.append(_Label(field, start, end, count, (element,)))
                continue
            prefix = field.rpartition(".")[0]
            prefix = f"{prefix}." if prefix else ""
            siblings: dict[str, None] = {}
            for name in self.names:
                if name.startswith(prefix):
                    head = name[len(prefix) :].split(".", 1)[0]
                    if "[" in head:
                        siblings[prefix + head.split("[", 1)[0]] = None
            if siblings:
                out.append(_Label(field, start, end, count, tuple(siblings)))
        return tuple(out)

    # -- primitives
    def align(self, width: int) -> None:
        if self.cdr and width > 1:
            rel = self.pos - self.base
            self.pos = self.base + ((rel + width - 1) & -width)

    def need(self, nbytes: int) -> None:
        if self.pos + nbytes > len(self.data):
            raise LayoutError("message shorter than its definition")

    def length(self) -> int:
        self.align(4)
        self.need(4)
        value = int(self.u32(self.data, self.pos)[0])
        self.checks.append((self.pos, value))
        self.pos += 4
        return value

    # -- structure
    def message(self, msgtype: str, prefix: str, *, skip: bool, top: bool = False) -> None:
        try:
            fields = self.store.fielddefs[msgtype][1]
        except KeyError:
            raise LayoutError(f"type {msgtype!r} is not defined") from None
        for fieldname, desc in fields:
            filler = fieldname == FILLER_FIELD
            self.field(prefix + fieldname, desc, skip=skip or filler, top=top)

    def field(self, name: str, desc: FieldDesc, *, skip: bool, top: bool) -> None:
        node = desc[0]
        if node == Nodetype.NAME:
            sub = desc[1]
            if sub == HEADER_TYPE:
                mark = len(self.names)
                self.message(sub, name + ".", skip=False)
                found = dict(zip(self.names[mark:], self.offsets[mark:], strict=True))
                sec, nsec = found.get(f"{name}.stamp.sec"), found.get(f"{name}.stamp.nanosec")
                if top and self.stamp is None and sec is not None and nsec is not None:
                    self.stamp = (sec, nsec)
                del self.names[mark:], self.offsets[mark:], self.kinds[mark:]
            else:
                self.message(sub, name + ".", skip=skip)
        elif node == Nodetype.BASE:
            self.base_value(name, desc[1][0], skip=skip)
        elif node == Nodetype.ARRAY:
            sub, count = desc[1]
            self.array(name, sub, int(count), skip=skip)
        elif node == Nodetype.SEQUENCE:
            sub = desc[1][0]
            self.array(name, sub, self.length(), skip=skip)
        else:  # pragma: no cover - rosbags has no other node types
            raise LayoutError(f"unknown node type {node!r}")

    def base_value(self, name: str, kind: str, *, skip: bool) -> None:
        if kind in STRING_TYPES:
            self.align(4)
            start = self.pos
            size = self.length()
            self.need(size)
            self.pos += size
            if not skip and "]." in name and name.rpartition(".")[2] in IDENTITY_FIELDS:
                # a name of an array's element (TransformStamped.child_frame_id in
                # TFMessage.transforms[i]): it says what the element's numbers measure
                self.labels.append((name, start, self.pos, 1))
            return
        code = NUMERIC.get(kind)
        if code is None:
            raise LayoutError(f"base type {kind!r} is not supported by the bulk decoder")
        width = int(code[1])
        self.align(width)
        self.need(width)
        if not skip:
            self.names.append(name)
            self.offsets.append(self.pos)
            self.kinds.append(kind)
        self.pos += width

    def array(self, name: str, sub: FieldDesc, count: int, *, skip: bool) -> None:
        if sub[0] == Nodetype.BASE:
            kind = sub[1][0]
            if kind in STRING_TYPES:
                if count:
                    self.align(4)
                start = self.pos
                for _ in range(count):
                    self.base_value(name, kind, skip=True)
                if not skip:
                    self.labels.append((name, start, self.pos, count))
                return
            code = NUMERIC.get(kind)
            if code is None:
                raise LayoutError(f"base type {kind!r} is not supported by the bulk decoder")
            width = int(code[1])
            if count:
                self.align(width)
                self.need(count * width)
                if not skip and kind not in BLOB_TYPES:
                    self.names.extend(f"{name}[{i}]" for i in range(count))
                    self.offsets.extend(range(self.pos, self.pos + count * width, width))
                    self.kinds.extend([kind] * count)
                self.pos += count * width
            return
        for i in range(count):
            self.field(f"{name}[{i}]", sub, skip=skip, top=False)


def compute_layout(store: Typestore, msgtype: str, data: bytes, encoding: Encoding) -> Layout:
    """The layout of ``data``, one serialized ``msgtype`` message (raises LayoutError)."""
    return _Walker(store, data, encoding).layout(msgtype)


# --------------------------------------------------------------------------- field types

TIME_TYPES: dict[str, str] = {
    "builtin_interfaces/msg/Time": "time",
    "builtin_interfaces/msg/Duration": "duration",
}
"""The message types of a time written in a message (ROS 2's ``builtin_interfaces``;
rosbags reads ROS 1's ``time`` and ``duration`` as the same two), by what they hold: a
moment (``time``) or a span (``duration``)."""


def time_fields(store: Typestore, msgtype: str) -> dict[str, str]:
    """The numeric leaves of ``msgtype`` that belong to a time or a duration
    (:data:`TIME_TYPES`), named as the channels are (:class:`Layout`) with every array
    index written ``[*]`` (``points[*].time_from_start.sec``), each with its kind. From
    the message definition, not the names: a ``float64 stamp`` is a measurement, a
    ``duration`` a span (a header's stamp is no channel: left out). One walk of the
    definition; arrays of messages are walked once."""
    out: dict[str, str] = {}

    def walk(typename: str, prefix: str, kind: str | None, depth: int) -> None:
        if depth > 32 or typename not in store.fielddefs:  # (definitions do not nest so deep)
            return
        for fieldname, desc in store.fielddefs[typename][1]:
            if fieldname != FILLER_FIELD:
                leaf(f"{prefix}{fieldname}", desc, kind, depth)

    def leaf(name: str, desc: FieldDesc, kind: str | None, depth: int) -> None:
        node = desc[0]
        if node == Nodetype.NAME:
            if desc[1] != HEADER_TYPE:
                walk(desc[1], f"{name}.", TIME_TYPES.get(desc[1], kind), depth + 1)
        elif node == Nodetype.BASE:
            if kind is not None and desc[1][0] in NUMERIC:
                out[name] = kind
        else:
            leaf(f"{name}[*]", desc[1][0], kind, depth)

    walk(msgtype, "", None, 0)
    return out


# --------------------------------------------------------------------------- reference path


def flatten_message(store: Typestore, msgtype: str, obj: object) -> tuple[dict[str, float], int]:
    """Numeric leaves of a rosbags message object, named like :class:`Layout` names, and
    its top-level header stamp (``NO_STAMP`` if none)."""
    out: dict[str, float] = {}
    stamp = NO_STAMP
    for fieldname, desc in store.fielddefs[msgtype][1]:
        if fieldname == FILLER_FIELD:
            continue
        value = getattr(obj, normalize_fieldname(fieldname))
        if desc[0] == Nodetype.NAME and desc[1] == HEADER_TYPE:
            if stamp == NO_STAMP:
                stamp = int(value.stamp.sec) * 1_000_000_000 + int(value.stamp.nanosec)
            continue
        _flatten_field(store, fieldname, desc, value, out)
    return out, stamp


def _flatten_field(
    store: Typestore,
    name: str,
    desc: tuple,
    value: object,
    out: dict[str, float],
) -> None:
    node = desc[0]
    if node == Nodetype.NAME:
        if desc[1] == HEADER_TYPE:
            return
        for fieldname, sub in store.fielddefs[desc[1]][1]:
            if fieldname == FILLER_FIELD:
                continue
            _flatten_field(
                store,
                f"{name}.{fieldname}",
                sub,
                getattr(value, normalize_fieldname(fieldname)),
                out,
            )
    elif node == Nodetype.BASE:
        if desc[1][0] in NUMERIC:
            out[name] = float(value)  # type: ignore[arg-type]
    else:
        sub = desc[1][0]
        items: Sequence[object] = value  # type: ignore[assignment]
        if sub[0] == Nodetype.BASE:
            kind = sub[1][0]
            if kind in NUMERIC and kind not in BLOB_TYPES:
                for i, item in enumerate(np.asarray(items).tolist()):
                    out[f"{name}[{i}]"] = float(item)
        else:
            for i, item in enumerate(items):
                _flatten_field(store, f"{name}[{i}]", sub, item, out)


# --------------------------------------------------------------------------- batch decoder


@dataclass(slots=True)
class _LabelRows:
    """One string array over a batch: its hash per message and the index of the layout
    that decoded it (-1: not decoded in bulk)."""

    hashes: npt.NDArray[np.uint64]
    layout: IntArray

    @classmethod
    def empty(cls, n: int) -> _LabelRows:
        return cls(np.zeros(n, dtype=np.uint64), np.full(n, -1, dtype=np.int64))


class RosBatchDecoder:
    """Decodes batches of serialized messages of one ROS type into numeric columns.

    ``stores`` are candidate typestores (several when a bag embeds no definition and the
    standard typestores of different distributions disagree); the first one that decodes
    the first message exactly is kept. ``bulk=False`` forces the reference path (tests
    compare both).
    """

    def __init__(
        self,
        stores: Sequence[Typestore],
        msgtype: str,
        encoding: Encoding,
        *,
        bulk: bool = True,
        max_layouts: int = MAX_LAYOUTS,
        fallback: Callable[[], Sequence[Typestore]] | None = None,
    ) -> None:
        if not stores:
            raise ValueError("at least one typestore is needed")
        self.msgtype = msgtype
        self.encoding = encoding
        self.bulk = bulk
        self.max_layouts = max_layouts
        self._candidates = list(stores)
        self._fallback = fallback
        one = len(stores) == 1 and fallback is None
        self._store: Typestore | None = stores[0] if one else None
        self.notice = ""
        """Said once by the reader: the file's own definition did not decode its
        messages, so another (``fallback``'s) did."""
        self._label_index: list[dict[str, _Label]] = []
        """Per layout (as ``_layouts``): its labels by field."""
        self._label_texts: dict[tuple[str, int], tuple[str, ...]] = {}
        """A label's strings by field and hash, read once (:meth:`_relabels`)."""
        self._layouts: list[Layout] = []
        self._layout_failed = False

    # -- public
    def decode(self, buf: ByteArray, starts: IntArray, sizes: IntArray) -> Decoded:
        n = int(starts.shape[0])
        decoded = Decoded(n)
        if n == 0:
            return decoded
        if self._store is None:
            self._store = self._choose_store(buf, int(starts[0]), int(sizes[0]))
        parts: dict[str, list[tuple[IntArray | None, FloatArray]]] = {}
        stamps = np.full(n, NO_STAMP, dtype=np.int64)
        any_stamp = False
        remaining = np.arange(n, dtype=np.int64)
        labels: dict[str, _LabelRows] = {}
        if self.bulk:
            remaining, any_stamp = self._bulk(buf, starts, sizes, remaining, parts, stamps, labels)
        if remaining.size:
            any_stamp |= self._reference(buf, starts, sizes, remaining, parts, stamps, decoded)
        decoded.columns = merge_parts(parts, n)
        decoded.stamps = stamps if any_stamp else None
        if labels:
            decoded.relabels = self._relabels(
                buf, starts, labels, decoded.label_ends, decoded.label_rows
            )
        return decoded

    def time_fields(self) -> dict[str, str]:
        """The fields of its type that hold a time or a duration (:func:`time_fields`),
        from the definition it decodes with (the first candidate before a message chose
        one: the candidates define the same type)."""
        return time_fields(self._store or self._candidates[0], self.msgtype)

    def deserialize(self, data: bytes) -> object:
        """The reference decoder (rosbags) for one message."""
        store = self._store or self._candidates[0]
        if self.encoding == "cdr":
            return store.deserialize_cdr(data, self.msgtype)
        return store.deserialize_ros1(data, self.msgtype)

    # -- internals
    def _choose_store(self, buf: ByteArray, start: int, size: int) -> Typestore:
        data = buf[start : start + size].tobytes()
        found = self._decoding(data, self._candidates)
        if found is None and self._fallback is not None:
            # the file's definition does not fit its messages (a stub written by a test
            # or a recorder that lacked the type): the standard definition may
            found = self._decoding(data, self._fallback())
            if found is not None:
                self.notice = (
                    f"the file's definition of {self.msgtype} does not decode its messages; "
                    "read with the standard definition of that type"
                )
        return found if found is not None else self._candidates[0]

    def _decoding(self, data: bytes, stores: Sequence[Typestore]) -> Typestore | None:
        """The first of ``stores`` that decodes the message ``data``."""
        for store in stores:
            try:
                compute_layout(store, self.msgtype, data, self.encoding)
            except LayoutError:
                try:
                    if self.encoding == "cdr":
                        store.deserialize_cdr(data, self.msgtype)
                    else:
                        store.deserialize_ros1(data, self.msgtype)
                except _NOT_THIS_STORE:
                    continue
            return store
        return None

    def _bulk(
        self,
        buf: ByteArray,
        starts: IntArray,
        sizes: IntArray,
        remaining: IntArray,
        parts: dict[str, list[tuple[IntArray | None, FloatArray]]],
        stamps: IntArray,
        labels: dict[str, _LabelRows],
    ) -> tuple[IntArray, bool]:
        assert self._store is not None
        any_stamp = False
        tried = 0
        layouts = list(self._layouts)
        while remaining.size:
            if tried < len(layouts):
                layout = layouts[tried]
            else:
                if self._layout_failed or len(self._layouts) >= self.max_layouts:
                    break
                first = int(remaining[0])
                data = buf[int(starts[first]) : int(starts[first] + sizes[first])].tobytes()
                try:
                    layout = compute_layout(self._store, self.msgtype, data, self.encoding)
                except LayoutError:
                    if not self._layouts:
                        self._layout_failed = True  # the walker cannot handle this type
                    break
                self._layouts.append(layout)
                self._label_index.append({x.field: x for x in layout.labels})
                layouts.append(layout)
            tried += 1
            candidates = remaining[sizes[remaining] == layout.size]
            if candidates.size == 0:
                continue
            rows = gather_rows(buf, starts[candidates], layout.size)
            ok = layout.matches(rows)
            if not bool(ok.all()):
                rows = rows[ok]
                candidates = candidates[ok]
                if candidates.size == 0:
                    continue
            group = None if candidates.size == starts.shape[0] else candidates
            for name, values in layout.extract(rows).items():
                parts.setdefault(name, []).append((group, values))
            group_stamps = layout.stamps(rows)
            if group_stamps is not None:
                stamps[candidates] = group_stamps
                any_stamp = True
            for label in layout.labels:
                found = labels.get(label.field)
                if found is None:
                    found = labels[label.field] = _LabelRows.empty(starts.shape[0])
                found.hashes[candidates] = layout.label_hashes(rows, label)
                found.layout[candidates] = tried - 1  # (its index in self._layouts)
            if candidates.size == remaining.size:
                remaining = remaining[:0]
            else:
                remaining = np.setdiff1d(remaining, candidates, assume_unique=True)
        return remaining, any_stamp

    def _relabels(
        self,
        buf: ByteArray,
        starts: IntArray,
        labels: dict[str, _LabelRows],
        ends: dict[str, LabelEnds],
        by_row: dict[str, LabelRows],
    ) -> list[Relabel]:
        """Where each string array's content changed in the batch (compared in bulk by
        hash; the strings are read only at the first change and at the batch's ends,
        which go into ``ends`` with the siblings and its contents). A string array that
        changes into at most :data:`~analyzer.readers._common.BY_NAME_ORDERS` contents
        gives ``by_row`` which message has which (each content read once)."""

        cache = self._label_texts
        if len(cache) > LABEL_CACHE:  # (ids unique to each message: read them again)
            cache.clear()

        def names(k: int) -> tuple[str, ...]:
            """The strings of row ``rows[k]``'s label ``field`` (read once per content)."""
            key = (field, int(hashes[k]))
            got = cache.get(key)
            if got is None:
                row = int(rows[k])
                at = int(found.layout[row])
                start = int(starts[row])
                layout = self._layouts[at]
                message = buf[start : start + layout.size].tobytes()
                got = cache[key] = layout.label_names(message, self._label_index[at][field])
            return got

        out: list[Relabel] = []
        for field, found in labels.items():
            rows = np.nonzero(found.layout >= 0)[0]
            if rows.size == 0:
                continue
            hashes = found.hashes[rows]
            siblings = self._label_index[int(found.layout[rows[0]])][field].siblings
            # the batch's first and last strings: the topic's tracker compares them with
            # the batches before, whichever decoder (publisher) they came from
            first = names(0)
            changed = np.not_equal(hashes[1:], hashes[:-1])
            where = np.nonzero(changed)[0] + 1
            last = names(rows.size - 1) if where.size else first
            # every content the batch holds (a few: read once each)
            if where.size:
                _, at, code = np.unique(hashes, return_index=True, return_inverse=True)
                kinds = tuple(names(int(k)) for k in np.sort(at)[:LABEL_KINDS])
                if at.size <= BY_NAME_ORDERS:
                    contents = tuple(names(int(k)) for k in at)
                    by_row[field] = (rows, code.astype(np.int64).reshape(-1), contents)
            else:
                kinds = (first,)
            ends[field] = (first, last, siblings, kinds)
            if where.size:
                k = int(where[0])
                out.append(
                    Relabel(field, int(rows[k]), names(k - 1), names(k), int(where.size), siblings)
                )
        return out

    def _reference(
        self,
        buf: ByteArray,
        starts: IntArray,
        sizes: IntArray,
        rows: IntArray,
        parts: dict[str, list[tuple[IntArray | None, FloatArray]]],
        stamps: IntArray,
        decoded: Decoded,
    ) -> bool:
        store = self._store or self._candidates[0]
        acc = ColumnAccumulator()
        any_stamp = False
        raw = buf.tobytes() if rows.size > 64 else None
        for row in rows.tolist():
            start, size = int(starts[row]), int(sizes[row])
            data = (
                raw[start : start + size]
                if raw is not None
                else buf[start : start + size].tobytes()
            )
            try:
                obj = self.deserialize(data)
                flat, stamp = flatten_message(store, self.msgtype, obj)
            except MESSAGE_DAMAGE as err:  # recorded per topic, never fatal
                decoded.note_failure(err)
                continue
            acc.add(row, flat)
            if stamp != NO_STAMP:
                stamps[row] = stamp
                any_stamp = True
        sub = Decoded(decoded.n)
        acc.into(sub)
        for name, column in sub.columns.items():
            parts.setdefault(name, []).append(column)
        return any_stamp
