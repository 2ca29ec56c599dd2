"""Archives: several inputs stitched in time order, damaged members recorded, identical
data in every format giving identical channels."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest
from readers_helpers import T0, collect, synthetic

from analyzer.errors import ReaderError
from analyzer.readers import open_archive
from analyzer.types import Format
from analyzer.writers import write_archive

HOUR = 3_600_000_000_000


def _hours(tmp_path: Path, n: int = 600) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Three 'hourly' MCAP files whose names are not in time order."""
    t, data = synthetic(3 * n, channels=2, rate_hz=n / 3600)
    for index, name in enumerate(["c.mcap", "a.mcap", "b.mcap"]):
        part = slice(index * n, (index + 1) * n)
        write_archive(tmp_path / name, "mcap", t[part], {k: v[part] for k, v in data.items()})
    return t, data


def test_directory_is_stitched_in_time_order(tmp_path: Path) -> None:
    t, data = _hours(tmp_path)
    archive = open_archive(tmp_path)
    assert [p.path.name for p in archive.inputs] == ["c.mcap", "a.mcap", "b.mcap"]
    assert archive.start_ns() == T0
    got = collect(archive.chunks())
    np.testing.assert_array_equal(got["/s1.data"][0], t)
    np.testing.assert_array_equal(got["/s1.data"][1], data["s1"])
    for info in archive.inputs:
        assert info.errors == []
        digest = hashlib.sha256(info.path.read_bytes()).hexdigest()
        assert (info.sha256, info.size_bytes) == (digest, info.path.stat().st_size)


@pytest.mark.parametrize("damage", ["zero-bytes", "crlf", "truncated"])
def test_damaged_member_is_recorded_not_raised(tmp_path: Path, damage: str) -> None:
    t, data = _hours(tmp_path)
    victim = tmp_path / "a.mcap"  # the second hour
    raw = victim.read_bytes()
    if damage == "zero-bytes":
        victim.write_bytes(b"")
    elif damage == "crlf":
        victim.write_bytes(raw.replace(b"\r\n", b"\n"))
    else:
        second = slice(600, 1200)
        write_archive(
            victim.with_suffix(".tmp"),
            "mcap",
            t[second],
            {k: v[second] for k, v in data.items()},
            chunk_size=2048,
        )
        raw = victim.with_suffix(".tmp").read_bytes()
        victim.with_suffix(".tmp").unlink()
        victim.write_bytes(raw[: len(raw) // 2])
    archive = open_archive([tmp_path])
    got = collect(archive.chunks())
    info = next(i for i in archive.inputs if i.path == victim)
    assert info.errors, "the damage must be recorded"
    assert info.format is Format.MCAP
    assert info.sha256 == hashlib.sha256(victim.read_bytes()).hexdigest()
    others = [i for i in archive.inputs if i.path != victim]
    assert all(i.errors == [] for i in others)
    t_got, v_got = got["/s0.data"]
    first, third = slice(0, 600), slice(1200, 1800)
    np.testing.assert_array_equal(t_got[:600], t[first])
    np.testing.assert_array_equal(t_got[-600:], t[third])
    np.testing.assert_array_equal(v_got[-600:], data["s0"][third])
    if damage == "truncated":
        assert 1200 < t_got.size < 1800 and any("truncated" in e for e in info.errors)
        read_part = t_got.size - 1200
        np.testing.assert_array_equal(
            v_got[600 : 600 + read_part], data["s0"][600 : 600 + read_part]
        )
    else:
        assert t_got.size == 1200


def test_single_bad_input_raises(tmp_path: Path) -> None:
    bad = tmp_path / "only" / "x.mcap"
    bad.parent.mkdir()
    bad.write_bytes(b"")
    with pytest.raises(ReaderError, match="empty file"):
        open_archive(bad)
    with pytest.raises(ReaderError, match="empty file"):
        open_archive(bad.parent)  # a directory holding one input is a single input


def test_all_members_bad_raises(tmp_path: Path) -> None:
    for name in ("a.mcap", "b.bag"):
        (tmp_path / name).write_bytes(b"")
    with pytest.raises(ReaderError, match="none of the 2 inputs can be read"):
        open_archive(tmp_path)


def test_overlapping_inputs_drop_the_overlap(tmp_path: Path) -> None:
    t, data = synthetic(1000, channels=1)
    write_archive(tmp_path / "one.mcap", "mcap", t[:600], {"s0": data["s0"][:600]})
    write_archive(tmp_path / "two.mcap", "mcap", t[500:], {"s0": data["s0"][500:]})
    archive = open_archive([tmp_path / "two.mcap", tmp_path / "one.mcap"])
    got = collect(archive.chunks())
    np.testing.assert_array_equal(got["/s0.data"][0], np.concatenate([t[:600], t[600:]]))
    assert archive.inputs[1].errors == [
        "/s0: 100 messages overlap the previous input in time (495 ms that one.mcap covers "
        "already; its samples are kept); dropped"
    ]


def test_same_data_in_every_format(tmp_path: Path) -> None:
    t, data = synthetic(1200, channels=3)
    variants = {
        "csv": ("x.csv", "csv", {"start_iso": "2026-01-01T00:00:00Z"}),
        "mcap": ("x.mcap", "mcap", {}),
        "ros1": ("x.bag", "ros1bag", {}),
        "ros2-sqlite3": ("sq", "ros2bag", {"storage": "sqlite3"}),
        "ros2-mcap": ("mc", "ros2bag", {"storage": "mcap"}),
    }
    results = {}
    for label, (name, fmt, kwargs) in variants.items():
        names = write_archive(tmp_path / name, fmt, t, data, **kwargs)
        archive = open_archive(tmp_path / name)
        assert archive.inputs[0].errors == []
        got = collect(archive.chunks())
        results[label] = {key: got[channel] for key, channel in names.items()}
    reference = results.pop("csv")
    for label, samples in results.items():
        for key, (times, values) in samples.items():
            np.testing.assert_array_equal(times, reference[key][0], err_msg=label)
            np.testing.assert_array_equal(values, reference[key][1], err_msg=label)
    for key in data:
        np.testing.assert_array_equal(reference[key][1], data[key])


def test_read_ahead_gives_the_same_stream_and_stops_with_its_consumer(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The next input is read on a thread into a bounded queue: the stream is the same
    chunk for chunk, a consumer that stops early stops the thread, and no thread is left."""
    import threading

    import analyzer.readers as readers

    _hours(tmp_path)
    with monkeypatch.context() as m:
        m.setattr(readers, "_threadable", lambda reader: False)  # one input after the other
        sequential = list(open_archive(tmp_path).chunks())
    assert sequential
    monkeypatch.setattr(readers, "READ_AHEAD_CHUNKS", 1)  # the producer waits on the queue
    ahead = list(open_archive(tmp_path).chunks())
    assert [c.name for c in ahead] == [c.name for c in sequential]
    for a, b in zip(ahead, sequential, strict=True):
        np.testing.assert_array_equal(a.t_ns, b.t_ns)
        np.testing.assert_array_equal(a.values, b.values)
    stream = open_archive(tmp_path).chunks()
    next(stream)
    assert any(t.name == "analyzer-read-ahead" for t in threading.enumerate())
    stream.close()  # the consumer gives up in the first file, the second is being read
    assert not any(t.name == "analyzer-read-ahead" for t in threading.enumerate())


@pytest.mark.parametrize("fmt", ["mcap", "csv", "csv.gz"])
def test_reading_progress_rises_by_bytes_within_and_across_files(
    tmp_path: Path, fmt: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``Archive.chunks(progress=...)`` reports the share read by input bytes: rising,
    below 1 (the caller ends the stage), past each file's share when it is done, and
    inside a file as its reader gets through it (an MCAP file's chunks, a CSV's blocks);
    every report made while the archive is read, none after."""
    import analyzer.readers as readers_module
    from analyzer.readers import _common, csv_reader

    monkeypatch.setattr(readers_module, "PROGRESS_EVERY_S", 0.0)  # every chunk
    monkeypatch.setattr(csv_reader, "BLOCK_BYTES", 1 << 14)  # several blocks per file
    # chunks released every 5000 samples, not every 2 M: a small file's arrive while
    # it is read, as a long file's do
    window = _common.Reorderer.__init__.__defaults__[0]
    monkeypatch.setattr(_common.Reorderer.__init__, "__defaults__", (window, 5000))
    n = 20_000
    t, data = synthetic(3 * n, channels=3, rate_hz=100.0)
    for index in range(3):
        part = slice(index * n, (index + 1) * n)
        start = np.datetime_as_string(np.datetime64(int(t[part][0]), "ns"), unit="ns") + "Z"
        write_archive(
            tmp_path / f"h{index}.{fmt}",
            fmt.split(".")[0],
            t[part],
            {k: v[part] for k, v in data.items()},
            chunk_size=1 << 14,
            start_iso=start if fmt != "mcap" else None,
        )
    archive = open_archive(tmp_path)
    sizes = [info.size_bytes for info in archive.inputs]
    bounds = np.cumsum(sizes) / sum(sizes)
    seen: list[float] = []
    got = collect(archive.chunks(progress=seen.append))
    assert len(got["/s0.data" if fmt == "mcap" else "s0"][0]) == 3 * n  # all read
    assert seen == sorted(seen) and seen[0] >= 0.0 and seen[-1] == readers_module.PROGRESS_CAP
    assert all(f < 1.0 for f in seen)
    for bound in bounds[:-1]:  # each file's end is reported
        assert any(abs(f - bound) < 1e-12 for f in seen)
    # inside the first file: strictly between 0 and its share
    assert any(0.0 < f < bounds[0] - 1e-9 for f in seen), seen[:10]
