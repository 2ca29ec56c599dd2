"""Where the work runs: one small executor protocol for the pipeline and the detectors.

The pipeline runs each detector as a task (:meth:`Executor.submit`) and a detector may
split its own work with :meth:`Executor.map` (through :meth:`RunContext.map
<analyzer.detectors.base.RunContext.map>`), for example the AR-Kalman bank's time blocks.
Three back ends, all with the same results as the serial run:

* :class:`SerialExecutor` -- a plain loop (the default);
* :class:`ThreadExecutor` -- ``--jobs N``: a thread pool; the hot paths (numpy, BLAS,
  scipy, numba) release the GIL, and threads share the aligned matrix without copies;
* :class:`DaskExecutor` -- ``--scheduler tcp://HOST:PORT``: an existing Dask distributed
  cluster. The detectors' own steps stay in the calling process (over its memory-mapped
  archive); the pieces they split off go to the workers, each with its rows only, a
  bounded number at a time (:meth:`Executor.imap`), so neither side holds the archive.

Tasks are module-level (picklable) functions. An exception raised in a task comes back
from ``map``/``result()`` as the same type with the same message (Dask pickles it back),
so a :class:`~analyzer.errors.DetectorError` in a worker is still a skipped detector.

This module holds the protocol, the two local executors and :func:`make_executor`; the
cluster's side is in its own modules, whose public names (and tunables) are importable
from here too:

* :mod:`analyzer.parallel_dask` -- :class:`DaskExecutor`: tasks streamed to the cluster,
  a lost one sent again or computed here;
* :mod:`analyzer.parallel_connect` -- connecting to the scheduler, with deadlines;
* :mod:`analyzer.parallel_tasks` -- what a cluster task is made of;
* :mod:`analyzer.parallel_logs` -- Dask's own log lines kept off stderr meanwhile.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Protocol, TypeVar

from analyzer.cgroup_cpus import cgroup_cpu_limit
from analyzer.errors import UsageError
from analyzer.parallel_connect import CONNECT_MARGIN_S, blas_threads_setting
from analyzer.parallel_dask import (
    CONNECT_TIMEOUT_S,
    IN_FLIGHT_PER_THREAD,
    INLINE_BYTES,
    RESEND_LIMIT,
    SEND_TIMEOUT_S,
    WAIT_POLL_S,
    ClusterTrouble,
    DaskExecutor,
)
from analyzer.parallel_tasks import _pickled_nbytes as _pickled_nbytes

T = TypeVar("T")
R = TypeVar("R")

_THREAD_PREFIX = "analyzer-pool"
"""Names of the ThreadExecutor's threads (how a nested map knows it runs in one)."""


class TaskHandle(Protocol):
    """What :meth:`Executor.submit` returns: ``result()`` waits and re-raises the task's
    exception; ``cancel()`` drops a task that has not started."""

    def result(self) -> Any: ...

    def cancel(self) -> bool: ...


class Executor(Protocol):
    """Runs picklable module-level functions; ``workers`` is the parallelism it offers."""

    workers: int
    shares_memory: bool
    """True when tasks run in this process: a task may then write into the caller's
    arrays (disjoint slices) instead of returning copies."""

    def map(self, fn: Callable[[T], R], items: Sequence[T]) -> list[R]:
        """``[fn(x) for x in items]``, possibly concurrently, results in input order."""
        ...

    def imap(self, fn: Callable[[T], R], items: Iterable[T]) -> Iterator[R]:
        """:meth:`map` as an iterator, for a caller that consumes each result once (a
        time block's outputs, written into the caller's arrays): on a cluster only a few
        items and results are held at once, the rest not yet sent or already handed over."""
        ...

    def scatter(self, obj: T) -> Any:
        """A handle for a large argument shared by several items of :meth:`map` or
        :meth:`imap` (a fitted model): the object itself locally, a future on a cluster,
        sent to each worker once; put it in the items (tuples) in place of ``obj``."""
        ...

    def submit(self, fn: Callable[..., R], *args: Any) -> TaskHandle:
        """Start ``fn(*args)``; the handle's ``result()`` returns its value."""
        ...

    def close(self, wait: bool = True) -> None:
        """Release the executor; ``wait=False`` (a run that stopped on an error or an
        interrupt) does not wait for tasks already running."""
        ...


class _Deferred:
    """A serial task: runs on the first ``result()``, so a run stopped by an error in an
    earlier task never starts the later ones (exactly the plain loop's behaviour)."""

    __slots__ = ("_args", "_done", "_error", "_fn", "_value")

    def __init__(self, fn: Callable[..., Any], args: tuple[Any, ...]) -> None:
        self._fn, self._args = fn, args
        self._done = False
        self._value: Any = None
        self._error: BaseException | None = None

    def result(self) -> Any:
        if not self._done:
            self._done = True
            try:
                self._value = self._fn(*self._args)
            except BaseException as err:  # re-raised below, and on every later call
                self._error = err
            self._fn, self._args = None, ()  # type: ignore[assignment]
        if self._error is not None:
            raise self._error
        return self._value

    def cancel(self) -> bool:
        if self._done:
            return False
        self._done = True
        self._fn, self._args = None, ()  # type: ignore[assignment]
        return True


class SerialExecutor:
    """Everything in the calling thread, in order."""

    workers = 1
    shares_memory = True

    def map(self, fn: Callable[[T], R], items: Sequence[T]) -> list[R]:
        return [fn(x) for x in items]

    def imap(self, fn: Callable[[T], R], items: Iterable[T]) -> Iterator[R]:
        return map(fn, items)

    def submit(self, fn: Callable[..., R], *args: Any) -> TaskHandle:
        return _Deferred(fn, args)

    def scatter(self, obj: T) -> T:
        return obj

    def close(self, wait: bool = True) -> None:
        pass

    def __repr__(self) -> str:
        return "SerialExecutor()"


class ThreadExecutor:
    """``jobs`` threads. :meth:`map` may be called from inside a task (a detector that
    splits its work): the calling pool thread then runs the items no thread has started
    yet itself, from the back, while the other threads take them from the front, so a
    nested map neither deadlocks a full pool nor leaves its caller idle."""

    shares_memory = True

    def __init__(self, jobs: int) -> None:
        if jobs < 1:
            raise UsageError(f"--jobs: must be >= 1, got {jobs}")
        self.workers = jobs
        self._pool = ThreadPoolExecutor(max_workers=jobs, thread_name_prefix=_THREAD_PREFIX)

    def map(self, fn: Callable[[T], R], items: Sequence[T]) -> list[R]:
        items = list(items)
        if len(items) <= 1:
            return [fn(x) for x in items]
        futures = [self._pool.submit(fn, x) for x in items]
        mine: dict[int, R] = {}
        try:
            if threading.current_thread().name.startswith(_THREAD_PREFIX):
                # called from a task of this pool, whose thread would otherwise only wait:
                # it takes the items no thread has picked up, from the back (the pool's
                # threads take them from the front); cancel() succeeds only for those
                for i in range(len(items) - 1, -1, -1):
                    if futures[i].cancel():
                        mine[i] = fn(items[i])
            return [mine[i] if i in mine else futures[i].result() for i in range(len(items))]
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise

    def imap(self, fn: Callable[[T], R], items: Iterable[T]) -> Iterator[R]:
        return iter(self.map(fn, list(items)))

    def submit(self, fn: Callable[..., R], *args: Any) -> Future[R]:
        return self._pool.submit(fn, *args)

    def scatter(self, obj: T) -> T:
        return obj

    def close(self, wait: bool = True) -> None:
        # after an interrupt the caller unwinds at once: a task inside a compiled kernel
        # (minutes, on a large group of channels) is left to the process's end
        self._pool.shutdown(wait=wait, cancel_futures=True)

    def __repr__(self) -> str:
        return f"ThreadExecutor({self.workers})"


def make_executor(jobs: int | None = None, scheduler: str | None = None) -> Executor:
    """The executor for ``--jobs``/``--scheduler``: Dask when a scheduler is given,
    threads for ``jobs > 1``, else serial."""
    if scheduler is not None:  # (an empty one is refused there, not run locally)
        return DaskExecutor(scheduler)
    if jobs is not None and jobs > 1:
        return ThreadExecutor(jobs)
    return SerialExecutor()


def locked(progress: Callable[[str, float], None] | None) -> Callable[[str, float], None] | None:
    """``progress`` made safe to call from several threads (one line at a time)."""
    if progress is None:
        return None
    lock = threading.Lock()

    def report(stage: str, fraction: float) -> None:
        with lock:
            progress(stage, fraction)

    return report


def usable_cpus() -> int:
    """The number of CPUs this process may use, ``--jobs``' default: its CPU affinity
    (``taskset``, a container's cpuset), where the system gives one, else the machine's
    cores; and no more than its cgroup's CPU-time quota allows (a container's ``--cpus
    2``: :func:`analyzer.cgroup_cpus.cgroup_cpu_limit`, the quota over its period rounded
    up). ``os.cpu_count()`` counted the host's
    cores: ``taskset -c 0`` on a 2-core machine ran 2 analysis processes on one CPU, and
    a CI container allowed a few CPUs of a large host ran a thread for each of its cores
    (a QA audit's ux59 item L4); a quota was not counted until the integrator's audit's
    int56 item 3 (``os.process_cpu_count()`` of Python 3.13 does not count it either)."""
    try:
        cpus = len(os.sched_getaffinity(0)) or 1
    except (AttributeError, OSError):  # (no affinity: macOS, Windows)
        cpus = os.cpu_count() or 1
    quota = cgroup_cpu_limit()
    return cpus if quota is None else max(1, min(cpus, quota))


__all__ = [
    "CONNECT_MARGIN_S",
    "CONNECT_TIMEOUT_S",
    "IN_FLIGHT_PER_THREAD",
    "INLINE_BYTES",
    "RESEND_LIMIT",
    "SEND_TIMEOUT_S",
    "WAIT_POLL_S",
    "ClusterTrouble",
    "DaskExecutor",
    "Executor",
    "SerialExecutor",
    "TaskHandle",
    "ThreadExecutor",
    "usable_cpus",
    "blas_threads_setting",
    "locked",
    "make_executor",
]
