"""``analyzer watch`` logs, for each archive it analyzes, the config warnings that
``analyzer run`` prints (:func:`analyzer.pipeline.config_warnings`): a ``[model]`` naming a
channel the archive lacks is not used, and the user is told so in both modes."""

from __future__ import annotations

import logging
import multiprocessing
import multiprocessing.forkserver
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from analyzer.cli import main
from analyzer.options import RunOptions, load_options
from analyzer.simulate import simulate_building
from analyzer.watch import CONFIG_WARNINGS, WatchSettings, analysis_into, watch
from analyzer.writers import write_archive

TIMEOUT = 120.0
CONFIG = """\
[model]
A = [[0.5]]
B = [[1.0]]
C = [[1.0]]
D = [[0.0]]
outputs = ["nope"]
inputs = []
dt = 0.01
"""
WARNING = "the config's [model] is not used, detection_filter: the [model] names channels"


def _archive(path: Path, seed: int = 0) -> Path:
    t, y, names = simulate_building(3, 40.0, 100.0, seed=seed)
    t_ns = np.round(t * 1e9).astype(np.int64)
    data = {name: y[:, i] for i, name in enumerate(names)}
    write_archive(path, "csv", t_ns, data, start_iso="2026-01-01T00:00:00Z")
    return path


@pytest.fixture(scope="module", autouse=True)
def _stop_fork_server() -> Iterator[None]:
    """The analyses fork from multiprocessing's fork server: stop it after this module."""
    yield
    server = getattr(multiprocessing.forkserver, "_forkserver", None)
    stop = getattr(server, "_stop", None)
    if callable(stop):
        stop()


def _options(tmp_path: Path) -> RunOptions:
    cfg = tmp_path / "cfg.toml"
    cfg.write_text(CONFIG)
    return load_options(str(cfg), train="0:12")


def _watch_once(settings: WatchSettings, options: RunOptions) -> object:
    """``watch --once`` in a thread, with a hard timeout (stopped and joined on failure)."""
    outcome: dict[str, object] = {}
    stop, abandon = threading.Event(), threading.Event()

    def body() -> None:
        try:
            outcome["code"] = watch(settings, options, stop=stop, abandon=abandon)
        except BaseException as err:  # noqa: BLE001 - handed to the test
            outcome["error"] = err

    thread = threading.Thread(target=body, daemon=True)
    thread.start()
    thread.join(TIMEOUT)
    if thread.is_alive():
        stop.set()
        abandon.set()
        thread.join(TIMEOUT)
        raise AssertionError(f"watch --once still running after {TIMEOUT:.0f} s")
    assert multiprocessing.active_children() == []
    if "error" in outcome:
        raise outcome["error"]  # type: ignore[misc]
    return outcome["code"]


def test_run_prints_the_warning(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The reference behaviour: ``run`` says the [model] is not used."""
    archive = _archive(tmp_path / "a.csv")
    cfg = tmp_path / "cfg.toml"
    cfg.write_text(CONFIG)
    argv = ["run", str(archive), "--config", str(cfg), "--train", "0:12", "--no-progress"]
    code = main([*argv, "--out", str(tmp_path / "out")])
    assert code in (0, 1)
    assert f"{cfg}: {WARNING}" in capsys.readouterr().err


def test_watch_logs_the_config_warnings_of_each_archive(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    inbox, reports = tmp_path / "inbox", tmp_path / "reports"
    inbox.mkdir()
    for seed in (1, 2):
        _archive(inbox / f"hour{seed}.csv", seed=seed)
    options = _options(tmp_path)
    settings = WatchSettings(inbox, reports, settle=0.3, jobs=1, once=True)
    assert _watch_once(settings, options) in (0, 1)
    warned = [
        r.getMessage()
        for r in caplog.records
        if r.name == "analyzer.watch" and r.levelno == logging.WARNING
    ]
    for name in ("hour1.csv", "hour2.csv"):
        # (the config's line; a training window run would warn of is the watcher's too)
        (line,) = [w for w in warned if w.startswith(f"{name}: {tmp_path / 'cfg.toml'}: ")]
        assert line == f"{name}: {tmp_path / 'cfg.toml'}: {line.split(': ', 2)[2]}"
        assert WARNING in line and "nope" in line
        folder = next(p for p in reports.iterdir() if p.is_dir() and name in p.name)
        assert (folder / "findings.json").is_file()
        assert not (folder / CONFIG_WARNINGS).exists()  # not part of the report
    # a second pass finds both analyzed already: nothing analyzed, nothing warned again
    caplog.clear()
    assert _watch_once(settings, options) in (0, 1)
    assert not [r for r in caplog.records if r.levelno == logging.WARNING]


def test_analysis_into_leaves_the_lines_for_the_watcher(tmp_path: Path) -> None:
    """The analysis (a process of its own, or a cluster task whose files come back) hands
    the lines over in a file beside its outputs; none without a warning."""
    archive = _archive(tmp_path / "a.csv")
    out, work = tmp_path / "out", tmp_path / "work"
    out.mkdir()
    work.mkdir()
    assert analysis_into([str(archive)], _options(tmp_path), out, work) in (0, 1)
    lines = (out / CONFIG_WARNINGS).read_text().splitlines()
    assert len(lines) == 1 and WARNING in lines[0]
    clean, work2 = tmp_path / "clean", tmp_path / "work2"
    clean.mkdir()
    work2.mkdir()
    assert analysis_into([str(archive)], RunOptions(train="0:12"), clean, work2) in (0, 1)
    assert not (clean / CONFIG_WARNINGS).exists()


def test_the_training_window_warning_of_run_is_left_for_the_watcher_too(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A fault inside the default training window: ``run`` warns that it trained on the
    window's part before the change; the watcher, which logs the lines the analysis
    leaves, said nothing (the note was in findings.json alone)."""
    from analyzer.simulate import inject_fault

    t, y, names = simulate_building(4, 300.0, 100.0, seed=14, sensors_per_floor=2)
    sd = y[: int(0.2 * t.size), 2].std()
    y[:, 2] = inject_fault(y[:, 2], 100.0, "additive", 45.0, 3.0 * sd)
    archive = tmp_path / "b.csv"
    header = "time," + ",".join(names)
    np.savetxt(archive, np.column_stack([t, y]), delimiter=",", header=header, comments="")
    assert main(["run", str(archive), "--out", str(tmp_path / "run"), "--no-progress"]) == 1
    printed = [
        line.removeprefix("analyzer: warning: ")
        for line in capsys.readouterr().err.splitlines()
        if "trained on 0-" in line
    ]
    assert printed
    out, work = tmp_path / "out", tmp_path / "work"
    out.mkdir()
    work.mkdir()
    assert analysis_into([str(archive)], RunOptions(), out, work) == 1
    assert (out / CONFIG_WARNINGS).read_text().splitlines() == printed
