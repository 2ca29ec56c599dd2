"""The warnings of an analyzed archive are in the watcher's index, not the log alone: an
anomaly on every sensor that the detectors attributed to no sensor (a change of the
structure, of the excitation, or of every sensor's unit), or a config that names no
channel of the archive, was a plain "no fault" in ``index.html`` and ``index.json``
(a new user's audit, ux53 item 3)."""

from __future__ import annotations

import html
import json
import logging
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import test_watch_run
from test_watch_run import SETTLE, START, Watcher, state

from analyzer.options import load_options
from analyzer.simulate import simulate_building
from analyzer.watch import WatchSettings
from analyzer.writers import write_archive

folders = test_watch_run.folders
start_watcher = test_watch_run.start_watcher
_info_logs = test_watch_run._info_logs
_stop_fork_server = test_watch_run._stop_fork_server

CONFIG = """\
[[group]]
name = "truss"
channels = ["s0", "s1", "nope"]
"""


def _archive(path: Path, seed: int, gain_from_25_s: float = 1.0) -> Path:
    """40 s of a 3-floor building at 100 Hz; every channel's readings times
    ``gain_from_25_s`` from 25 s on (all sensors at once: no sensor to blame)."""
    t, y, names = simulate_building(3, 40.0, 100.0, seed=seed)
    y[2500:, :] *= gain_from_25_s
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: y[:, i] for i, n in enumerate(names)}, start_iso=START)
    return path


def test_the_index_says_an_archive_has_warnings(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    inbox, reports = folders
    _archive(inbox / "plain.csv", seed=1)
    _archive(inbox / "all3.csv", seed=3, gain_from_25_s=3.0)
    cfg = tmp_path / "cfg.toml"
    cfg.write_text(CONFIG)
    options = load_options(str(cfg), train="0:12")
    settings = WatchSettings(inbox, reports, settle=SETTLE, once=True)
    assert start_watcher(settings, options).join() == 0
    records = state(reports)
    index = json.loads((reports / "index.json").read_text())
    rows = {row["name"]: row for row in index["archives"]}
    for name in ("plain.csv", "all3.csv"):
        rec = records[name]
        assert rec["verdict"] == "no fault"
        # the lines the log warned of after the verdict, each in the record and index
        logged = [
            r.getMessage().removeprefix(f"{name}: ")
            for r in caplog.records
            if r.levelno == logging.WARNING and r.getMessage().startswith(f"{name}: ")
        ]
        assert rec["warnings"] == logged, (rec["warnings"], logged)
        assert rows[name]["warnings"] == rec["warnings"]
        assert any("[[group]] 'truss': 'nope' not in the archive" in w for w in rec["warnings"])
    (anomaly,) = [w for w in records["all3.csv"]["warnings"] if "attributed to no sensor" in w]
    assert anomaly.startswith("anomaly at 25.0 s on s0, s1, s2 "), anomaly
    assert not any("attributed to no sensor" in w for w in records["plain.csv"]["warnings"])
    page = (reports / "index.html").read_text()
    for name in ("plain.csv", "all3.csv"):
        n = len(records[name]["warnings"])
        said = f"{n} warnings: " if n > 1 else "1 warning: "
        assert said + records[name]["warnings"][0] in html.unescape(page), name


def test_the_archives_own_warnings_come_before_the_configs(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
) -> None:
    """The config's lines, which every archive gets, came first: the index's first warning
    of an archive with an anomaly on every sensor was the config line a plain archive
    had too (rcfg53 item 2)."""
    inbox, reports = folders
    _archive(inbox / "all3.csv", seed=3, gain_from_25_s=3.0)
    cfg = tmp_path / "cfg.toml"
    cfg.write_text(CONFIG)
    options = load_options(str(cfg), train="0:12")
    assert (
        start_watcher(WatchSettings(inbox, reports, settle=SETTLE, once=True), options).join() == 0
    )
    said = state(reports)["all3.csv"]["warnings"]
    config_at = [i for i, w in enumerate(said) if w.startswith(f"{cfg}: ")]
    assert said[0].startswith("anomaly at 25.0 s on s0, s1, s2 "), said
    assert config_at and config_at == list(range(len(said) - len(config_at), len(said))), said
    page = html.unescape((reports / "index.html").read_text())
    assert f"{len(said)} warnings: anomaly at 25.0 s on s0, s1, s2 " in page


def test_an_archives_warnings_are_capped_and_the_shown_one_cut(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Every warning line went into every record: a config of 300 groups naming a missing
    channel made 300 lines per archive in the state and index.json, and one group naming
    2000 missing channels one line of ~20 KB on the index page (rcfg53 item 1). The
    record keeps the first lines and a count of the rest, as ``input_errors``; the log
    has them all; the page cuts the one it shows."""
    inbox, reports = folders
    _archive(inbox / "plain.csv", seed=1)
    wide = ", ".join(f'"gone{i:04d}"' for i in range(2000))
    groups = "".join(f'[[group]]\nname = "g{i}"\nchannels = ["x{i}"]\n' for i in range(300))
    cfg = tmp_path / "cfg.toml"
    cfg.write_text(f'[[group]]\nname = "wide"\nchannels = ["s0", "s1", {wide}]\n' + groups)
    options = load_options(str(cfg), train="0:12")
    assert (
        start_watcher(WatchSettings(inbox, reports, settle=SETTLE, once=True), options).join() == 0
    )
    logged = [
        r.getMessage()
        for r in caplog.records
        if r.levelno == logging.WARNING and r.getMessage().startswith("plain.csv: ")
    ]
    assert len(logged) == 301, len(logged)  # (the log: every line)
    said = state(reports)["plain.csv"]["warnings"]
    assert said[-1] == "296 more warnings in the watcher's log", said[-1]
    assert len(said) == 6 and said[:5] == [m.removeprefix("plain.csv: ") for m in logged[:5]]
    index = json.loads((reports / "index.json").read_text())
    assert index["archives"][0]["warnings"] == said
    page = html.unescape((reports / "index.html").read_text())
    assert "301 warnings: " in page and "(all of them in the watcher's log)" in page
    assert "gone0000" in page and "gone1999" not in page  # (cut, not dropped)
    assert " ... [" in page and len(page) < 20_000, len(page)


def test_a_blank_model_channel_is_among_the_archives_warnings(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
) -> None:
    """``watch --model`` on an archive whose column of a model's channel is blank in
    every row: what the model lost with it (its detectors that have no residual without
    it) is among the archive's warnings, as ``run`` warns it; the record's warnings held
    only the reader's "blank in every row; not analyzed" (ch57)."""
    from analyzer.cli import main

    inbox, reports = folders
    fit = _archive(tmp_path / "fit.csv", seed=1)
    model = tmp_path / "building.model"
    out = tmp_path / "fit"
    assert (
        main(
            [
                "run",
                str(fit),
                "--out",
                str(out),
                "--no-progress",
                "--train",
                "0:12",
                "--save-model",
                str(model),
            ]
        )
        == 0
    )
    t, y, names = simulate_building(3, 40.0, 100.0, seed=2)
    y[:, 1] = np.nan
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(
        inbox / "dead.csv", "csv", t_ns, {n: y[:, i] for i, n in enumerate(names)}, start_iso=START
    )
    options = load_options(None, model=str(model))
    assert (
        start_watcher(WatchSettings(inbox, reports, settle=SETTLE, once=True), options).join() == 1
    )
    said = state(reports)["dead.csv"]["warnings"]
    (lost,) = [w for w in said if "the model's detectors need it" in w]
    assert lost.startswith(f"{names[1]} is blank in every row (a dead sensor"), lost
