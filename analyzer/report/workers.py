"""Report figures drawn in worker processes, warm before the report is needed.

At the end of ``analyzer run`` the report draws about eight matplotlib figures (0.2-0.9 s
each) after importing matplotlib (about 0.7 s): 1.8-2.8 s on one core while the other is
idle, and matplotlib holds the GIL, so threads cannot share the work. The CLI therefore
enters :func:`figure_workers` first thing in ``run``:

* a ``forkserver`` (a multiprocessing *context*, so the default start method of the
  process is not changed) is started with :data:`~analyzer.report.jobs.PRELOAD_MODULE`
  preloaded: the server imports matplotlib while the main process imports the pipeline
  (a second of start-up on one core) and reads the archive;
* at the report, :class:`FigureBatch` submits each figure job as the view describes it
  to a :class:`~concurrent.futures.ProcessPoolExecutor` (at most :data:`MAX_WORKERS`
  workers forked from that server, matplotlib already imported); the main process
  never imports matplotlib and builds the rest of the page meanwhile.

Without the context (library callers of :func:`analyzer.findings.write_outputs`, the
tests that call the CLI in-process, the watcher's analysis processes) figures are drawn
in-process, in the same order; a figure does not depend on where it is drawn, so the
page is byte-identical either way.

Robustness: if the server cannot start, a worker dies (``BrokenProcessPool``), a job
cannot be pickled or anything else goes wrong in the pool, the figures it did not
deliver are drawn in-process (one line in the log, no figure lost). Workers ignore
SIGINT (the main process handles Ctrl-C and SIGTERM), are terminated when the context
is left by an exception, and exit by themselves if the main process disappears
without leaving it (``kill -9``, ``os._exit``): nothing outlives the CLI.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import multiprocessing.forkserver
import os
import signal
import threading
from collections.abc import Iterator
from concurrent.futures import Future, ProcessPoolExecutor
from multiprocessing.connection import wait

from markupsafe import Markup

from analyzer.report.jobs import PRELOAD_MODULE, FigureJob, draw

log = logging.getLogger("analyzer.report")

MAX_WORKERS = 2
"""Figure processes: the machine this is tuned for has two cores, and eight figures."""
NICENESS = 10
"""How much lower than the run the figure processes are scheduled (see
:meth:`FigureWorkers._yield_cpu`)."""
JOIN_TIMEOUT_S = 5.0
"""How long a terminated worker is waited for before it is killed."""


def _worker_init() -> None:
    """In each worker: leave Ctrl-C to the main process (a terminal sends SIGINT to the
    whole process group), and exit when the main process is gone. A forkserver child's
    ``parent_process().sentinel`` is the read end of a pipe whose write end only the main
    process holds: it becomes readable (EOF) exactly when that process ends."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGHUP, signal.SIG_IGN)  # (and a hang-up: the main process's too)
    parent = multiprocessing.parent_process()
    if parent is not None and parent.sentinel is not None:
        threading.Thread(
            target=_exit_with, args=(parent.sentinel,), name="analyzer-orphan-watch", daemon=True
        ).start()


@contextlib.contextmanager
def _hangup_ignored() -> Iterator[None]:
    """SIGHUP ignored during the block, in which the forkserver and multiprocessing's
    resource tracker are started (a fork and exec, which keeps an ignored signal
    ignored): a hang-up sent to the whole process group (a terminal closed) is the main
    process's to act on, which stops the run as SIGTERM does; the two helpers, killed
    by it, printed "resource_tracker: process died unexpectedly" and a traceback per
    semaphore above "interrupted" (ux66 L1). They end with the main process anyway. A
    hang-up in these milliseconds is lost."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGHUP, previous)


def _exit_with(sentinel: int) -> None:
    wait([sentinel])
    os._exit(1)


class FigureWorkers:
    """A process pool for figure jobs, forked from a server that imported matplotlib.

    Raises whatever starting the server raises (``ValueError`` where there is no
    ``forkserver``, ``OSError``...); :func:`figure_workers` turns that into "no pool"."""

    def __init__(self, max_workers: int = MAX_WORKERS) -> None:
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload([PRELOAD_MODULE])
        server = getattr(multiprocessing.forkserver, "_forkserver", None)
        self._own_server = getattr(server, "_forkserver_pid", 0) is None
        # starts the server now (a fork and exec: milliseconds), not at the first figure:
        # its imports run on the idle core while this process reads the archive
        with _hangup_ignored():
            multiprocessing.forkserver.ensure_running()
        if self._own_server:
            self._yield_cpu(getattr(server, "_forkserver_pid", None))
        self._lock = threading.Lock()
        self._futures: list[Future[str]] = []
        try:
            self._executor: ProcessPoolExecutor | None = ProcessPoolExecutor(
                max_workers=max_workers, mp_context=ctx, initializer=_worker_init
            )
        except BaseException:
            self.close()
            raise

    @staticmethod
    def _yield_cpu(pid: int | None) -> None:
        """Lower the server's scheduling priority by :data:`NICENESS` (its workers inherit
        it): its matplotlib import should take a core the run leaves idle, not compete
        with the run's reading (a CSV archive is parsed on every core); the figures are
        needed only at the end, when the workers have the cores to themselves. Without
        the permission or the call, the server keeps its priority."""
        if pid is not None:
            with contextlib.suppress(AttributeError, OSError):
                os.setpriority(os.PRIO_PROCESS, pid, os.getpriority(os.PRIO_PROCESS, 0) + NICENESS)

    @property
    def usable(self) -> bool:
        return self._executor is not None

    def submit(self, job: FigureJob) -> Future[str] | None:
        """The job's SVG to come, or None if the pool is not (or no longer) usable."""
        with self._lock:
            if self._executor is None:
                return None
            try:
                future = self._executor.submit(draw, job)
                self._futures.append(future)
                return future
            except Exception as err:  # noqa: BLE001 - broken or shut down: draw in-process
                self._fail(err)
                return None

    def failed(self, err: BaseException) -> None:
        """A job came back with ``err``: stop using the pool (its figures are drawn
        in-process from now on)."""
        with self._lock:
            self._fail(err)

    def _fail(self, err: BaseException) -> None:
        if self._executor is not None:
            log.info("figures drawn in-process: the figure workers failed (%s)", err)
            self._shutdown(self._executor, cancel=True)
            self._executor = None

    def close(self, cancel: bool = False) -> None:
        """Stop the workers: after their jobs, or at once with ``cancel`` (an interrupt);
        then the server, if this pool started it."""
        with self._lock:
            executor = getattr(self, "_executor", None)  # None, or unset if __init__ failed
            if executor is not None:
                # idle workers are stopped at once too: they have nothing left to do, and
                # a normal exit of each (an interpreter with matplotlib to finalize) would
                # add 0.1-0.2 s to the end of the run
                idle = all(f.done() for f in self._futures)
                self._shutdown(executor, cancel or idle)
                self._executor = None
            if self._own_server:
                self._own_server = False
                self._stop_server()

    @staticmethod
    def _stop_server() -> None:
        """The server would otherwise live until this process exits: a process left
        behind by each test that uses a pool, and it leaves its socket file in
        multiprocessing's temporary folder after an ``os._exit``. It stops once every
        worker (they hold its "alive" pipe too) is gone. There is no public API for
        this; ``_stop`` is what CPython's own tests use."""
        server = getattr(multiprocessing.forkserver, "_forkserver", None)
        stop = getattr(server, "_stop", None)
        if stop is None:
            return
        pid = getattr(server, "_forkserver_pid", None)
        with contextlib.suppress(Exception):
            if pid is not None:
                os.kill(pid, signal.SIGTERM)  # it has nothing to save: no slow normal exit
            stop()

    @staticmethod
    def _shutdown(executor: ProcessPoolExecutor, cancel: bool) -> None:
        """Shut ``executor`` down; with ``cancel``, terminate its workers first (the
        executor has no public way to do that before Python 3.14)."""
        procs = list((getattr(executor, "_processes", None) or {}).values())
        if cancel:
            for p in procs:
                with contextlib.suppress(Exception):
                    p.terminate()
        executor.shutdown(wait=True, cancel_futures=cancel)
        for p in procs:
            p.join(JOIN_TIMEOUT_S)
            if p.is_alive():
                p.kill()
                p.join()


_active: FigureWorkers | None = None
"""The pool :func:`figure_workers` made current (None outside it: draw in-process)."""


def active_workers() -> FigureWorkers | None:
    """The pool of the enclosing :func:`figure_workers` context, if any."""
    return _active


@contextlib.contextmanager
def figure_workers(max_workers: int = MAX_WORKERS) -> Iterator[FigureWorkers | None]:
    """Start the figure workers' server now and make the pool current for the block
    (the report drawn in the block uses it); stop the workers when the block ends, at
    once if it ends by an exception (an interrupt). Yields None, and the report is drawn
    in-process, where the pool cannot be started."""
    global _active
    try:
        workers: FigureWorkers | None = FigureWorkers(max_workers)
    except Exception as err:  # noqa: BLE001 - no pool: draw in-process
        log.info("figures drawn in-process: no figure workers (%s)", err)
        workers = None
    previous, _active = _active, workers
    try:
        yield workers
    except BaseException:
        if workers is not None:
            workers.close(cancel=True)
        raise
    else:
        if workers is not None:
            workers.close()
    finally:
        _active = previous


class FigureBatch:
    """The figures of one report: each job goes to the pool as soon as it is added (the
    workers draw while the view is being built), :meth:`results` returns every SVG in
    the order added, drawing in-process whatever the pool did not deliver."""

    def __init__(self, workers: FigureWorkers | None = None) -> None:
        self.workers = workers if workers is not None and workers.usable else None
        self.jobs: list[FigureJob] = []
        self.futures: list[Future[str] | None] = []
        self.failures: dict[int, str] = {}
        """Index of each job that could not be drawn (by a worker nor here) -> why."""

    def add(self, job: FigureJob) -> int:
        """Add ``job``; its index in :meth:`results`."""
        self.jobs.append(job)
        self.futures.append(None if self.workers is None else self.workers.submit(job))
        return len(self.jobs) - 1

    def results(self) -> list[Markup]:
        """Every SVG in the order added. A figure that cannot be drawn in-process either
        (its data breaks the plotting library) becomes a line saying so, and its reason is
        kept in :attr:`failures`: one figure does not cost the page."""
        out = []
        for i, (job, future) in enumerate(zip(self.jobs, self.futures, strict=True)):
            svg = None
            if future is not None:
                try:
                    svg = future.result()
                except Exception as err:  # noqa: BLE001 - drawn in-process below
                    if self.workers is not None:
                        self.workers.failed(err)
            if svg is None:
                try:
                    svg = draw(job)
                except Exception as err:  # noqa: BLE001 - one figure, not the page
                    why = f"{type(err).__name__}: {' '.join(str(err).split())}"[:300]
                    self.failures[i] = why
                    svg = str(
                        Markup(
                            '<p class="figure-failed">This figure could not be drawn ({}).</p>'
                        ).format(why)
                    )
            out.append(Markup(svg))
        return out


__all__ = [
    "MAX_WORKERS",
    "FigureBatch",
    "FigureWorkers",
    "active_workers",
    "figure_workers",
]
