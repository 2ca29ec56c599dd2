"""``--scheduler tcp://HOST:PORT`` against a real local Dask cluster (two worker
processes): the same findings as the serial run, errors that keep their type, and a
one-line exit 2 for an unreachable scheduler.

One cluster serves the whole module (starting one takes a few seconds)."""

from __future__ import annotations

import json
import os
import socket
import sys
from pathlib import Path

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")
cloudpickle = pytest.importorskip("cloudpickle")

import analyzer.parallel  # noqa: E402
import analyzer.parallel_dask  # noqa: E402
from analyzer.cli import main  # noqa: E402
from analyzer.errors import DetectorError, UsageError  # noqa: E402
from analyzer.parallel import (  # noqa: E402
    IN_FLIGHT_PER_THREAD,
    DaskExecutor,
    blas_threads_setting,
    make_executor,
)
from analyzer.pipeline import RunOptions, analyze  # noqa: E402

SAMPLES = Path(__file__).resolve().parents[2] / "samples"
SAMPLE = SAMPLES / "building_additive.mcap"
BLAS_ENV = {v: "1" for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}

# the workers cannot import this test module: ship its functions by value
cloudpickle.register_pickle_by_value(sys.modules[__name__])


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        env=BLAS_ENV,
    ) as c:
        yield c


@pytest.fixture(scope="module")
def dask_ex(cluster):
    ex = DaskExecutor(cluster.scheduler_address)
    yield ex
    ex.close()


@pytest.fixture(scope="module")
def serial_run():
    return analyze([SAMPLE], RunOptions())


def _truth_offset() -> float:
    truth = json.loads((SAMPLES / "truth.json").read_text())
    entry = next(t for t in truth if t["file"] == SAMPLE.name)
    return float(entry["faults"][0]["offset"])


def _double(x: np.ndarray) -> np.ndarray:
    return 2.0 * x


def _fail_on_three(x: int) -> int:
    if x == 3:
        raise DetectorError(f"cannot fit block {x}")
    return x


def _weighted(item: tuple[np.ndarray, np.ndarray, int]) -> float:
    """A time block's task: a shared array (a fitted model), the block's rows, its index."""
    shared, rows, k = item
    return float(rows @ shared[: rows.shape[0]]) + k


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_workers_have_one_blas_thread(dask_ex):
    assert dask_ex.n_workers == 2 and dask_ex.workers == 2
    settings = dask_ex.client.run(blas_threads_setting)
    assert len(settings) == 2 and set(settings.values()) == {"1"}
    assert set(dask_ex.client.run(os.getpid).values()) != {os.getpid()}  # other processes
    assert "without OPENBLAS_NUM_THREADS" not in dask_ex.describe()


def _heap_tuned_blocks(_: object = None) -> int:
    """How many ``heap_tuned`` blocks the task runs in, on its worker."""
    import analyzer.paging

    return analyzer.paging._tuned_blocks


def test_tasks_run_with_the_heap_tuned_on_dask_s_workers(dask_ex):
    """Every task the executor sends runs inside ``heap_tuned`` (what that does to a
    worker's heap is checked in a clean process: ``tests/store/test_paging.py``; inside
    a worker, its other threads' allocations make page-fault counts too noisy to test)."""
    assert dask_ex.client.submit(_heap_tuned_blocks, pure=False).result() == 0  # plain
    assert dask_ex.map(_heap_tuned_blocks, [None, None]) == [1, 1]
    assert dask_ex.submit(_heap_tuned_blocks, None).result() == 1
    assert list(dask_ex.imap(_heap_tuned_blocks, [(np.zeros(1 << 14),)])) == [1]  # scattered
    # and the worker's own setting is back after each
    assert set(dask_ex.client.run(_heap_tuned_blocks).values()) == {0}


def test_dask_map_keeps_order_and_error_types(dask_ex):
    items = [np.full(100 + k, float(k)) for k in range(9)]
    out = dask_ex.map(_double, items)
    for x, y in zip(items, out, strict=True):
        np.testing.assert_array_equal(y, 2.0 * x)
    with pytest.raises(DetectorError, match="cannot fit block 3"):
        dask_ex.map(_fail_on_three, list(range(6)))
    with pytest.raises(DetectorError, match="cannot fit block 3"):
        dask_ex.submit(_fail_on_three, 3).result()


def test_imap_keeps_a_few_items_in_flight(dask_ex):
    """Items are taken from the caller one at a time as results are handed over: at most
    IN_FLIGHT_PER_THREAD per worker thread beyond the ones consumed, so a long archive's
    time blocks are never all read (nor all on the workers) at once."""
    window = IN_FLIGHT_PER_THREAD * dask_ex.workers
    taken = []

    def blocks():
        for k in range(20):
            taken.append(k)
            yield np.full(50, float(k))

    results = dask_ex.imap(_double, blocks())
    first = next(results)
    np.testing.assert_array_equal(first, np.zeros(50))
    assert len(taken) <= window + 1
    rest = list(results)
    assert len(taken) == 20
    for k, y in enumerate([first, *rest]):
        np.testing.assert_array_equal(y, np.full(50, 2.0 * k))


def test_imap_items_with_a_scattered_model_and_memory_mapped_rows(dask_ex, tmp_path):
    """Tuple items: a scattered handle is replaced by its value on the worker, a large
    array (a view of a memory-mapped file, as a long archive's rows are) is scattered
    beside the task, small ones go with it; results in order."""
    shared = np.linspace(0.0, 1.0, 40_000)
    rows = np.memmap(tmp_path / "rows.f64", dtype=np.float64, mode="w+", shape=(30_000,))
    rows[:] = np.arange(30_000.0)
    spans = [(0, 20_000), (5_000, 30_000), (29_000, 30_000)]
    handle = dask_ex.scatter(shared)
    items = ((handle, rows[a:b], k) for k, (a, b) in enumerate(spans))
    got = list(dask_ex.imap(_weighted, items))
    want = [_weighted((shared, np.asarray(rows[a:b]), k)) for k, (a, b) in enumerate(spans)]
    assert got == pytest.approx(want, rel=1e-12)


def test_imap_error_keeps_its_type(dask_ex):
    with pytest.raises(DetectorError, match="cannot fit block 3"):
        list(dask_ex.imap(_fail_on_three, iter(range(10))))
    assert list(dask_ex.imap(_fail_on_three, [])) == []


def test_scheduler_gives_the_serial_findings(cluster, serial_run, findings_of, same_findings):
    serial = serial_run
    dask = analyze([SAMPLE], RunOptions(scheduler=cluster.scheduler_address))
    found = findings_of(dask)
    same_findings(found, findings_of(serial))
    assert [r.detector for r in dask.results] == [r.detector for r in serial.results]
    assert dask.skipped == serial.skipped
    assert found[0][:2] == ("/s4.data", "additive")
    assert found[0][2] == pytest.approx(16.0, abs=0.05)
    assert found[0][3]["offset"] == pytest.approx(_truth_offset(), rel=0.01)
    note = f"ran on Dask scheduler {cluster.scheduler_address}: 2 workers"
    assert any(n.startswith(note) for n in dask.notes), dask.notes
    assert not any("not implemented" in n for n in dask.notes)


def test_cluster_time_blocks_are_bounded_and_give_the_serial_run(
    cluster, serial_run, findings_of, same_findings, monkeypatch
):
    """With blocks capped at a few thousand values (and one warm-up), the bank and the
    detection filter send the record to the workers in many blocks (each with its
    warm-up), a few at a time, and write each back as it arrives: the serial findings,
    and the serial residuals to the precision they are kept in."""
    import analyzer.detectors.ar_kalman as ak
    import analyzer.detectors.detection_filter as df
    import analyzer.detectors.lti as lti

    monkeypatch.setattr(lti, "CLUSTER_BLOCK_VALUES", 1 << 12)
    monkeypatch.setattr(lti, "MIN_TIME_BLOCK", 1)  # blocks as short as one warm-up
    sizes: dict[str, list[int]] = {"bank": [], "df": []}

    def spy(tag):
        def blocks(start, stop, warmup, context, width=1):
            spans = lti.time_blocks(start, stop, warmup, context, width)
            if not context.shares_memory and len(spans) > 1:
                sizes[tag].append(len(spans))
                assert all(b - a <= max(warmup, (1 << 12) // width) for a, b, _ in spans)
            return spans

        return blocks

    monkeypatch.setattr(ak, "time_blocks", spy("bank"))
    monkeypatch.setattr(df, "time_blocks", spy("df"))
    dask = analyze([SAMPLE], RunOptions(scheduler=cluster.scheduler_address))
    # (two blocks per worker thread without the cap)
    assert max(sizes["bank"]) > 4 and max(sizes["df"]) > 4, sizes
    same_findings(findings_of(dask), findings_of(serial_run))
    for mine, ref in zip(dask.results, serial_run.results, strict=True):
        assert mine.detector == ref.detector
        for c, r in ref.residuals.items():
            want = np.asarray(r, dtype=np.float64)
            got = np.asarray(mine.residuals[c], dtype=np.float64)
            scale = np.nanstd(want) or 1.0
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-5 * scale, err_msg=c)


def test_cli_scheduler_writes_the_serial_findings(cluster, tmp_path, capsys, same_findings):
    # (--jobs 2 against the serial run: tests/test_parallel.py)
    docs = {}
    for label, extra in {
        "serial": [],
        "dask": ["--scheduler", cluster.scheduler_address],
    }.items():
        out = tmp_path / label
        code = main(["run", str(SAMPLE), "--out", str(out), "--no-progress", *extra])
        assert code == 1, capsys.readouterr().err
        docs[label] = json.loads((out / "findings.json").read_text())
    got, want = docs["dask"]["faults"], docs["serial"]["faults"]
    same_findings(
        [(f["channel"], f["type"], f["onset_s"], f["magnitude"]) for f in got],
        [(f["channel"], f["type"], f["onset_s"], f["magnitude"]) for f in want],
    )
    assert docs["dask"]["skipped_detectors"] == docs["serial"]["skipped_detectors"]
    assert any(n.startswith("ran on Dask scheduler") for n in docs["dask"]["notes"])


def test_explicit_detector_error_on_the_cluster(cluster):
    with pytest.raises(DetectorError, match=r"^ar_kalman_bank: needs at least 2 channels"):
        analyze(
            [SAMPLE],
            RunOptions(
                scheduler=cluster.scheduler_address,
                channels=["/s4.data"],
                detectors=["ar_kalman_bank", "equivalent_model"],
            ),
        )


def test_unreachable_scheduler_is_exit_2_in_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(analyzer.parallel_dask, "CONNECT_TIMEOUT_S", 2.0)
    address = f"tcp://127.0.0.1:{_free_port()}"
    code = main(["run", str(SAMPLE), "--out", str(tmp_path / "o"), "--scheduler", address])
    _, err = capsys.readouterr()
    assert code == 2
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert f"--scheduler {address}: cannot connect" in lines[0]
    assert not (tmp_path / "o").exists()


def test_scheduler_without_workers_is_exit_2_before_reading(tmp_path, capsys, monkeypatch):
    """A scheduler with no worker connected: one line naming --scheduler, after waiting
    CONNECT_TIMEOUT_S for one, and nothing read or written (rather than Dask's "No valid
    workers found" once the archive has been read)."""
    monkeypatch.setattr(analyzer.parallel_dask, "CONNECT_TIMEOUT_S", 1.0)
    read = []
    monkeypatch.setattr("analyzer.pipeline.open_archive", lambda *a: read.append(a))
    with distributed.LocalCluster(n_workers=0, processes=False, dashboard_address=":0") as c:
        address = c.scheduler_address
        code = main(["run", str(SAMPLE), "--out", str(tmp_path / "o"), "--scheduler", address])
    _, err = capsys.readouterr()
    assert code == 2 and not read
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert f"--scheduler {address}: no worker is connected to the scheduler" in lines[0]
    assert not (tmp_path / "o").exists()


def test_bad_scheduler_address(monkeypatch):
    with pytest.raises(UsageError, match="--scheduler tcp://host: expected an address"):
        make_executor(None, "tcp://host")


def test_grouped_run_on_the_cluster_gives_the_local_findings(cluster, tmp_path, monkeypatch):
    """Channel groups (analyzer.grouping) on the cluster: each group's detectors are
    tasks of their own, and the joined findings equal the local run's."""
    import functools

    from analyzer import grouping, pipeline
    from analyzer.simulate import simulate_building

    t, Y, names = simulate_building(6, 240.0, 50.0, seed=7, sensors_per_floor=2)
    k = 150 * 50
    Y[k:, 3] += Y[: k // 2, 3].std()
    path = tmp_path / "b.csv"
    header = "time," + ",".join(names)
    np.savetxt(path, np.column_stack([t, Y]), delimiter=",", header=header, comments="")
    monkeypatch.setattr(pipeline, "partition", functools.partial(grouping.partition, size=6))
    local = analyze([path], RunOptions(jobs=2))
    remote = analyze([path], RunOptions(scheduler=cluster.scheduler_address))
    assert any("in 2 groups" in n for n in remote.notes)
    assert (
        [(f.channel, f.type) for f in remote.findings]
        == [(f.channel, f.type) for f in local.findings]
        == [("s3", local.findings[0].type)]
    )
    for a, b in zip(remote.findings, local.findings, strict=True):
        assert a.onset_s == pytest.approx(b.onset_s, abs=1e-9)
        assert a.magnitude == pytest.approx(b.magnitude, rel=1e-9)


def test_models_saved_and_run_on_the_cluster_match_the_local_ones(
    cluster, tmp_path, capsys, same_findings
):
    """``--save-model`` with the fits done on workers writes the model the local run
    writes, and ``--model`` runs on the cluster give the local findings."""
    faults = {}
    for label, extra in {
        "serial": [],
        "dask": ["--scheduler", cluster.scheduler_address],
    }.items():
        model = tmp_path / f"{label}.model"
        code = main(["run", str(SAMPLE), "--out", str(tmp_path / f"fit-{label}"),
                     "--no-progress", "--save-model", str(model), *extra])  # fmt: skip
        assert code == 1, capsys.readouterr().err
        for where, more in {
            "serial": [],
            "dask": ["--scheduler", cluster.scheduler_address],
        }.items():
            out = tmp_path / f"{label}-model-{where}"
            code = main(["run", str(SAMPLE), "--out", str(out), "--no-progress",
                         "--model", str(model), *more])  # fmt: skip
            assert code == 1, capsys.readouterr().err
            doc = json.loads((out / "findings.json").read_text())
            faults[label, where] = [
                (f["channel"], f["type"], f["onset_s"], f["magnitude"]) for f in doc["faults"]
            ]
    want = faults["serial", "serial"]
    assert want[0][:2] == ("/s4.data", "additive")
    for got in faults.values():
        same_findings(got, want)
