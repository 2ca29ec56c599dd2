"""The same recording twice in one archive (a QA audit, ux56 item 7): a folder holding
a CSV and an MCAP of one recording was analyzed as 10 sensors ("2 sensor faults found
on 2 sensors", one fault found twice) without a word that the inputs were one recording.
Now one copy is analyzed and a note, repeated on stderr, names both files and which one
was kept; a file copied under another name is read once, with a note that says so."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from analyzer.cli import main
from analyzer.readers import open_archive
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

START = "2026-01-01T00:00:00Z"


def _recording() -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """A 4-floor building for 60 s at 100 Hz with an offset on s1 from 36 s."""
    t, y, names = simulate_building(n_floors=4, duration_s=60.0, rate_hz=100.0, seed=3)
    y[:, 1] = inject_fault(y[:, 1], 100.0, "additive", 36.0, 3 * y[:, 1].std())
    t_ns = np.round(t * 1e9).astype(np.int64) + 3  # (nanoseconds a CSV in µs cannot hold)
    return t_ns, {n: y[:, i] for i, n in enumerate(names)}


def _run(args: list[str], capsys) -> tuple[int, str]:
    code = main([*args, "--no-progress"])
    return code, capsys.readouterr().err


def test_a_recording_as_csv_and_as_mcap_is_analyzed_once(tmp_path, capsys):
    t_ns, cols = _recording()
    folder = tmp_path / "in"
    folder.mkdir()
    # the CSV export keeps microseconds: its times differ from the MCAP's by 3 ns
    write_archive(folder / "a.csv", "csv", t_ns // 1000 * 1000, cols, start_iso=START)
    write_archive(folder / "b.mcap", "mcap", t_ns, cols, start_iso=START)
    out = tmp_path / "o"
    code, err = _run(["run", str(folder), "--out", str(out)], capsys)
    assert code == 1
    warned = [line for line in err.splitlines() if "holds the same recording as" in line]
    assert len(warned) == 1
    assert f"{folder / 'b.mcap'} holds the same recording as {folder / 'a.csv'}" in warned[0]
    assert "the first of the two by file name" in warned[0]
    assert "1 sensor fault found on 1 sensor: s1 additive" in err
    assert "linearly dependent" not in err
    doc = json.loads((out / "findings.json").read_text())
    (note,) = [n for n in doc["notes"] if "holds the same recording as" in n]
    assert "/s1.data = s1" in note
    analyzed = sorted(c["name"] for c in doc["channels"] if c["analyzed"])
    assert analyzed == ["s0", "s1", "s2", "s3"]
    twins = {c["name"]: c for c in doc["channels"] if c["name"].startswith("/")}
    assert twins["/s1.data"]["analyzed"] is False
    assert not [n for n in doc["notes"] if n.startswith("copies of another channel")]


def test_sensor_nodes_over_the_same_time_are_no_twins(tmp_path, capsys):
    """One file per sensor node (other channels, same times): both analyzed, no note."""
    t_ns, cols = _recording()
    folder = tmp_path / "in"
    folder.mkdir()
    write_archive(
        folder / "a.csv", "csv", t_ns, {k: cols[k] for k in ("s0", "s1")}, start_iso=START
    )
    write_archive(
        folder / "b.csv", "csv", t_ns, {k: cols[k] for k in ("s2", "s3")}, start_iso=START
    )
    out = tmp_path / "o"
    code, err = _run(["run", str(folder), "--out", str(out)], capsys)
    assert code == 1
    assert "same recording" not in err and "same bytes" not in err
    doc = json.loads((out / "findings.json").read_text())
    assert sorted(c["name"] for c in doc["channels"] if c["analyzed"]) == ["s0", "s1", "s2", "s3"]


def test_a_file_copied_under_another_name_is_read_once(tmp_path, capsys):
    t_ns, cols = _recording()
    folder = tmp_path / "in"
    folder.mkdir()
    write_archive(folder / "a.csv", "csv", t_ns, cols, start_iso=START)
    shutil.copy(folder / "a.csv", folder / "a copy.csv")
    archive = open_archive(folder)
    assert [r.info.path.name for r in archive.readers] == ["a copy.csv"]
    (note,) = archive.notes
    assert note == (
        f"{folder / 'a.csv'} holds the same bytes as {folder / 'a copy.csv'} (a copy of the "
        f"file): read once, as {folder / 'a copy.csv'} (the first of the two by file name)"
    )
    out = tmp_path / "o"
    code, err = _run(["run", str(folder), "--out", str(out)], capsys)
    assert code == 1
    assert "overlap the previous input" not in err  # (five lines that never said why)
    assert err.count("holds the same bytes as") == 1


@pytest.mark.parametrize("shift_ns", [0, 999])
def test_times_within_a_microsecond_are_the_same_times(tmp_path, shift_ns):
    from analyzer.store import ChannelStore
    from analyzer.store.copies import find_copies

    t_ns, cols = _recording()
    write_archive(tmp_path / "a.csv", "csv", t_ns, {"x": cols["s0"]}, start_iso=START)
    later = t_ns.copy()
    later[1::2] += shift_ns  # (every other sample's time off: the start stays)
    write_archive(tmp_path / "b.csv", "csv", later, {"y": cols["s0"]}, start_iso=START)
    write_archive(tmp_path / "c.csv", "csv", t_ns, {"z": cols["s1"]}, start_iso=START)
    paths = [tmp_path / n for n in ("a.csv", "b.csv", "c.csv")]
    with ChannelStore.from_chunks(open_archive(paths).chunks(), tmp_path / "st") as store:
        assert [c.relation for c in find_copies(store, store.select(None))] == ["= x"]


def test_times_apart_by_more_than_a_microsecond_are_not_the_same_times(tmp_path):
    """Equal values at times 2 µs apart (on every other sample) are two recordings."""
    from analyzer.store import ChannelStore
    from analyzer.store.copies import find_copies

    t_ns, cols = _recording()
    write_archive(tmp_path / "a.csv", "csv", t_ns, {"x": cols["s0"]}, start_iso=START)
    later = t_ns.copy()
    later[1::2] += 2_000
    write_archive(tmp_path / "b.csv", "csv", later, {"y": cols["s0"]}, start_iso=START)
    paths = [tmp_path / n for n in ("a.csv", "b.csv")]
    with ChannelStore.from_chunks(open_archive(paths).chunks(), tmp_path / "st") as store:
        assert find_copies(store, store.select(None)) == []
