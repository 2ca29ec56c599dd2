"""``--scheduler`` when the cluster misbehaves (``analyzer.parallel.DaskExecutor``): a
task lost with its worker is sent again, or computed here when the cluster cannot take it
(the same results either way), while a task's own exception comes back unchanged and is
never retried; a scheduler that accepts the connection and never answers is given up
(and a signal ends the wait); an item's large objects travel beside its task, not in the
task graph; an empty ``--scheduler`` is refused; what the cluster's failures still raise
is one line naming ``--scheduler``.

The lost worker is made deterministic: the task kills its own worker process the first
time it runs (a marker file says it did), on a cluster of one worker, so the item's
scattered rows (and the shared model) are lost with it and Dask cancels the task."""

from __future__ import annotations

import dataclasses
import os
import signal
import socket
import sys
import threading
import time
import types
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")
cloudpickle = pytest.importorskip("cloudpickle")

import analyzer.parallel  # noqa: E402
import analyzer.parallel_dask  # noqa: E402
from analyzer.cli import main  # noqa: E402
from analyzer.errors import DetectorError, UsageError  # noqa: E402
from analyzer.parallel import INLINE_BYTES, DaskExecutor  # noqa: E402
from analyzer.pipeline import RunOptions, analyze  # noqa: E402
from analyzer.watch import EXIT_INTERRUPTED, WatchSettings, watch  # noqa: E402

SAMPLES = Path(__file__).resolve().parents[2] / "samples"
SAMPLE = SAMPLES / "building_additive.mcap"
BLAS_ENV = {v: "1" for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}

# the workers cannot import this test module: ship its functions by value
cloudpickle.register_pickle_by_value(sys.modules[__name__])


@pytest.fixture(scope="module")
def cluster() -> Iterator[Any]:
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0", env=BLAS_ENV
    ) as c:
        yield c


@pytest.fixture(scope="module")
def lone() -> Iterator[Any]:
    """One worker process (its nanny starts another when it dies): a task's data and
    the shared model are all on it."""
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0", env=BLAS_ENV
    ) as c:
        yield c


def _within(seconds: float, call: Callable[[], Any]) -> Any:
    """``call()``, failing the test when it has not returned after ``seconds`` (before
    the fixes these calls never returned)."""
    out: list[Any] = []

    def run() -> None:
        try:
            out.append(("ok", call()))
        except BaseException as err:  # handed to the test's thread
            out.append(("error", err))

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(seconds)
    assert out, f"still waiting after {seconds} s"
    kind, value = out[0]
    if kind == "error":
        raise value
    return value


def _weighted_once(item: tuple[Any, ...]) -> float:
    """A time block's task (a shared model, the block's rows, its index) that kills its
    worker the first time it runs on one (never in the test's own process)."""
    shared, rows, k, marker, home = item
    if os.getpid() != home and not os.path.exists(marker):
        Path(marker).touch()
        os.kill(os.getpid(), signal.SIGKILL)
    return float(rows @ shared[: rows.shape[0]]) + k


def _weighted(item: tuple[Any, ...]) -> float:
    shared, rows, k = item[:3]
    return float(rows @ shared[: rows.shape[0]]) + k


def _counted(item: tuple[int, str]) -> int:
    """Appends a line to ``log`` per run, and fails on item 3 (the task's own error)."""
    k, log = item
    with open(log, "a") as f:
        f.write(f"{k}\n")
    if k == 3:
        raise DetectorError(f"cannot fit block {k}")
    return k


def _comm_closed_by_the_task(item: tuple[int, int]) -> int:
    """A task whose own exception is one of Dask's connection errors."""
    from distributed.comm.core import CommClosedError

    if item[0] == 1:
        raise CommClosedError("the task's own connection closed")
    return item[0]


def test_a_task_lost_with_its_worker_is_sent_again(lone: Any, tmp_path: Path) -> None:
    """The first task kills its worker: its rows and the shared model go with it and
    Dask cancels it ("lost dependencies", before: FutureCancelledError out of the run);
    it is sent again with both, and the results are the local ones."""
    ex = DaskExecutor(lone.scheduler_address)
    try:
        shared = np.linspace(0.0, 1.0, 40_000)
        rows = np.arange(30_000.0)
        spans = [(0, 20_000), (5_000, 30_000), (10_000, 30_000), (0, 9_000)]
        handle = ex.scatter(shared)
        marker, home = str(tmp_path / "killed"), os.getpid()
        items = ((handle, rows[a:b], k, marker, home) for k, (a, b) in enumerate(spans))
        got = _within(120, lambda: list(ex.imap(_weighted_once, items)))
        want = [_weighted((shared, rows[a:b], k)) for k, (a, b) in enumerate(spans)]
        assert Path(marker).exists()  # a worker did die
        assert got == pytest.approx(want, rel=1e-12)
        assert ex.resent >= 1 and ex.gone is None
        assert "sent again after the cluster lost them" in ex.describe()
    finally:
        ex.close()


def test_the_task_s_own_error_is_not_sent_again(cluster: Any, tmp_path: Path) -> None:
    """An exception raised by the task itself comes back with its type and message and
    the task ran once, even when it is one of Dask's connection errors."""
    from distributed.comm.core import CommClosedError

    ex = DaskExecutor(cluster.scheduler_address)
    try:
        log = tmp_path / "runs.txt"
        with pytest.raises(DetectorError, match="cannot fit block 3"):
            _within(60, lambda: list(ex.imap(_counted, [(k, str(log)) for k in range(6)])))
        assert log.read_text().split().count("3") == 1
        with pytest.raises(CommClosedError, match="the task's own connection closed"):
            _within(60, lambda: ex.map(_comm_closed_by_the_task, [(0, 0), (1, 0), (2, 0)]))
        assert getattr(ex, "resent", 0) == 0 and getattr(ex, "here", 0) == 0
        assert "sent again" not in ex.describe() and "computed here" not in ex.describe()
    finally:
        ex.close()


def _items() -> list[tuple[Any, ...]]:
    shared = np.linspace(0.0, 1.0, 40_000)
    big = [(shared, np.full(20_000, float(k)), k) for k in range(4)]  # scattered rows
    return [*big, (shared[:3], np.ones(3), 9)]  # and one that goes with its task


def test_items_are_computed_here_when_no_worker_is_left(
    in_process: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every worker gone (before: the tasks waited for one forever): after the
    connection timeout the items are computed in this process, with the same results."""
    monkeypatch.setattr(analyzer.parallel_dask, "WAIT_POLL_S", 0.2, raising=False)
    ex = DaskExecutor(in_process.scheduler_address, timeout=1.0)
    try:
        in_process.scale(0)
        deadline = time.monotonic() + 20
        while ex.client.nthreads() and time.monotonic() < deadline:
            time.sleep(0.05)
        items = _items()
        got = _within(60, lambda: ex.map(_weighted, items))
        assert got == [_weighted(x) for x in items]
        assert ex.here == len(items) and ex.gone == "no worker left"
        assert "5 tasks computed here (the cluster could not take them: no worker left)" in (
            ex.describe()
        )
    finally:
        ex.close()


def test_items_are_computed_here_when_the_scheduler_is_gone(
    in_process: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(analyzer.parallel_dask, "WAIT_POLL_S", 0.2, raising=False)
    ex = DaskExecutor(in_process.scheduler_address, timeout=1.0)
    try:
        in_process.close()
        items = _items()
        got = _within(60, lambda: ex.map(_weighted, items))
        assert got == [_weighted(x) for x in items]
        assert ex.here == len(items) and ex.gone == "the scheduler is gone"
        assert "computed here (the cluster could not take them: the scheduler is gone)" in (
            ex.describe()
        )
    finally:
        ex.close()


def test_a_task_computed_here_gets_its_own_copy(
    in_process: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """As on a worker, a task computed here may write into its arguments: the caller's
    arrays (a memory-mapped archive's rows) and the shared model stay as they were."""
    monkeypatch.setattr(analyzer.parallel_dask, "WAIT_POLL_S", 0.2, raising=False)
    ex = DaskExecutor(in_process.scheduler_address, timeout=1.0)
    try:
        shared = np.ones(20_000)
        handle = ex.scatter(shared)
        in_process.close()
        rows = np.arange(20_000.0)
        got = _within(60, lambda: ex.map(_scribble, [(handle, rows), (handle, rows)]))
        assert got == [float(np.arange(20_000.0).sum())] * 2
        assert ex.here == 2
        np.testing.assert_array_equal(rows, np.arange(20_000.0))
        np.testing.assert_array_equal(shared, np.ones(20_000))
    finally:
        ex.close()


def _scribble(item: tuple[np.ndarray, np.ndarray]) -> float:
    shared, rows = item
    out = float(rows @ shared)
    rows[:] = -1.0
    shared[:] = 0.0
    return out


def test_killed_workers_are_one_line_naming_scheduler(
    in_process: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Dask gave up a task whose workers died running it (KilledWorker): not computed
    here (it may be what kills them), a UsageError naming --scheduler."""
    from distributed.scheduler import KilledWorker

    ex = DaskExecutor(in_process.scheduler_address)
    try:
        worker = types.SimpleNamespace(address="tcp://127.0.0.1:1")
        killed = KilledWorker("_apply-1", worker, 3)

        class Dead:  # a future whose task Dask gave up
            key = "_apply-1"
            status = "error"

            def result(self, timeout: float | None = None) -> Any:
                raise killed

            def done(self) -> bool:
                return True

            def cancel(self) -> bool:
                return True

        monkeypatch.setattr(ex, "_submit", lambda fn, item: Dead())
        with pytest.raises(UsageError, match=r"^--scheduler .*: the workers that ran a task died"):
            ex.map(_weighted, _items()[:1])
        assert ex.here == 0
    finally:
        ex.close()


@dataclasses.dataclass(frozen=True)
class _Stretch:
    """Like the detection filter's calibration segment: arrays inside an object."""

    rows: np.ndarray
    filters: tuple[np.ndarray, ...]
    start: int


def _stretch_sum(item: tuple[_Stretch, float]) -> float:
    stretch, scale = item
    return scale * (
        float(stretch.rows[stretch.start :].sum()) + sum(float(f.sum()) for f in stretch.filters)
    )


def test_large_objects_in_an_item_travel_beside_the_task(
    cluster: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An item's part that is an object holding arrays (the detection filter's
    calibration stretch: 10 MB for 10 minutes of 16 channels) is scattered like a large
    array, so Dask does not warn of a large task graph; small ones go with the task."""
    import dask

    ex = DaskExecutor(cluster.scheduler_address)
    try:
        stretch = _Stretch(np.arange(400_000.0), tuple(np.full(100_000, k) for k in range(4)), 7)
        items = [(stretch, 1.0), (stretch, 2.0), (_Stretch(np.ones(4), (), 0), 3.0)]
        threshold = {"distributed.admin.large-graph-warning-threshold": "1MB"}
        with dask.config.set(threshold), warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always")
            got = ex.map(_stretch_sum, items)
        assert got == [_stretch_sum(x) for x in items]
        large = [str(w.message) for w in seen if "large graph" in str(w.message)]
        assert not large, large
        assert analyzer.parallel._pickled_nbytes(stretch) > 6_000_000  # counted, not copied
        assert not ex._heavy(np.ones(4)) and ex._heavy(np.ones(INLINE_BYTES))
        assert not ex._heavy((ex.scatter(np.ones(4)), 1))  # (futures are resolved in the task)
    finally:
        ex.close()


def test_detection_filter_sends_no_large_graph(cluster: Any) -> None:
    """The detection filter's calibration tasks (its segments, 0.35-0.4 MB on the sample,
    10 MB on 10 minutes of 16 channels) used to go inside the task graph: with Dask's
    warning threshold lowered to 200 kB they warned; the findings are the serial run's."""
    import dask

    options = RunOptions(detectors=["detection_filter"])
    serial = analyze([SAMPLE], options)
    threshold = {"distributed.admin.large-graph-warning-threshold": "200kB"}
    remote = RunOptions(detectors=["detection_filter"], scheduler=cluster.scheduler_address)
    with dask.config.set(threshold), warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        on_cluster = analyze([SAMPLE], remote)
    large = [str(w.message) for w in seen if "large graph" in str(w.message)]
    assert not large, large
    key = [(f.channel, str(f.type), round(f.onset_s, 6)) for f in serial.findings]
    assert [(f.channel, str(f.type), round(f.onset_s, 6)) for f in on_cluster.findings] == key


class _Silent:
    """A TCP server that accepts connections and never says anything."""

    def __init__(self) -> None:
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.sock.settimeout(0.2)
        self.held: list[socket.socket] = []
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    @property
    def address(self) -> str:
        return f"tcp://127.0.0.1:{self.sock.getsockname()[1]}"

    def _serve(self) -> None:
        while not self.stop.is_set():
            try:
                conn, _ = self.sock.accept()
            except OSError:
                continue
            self.held.append(conn)

    def close(self) -> None:
        self.stop.set()
        self.thread.join(2)
        for conn in self.held:
            conn.close()
        self.sock.close()


@pytest.fixture
def silent() -> Iterator[_Silent]:
    server = _Silent()
    yield server
    server.close()


def test_a_silent_scheduler_is_exit_2_in_one_line(
    silent: _Silent,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """It accepts the connection and never answers (before: run waited forever)."""
    monkeypatch.setattr(analyzer.parallel_dask, "CONNECT_TIMEOUT_S", 1.0)
    out = tmp_path / "o"
    began = time.monotonic()
    argv = ["run", str(SAMPLE), "--out", str(out), "--scheduler", silent.address]
    code = _within(30, lambda: main(argv))
    assert time.monotonic() - began < 15
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, err
    assert lines[0] == (
        f"analyzer: error: --scheduler {silent.address}: cannot connect (no answer within 1 s)"
    )
    assert not out.exists()


def test_stop_ends_the_wait_for_a_silent_scheduler(silent: _Silent, tmp_path: Path) -> None:
    """The watcher's signal handler only sets ``stop``: the connection's wait ends on
    it (before: SIGTERM was ignored until the scheduler answered, i.e. never)."""
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    settings = WatchSettings(inbox=inbox, reports=tmp_path / "reports", once=True)
    stop = threading.Event()
    threading.Timer(0.5, stop.set).start()
    began = time.monotonic()
    code = _within(30, lambda: watch(settings, RunOptions(scheduler=silent.address), stop=stop))
    assert code == EXIT_INTERRUPTED and time.monotonic() - began < 5

    stop = threading.Event()
    threading.Timer(0.5, stop.set).start()
    began = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        _within(30, lambda: DaskExecutor(silent.address, timeout=60.0, stop=stop))
    assert time.monotonic() - began < 5


@pytest.mark.parametrize("command", ["run", "watch"])
def test_an_empty_scheduler_is_a_usage_error(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: ``--scheduler ""`` ran locally without a word."""
    if command == "run":
        argv = ["run", str(SAMPLE), "--out", str(tmp_path / "o")]
    else:
        (tmp_path / "inbox").mkdir()
        argv = ["watch", str(tmp_path / "inbox"), "--out", str(tmp_path / "o"), "--once"]
    for empty in ("", "  "):
        assert main([*argv, "--scheduler", empty]) == 2
        err = capsys.readouterr().err
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert lines == [
            "analyzer: error: --scheduler: an empty address; expected one like tcp://HOST:PORT"
        ], err
    assert not (tmp_path / "o").exists()
    with pytest.raises(UsageError, match="--scheduler: an empty address"):
        analyzer.parallel.make_executor(None, "")


def _raising(error: BaseException) -> Callable[..., Any]:
    def run(*args: Any, **kwargs: Any) -> Any:
        raise error

    return run


@pytest.mark.parametrize(
    "error",
    [
        "CommClosedError('in <TCP (closed) ConnectionPool.scatter local=tcp://127.0.0.1:1 "
        "remote=tcp://127.0.0.1:2>: Stream is closed')",
        "FutureCancelledError('_apply-1', reason='lost dependencies')",
        "StreamClosedError()",
    ],
)
def test_what_the_cluster_still_raises_is_one_line_naming_scheduler(
    error: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Before: 'internal error: FutureCancelledError...', or a CommClosedError (an
    OSError) in the file system's words ('analyzer: error: in <TCP (closed)...')."""
    from distributed.client import FutureCancelledError  # noqa: F401 - for eval
    from distributed.comm.core import CommClosedError  # noqa: F401 - for eval
    from tornado.iostream import StreamClosedError  # noqa: F401 - for eval

    err = eval(error)
    monkeypatch.setattr("analyzer.pipeline.run", _raising(err))
    address = "tcp://127.0.0.1:8786"
    argv = ["run", str(SAMPLE), "--out", str(tmp_path / "o"), "--scheduler", address]
    assert main(argv) == 2
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(lines) == 1
    assert lines[0].startswith(
        f"analyzer: error: --scheduler {address}: the cluster failed during the run "
        f"({type(err).__name__}"
    ), lines[0]


def test_the_task_s_own_errors_are_not_named_as_the_cluster_s(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """What is not Dask's keeps its own line (a bug stays an internal error, a file the
    system refused its file system's words), with --scheduler or without."""
    address = "tcp://127.0.0.1:8786"
    argv = ["run", str(SAMPLE), "--out", str(tmp_path / "o"), "--scheduler", address]
    monkeypatch.setattr("analyzer.pipeline.run", _raising(ValueError("a bug")))
    assert main(argv) == 2
    assert "internal error: ValueError: a bug" in capsys.readouterr().err
    refused = PermissionError(13, "Permission denied", str(tmp_path / "o"))
    monkeypatch.setattr("analyzer.pipeline.run", _raising(refused))
    assert main(argv) == 2
    assert capsys.readouterr().err.strip() == (
        f"analyzer: error: {tmp_path / 'o'}: Permission denied"
    )


def _block_outputs(k: int) -> np.ndarray:
    """A time block's outputs (8 MB): a result that takes a while to fetch."""
    return np.full(1_000_000, float(k))


def test_a_finished_task_s_result_is_fetched_not_sent_again(
    cluster: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A finished task whose result takes longer to fetch than the poll for its end
    (a block's 80 MB of outputs on a loaded machine, against 2 s; here any fetch, against
    a poll of a microsecond) is fetched, not counted as lost: before, each such fetch
    given up sent the task again, and at the limit computed it in the run's process
    (what raised the run's memory with ``--scheduler``)."""
    monkeypatch.setattr(analyzer.parallel_dask, "WAIT_POLL_S", 1e-6)
    ex = DaskExecutor(cluster.scheduler_address)
    try:
        got = _within(120, lambda: list(ex.imap(_block_outputs, range(4))))
        assert [float(x[0]) for x in got] == [0.0, 1.0, 2.0, 3.0]
        assert (ex.resent, ex.here) == (0, 0), ex.describe()
    finally:
        ex.close()
