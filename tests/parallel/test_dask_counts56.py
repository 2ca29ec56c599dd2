"""What ``--scheduler`` counts and says of the cluster's failures (ux62 MEDIUM 3 and 4):
a result that could not be fetched once is fetched again, not counted as a task "sent
again after the cluster lost them" (3-5 in runs where nothing was lost); a task cancelled
is; and a run the cluster failed (the scheduler gone, the workers restarted for memory)
has one line naming the cause, which ``run`` warns of on stderr."""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from typing import Any

import pytest

distributed = pytest.importorskip("distributed")

import analyzer.parallel_dask  # noqa: E402
from analyzer.errors import UsageError  # noqa: E402
from analyzer.parallel import DaskExecutor  # noqa: E402


class _Future:
    """A stand-in for a Dask future: ``script`` says what each ``result()`` call does
    (an exception raised, or a value returned), ``status`` what the future says then."""

    def __init__(self, script: list[Any], status: str) -> None:
        self.script = list(script)
        self.status = status
        self.key = object()

    def result(self, timeout: float | None = None) -> Any:
        step = self.script.pop(0)
        if isinstance(step, BaseException):
            raise step
        return step

    def done(self) -> bool:
        return self.status in ("finished", "error", "cancelled")

    def cancelled(self) -> bool:
        return self.status == "cancelled"

    def release(self) -> None:
        pass


class _Client:
    status = "running"

    def nthreads(self, callback_timeout: float | None = None) -> dict[str, int]:
        return {"tcp://w": 1}


def _executor(futures: list[_Future]) -> DaskExecutor:
    """A :class:`DaskExecutor` without a cluster: its tasks are ``futures``, in turn."""
    ex = DaskExecutor.__new__(DaskExecutor)
    ex.address, ex.timeout, ex.client = "tcp://stand-in:8786", 1.0, _Client()
    ex.resent, ex.here, ex.gone = 0, 0, None
    ex.retried = 0
    ex._future, ex._shared, ex._renewed = _Future, {}, {}
    ex._unusable_since, ex._lock = None, threading.Lock()
    queue = list(futures)
    ex._submit = lambda fn, item: queue.pop(0)  # type: ignore[method-assign]
    ex.n_workers, ex.workers, ex.blas_threads = 1, 1, {}
    return ex


def test_a_result_that_failed_to_arrive_once_is_fetched_again_not_counted_lost() -> None:
    """The task was computed (``finished``), but fetching its result failed once (a
    connection that timed out on a loaded machine): before, it was sent again and counted
    as lost by the cluster."""
    first = _Future([OSError("Timed out trying to connect"), 42.0], "finished")
    spare = _Future([42.0], "finished")
    ex = _executor([first, spare])
    assert ex.map(lambda x: x, [1]) == [42.0]
    assert ex.resent == 0 and not first.script and spare.script == [42.0]
    assert "sent again" not in ex.describe()


def test_a_cancelled_task_is_counted_lost_and_a_refused_send_as_slow() -> None:
    """A task Dask cancelled (its data lost with a worker) is sent again and counted
    lost; a send the cluster refused (timed out) and then took is counted apart, in
    words that say nothing was lost."""
    cancelled = _Future([distributed.client.FutureCancelledError("k", "lost")], "cancelled")
    again = _Future([7.0], "finished")
    ex = _executor([cancelled, again])
    assert ex.map(lambda x: x, [1]) == [7.0]
    assert (ex.resent, ex.retried) == (1, 0)
    assert "1 task sent again after the cluster lost them (a worker gone with their data)" in (
        ex.describe()
    )
    calls = iter([TimeoutError("scatter timed out"), _Future([3.0], "finished")])

    def refused_once(fn: Any, item: Any) -> Any:
        step = next(calls)
        if isinstance(step, BaseException):
            raise step
        return step

    slow = _executor([])
    slow._submit = refused_once  # type: ignore[method-assign]
    assert slow.map(lambda x: x, [1]) == [3.0]
    assert (slow.resent, slow.retried) == (0, 1)
    assert "1 task sent again after a reply timed out or failed (a slow or loaded cluster; " in (
        slow.describe()
    )
    assert "lost them" not in slow.describe()


def test_an_undisturbed_cluster_has_no_trouble_and_memory_restarts_are_named(
    in_process: Any,
) -> None:
    """Nothing failed: no line. Then the scheduler holds two of the nannies' "restarted
    for memory" events (as a nanny logs them): the line names them and what to do."""
    ex = DaskExecutor(in_process.scheduler_address, timeout=5.0)
    try:
        assert ex.map(lambda x: x + 1, [1, 2, 3]) == [2, 3, 4]
        assert ex.trouble() is None and ex.resent == 0
        for _ in range(2):
            ex.client.log_event(analyzer.parallel_dask.MEMORY_RESTARTS, {"worker": "w"})
        deadline = time.monotonic() + 10
        while ex.trouble() is None and time.monotonic() < deadline:
            time.sleep(0.1)
        line = ex.trouble()
        assert line is not None and line.startswith(f"--scheduler {ex.address}: ")
        assert "the workers were restarted 2 times for going over their memory limit" in line
        assert "give them more (dask worker --memory-limit)" in line
    finally:
        ex.close()


def test_a_scheduler_gone_mid_run_is_named_with_the_tasks_run_here(
    in_process: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(analyzer.parallel_dask, "WAIT_POLL_S", 0.2, raising=False)
    ex = DaskExecutor(in_process.scheduler_address, timeout=1.0)
    try:
        in_process.close()
        assert ex.map(lambda x: 2 * x, [1, 2]) == [2, 4]
        line = ex.trouble()
        assert line is not None
        assert line.startswith(f"--scheduler {ex.address}: the scheduler went away ")
        assert " s into the run; 2 tasks computed here instead, slower" in line
    finally:
        ex.close()


def test_a_service_of_another_protocol_is_said_without_numpy_s_words() -> None:
    """An HTTP server at the address: Dask read "HTTP/1.1" as a frame count and the line
    ended "Unable to allocate 3.07 EiB for an array with shape ... and data type uint8"."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(4)
    port = server.getsockname()[1]

    def answer() -> None:
        while True:
            try:
                conn, _ = server.accept()
            except OSError:  # (closed: the test is over)
                return
            with contextlib.suppress(OSError):
                conn.recv(65536)
                conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")
            conn.close()

    threading.Thread(target=answer, daemon=True).start()
    address = f"tcp://127.0.0.1:{port}"
    try:
        with pytest.raises(UsageError) as caught:
            DaskExecutor(address, timeout=5.0)
    finally:
        server.close()
    assert str(caught.value) == (
        f"--scheduler {address}: cannot connect (no Dask scheduler answered there: the "
        "service there speaks another protocol)"
    )
