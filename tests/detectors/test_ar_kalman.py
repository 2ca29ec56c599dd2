"""The AR -> Kalman bank detector against Chang et al. (2017)'s numerical example and
randomized buildings."""

import functools
import inspect
from typing import Any

import numpy as np
import pytest

from analyzer.detectors.ar_kalman import ARKalmanBank, leave_one_out
from analyzer.detectors.ar_model import fit_ar
from analyzer.detectors.base import Dataset, RunContext
from analyzer.detectors.lti import simulate_reference
from analyzer.errors import DetectorError
from analyzer.simulate import inject_fault, shear_building, simulate_building

RATE = 200.0


def _run(Y, names, train_s=15.0, order=7):
    ds = Dataset(Y, tuple(names), RATE, (0, int(train_s * RATE)))
    det = ARKalmanBank(order=order)
    ctx = RunContext()
    return det.run(det.fit(ds, ctx), ds, ctx)


# Chang et al. (2017), Section 3 "Numerical example" (/work/shared/seeds/001_*.txt, the
# paragraphs at lines 168 and 172): "the natural frequencies are 1.01 Hz, 2.93 Hz, 4.63 Hz,
# 5.94 Hz, 6.78 Hz, while the damping is assumed to be 2%", sampled at 200 Hz for 60 s, the
# first 15 s fit the AR model, each fault is added to the 5th floor at 16 s. The paper's
# sizes (Section 3, Figs. 6-8, lines 201-205): offset 0.8 x the largest reading, gain
# 1.5, drift 2.5e-3 per sample.
PAPER_FREQUENCIES_HZ = (1.01, 2.93, 4.63, 5.94, 6.78)
PAPER_DAMPING = 0.02
PAPER_FAULT_ONSET_S = 16.0
PAPER_TRAIN_S = 15.0

MODEL_FREQUENCIES_REL_ERROR = 0.0065
"""A uniform shear building cannot match the paper's spacing: its five frequencies are
1.01, 2.948, 4.648, 5.970 and 6.809 Hz, 0.61 % above the paper's at most (2.948 vs 2.93)."""

PAPER_SEEDS = (0, 1, 2, 3, 4)
"""Measured at the default order (BIC, capped at 10) over seeds 0-9 (README's table of
this example): the largest size errors are 0.30 % (offset), 2.44 % (gain) and 0.14 %
(drift), the largest onset errors 0.000 s, 0.31 s and 0.057 s; over the seeds run here,
0.13 %, 2.15 %, 0.14 % and 0.000 s, 0.15 s, 0.025 s. At the paper's order 7 the gain of
1.5 is found within 0.5 s on 4 of those 10 seeds only (README says why)."""

SIZE_REL_TOL = {"additive": 0.01, "multiplicative": 0.03, "drift": 0.004}
"""README's bounds: 1 % (offset), 3 % (gain), 0.4 % (drift), above the measured maxima
(0.30 %, 2.44 %, 0.14 %) and below a 5 % error in the fitted offset or drift and a 10 %
error in the gain's change (1.5 read as 1.55), which must fail."""

ONSET_TOL_S = {"additive": 0.02, "multiplicative": 0.35, "drift": 0.1}
"""README's bounds on the onset (measured: 0.000 s, 0.31 s, 0.057 s over seeds 0-9)."""


@functools.cache
def _paper_case(seed: int) -> tuple[np.ndarray, list[str], ARKalmanBank, Any]:
    """Chang et al.'s building at ``seed`` and the bank fitted at the default order on
    its first 15 s."""
    _, Y, names = simulate_building(n_floors=5, duration_s=60.0, seed=seed)
    det = ARKalmanBank()
    ds = Dataset(Y, tuple(names), RATE, (0, int(PAPER_TRAIN_S * RATE)))
    return Y, names, det, det.fit(ds, RunContext())


@pytest.fixture(scope="module")
def paper_building():
    # Section 3: five stories, f1 = 1.01 Hz, 2 % damping, 200 Hz, ~20 dB SNR, 60 s
    return simulate_building(n_floors=5, duration_s=60.0, seed=0)


def test_paper_building_constants() -> None:
    """The constants of Chang et al.'s building, as the paper gives them (Section 3):
    the simulator's defaults are 1.01 Hz and 2 % damping, and its five frequencies are
    the paper's to the measured 0.61 % (a uniform shear building's spacing)."""
    for fn in (simulate_building, shear_building):
        params = inspect.signature(fn).parameters
        assert params["f1_hz"].default == PAPER_FREQUENCIES_HZ[0]
        assert params["damping"].default == PAPER_DAMPING
        assert params["n_floors"].default == len(PAPER_FREQUENCIES_HZ)
    b = shear_building()
    np.testing.assert_allclose(
        b.frequencies_hz, PAPER_FREQUENCIES_HZ, rtol=MODEL_FREQUENCIES_REL_ERROR
    )
    np.testing.assert_allclose(b.frequencies_hz, [1.01, 2.948, 4.648, 5.970, 6.809], atol=5e-4)
    # the model itself (not only the record it keeps): 2 % of critical in every mode
    lam = np.linalg.eigvals(b.A)
    lam = lam[lam.imag > 0]
    np.testing.assert_allclose(-lam.real / np.abs(lam), PAPER_DAMPING, rtol=1e-9)
    np.testing.assert_allclose(np.sort(np.abs(lam)) / (2 * np.pi), b.frequencies_hz, rtol=1e-9)


@pytest.mark.parametrize("seed", PAPER_SEEDS)
def test_paper_healthy_run_has_no_finding(seed: int) -> None:
    Y, names, det, model = _paper_case(seed)
    ds = Dataset(Y, tuple(names), RATE, (0, int(PAPER_TRAIN_S * RATE)))
    assert det.run(model, ds, RunContext()).events == []


@pytest.mark.parametrize("seed", PAPER_SEEDS)
@pytest.mark.parametrize(
    ("kind", "size"),
    [("additive", "0.8max"), ("multiplicative", 1.5), ("drift", 2.5e-3 * RATE)],
)
def test_paper_faults_on_floor_5(seed: int, kind: str, size: float | str) -> None:
    """Chang et al.'s three faults on floor 5 at 16 s, at the default order: one finding,
    on s4, of the right type, its onset and size within README's bounds."""
    Y, names, det, model = _paper_case(seed)
    y5 = Y[:, 4]
    amount = 0.8 * float(np.max(np.abs(y5))) if size == "0.8max" else float(size)
    Yf = Y.copy()
    Yf[:, 4] = inject_fault(y5, RATE, kind, PAPER_FAULT_ONSET_S, amount)
    ds = Dataset(Yf, tuple(names), RATE, (0, int(PAPER_TRAIN_S * RATE)))
    res = det.run(model, ds, RunContext())
    assert len(res.events) == 1, res.events
    ev = res.events[0]
    assert ev.channel == "s4"
    assert ev.type.value == kind
    assert abs(ev.onset_s - PAPER_FAULT_ONSET_S) <= ONSET_TOL_S[kind]
    assert ev.end_s is None
    key = {"additive": "offset", "multiplicative": "gain", "drift": "rate_per_s"}[kind]
    assert ev.magnitude[key] == pytest.approx(amount, rel=SIZE_REL_TOL[kind])
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


@pytest.mark.parametrize("seed", [3, 4])
def test_reoccurring_faults_at_the_default_order_keep_the_drift_and_the_offsets_size(seed):
    """Fig. 15 at the default order: the offset on s4 from 16 s is fitted before the
    drift on s5 from 32 s begins, where the estimator that leaves s4 out first loses
    consistency. Before, its fit ran to a long window before the first alarm interval
    that began later (37.03 s at seed 4, the other channels alarming since 16 s with the
    offset's spread): 3.04 and 5.06 for 4.01 and 5.36, and the leftover kept s5's residual
    alarmed from 16 s, so its drift was taken for the offset's echo and lost."""
    _, Y, names = simulate_building(n_floors=3, sensors_per_floor=2, duration_s=50.0, seed=seed)
    Yf = Y.copy()
    offset = 2.0 * np.std(Y[:, 4])
    Yf[:, 4] = inject_fault(Y[:, 4], RATE, "additive", 16.0, offset)
    Yf[:, 5] = inject_fault(Y[:, 5], RATE, "drift", 32.0, 0.5 * np.std(Y[:, 5]))
    res = _run(Yf, names, order="bic")
    got = sorted(res.events, key=lambda e: e.channel)
    assert [(e.channel, e.type.value) for e in got] == [("s4", "additive"), ("s5", "drift")]
    assert abs(got[0].onset_s - 16.0) < 0.1 and abs(got[1].onset_s - 32.0) < 0.1
    assert got[0].magnitude["offset"] == pytest.approx(offset, rel=0.01)
    assert got[1].magnitude["rate_per_s"] == pytest.approx(0.5 * np.std(Y[:, 5]), rel=0.01)


def _loss(common: bool) -> tuple[int | None, int]:
    """``_first_violation`` for estimator 0 of a bank fitted on the 3x2 building, over
    the consistency of the healthy record with every estimator's raised 3 times from
    row ``r``: alike (``common``, a change of the environment), or from ``r`` for
    estimator 0 and already from a third of the record for the others (the others see
    sensor 0's fault under way, estimator 0 only the next fault, of another sensor)."""
    _, Y, names = simulate_building(n_floors=3, sensors_per_floor=2, duration_s=30.0, seed=0)
    ds = Dataset(Y, tuple(names), RATE, (0, int(15.0 * RATE)))
    det = ARKalmanBank()
    model = det.fit(ds, RunContext())
    N = Y.shape[0]
    nis = det._consistency(model, Y, [], 0, N).copy()
    r = int(24.0 * RATE)
    nis[r:] *= 3.0
    if not common:
        nis[int(N / 3) :, 1:] *= 10.0
    lost = det._first_violation(
        model,
        0,
        (int(15.0 * RATE), N),
        lambda j, windows: (nis[a:b, j] for a, b in windows),
        lambda lo, hi: nis[lo:hi],
    )
    return lost, r


def test_a_loss_of_consistency_common_to_every_estimator_is_not_the_next_fault():
    """A change of the environment (sweep_eov's thermal records) raises every
    estimator's statistic alike: estimator 0 loses consistency with the others, which
    is no fault of another sensor, so it sets no limit on sensor 0's fault's fit (the
    bank's s3 offset 89 s before the fault at thermalgain, 2 floors, seed 2, came from
    such a limit). Where the others, seeing sensor 0's fault, are far more inconsistent
    when estimator 0 loses it, the loss stands, within a long window of the change."""
    lost, _ = _loss(common=True)
    assert lost is None
    lost, r = _loss(common=False)
    assert lost is not None and r <= lost <= r + int(2.0 * RATE)


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
