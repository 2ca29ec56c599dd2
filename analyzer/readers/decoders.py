"""Batch decoders for the message encodings of MCAP (besides ROS, see :mod:`rosdecode`).

Every decoder has ``decode(buf, starts, sizes) -> Decoded``: the payloads of a batch of
messages of one topic are slices of one byte buffer.

* JSON (``json`` / ``jsonschema``): the payloads are joined into newline-delimited JSON and
  parsed by Arrow in one call (columnar, in C++); nested objects and arrays are flattened
  column-wise. If Arrow cannot type a batch (a field changing type), the batch falls back
  to ``json.loads`` per message, flattened with the same naming.
* Protobuf (schema in the file): ``mcap_protobuf`` decodes each message, fields are read
  through the descriptor. There is no bulk path for protobuf.
* ROS 2 CDR whose schema rosbags cannot parse: ``mcap_ros2``'s dynamic decoder per message.

Naming follows the contract: ``field.subfield``, ``field[i]``; booleans are 0/1; strings,
bytes and nulls are skipped; a top-level ``header`` is not a channel (its ``stamp`` with
``sec`` and ``nanosec``/``nsec`` is the header time).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.json as pajson

from analyzer.readers._common import (
    NO_STAMP,
    ByteArray,
    ColumnAccumulator,
    Decoded,
    FloatArray,
    IntArray,
)
from analyzer.readers.base import DAMAGE


class BatchDecoder(Protocol):
    """Decodes the payloads ``buf[starts[i] : starts[i] + sizes[i]]`` of one topic."""

    def decode(self, buf: ByteArray, starts: IntArray, sizes: IntArray) -> Decoded: ...


# --------------------------------------------------------------------------- generic objects


def flatten_value(value: Any, name: str, out: dict[str, float]) -> None:
    """Numeric leaves of a decoded value (dicts, lists, numpy arrays, protobuf messages,
    ``mcap_ros2`` objects with ``__slots__``) into ``out``."""
    if isinstance(value, bool | np.bool_):
        out[name] = 1.0 if value else 0.0
    elif isinstance(value, int | float | np.integer | np.floating):
        out[name] = float(value)
    elif value is None or isinstance(value, str | bytes | bytearray | memoryview):
        return
    elif isinstance(value, dict):
        for key, item in value.items():
            flatten_value(item, f"{name}.{key}" if name else str(key), out)
    elif isinstance(value, np.ndarray):
        if value.dtype.kind in "iu" and value.dtype.itemsize == 1:
            return  # binary blob
        for i, item in enumerate(value.tolist()):
            flatten_value(item, f"{name}[{i}]", out)
    elif isinstance(value, list | tuple):
        for i, item in enumerate(value):
            flatten_value(item, f"{name}[{i}]", out)
    elif hasattr(value, "DESCRIPTOR") and hasattr(value, "ListFields"):
        _flatten_protobuf(value, name, out)
    elif hasattr(value, "__slots__"):
        for attr in value.__slots__:
            if not attr.startswith("_"):
                flatten_value(getattr(value, attr), f"{name}.{attr}" if name else attr, out)


def _flatten_protobuf(message: Any, name: str, out: dict[str, float]) -> None:
    prefix = f"{name}." if name else ""
    for field in message.DESCRIPTOR.fields:
        value = getattr(message, field.name)
        if field.message_type is not None:
            if _is_repeated(field):
                if field.message_type.GetOptions().map_entry:
                    continue  # maps have no stable index: skipped
                for i, item in enumerate(value):
                    _flatten_protobuf(item, f"{prefix}{field.name}[{i}]", out)
            elif message.HasField(field.name):
                _flatten_protobuf(value, f"{prefix}{field.name}", out)
        elif _is_repeated(field):
            for i, item in enumerate(value):
                flatten_value(item, f"{prefix}{field.name}[{i}]", out)
        else:
            flatten_value(value, f"{prefix}{field.name}", out)


def _is_repeated(field: Any) -> bool:
    repeated = getattr(field, "is_repeated", None)
    if repeated is not None:
        return bool(repeated)
    return bool(field.label == field.LABEL_REPEATED)


def split_header(top: dict[str, Any]) -> int:
    """Remove a top-level ``header`` from a decoded dict; return its stamp or NO_STAMP."""
    header = top.pop("header", None)
    if isinstance(header, dict):
        stamp = header.get("stamp")
        if isinstance(stamp, dict):
            sec = stamp.get("sec", stamp.get("secs"))
            nsec = stamp.get("nanosec", stamp.get("nsec", stamp.get("nsecs", 0)))
            if isinstance(sec, int | float) and isinstance(nsec, int | float):
                return int(sec) * 1_000_000_000 + int(nsec)
    return NO_STAMP


class ObjectDecoder:
    """Per-message decoder: ``decode_one(bytes) -> object``, flattened generically. A
    message ``decode_one`` refuses with :data:`~analyzer.readers.base.DAMAGE` or one of
    ``damage`` (its library's errors: protobuf's ``DecodeError``) is counted as
    undecodable; any other exception is a bug, and raised."""

    def __init__(
        self, decode_one: Callable[[bytes], Any], damage: tuple[type[Exception], ...] = ()
    ) -> None:
        self._decode_one = decode_one
        self._damage = (*DAMAGE, *damage)

    def decode(self, buf: ByteArray, starts: IntArray, sizes: IntArray) -> Decoded:
        n = int(starts.shape[0])
        decoded = Decoded(n)
        acc = ColumnAccumulator()
        raw = buf.tobytes()
        stamps = np.full(n, NO_STAMP, dtype=np.int64)
        for row, (start, size) in enumerate(zip(starts.tolist(), sizes.tolist(), strict=True)):
            try:
                obj = self._decode_one(raw[start : start + size])
            except self._damage as err:  # recorded per topic
                decoded.note_failure(err)
                continue
            flat: dict[str, float] = {}
            if hasattr(obj, "__slots__") and not hasattr(obj, "DESCRIPTOR"):
                header = getattr(obj, "header", None)
                stamp = getattr(header, "stamp", None)
                if stamp is not None:
                    sec = getattr(stamp, "sec", None)
                    nsec = getattr(stamp, "nanosec", None)
                    if sec is not None and nsec is not None:
                        stamps[row] = int(sec) * 1_000_000_000 + int(nsec)
                for attr in obj.__slots__:
                    if attr != "header" and not attr.startswith("_"):
                        flatten_value(getattr(obj, attr), attr, flat)
            else:
                flatten_value(obj, "", flat)
            acc.add(row, flat)
        acc.into(decoded)
        if bool(np.any(stamps != NO_STAMP)):
            decoded.stamps = stamps
        return decoded


# --------------------------------------------------------------------------- JSON


class JsonBatchDecoder:
    """JSON messages, parsed by Arrow as newline-delimited JSON in one call per batch."""

    def __init__(self, *, bulk: bool = True) -> None:
        self.bulk = bulk

    def decode(self, buf: ByteArray, starts: IntArray, sizes: IntArray) -> Decoded:
        n = int(starts.shape[0])
        if n == 0:
            return Decoded(0)
        if self.bulk:
            try:
                return self._decode_arrow(buf, starts, sizes)
            except (pa.ArrowException, _ArrowShapeError, ValueError, TypeError, KeyError):
                pass  # Arrow cannot type this batch: per-message fallback below
        return self._decode_python(buf, starts, sizes)

    def _decode_arrow(self, buf: ByteArray, starts: IntArray, sizes: IntArray) -> Decoded:
        n = int(starts.shape[0])
        lines = _join_lines(buf, starts, sizes)
        table = pajson.read_json(
            pa.BufferReader(lines),
            read_options=pajson.ReadOptions(block_size=max(len(lines) + 1, 1 << 20)),
        )
        if table.num_rows != n:
            raise _ArrowShapeError("a payload is not exactly one JSON object")
        decoded = Decoded(n)
        rows_all = np.arange(n, dtype=np.int64)
        for fieldname, column in zip(table.column_names, table.columns, strict=True):
            array = column.combine_chunks() if column.num_chunks != 1 else column.chunk(0)
            if fieldname == "header":
                decoded.stamps = _arrow_header_stamps(array)
                continue
            _flatten_arrow(array, fieldname, rows_all, decoded.columns)
        for name, (rows, values) in list(decoded.columns.items()):
            if rows is not None and rows.size == n:
                decoded.columns[name] = (None, values)
        return decoded

    def _decode_python(self, buf: ByteArray, starts: IntArray, sizes: IntArray) -> Decoded:
        n = int(starts.shape[0])
        decoded = Decoded(n)
        acc = ColumnAccumulator()
        raw = buf.tobytes()
        stamps = np.full(n, NO_STAMP, dtype=np.int64)
        for row, (start, size) in enumerate(zip(starts.tolist(), sizes.tolist(), strict=True)):
            try:
                obj = json.loads(raw[start : start + size])
            except ValueError as err:
                decoded.note_failure(err)
                continue
            flat: dict[str, float] = {}
            if isinstance(obj, dict):
                stamps[row] = split_header(obj)
            flatten_value(obj, "", flat)
            acc.add(row, flat)
        acc.into(decoded)
        if bool(np.any(stamps != NO_STAMP)):
            decoded.stamps = stamps
        return decoded


class _ArrowShapeError(Exception):
    """Arrow parsed the batch into something other than one row per message."""


def _join_lines(buf: ByteArray, starts: IntArray, sizes: IntArray) -> bytes:
    """Payloads joined by newlines, built with index arithmetic (no loop per message).

    Raw newlines can only be whitespace between JSON tokens (inside strings they are
    escaped), so replacing them by spaces keeps every payload on one line.
    """
    n = int(starts.shape[0])
    lengths = sizes + 1
    out_starts = np.cumsum(lengths) - lengths
    total = int(lengths.sum())
    source = np.repeat(starts - out_starts, lengths) + np.arange(total, dtype=np.int64)
    np.minimum(source, buf.shape[0] - 1, out=source)
    out = buf[source]
    out[(out == 10) | (out == 13)] = 32
    out[out_starts[:n] + sizes] = 10
    return out.tobytes()


_NUMERIC_ARROW = (pa.types.is_integer, pa.types.is_floating, pa.types.is_boolean)


def _flatten_arrow(
    array: pa.Array,
    name: str,
    rows: IntArray,
    out: dict[str, tuple[IntArray | None, FloatArray]],
) -> None:
    """Numeric leaves of an Arrow column; ``rows`` maps its elements to message rows."""
    kind = array.type
    if pa.types.is_struct(kind):
        valid = _validity(array)
        for i in range(kind.num_fields):
            child = array.field(i)
            sub_rows = rows if valid is None else rows[valid]
            child_sel = child if valid is None else child.filter(pa.array(valid))
            _flatten_arrow(child_sel, f"{name}.{kind.field(i).name}", sub_rows, out)
    elif pa.types.is_list(kind) or pa.types.is_large_list(kind):
        lengths = pc.fill_null(pc.list_value_length(array), 0).to_numpy(zero_copy_only=False)
        offsets = array.offsets.to_numpy(zero_copy_only=False).astype(np.int64)[:-1]
        values = array.values
        longest = int(lengths.max()) if lengths.size else 0
        for i in range(longest):
            present = np.nonzero(lengths > i)[0]
            items = values.take(pa.array(offsets[present] + i))
            _flatten_arrow(items, f"{name}[{i}]", rows[present], out)
    elif any(test(kind) for test in _NUMERIC_ARROW):
        valid = _validity(array)
        numbers = pc.cast(array, pa.uint8()) if pa.types.is_boolean(kind) else array
        values = numbers.to_numpy(zero_copy_only=False).astype(np.float64)
        if valid is None:
            out[name] = (rows, values)
        elif bool(valid.any()):
            out[name] = (rows[valid], values[valid])
    # strings, binaries, nulls, timestamps: not channels


def _validity(array: pa.Array) -> np.ndarray | None:
    if array.null_count == 0:
        return None
    return np.asarray(pc.is_valid(array).to_numpy(zero_copy_only=False), dtype=bool)


def _arrow_header_stamps(array: pa.Array) -> IntArray | None:
    """Stamps of a top-level ``header`` struct column (``stamp.sec`` + ``stamp.nanosec``)."""
    if not pa.types.is_struct(array.type) or array.type.get_field_index("stamp") < 0:
        return None
    stamp = pc.struct_field(array, "stamp")
    if not pa.types.is_struct(stamp.type):
        return None
    names = [stamp.type.field(i).name for i in range(stamp.type.num_fields)]
    sec_name = next((x for x in ("sec", "secs") if x in names), None)
    nsec_name = next((x for x in ("nanosec", "nsec", "nsecs") if x in names), None)
    if sec_name is None or nsec_name is None:
        return None
    sec = pc.fill_null(pc.cast(pc.struct_field(stamp, sec_name), pa.int64()), NO_STAMP)
    nsec = pc.fill_null(pc.cast(pc.struct_field(stamp, nsec_name), pa.int64()), 0)
    s = sec.to_numpy(zero_copy_only=False)
    ns = nsec.to_numpy(zero_copy_only=False)
    return np.where(s == NO_STAMP, NO_STAMP, s * 1_000_000_000 + ns).astype(np.int64)
