"""stderr closed (``2>&-``), a pipe whose reader has gone (EPIPE), or a full pipe made
non-blocking (EAGAIN): the command's files and exit code are those it has with stderr
open; only what it would have said is lost (the integrator's audit, int56 item 2).

Before: ``run ... 2>&-`` wrote its outputs, failed at its summary line ("Bad file
descriptor"), removed them and exited 1; a usage error exited 1, not 2."""

from __future__ import annotations

import errno
import fcntl
import io
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import run_cli

from analyzer.lossy_stderr import LossyStream
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

REPO = Path(__file__).resolve().parents[2]
RATE = 50.0


def _archive(folder: Path, fault: bool) -> Path:
    """A folder of two files: 60 s of a 3-floor building at 50 Hz (with an offset on its
    second sensor at 36 s where ``fault``), and a damaged file (a warning on stderr)."""
    t, y, names = simulate_building(3, 60.0, RATE, seed=3)
    if fault:
        y[:, 1] = inject_fault(y[:, 1], RATE, "additive", 36.0, 3.0 * float(np.std(y[:, 1])))
    folder.mkdir()
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(
        folder / "a.csv",
        "csv",
        t_ns,
        dict(zip(names, y.T, strict=True)),
        start_iso="2026-03-01T12:00:00Z",
    )
    (folder / "z.csv").write_bytes(b"time,s0\n\x00\x01not text")
    return folder


@pytest.fixture(scope="module")
def faulty(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An archive with one fault and one damaged file (exit 1, a warning)."""
    return _archive(tmp_path_factory.mktemp("in") / "arch", fault=True)


@pytest.fixture(scope="module")
def healthy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An archive with no fault and one damaged file (exit 0, a warning): an exit code
    that an uncaught error (1) cannot pass for."""
    return _archive(tmp_path_factory.mktemp("in") / "arch", fault=False)


def _reference(src: Path, out: Path, code: int) -> Path:
    """The run of ``src`` into ``out`` with stderr open (exit ``code``, a warning)."""
    done = _analyzer(["run", src, "--out", out, "--train", "0:15"], stderr=subprocess.PIPE)
    assert done.returncode == code, done.stderr
    assert "warning: " in done.stderr and "sensor fault" in done.stderr
    return out


@pytest.fixture(scope="module")
def with_stderr(faulty: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The faulty archive's run with stderr open: its output folder."""
    return _reference(faulty, tmp_path_factory.mktemp("open") / "o", 1)


@pytest.fixture(scope="module")
def healthy_with_stderr(healthy: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The healthy archive's run with stderr open: its output folder."""
    return _reference(healthy, tmp_path_factory.mktemp("open") / "o", 0)


def _analyzer(
    argv: list[object], shell_suffix: str = "", **kw: object
) -> subprocess.CompletedProcess[str]:
    """``python -m analyzer ARGV`` (through a shell when ``shell_suffix`` is given:
    ``2>&-``); stdout captured."""
    env = {**os.environ, "PYTHONPATH": str(REPO), "OPENBLAS_NUM_THREADS": "1"}
    words = [sys.executable, "-m", "analyzer", *(str(a) for a in argv)]
    if shell_suffix:
        line = " ".join(f"'{w}'" for w in words) + " " + shell_suffix
        return subprocess.run(
            line, shell=True, stdout=subprocess.PIPE, text=True, env=env, timeout=600, **kw
        )  # type: ignore[call-overload, no-any-return]
    return subprocess.run(  # type: ignore[call-overload, no-any-return]
        words, stdout=subprocess.PIPE, text=True, env=env, timeout=600, **kw
    )


def _same_outputs(out: Path, reference: Path) -> None:
    assert sorted(p.name for p in out.iterdir()) == ["findings.json", "report.html"]
    assert (out / "findings.json").read_bytes() == (reference / "findings.json").read_bytes()


def test_run_with_stderr_closed(faulty: Path, with_stderr: Path, tmp_path: Path) -> None:
    out = tmp_path / "o"
    done = _analyzer(["run", faulty, "--out", out, "--train", "0:15", "--progress"], "2>&-")
    assert done.returncode == 1
    assert done.stdout == ""
    _same_outputs(out, with_stderr)


def test_a_usage_error_with_stderr_closed_still_exits_2(faulty: Path, tmp_path: Path) -> None:
    done = _analyzer(["run", faulty, "--out", tmp_path / "o", "--bogus"], "2>&-")
    assert (done.returncode, done.stdout) == (2, "")
    done = _analyzer(["run", faulty, "--out", tmp_path / "o", "--train", "0:5"], "2>&-")
    assert (done.returncode, done.stdout) == (2, "")  # (no detector could run)


def test_inspect_with_stderr_closed(faulty: Path) -> None:
    open_ = _analyzer(["inspect", faulty, "--json"], stderr=subprocess.DEVNULL)
    closed = _analyzer(["inspect", faulty, "--json"], "2>&-")
    assert (closed.returncode, closed.stdout) == (open_.returncode, open_.stdout)
    assert closed.returncode == 0 and '"channels"' in closed.stdout


def test_export_with_stderr_closed(faulty: Path, tmp_path: Path) -> None:
    """The damaged file's warning cannot be said. Before: the file written, exit 1."""
    opened = _analyzer(["export", faulty, "--out", tmp_path / "a.csv"], stderr=subprocess.DEVNULL)
    closed = _analyzer(["export", faulty, "--out", tmp_path / "b.csv"], "2>&-")
    assert (closed.returncode, closed.stdout) == (opened.returncode, opened.stdout) == (0, "")
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()


def test_watch_once_with_stderr_closed(faulty: Path, tmp_path: Path) -> None:
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    shutil.copy(faulty / "a.csv", inbox / "a.csv")
    reports = tmp_path / "reports"
    done = _analyzer(
        ["watch", inbox, "--out", reports, "--once", "--train", "0:15"],
        "2>&-",
    )
    assert (done.returncode, done.stdout) == (1, "")
    assert (reports / "a.csv" / "findings.json").is_file()
    assert (reports / "index.json").is_file()


def test_run_with_stderr_a_pipe_whose_reader_has_gone(
    healthy: Path, healthy_with_stderr: Path, tmp_path: Path
) -> None:
    """Every write to stderr meets EPIPE (Python ignores SIGPIPE)."""
    read, write = os.pipe()
    os.close(read)
    try:
        done = _analyzer(["run", healthy, "--out", tmp_path / "o", "--train", "0:15"], stderr=write)
    finally:
        os.close(write)
    assert (done.returncode, done.stdout) == (0, "")
    _same_outputs(tmp_path / "o", healthy_with_stderr)


def test_run_with_stderr_a_full_non_blocking_pipe(
    healthy: Path, healthy_with_stderr: Path, tmp_path: Path
) -> None:
    """A reader that made its pipe non-blocking and has not read: writes meet EAGAIN.
    Nothing is added to the pipe; the run is the same."""
    read, write = os.pipe()
    fcntl.fcntl(write, fcntl.F_SETFL, fcntl.fcntl(write, fcntl.F_GETFL) | os.O_NONBLOCK)
    filled = 0
    while True:
        try:
            filled += os.write(write, b"x" * 4096)
        except BlockingIOError:
            break
    try:
        done = _analyzer(["run", healthy, "--out", tmp_path / "o", "--train", "0:15"], stderr=write)
    finally:
        os.close(write)
    with os.fdopen(read, "rb") as f:
        assert f.read() == b"x" * filled
    assert (done.returncode, done.stdout) == (0, "")
    _same_outputs(tmp_path / "o", healthy_with_stderr)


class _Broken(io.StringIO):
    """A stream every write to which meets ``err``."""

    def __init__(self, err: int) -> None:
        super().__init__()
        self.err = err

    def write(self, text: str) -> int:
        raise OSError(self.err, os.strerror(self.err))


@pytest.mark.parametrize("err", [errno.EPIPE, errno.EAGAIN, errno.EBADF])
def test_a_lost_stderr_is_given_up_at_its_first_failed_write(err: int) -> None:
    stream = LossyStream(_Broken(err))
    assert stream.write("analyzer: warning: x\n") == len("analyzer: warning: x\n")
    assert stream.lost
    stream.write("more\n")
    stream.flush()
    assert not stream.isatty()


def test_run_in_process_with_stderr_none(
    faulty: Path,
    with_stderr: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Python's ``sys.stderr`` is None when the process started without one: nothing
    said, and nothing printed to stdout in its place (``print(file=None)`` writes to
    stdout)."""
    monkeypatch.setattr(sys, "stderr", None)
    code, out, _ = run_cli(["run", faulty, "--out", tmp_path / "o", "--train", "0:15"], capsys)
    assert (code, out) == (1, "")
    _same_outputs(tmp_path / "o", with_stderr)
    code, out, _ = run_cli(["run", faulty, "--out", tmp_path / "o", "--bogus"], capsys)
    assert (code, out) == (2, "")
