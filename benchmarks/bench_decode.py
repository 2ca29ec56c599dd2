"""Decoding throughput and peak memory of the readers, against the reference decoders.

Writes (in a temporary directory) a 16-channel, 200 Hz archive of ``--hours`` hours as

* MCAP, ROS 2 profile: one ``std_msgs/Float64MultiArray`` topic holding the 16 values,
* MCAP, ROS 2 profile: per-sensor ``sensor_msgs/Imu`` topics (3 channels per topic),
* a ROS 1 bag with the same ``Float64MultiArray`` messages,

then measures numeric values decoded per second by

(a) the reference decoders, message by message: ``mcap``'s reader with
    ``mcap_ros2.decoder.DecoderFactory``; ``rosbags.rosbag1.Reader`` with
    ``Typestore.deserialize_ros1``. They run over the first ``--reference-messages``
    messages (they are slow) and their rate is per message, so it extrapolates;
(b) ``analyzer.readers.open_archive`` over the whole file (opening, hashing, reading,
    decoding and time-ordering included),

checks that (b) gives exactly the values (a) gives for those messages, and prints a table.
Last, it compares the peak memory (tracemalloc) of streaming a 1-hour and a 4-hour
archive (``--hours`` and 4 x ``--hours``): a streaming reader needs the same memory for
both. A script, not a timed test::

    python benchmarks/bench_decode.py [--hours 1] [--quick] [--reference-messages 100000]
                                      [--memory {mcap,ros1bag,both,none}]
"""

from __future__ import annotations

import argparse
import itertools
import sys
import tempfile
import time
import tracemalloc
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from analyzer.readers import open_archive  # noqa: E402
from analyzer.writers import write_archive  # noqa: E402

CHANNELS = 16
RATE_HZ = 200.0
T0 = 1_767_225_600_000_000_000  # 2026-01-01T00:00:00Z
IMU_FIELDS = (
    [f"orientation.{a}" for a in "xyzw"]
    + [f"orientation_covariance[{i}]" for i in range(9)]
    + [f"angular_velocity.{a}" for a in "xyz"]
    + [f"angular_velocity_covariance[{i}]" for i in range(9)]
    + [f"linear_acceleration.{a}" for a in "xyz"]
    + [f"linear_acceleration_covariance[{i}]" for i in range(9)]
)


def make_data(hours: float) -> tuple[npt.NDArray[np.int64], dict[str, npt.NDArray[np.float64]]]:
    """``hours`` of 16 random-walk channels at 200 Hz."""
    n = int(round(hours * 3600 * RATE_HZ))
    rng = np.random.default_rng(42)
    t = T0 + np.round(np.arange(n) * (1e9 / RATE_HZ)).astype(np.int64)
    data = {f"s{i}": np.cumsum(rng.normal(scale=0.01, size=n)) for i in range(CHANNELS)}
    return t, data


# --------------------------------------------------------------------------- references


def _get(obj: Any, path: str) -> float:
    """``orientation_covariance[3]`` / ``linear_acceleration.x`` of a decoded object."""
    for part in path.split("."):
        if part.endswith("]"):
            name, index = part[:-1].split("[")
            obj = getattr(obj, name)[int(index)]
        else:
            obj = getattr(obj, part)
    return float(obj)


def flat_values(topic: str, msg: Any, layout: str) -> dict[str, float]:
    """The numeric fields of one decoded message, named as the readers name them."""
    if layout == "imu":
        return {f"{topic}.{f}": _get(msg, f) for f in IMU_FIELDS}
    out = {f"{topic}.data[{i}]": float(v) for i, v in enumerate(msg.data)}
    out[f"{topic}.layout.data_offset"] = float(msg.layout.data_offset)
    for j, dim in enumerate(msg.layout.dim):
        out[f"{topic}.layout.dim[{j}].size"] = float(dim.size)
        out[f"{topic}.layout.dim[{j}].stride"] = float(dim.stride)
    return out


def reference_mcap(path: Path, limit: int) -> Iterator[tuple[str, int, Any]]:
    """mcap reader + mcap_ros2 decoder, one message at a time."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    with path.open("rb") as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in itertools.islice(reader.iter_decoded_messages(), limit):
            yield channel.topic, message.log_time, decoded


def reference_ros1(path: Path, limit: int) -> Iterator[tuple[str, int, Any]]:
    """rosbags' ROS 1 reader + typestore deserializer, one message at a time."""
    from rosbags.rosbag1 import Reader
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    with Reader(path) as reader:
        store = get_typestore(Stores.EMPTY)
        for conn in reader.connections:
            store.register(get_types_from_msg(conn.msgdef.data, conn.msgtype))
        for conn, stamp, raw in itertools.islice(reader.messages(), limit):
            yield conn.topic, stamp, store.deserialize_ros1(raw, conn.msgtype)


# --------------------------------------------------------------------------- measurements


@dataclass
class Row:
    variant: str
    messages: int
    values_per_message: float
    write_s: float
    reference_rate: float
    ours_rate: float
    checked: int
    identical: bool


def measure(
    label: str,
    path: Path,
    layout: str,
    reference: Callable[[Path, int], Iterator[tuple[str, int, Any]]],
    limit: int,
    write_s: float,
) -> Row:
    """Rates of the reference decoder (first ``limit`` messages) and of the reader (whole
    file), and whether the reader's values equal the reference's on those messages."""
    start = time.perf_counter()
    decoded = list(reference(path, limit))  # decoding timed alone; flattening below
    reference_s = time.perf_counter() - start
    expected: dict[str, list[float]] = {}
    expected_t: dict[str, list[int]] = {}
    for topic, stamp, msg in decoded:
        for name, value in flat_values(topic, msg, layout).items():
            expected.setdefault(name, []).append(value)
            expected_t.setdefault(name, []).append(stamp)
    reference_messages = len(decoded)
    reference_values = sum(len(v) for v in expected.values())
    last_checked = max(stamp for _, stamp, _ in decoded)
    del decoded

    start = time.perf_counter()
    total_values = 0
    got: dict[str, list[npt.NDArray[np.float64]]] = {}
    got_t: dict[str, list[npt.NDArray[np.int64]]] = {}
    for chunk in open_archive(path).chunks():
        total_values += len(chunk)
        head = chunk.t_ns <= last_checked
        if head.any():
            got.setdefault(chunk.name, []).append(chunk.values[head])
            got_t.setdefault(chunk.name, []).append(chunk.t_ns[head])
    ours_s = time.perf_counter() - start

    identical = set(expected) <= set(got)
    for name, values in expected.items():
        if not identical:
            break
        n = len(values)
        identical = np.array_equal(
            np.concatenate(got[name])[:n], np.asarray(values)
        ) and np.array_equal(np.concatenate(got_t[name])[:n], np.asarray(expected_t[name]))
    per_message = reference_values / reference_messages
    return Row(
        variant=label,
        messages=int(round(total_values / per_message)),
        values_per_message=per_message,
        write_s=write_s,
        reference_rate=reference_values / reference_s,
        ours_rate=total_values / ours_s,
        checked=reference_messages,
        identical=identical,
    )


def peak_memory(path: Path) -> tuple[float, int]:
    """Peak traced memory (MB) while streaming ``path`` through the reader, and values."""
    tracemalloc.start()
    tracemalloc.reset_peak()
    count = 0
    for chunk in open_archive(path).chunks():
        count += len(chunk)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return peak / 2**20, count


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=1.0, help="archive length (default 1)")
    parser.add_argument("--quick", action="store_true", help="6-minute archives, small reference")
    parser.add_argument(
        "--reference-messages",
        type=int,
        default=100_000,
        help="messages decoded by the reference decoders (default 100000)",
    )
    parser.add_argument(
        "--memory",
        choices=("mcap", "ros1bag", "both", "none"),
        default="mcap",
        help="archives of the 1 h vs 4 h peak-memory run (default mcap)",
    )
    args = parser.parse_args(argv)
    hours = 0.1 if args.quick else args.hours
    limit = min(args.reference_messages, 20_000) if args.quick else args.reference_messages

    rows: list[Row] = []
    with tempfile.TemporaryDirectory(prefix="bench_decode_") as tmp:
        base = Path(tmp)
        t, data = make_data(hours)
        print(
            f"{hours:g} h x {CHANNELS} channels x {RATE_HZ:g} Hz = {t.size:,} samples per channel",
            flush=True,
        )
        variants = [
            ("MCAP Float64MultiArray", "mcap", "multiarray", "multi.mcap", reference_mcap),
            ("MCAP per-sensor Imu", "mcap", "imu", "imu.mcap", reference_mcap),
            ("ROS 1 Float64MultiArray", "ros1bag", "multiarray", "multi.bag", reference_ros1),
        ]
        for label, fmt, layout, name, reference in variants:
            start = time.perf_counter()
            write_archive(base / name, fmt, t, data, layout=layout)
            write_s = time.perf_counter() - start
            print(
                f"  wrote {name} ({(base / name).stat().st_size / 2**20:.0f} MB) "
                f"in {write_s:.1f} s",
                flush=True,
            )
            rows.append(measure(label, base / name, layout, reference, limit, write_s))
            print(f"  measured {label}", flush=True)

        print()
        print(
            f"{'archive':<26}{'messages':>11}{'values/msg':>11}{'reference':>14}"
            f"{'ours':>14}{'speedup':>9}  identical"
        )
        for row in rows:
            print(
                f"{row.variant:<26}{row.messages:>11,}{row.values_per_message:>11.0f}"
                f"{row.reference_rate / 1e6:>10.2f} M/s{row.ours_rate / 1e6:>10.1f} M/s"
                f"{row.ours_rate / row.reference_rate:>8.0f}x  "
                f"{'yes' if row.identical else 'NO'} (first {row.checked:,} messages)"
            )
        print(
            "values/s: numeric values decoded per second (reference: per-message "
            "decoding only; ours: open + hash + read + decode + order)"
        )
        print(f"writing the archives took {sum(r.write_s for r in rows):.0f} s")

        memory = [("mcap", "multi.mcap"), ("ros1bag", "multi.bag")]
        memory = [m for m in memory if args.memory in (m[0], "both")]
        if memory:
            print()
            for fmt, name in memory:
                results = []
                for factor in (1, 4):
                    if factor == 1:
                        path = base / name
                    else:
                        t4, data4 = make_data(hours * factor)
                        path = base / f"x{factor}_{name}"
                        write_archive(path, fmt, t4, data4, layout="multiarray")
                        del t4, data4
                    mb, count = peak_memory(path)
                    results.append((hours * factor, mb, count, path.stat().st_size / 2**20))
                    if factor != 1:
                        path.unlink()
                for h, mb, count, size in results:
                    print(
                        f"peak memory streaming {name:<11} {h:>4g} h ({size:>5.0f} MB file, "
                        f"{count:>11,} values): {mb:6.1f} MB (tracemalloc)"
                    )
    ok = all(r.identical for r in rows)
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
