"""Wording a QA audit found uneven (ux56 item 13): an unknown detector is "unknown
detector" to ``--screen`` as to ``--detectors``; an unknown config key is written as in
the TOML file (``[train] bogus``, not ``train.'bogus'``); an ISO ``--train`` after the
data is answered with a time, not in seconds; a dangling symbolic link in an input
folder is said, as a link loop is."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from analyzer.cli import main
from analyzer.readers import open_archive
from analyzer.simulate import simulate_building
from analyzer.writers import write_archive

START = "2026-01-01T00:00:00Z"


@pytest.fixture(scope="module")
def record(tmp_path_factory) -> Path:
    """A 3-floor building, 60 s at 50 Hz, as a CSV of ISO times from ``START``."""
    t, y, names = simulate_building(n_floors=3, duration_s=60.0, rate_hz=50.0, seed=2)
    path = tmp_path_factory.mktemp("rec") / "r.csv"
    cols = {n: y[:, i] for i, n in enumerate(names)}
    write_archive(path, "csv", np.round(t * 1e9).astype(np.int64), cols, start_iso=START)
    return path


def _error(args: list[str], capsys) -> str:
    assert main([*args, "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    return err.removeprefix("analyzer: error: ").strip()


def test_an_unknown_detector_is_one_wording(record, tmp_path, capsys):
    out = str(tmp_path / "o")
    screen = _error(["run", str(record), "--out", out, "--screen", "nosuch"], capsys)
    detectors = _error(["run", str(record), "--out", out, "--detectors", "nosuch"], capsys)
    assert screen.startswith("--screen: unknown detector 'nosuch' (known: ")
    assert detectors.startswith("--detectors: unknown detector 'nosuch' (known: ")
    assert screen.split("(known: ")[1] == detectors.split("(known: ")[1]


@pytest.mark.parametrize(
    "toml, said",
    [
        ("[train]\nstart = 0.0\nend = 12.0\nbogus = 1\n", "unknown key [train] bogus"),
        ('[train]\n"a b" = 1\n', 'unknown key [train] "a b"'),
        ("bogus = 1\n", "unknown key bogus"),
        ("[bogus]\nx = 1\n", "unknown section [bogus]"),
        ('[[group]]\nname = "g"\nfoo = 1\n', "unknown key [[group]] #1 foo"),
        ("[detectors.nosuch]\nx = 1\n", "[detectors.nosuch]: unknown detector 'nosuch'"),
    ],
)
def test_an_unknown_config_key_is_written_as_in_the_file(record, tmp_path, capsys, toml, said):
    config = tmp_path / "c.toml"
    config.write_text(toml)
    args = ["run", str(record), "--out", str(tmp_path / "o"), "--config", str(config)]
    assert _error(args, capsys).startswith(f"{config}: {said} (")


def test_an_iso_window_after_the_data_is_answered_with_a_time(record, tmp_path, capsys):
    window = "2027-01-01T00:00:00Z:2027-01-01T00:00:10Z"
    err = _error(["run", str(record), "--out", str(tmp_path / "o"), "--train", window], capsys)
    assert err == (
        f"--train: the window '{window}' starts after the data, which ends at "
        "2026-01-01T00:01:00.000Z"
    )
    seconds = _error(["run", str(record), "--out", str(tmp_path / "o"), "--train", "70:80"], capsys)
    assert seconds == "--train: the window '70:80' starts after the data ends (60.000 s)"


def test_a_dangling_link_in_an_input_folder_is_said(record, tmp_path, capsys):
    folder = tmp_path / "in"
    folder.mkdir()
    os.symlink(record, folder / "r.csv")
    os.symlink(tmp_path / "unmounted" / "run3", folder / "run3")  # (a folder's link)
    os.symlink(tmp_path / "gone.csv", folder / "gone.csv")
    os.symlink(tmp_path / "gone.txt", folder / "notes.txt")  # (no input: not said)
    archive = open_archive(folder)
    assert [r.info.path.name for r in archive.readers] == ["r.csv"]
    assert archive.notes == [
        f"{folder / 'gone.csv'} not read: a symbolic link to {tmp_path / 'gone.csv'}, which "
        "does not exist",
        f"{folder / 'run3'} not read: a symbolic link to {tmp_path / 'unmounted' / 'run3'}, "
        "which does not exist",
    ]
    args = ["run", str(folder), "--out", str(tmp_path / "o"), "--train", "0:20"]
    assert main([*args, "--no-progress"]) in (0, 1)
    err = capsys.readouterr().err
    assert f"warning: {folder / 'run3'} not read: a symbolic link to " in err
