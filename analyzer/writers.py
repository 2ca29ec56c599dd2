"""Archive writers for tests, sample data and benchmarks, built on the real writer
libraries: ``mcap`` (ROS 2 profile, CDR), ``rosbags`` (ROS 1 bags, ROS 2 bags with sqlite3 or
MCAP storage) and pandas (CSV).

Messages are serialized in bulk: one template message is serialized by rosbags, its
byte layout computed (:func:`analyzer.readers.rosdecode.compute_layout`), and the values of
all messages written into an ``(n, size)`` byte matrix with numpy; the libraries then
write the records. ``serializer="library"`` (MCAP only) instead encodes every message with
``mcap_ros2``'s own encoder, which the tests use to cross-check the bulk bytes.

Layouts and the channel names they produce (``write_archive`` returns this mapping):

* ``"float64"``: one ``std_msgs/msg/Float64`` topic per key; key ``s0`` -> topic ``/s0``
  -> channel ``/s0.data``.
* ``"multiarray"``: one ``std_msgs/msg/Float64MultiArray`` topic ``/data``; the i-th key
  (in mapping order) -> channel ``/data.data[i]``. The message also carries the numeric
  field ``layout.data_offset`` (always 0): channel ``/data.layout.data_offset``.
* ``"imu"``: keys taken three at a time (in mapping order) into ``sensor_msgs/msg/Imu``
  topics ``/imu0``, ``/imu1``, ...: the keys of group K -> channels
  ``/imuK.linear_acceleration.x``, ``.y``, ``.z`` (a last group with fewer keys leaves the
  remaining axes 0). Every Imu message also has orientation ``(0, 0, 0, 1)``, zero
  angular velocity and zero covariances (34 more constant channels per topic), and
  ``header.stamp`` equal to its log time (plus ``header_offset_ns``: one offset for
  all, or one per message, as a recorder that logs some messages late gives: log times
  ``t_ns`` that jitter, and ``header_offset_ns = regular - t_ns``).
* CSV ignores the layout: column ``time`` (seconds from the first sample, with 9
  decimals, or ISO-8601 UTC strings when ``start_iso`` is given), then one column per key
  named by the key.

Timestamps: ``t_ns`` is written as given (log time), unless ``start_iso`` is given; then
every format starts at that instant (``start + t_ns - t_ns[0]``).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore

from analyzer.readers.rosdecode import NUMERIC, Layout, compute_layout
from analyzer.types import Format

LAYOUTS = ("float64", "multiarray", "imu")
IMU_AXES = ("x", "y", "z")


# --------------------------------------------------------------------------- messages


def default_message(store: Typestore, msgtype: str, **values: Any) -> Any:
    """A ``msgtype`` object of ``store`` with zeros, empty strings and empty sequences,
    and ``values`` for top-level fields."""
    cls = store.types[msgtype]
    kwargs: dict[str, Any] = {}
    for name, desc in store.fielddefs[msgtype][1]:
        kwargs[name] = _default_value(store, desc)
    kwargs.update(values)
    return cls(**kwargs)


def _default_value(store: Typestore, desc: Any) -> Any:
    node = desc[0]
    if node == Nodetype.BASE:
        kind = desc[1][0]
        if kind == "string":
            return ""
        if kind == "bool":
            return False
        return 0.0 if kind.startswith("float") else 0
    if node == Nodetype.NAME:
        return default_message(store, desc[1])
    sub, count = desc[1]
    length = count if node == Nodetype.ARRAY else 0
    if sub[0] == Nodetype.BASE and sub[1][0] != "string":
        kind = sub[1][0]
        return np.zeros(length, dtype=np.dtype(NUMERIC[kind]).newbyteorder("="))
    return [_default_value(store, sub) for _ in range(length)]


def bulk_serialize(
    store: Typestore,
    msgtype: str,
    template: Any,
    columns: Mapping[str, npt.ArrayLike],
    *,
    encoding: str,
    stamps: npt.NDArray[np.int64] | None = None,
) -> npt.NDArray[np.uint8]:
    """Serialize ``n`` messages that differ from ``template`` only in numeric leaves.

    ``columns`` maps leaf names (``linear_acceleration.x``, ``data[3]``) to n values;
    ``stamps`` (nanoseconds) fills the top-level ``header.stamp``. Returns the messages
    as an ``(n, size)`` uint8 matrix (each row one serialized message).
    """
    raw = (
        store.serialize_cdr(template, msgtype)
        if encoding == "cdr"
        else store.serialize_ros1(template, msgtype)
    )
    data = bytes(raw)
    layout: Layout = compute_layout(store, msgtype, data, "cdr" if encoding == "cdr" else "ros1")
    lengths = {len(np.asarray(v)) for v in columns.values()}
    if stamps is not None:
        lengths.add(len(stamps))
    if len(lengths) != 1:
        raise ValueError(f"columns of different lengths: {sorted(lengths)}")
    n = lengths.pop()
    rows = np.tile(np.frombuffer(data, dtype=np.uint8), (n, 1))
    leaves = layout.leaves()
    for name, values in columns.items():
        if name not in leaves:
            raise KeyError(f"{msgtype} has no numeric field {name!r}")
        offset, kind = leaves[name]
        dtype = np.dtype(layout.endian + NUMERIC[kind])
        view = np.ndarray(
            shape=(n,), dtype=dtype, buffer=rows, offset=offset, strides=(layout.size,)
        )
        view[:] = np.asarray(values)
    if stamps is not None:
        if layout.stamp is None:
            raise ValueError(f"{msgtype} has no header stamp")
        sec_off, nsec_off = layout.stamp
        stamps = np.asarray(stamps, dtype=np.int64)
        for offset, part, code in (
            (sec_off, stamps // 1_000_000_000, "i4"),
            (nsec_off, stamps % 1_000_000_000, "u4"),
        ):
            view = np.ndarray(
                shape=(n,),
                dtype=layout.endian + code,
                buffer=rows,
                offset=offset,
                strides=(layout.size,),
            )
            view[:] = part
    return rows


# --------------------------------------------------------------------------- topics


def _topics(
    layout: str,
    store: Typestore,
    data: Mapping[str, npt.NDArray[Any]],
    stamps: npt.NDArray[np.int64],
    *,
    encoding: str,
) -> tuple[list[tuple[str, str, npt.NDArray[np.uint8]]], dict[str, str]]:
    """(topic, msgtype, serialized rows) per topic, and the key -> channel mapping."""
    keys = list(data)
    out: list[tuple[str, str, npt.NDArray[np.uint8]]] = []
    names: dict[str, str] = {}
    if layout == "float64":
        msgtype = "std_msgs/msg/Float64"
        template = default_message(store, msgtype)
        for key in keys:
            rows = bulk_serialize(store, msgtype, template, {"data": data[key]}, encoding=encoding)
            out.append((f"/{key}", msgtype, rows))
            names[key] = f"/{key}.data"
    elif layout == "multiarray":
        msgtype = "std_msgs/msg/Float64MultiArray"
        template = default_message(store, msgtype, data=np.zeros(len(keys), dtype=np.float64))
        columns = {f"data[{i}]": data[key] for i, key in enumerate(keys)}
        rows = bulk_serialize(store, msgtype, template, columns, encoding=encoding)
        out.append(("/data", msgtype, rows))
        names.update({key: f"/data.data[{i}]" for i, key in enumerate(keys)})
    elif layout == "imu":
        msgtype = "sensor_msgs/msg/Imu"
        for group in range(0, len(keys), 3):
            index = group // 3
            header = default_message(store, "std_msgs/msg/Header", frame_id=f"imu{index}")
            orientation = default_message(store, "geometry_msgs/msg/Quaternion", w=1.0)
            template = default_message(store, msgtype, header=header, orientation=orientation)
            columns = {}
            for axis, key in zip(IMU_AXES, keys[group : group + 3], strict=False):
                columns[f"linear_acceleration.{axis}"] = data[key]
                names[key] = f"/imu{index}.linear_acceleration.{axis}"
            rows = bulk_serialize(
                store, msgtype, template, columns, encoding=encoding, stamps=stamps
            )
            out.append((f"/imu{index}", msgtype, rows))
    else:
        raise ValueError(f"unknown layout {layout!r}; expected one of {', '.join(LAYOUTS)}")
    return out, names


def _interleaved(
    topics: list[tuple[str, str, npt.NDArray[np.uint8]]], t_ns: npt.NDArray[np.int64]
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]]:
    """Write order: time-major, topics interleaved (as a recorder would write them).
    Returns (topic index, row index, time) per message."""
    n, k = t_ns.shape[0], len(topics)
    topic = np.tile(np.arange(k, dtype=np.int64), n)
    row = np.repeat(np.arange(n, dtype=np.int64), k)
    return topic, row, t_ns[row]


# --------------------------------------------------------------------------- writers


def _mcap(
    path: Path,
    layout: str,
    t_ns: npt.NDArray[np.int64],
    data: Mapping[str, npt.NDArray[Any]],
    *,
    compression: str | None,
    serializer: str,
    chunk_size: int,
    header_offset_ns: int | npt.NDArray[np.int64],
) -> dict[str, str]:
    from mcap.writer import CompressionType
    from mcap.writer import Writer as McapWriter

    store = get_typestore(Stores.ROS2_HUMBLE)
    topics, names = _topics(layout, store, data, t_ns + header_offset_ns, encoding="cdr")
    kind = {
        None: CompressionType.ZSTD,
        "zstd": CompressionType.ZSTD,
        "lz4": CompressionType.LZ4,
        "none": CompressionType.NONE,
    }[compression]
    order = _interleaved(topics, t_ns)
    if serializer == "library":
        from mcap_ros2.writer import Writer as Ros2Writer

        with path.open("wb") as stream:
            ros2 = Ros2Writer(stream, chunk_size=chunk_size, compression=kind)
            schemas = {}
            for topic, msgtype, _ in topics:
                text, _ = store.generate_msgdef(msgtype, ros_version=2)
                schemas[topic] = ros2.register_msgdef(msgtype, text)
            decoded = [
                [store.deserialize_cdr(row.tobytes(), msgtype) for row in rows]
                for _, msgtype, rows in topics
            ]
            for ti, ri, t in zip(*(a.tolist() for a in order), strict=True):
                topic = topics[ti][0]
                ros2.write_message(
                    topic, schemas[topic], _as_dict(decoded[ti][ri]), log_time=t, publish_time=t
                )
            ros2.finish()
        return names
    with path.open("wb") as stream:
        writer = McapWriter(stream, chunk_size=chunk_size, compression=kind)
        writer.start(profile="ros2", library="analyzer.writers")
        channel_ids = []
        for topic, msgtype, _ in topics:
            text, _ = store.generate_msgdef(msgtype, ros_version=2)
            schema_id = writer.register_schema(msgtype, "ros2msg", text.encode())
            channel_ids.append(writer.register_channel(topic, "cdr", schema_id))
        blobs = [rows.tobytes() for _, _, rows in topics]
        sizes = [rows.shape[1] for _, _, rows in topics]
        add = writer.add_message
        for ti, ri, t in zip(*(a.tolist() for a in order), strict=True):
            size = sizes[ti]
            add(channel_ids[ti], t, blobs[ti][ri * size : (ri + 1) * size], t, ri)
        writer.finish()
    return names


def _as_dict(obj: Any) -> Any:
    """A rosbags message as the nested dicts/lists ``mcap_ros2``'s encoder takes."""
    if hasattr(obj, "__dataclass_fields__"):
        return {
            name: _as_dict(getattr(obj, name))
            for name in obj.__dataclass_fields__
            if name != "__msgtype__"
        }
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, list):
        return [_as_dict(x) for x in obj]
    return obj


def _ros1(
    path: Path,
    layout: str,
    t_ns: npt.NDArray[np.int64],
    data: Mapping[str, npt.NDArray[Any]],
    *,
    compression: str | None,
    header_offset_ns: int | npt.NDArray[np.int64],
) -> dict[str, str]:
    from rosbags.rosbag1 import Writer as Bag1Writer

    store = get_typestore(Stores.ROS1_NOETIC)
    topics, names = _topics(layout, store, data, t_ns + header_offset_ns, encoding="ros1")
    order = _interleaved(topics, t_ns)
    writer = Bag1Writer(path)
    if compression in ("bz2", "lz4"):
        writer.set_compression(getattr(Bag1Writer.CompressionFormat, compression.upper()))
    elif compression not in (None, "none"):
        raise ValueError(f"ROS 1 bags support bz2 or lz4 compression, not {compression!r}")
    with writer:
        conns = [
            writer.add_connection(topic, msgtype, typestore=store) for topic, msgtype, _ in topics
        ]
        blobs = [rows.tobytes() for _, _, rows in topics]
        sizes = [rows.shape[1] for _, _, rows in topics]
        write = writer.write
        for ti, ri, t in zip(*(a.tolist() for a in order), strict=True):
            size = sizes[ti]
            write(conns[ti], t, blobs[ti][ri * size : (ri + 1) * size])
    return names


def write_ros2_bag(
    path: str | Path,
    t_ns: npt.NDArray[np.int64],
    data: Mapping[str, npt.NDArray[Any]],
    *,
    layout: str = "float64",
    storage: str = "sqlite3",
    header_offset_ns: int | npt.NDArray[np.int64] = 0,
) -> dict[str, str]:
    """Write a ROS 2 bag directory (rosbag2 version 9, ``storage`` ``"sqlite3"`` or
    ``"mcap"``) with rosbags; returns the key -> channel mapping (see the module doc)."""
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Bag2Writer

    path = Path(path)
    t_ns = np.asarray(t_ns, dtype=np.int64)
    store = get_typestore(Stores.ROS2_HUMBLE)
    plugins = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}
    if storage not in plugins:
        raise ValueError(f"storage must be 'sqlite3' or 'mcap', not {storage!r}")
    topics, names = _topics(layout, store, data, t_ns + header_offset_ns, encoding="cdr")
    order = _interleaved(topics, t_ns)
    with Bag2Writer(path, version=9, storage_plugin=plugins[storage]) as writer:
        conns = [
            writer.add_connection(topic, msgtype, typestore=store) for topic, msgtype, _ in topics
        ]
        blobs = [rows.tobytes() for _, _, rows in topics]
        sizes = [rows.shape[1] for _, _, rows in topics]
        write = writer.write
        for ti, ri, t in zip(*(a.tolist() for a in order), strict=True):
            size = sizes[ti]
            write(conns[ti], t, blobs[ti][ri * size : (ri + 1) * size])
    return names


def _csv(
    path: Path,
    t_ns: npt.NDArray[np.int64],
    data: Mapping[str, npt.NDArray[Any]],
    *,
    start_ns: int | None,
) -> dict[str, str]:
    relative = t_ns - t_ns[0]
    if start_ns is None:
        sec = (relative // 1_000_000_000).astype(str)
        frac = np.char.zfill((relative % 1_000_000_000).astype(str), 9)
        time = np.char.add(np.char.add(sec, "."), frac)
    else:
        absolute = start_ns + relative
        whole = pd.to_datetime(absolute // 1_000_000_000 * 1_000_000_000, utc=True)
        frac = np.char.zfill((absolute % 1_000_000_000).astype(str), 9)
        stamp = np.asarray(whole.strftime("%Y-%m-%dT%H:%M:%S"), dtype=str)
        time = np.char.add(np.char.add(np.char.add(stamp, "."), frac), "Z")
    frame = pd.DataFrame({"time": time, **{key: np.asarray(v) for key, v in data.items()}})
    sep = "\t" if path.name.lower().removesuffix(".gz").endswith(".tsv") else ","
    frame.to_csv(path, index=False, sep=sep)
    return {key: key for key in data}


def write_archive(
    path: str | Path,
    fmt: Format | str,
    t_ns: npt.NDArray[np.int64],
    data: Mapping[str, npt.NDArray[Any]],
    *,
    layout: str = "float64",
    storage: str = "sqlite3",
    start_iso: str | None = None,
    compression: str | None = None,
    serializer: str = "numpy",
    chunk_size: int = 1 << 20,
    header_offset_ns: int | npt.NDArray[np.int64] = 0,
) -> dict[str, str]:
    """Write ``data`` (key -> values, one value per ``t_ns`` entry) as ``fmt``.

    ``fmt``: ``"mcap"`` (ROS 2 profile, CDR; ``compression`` ``"zstd"`` (default),
    ``"lz4"`` or ``"none"``), ``"ros1bag"`` (``compression`` ``None``, ``"bz2"`` or
    ``"lz4"``), ``"ros2bag"`` (``storage`` ``"sqlite3"`` or ``"mcap"``) or ``"csv"`` (a
    ``.tsv`` path is tab separated, ``.gz`` is compressed). ``layout``: see the module
    doc. Returns the mapping key -> channel name the readers produce.
    """
    path = Path(path)
    fmt = Format(fmt)
    t_ns = np.asarray(t_ns, dtype=np.int64)
    if t_ns.ndim != 1 or t_ns.size == 0:
        raise ValueError("t_ns must be a non-empty 1-D array of nanoseconds")
    arrays = {str(k): np.asarray(v, dtype=np.float64) for k, v in data.items()}
    if not arrays:
        raise ValueError("data holds no channel")
    for key, values in arrays.items():
        if values.shape != t_ns.shape:
            raise ValueError(f"data[{key!r}] has shape {values.shape}, expected {t_ns.shape}")
    start_ns = None
    if start_iso is not None:
        stamp = pd.Timestamp(start_iso)
        stamp = stamp.tz_localize("UTC") if stamp.tzinfo is None else stamp.tz_convert("UTC")
        start_ns = int(stamp.value)
        t_ns = start_ns + (t_ns - t_ns[0])
    if fmt is Format.CSV:
        return _csv(path, t_ns, arrays, start_ns=start_ns)
    if fmt is Format.MCAP:
        return _mcap(
            path,
            layout,
            t_ns,
            arrays,
            compression=compression,
            serializer=serializer,
            chunk_size=chunk_size,
            header_offset_ns=header_offset_ns,
        )
    if fmt is Format.ROS1BAG:
        return _ros1(
            path, layout, t_ns, arrays, compression=compression, header_offset_ns=header_offset_ns
        )
    return write_ros2_bag(
        path, t_ns, arrays, layout=layout, storage=storage, header_offset_ns=header_offset_ns
    )
