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
"""

from __future__ import annotations

import contextlib
import itertools
import os
import socket
import threading
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Protocol, TypeVar

import numpy as np

from analyzer.errors import UsageError
from analyzer.paging import heap_tuned, release

T = TypeVar("T")
R = TypeVar("R")

_THREAD_PREFIX = "analyzer-pool"
"""Names of the ThreadExecutor's threads (how a nested map knows it runs in one)."""

CONNECT_TIMEOUT_S = 10.0
"""How long ``--scheduler`` waits for the scheduler to answer before giving up."""


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


class DaskExecutor:
    """A client of the Dask distributed scheduler at ``address`` (``tcp://HOST:PORT``).

    Raises :class:`UsageError` naming ``--scheduler`` when ``distributed`` is missing,
    the scheduler does not answer within ``timeout`` seconds, or no worker is connected
    to it within that time (before anything is read, not when the first task waits).
    ``workers`` is the cluster's total worker threads when connected (at least 1)."""

    shares_memory = False

    def __init__(self, address: str, timeout: float | None = None) -> None:
        try:
            from distributed import Client
        except ImportError as err:
            raise UsageError(
                f"--scheduler {address}: needs the 'distributed' package "
                "(pip install 'analyzer[distributed]')"
            ) from err
        self.address = address
        wait = CONNECT_TIMEOUT_S if timeout is None else timeout
        _probe(address, wait)
        client = Client.__new__(Client)
        try:
            client.__init__(address, timeout=wait, set_as_default=False)  # type: ignore[misc]
        except Exception as err:  # whatever answered there, it is not a usable scheduler
            _quiet_close(client)
            why = " ".join(str(err).split())[:200] or type(err).__name__
            if not isinstance(err, OSError | TimeoutError):
                why = f"no Dask scheduler answered there: {why}"
            raise UsageError(f"--scheduler {address}: cannot connect ({why})") from err
        self.client = client
        info = self.client.scheduler_info()
        if not info.get("workers"):  # workers may still be starting: wait for one
            try:
                client.wait_for_workers(1, timeout=wait)
            except Exception as err:  # noqa: BLE001 - Dask's timeout types vary by version
                _quiet_close(client)
                raise UsageError(
                    f"--scheduler {address}: no worker is connected to the scheduler (waited "
                    f"{wait:g} s); start some with 'dask worker {address}'"
                ) from err
            info = self.client.scheduler_info()
        workers = info.get("workers", {})
        self.n_workers = len(workers)
        self.workers = max(1, sum(int(w.get("nthreads", 1)) for w in workers.values()))
        self.blas_threads: dict[str, str | None] = (
            dict(self.client.run(blas_threads_setting)) if workers else {}
        )

    def map(self, fn: Callable[[T], R], items: Sequence[T]) -> list[R]:
        return list(self.imap(fn, items))

    def imap(self, fn: Callable[[T], R], items: Iterable[T]) -> Iterator[R]:
        return _stream_on(self.client, fn, items, IN_FLIGHT_PER_THREAD * self.workers)

    def submit(self, fn: Callable[..., R], *args: Any) -> TaskHandle:
        return self.client.submit(_on_worker, fn, *args, pure=False)

    def scatter(self, obj: T) -> Any:
        return self.client.scatter(obj, broadcast=True, hash=False)

    def close(self, wait: bool = True) -> None:
        self.client.close()

    def describe(self) -> str:
        """For the findings' notes: where the run happened."""
        n = self.n_workers
        text = (
            f"ran on Dask scheduler {self.address}: {n} worker{'s' if n != 1 else ''}, "
            f"{self.workers} thread{'s' if self.workers != 1 else ''}"
        )
        loose = sorted(w for w, v in self.blas_threads.items() if v != "1")
        if loose:
            text += (
                f"; {len(loose)} worker{'s' if len(loose) != 1 else ''} without "
                "OPENBLAS_NUM_THREADS=1 (threaded BLAS slows the filters down)"
            )
        return text

    def __repr__(self) -> str:
        return f"DaskExecutor({self.address!r})"


IN_FLIGHT_PER_THREAD = 2
"""Items of :meth:`DaskExecutor.imap` on the cluster at once, per worker thread: enough
to keep every thread busy while the results of the others travel."""


INLINE_BYTES = 1 << 16
"""An item's arrays smaller than this go with its task; larger ones are scattered."""


def _stream_on(client: Any, fn: Callable[[T], R], items: Iterable[T], window: int) -> Iterator[R]:
    """``fn`` over ``items`` as tasks of ``client``, results in order, with at most
    ``window`` items sent and not yet handed over: an item is taken from ``items`` (and
    its rows read, for a view of a memory-mapped archive) only when one of those is
    handed over, so the caller and the workers hold a few items each, not the archive.
    An item's arrays are scattered rather than packed into the task graph, which stays
    small however large they are; its futures (:meth:`DaskExecutor.scatter`) are passed
    on, so what they stand for is sent to a worker once, not with every item. Tasks
    still pending are cancelled when the caller stops early (an error, or a result it
    did not need)."""
    source = iter(items)
    pending: deque[Any] = deque()

    def send(count: int) -> None:
        for item in itertools.islice(source, count):
            if isinstance(item, tuple):
                # (a view of a memory-mapped array goes as a plain array)
                parts = [np.asarray(x) if isinstance(x, np.ndarray) else x for x in item]
                big = [
                    k
                    for k, x in enumerate(parts)
                    if isinstance(x, np.ndarray) and x.nbytes >= INLINE_BYTES
                ]
                if big:
                    sent = client.scatter([parts[k] for k in big], hash=False)
                    for k, handle in zip(big, sent, strict=True):
                        release(parts[k])  # rows of a memory-mapped archive: sent, let go
                        parts[k] = handle
                # futures among the arguments are replaced by their values on the worker
                pending.append(client.submit(_apply, fn, *parts, pure=False))
            else:
                [handle] = client.scatter([item], hash=False)
                pending.append(client.submit(_on_worker, fn, handle, pure=False))

    try:
        send(max(1, window))
        while pending:
            value = pending[0].result()
            pending.popleft()
            send(1)
            yield value
    finally:
        for future in pending:
            future.cancel()


def _apply(fn: Callable[[tuple[Any, ...]], R], *parts: Any) -> R:
    """``fn`` on the tuple of ``parts`` (a task of :func:`_stream_on`)."""
    with heap_tuned():
        return fn(parts)


def _on_worker(fn: Callable[..., R], *args: Any) -> R:
    """``fn(*args)`` as a task on a worker, whose heap Dask leaves set to give every freed
    block back to the kernel (:func:`~analyzer.paging.heap_tuned`: twice the CPU)."""
    with heap_tuned():
        return fn(*args)


def _quiet_close(client: Any) -> None:
    """Close a client whose start failed, so its finalizer has nothing left to report."""
    with contextlib.suppress(Exception):  # best effort on an already broken client
        client.close(timeout=2)


def _probe(address: str, timeout: float) -> None:
    """Check ``address`` is a scheduler address and, over TCP, that something listens
    there: an unreachable scheduler fails at once with a clear message (rather than
    after the client's retries)."""
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, location = parse_address(address)
        if scheme not in ("tcp", "tls"):
            return
        host, port = parse_host_port(location)
    except ValueError as err:
        raise UsageError(
            f"--scheduler {address}: expected an address like tcp://HOST:PORT ({err})"
        ) from err
    try:
        with socket.create_connection((host, port), timeout=timeout):
            pass
    except OSError as err:
        why = err.strerror or " ".join(str(err).split()) or type(err).__name__
        raise UsageError(f"--scheduler {address}: cannot connect ({why})") from err


def blas_threads_setting() -> str | None:
    """``OPENBLAS_NUM_THREADS`` of the process that runs this (asked of each worker)."""
    return os.environ.get("OPENBLAS_NUM_THREADS")


def make_executor(jobs: int | None = None, scheduler: str | None = None) -> Executor:
    """The executor for ``--jobs``/``--scheduler``: Dask when a scheduler is given,
    threads for ``jobs > 1``, else serial."""
    if scheduler:
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


__all__ = [
    "CONNECT_TIMEOUT_S",
    "DaskExecutor",
    "Executor",
    "SerialExecutor",
    "TaskHandle",
    "ThreadExecutor",
    "blas_threads_setting",
    "locked",
    "make_executor",
]
