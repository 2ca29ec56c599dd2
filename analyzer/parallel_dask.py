"""``--scheduler``: the detectors' split-off work as tasks of a Dask distributed cluster.

:class:`DaskExecutor` is the :class:`~analyzer.parallel.Executor` of an existing cluster.
The detectors' own steps stay in the calling process (over its memory-mapped archive);
the pieces they split off go to the workers, each with its rows only, a bounded number at
a time (:func:`_stream_on`), so neither side holds the archive. A task the cluster loses
(a worker gone with its rows, its inputs or its connection) is sent again, or computed in
this process when the cluster cannot take it; the task's own exception comes back
unchanged and is never retried. While the executor is open, Dask's own log lines about
those losses are kept off stderr (:mod:`analyzer.parallel_logs`).

Connecting is :mod:`analyzer.parallel_connect`; what a task is made of (the functions run
on a worker, an item's size, which errors are the cluster's) is
:mod:`analyzer.parallel_tasks`. The tunables below are importable from
:mod:`analyzer.parallel` too, and setting one there sets it here.
"""

from __future__ import annotations

import contextlib
import itertools
import threading
import time
import weakref
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from analyzer.errors import UsageError, counted
from analyzer.paging import release
from analyzer.parallel_connect import _connect, _probe
from analyzer.parallel_logs import DaskLog
from analyzer.parallel_tasks import (
    _apply,
    _killed_worker,
    _on_worker,
    _pickled_nbytes,
    _raise_unless_from_the_cluster,
    _said,
    _tasks,
)
from analyzer.types import Note

if TYPE_CHECKING:
    from analyzer.parallel import TaskHandle

T = TypeVar("T")
R = TypeVar("R")

CONNECT_TIMEOUT_S = 10.0
"""How long ``--scheduler`` waits for the scheduler to answer before giving up."""

IN_FLIGHT_PER_THREAD = 2
"""Items of :meth:`DaskExecutor.imap` on the cluster at once, per worker thread: enough
to keep every thread busy while the results of the others travel."""

INLINE_BYTES = 1 << 16
"""An item's parts smaller than this (pickled) go with its task; larger ones are
scattered beside it."""

FETCH_TRIES = 3
"""How many times the result of a task the cluster has computed is waited for again
when fetching it fails or times out, before the task is sent again."""

MEMORY_RESTARTS = "worker-restart-memory"
"""The scheduler's topic of the events a nanny sends when it restarts its worker for
going over its memory limit."""

RESEND_LIMIT = 3
"""How many times an item whose task the cluster lost is sent again before it is
computed in this process."""

WAIT_POLL_S = 2.0
"""How often a wait for a task to finish checks that the cluster can still run it (not a
limit on fetching a finished task's result: that is :data:`SEND_TIMEOUT_S`)."""

SEND_TIMEOUT_S = 120.0
"""How long sending an item's data (or a shared object) to the cluster may take before it
counts as refused (and is tried again): the largest block (4 M values, 32 MB) takes
about 0.3 s over gigabit Ethernet, 30 s at 10 Mbit/s."""


class ClusterTrouble(Note):
    """The line of :meth:`DaskExecutor.trouble` among a run's notes: ``run`` repeats it on
    stderr as a warning (the run went on in its own process)."""

    __slots__ = ()


class DaskExecutor:
    """A client of the Dask distributed scheduler at ``address`` (``tcp://HOST:PORT``).

    Raises :class:`UsageError` naming ``--scheduler`` when ``distributed`` is missing,
    the scheduler does not answer within ``timeout`` seconds, or no worker is connected
    to it within that time (before anything is read, not when the first task waits).
    The connection is made on a thread of its own, so that a scheduler which accepts it
    and then says nothing (Dask's client would wait for its handshake forever) is given
    up after ``timeout`` seconds too, and ``stop`` (the watcher's signal) or an interrupt
    ends the wait at once. ``workers`` is the cluster's total worker threads when
    connected (at least 1).

    A task the cluster loses (a worker gone with its rows, its inputs or its connection)
    is sent again, up to :data:`RESEND_LIMIT` times, and computed in this process when
    the cluster cannot take it (no worker left, the scheduler gone): its item is kept
    until its result is handed over (:func:`_stream_on`). An exception raised by the
    task itself is never retried: it comes back unchanged. ``resent`` and ``here``
    count those tasks, and :meth:`describe` says so.

    From the connection to :meth:`close`, Dask's own log lines (about a lost worker, a
    scheduler gone) are held in ``dask_log`` instead of printed on stderr
    (:mod:`analyzer.parallel_logs`)."""

    shares_memory = False

    def __init__(
        self, address: str, timeout: float | None = None, stop: threading.Event | None = None
    ) -> None:
        try:
            import distributed
        except ImportError as err:
            raise UsageError(
                f"--scheduler {address}: needs the 'distributed' package "
                "(pip install 'sensorlog-analyzer[distributed]')"
            ) from err
        if not address.strip():
            raise UsageError("--scheduler: an empty address; expected one like tcp://HOST:PORT")
        self.address = address
        wait = CONNECT_TIMEOUT_S if timeout is None else timeout
        self.timeout = wait
        self.dask_log = DaskLog().open()
        """Dask's own log lines while the executor is open, kept off stderr."""
        weakref.finalize(self, self.dask_log.close)  # (an executor dropped unclosed)
        try:
            _probe(address, wait)
            self.client, info, self.blas_threads = _connect(address, wait, stop)
        except BaseException:
            self.dask_log.close()
            raise
        workers = info.get("workers", {})
        self.n_workers = len(workers)
        self.workers = max(1, sum(int(w.get("nthreads", 1)) for w in workers.values()))
        self.resent = 0
        """Tasks sent to the cluster again after it lost them (cancelled: a worker gone
        with their data, or the data they need)."""
        self.retried = 0
        """Tasks sent again after the cluster refused them, or after their result could
        not be fetched :data:`FETCH_TRIES` times (a slow or loaded cluster, a connection
        that timed out: nothing lost)."""
        self.here = 0
        """Tasks computed in this process because the cluster could not take them."""
        self.gone: str | None = None
        """Why the cluster no longer gets tasks (none of them is sent once this is set)."""
        self._future = distributed.Future
        self._wait = distributed.wait
        self._shared: dict[Any, Any] = {}  # what each live handle of scatter() stands for
        self._renewed: dict[Any, Any] = {}  # a lost handle's replacement
        self._unusable_since: float | None = None
        self._lock = threading.Lock()
        self._began = time.monotonic()
        self._began_wall = time.time()  # (the scheduler's events carry wall times)
        self.gone_after_s: float | None = None
        """Seconds from the connection to when :attr:`gone` was set."""
        self._restarts = 0  # the workers' restarts for memory, last counted
        limits = {int(w.get("memory_limit") or 0) for w in workers.values()}
        self._memory_limit = min(limits) if limits and 0 not in limits else None

    def map(self, fn: Callable[[T], R], items: Sequence[T]) -> list[R]:
        return list(self.imap(fn, items))

    def imap(self, fn: Callable[[T], R], items: Iterable[T]) -> Iterator[R]:
        return _stream_on(self, fn, items, IN_FLIGHT_PER_THREAD * self.workers)

    def submit(self, fn: Callable[..., R], *args: Any) -> TaskHandle:
        return self.client.submit(_on_worker, fn, *args, pure=False)

    def scatter(self, obj: T) -> Any:
        """A future of ``obj``, on one worker: each other worker fetches it from there (or
        from one that has it by then) for its first task that needs it, and keeps it, so
        it is sent to each worker once. ``obj`` itself when the cluster cannot take it (it
        then goes with each item, scattered beside its task: :func:`_stream_on`).

        Not Dask's ``broadcast``: its scheduler copies the data to every worker in a loop
        that never ends when one of them dies meanwhile (``Scheduler.replicate``), which
        held a run whose worker was killed forever."""
        for _ in range(RESEND_LIMIT + 1):
            if self.gone is not None:
                break
            try:
                [future] = _scatter(self.client, [obj], self.timeout)
            except Exception as err:
                _raise_unless_from_the_cluster(err)
                self._stranded()
                continue
            self._shared[future.key] = obj  # sent again from here if the cluster loses it
            weakref.finalize(future, self._shared.pop, future.key, None)
            return future
        return obj

    def close(self, wait: bool = True) -> None:
        try:
            # a cluster that failed during the run does not fail the run's end
            with contextlib.suppress(Exception):
                self.client.close(timeout=self.timeout)
        finally:
            self.dask_log.close()  # (after the client's own last words)

    def describe(self) -> str:
        """For the findings' notes: where the run happened (and what the cluster lost)."""
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
        if self.resent:
            # (a task cancelled: a worker gone with its data or the data it needs)
            text += (
                f"; {_tasks(self.resent)} sent again after the cluster lost them (a worker "
                "gone with their data)"
            )
        if self.retried:
            # (a send refused, or a result that could not be fetched: on a loaded machine,
            # a connection that timed out; before, counted as lost, 3-5 in runs where
            # nothing was: ux62 MEDIUM 3)
            text += (
                f"; {_tasks(self.retried)} sent again after a reply timed out or failed (a "
                "slow or loaded cluster; nothing lost)"
            )
        if self.here:
            why = f": {self.gone}" if self.gone else ""
            text += f"; {_tasks(self.here)} computed here (the cluster could not take them{why})"
        return text

    def trouble(self) -> str | None:
        """One line for stderr where the cluster failed the run, naming the cause: the
        scheduler gone (and when), no worker left, the workers restarted for going over
        their memory limit (what to do), and the tasks computed in this process instead;
        None where nothing of that happened. Before, a run whose scheduler was killed, or
        whose workers the nannies kept restarting for memory (190 s against 80 s), ended
        as a local run with only a note in findings.json (ux62 MEDIUM 4)."""
        if self.gone != "the scheduler is gone":
            self._count_restarts()
        parts = []
        after = f" {self.gone_after_s:.0f} s into the run" if self.gone_after_s is not None else ""
        if self.gone == "the scheduler is gone":
            parts.append(f"the scheduler went away{after}")
        elif self.gone:
            parts.append(f"no worker was left{after}")
        if self._restarts:
            limit = (
                f" ({self._memory_limit / 2**20:.0f} MiB)" if self._memory_limit is not None else ""
            )
            parts.append(
                f"the workers were restarted {counted(self._restarts, 'time')} for going over "
                f"their memory limit{limit}: give them more (dask worker --memory-limit)"
            )
        if self.here:
            parts.append(f"{_tasks(self.here)} computed here instead, slower")
        return f"--scheduler {self.address}: {'; '.join(parts)}" if parts else None

    def _count_restarts(self) -> None:
        """Count the workers' restarts for going over their memory limit since the
        connection (the nannies' ``worker-restart-memory`` events, kept by the scheduler),
        while the scheduler answers."""
        client = self.client
        if client.status != "running":
            return
        with contextlib.suppress(Exception):  # (a scheduler that no longer answers)
            events = client.sync(
                client.scheduler.events, topic=MEMORY_RESTARTS, callback_timeout=self.timeout
            )
            self._restarts = sum(1 for when, _ in events if when >= self._began_wall)

    # -- a task the cluster lost -------------------------------------------------------------
    def _send(self, fn: Callable[[Any], Any], entry: _Sent) -> None:
        """Send ``entry``'s item as a task, trying again (at most :data:`RESEND_LIMIT`
        times in all for the item) when the cluster refuses it; else leave it to be
        computed here (``entry.future`` None)."""
        entry.future = None
        entry.fetches = 0
        while self.gone is None and entry.tries <= RESEND_LIMIT:
            try:
                entry.future = self._submit(fn, entry.item)
            except Exception as err:
                _raise_unless_from_the_cluster(err)
                entry.tries += 1
                self._stranded()
                continue
            if entry.tries:
                with self._lock:
                    if entry.lost:
                        self.resent += 1
                    else:
                        self.retried += 1
            return

    def _submit(self, fn: Callable[[Any], Any], item: Any) -> Any:
        """The task of ``item``: its large parts scattered beside it (so the task graph
        stays small however large they are), the rest packed into it."""
        client = self.client
        if not isinstance(item, tuple):
            [handle] = _scatter(client, [item], self.timeout)
            return client.submit(_on_worker, fn, handle, pure=False)
        # (a view of a memory-mapped array goes as a plain array)
        parts = [np.asarray(x) if isinstance(x, np.ndarray) else self._live(x) for x in item]
        big = [k for k, x in enumerate(parts) if self._heavy(x)]
        if big:
            sent = _scatter(client, [parts[k] for k in big], self.timeout)
            for k, handle in zip(big, sent, strict=True):
                if isinstance(parts[k], np.ndarray):
                    release(parts[k])  # rows of a memory-mapped archive: sent, let go
                parts[k] = handle
        # futures among the arguments are replaced by their values on the worker
        return client.submit(_apply, fn, *parts, pure=False)

    def _heavy(self, x: Any) -> bool:
        """True for a part of an item that should travel beside its task, not in it:
        an array, or any object (a dataclass holding a stretch of rows, a tuple of
        filters...) that takes :data:`INLINE_BYTES` or more pickled; never a part that
        holds futures (Dask replaces them by their values only in the task itself)."""
        if isinstance(x, np.ndarray):
            return x.nbytes >= INLINE_BYTES
        if x is None or isinstance(x, bool | int | float | complex | str | bytes):
            return False
        if self._holds_future(x):
            return False
        return _pickled_nbytes(x) >= INLINE_BYTES

    def _holds_future(self, x: Any) -> bool:
        if isinstance(x, self._future):
            return True
        if isinstance(x, list | tuple | set | frozenset):
            return any(self._holds_future(y) for y in x)
        if isinstance(x, dict):
            return any(self._holds_future(y) for y in x.values())
        return False

    def _live(self, x: Any) -> Any:
        """``x``, or for a handle of :meth:`scatter` whose data the cluster lost (every
        worker that held it gone) a new handle of the same object."""
        if not isinstance(x, self._future) or x.status == "finished":
            return x
        with self._lock:
            renewed = self._renewed.get(x.key)
            if renewed is not None and (
                not isinstance(renewed, self._future) or renewed.status == "finished"
            ):
                return renewed
            if x.key not in self._shared:
                return x  # not one of ours: as it is (computed here if lost for good)
            obj = self._shared[x.key]
        fresh = self.scatter(obj)
        with self._lock:
            self._renewed[x.key] = fresh
        return fresh

    def _outcome(self, fn: Callable[[Any], Any], entry: _Sent, pending: deque[_Sent]) -> Any:
        """The result of ``entry``'s task (the item computed here when the cluster cannot
        take it); the task's own exception raised unchanged. A finished task's result is
        fetched within :data:`SEND_TIMEOUT_S`, not :data:`WAIT_POLL_S`: a block's outputs
        (up to 80 MB) took longer than the poll on a loaded machine, and each such fetch
        given up sent the task again (4-5 times a run without a worker lost, 35 when
        the poll was 0.3 s) and, at the limit, computed it here, in this process."""
        while True:
            future = entry.future
            if future is None:
                return self._here(fn, entry.item)
            try:
                if not future.done():
                    self._wait([future], timeout=WAIT_POLL_S)  # TimeoutError while it runs
                # done: its result travels, which for a large block on a loaded machine can
                # take longer than the poll (given up then, it was sent again for nothing)
                return future.result(timeout=SEND_TIMEOUT_S)
            except Exception as err:
                if (
                    future.status == "finished"
                    and entry.fetches < FETCH_TRIES
                    and not self._stranded()
                ):
                    # computed, and its result on a worker: the wait timed out as it came,
                    # or fetching it failed (a connection that timed out): fetched again,
                    # not sent again as lost
                    entry.fetches += 1
                    if not isinstance(err, TimeoutError):
                        time.sleep(WAIT_POLL_S / 4)
                    continue
                if not future.done():
                    # still on its way (or the connection is down): while the cluster has a
                    # worker it will come; without one for a while it never will
                    if self._stranded():
                        self._lost(fn, entry, lost=False)
                    elif not isinstance(err, TimeoutError):  # (failed at once: not so often)
                        time.sleep(WAIT_POLL_S / 4)
                    continue
                if future.status == "error":
                    if _killed_worker(err):
                        raise UsageError(
                            f"--scheduler {self.address}: the workers that ran a task died "
                            f"({_said(err)})"
                        ) from err
                    raise  # the task's own exception: unchanged
                # cancelled (its inputs lost with a worker), or its result lost in transit
                self._lost(fn, entry)
                for other in pending:  # the others the same loss cancelled: at once
                    if other is not entry and other.future is not None and other.future.cancelled():
                        self._lost(fn, other)

    def _lost(self, fn: Callable[[Any], Any], entry: _Sent, lost: bool = True) -> None:
        """Send ``entry`` again (or compute it here): ``lost``, its task was cancelled or
        its result lost (counted in :attr:`resent` when sent), else it could not be had
        (counted in :attr:`retried`)."""
        entry.lost = entry.lost or lost
        if entry.future is not None:
            with contextlib.suppress(Exception):
                entry.future.release()
        entry.tries += 1
        self._send(fn, entry)

    def _stranded(self) -> bool:
        """True once the cluster has had no worker, or the scheduler no connection, for
        the connection timeout: its tasks are then computed here (``gone`` says why)."""
        if self.gone is not None:
            return True
        why = self._unusable()
        now = time.monotonic()
        with self._lock:
            if why is None:
                self._unusable_since = None
                return False
            if self._unusable_since is None:
                self._unusable_since = now
            # (a closed client gave up reconnecting after the timeout already)
            closed = self.client.status in ("closing", "closed")
            if now - self._unusable_since < self.timeout and not closed:
                return False
            self.gone = why
            self.gone_after_s = now - self._began
            self._count_restarts()
            return True

    def _unusable(self) -> str | None:
        """Why no task can run on the cluster now, or None when one can."""
        client = self.client
        if client.status != "running":
            return "the scheduler is gone"
        try:
            threads = client.nthreads(callback_timeout=self.timeout)
        except Exception:  # noqa: BLE001 - whatever broke, the scheduler did not answer
            return "the scheduler is gone"
        return None if threads else "no worker left"

    def _here(self, fn: Callable[[Any], Any], item: Any) -> Any:
        """``fn`` on ``item`` in this process, on a copy of what a worker would get (a
        task may write into its arguments, which are the caller's here)."""
        from distributed.protocol.pickle import dumps, loads

        if isinstance(item, tuple):
            value: Any = tuple(self._value(x) for x in item)
        else:
            value = self._value(item)
        own = loads(dumps(value))
        del value
        with self._lock:
            self.here += 1
        return fn(own)

    def _value(self, x: Any) -> Any:
        """What a part of an item stands for (a handle's object), in this process."""
        if isinstance(x, np.ndarray):
            return np.asarray(x)
        if not isinstance(x, self._future):
            return x
        if x.key in self._shared:
            return self._shared[x.key]
        try:
            return x.result(timeout=self.timeout)
        except Exception as err:  # noqa: BLE001 - lost, in whatever way
            raise UsageError(
                f"--scheduler {self.address}: the cluster lost what a task needs and it cannot "
                f"be computed here ({type(err).__name__})"
            ) from err

    def __repr__(self) -> str:
        return f"DaskExecutor({self.address!r})"


class _Sent:
    """An item of :func:`_stream_on` and its task. The item itself is kept (for a time
    block, a view of its memory-mapped rows: read again if it must be sent again), not
    the arrays that went."""

    __slots__ = ("fetches", "future", "item", "lost", "tries")

    def __init__(self, item: Any) -> None:
        self.item = item
        self.future: Any = None
        self.tries = 0
        self.fetches = 0  # waits for a computed result that did not bring it
        self.lost = False  # its task was cancelled, or its result lost, once


def _stream_on(
    executor: DaskExecutor, fn: Callable[[T], R], items: Iterable[T], window: int
) -> Iterator[R]:
    """``fn`` over ``items`` as tasks of ``executor``'s cluster, results in order, with at
    most ``window`` items sent and not yet handed over: an item is taken from ``items``
    (and its rows read, for a view of a memory-mapped archive) only when one of those is
    handed over, so the caller and the workers hold a few items each, not the archive.
    An item's large parts are scattered rather than packed into the task graph, which
    stays small however large they are; its futures (:meth:`DaskExecutor.scatter`) are
    passed on, so what they stand for is sent to a worker once, not with every item.
    A task the cluster loses is sent again, or computed here (:meth:`DaskExecutor._outcome`).
    Tasks still pending are cancelled when the caller stops early (an error, or a
    result it did not need)."""
    source = iter(items)
    pending: deque[_Sent] = deque()

    def send(count: int) -> None:
        for item in itertools.islice(source, count):
            entry = _Sent(item)
            executor._send(fn, entry)
            pending.append(entry)

    try:
        send(max(1, window))
        while pending:
            value = executor._outcome(fn, pending[0], pending)
            pending.popleft()
            send(1)
            yield value
    finally:
        for entry in pending:
            if entry.future is not None:
                with contextlib.suppress(Exception):  # (a cluster already gone)
                    entry.future.cancel()


def _scatter(client: Any, data: list[Any], timeout: float) -> list[Any]:
    """``client.scatter(data, hash=False)`` (one worker each, waiting at most ``timeout``
    for one), given up with :class:`TimeoutError` after :data:`SEND_TIMEOUT_S`: Dask's
    own call waits without limit for the scheduler's answer."""
    out: list[Any] = client.sync(
        client._scatter, data, hash=False, timeout=timeout, callback_timeout=SEND_TIMEOUT_S
    )
    return out
