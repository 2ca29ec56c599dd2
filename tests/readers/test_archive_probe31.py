"""How a folder becomes one archive (archive probe 31): files in subfolders are read
(day folders of hourly files), pieces with relative times that overlap are refused
instead of dropped as repeats, and the archive's notes (a FIFO skipped, an input given
twice) reach ``inspect`` and ``run``'s stderr."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from readers_helpers import collect

from analyzer.cli import main
from analyzer.errors import ReaderError
from analyzer.readers import ArchiveNote, Unstitchable, open_archive
from analyzer.simulate import simulate_building
from analyzer.watch_inbox import InboxTracker
from analyzer.writers import write_ros2_bag

START_S = 1_774_742_400.0  # 2026-03-29T00:00:00Z
RATE_HZ = 50.0


def _csv(path: Path, t_s: np.ndarray, data: dict[str, np.ndarray]) -> Path:
    """A CSV of ``t_s`` (seconds: Unix times from :data:`START_S`, or relative) and
    ``data``, written as a logger's export would be."""
    path.parent.mkdir(parents=True, exist_ok=True)
    columns = [t_s, *data.values()]
    rows = "".join(",".join(f"{v:.6f}" for v in row) + "\n" for row in zip(*columns, strict=True))
    path.write_text("time," + ",".join(data) + "\n" + rows)
    return path


def _piece(path: Path, k: int, n: int = 500, *, relative: bool = False) -> Path:
    """Piece ``k`` of an archive cut every ``n`` samples: channels ``s0``, ``s1``, in Unix
    times going on from the pieces before it; with ``relative``, counting seconds from
    its own start (a logger's export without dates)."""
    i = np.arange(k * n, (k + 1) * n)
    t_s = (i - k * n if relative else i) / RATE_HZ + (0.0 if relative else START_S)
    return _csv(path, t_s, {"s0": np.sin(i / 7.0), "s1": np.cos(i / 11.0)})


# --------------------------------------------------------------------------- subfolders


def test_files_in_subfolders_are_read(tmp_path: Path) -> None:
    """Five hourly files and a sixth in ``sub/``: the sixth was left out without a word
    (a sixth of the archive lost)."""
    folder = tmp_path / "site"
    for k in range(5):
        _piece(folder / f"piece_{k:02d}.csv", k)
    _piece(folder / "sub" / "piece_05.csv", 5)
    archive = open_archive(folder)
    assert [i.path.relative_to(folder).as_posix() for i in archive.inputs] == [
        *(f"piece_{k:02d}.csv" for k in range(5)),
        "sub/piece_05.csv",
    ]
    samples = collect(archive.chunks())
    assert {name: t.size for name, (t, _) in samples.items()} == {"s0": 3000, "s1": 3000}
    assert all(not i.errors for i in archive.inputs) and archive.notes == []


def test_a_folder_of_day_folders_is_one_archive(tmp_path: Path, capsys) -> None:
    """``2026-03-29/`` and ``2026-03-30/`` alone (a common SHM layout): "the directory
    holds no input", exit 2."""
    folder = tmp_path / "site"
    for k in range(3):
        _piece(folder / "2026-03-29" / f"h{k:02d}.csv", k)
    for k in range(3, 6):
        _piece(folder / "2026-03-30" / f"h{k:02d}.csv", k)
    assert main(["inspect", str(folder), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert len(doc["inputs"]) == 6
    assert [(c["name"], c["samples"]) for c in doc["channels"]] == [("s0", 3000), ("s1", 3000)]
    assert doc["channels"][0]["end_s"] == pytest.approx(2999 / RATE_HZ)


def test_empty_subfolders_still_hold_no_input(tmp_path: Path) -> None:
    (tmp_path / "site" / "a" / "b").mkdir(parents=True)
    (tmp_path / "site" / "a" / "readme.txt").write_text("no data\n")
    with pytest.raises(ReaderError, match=r"site: the directory holds no input .* subfolders"):
        open_archive(tmp_path / "site")


def test_subfolders_skip_what_is_not_the_archive(tmp_path: Path) -> None:
    """Hidden folders are skipped without a word, as hidden files are; a backup folder,
    an analysis's output folder (its corrected.csv spans the time from 0), and a folder
    reached again through a symbolic link (a loop up the tree, a ``latest`` link) are
    skipped with a note; a ROS 2 bag inside stays one input."""
    folder = tmp_path / "site"
    _piece(folder / "day1" / "a.csv", 0)
    _piece(folder / "day2" / "b.csv", 1)
    _piece(folder / ".cache" / "x.csv", 2)
    _piece(folder / "day1.bak" / "a.csv", 0)
    out = folder / "day2" / "report"
    out.mkdir()
    (out / "findings.json").write_text("{}")
    (out / "report.html").write_text("<html></html>")
    (out / "corrected.csv").write_text("time,s0\n0.0,1.0\n0.02,1.0\n")
    os.symlink("..", folder / "day1" / "up")  # a loop
    os.symlink("day2", folder / "latest")  # the same folder twice
    t_ns = int((START_S + 20) * 1e9) + np.arange(100, dtype=np.int64) * int(1e9 / RATE_HZ)
    write_ros2_bag(folder / "day2" / "bag", t_ns, {"v": np.arange(100.0)})
    archive = open_archive(folder)
    assert sorted(i.path.relative_to(folder).as_posix() for i in archive.inputs) == [
        "day1/a.csv",
        "day2/b.csv",
        "day2/bag",
    ]
    assert archive.notes == [
        f"{folder / 'day1' / 'up'} not read: a link to {folder.resolve()}, a folder read already",
        f"{folder / 'day1.bak'} not read: a backup or temporary folder (ends in .bak)",
        f"{out / 'corrected.csv'} not read: the analyzer's output beside {out / 'findings.json'}",
        f"{folder / 'latest'} not read: a link to {(folder / 'day2').resolve()}, a folder read "
        "already",
    ]
    assert all(isinstance(n, ArchiveNote) for n in archive.notes)
    samples = collect(archive.chunks())
    assert samples["s0"][0].size == 1000 and samples["/v.data"][0].size == 100


def test_watch_takes_a_dropped_folder_of_day_folders_as_one_archive(tmp_path: Path) -> None:
    """The watcher's archives are INBOX's entries: a folder of day folders stays one
    archive, and its analysis (``open_archive`` of its paths) now reads every day."""
    inbox = tmp_path / "inbox"
    for k in range(2):
        _piece(inbox / "site" / "2026-03-29" / f"h{k}.csv", k)
    _piece(inbox / "site" / "2026-03-30" / "h2.csv", 2)
    _piece(inbox / "other.csv", 0)
    tracker = InboxTracker(inbox, settle=0.5, quiet=True)
    tracker.rescan()
    assert tracker.keys == {"site", "other.csv"}
    tracker.step(0.0)
    ready = {r.name: r for r in tracker.step(1.0)}
    assert set(ready) == {"site", "other.csv"}
    assert ready["site"].paths == (inbox / "site",) and ready["site"].incomplete is None
    archive = open_archive(list(ready["site"].paths))
    assert len(archive.inputs) == 3
    assert collect(archive.chunks())["s0"][0].size == 1500


# --------------------------------------------------------------------------- relative clocks


def test_relative_pieces_that_overlap_are_refused(tmp_path: Path, capsys) -> None:
    """Six pieces each counting from 0 s: pieces 2..6 were dropped sample by sample as
    "overlap the previous input", 100 s analyzed, exit 0, a fault in piece 5 unseen."""
    folder = tmp_path / "rel"
    for k in range(6):
        _piece(folder / f"p{k}.csv", k, relative=True)
    archive = open_archive(folder)
    with pytest.raises(
        Unstitchable,
        match=(
            r"p0\.csv and .*p1\.csv have relative times \(seconds from their own start\) and "
            r"both hold s0 over the same span: they cannot be stitched in time; give them "
            r"absolute times \(dates\), or analyze them one at a time$"
        ),
    ):
        collect(archive.chunks())
    assert main(["inspect", str(folder)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("analyzer: error: ") and "relative times" in err
    assert main(["inspect", str(folder / "p3.csv")]) == 0  # one at a time: fine
    capsys.readouterr()


def test_relative_pieces_of_other_channels_merge(tmp_path: Path) -> None:
    """One file per sensor node, each from 0 s, different channels: merged as before."""
    t_s = np.arange(300) / RATE_HZ
    _csv(tmp_path / "node_a.csv", t_s, {"a0": np.sin(t_s)})
    _csv(tmp_path / "node_b.csv", t_s, {"b0": np.cos(t_s)})
    archive = open_archive([tmp_path / "node_a.csv", tmp_path / "node_b.csv"])
    samples = collect(archive.chunks())
    assert {n: t.size for n, (t, _) in samples.items()} == {"a0": 300, "b0": 300}
    assert all(not i.errors for i in archive.inputs)


def test_relative_pieces_that_follow_each_other_still_stitch(tmp_path: Path) -> None:
    """Relative times that go on from file to file (seconds from the archive's start) are
    one clock; a sample repeated at the seam is dropped as before, not refused."""
    t_s = np.arange(300) / RATE_HZ
    data = {"x": np.arange(300.0)}
    _csv(tmp_path / "a.csv", t_s, data)
    _csv(tmp_path / "b.csv", t_s + t_s[-1], data)  # seam: one sample repeated
    _csv(tmp_path / "c.csv", t_s + 2 * t_s[-1] + t_s[1], data)
    archive = open_archive(tmp_path)
    assert not any(i.info.absolute_time for i in archive.readers)
    samples = collect(archive.chunks())
    assert samples["x"][0].size == 899
    assert archive.inputs[1].errors == [
        "x: 1 samples overlap the previous input in time (a time that a.csv covers already; "
        "its samples are kept); dropped"
    ]


# --------------------------------------------------------------------------- notes


def _fifo_archive(tmp_path: Path) -> Path:
    """A building's 60 s in two CSVs of Unix times, and a FIFO named ``live.csv``."""
    folder = tmp_path / "site"
    t, Y, names = simulate_building(n_floors=4, duration_s=60.0, seed=3)
    half = t.size // 2
    for k, part in enumerate((slice(0, half), slice(half, None))):
        data = {n: Y[part, j] for j, n in enumerate(names)}
        _csv(folder / f"part{k}.csv", START_S + t[part], data)
    os.mkfifo(folder / "live.csv")
    return folder


def test_inspect_shows_the_archives_notes(tmp_path: Path, capsys) -> None:
    """``inspect`` dropped them: neither --json nor the table said that live.csv (a FIFO)
    was not read, nor that part0.csv was given twice."""
    folder = _fifo_archive(tmp_path)
    argv = ["inspect", str(folder), str(folder / "part0.csv")]
    expected = [
        f"{folder / 'live.csv'} not read: not a regular file (a FIFO)",
        f"{folder / 'part0.csv'} given twice: read once",
    ]
    assert main([*argv, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["notes"] == expected
    assert len(doc["inputs"]) == 2
    assert main(argv) == 0
    table = capsys.readouterr().out.splitlines()
    assert [line for line in table if line.startswith("note: ")] == [f"note: {n}" for n in expected]
    assert main(["inspect", str(folder / "part1.csv"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["notes"] == []


def test_run_repeats_the_archives_notes_on_stderr(tmp_path: Path, capsys) -> None:
    """``run`` kept them to findings.json; stderr said nothing."""
    folder = _fifo_archive(tmp_path)
    out = tmp_path / "o"
    code = main(["run", str(folder), str(folder / "part0.csv"), "--out", str(out), "--no-progress"])
    err = capsys.readouterr().err
    assert code == 0, err
    assert err.splitlines() == [
        f"analyzer: warning: {folder / 'live.csv'} not read: not a regular file (a FIFO)",
        f"analyzer: warning: {folder / 'part0.csv'} given twice: read once",
        f"analyzer: no sensor fault found; report: {out / 'report.html'}",
    ]
    notes = json.loads((out / "findings.json").read_text())["notes"]
    assert f"{folder / 'live.csv'} not read: not a regular file (a FIFO)" in notes


def test_relative_pieces_that_overlap_by_a_few_samples_still_stitch(tmp_path: Path) -> None:
    """Pieces that repeat the previous one's last rows (3 of 300) were refused as files
    that each count from their own start (review): only an overlap of half the earlier
    piece's span is that."""
    t_s = np.arange(300) / RATE_HZ
    data = {"x": np.arange(300.0)}
    _csv(tmp_path / "a.csv", t_s, data)
    _csv(tmp_path / "b.csv", t_s + t_s[-3], data)  # its first 3 samples repeat a's last
    archive = open_archive(tmp_path)
    assert collect(archive.chunks())["x"][0].size == 597
    assert archive.inputs[1].errors == [
        "x: 3 samples overlap the previous input in time (40 ms that a.csv covers already; "
        "its samples are kept); dropped"
    ]
