"""The AR -> Kalman bank detector against Chang et al. (2017)'s numerical example and
randomized buildings."""

import numpy as np
import pytest

from analyzer.detectors.ar_kalman import ARKalmanBank, leave_one_out
from analyzer.detectors.ar_model import fit_ar
from analyzer.detectors.base import Dataset, RunContext
from analyzer.detectors.lti import simulate_reference
from analyzer.errors import DetectorError
from analyzer.simulate import inject_fault, simulate_building

RATE = 200.0


def _run(Y, names, train_s=15.0, order=7):
    ds = Dataset(Y, tuple(names), RATE, (0, int(train_s * RATE)))
    det = ARKalmanBank(order=order)
    ctx = RunContext()
    return det.run(det.fit(ds, ctx), ds, ctx)


@pytest.fixture(scope="module")
def paper_building():
    # Section 3: five stories, f1 = 1.01 Hz, 2 % damping, 200 Hz, ~20 dB SNR, 60 s
    return simulate_building(n_floors=5, duration_s=60.0, seed=0)


def test_paper_healthy_run_has_no_finding(paper_building):
    _, Y, names = paper_building
    assert _run(Y, names).events == []


@pytest.mark.parametrize(
    ("kind", "size"),
    [("additive", "0.8max"), ("multiplicative", 1.5), ("drift", 2.5e-3 * RATE)],
)
def test_paper_faults_on_floor_5(paper_building, kind, size):
    _, Y, names = paper_building
    y5 = Y[:, 4]
    amount = 0.8 * np.max(np.abs(y5)) if size == "0.8max" else size
    Yf = Y.copy()
    Yf[:, 4] = inject_fault(y5, RATE, kind, 16.0, amount)
    res = _run(Yf, names)
    assert len(res.events) == 1, res.events
    ev = res.events[0]
    assert ev.channel == "s4"
    assert ev.type.value == kind
    assert abs(ev.onset_s - 16.0) < 0.5
    assert ev.end_s is None
    key = {"additive": "offset", "multiplicative": "gain", "drift": "rate_per_s"}[kind]
    assert ev.magnitude[key] == pytest.approx(amount, rel=0.1)
    assert ev.confidence > 0.7
    # the evidence names the candidate sensors and the estimators by channel
    assert "s4" in ev.evidence["candidates"] and set(ev.evidence["candidates"]) <= set(names)
    assert sorted(ev.evidence["estimator_consistency"]) == sorted(names)


def test_reoccurring_faults_are_isolated_one_after_the_other():
    # Section 4, Fig. 15: an additive fault on sensor 5 at 16 s, a drift on sensor 6 at
    # 32 s, on a three-story building with two accelerometers per floor.
    _, Y, names = simulate_building(n_floors=3, sensors_per_floor=2, duration_s=50.0, seed=4)
    Yf = Y.copy()
    Yf[:, 4] = inject_fault(Y[:, 4], RATE, "additive", 16.0, 2.0 * np.std(Y[:, 4]))
    Yf[:, 5] = inject_fault(Y[:, 5], RATE, "drift", 32.0, 0.5 * np.std(Y[:, 5]))
    res = _run(Yf, names)
    got = sorted((e.channel, e.type.value, round(e.onset_s)) for e in res.events)
    assert [(c, t) for c, t, _ in got] == [("s4", "additive"), ("s5", "drift")]
    assert abs(got[0][2] - 16) <= 1 and abs(got[1][2] - 32) <= 1


def test_intermittent_fault_has_an_end():
    _, Y, names = simulate_building(n_floors=4, duration_s=45.0, seed=7)
    Yf = Y.copy()
    Yf[:, 1] = inject_fault(Y[:, 1], RATE, "additive", 20.0, 1.5 * np.std(Y[:, 1]), end_s=30.0)
    (ev,) = _run(Yf, names).events
    assert ev.channel == "s1" and ev.type.value == "additive"
    assert abs(ev.onset_s - 20.0) < 0.5 and ev.end_s is not None and abs(ev.end_s - 30.0) < 0.5


def test_randomized_buildings_accuracy_and_no_false_alarms():
    """3-8 floors, one or two sensors per floor, random sensor, size and type: the first
    finding must name the right sensor and type in at least 90 % of the cases, and the
    healthy records must give no finding at all."""
    ok = total = false_alarms = 0
    for seed in range(8):
        rng = np.random.default_rng(1000 + seed)
        nf, spf = int(rng.integers(3, 9)), int(rng.integers(1, 3))
        _, Y, names = simulate_building(
            n_floors=nf, sensors_per_floor=spf, duration_s=40.0, seed=seed
        )
        ds = Dataset(Y, tuple(names), RATE, (0, int(15 * RATE)))
        det = ARKalmanBank()
        ctx = RunContext()
        model = det.fit(ds, ctx)
        false_alarms += len(det.run(model, ds, ctx).events)
        for kind in ("additive", "multiplicative", "drift"):
            j = int(rng.integers(0, Y.shape[1]))
            sd = float(np.std(Y[:, j]))
            size = {
                "additive": rng.choice([-1, 1]) * rng.uniform(0.5, 2.0) * sd,
                "multiplicative": rng.choice([0.0, 0.5, 1.5, 2.0]),
                "drift": rng.choice([-1, 1]) * rng.uniform(0.1, 0.5) * sd,
            }[kind]
            Yf = Y.copy()
            Yf[:, j] = inject_fault(Y[:, j], RATE, kind, 20.0, float(size))
            evs = det.run(model, Dataset(Yf, tuple(names), RATE, ds.train), ctx).events
            total += 1
            ok += bool(evs) and evs[0].channel == names[j] and evs[0].type.value == kind
    assert false_alarms == 0
    assert ok / total >= 0.9, f"{ok}/{total}"


def test_gap_in_a_channel_is_no_fault(paper_building):
    _, Y, names = paper_building
    Yg = Y.copy()
    Yg[int(30 * RATE) : int(31 * RATE), 2] = np.nan
    res = _run(Yg, names)
    assert res.events == []
    assert np.isnan(res.residuals["s2"][int(30.5 * RATE)])


def test_estimator_matches_the_plain_recursion(paper_building):
    _, Y, _ = paper_building
    ar = fit_ar(Y[:3000], 4)
    est = leave_one_out(ar, 2, block=16)
    s = est.system
    u = ((Y[:1000] - ar.mean) / ar.scale)[:, list(est.measured)]
    lifted, _ = s.run(u)
    np.testing.assert_allclose(lifted, simulate_reference(s.F, s.G, s.H, s.J, u), atol=1e-9)


def test_single_channel_is_refused():
    Y = np.random.default_rng(0).normal(size=(5000, 1))
    ds = Dataset(Y, ("a",), RATE, (0, 3000))
    det = ARKalmanBank()
    assert "at least 2 channels" in det.applicable(ds, RunContext())
    with pytest.raises(DetectorError, match="at least 2 channels"):
        det.fit(ds, RunContext())


def test_bad_order_setting():
    with pytest.raises(DetectorError, match="order"):
        ARKalmanBank(order="hqic")
    with pytest.raises(DetectorError, match="order"):
        ARKalmanBank(order=0)


def test_the_as_measured_copy_of_a_long_archive_is_written_by_pwrite(tmp_path, monkeypatch):
    """``_kept`` (the bank's outputs as measured, kept before the first correction) goes
    to its memory-mapped float32 buffer by ``pwrite``, channel by channel, not by stores
    through the new file's mapping (which fault in and zero every page first)."""
    import os

    from analyzer import paging
    from analyzer.detectors.ar_kalman import _kept
    from analyzer.detectors.base import SIGNAL_DTYPE
    from analyzer.paging import is_mapped

    a = np.random.default_rng(0).standard_normal((200_000, 5))
    written: list[int] = []
    pwrite = os.pwrite

    def counting(fd: int, data: object, offset: int) -> int:
        written.append(memoryview(data).nbytes)  # type: ignore[arg-type]
        return pwrite(fd, data, offset)

    monkeypatch.setattr(paging.os, "pwrite", counting)
    out = _kept(RunContext(workdir=tmp_path, map_outputs=True), "k", a)
    assert is_mapped(out) and out.dtype == SIGNAL_DTYPE
    assert np.array_equal(out, a.astype(SIGNAL_DTYPE))
    assert sum(written) == a.size * np.dtype(SIGNAL_DTYPE).itemsize
    assert np.array_equal(_kept(RunContext(), "k", a), out)  # in memory: the same values
