"""Dask's own log lines stay off stderr while a run uses the cluster
(``analyzer.parallel_logs``): a worker lost mid-run, which the run survives, used to put
``distributed.client - WARNING - Couldn't gather 1 keys, rescheduling (...)`` (and, with
the cluster in the same process, the scheduler's and nanny's lines) among the analyzer's
one-line messages. The lines are kept in the executor's ``dask_log``; Dask's handlers
are as they were once the executor is closed; ``ANALYZER_DEBUG`` lets them through; an
error that ends the run still ends it, as one line.

The lost worker is made deterministic as in ``test_dask_robust33``: the task kills its
own worker process the first time it runs, on a cluster of one worker."""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")
cloudpickle = pytest.importorskip("cloudpickle")

from analyzer.cli import main  # noqa: E402
from analyzer.errors import DetectorError, UsageError  # noqa: E402
from analyzer.parallel import DaskExecutor  # noqa: E402

SAMPLE = Path(__file__).resolve().parents[2] / "samples" / "building_additive.mcap"
BLAS_ENV = {v: "1" for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}

# the workers cannot import this test module: ship its functions by value
cloudpickle.register_pickle_by_value(sys.modules[__name__])


CLIENT_BOOKKEEPING = ("Remove client", "Close client connection", "Receive client connection")


class _Recorder(logging.Handler):
    """Stands for Dask's stderr handler: what it would have printed."""

    def __init__(self) -> None:
        super().__init__()
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        message = record.getMessage()
        if record.name == "distributed.scheduler" and message.startswith(CLIENT_BOOKKEEPING):
            # the in-process cluster's scheduler notes a client leaving on its own thread,
            # whenever it gets to it (after the executor closed, in the next test): a
            # cluster of its own logs that in its own process (CI saw such lines)
            return
        self.lines.append(f"{record.name} - {record.levelname} - {message}")


@pytest.fixture
def stderr_stand_in() -> Iterator[_Recorder]:
    """A handler on the ``distributed`` logger, as distributed configures its own."""
    recorder = _Recorder()
    logger = logging.getLogger("distributed")
    logger.addHandler(recorder)
    try:
        yield recorder
    finally:
        logger.removeHandler(recorder)


@pytest.fixture(scope="module")
def lone() -> Iterator[Any]:
    """One worker process (its nanny starts another when it dies); the scheduler and
    the nanny in this process, so their lines about the loss are logged here."""
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0", env=BLAS_ENV
    ) as c:
        yield c


def _killing_once(item: tuple[Any, ...]) -> float:
    """Kills its worker the first time it runs on one (never in the test's process)."""
    rows, k, marker, home = item
    if os.getpid() != home and not os.path.exists(marker):
        Path(marker).touch()
        os.kill(os.getpid(), signal.SIGKILL)
    return float(rows.sum()) + k


def _items(tmp_path: Path) -> list[tuple[Any, ...]]:
    marker, home = str(tmp_path / "killed"), os.getpid()
    return [(np.arange(20_000.0) * k, k, marker, home) for k in range(4)]


def _want(items: list[tuple[Any, ...]]) -> list[float]:
    return [float(rows.sum()) + k for rows, k, *_ in items]


def test_a_lost_worker_s_lines_are_held_then_handlers_restored(
    lone: Any, tmp_path: Path, stderr_stand_in: _Recorder
) -> None:
    """Before: the scheduler's 'Remove worker' and the nanny's lines reached the handler
    (stderr) in the middle of the run. Now they are in ``dask_log``, and what Dask logs
    after the executor closed reaches the handler again."""
    ex = DaskExecutor(lone.scheduler_address)
    try:
        items = _items(tmp_path)
        assert ex.map(_killing_once, items) == _want(items)
        assert Path(tmp_path / "killed").exists() and ex.resent >= 1
    finally:
        ex.close()
    assert stderr_stand_in.lines == []
    held = "\n".join(ex.dask_log.lines)
    assert "distributed.scheduler - INFO - Remove worker" in held, held
    assert ex.dask_log.count >= len(ex.dask_log.lines) > 0
    logging.getLogger("distributed.client").warning("after the run")
    assert stderr_stand_in.lines == ["distributed.client - WARNING - after the run"]
    names = ("distributed", "distributed.client", "tornado", "tornado.application")
    handlers = [h for n in names for h in logging.getLogger(n).handlers]
    assert all(not h.filters for h in [*handlers, logging.lastResort] if h is not None)


def test_only_dask_s_records_are_held(
    lone: Any, stderr_stand_in: _Recorder, caplog: pytest.LogCaptureFixture
) -> None:
    """Every ``distributed.*`` and ``tornado.*`` record, at any level, goes to the log
    once (however many handlers it reaches); other loggers' records pass, also through
    a handler they share with Dask's."""
    tornado = logging.getLogger("tornado.application")
    tornado.addHandler(stderr_stand_in)
    mine = logging.getLogger("analyzer.test_dask_quiet")
    mine.addHandler(stderr_stand_in)
    ex = DaskExecutor(lone.scheduler_address)
    try:
        before = ex.dask_log.count
        logging.getLogger("distributed.client").error("Failed to reconnect to scheduler")
        logging.getLogger("distributed.batched").info("Batched Comm Closed")
        tornado.error("Exception in callback")
        mine.warning("not Dask's")
        assert stderr_stand_in.lines == ["analyzer.test_dask_quiet - WARNING - not Dask's"]
        assert ex.dask_log.count - before >= 3
        kept = [line.split(" - ", 1)[1] for line in ex.dask_log.lines]
        ours = [
            "distributed.client - ERROR - Failed to reconnect to scheduler",
            "distributed.batched - INFO - Batched Comm Closed",
            "tornado.application - ERROR - Exception in callback",
        ]
        assert [line for line in kept if line in ours] == ours
    finally:
        ex.close()
        tornado.removeHandler(stderr_stand_in)
        mine.removeHandler(stderr_stand_in)


def test_held_while_any_executor_is_open(lone: Any, stderr_stand_in: _Recorder) -> None:
    """Two executors (the watcher's and a run's, say): held until the last one closes,
    each keeping what was logged while it was open."""
    client = logging.getLogger("distributed.client")
    first = DaskExecutor(lone.scheduler_address)
    second = DaskExecutor(lone.scheduler_address)
    try:
        client.warning("both open")
        first.close()
        client.warning("second open")
        assert stderr_stand_in.lines == []
    finally:
        first.close()
        second.close()
    client.warning("none open")
    assert stderr_stand_in.lines == ["distributed.client - WARNING - none open"]
    assert any("both open" in line for line in first.dask_log.lines)
    assert not any("second open" in line for line in first.dask_log.lines)
    assert any("second open" in line for line in second.dask_log.lines)


def test_analyzer_debug_lets_dask_s_lines_through(
    lone: Any, stderr_stand_in: _Recorder, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("ANALYZER_DEBUG", "1")
    ex = DaskExecutor(lone.scheduler_address)
    try:
        logging.getLogger("distributed.client").warning("Couldn't gather 1 keys")
    finally:
        ex.close()
    assert "distributed.client - WARNING - Couldn't gather 1 keys" in stderr_stand_in.lines
    assert ex.dask_log.count == 0


def test_a_failed_connection_holds_nothing_after(stderr_stand_in: _Recorder) -> None:
    """The executor never opened (no scheduler there): its error is raised and Dask's
    handlers are as before."""
    with pytest.raises(UsageError, match="--scheduler tcp://127.0.0.1:1: cannot connect"):
        DaskExecutor("tcp://127.0.0.1:1", timeout=1.0)
    logging.getLogger("distributed.client").warning("after")
    assert stderr_stand_in.lines == ["distributed.client - WARNING - after"]


def _fails(item: int) -> int:
    if item == 2:
        raise DetectorError("cannot fit block 2")
    return item


def test_an_error_that_ends_the_run_still_ends_it(lone: Any, stderr_stand_in: _Recorder) -> None:
    """The task's own error comes back unchanged through the hold; closing (as the
    pipeline does on its way out) restores the handlers."""
    ex = DaskExecutor(lone.scheduler_address)
    try:
        with pytest.raises(DetectorError, match="cannot fit block 2"):
            ex.map(_fails, [0, 1, 2, 3])
    finally:
        ex.close()
    logging.getLogger("distributed.client").warning("after")
    assert stderr_stand_in.lines == ["distributed.client - WARNING - after"]


def test_a_run_s_stderr_carries_only_the_analyzer_s_lines(lone: Any, tmp_path: Path) -> None:
    """The run in a process of its own, against a cluster whose scheduler logs into
    that process's stderr (as a client's lines do): between the executor's opening and
    its close, with a worker killed, stderr gets nothing from Dask; the results are
    the undisturbed ones."""
    script = tmp_path / "lose_a_worker.py"
    script.write_text(
        textwrap.dedent(
            f"""
            import os, signal, sys
            from pathlib import Path
            import numpy as np
            import distributed
            from analyzer.parallel import DaskExecutor

            def killing_once(item):
                rows, k, marker, home = item
                if os.getpid() != home and not os.path.exists(marker):
                    Path(marker).touch()
                    os.kill(os.getpid(), signal.SIGKILL)
                return float(rows.sum()) + k

            if __name__ == "__main__":
                with distributed.LocalCluster(
                    n_workers=1, threads_per_worker=1, processes=True,
                    dashboard_address=":0", env={BLAS_ENV!r},
                ) as cluster:
                    ex = DaskExecutor(cluster.scheduler_address)
                    print("=== open", file=sys.stderr, flush=True)
                    items = [(np.arange(20_000.0) * k, k, {str(tmp_path / "killed")!r},
                              os.getpid()) for k in range(4)]
                    got = ex.map(killing_once, items)
                    print("=== close", file=sys.stderr, flush=True)
                    ex.close()
                    want = [float(rows.sum()) + k for rows, k, *_ in items]
                    print(got == want, ex.resent)
            """
        )
    )
    done = subprocess.run(
        [sys.executable, str(script)],
        capture_output=True,
        text=True,
        timeout=180,
        env={**os.environ, **BLAS_ENV, "PYTHONDONTWRITEBYTECODE": "1"},
        check=False,
    )
    assert done.returncode == 0, done.stderr
    same, resent = done.stdout.split()
    assert same == "True" and int(resent) >= 1
    assert (tmp_path / "killed").exists()
    err = done.stderr.splitlines()
    during = err[err.index("=== open") + 1 : err.index("=== close")]
    assert during == [], "\n".join(during)


def test_the_cli_run_on_a_cluster_prints_no_dask_line(
    lone: Any, tmp_path: Path, stderr_stand_in: _Recorder, capsys: pytest.CaptureFixture[str]
) -> None:
    """A whole ``run --scheduler`` (in this process, whose scheduler logs the client's
    arrival and departure here): nothing from Dask during it, and the sample's fault
    found (exit 1)."""
    out = tmp_path / "o"
    argv = ["run", str(SAMPLE), "--out", str(out), "--scheduler", lone.scheduler_address]
    assert main(argv) == 1 and (out / "findings.json").exists()
    assert stderr_stand_in.lines == []
    assert capsys.readouterr().err.splitlines() == [  # (the run's last line alone)
        f"analyzer: 1 sensor fault found on 1 sensor: /s4.data additive from 16.000 s; "
        f"report: {out / 'report.html'}"
    ]
