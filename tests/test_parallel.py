"""Executors (analyzer.parallel), RunContext.map, and ``--jobs N`` giving the serial run's
findings. The Dask back end is checked against a real local cluster in
tests/cli/test_scheduler.py."""

from __future__ import annotations

import pickle
import threading
from pathlib import Path

import numpy as np
import pytest

from analyzer import paging
from analyzer.detectors import REGISTRY, Dataset, RunContext, detector_class
from analyzer.errors import AnalyzerError, DetectorError, UsageError
from analyzer.parallel import (
    SerialExecutor,
    ThreadExecutor,
    make_executor,
)
from analyzer.pipeline import RunOptions, analyze

SAMPLE = Path(__file__).resolve().parents[1] / "samples" / "building_additive.mcap"


def _square_sum(x: np.ndarray) -> float:
    return float(np.sum(x * x))


def _fail_on_three(x: int) -> int:
    if x == 3:
        raise DetectorError(f"cannot fit block {x}")
    return x


def _nested(args: tuple[ThreadExecutor, int]) -> list[int]:
    pool, k = args
    return pool.map(_fail_on_three, [10 * k + i for i in range(4)])


@pytest.fixture
def pool():
    ex = ThreadExecutor(2)
    yield ex
    ex.close()


# -- executors ---------------------------------------------------------------------------


@pytest.mark.parametrize("make", [SerialExecutor, lambda: ThreadExecutor(3)])
def test_map_keeps_input_order(make):
    ex = make()
    try:
        rng = np.random.default_rng(0)
        items = [rng.standard_normal(1000 + 37 * k) for k in range(20)]
        assert ex.map(_square_sum, items) == [_square_sum(x) for x in items]
        assert ex.map(_square_sum, []) == []
    finally:
        ex.close()


@pytest.mark.parametrize("make", [SerialExecutor, lambda: ThreadExecutor(2)])
def test_task_errors_keep_type_and_message(make):
    ex = make()
    try:
        with pytest.raises(DetectorError, match="cannot fit block 3"):
            ex.map(_fail_on_three, list(range(6)))
        handle = ex.submit(_fail_on_three, 3)
        with pytest.raises(DetectorError, match="cannot fit block 3"):
            handle.result()
        assert ex.submit(_fail_on_three, 4).result() == 4
    finally:
        ex.close()


def test_serial_submit_runs_lazily_in_order():
    seen: list[int] = []
    ex = SerialExecutor()
    handles = [ex.submit(seen.append, k) for k in range(3)]
    assert seen == []
    assert handles[1].cancel()
    handles[0].result()
    handles[2].result()
    assert seen == [0, 2]


def test_nested_map_on_a_full_pool_does_not_deadlock(pool):
    # every thread of the pool runs a task that maps again on the same pool
    handles = [pool.submit(_nested, (pool, k)) for k in (1, 2)]
    assert handles[0].result() == [10, 11, 12, 13]
    assert handles[1].result() == [20, 21, 22, 23]
    with pytest.raises(DetectorError, match="cannot fit block 3"):
        pool.map(_nested, [(pool, 0), (pool, 1)])


def test_thread_executor_uses_several_threads(pool):
    names = set(pool.map(lambda _: threading.current_thread().name, list(range(50))))
    assert any(n.startswith("analyzer") for n in names)


def test_make_executor():
    assert isinstance(make_executor(None, None), SerialExecutor)
    assert isinstance(make_executor(1, None), SerialExecutor)
    ex = make_executor(3, None)
    try:
        assert isinstance(ex, ThreadExecutor)
        assert ex.workers == 3
    finally:
        ex.close()
    with pytest.raises(UsageError, match="--jobs"):
        ThreadExecutor(0)


def test_bad_scheduler_address_is_a_usage_error():
    pytest.importorskip("distributed")
    with pytest.raises(UsageError, match=r"--scheduler nonsense: expected an address like tcp"):
        make_executor(None, "nonsense")


# -- RunContext ----------------------------------------------------------------------------


def test_run_context_map_is_serial_without_executor():
    ctx = RunContext(false_alarm_rate=1e-4, config={"group": []})
    assert ctx.executor is None and ctx.jobs == 1
    assert ctx.map(_fail_on_three, [1, 2]) == [1, 2]
    with pytest.raises(DetectorError, match="block 3"):
        ctx.map(_fail_on_three, [3])


def test_run_context_map_uses_its_executor(pool):
    calls = []

    class Spy:
        def map(self, fn, items):
            calls.append(len(items))
            return pool.map(fn, items)

    ctx = RunContext(jobs=2, executor=Spy())
    items = [np.arange(k, dtype=float) for k in range(5)]
    assert ctx.map(_square_sum, items) == [_square_sum(x) for x in items]
    assert calls == [5]


def test_map_shared_on_a_cluster_runs_on_the_local_threads(two_thread_pool):
    """Items over this process's memory are never shipped to a cluster: they run on the
    run's own threads (``local``) when it has some, else one after the other in the
    calling thread; with shared memory, on the executor itself."""

    def where(x: int) -> tuple[int, str]:
        return x, threading.current_thread().name

    cluster = two_thread_pool(False)
    local = ThreadExecutor(2)
    try:
        got = RunContext(jobs=4, executor=cluster, local=local).map_shared(where, list(range(8)))
        assert [x for x, _ in got] == list(range(8)) and cluster.calls == 0
        assert any(name.startswith("analyzer-pool") for _, name in got)
        alone = RunContext(jobs=4, executor=cluster).map_shared(where, [1, 2])
        assert [name for _, name in alone] == [threading.current_thread().name] * 2
        threads = two_thread_pool(True)
        RunContext(jobs=2, executor=threads, local=local).map_shared(where, [1, 2])
        assert threads.calls == 1
    finally:
        local.close()


def test_run_context_and_error_pickle():
    ctx = RunContext(false_alarm_rate=1e-4, config={"group": [{"name": "g"}]}, jobs=2)
    back = pickle.loads(pickle.dumps(ctx))
    assert back.false_alarm_rate == 1e-4 and back.config == ctx.config and back.jobs == 2
    err = pickle.loads(pickle.dumps(DetectorError("singular model")))
    assert type(err) is DetectorError and str(err) == "singular model"
    assert isinstance(err, AnalyzerError)


# -- detectors as tasks ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def serial_run():
    return analyze([SAMPLE], RunOptions())


def _same(a: object, b: object, where: str = "") -> None:
    """``a`` and ``b`` equal to the bit: dataclasses field by field, containers element by
    element, arrays with NaN where NaN is (what a pickle round trip must keep)."""
    import dataclasses

    assert type(a) is type(b), where
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        for f in dataclasses.fields(a):
            _same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), where
        for k in a:
            _same(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, list | tuple):
        assert isinstance(b, list | tuple) and len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _same(x, y, f"{where}[{i}]")
    elif isinstance(a, np.ndarray):
        np.testing.assert_array_equal(a, b, err_msg=where)
    elif isinstance(a, float) and np.isnan(a):
        assert isinstance(b, float) and np.isnan(b), where
    else:
        assert a == b, where


@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_detectors_and_fitted_models_pickle(serial_run, name):
    """What a Dask worker receives (detector, data) and sends back (result): each
    unpickled, the detector runs the unpickled model on the unpickled data to the same
    result as the originals, and the result itself comes back equal (test audit ux65:
    this checked only that the round trips did not raise, and passed over a detector the
    sample does not suit without a word). A detector the sample's own run used must
    fit; any other is skipped with its reason."""
    a = serial_run
    data = Dataset(a.values, a.analyzed, a.rate_hz, a.train)
    ctx = RunContext(explicit=True)
    det = detector_class(name)()
    reason = det.applicable(data, ctx)
    if reason is not None:
        assert name not in [r.detector for r in a.results], reason
        pytest.skip(f"{name} does not suit the sample: {reason}")
    model = det.fit(data, ctx)
    result = det.run(model, data, ctx)
    back = pickle.loads(pickle.dumps((det, model, data, ctx)))
    _same(back[2], data, "data")
    again = back[0].run(back[1], back[2], back[3])
    _same(again, result, name)
    _same(pickle.loads(pickle.dumps(result)), result, name)


def test_jobs_gives_the_serial_findings(serial_run, findings_of, same_findings):
    serial = serial_run
    assert serial.findings, "the sample has an additive fault on s4"
    par = analyze([SAMPLE], RunOptions(jobs=2))
    same_findings(findings_of(par), findings_of(serial))
    assert [r.detector for r in par.results] == [r.detector for r in serial.results]
    assert par.skipped == serial.skipped
    for rs, rp in zip(serial.results, par.results, strict=True):
        for c, res in rs.residuals.items():
            scale = float(np.nanmax(np.abs(res)))
            assert float(np.nanmax(np.abs(res - rp.residuals[c]))) <= 1e-9 * scale


def test_jobs_keeps_explicit_detector_errors():
    # detection_filter/equivalent_model need more channels than one: the first
    # explicitly named detector that cannot run is the error, as in the serial loop
    for jobs in (None, 2):
        with pytest.raises(DetectorError, match=r"^ar_kalman_bank: needs at least 2 channels"):
            analyze(
                [SAMPLE],
                RunOptions(
                    jobs=jobs,
                    channels=["/s4.data"],
                    detectors=["ar_kalman_bank", "equivalent_model"],
                ),
            )


@pytest.mark.parametrize("jobs", [1, 2])
def test_progress_is_reported_for_reading_detection_and_tests(jobs):
    """The long stages report their progress: reading (by input bytes), alignment, the
    detectors (on threads each fit, then each run), the residual tests; each stage's
    fractions rise to 1."""
    seen: list[tuple[str, float]] = []
    analyze([SAMPLE], RunOptions(jobs=jobs, progress=lambda s, f: seen.append((s, f))))
    assert ("read", 1.0) in seen and ("align", 1.0) in seen
    # one after the other (a detector may report its own steps among the detectors')
    first = {s: next(i for i, (t, _) in enumerate(seen) if t == s) for s, _ in seen}
    last = {s: max(i for i, (t, _) in enumerate(seen) if t == s) for s, _ in seen}
    assert last["read"] < first["align"] <= last["align"] < first["detect"]
    assert last["detect"] < first["tests"]
    for stage in ("read", "detect", "tests"):
        fractions = [f for s, f in seen if s == stage]
        assert fractions and fractions[-1] == 1.0, stage
        assert all(b >= a for a, b in zip(fractions, fractions[1:], strict=False)), stage
    # three detectors, each run's end said (their steps advance detect in between)
    ended = [s for s, _ in seen if s == "detect" and s.detail.endswith(" run: done")]
    assert len(ended) == 3


@pytest.mark.parametrize(("jobs", "row_files"), [(1, True), (2, True), (2, False)])
def test_long_archive_paths_give_the_in_memory_findings(
    serial_run, findings_of, same_findings, tmp_path, monkeypatch, jobs, row_files
):
    """A long archive (here: any archive, with the size limits lowered) is memory-mapped,
    read chunk by chunk with its pages released, and every detector's signals are moved to
    files as it finishes: the findings and residuals of the in-memory run. The alarm
    searches' scratch rows are files too (``row_files``: a record longer than
    ``MEMORY_ROW_BYTES`` allows in memory) or arrays in memory (the 4-hour case)."""
    import analyzer.detectors.base as base
    import analyzer.pipeline as pl

    monkeypatch.setattr(pl, "MATERIALIZE_IN_MEMORY", 1000)
    if row_files:
        monkeypatch.setattr(paging, "MEMORY_ROW_BYTES", 0)
    mapped: list[str] = []
    original = paging.buffer

    def buffer(workdir, name, shape, dtype=np.float64):
        if workdir is not None:
            mapped.append(name)
        return original(workdir, name, shape, dtype)

    for module in (base, paging):  # paging's: the scratch rows (ScratchRows)
        monkeypatch.setattr(module, "buffer", buffer)
    paged = analyze([SAMPLE], RunOptions(jobs=jobs), workdir=tmp_path)
    # each detector's outputs went to buffers: the bank's also to its as-measured copy,
    # made when it corrected the first fault it isolated
    assert {"ar_kalman_bank-resid", "ar_kalman_bank-resid0", "zeta", "ref"} <= set(mapped)
    assert "equivalent_model-resid" in mapped
    # and so did the whole-record float64 signals of the alarm searches (each detection
    # filter's estimate in sensor units, each observer's two signals), in scratch rows
    # that the next filter or observer reuses: at most one of each per thread
    for row in ("units", "observer-zeta", "observer-z"):
        files = sum(name.rstrip("0123456789") == row for name in mapped)
        assert 1 <= files <= jobs if row_files else files == 0
    same_findings(findings_of(paged), findings_of(serial_run))
    assert isinstance(paged.values, np.memmap)
    for rs, rp in zip(serial_run.results, paged.results, strict=True):
        assert rp.detector == rs.detector
        for c, res in rs.residuals.items():
            kept = rp.residuals[c]
            assert isinstance(kept.base, np.memmap) and not kept.flags.writeable
            scale = float(np.nanmax(np.abs(res)))
            assert float(np.nanmax(np.abs(res - kept))) <= 1e-6 * scale
            assert kept.dtype == res.dtype == np.float32
        # the detectors' own outputs went to memory-mapped buffers (RunContext.buffer)
        # on the way: the fault-free estimates too, rounded once to float32 as in memory
        assert rp.reference.keys() == rs.reference.keys()
        for c, ref in rs.reference.items():
            scale = float(np.nanmax(np.abs(ref)))
            assert float(np.nanmax(np.abs(ref - rp.reference[c]))) <= 1e-6 * scale
        assert rp.model["windowed_tests"].keys() == rs.model["windowed_tests"].keys()
    # no signal went to a new file: the detection filter's float64 fault estimates (a
    # whole buffer) were narrowed to float32 over their own file, the others (the
    # observers' signals, the filters' estimates, the bank's float32 copies here) are
    # kept where they are
    assert not list((tmp_path / "signals").iterdir())
    # the buffers' files were unlinked as they were made: nothing else is left
    assert {p.name for p in tmp_path.iterdir()} <= {"signals", "aligned.npy", "store", ".lock"}


# -- runs start as fits finish -------------------------------------------------------------

RUNS: list[str] = []


class _Timed:
    """A detector whose fit takes ``delay`` s (and fails when ``fail``); its run records
    when it starts."""

    name = "timed"
    delay = 0.0
    fail = False

    def applicable(self, data, context):
        return None

    def fit(self, data, context):
        threading.Event().wait(self.delay)
        if self.fail:
            raise DetectorError(f"{self.name} cannot fit")
        return self.name

    def run(self, model, data, context):
        from analyzer.detectors import DetectorResult

        RUNS.append(model)
        return DetectorResult(model, tuple(data.channels), {}, [], {})


class SlowFit(_Timed):
    name, delay = "slow", 0.4


class FastFit(_Timed):
    name = "fast"


class SlowFail(_Timed):
    name, delay, fail = "slow", 0.4, True


class FastFail(_Timed):
    name, fail = "fast", True


@pytest.mark.parametrize("jobs", [1, 2])
def test_runs_start_as_fits_finish_and_results_keep_registry_order(monkeypatch, jobs):
    from analyzer.detector_runs import run_detectors

    monkeypatch.setitem(REGISTRY, "slow", f"{__name__}:SlowFit")
    monkeypatch.setitem(REGISTRY, "fast", f"{__name__}:FastFit")
    RUNS.clear()
    data = Dataset(np.zeros((100, 2)), ("a", "b"), 10.0, (0, 50))
    ex = make_executor(jobs)
    try:
        ctx = RunContext(executor=ex if jobs > 1 else None)
        results, skipped = run_detectors(["slow", "fast"], RunOptions(jobs=jobs), data, ctx, ex)
    finally:
        ex.close()
    assert [r.detector for r in results] == ["slow", "fast"] and not skipped
    # on threads the fast fit's run does not wait for the slow fit; serially, registry order
    assert (["fast", "slow"] if jobs > 1 else ["slow", "fast"]) == RUNS


@pytest.mark.parametrize("jobs", [1, 2])
def test_the_first_explicit_error_in_registry_order_is_raised(monkeypatch, jobs):
    from analyzer.detector_runs import run_detectors

    monkeypatch.setitem(REGISTRY, "slow", f"{__name__}:SlowFail")
    monkeypatch.setitem(REGISTRY, "fast", f"{__name__}:FastFail")
    data = Dataset(np.zeros((100, 2)), ("a", "b"), 10.0, (0, 50))
    ex = make_executor(jobs)
    try:
        ctx = RunContext(executor=ex if jobs > 1 else None, explicit=True)
        with pytest.raises(DetectorError, match="^slow cannot fit"):
            run_detectors(["slow", "fast"], RunOptions(jobs=jobs), data, ctx, ex)
        ctx = RunContext(executor=ex if jobs > 1 else None)  # not named: both skipped
        results, skipped = run_detectors(["slow", "fast"], RunOptions(jobs=jobs), data, ctx, ex)
        assert results == [] and list(skipped) == ["slow", "fast"]
    finally:
        ex.close()


def test_an_interrupted_run_does_not_wait_for_running_tasks(monkeypatch, tmp_path):
    """A run stopped by an error or an interrupt closes its pool without waiting for the
    tasks already running (one can be minutes inside a compiled kernel); a run that ends
    normally waits for them."""
    from analyzer import pipeline

    release_task = threading.Event()
    running = threading.Event()
    closed: list[bool] = []

    class Spy(ThreadExecutor):
        def close(self, wait: bool = True) -> None:
            closed.append(wait)
            super().close(wait)

    def stuck(*_args: object, **_kwargs: object) -> None:
        pool = created[0]
        pool.submit(lambda: (running.set(), release_task.wait(30)))
        running.wait(5)
        raise KeyboardInterrupt

    created: list[Spy] = []

    def make(jobs: int, scheduler: str | None) -> Spy:
        created.append(Spy(2))
        return created[0]

    monkeypatch.setattr(pipeline, "make_executor", make)
    monkeypatch.setattr(pipeline, "_analyze", stuck)
    with pytest.raises(KeyboardInterrupt):
        analyze([tmp_path / "x.csv"], RunOptions(jobs=2))
    assert closed == [False]
    assert not release_task.is_set()  # the task still runs: close did not wait for it
    release_task.set()


def test_raw_store_files_go_once_the_archive_is_aligned(tmp_path, monkeypatch):
    """The raw store's files (a time and a value per sample: after the aligned matrix the
    largest scratch files of a long archive) are removed once the matrix is built, not
    kept to the end of the run: the detectors run without them."""
    import analyzer.pipeline as pl
    from analyzer.store.store import ChannelStore

    real = ChannelStore.from_chunks.__func__
    seen: dict[str, object] = {}

    def from_chunks(cls, chunks, workdir=None, spill_samples=0):
        store = real(cls, chunks, workdir, spill_samples=1000)  # every channel to files
        seen["files"] = sorted(p.suffix for p in Path(workdir).iterdir())
        return store

    def healthy_stats(*args, **kwargs):
        seen["during"] = (tmp_path / "store").exists()
        return real_stats(*args, **kwargs)

    real_stats = pl.healthy_stats
    monkeypatch.setattr(ChannelStore, "from_chunks", classmethod(from_chunks))
    monkeypatch.setattr(pl, "healthy_stats", healthy_stats)
    analysis = analyze([SAMPLE], RunOptions(jobs=1), workdir=tmp_path)
    assert {".t", ".v"} <= set(seen["files"])  # the store was on disk
    assert seen["during"] is False  # and gone before the detectors ran
    assert [(f.channel, str(f.type)) for f in analysis.findings] == [("/s4.data", "additive")]


def test_long_archive_signals_go_to_files_while_the_next_detector_runs(tmp_path, monkeypatch):
    """On threads, a long archive's finished detector moves its signals to files on the
    pool while the next detector runs (not in between, with a core idle), and its
    residual tests start only once they are there: every detector's tests are in the
    results, computed on the spilled (file-backed) residuals."""
    import analyzer.detector_runs as runs
    import analyzer.pipeline as pl

    monkeypatch.setattr(pl, "MATERIALIZE_IN_MEMORY", 1000)
    main = threading.main_thread()
    spilled_on: list[bool] = []
    tested: list[bool] = []
    real_spill, real_tests = runs._spill, pl._residual_tests

    def spill(result, spill_dir, tag=""):
        spilled_on.append(threading.current_thread() is main)
        return real_spill(result, spill_dir, tag)

    def residual_tests(task):
        res = task[0].residuals[task[1][0]]
        # spilled: a read-only float32 row of a file (a float64 or writable one is the
        # detector's own buffer, not yet moved)
        tested.append(res.dtype == np.float32 and not res.flags.writeable)
        return real_tests(task)

    monkeypatch.setattr(runs, "_spill", spill)
    monkeypatch.setattr(pl, "_residual_tests", residual_tests)
    analysis = analyze([SAMPLE], RunOptions(jobs=2), workdir=tmp_path)
    assert spilled_on == [False, False, False]  # on the pool, one per detector
    assert tested and all(tested)  # each test read a spilled residual
    for r in analysis.results:
        assert r.model["windowed_tests"].keys() == r.residuals.keys(), r.detector


@pytest.mark.parametrize("jobs", [1, 2])
def test_the_bank_reports_its_whole_record_pass_as_it_goes(jobs):
    """The bank's pass over the whole record advances ``detect`` chunk by chunk, named
    ``ar_kalman_bank run: whole record NN%`` in its detail, serially and on threads: the
    longest step of a day's run, which left ``--progress`` silent for 45-58 s (the ux55
    audit). Its percentages rise, at most one report a hundredth (no per-sample
    reports), short of 100 % (the run's end is said as ``ar_kalman_bank run: done``)."""
    seen: list[tuple[str, float]] = []
    analyze([SAMPLE], RunOptions(jobs=jobs, progress=lambda s, f: seen.append((s, f))))
    said = "ar_kalman_bank run: whole record "
    steps = [getattr(s, "detail", "") for s, _ in seen]
    shown = [int(d.removeprefix(said).rstrip("%")) for d in steps if d.startswith(said)]
    assert len(shown) >= 3 and 90 <= shown[-1] < 100, seen
    assert shown[0] > 0
    assert all(b > a for a, b in zip(shown, shown[1:], strict=False))
    assert len(shown) <= 99
    first = next(i for i, d in enumerate(steps) if d.startswith(said))
    assert "ar_kalman_bank run: done" in steps[first:]  # (detect goes on after it)
