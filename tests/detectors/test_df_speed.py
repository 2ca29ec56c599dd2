"""The fast paths of the detection-filter and equivalent-model detectors against the
straightforward computations they replace: the bank run as impulse responses by FFT (and
its stacked lifted fallback) against each filter's own lifted run, the streamed run
outputs against the full residual vectors, the shared PBH tests of conjugate eigenvalues,
and the sliding-window least squares of the relations against ``lstsq``."""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy import signal

import analyzer.detectors.lti as lti
from analyzer import paging
from analyzer.detectors import beard_jones as bjm
from analyzer.detectors import detection_filter as dfm
from analyzer.detectors import state_space as ssm
from analyzer.detectors.assistant_observer import fit_relation
from analyzer.detectors.base import Dataset, RunContext
from analyzer.detectors.beard_jones import filter_bank, park_filter, unobservable_modes
from analyzer.detectors.detection_filter import DetectionFilter
from analyzer.detectors.lti import ImpulseResponseBank, StackedLiftedSystem, run_chunked
from analyzer.simulate import simulate_building

RATE = 200.0
TRAIN = (0, int(15 * RATE))


def _bank(seed, n=6, m=4, sigma=0.9):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    A *= 0.9 / np.max(np.abs(np.linalg.eigvals(A)))
    B, C, D = np.zeros((n, 0)), rng.standard_normal((m, n)), np.zeros((m, 0))
    Q, R = np.eye(n), np.eye(m)
    return [park_filter(A, B, C, D, i, Q, R, sigma=sigma) for i in range(m)]


def _collect(bank, v):
    parts = list(bank.run(v))
    starts = [s for s, _ in parts]
    assert starts == sorted(starts) and starts[0] == 0
    return np.concatenate([y for _, y in parts], axis=2)


@pytest.mark.parametrize("seed", [0, 1])
def test_impulse_response_bank_equals_each_filters_lifted_run(seed, monkeypatch):
    monkeypatch.setattr(lti, "CHUNK", 3000)  # several chunks over the record
    filters = _bank(seed)
    v = np.random.default_rng(seed + 10).standard_normal((10007, filters[0].n_outputs))
    bank = filter_bank(filters)
    assert isinstance(bank, ImpulseResponseBank)
    out = _collect(bank, v)
    for i, f in enumerate(filters):
        ref = f.run(v)
        assert np.max(np.abs(out[i].T - ref)) <= 1e-10 * np.max(np.abs(ref))


def test_long_memory_falls_back_to_the_stacked_lifted_system(monkeypatch):
    monkeypatch.setattr(lti, "CHUNK", 1000)
    filters = _bank(2, sigma=0.999)  # the fault estimate remembers ~1e4 samples
    systems = [(f.F, f.G, f.H, f.J) for f in filters]
    assert ImpulseResponseBank.build(systems) is None
    bank = filter_bank(filters)
    assert bank.history is None
    v = np.random.default_rng(3).standard_normal((5003, filters[0].n_outputs))
    out = _collect(bank, v)
    stacked, _ = StackedLiftedSystem.build(systems, 16).run(v)
    assert np.allclose(out, stacked.transpose(1, 2, 0), rtol=0, atol=1e-12)
    for i, f in enumerate(filters):
        ref = f.run(v)
        assert np.max(np.abs(out[i].T - ref)) <= 1e-10 * np.max(np.abs(ref))
    # a stretch recomputed alone equals the same stretch of the whole run
    assert np.allclose(bank_segment(bank, v, 2100, 2130), out[:, :, 2100:2130], atol=1e-12)


def bank_segment(bank, v, lo, hi):
    """Outputs ``(k, q, hi - lo)`` of the bank over samples ``lo .. hi - 1`` of the run over
    ``v``, as :func:`~analyzer.detectors.lti.run_chunked` gives them from ``lo`` (the
    detection filter's isolation and streamed runs start there), recomputed from the
    input the bank remembers only."""
    parts = [y for _, y in run_chunked(bank, lambda a, b: v[a:b], hi, lo)]
    return np.concatenate(parts, axis=2)


@pytest.mark.parametrize(("lo", "hi"), [(0, 5), (1, 40), (2990, 3020), (9990, 10007)])
def test_bank_segment_equals_the_whole_run(lo, hi, monkeypatch):
    monkeypatch.setattr(lti, "CHUNK", 3000)
    filters = _bank(4)
    v = np.random.default_rng(5).standard_normal((10007, filters[0].n_outputs))
    bank = filter_bank(filters)
    out = _collect(bank, v)
    seg = bank_segment(bank, v, lo, hi)
    assert seg.shape == (len(filters), filters[0].n_outputs + 2, hi - lo)
    assert np.max(np.abs(seg - out[:, :, lo:hi])) <= 1e-12 * np.max(np.abs(out))


def _fitted_filter(duration_s, seed):
    """A detection filter fitted on a simulated 4-floor building, and the record."""
    _, Y, names = simulate_building(n_floors=4, duration_s=duration_s, rate_hz=RATE, seed=seed)
    det = DetectionFilter()
    return det, det.fit(Dataset(Y, tuple(names), RATE, TRAIN), RunContext()), Y


def test_streamed_run_outputs_equal_the_full_residual_vectors(monkeypatch):
    """``_run_outputs`` (chunked, residual vectors reduced to their off-direction statistic)
    against ``_outputs`` (every residual vector kept), with a gap in the record."""
    det, model, Y = _fitted_filter(40.0, seed=7)
    Yg = Y.copy()
    Yg[5000:5040, 2] = np.nan
    full = det._outputs(model.model, model.filters, Yg)
    monkeypatch.setattr(lti, "CHUNK", 1500)  # several chunks, each with its history
    zeta, ref, nis, bad = det._run_outputs(model, Yg)
    assert bad[5000:5040].all() and not bad[:5000].any()
    for i, (q, z, r) in enumerate(full):
        np.testing.assert_allclose(zeta[i], z, rtol=1e-10, atol=1e-12)
        # kept centred and scaled in float32: back in sensor units to single precision
        assert ref.dtype == np.float32
        in_units = ref[i] * model.model.y_scale[i] + model.model.y_mean[i]
        np.testing.assert_allclose(in_units, r, rtol=0, atol=1e-6 * model.model.y_scale[i])
        off = np.delete(q, i, axis=1)
        inv = model.direction_inv_cov[i]
        expect = np.einsum("ki,ij,kj->k", off, inv, off) / off.shape[1]
        assert nis.dtype == np.float32  # kept in single precision (alarm statistics only)
        np.testing.assert_allclose(nis[i], expect, rtol=2e-7, atol=1e-12)
        assert np.isnan(zeta[i, 5000:5040]).all() and np.isfinite(zeta[i, :5000]).all()
        # rebuilt from the data around the stretch only (across the gap, and far in)
        seg = det._residual_vectors(model, i, Yg, bad, 4990, 5010)
        np.testing.assert_allclose(seg, q[4990:5010], rtol=1e-10, atol=1e-12)
        seg = det._residual_vectors(model, i, Yg, bad, 7000, 7030)
        np.testing.assert_allclose(seg, q[7000:7030], rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("start", [0, 3000, 5045, 6000])
def test_outputs_from_a_start_row_equal_the_whole_run(start):
    """The calibration's held-out halves filter only the rows they evaluate (and the
    history before them): the same outputs as a run from row 0, also just after a gap."""
    det, model, Y = _fitted_filter(40.0, seed=7)
    Yg = Y.copy()
    Yg[5000:5040, 2] = np.nan
    full = det._outputs(model.model, model.filters, Yg[:7000])
    part = det._outputs(model.model, model.filters, Yg[:7000], start=start)
    for (q, z, r), (qp, zp, rp) in zip(full, part, strict=True):
        assert qp.shape == q[start:].shape
        for a, b in ((q[start:], qp), (z[start:], zp), (r[start:], rp)):
            assert np.array_equal(np.isnan(a), np.isnan(b))
            np.testing.assert_allclose(b, a, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("shares_memory", [True, False])
def test_run_outputs_in_time_blocks_equal_the_serial_run(
    shares_memory, monkeypatch, two_thread_pool
):
    """With a parallel executor the bank runs in time blocks (each from the history it
    remembers), written in place (threads) or returned and copied (a cluster): the serial
    outputs to rounding, gap mask included."""
    det, model, Y = _fitted_filter(60.0, seed=3)
    Yg = Y.copy()
    Yg[9000:9030, 1] = np.nan
    monkeypatch.setattr(lti, "MIN_TIME_BLOCK", 2)  # several blocks on a short record
    serial = det._run_outputs(model, Yg)
    pool = two_thread_pool(shares_memory)
    ctx = RunContext(jobs=2, executor=pool)
    blocked = det._run_outputs(model, Yg, ctx)
    assert pool.calls == 1
    np.testing.assert_array_equal(blocked[3], serial[3])
    for a, b in zip(blocked[:3], serial[:3], strict=True):
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-10 * np.nanmax(np.abs(b)))


def test_conjugate_eigenvalues_share_their_pbh_test():
    rng = np.random.default_rng(8)
    # a complex pair and a real mode that C does not see, plus observable modes
    T = rng.standard_normal((5, 5))
    blocks = np.zeros((5, 5))
    blocks[:2, :2] = [[0.5, -0.4], [0.4, 0.5]]
    blocks[2, 2], blocks[3:, 3:] = 0.3, [[0.1, 0.7], [-0.7, 0.1]]
    A = T @ blocks @ np.linalg.inv(T)
    C = rng.standard_normal((2, 5))
    C -= (C @ T[:, :3]) @ np.linalg.pinv(T[:, :3])  # C v = 0 on the first three modes
    found = unobservable_modes(A, C)
    brute = []
    for lam in np.linalg.eigvals(A):
        pbh = np.vstack([A - lam * np.eye(5), C.astype(np.complex128)])
        smin = np.linalg.svd(pbh, compute_uv=False)[-1]
        scale = max(1.0, np.linalg.norm(A, 2) + np.linalg.norm(C, 2))
        if smin <= bjm.PBH_RTOL * scale:
            brute.append(complex(lam))
    assert found == brute
    assert sorted(np.round(np.abs(found), 6)) == [0.3, 0.640312, 0.640312]


def test_fit_relation_equals_lstsq_on_the_lagged_matrix():
    rng = np.random.default_rng(9)
    X = rng.standard_normal((4000, 3))
    y = 0.2 + signal.lfilter([0.5, -0.3, 0.2, 0.1], 1, X[:, 0]) - 0.4 * X[:, 2]
    y += 0.1 * rng.standard_normal(4000)
    V = np.column_stack([X, y])
    V[100:103, 0] = np.nan
    V[2000, 3] = np.nan
    L = 5
    rel = fit_relation(V, 3, [0, 2], lags=L)
    rows = np.arange(L, 4000)
    M = np.column_stack(
        [np.ones(rows.size)] + [V[rows - g, j] for j in (0, 2) for g in range(L + 1)]
    )
    t = V[rows, 3]
    ok = np.isfinite(M).all(axis=1) & np.isfinite(t)
    coef = np.linalg.lstsq(M[ok], t[ok], rcond=None)[0]
    assert rel.intercept == pytest.approx(coef[0], abs=1e-8)
    np.testing.assert_allclose(rel.coef.ravel(), coef[1:], atol=1e-8)


@pytest.mark.parametrize("shares_memory", [None, True, False])
def test_estimates_alone_and_direction_windows_equal_the_full_run(
    shares_memory, monkeypatch, two_thread_pool
):
    """Without the direction statistic the bank runs its two estimate outputs per filter
    only (serially, on threads, on a cluster): the same estimates and gap rows. The
    alarm statistics of the direction statistic recomputed over a window equal those of
    the whole-record direction statistic there, sample by sample (gap included)."""
    from analyzer.diagnosis.changes import alarm_statistic

    det, model, Y = _fitted_filter(60.0, seed=5)
    Yg = Y.copy()
    Yg[9000:9030, 1] = np.nan
    zeta, ref, nis, bad = det._run_outputs(model, Yg)
    ctx = None
    if shares_memory is not None:
        monkeypatch.setattr(lti, "MIN_TIME_BLOCK", 2)  # several blocks on a short record
        ctx = RunContext(jobs=2, executor=two_thread_pool(shares_memory))
    bank = filter_bank(model.filters)
    z2, r2, n2, b2 = det._run_outputs(model, Yg, ctx, directions=False, bank=bank)
    assert n2 is None
    np.testing.assert_array_equal(b2, bad)
    for a, b in ((z2, zeta), (r2, ref)):
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
        np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-9 * np.nanmax(np.abs(b)))
    stats = [alarm_statistic(nis[i], model.direction_cal[i], raw=True) for i in range(len(nis))]
    windows = [(10, 700), (8600, 9600), (11000, 11900)]
    for lo, hi in windows:
        got = det._direction_statistics(model, bank, Yg, bad, lo, hi)
        for g, s in zip(got, stats, strict=True):
            np.testing.assert_allclose(g, s[lo:hi], rtol=1e-5, atol=1e-7)
    # each filter's largest statistic over each window, every sample computed once over
    # the windows' union in stretches (overlapping, adjacent, nested, far apart windows;
    # stretches shorter than some windows): the maxima of the per-window statistics
    n = Yg.shape[0]
    windows += [(9000, 9500), (9500, 9800), (9200, 9300), (11500, n - 200), (n - 100, n)]
    windows += [(300, 9700), (9600, 9600)]
    monkeypatch.setattr(dfm, "DIRECTION_BATCH", 1500)
    got = det._window_violations(model, bank, Yg, bad, windows, ctx)
    assert len(got) == len(windows)
    # the stretches on the context's threads (or one after the other on a cluster's
    # context): the same maxima as one after the other here
    assert got == det._window_violations(model, bank, Yg, bad, windows)
    for (lo, hi), viol in zip(windows, got, strict=True):
        each = det._direction_statistics(model, bank, Yg, bad, lo, hi) if hi > lo else []
        want = [float(np.max(st, initial=0.0)) for st in each] or [0.0] * len(stats)
        assert viol == pytest.approx(want, rel=1e-5, abs=1e-7), (lo, hi)
    assert max(max(v) for v in got) > 0.1  # the statistics are not all zero


def _ar_innovations(seed, m=4, p=3, radius=0.9):
    """A random stable AR model's innovations form in block observer form, with the
    noise covariances :func:`model_from_ar` gives it (``Q = K R K'``, ``S = K R``)."""
    rng = np.random.default_rng(seed)
    coefs = rng.standard_normal((p, m, m)) / (m * p)
    A, C, K = ssm.ar_observer_form(SimpleNamespace(order=p, m=m, coefs=coefs))
    rho = np.max(np.abs(np.linalg.eigvals(A)))
    coefs = coefs * np.array([(radius / rho) ** (j + 1) for j in range(p)])[:, None, None]
    A, C, K = ssm.ar_observer_form(SimpleNamespace(order=p, m=m, coefs=coefs))
    L = rng.standard_normal((m, m))
    R = L @ L.T + 0.5 * np.eye(m)  # correlated innovations
    return A, C, K, K @ R @ K.T, R, K @ R


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_observer_pbh_bound_is_below_the_smallest_singular_value(seed):
    """The cheap bound that lets the PBH tests skip their SVD never exceeds the smallest
    singular value it stands for: at the modes, at arbitrary complex points (far ones
    included) and, for the augmented pair, at the fault pole (also at a mode of A)."""
    A, C, _, _, _, _ = _ar_innovations(seed, m=3, p=4)
    n, m = A.shape[0], C.shape[0]
    blocks = bjm.observer_blocks(A, C)
    assert blocks is not None and blocks.shape == (4, 3, 3)
    rng = np.random.default_rng(seed + 20)
    lams = np.concatenate(
        [np.linalg.eigvals(A), rng.standard_normal(20) + 1j * rng.standard_normal(20), [3.0, -7.5j]]
    )
    bound = bjm.observer_pbh_bound(blocks, lams)
    for lam, b in zip(lams, bound, strict=True):
        smin = np.linalg.svd(np.vstack([A - lam * np.eye(n), C]), compute_uv=False)[-1]
        assert 0.0 <= b <= smin * (1 + 1e-12)
    assert np.all(bound[:n] > 1e-3)  # informative at the modes of a stable model
    for alpha in (1.0, 0.5, float(np.real(lams[np.argmin(np.abs(lams[:n].imag))]))):
        for i in range(m):
            Ab, _, Cb, _ = bjm.augment(A, np.zeros((n, 0)), C, i, alpha)
            smin = np.linalg.svd(np.vstack([Ab - alpha * np.eye(n + 1), Cb]), compute_uv=False)[-1]
            b = bjm.observer_pbh_bound(blocks, [alpha], i)[0]
            assert 0.0 <= b <= smin * (1 + 1e-12)
    assert bjm.observer_blocks(A + 1e-3 * np.eye(n), C) is None  # not the structure
    assert bjm.observer_blocks(A, C[::-1]) is None


def test_observer_form_pbh_test_equals_the_svd_test():
    """With a threshold that flags some modes, the certified skips leave the answer of
    the SVD test unchanged."""
    A, C, _, _, _, _ = _ar_innovations(3, m=3, p=4)
    n = A.shape[0]
    modes = np.linalg.eigvals(A)
    scale = max(1.0, np.linalg.norm(A, 2) + np.linalg.norm(C, 2))
    smins = np.array(
        [np.linalg.svd(np.vstack([A - lam * np.eye(n), C]), compute_uv=False)[-1] for lam in modes]
    )
    for rtol in (bjm.PBH_RTOL, float(np.median(smins)) / scale, 2.0 * smins.max() / scale):
        brute = [complex(lam) for lam, s in zip(modes, smins, strict=True) if s <= rtol * scale]
        assert unobservable_modes(A, C, rtol=rtol) == brute
    assert unobservable_modes(A, C) == []


def _general_design(monkeypatch, *args, **kwargs):
    """``park_filter`` without the observer-form shortcuts (dense Riccati, eigenvalues
    and SVDs): the straightforward design."""
    with monkeypatch.context() as mp:
        mp.setattr(bjm, "observer_blocks", lambda A, C: None)
        return park_filter(*args, **kwargs)


@pytest.mark.parametrize(
    ("seed", "m", "p", "sigma", "drop"),
    [(0, 4, 3, 0.5, None), (1, 3, 5, 0.9, None), (2, 4, 3, 0.5, 1), (4, 2, 10, 0.05, None)],
)
def test_ar_reduced_design_equals_the_general_design(seed, m, p, sigma, drop, monkeypatch):
    """For an AR model's innovations form the detection gain comes from a Riccati
    equation of ``p`` states and the spectral radius from the ``p``-state closed loop
    (:func:`_ar_state_gain`): the same filter as the ``n``-state design, also when the last
    AR coefficient ignores the sensor (the lag basis loses rank) and when a small radius
    falls back to the dense eigenvalues."""
    A, C, K, Q, R, S = _ar_innovations(seed, m=m, p=p, radius=0.1 if sigma < 0.1 else 0.9)
    n = A.shape[0]
    if drop is not None:  # A_p e_drop = 0
        A[(p - 1) * m :, drop] = 0.0
        K = A[:, :m].copy()
        Q, S = K @ R @ K.T, K @ R
    B, D = np.zeros((n, 0)), np.zeros((m, 0))
    assert bjm._innovations_form(A, Q, R, S)
    assert not bjm._innovations_form(A, Q + 1e-6 * np.eye(n), R, S)
    floor = 4.0 * 1e-12 ** (1.0 / p)  # below it the dense eigenvalues are taken
    blocks = bjm.observer_blocks(A, C)
    for i in range(m):
        rho_x = bjm._ar_state_gain(A, blocks, R, i)[2]
        assert (max(rho_x, sigma) < floor) == (sigma < 0.1)  # each branch is exercised
        fast = park_filter(A, B, C, D, i, Q, R, S, sigma=sigma)
        ref = _general_design(monkeypatch, A, B, C, D, i, Q, R, S, sigma=sigma)
        for a, b in ((fast.F, ref.F), (fast.G, ref.G), (fast.H, ref.H), (fast.J, ref.J)):
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-11)
        assert fast.spectral_radius == pytest.approx(ref.spectral_radius, rel=1e-9)
        dense = float(np.max(np.abs(np.linalg.eigvals(fast.closed_loop))))
        assert fast.spectral_radius == pytest.approx(dense, rel=1e-9)
        assert fast.settle() == ref.settle()


def test_ar_detector_fit_equals_the_general_design(monkeypatch):
    """The detector's fit on an AR model (bank and held-out calibration) with the
    observer-form shortcuts gives the filters and thresholds of the general design."""
    det, fast, Y = _fitted_filter(40.0, seed=11)
    monkeypatch.setattr(bjm, "observer_blocks", lambda A, C: None)
    ref = det.fit(Dataset(Y, tuple(fast.model.summary["outputs"]), RATE, TRAIN), RunContext())
    for a, b in zip(fast.filters, ref.filters, strict=True):
        np.testing.assert_allclose(a.F, b.F, rtol=1e-9, atol=1e-11)
        np.testing.assert_allclose(a.G, b.G, rtol=1e-9, atol=1e-11)
        assert a.spectral_radius == pytest.approx(b.spectral_radius, rel=1e-9)
    for a, b in zip(
        fast.zeta_cal + fast.direction_cal, ref.zeta_cal + ref.direction_cal, strict=True
    ):
        da, db = a.as_dict(), b.as_dict()
        assert da.keys() == db.keys()
        for key in da:
            np.testing.assert_allclose(np.asarray(da[key]), np.asarray(db[key]), rtol=1e-6)


@pytest.mark.parametrize(
    ("gap", "mapped", "keep"),
    [
        (False, False, False),
        (True, False, False),
        (True, True, False),
        (False, False, True),
        (True, False, True),
        (True, True, True),
    ],
)
def test_streamed_calibration_equals_the_kept_residual_vectors(
    gap, mapped, keep, monkeypatch, tmp_path
):
    """The calibration streams each healthy stretch's outputs (fault estimates kept,
    residual vectors reduced to their moments, then either kept off their own directions
    (``keep``) or run again for their normalized squares) instead of holding every
    filter's outputs: the same numbers as ``_outputs`` and ``np.cov`` / ``np.std`` / the
    squares of the kept vectors, across chunk edges and a gap; written into a
    memory-mapped buffer (``mapped``: a long archive's) or into a new array."""
    det, model, Y = _fitted_filter(40.0, seed=7)
    Yg = Y[:7000].copy()
    if gap:
        Yg[3000:3040, 1] = np.nan
    monkeypatch.setattr(lti, "CHUNK", 900)  # several chunks, each with its history
    monkeypatch.setattr(dfm, "CALIBRATION_ROWS", 1000)  # gaps found block by block
    start = 1500
    seg = dfm._Segment(model.model, model.filters, Yg, start)
    k = len(model.filters)

    def into(name):
        return paging.buffer(tmp_path, name, (Yg.shape[0] - start, k)) if mapped else None

    zetas, moments, offs = dfm._moments_task((seg, into("z"), keep))
    assert paging.is_mapped(zetas) == mapped
    assert (offs is not None) == keep
    zetas = zetas.T  # filter i's series: row i
    full = det._outputs(model.model, model.filters, Yg, start=start)
    inv_covs = []
    for i, (q, z, _) in enumerate(full):
        assert np.array_equal(np.isnan(zetas[i]), np.isnan(z))
        np.testing.assert_allclose(zetas[i], z, rtol=1e-10, atol=1e-12)
        good = np.isfinite(q).all(axis=1)
        assert moments[i].n == good.sum()
        assert good.all() != gap  # a gap masks rows (and the settling after it)
        off = np.delete(q[good], i, axis=1)
        cov = np.delete(np.delete(moments[i].m2, i, 0), i, 1) / (moments[i].n - 1)
        np.testing.assert_allclose(cov, np.cov(off.T), rtol=1e-9, atol=0)
        std = np.sqrt(np.diag(moments[i].m2) / moments[i].n)
        np.testing.assert_allclose(std, np.nanstd(q, axis=0), rtol=1e-10, atol=0)
        inv_covs.append(np.linalg.pinv(cov))
    if gap:
        assert moments[0].n < Yg.shape[0] - start
    if keep:
        for i, (q, _, _) in enumerate(full):
            off = np.delete(q, i, axis=1)
            assert np.array_equal(np.isnan(offs[i]), np.isnan(off))
            np.testing.assert_allclose(offs[i], off, rtol=1e-10, atol=1e-12)
    nis = dfm._nis_task((seg, tuple(inv_covs), into("nis"), offs)).T
    for i, (q, _, _) in enumerate(full):
        expect = dfm._nis(np.delete(q, i, axis=1), inv_covs[i])
        assert np.array_equal(np.isnan(nis[i]), np.isnan(expect))
        np.testing.assert_allclose(nis[i], expect, rtol=1e-10, atol=1e-12)
    # the merged moments of two stretches are the moments of both
    both = dfm.RowMoments.merged([moments[0], moments[0]])
    assert both.n == 2 * moments[0].n
    np.testing.assert_allclose(both.mean, moments[0].mean, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(both.m2, 2 * moments[0].m2, rtol=1e-12, atol=0)


def test_fit_from_kept_residual_vectors_equals_running_the_bank_again(monkeypatch):
    """Pass 2 of the calibration from the residual vectors pass 1 kept (the default for a
    10-minute window) against running the bank over the held-out halves again (what a
    training window too long for KEPT_RESIDUALS_BYTES does): the same thresholds."""
    _, Y, names = simulate_building(n_floors=4, duration_s=40.0, rate_hz=RATE, seed=11)
    data = Dataset(Y, tuple(names), RATE, TRAIN)
    calls = []
    real = dfm._segment_chunks

    def counted(seg):
        calls.append(seg.start)
        return real(seg)

    monkeypatch.setattr(dfm, "_segment_chunks", counted)
    kept = DetectionFilter().fit(data, RunContext())
    assert len(calls) == 2  # pass 1 over each held-out half, no pass 2
    monkeypatch.setattr(dfm, "KEPT_RESIDUALS_BYTES", 0)
    again = DetectionFilter().fit(data, RunContext())
    assert len(calls) == 6  # both passes over each half
    assert kept.zeta_cal == again.zeta_cal
    for a, b in zip(kept.direction_cal, again.direction_cal, strict=True):
        assert (a.window, a.windows) == (b.window, b.windows)
        for x, y in (
            (a.mean, b.mean),
            (a.std, b.std),
            (a.mean_sd, b.mean_sd),
            (a.logq_mean, b.logq_mean),
            (a.logq_sd, b.logq_sd),
        ):
            np.testing.assert_allclose(x, y, rtol=1e-12, atol=0)
