"""``analyzer watch --scheduler ADDRESS``: each archive's analysis is a task of a Dask
cluster, and the worker that runs it reads the archive itself.

A year of hourly files is 8 760 independent analyses: the watcher keeps the queue, the
state and the index, and sends each archive's *paths* to the cluster, never its data. A
worker reads the files (so INBOX must be at the same path on every worker: a shared or
network file system), analyzes them in a scratch directory of its own, and returns the
report's files (``findings.json``, ``report.html``, ``corrected.csv`` with
``--corrected``), which the watcher writes and publishes exactly as for a local
analysis; REPORTS need not be visible to the workers. The analyses are the local
watcher's, so are their findings (``tests/watch/test_watch_cluster.py``).

As many analyses are in flight as the cluster has worker threads (each runs on one
thread, with the BLAS threads its worker was started with). A worker that cannot see an
archive's files records an error naming the file and the worker; a task that fails on the
cluster (its worker lost twice, say) records an error too, never a silent gap. Stopping
cancels the tasks not yet started; a task already running on a worker cannot be
interrupted there: it finishes and its result is dropped (it is analyzed again on the
next start, as a local analysis that was abandoned).
"""

from __future__ import annotations

import asyncio
import contextlib
import importlib
import os
import socket
import threading
from pathlib import Path
from typing import Any

from analyzer.errors import one_line
from analyzer.options import RunOptions
from analyzer.outdir import write_atomic
from analyzer.paging import heap_tuned
from analyzer.parallel import DaskExecutor

CANCELLED = -15
"""The exit code a cancelled task reports (as a process ended by SIGTERM would)."""


def analyze_on_worker(
    inputs: list[str], options: RunOptions, msg_path: str = ""
) -> tuple[int, dict[str, bytes]]:
    """Body of a cluster task: the analysis of ``inputs`` (paths as the watcher sees them)
    in a scratch directory of this worker; returns the exit code (0/1 analyzed, 2 input
    error, 3 internal error) and the output files by name. ``msg_path``: the watcher's
    ``--msg-path`` (:data:`~analyzer.readers.rostypes.MSG_PATH_ENV`), read here too."""
    from analyzer.readers.rostypes import MSG_PATH_ENV, MessagePathError, user_store
    from analyzer.scratch import scratch
    from analyzer.watch import analysis_into

    host = socket.gethostname()
    missing = [p for p in inputs if not os.path.exists(p)]
    if missing:
        return 2, {
            "error.txt": (
                f"{missing[0]}: not found on the cluster worker {host} (the workers read "
                "the archives themselves: INBOX must be at the same path on every worker)\n"
            ).encode()
        }
    if msg_path:
        try:
            user_store(msg_path)
        except MessagePathError as err:
            return 2, {
                "error.txt": (
                    f"--msg-path: {err} on the cluster worker {host} (the workers read the "
                    "message definitions themselves: the same path on every worker)\n"
                ).encode()
            }
        os.environ[MSG_PATH_ENV] = msg_path
    # (a worker's heap as Dask leaves it would make the analysis take twice the CPU)
    with heap_tuned(), scratch("analyzer-worker-") as tmp:
        out, work = tmp / "out", tmp / "work"
        out.mkdir()
        work.mkdir()
        code = analysis_into(inputs, options, out, work)
        return code, {f.name: f.read_bytes() for f in sorted(out.iterdir()) if f.is_file()}


def warm_worker() -> bool:
    """Run once on every worker at start-up: import what the local watcher's fork server
    preloads (the pipeline, the report's figure module, the compiled kernels loaded:
    :data:`analyzer.watch.PRELOADED`), so the first archives do not pay for it."""
    from analyzer.watch import PRELOADED, WARM_PRELOAD

    for name in PRELOADED:
        importlib.import_module(name)
    return bool(importlib.import_module(WARM_PRELOAD).WARMED)


class ClusterTask:
    """One archive's analysis on the cluster, behind the part of the interface of
    :class:`multiprocessing.Process` the watcher uses: ``sentinel`` (a pipe that becomes
    readable when the task ends, for ``multiprocessing.connection.wait``), ``exitcode``,
    ``join``, ``is_alive``, ``terminate``/``kill`` (cancel). ``join`` writes the task's
    files into ``out``, the archive's report folder under its temporary name."""

    def __init__(
        self, executor: DaskExecutor, inputs: list[str], options: Any, out: Path, msg_path: str = ""
    ) -> None:
        self.out = out
        self.exitcode: int | None = None
        self._abandoned = False  # cancelled by the watcher (not by the cluster)
        self._read, self._write = os.pipe()
        self._lock = threading.Lock()
        self.future = executor.client.submit(
            analyze_on_worker, inputs, options, msg_path, pure=False
        )
        self.future.add_done_callback(self._ended)

    @property
    def sentinel(self) -> int:
        return self._read

    def _ended(self, _future: Any) -> None:  # on the client's thread
        with self._lock, contextlib.suppress(OSError):
            if self._write >= 0:
                os.write(self._write, b"x")

    def is_alive(self) -> bool:
        return self.exitcode is None and not self.future.done()

    def join(self, timeout: float | None = None) -> None:
        if self.exitcode is not None:
            return
        try:
            code, files = self.future.result(timeout=timeout)
        except TimeoutError:
            return
        except (Exception, asyncio.CancelledError) as err:  # recorded as this archive's
            if self._abandoned:
                code, files = CANCELLED, {}
            else:  # failed, or cancelled by the cluster (its scheduler lost, say)
                how = "cancelled by" if self.future.cancelled() else "failed on"
                why = one_line(err) or "no reason given"
                text = f"internal error: the analysis task {how} the cluster: "
                text += f"{type(err).__name__}: {why}\n"
                code, files = 3, {"error.txt": text.encode()}
        try:
            for name, data in files.items():
                write_atomic(self.out / Path(name).name, data)
        except OSError as err:  # (REPORTS full): the file's error, as a local analysis's
            code = self._unwritten(err)
        self.exitcode = code
        self._close()

    def _unwritten(self, err: OSError) -> int:
        """The task's files could not be written into :attr:`out` (REPORTS full): what
        was written is removed, ``error.txt`` names the file where it can be written,
        and the exit code is a local analysis's that could not write its report
        (:data:`analyzer.watch.EXIT_UNWRITTEN`). Before, the error went up through the
        watcher's loop."""
        from analyzer.watch import EXIT_UNWRITTEN, unwritten_line

        for leftover in self.out.iterdir():
            with contextlib.suppress(OSError):
                leftover.unlink()
        with contextlib.suppress(OSError):
            write_atomic(self.out / "error.txt", unwritten_line(err, self.out) + "\n")
        return EXIT_UNWRITTEN

    def terminate(self) -> None:
        """Cancel the task: one not yet started never runs; one running on a worker
        finishes there, and its result is dropped."""
        self._abandoned = True
        self.future.cancel()

    kill = terminate

    def _close(self) -> None:
        with self._lock:
            for fd in (self._read, self._write):
                with contextlib.suppress(OSError):
                    os.close(fd)
            self._read = self._write = -1


__all__ = ["CANCELLED", "ClusterTask", "analyze_on_worker", "warm_worker"]
