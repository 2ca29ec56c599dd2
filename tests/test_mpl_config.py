"""A user whose home cannot be written (a service account: ``nobody``, a systemd
``DynamicUser``, a container's user) gets a private matplotlib folder, instead of
matplotlib's two warnings on stderr and a ``matplotlib-XXXXXXXX`` folder left in the
temporary directory by the figure workers at every run."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from analyzer import mpl_config

REPO = Path(__file__).resolve().parents[1]


def test_a_writable_home_needs_nothing(tmp_path):
    assert not mpl_config.needs_fallback({"HOME": str(tmp_path / "home")})
    env = {"XDG_CONFIG_HOME": str(tmp_path / "c"), "XDG_CACHE_HOME": str(tmp_path / "k")}
    assert not mpl_config.needs_fallback(env)


@pytest.mark.parametrize("which", ["HOME", "XDG_CONFIG_HOME", "XDG_CACHE_HOME"])
def test_a_home_or_folder_that_cannot_be_made_needs_the_fallback(tmp_path, which):
    blocker = tmp_path / "a-file"
    blocker.write_text("")  # no folder can be made under a file, whoever runs this
    env = {"HOME": str(tmp_path / "home"), which: str(blocker)}
    assert mpl_config.needs_fallback(env)
    assert not mpl_config.needs_fallback({**env, "MPLCONFIGDIR": str(tmp_path / "mine")})


def test_the_folder_is_private_and_reused(tmp_path, monkeypatch):
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    monkeypatch.setenv("HOME", str(tmp_path / "a-file"))
    (tmp_path / "a-file").write_text("")
    monkeypatch.delenv("XDG_CONFIG_HOME", raising=False)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.delenv("MPLCONFIGDIR", raising=False)
    first = Path(mpl_config.ensure_config_dir() or "")
    assert first == tmp_path / f"analyzer-mpl-{os.getuid()}"
    assert os.environ["MPLCONFIGDIR"] == str(first)
    info = first.stat()
    assert stat.S_IMODE(info.st_mode) & 0o077 == 0 and info.st_uid == os.getuid()
    monkeypatch.delenv("MPLCONFIGDIR")
    assert mpl_config.ensure_config_dir() == str(first)


def test_a_name_others_could_write_is_never_used(tmp_path, monkeypatch):
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    name = tmp_path / f"analyzer-mpl-{os.getuid()}"
    name.mkdir()
    name.chmod(0o777)
    monkeypatch.setenv("HOME", str(tmp_path / "a-file"))
    (tmp_path / "a-file").write_text("")
    monkeypatch.delenv("MPLCONFIGDIR", raising=False)
    chosen = Path(mpl_config.ensure_config_dir() or "")
    assert chosen != name and chosen.parent == tmp_path and chosen.is_dir()
    assert stat.S_IMODE(chosen.stat().st_mode) & 0o077 == 0


def test_an_explicit_mplconfigdir_is_left_alone(tmp_path, monkeypatch):
    monkeypatch.setenv("MPLCONFIGDIR", str(tmp_path / "mine"))
    monkeypatch.setenv("HOME", "/nonexistent")
    assert mpl_config.ensure_config_dir() is None
    assert os.environ["MPLCONFIGDIR"] == str(tmp_path / "mine")


@pytest.mark.slow
def test_a_run_without_a_writable_home_leaves_nothing_and_prints_only_its_own_lines(tmp_path):
    """The whole run in a fresh interpreter, its figures drawn by the workers: before,
    matplotlib printed two lines and the fork server left ``matplotlib-*`` in TMPDIR."""
    home = tmp_path / "home-is-a-file"
    home.write_text("")
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("MPLCONFIGDIR", "XDG_CONFIG_HOME", "XDG_CACHE_HOME")
    }
    env.update(HOME=str(home), TMPDIR=str(tmp), PYTHONPATH=str(REPO))
    sample = REPO / "samples" / "building_multiplicative.csv.gz"
    done = subprocess.run(
        [sys.executable, "-m", "analyzer", "run", str(sample), "--out", str(tmp_path / "o")],
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert done.returncode == 1, done.stderr
    assert "matplotlib" not in done.stderr.lower(), done.stderr
    assert (tmp_path / "o" / "report.html").is_file()
    left = sorted(p.name for p in tmp.iterdir())
    assert left == [f"analyzer-mpl-{os.getuid()}"], left
