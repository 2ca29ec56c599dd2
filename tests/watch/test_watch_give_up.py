"""``--give-up-after``: an archive too short for the training window stays in INBOX (a
file still being written grows, and is analyzed again); one unchanged (size and mtime)
that long is given up: an error of its own, moved to ``--failed`` with its reason. Before,
a short but complete archive stayed in INBOX for good, and each ``--once`` exited 2."""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path

import pytest
import test_watch_run
from test_watch_run import SETTLE, Watcher, said, state, wait_until, write

from analyzer.cli import build_parser
from analyzer.config import load_config
from analyzer.options import RunOptions
from analyzer.watch import WatchSettings

# the fixtures of test_watch_run (found by pytest among this module's names)
folders = test_watch_run.folders
start_watcher = test_watch_run.start_watcher
_info_logs = test_watch_run._info_logs
_stop_fork_server = test_watch_run._stop_fork_server


def short_csv(tmp_path: Path, path: Path) -> Path:
    """A CSV of 2 s: too short for the tests' 12 s training window."""
    write(path, "csv", seconds=2.0, seed=4)
    return path


class Clock:
    """The give-up's clock (``analyzer.watch._now``), stopped at the test's start and
    moved only by the test (``ahead`` seconds): no give-up depends on how long the
    machine took (before, the clock ran on with ours, ``ahead`` seconds ahead)."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.ahead = 0.0
        self.start = time.time()
        # (raising=False: on a watcher without it, the assertions fail, not this)
        monkeypatch.setattr("analyzer.watch._now", lambda: self.start + self.ahead, raising=False)


def test_the_give_up_counts_from_first_sight_not_from_the_mtime(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A short file whose mtime is two hours old (a share whose clock is behind, a copy
    that kept it) is not given up at first sight (before: moved to --failed at once);
    an hour after (the default) the watcher first saw it, it is, and its error.txt says
    so. A long archive fits these options."""
    clock = Clock(monkeypatch)
    inbox, reports = folders
    failed = tmp_path / "failed"
    old = short_csv(tmp_path, inbox / "old.csv")
    two_hours_ago = time.time() - 7200
    os.utime(old, (two_hours_ago, two_hours_ago))
    write(inbox / "long.csv", "csv", seed=5)
    settings = WatchSettings(
        inbox, reports, settle=SETTLE, failed=failed, once=True, give_up_after=3600.0
    )
    assert start_watcher(settings).join() == 2
    assert (inbox / "old.csv").is_file() and not any(failed.iterdir())
    (left,) = said(caplog, "old.csv: left in INBOX")
    assert "given up and moved to --failed at " in left and "--give-up-after 3600" in left
    # a touch, and 59 minutes later: still there
    os.utime(old)
    clock.ahead = 59 * 60
    caplog.clear()
    assert start_watcher(settings).join() == 2
    assert (inbox / "old.csv").is_file() and not said(caplog, "given up:")
    (again,) = said(caplog, "old.csv: left in INBOX")  # (the time it said at first sight)
    assert again.partition(" at ")[2][:19] == left.partition(" at ")[2][:19], (left, again)
    clock.ahead = 3601
    caplog.clear()
    assert start_watcher(settings).join() == 0
    assert not (inbox / "old.csv").exists() and (failed / "old.csv").is_file()
    (line,) = said(caplog, "old.csv: given up")
    assert "too short for the training window and unchanged for 60 min" in line, line
    rec = state(reports)["old.csv"]
    assert (rec["error_kind"], rec["error_reason"]) == ("input", "too short")
    assert "(given up: unchanged for 60 min" in rec["error"]
    # error.txt's first line is the error the index says (before: the plain one)
    error_txt = (reports / rec["report"]).read_text()
    assert error_txt.partition("\n")[0] == rec["error"], (error_txt, rec["error"])


def test_a_train_window_that_fits_no_archive_gives_up_none(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Every archive too short for these options' training window (a mistyped
    ``--train``), however long unchanged: all stay in INBOX, said "check --train", as on
    the base (before: the whole INBOX given up to --failed as the archives' errors). Once
    an archive fits, the ones unchanged that long are given up."""
    clock = Clock(monkeypatch)
    inbox, reports = folders
    failed = tmp_path / "failed"
    two_hours_ago = time.time() - 7200
    for name in ("a.csv", "b.csv"):
        os.utime(short_csv(tmp_path, inbox / name), (two_hours_ago, two_hours_ago))
    settings = WatchSettings(inbox, reports, settle=SETTLE, failed=failed, once=True)
    assert start_watcher(settings).join() == 2
    clock.ahead = 7200
    caplog.clear()
    assert start_watcher(settings).join() == 2
    assert sorted(p.name for p in inbox.iterdir()) == ["a.csv", "b.csv"]
    assert not any(failed.iterdir())
    assert not said(caplog, "given up:")
    assert all("check --train" in line for line in said(caplog, ": left in INBOX:"))
    assert len(said(caplog, ": left in INBOX:")) == 2
    write(inbox / "long.csv", "csv", seed=5)
    caplog.clear()
    assert start_watcher(settings).join() == 0
    assert sorted(p.name for p in failed.iterdir()) == ["a.csv", "b.csv"]


def test_a_config_train_window_that_fits_no_archive_names_the_config(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A training window set by the config's ``[train]`` (no ``--train``) that fits no
    archive: the line says to check that config's [train], where the window came from
    (a new user's audit, ux53 item 6: before, "check --train", which was not given)."""
    inbox, reports = folders
    for name in ("a.csv", "b.csv"):
        short_csv(tmp_path, inbox / name)
    cfg = tmp_path / "cfg.toml"
    cfg.write_text("[train]\nstart = 0.0\nend = 12.0\n")
    options = RunOptions(config=load_config(cfg))
    settings = WatchSettings(inbox, reports, settle=SETTLE, failed=tmp_path / "failed", once=True)
    assert start_watcher(settings, options).join() == 2
    lines = said(caplog, ": left in INBOX:")
    assert len(lines) == 2
    for line in lines:
        assert f"check --config {cfg} [train]" in line, line
        assert "--train" not in line, line


def test_the_default_window_that_fits_no_archive_says_to_give_one(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Neither ``--train`` nor a config ``[train]``: the default window fits no archive,
    and the line says to give one, in one parenthesis (rcfg53 item 3: before, "check
    --train (the default training window is used) (given up only once ...)", an option
    not given and two parentheses in a row)."""
    inbox, reports = folders
    for name in ("a.csv", "b.csv"):
        short_csv(tmp_path, inbox / name)
    settings = WatchSettings(inbox, reports, settle=SETTLE, failed=tmp_path / "failed", once=True)
    assert start_watcher(settings, RunOptions()).join() == 2
    lines = said(caplog, ": left in INBOX:")
    assert len(lines) == 2
    for line in lines:
        advice = line.split("no archive has fit these options yet: ", 1)[1]
        assert advice.startswith("give --train or a config [train] ("), line
        assert "check" not in advice and ") (" not in advice, line
        assert advice.count("(") == 1 and advice.endswith(")"), line


def test_a_running_watcher_gives_up_a_short_archive_once_its_time_is_up(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A watcher left running gives the short file up once the give-up's clock (stopped,
    moved by the test alone: no wall-clock time counts) passes its time, without a
    change or a restart to look at it again."""
    clock = Clock(monkeypatch)
    inbox, reports = folders
    failed = tmp_path / "failed"
    write(inbox / "long.csv", "csv", seed=5)
    short_csv(tmp_path, inbox / "a.csv")
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, failed=failed)
    watcher = start_watcher(settings)
    wait_until(lambda: said(caplog, "a.csv: left in INBOX"), "the short file's error")
    wait_until(lambda: "long.csv" in state(reports), "the long file's analysis")
    assert (inbox / "a.csv").is_file()
    clock.ahead = 3601  # (the give-up's clock, not ours: no test waits an hour)
    wait_until(lambda: (failed / "a.csv").is_file(), "the short file given up")
    watcher.stop.set()
    assert watcher.join() == 0
    assert said(caplog, "a.csv: given up: too short for the training window and unchanged")


def test_give_up_after_is_an_option_of_watch() -> None:
    args = build_parser().parse_args(["watch", "in", "--out", "r", "--give-up-after", "90"])
    assert WatchSettings.from_args(args).give_up_after == 90.0
    args = build_parser().parse_args(["watch", "in", "--out", "r", "--give-up-after", "0"])
    assert WatchSettings.from_args(args).give_up_after == 0.0
    args = build_parser().parse_args(["watch", "in", "--out", "r"])
    assert WatchSettings.from_args(args).give_up_after == 3600.0
