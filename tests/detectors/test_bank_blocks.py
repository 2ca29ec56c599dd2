"""The bank's fast paths against their references: the doubling DARE solver against
scipy's QZ solver, the stacked lifted system against the sample-by-sample recursion, time
blocks filtered after a warm-up against one pass over the record, and whitened
consistency against the explicit ``nu' S^-1 nu``."""

import numpy as np
import pytest
from scipy import linalg

from analyzer.detectors import ar_kalman, kalman_bank
from analyzer.detectors.ar_kalman import ARKalmanBank
from analyzer.detectors.base import Dataset, RunContext
from analyzer.detectors.kalman_bank import BankFilter, bank_block, forgets_within, leave_one_out
from analyzer.detectors.lti import StackedLiftedSystem, simulate_reference
from analyzer.detectors.riccati import solve_dare
from analyzer.errors import DetectorError
from analyzer.simulate import inject_fault, simulate_building

RATE = 100.0


def _random_system(rng, n, r, stable=False):
    A = rng.normal(size=(n, n))
    A *= (0.9 if stable else 1.05) / np.max(np.abs(np.linalg.eigvals(A)))
    B = rng.normal(size=(n, r))
    Qh = rng.normal(size=(n, n))
    Rh = rng.normal(size=(r, r))
    return A, B, Qh @ Qh.T + 1e-3 * np.eye(n), Rh @ Rh.T + 0.1 * np.eye(r)


@pytest.mark.parametrize("seed", range(6))
def test_doubling_dare_equals_scipy(seed):
    rng = np.random.default_rng(seed)
    A, B, Q, R = _random_system(rng, 12, 3)
    ref = linalg.solve_discrete_are(A, B, Q, R)
    X = solve_dare(A, B, Q, R)
    assert np.abs(X - ref).max() <= 1e-8 * np.abs(ref).max()


def test_doubling_dare_with_cross_term_equals_scipy():
    rng = np.random.default_rng(11)
    A, B, Q, R = _random_system(rng, 10, 2)
    S = 0.05 * rng.normal(size=(10, 2))
    ref = linalg.solve_discrete_are(A, B, Q, R, s=S)
    X = solve_dare(A, B, Q, R, S)
    assert np.abs(X - ref).max() <= 1e-8 * np.abs(ref).max()


def test_unsolvable_dare_is_refused_like_scipy():
    # an unstable mode that the input cannot reach: no stabilizing solution
    A = np.diag([1.5, 0.5])
    B = np.array([[0.0], [1.0]])
    with pytest.raises((linalg.LinAlgError, ValueError)):
        solve_dare(A, B, np.eye(2), np.eye(1))


def test_stacked_system_equals_the_recursion_across_chunks():
    rng = np.random.default_rng(3)
    k, n, q, r = 3, 7, 4, 5
    systems = []
    for _ in range(k):
        F = rng.normal(size=(n, n))
        F *= 0.95 / np.max(np.abs(np.linalg.eigvals(F)))
        systems.append(
            (F, rng.normal(size=(n, r)), rng.normal(size=(q, n)), rng.normal(size=(q, r)))
        )
    u = rng.normal(size=(1003, r))
    stack = StackedLiftedSystem.build(systems, T=16)
    y1, x = stack.run(u[:517])  # a chunk that is not a multiple of T, state carried
    y2, _ = stack.run(u[517:], x)
    y = np.concatenate([y1, y2])
    for i, s in enumerate(systems):
        np.testing.assert_allclose(y[:, i], simulate_reference(*s, u), atol=1e-10)


@pytest.fixture(scope="module")
def fitted():
    _, Y, names = simulate_building(3, 300.0, RATE, seed=4, sensors_per_floor=2)
    data = Dataset(Y, tuple(names), RATE, (0, int(100 * RATE)))
    det = ARKalmanBank(order=5)
    return det, det.fit(data, RunContext()), data


def test_time_blocks_after_warmup_equal_one_pass(fitted):
    det, model, data = fitted
    Y = np.array(data.values, copy=True)
    Y[15000:15100, 2] = np.nan  # a gap: masks must agree too
    ar, bank = model.ar, model.bank
    whole = bank_block(ar.mean, ar.scale, bank, Y, 0, None)
    for a, b in ((4000, 9000), (14900, 16000), (20000, Y.shape[0])):
        w = min(a, bank.warmup)
        part = bank_block(ar.mean, ar.scale, bank, Y[a - w : b], w, None)
        for name in ("resid", "est", "nis"):
            ref = getattr(whole, name)[a:b]
            got = getattr(part, name)
            assert np.array_equal(np.isnan(ref), np.isnan(got)), name
            scale = np.nanmax(np.abs(ref))
            assert np.nanmax(np.abs(got - ref)) <= 1e-9 * scale, name


@pytest.mark.parametrize("radius", [0.3, 0.9, 0.99])
def test_forgetting_within_a_horizon_is_proven_and_only_then(radius):
    rng = np.random.default_rng(int(radius * 1000))
    F = rng.normal(size=(40, 40))
    F *= radius / np.max(np.abs(np.linalg.eigvals(F)))
    assert forgets_within(F, 1 << 14)
    assert not forgets_within(F, 8)  # radius^8 is far above the decay asked for
    assert not forgets_within(F * (1.001 / radius), 1 << 14)  # just outside the circle
    assert not forgets_within(F * (1.0 / radius), 1 << 14)  # on it
    assert not forgets_within(np.diag([0.5, 1.0]), 1 << 14)


def test_fold_estimators_with_given_times_equal_the_full_design(fitted):
    _, model, _ = fitted
    for j, full in enumerate(model.estimators):
        fast = leave_one_out(model.ar, j, full.block, (full.settle + 1, full.warmup + 2))
        for name in ("F", "G", "H", "J"):
            assert np.array_equal(getattr(fast, name), getattr(full, name)), name
        assert (fast.settle, fast.warmup) == (full.settle + 1, full.warmup + 2)
        # times the estimator cannot be shown to keep: it measures its own
        slow = leave_one_out(model.ar, j, full.block, (1, 1))
        assert (slow.settle, slow.warmup) == (full.settle, full.warmup)


def test_whitened_consistency_equals_explicit_form(fitted):
    _, model, data = fitted
    ar = model.ar
    plain = BankFilter.build(model.estimators, model.bank.block)
    explicit = bank_block(ar.mean, ar.scale, plain, data.values, 0, model.innovation_inv_cov)
    whitened = bank_block(ar.mean, ar.scale, model.bank, data.values, 0, None)
    np.testing.assert_allclose(whitened.nis, explicit.nis, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(whitened.est, explicit.est, rtol=0, atol=1e-10)


@pytest.mark.parametrize("shares_memory", [False, True])
def test_bank_run_in_time_blocks_equals_serial_run(fitted, shares_memory, two_thread_pool):
    """Blocks returned and copied (a cluster) or written in place (threads)."""
    det, model, data = fitted
    Y = np.array(data.values, copy=True)
    j = 4
    Y[:, j] = inject_fault(Y[:, j], RATE, "additive", 180.0, 3.0 * float(np.std(Y[:, j])))
    faulty = Dataset(Y, data.channels, RATE, data.train)
    serial = det.run(model, faulty, RunContext())
    pool = two_thread_pool(shares_memory)
    ctx = RunContext(jobs=2, executor=pool)
    blocked = det.run(model, faulty, ctx)
    assert pool.calls >= 1
    assert [(e.channel, e.type, e.onset_s) for e in blocked.events] == [
        (e.channel, e.type, e.onset_s) for e in serial.events
    ]
    assert serial.events and serial.events[0].channel == data.channels[j]
    for key, value in serial.events[0].magnitude.items():
        assert abs(blocked.events[0].magnitude[key] - value) <= 1e-9 * max(1.0, abs(value))
    for c in data.channels:
        a, b = serial.residuals[c], blocked.residuals[c]
        assert np.nanmax(np.abs(a - b)) <= 1e-9 * np.nanmax(np.abs(a))


def test_block_setting_is_checked():
    with pytest.raises(DetectorError, match="block"):
        ARKalmanBank(block=0)


def test_bank_equals_statsmodels_kalman_filter(fitted):
    """Every estimator of the stacked bank against statsmodels' KalmanFilter on the same
    model (companion form, Q = sigma through C', R = sigma of the measured channels) once
    statsmodels' time-varying gain has converged to the steady state."""
    sm = pytest.importorskip("statsmodels.tsa.statespace.kalman_filter")
    _, model, data = fitted
    ar = model.ar
    A, C = ar.companion()
    n_obs = 3000
    Y = np.asarray(data.values[:n_obs])
    plain = BankFilter.build(model.estimators, model.bank.block)
    ours = bank_block(ar.mean, ar.scale, plain, Y, 0, None)
    Z = (Y - ar.mean) / ar.scale
    assert sorted(e.left_out for e in model.estimators) == list(range(ar.m))
    for e in model.estimators:
        # the reference's inputs from the sensor left out, not from the bank's own list
        meas = [i for i in range(ar.m) if i != e.left_out]
        kf = sm.KalmanFilter(k_endog=len(meas), k_states=A.shape[0], k_posdef=ar.m)
        kf.bind(np.ascontiguousarray(Z[:, meas]))
        kf.design, kf.transition, kf.selection = C[meas], A, C.T
        kf.state_cov, kf.obs_cov = ar.sigma, ar.sigma[np.ix_(meas, meas)]
        kf.initialize_known(np.zeros(A.shape[0]), np.eye(A.shape[0]))
        res = kf.filter()
        k0 = int(res.period_converged) + e.settle
        nu = Z[:, meas] - (C[meas] @ np.asarray(res.predicted_state)[:, :n_obs]).T
        yhat = C[e.left_out] @ np.asarray(res.filtered_state)
        j = e.left_out
        assert np.abs(ours.innov[k0:, j] - nu[k0:]).max() < 1e-8
        est_scaled = (ours.est[:, j] - ar.mean[j]) / ar.scale[j]
        assert np.abs(est_scaled[k0:] - yhat[k0:]).max() < 1e-8


def test_each_estimate_is_blind_to_its_own_sensor_and_only_to_it(fitted):
    """Estimator ``j`` leaves out sensor ``j`` and measures every other: an offset of 50
    standard deviations added to sensor ``j`` leaves ``j``'s estimate as it was (to
    rounding) and moves every other sensor's estimate (test audit ux65 D5: a bank that
    left out the next sensor was caught only end to end, the statsmodels comparison
    above reading its inputs from the bank's own list)."""
    _, model, data = fitted
    ar = model.ar
    Y = np.array(data.values[:6000], copy=True)
    plain = BankFilter.build(model.estimators, model.bank.block)
    ref = bank_block(ar.mean, ar.scale, plain, Y, 0, None).est
    scale = float(np.max(np.abs(ref)))
    for j in range(ar.m):
        moved = Y.copy()
        moved[:, j] += 50.0 * ar.scale[j]
        est = bank_block(ar.mean, ar.scale, plain, moved, 0, None).est
        change = np.max(np.abs(est - ref), axis=0)
        assert change[j] <= 1e-9 * scale, (j, change)
        others = np.delete(change, j)
        assert np.all(others > 1e-3 * scale), (j, change)


def test_chunked_bank_block_equals_one_chunk(fitted, monkeypatch):
    """Chunks of the record (each with the impulse responses' history before it) and the
    in-place output give the outputs of one pass."""
    import analyzer.detectors.lti as lti
    from analyzer.detectors.kalman_bank import BankOutputs

    _, model, data = fitted
    ar, bank = model.ar, model.bank
    Y = np.array(data.values, copy=True)
    Y[7000:7050, 1] = np.nan
    whole = bank_block(ar.mean, ar.scale, bank, Y, 0, None)
    monkeypatch.setattr(lti, "CHUNK", 1000)
    N, m = Y.shape
    into = BankOutputs(np.zeros((N + 5, m)), np.zeros((N + 5, m)), np.zeros((N + 5, m)))
    bank_block(ar.mean, ar.scale, bank, Y, 0, None, into=into, at=5)
    for name in ("resid", "est", "nis"):
        ref, got = getattr(whole, name), getattr(into, name)[5:]
        assert np.array_equal(np.isnan(ref), np.isnan(got)), name
        assert np.nanmax(np.abs(got - ref)) <= 1e-12 * np.nanmax(np.abs(ref)), name


def test_estimate_outputs_alone_equal_the_whole_bank(fitted):
    """Without the consistency the bank runs its estimate outputs only: the same residuals
    and estimates (gaps and their masks included), and no consistency."""
    _, model, data = fitted
    ar, bank = model.ar, model.bank
    assert bank.estimates is not None and bank.estimates.k * bank.estimates.q == ar.m
    Y = np.array(data.values, copy=True)
    Y[7000:7050, 1] = np.nan
    whole = bank_block(ar.mean, ar.scale, bank, Y, 0, None)
    lean = bank_block(ar.mean, ar.scale, bank, Y, 0, None, consistency=False)
    assert lean.nis is None and lean.innov is None
    for name in ("resid", "est"):
        ref, got = getattr(whole, name), getattr(lean, name)
        assert np.array_equal(np.isnan(ref), np.isnan(got)), name
        assert np.nanmax(np.abs(got - ref)) <= 1e-12 * np.nanmax(np.abs(ref)), name


@pytest.mark.parametrize("pool", [None, "threads", "cluster"])
def test_consistency_windows_equal_the_whole_record_run(fitted, two_thread_pool, pool, monkeypatch):
    """The consistency recomputed over a window (pieces of a few rows, each after its
    warm-up; time blocks on a pool; with a gap, and with a correction of the record)
    equals the whole-record run's over the same rows."""
    import analyzer.detectors.ar_kalman as ak
    import analyzer.detectors.lti as lti

    det, model, data = fitted
    ctx = RunContext()
    if pool is not None:
        monkeypatch.setattr(lti, "MIN_TIME_BLOCK", 1)  # several time blocks per piece
        ctx = RunContext(jobs=2, executor=two_thread_pool(pool == "threads"))
    Y = np.array(data.values, copy=True)
    Y[12000:12030, 2] = np.nan
    whole = det._bank_outputs(model, Y, None)
    piece = ak.CONSISTENCY_PIECE
    try:
        ak.CONSISTENCY_PIECE = 2500  # several pieces in the window
        for lo, hi in [(0, 900), (11000, 19000), (29000, 30000)]:
            got = det._consistency(model, Y, [], lo, hi, ctx)
            ref = whole.nis[lo:hi]
            assert got.shape == ref.shape and got.dtype == ak.NIS_DTYPE
            assert np.array_equal(np.isnan(ref), np.isnan(got))
            np.testing.assert_allclose(got, ref, rtol=1e-5, atol=1e-6)
        # a correction: the window equals the run over the corrected record
        fixed = Y[15000:16000, 0] + 3.0
        fixes = [(0, 15000, 16000, fixed)]
        Yc = Y.copy()
        Yc[15000:16000, 0] = fixed
        ref = det._bank_outputs(model, Yc, None).nis[14000:18000]
        got = det._consistency(model, Y, fixes, 14000, 18000, ctx)
        np.testing.assert_allclose(got, ref, rtol=1e-5, atol=1e-6)
        assert np.array_equal(Y[15000:16000, 0], data.values[15000:16000, 0])  # input kept
        if pool is not None:
            assert ctx.executor.calls > 0
    finally:
        ak.CONSISTENCY_PIECE = piece


@pytest.mark.parametrize("gap", [False, True])
def test_calibration_from_kept_innovations_equals_filtering_again(fitted, gap, monkeypatch):
    """Pass 2 of the cross-validation from the innovations pass 1 kept, against filtering
    every fold again (what a bank too large for the memory budget does)."""
    det, model, data = fitted
    train = np.array(data.train_values(), dtype=np.float64)
    if gap:  # a gap masks rows of the consistency: kept innovations carry the same mask
        train[700:760, 2] = np.nan
    ar = model.ar
    kept = det._calibration_outputs(ar, model.estimators, train)
    monkeypatch.setattr(ar_kalman, "KEPT_INNOVATIONS_BYTES", 0)
    again = det._calibration_outputs(ar, model.estimators, train)
    assert kept[3] == again[3] == "5-fold out-of-sample"
    np.testing.assert_array_equal(kept[0], again[0])  # residuals: pass 1 in both
    assert np.array_equal(np.isnan(kept[1]), np.isnan(again[1]))
    if gap:
        assert np.isnan(kept[1][700:800]).all(axis=0).any()
    np.testing.assert_allclose(kept[1], again[1], rtol=1e-12, atol=0)


@pytest.mark.parametrize("gap", [False, True])
def test_long_folds_filtered_in_pieces_equal_one_pass(fitted, gap, monkeypatch):
    """A long fold is filtered a piece of FOLD_PIECE rows at a time, each after its own
    warm-up, in both passes (the bank's per-row outputs of a piece, not of the fold, are
    held): the same residuals, consistency and innovation covariances as one pass over
    each fold, to rounding (a gap straddling a piece's start masks the same rows)."""
    det, model, data = fitted
    train = np.array(data.train_values(), dtype=np.float64)
    if gap:
        train[990:1030, 1] = np.nan
    ar = model.ar
    monkeypatch.setattr(ar_kalman, "KEPT_INNOVATIONS_BYTES", 0)  # pass 2 filters again
    whole = det._calibration_outputs(ar, model.estimators, train)
    monkeypatch.setattr(ar_kalman, "FOLD_PIECE", 333)
    assert len(ar_kalman._fold_pieces(0, train.shape[0] // 5, 10)) > 2
    pieces = det._calibration_outputs(ar, model.estimators, train)
    for a, b in ((whole[0], pieces[0]), (whole[1], pieces[1])):
        assert np.array_equal(np.isnan(a), np.isnan(b))
        np.testing.assert_allclose(a, b, rtol=1e-7, atol=1e-10)
    for a, b in zip(whole[4], pieces[4], strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-9)


def test_one_estimators_consistency_equals_the_whole_banks(fitted, monkeypatch):
    """Estimator j's consistency from its own impulse responses (the bank's subset) equals
    column j of the whole bank's, with a gap masked for its settling time and with a
    correction of the record; over windows batched into shared passes; and its largest
    alarm statistic over a long stretch, taken a piece at a time, equals the one of the
    whole column."""
    import analyzer.detectors.ar_kalman as ak

    det, model, data = fitted
    Y = np.array(data.values, copy=True)
    Y[12000:12030, 2] = np.nan
    fixed = Y[15000:16000, 0] + 3.0
    fixes = [(0, 15000, 16000, fixed)]
    Yc = Y.copy()
    Yc[15000:16000, 0] = fixed
    whole = det._bank_outputs(model, Yc, None).nis
    m = Y.shape[1]
    monkeypatch.setattr(ak, "CONSISTENCY_PIECE", 2500)  # several pieces per stretch
    for j in (0, 2, m - 1):
        got = det._estimator_consistency(model, Y, fixes, j, 11000, 19000)
        ref = whole[11000:19000, j]
        assert got.dtype == ak.NIS_DTYPE and np.array_equal(np.isnan(ref), np.isnan(got))
        np.testing.assert_allclose(got, ref, rtol=1e-5, atol=1e-6)
        # windows: overlapping, adjacent, far apart, one inside another
        windows = [
            (9000, 9400),
            (9100, 9500),
            (9500, 9800),
            (14000, 14500),
            (14100, 14200),
            (20000, 27000),
            (28000, 29990),
        ]
        parts = list(det._window_consistency(model, Y, fixes, j, windows))
        assert [p.shape[0] for p in parts] == [b - a for a, b in windows]
        for (a, b), part in zip(windows, parts, strict=True):
            np.testing.assert_allclose(part, whole[a:b, j], rtol=1e-5, atol=1e-6)
        # the whole-period violation, 2500-row pieces with the windows' history carried
        for lo, hi in [(10000, 29000), (14000, 16500), (100, 2600)]:
            want = det._violation(model, whole[lo:hi, j], j)
            got_v = det._longest_violation(model, Y, fixes, j, lo, hi)
            assert got_v == pytest.approx(want, rel=1e-5, abs=1e-6)
    # the correction makes estimators that use channel 0 inconsistent: the check can fail
    assert max(det._violation(model, whole[14000:17000, j], j) for j in range(1, m)) > 1.0


def test_refiltering_after_a_correction_in_pieces_equals_one_pass(fitted, monkeypatch):
    """After isolating a fault the bank refilters the fault period (to the end of the
    record here) from corrected copies of its rows: in pieces of a few hundred rows, each
    after its own warm-up, it finds the same faults and the same residuals, to rounding,
    as in one piece; the input is never written."""
    import analyzer.detectors.ar_kalman as ak

    det, model, data = fitted
    Y = np.array(data.values, copy=True)
    Y[:, 1] = inject_fault(Y[:, 1], RATE, "additive", 150.0, 4.0 * np.std(Y[:, 1]))
    Y[:, 3] = inject_fault(Y[:, 3], RATE, "multiplicative", 220.0, 1.8)
    faulty = Dataset(Y, data.channels, RATE, data.train)
    kept = Y.copy()
    one = det.run(model, faulty, RunContext())
    monkeypatch.setattr(ak, "CONSISTENCY_PIECE", 700)
    pieces = det.run(model, faulty, RunContext())
    assert np.array_equal(Y, kept)
    assert [(e.channel, e.type) for e in pieces.events] == [(e.channel, e.type) for e in one.events]
    assert len(one.events) == 2
    for a, b in zip(one.events, pieces.events, strict=True):
        assert b.onset_s == pytest.approx(a.onset_s, abs=0.05)
        assert b.magnitude == pytest.approx(a.magnitude, rel=1e-6)
    for c in data.channels:
        ref = one.residuals[c]
        np.testing.assert_allclose(pieces.residuals[c], ref, atol=1e-5 * np.nanmax(np.abs(ref)))


@pytest.mark.parametrize("gap", [False, True])
def test_innovation_moments_taken_chunk_by_chunk_equal_the_stored_innovations(
    fitted, gap, monkeypatch
):
    """A long cross-validation fold takes its innovations' moments chunk by chunk instead
    of holding ``(N, m, m - 1)`` innovations: the same counts, sums and products (from
    the cold start's end on) as those of the stored innovations, across chunk edges and
    with a gap masked."""
    import analyzer.detectors.lti as lti

    monkeypatch.setattr(lti, "CHUNK", 700)  # many chunks over the block
    det, model, data = fitted
    ar = model.ar
    bank = BankFilter.build(model.estimators, model.estimators[0].block)
    Y = np.array(data.values[:9000], dtype=np.float64)
    if gap:
        Y[4000:4050, 1] = np.nan
    w, start = 300, 1234
    stored = bank_block(ar.mean, ar.scale, bank, Y, w, None)
    assert stored.innov is not None
    expect = kalman_bank.InnovationMoments(ar.m)
    expect.add(stored.innov[start:])
    got = kalman_bank.InnovationMoments(ar.m)
    chunked = bank_block(ar.mean, ar.scale, bank, Y, w, None, innov_moments=got, moments_from=start)
    assert chunked.innov is None
    np.testing.assert_array_equal(chunked.resid, stored.resid)
    np.testing.assert_array_equal(got.count, expect.count)
    if gap:  # the masked rows are left out, but not by the estimator without channel 1
        rows = Y.shape[0] - w - start
        assert got.count[1] == rows and (np.delete(got.count, 1) < rows).all()
    np.testing.assert_allclose(got.total, expect.total, rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(got.outer, expect.outer, rtol=1e-11, atol=0)
    for a, b in zip(got.inverse_covariances(), expect.inverse_covariances(), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=0)


def test_a_pickled_bank_keeps_its_markov_parameters_and_the_same_spectrum(fitted):
    """A pickle (a saved model, a task for a Dask worker) holds an impulse-response bank's
    Markov parameters, not its spectrum nor its cache of subsets: a fraction of the
    bytes, and the spectrum transformed again on loading is the same to the last bit, for
    the whole bank and for its selected estimate outputs; so are a run's outputs."""
    import pickle

    from analyzer.detectors.lti import ImpulseResponseBank

    det, model, data = fitted
    system, estimates = model.bank.system, model.bank.estimates
    assert isinstance(system, ImpulseResponseBank) and estimates is not None
    system.subset([0, 2])  # a cached subset is not saved
    for bank in (system, estimates):
        blob = pickle.dumps(bank, protocol=5)
        assert len(blob) < 0.5 * bank.spectrum.nbytes
        back = pickle.loads(blob)
        assert back.subsets == {}
        assert (back.taps, back.nfft, back.k, back.q) == (bank.taps, bank.nfft, bank.k, bank.q)
        assert np.array_equal(back.markov, bank.markov)
        assert np.array_equal(back.spectrum, bank.spectrum)  # bit for bit
    # the estimates are outputs of the whole bank: their spectrum is its columns
    last = [system.q - 1]
    assert np.array_equal(system.select(last).spectrum, estimates.spectrum)
    Y = np.asarray(data.values[:6000], dtype=np.float64)
    again = pickle.loads(pickle.dumps(model, protocol=5))
    one = det._bank_outputs(model, Y)
    two = det._bank_outputs(again, Y)
    for a, b in ((one.resid, two.resid), (one.est, two.est), (one.nis, two.nis)):
        assert np.array_equal(a, b, equal_nan=True)


@pytest.mark.parametrize("chunk", [300, 1000, 4096])
def test_gap_masks_made_chunk_by_chunk_equal_the_whole_block(fitted, monkeypatch, chunk):
    """The masks of a block with gaps are made chunk by chunk, each looking back the
    estimators' settling time (a boolean copy of the block, or all its memory-mapped
    pages at once, would grow with the block): an estimator's outputs are NaN exactly
    where one of its inputs is missing or was within its settling time, whatever the
    chunks; a residual also where its own sample is missing."""
    import analyzer.detectors.lti as lti
    from analyzer.detectors.base import dilate_forward

    _, model, data = fitted
    ar, bank = model.ar, model.bank
    Y = np.array(data.values, copy=True)
    step = max(chunk, 4 * bank.system.history)  # run_chunked's chunks
    Y[7000:7050, 1] = np.nan
    Y[step - 3 : step + 2, 4] = np.nan  # across a chunk's edge
    Y[2 * step - 20 : 2 * step - 10, 2] = np.nan  # its settling time across the next
    Y[21000, 0] = np.inf
    gap = ~np.isfinite(Y)
    n_gap = gap.sum(axis=1)
    bad = np.column_stack(
        [dilate_forward((n_gap - gap[:, j]) > 0, bank.settle[j]) for j in range(Y.shape[1])]
    )
    assert min(bank.settle) > 10  # settling times that cross chunks' edges
    monkeypatch.setattr(lti, "CHUNK", chunk)
    out = bank_block(ar.mean, ar.scale, bank, Y, 0, None, consistency=False)
    assert np.array_equal(np.isnan(out.est), bad)
    assert np.array_equal(np.isnan(out.resid), bad | gap)
