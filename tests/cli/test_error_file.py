"""A cut error line says where the whole message is (:mod:`analyzer.error_file`): the
line was cut at :data:`~analyzer.errors.LINE_MOST` characters with ``[N characters in
all]`` and the rest was nowhere (the audit: a refusal of several detectors cut at 817
characters, the advice that fixed the run in the part cut)."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import one_line_error, run_cli

from analyzer.error_file import error_place, keep_whole, remove_stale
from analyzer.errors import LINE_MOST
from analyzer.simulate import simulate_building

PREFIX = "analyzer: error: "


def _save(path: Path, t: np.ndarray, columns: np.ndarray, names: list[str]) -> Path:
    header = "time," + ",".join(names)
    np.savetxt(
        path, np.column_stack([t, columns]), delimiter=",", header=header, comments="", fmt="%.17g"
    )
    return path


def _too_short(path: Path) -> Path:
    """A CSV every detector refuses at length: 120 s of fast channels beside slow ones
    with long names (the clock runs at the slow channels' 5 Hz)."""
    t, y, _ = simulate_building(2, 120.0, 100.0, seed=1, sensors_per_floor=2)
    slow = np.full((t.size, 8), np.nan)
    slow[::20] = np.random.default_rng(0).standard_normal((t[::20].size, 8)).cumsum(axis=0)
    fast = [f"/a/rather/long/topic/name/of/an/accelerometer_{k}.data" for k in range(4)]
    names = [*fast, *(f"/slow/topic/with/a/long/name/c{k}.data" for k in range(8))]
    return _save(path, t, np.column_stack([y, slow]), names)


def _whole(err_line: str) -> tuple[int, str]:
    """The count of characters and the path a cut line ends with."""
    tail = err_line.rsplit(" [", 1)[1]
    count, _, where = tail.removesuffix("]").partition(" characters in all; the whole message: ")
    assert where, err_line
    return int(count.replace(",", "")), where


@pytest.fixture
def tmpdir_here(tmp_path, monkeypatch):
    """The system's temporary folder, for this test: a folder of its own."""
    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    return folder


def test_run_keeps_the_whole_message_in_out_error_txt(tmp_path, capsys, tmpdir_here):
    data = tmp_path / "data"
    data.mkdir()
    path = _too_short(data / "s.csv")
    out = tmp_path / "o"
    code, stdout, err = run_cli(["run", path, "--out", out, "--no-progress"], capsys)
    assert code == 2 and stdout == ""
    line = one_line_error(err, str(path), "no detector could run")
    assert len(line) <= len(PREFIX) + LINE_MOST
    count, where = _whole(line)
    assert where == str(out / "error.txt")
    head, message = (out / "error.txt").read_text(encoding="utf-8").splitlines()
    assert head.startswith("analyzer run: error (exit code 2), ")
    # the whole message: as long as the line says, and its cut head is the line's
    assert len(message) == count > LINE_MOST
    shown = line.removeprefix(PREFIX).rsplit(" ...", 1)[0]
    assert message.startswith(shown)
    assert sorted(p.name for p in out.iterdir()) == ["error.txt"]
    assert sorted(p.name for p in data.iterdir()) == ["s.csv"]  # nothing beside the input
    assert list(tmpdir_here.iterdir()) == []


def test_a_later_successful_run_removes_the_error_file(tmp_path, capsys, tmpdir_here):
    out = tmp_path / "o"
    bad = _too_short(tmp_path / "short.csv")
    assert run_cli(["run", bad, "--out", out, "--no-progress"], capsys)[0] == 2
    assert (out / "error.txt").is_file()
    t, y, names = simulate_building(2, 60.0, 100.0, seed=3)
    good = _save(tmp_path / "good.csv", t, y, names)
    code, _, err = run_cli(["run", good, "--out", out, "--no-progress"], capsys)
    assert code in (0, 1), err
    assert not (out / "error.txt").exists()
    assert (out / "findings.json").is_file()


def test_a_users_error_txt_is_left_alone(tmp_path):
    mine = tmp_path / "error.txt"
    mine.write_text("my notes on the failed sensor\n", encoding="utf-8")
    remove_stale(mine)
    assert mine.read_text(encoding="utf-8") == "my notes on the failed sensor\n"
    written = keep_whole("x" * 700, "run", tmp_path / "o" / "error.txt", [])
    assert written == str(tmp_path / "o" / "error.txt")
    remove_stale(Path(written))
    assert not Path(written).exists()


def test_out_beside_the_input_sends_the_message_to_tmpdir(tmp_path, capsys, tmpdir_here):
    """``--out`` the input's own folder: the error file is not written beside the input."""
    data = tmp_path / "data"
    data.mkdir()
    path = _too_short(data / "s.csv")
    code, _, err = run_cli(["run", path, "--out", data, "--no-progress"], capsys)
    assert code == 2
    count, where = _whole(one_line_error(err, str(path)))
    assert Path(where).parent == tmpdir_here and Path(where).name.startswith("analyzer-error-")
    assert len(Path(where).read_text(encoding="utf-8").splitlines()[1]) == count
    assert sorted(p.name for p in data.iterdir()) == ["s.csv"]


def test_an_unwritable_place_falls_back_to_tmpdir(tmp_path, tmpdir_here):
    blocker = tmp_path / "file"
    blocker.write_text("", encoding="utf-8")
    where = keep_whole("y" * 700, "run", blocker / "o" / "error.txt", [])
    assert where is not None and Path(where).parent == tmpdir_here
    assert Path(where).read_text(encoding="utf-8").splitlines()[1] == "y" * 700


def test_inspect_keeps_the_whole_message_in_tmpdir(tmp_path, capsys, tmpdir_here):
    """Three damaged MCAP files of long names in a folder: nothing read, the line lists
    their errors and is cut; inspect has no output folder."""
    src = Path(__file__).resolve().parents[2] / "samples" / "building_additive.mcap"
    folder = tmp_path / "in"
    folder.mkdir()
    for k in range(3):
        # (cut at 300-302 bytes: three copies of the same bytes would be read once)
        (folder / f"recording_{k}_{'0' * 150}.mcap").write_bytes(src.read_bytes()[: 300 + k])
    code, stdout, err = run_cli(["inspect", folder], capsys)
    assert code == 2 and stdout == ""
    # (cut inside their first chunk: nothing of it decompresses)
    cut = (
        "truncated inside the zstd-compressed chunk that starts at byte 45 (the file ends at "
        "byte 30"
    )
    count, where = _whole(one_line_error(err, cut))
    head, message = Path(where).read_text(encoding="utf-8").splitlines()
    assert Path(where).parent == tmpdir_here
    assert head.startswith("analyzer inspect: error (exit code 2), ")
    assert len(message) == count and message.count(cut) == 3
    assert len(list(folder.iterdir())) == 3


def test_error_place_of_each_command():
    assert error_place("run", "o") == Path("o/error.txt")
    assert error_place("export", "d/x.csv") == Path("d/x.csv.error.txt")
    assert error_place("inspect", None) is None
    assert error_place("watch", "reports") is None  # (its report folders keep theirs)
