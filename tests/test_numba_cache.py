"""A read-only install run by a user with no writable cache folder (a service account
running ``analyzer watch``) gets a private numba cache folder instead of an import error
("cannot cache function ...: no locator available")."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from analyzer import numba_cache

REPO = Path(__file__).resolve().parents[1]


def _deny_writes_under(monkeypatch: pytest.MonkeyPatch, *roots: Path) -> None:
    """``os.access`` as the module sees it: no write access under ``roots``."""
    real = os.access

    def access(path, mode, **kw):
        if mode & os.W_OK and any(Path(path).is_relative_to(r) for r in roots):
            return False
        return real(path, mode, **kw)

    monkeypatch.setattr(numba_cache.os, "access", access)


def _package(tmp_path: Path) -> Path:
    package = tmp_path / "site" / "analyzer"
    for name in numba_cache.KERNEL_FOLDERS:
        (package / name).mkdir(parents=True)
    return package


def test_a_writable_install_or_user_cache_needs_nothing(tmp_path, monkeypatch):
    package = _package(tmp_path)
    env = {"XDG_CACHE_HOME": str(tmp_path / "cache")}
    assert not numba_cache.needs_fallback(package, env)
    _deny_writes_under(monkeypatch, tmp_path / "site")
    assert not numba_cache.needs_fallback(package, env)  # the user's cache will do


def test_a_read_only_install_and_cache_need_the_fallback(tmp_path, monkeypatch):
    package = _package(tmp_path)
    (tmp_path / "cache").mkdir()  # read-only, and its missing folder cannot be made
    env = {"XDG_CACHE_HOME": str(tmp_path / "cache" / "deeper")}
    _deny_writes_under(monkeypatch, tmp_path / "site", tmp_path / "cache")
    assert numba_cache.needs_fallback(package, env)
    assert not numba_cache.needs_fallback(package, {**env, "NUMBA_CACHE_DIR": "/x"})


def test_one_read_only_kernel_folder_is_enough_to_need_it(tmp_path, monkeypatch):
    package = _package(tmp_path)
    (package / "stats" / "__pycache__").mkdir()
    (tmp_path / "cache").mkdir()
    _deny_writes_under(monkeypatch, package / "stats" / "__pycache__", tmp_path / "cache")
    env = {"XDG_CACHE_HOME": str(tmp_path / "cache")}
    assert numba_cache.needs_fallback(package, env)


def test_the_fallback_is_private_and_reused(tmp_path):
    first = Path(numba_cache.fallback_dir(str(tmp_path)))
    assert first == tmp_path / f"analyzer-numba-{os.getuid()}"
    info = first.stat()
    assert stat.S_IMODE(info.st_mode) & 0o077 == 0
    assert info.st_uid == os.getuid()
    assert Path(numba_cache.fallback_dir(str(tmp_path))) == first


@pytest.mark.parametrize("kind", ["world-writable", "symlink", "file"])
def test_a_name_others_could_write_is_never_used(tmp_path, kind):
    name = tmp_path / f"analyzer-numba-{os.getuid()}"
    if kind == "world-writable":
        name.mkdir()
        name.chmod(0o777)
    elif kind == "symlink":
        (tmp_path / "elsewhere").mkdir(mode=0o700)
        name.symlink_to(tmp_path / "elsewhere")
    else:
        name.write_text("")
    chosen = Path(numba_cache.fallback_dir(str(tmp_path)))
    assert chosen != name and chosen.parent == tmp_path
    assert chosen.is_dir() and not chosen.is_symlink()
    assert stat.S_IMODE(chosen.stat().st_mode) & 0o077 == 0


def test_the_kernels_compile_and_cache_there_when_nothing_else_is_writable(tmp_path):
    """The whole path in a fresh interpreter: writes refused everywhere (as for a service
    account on a read-only install), numba's kernels are cached in the private folder."""
    code = (
        "import os\n"
        "real = os.access\n"
        "os.access = lambda p, m, **k: False if m & os.W_OK else real(p, m, **k)\n"
        "import analyzer\n"
        "print(os.environ['NUMBA_CACHE_DIR'])\n"
        "from analyzer.warm import warm\n"
        "assert warm()\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(TMPDIR=str(tmp_path), PYTHONPATH=str(REPO), XDG_CACHE_HOME=str(tmp_path / "c"))
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr
    folder = Path(done.stdout.strip())
    assert folder == tmp_path / f"analyzer-numba-{os.getuid()}"
    assert list(folder.rglob("*.nbi")), "numba cached nothing in the private folder"


def test_an_explicit_numba_cache_dir_is_left_alone(tmp_path):
    code = "import os, analyzer; print(os.environ['NUMBA_CACHE_DIR'])"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "mine"), "PYTHONPATH": str(REPO)}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert done.stdout.strip() == str(tmp_path / "mine")
