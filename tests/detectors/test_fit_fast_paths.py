"""The bank's fitting fast paths against their straightforward forms: the AR fit and the
order selection from lagged cross-products (no design matrix) against least squares on
the explicit design matrix, with gaps; the DARE solved by Newton's method from a nearby
solution against scipy's QZ solver; a cross-validation fold's estimators, one Newton step
from the whole model's solutions, against the same estimators solved to convergence."""

from functools import partial

import numpy as np
import pytest
from scipy import linalg

import analyzer.detectors.ar_model as arm
from analyzer.detectors import riccati
from analyzer.detectors.ar_model import fit_ar
from analyzer.detectors.kalman_bank import solved_leave_one_out
from analyzer.detectors.riccati import solve_dare
from analyzer.simulate import simulate_building


@pytest.fixture(scope="module")
def building():
    _, Y, _ = simulate_building(n_floors=3, duration_s=60.0, seed=7, sensors_per_floor=2)
    return Y


def _with_gaps(Y):
    """Gaps of every kind: one channel, all channels, a stretch shorter than the order
    between two gaps, and a gap at each end."""
    Y = np.array(Y, dtype=np.float64, copy=True)
    Y[:3, 1] = np.nan
    Y[500:510, 2] = np.nan
    Y[900:1000] = np.nan
    Y[1003:1040] = np.nan  # leaves 3 finite rows between two gaps
    Y[-5:, 0] = np.nan
    return Y


def _design(Z, p):
    """Targets and lags 1..p as explicit rows, without the rows with a NaN in any lag."""
    n = Z.shape[0]
    T = Z[p:]
    X = np.hstack([Z[p - i : n - i] for i in range(1, p + 1)])
    ok = np.isfinite(T).all(axis=1) & np.isfinite(X).all(axis=1)
    return T[ok], X[ok]


def _reference_fit(Y, p):
    """fit_ar's quantities by np.linalg.lstsq on the explicit design matrix."""
    mean = np.nanmean(Y, axis=0)
    scale = np.nanstd(Y, axis=0)
    T, X = _design((Y - mean) / scale, p)
    B = np.linalg.lstsq(X, T, rcond=None)[0]
    E = T - X @ B
    N, k = X.shape
    coefs = B.T.reshape(Y.shape[1], p, Y.shape[1]).transpose(1, 0, 2)
    logdet = np.linalg.slogdet(E.T @ E / N)[1]
    return coefs, E.T @ E / (N - k), N, logdet + np.log(N) * k * Y.shape[1] / N


def _assert_fit_equals_reference(ar, Y, p):
    coefs, sigma, N, bic = _reference_fit(Y, p)
    assert ar.n_train == N
    np.testing.assert_allclose(ar.coefs, coefs, rtol=0, atol=1e-9 * np.abs(coefs).max())
    np.testing.assert_allclose(ar.sigma, sigma, rtol=0, atol=1e-9 * np.abs(sigma).max())
    assert ar.bic == pytest.approx(bic, rel=1e-9, abs=1e-9)


@pytest.mark.parametrize("gaps", [False, True])
def test_lagged_gram_equals_the_design_matrix_gram(building, gaps):
    Y = _with_gaps(building) if gaps else building
    Z = (Y - np.nanmean(Y, axis=0)) / np.nanstd(Y, axis=0)
    p = 4
    segments = arm._finite_segments(Z, p)
    assert segments is not None and len(segments) == (3 if gaps else 1)  # 3 rows: none
    T, X = _design(Z, p)
    M = np.hstack([T, X])
    ref = M.T @ M
    G = arm._lagged_gram(Z, p, segments)
    np.testing.assert_allclose(G, ref, rtol=0, atol=1e-11 * np.abs(ref).max())


@pytest.mark.parametrize("gaps", [False, True])
def test_fit_from_lagged_products_equals_least_squares(building, gaps):
    Y = _with_gaps(building) if gaps else building
    _assert_fit_equals_reference(fit_ar(Y, 5), Y, 5)


def test_fit_with_many_gaps_takes_the_design_matrix(building, monkeypatch):
    Y = _with_gaps(building)
    Y[2000::97, 3] = np.nan  # dozens of short gaps
    assert arm._finite_segments(Y, 5) is None
    used = []
    real = arm._lagged
    monkeypatch.setattr(arm, "_lagged", lambda *a: used.append(1) or real(*a))
    _assert_fit_equals_reference(fit_ar(Y, 5), Y, 5)
    assert used  # the design matrix was built


def test_nearly_perfect_fit_takes_its_residuals_by_rows(building, monkeypatch):
    rng = np.random.default_rng(5)
    Y = np.array(building, copy=True)
    # channel 0 follows the others one sample later, to 1e-5 of its spread (order 1:
    # its own lag is not in the regression, which stays well conditioned)
    Y[1:, 0] = Y[:-1, 1] - 0.5 * Y[:-1, 2]
    Y[:, 0] += 1e-5 * np.std(Y[:, 0]) * rng.normal(size=Y.shape[0])
    Z = (Y - Y.mean(axis=0)) / Y.std(axis=0)
    G = arm._lagged_gram(Z, 1, arm._finite_segments(Z, 1))
    m = Y.shape[1]
    B = arm._normal_equations(G[m:, m:], G[m:, :m])
    assert B is not None
    assert arm._residual_gram(G, B) is None  # would cancel too many digits
    rows = []
    real = arm._ar_residuals
    monkeypatch.setattr(arm, "_ar_residuals", lambda *a: rows.append(1) or real(*a))
    _assert_fit_equals_reference(fit_ar(Y, 1), Y, 1)
    assert rows


def test_ill_conditioned_fit_takes_pivoted_qr(building):
    rng = np.random.default_rng(8)
    Y = np.array(building, copy=True)
    # (1e-5 of its own noise: ill-conditioned for the normal equations, but not a copy;
    # at 1e-7 the fit refuses it as one, ar_model.NEAR_SINGULAR)
    Y[:, 0] = Y[:, 1] + 1e-5 * np.std(Y[:, 1]) * rng.normal(size=Y.shape[0])
    Z = (Y - Y.mean(axis=0)) / Y.std(axis=0)
    G = arm._lagged_gram(Z, 3, arm._finite_segments(Z, 3))
    m = Y.shape[1]
    assert arm._normal_equations(G[m:, m:], G[m:, :m]) is None
    # as before: pivoted QR on the design matrix
    T, X = _design(Z, 3)
    B = linalg.lstsq(X, T, lapack_driver="gelsy")[0]
    E = T - X @ B
    ar = fit_ar(Y, 3)
    np.testing.assert_allclose(ar.coefs, B.T.reshape(m, 3, m).transpose(1, 0, 2), rtol=1e-12)
    np.testing.assert_allclose(ar.sigma, E.T @ E / (X.shape[0] - X.shape[1]), rtol=1e-12)


def _reference_criteria(Y, criterion, max_order):
    """Order selection as before: QR of the explicit [X T] of the largest order."""
    n, m = Y.shape
    orders = [p for p in range(1, max_order + 1) if arm.required_samples(p, m) <= n]
    Z = (Y - np.nanmean(Y, axis=0)) / np.nanstd(Y, axis=0)
    pmax = orders[-1]
    T, X = _design(Z, pmax)
    R = linalg.qr(np.hstack([X, T]), mode="r")[0]
    k, N = X.shape[1], X.shape[0]
    vals = []
    for p in orders:
        rest = R[p * m : k, k:]
        resid = rest.T @ rest + R[k : k + m, k:].T @ R[k : k + m, k:]
        pen = 2.0 if criterion == "aic" else np.log(N)
        vals.append(np.linalg.slogdet(resid / N)[1] + pen * p * m * m / N)
    return orders[int(np.argmin(vals))]


@pytest.mark.parametrize("criterion", ["aic", "bic"])
@pytest.mark.parametrize("gaps", [False, True])
def test_order_selection_from_lagged_products_equals_qr(building, criterion, gaps):
    Y = _with_gaps(building) if gaps else building
    assert arm._select_order(Y, criterion, 8) == _reference_criteria(Y, criterion, 8)


def test_column_stats_without_gaps_equal_the_nan_aware_ones(building):
    mean, std, flat = arm._column_stats(building)
    np.testing.assert_array_equal(mean, np.nanmean(building, axis=0))
    np.testing.assert_array_equal(std, np.nanstd(building, axis=0))
    assert not flat.any()
    Y = np.array(building, copy=True)
    Y[:, 2] = 3.0
    Y[5, 0] = np.nan
    assert list(np.flatnonzero(arm._column_stats(Y)[2])) == [2]


@pytest.mark.parametrize("rows", [7, 1000])
def test_column_stats_block_by_block_equal_the_whole_window(building, rows, monkeypatch):
    """A window longer than COLUMN_ROWS is reduced a block of rows at a time (no copy of
    it): the whole window's mean, spread and flat channels to rounding, with NaN in some
    blocks (a column's count then differs from the others'), a column empty in a block
    and a constant column; and the rows outside a fold's block likewise."""
    monkeypatch.setattr(arm, "COLUMN_ROWS", rows)
    Y = np.array(building, copy=True)
    Y[10:2200, 1] = np.nan  # whole blocks of column 1 without a value
    Y[5, 0] = np.nan
    Y[:, 2] = 3.0
    mean, std, flat = arm._column_stats(Y)
    np.testing.assert_allclose(mean, np.nanmean(Y, axis=0), rtol=1e-12)
    np.testing.assert_allclose(std, np.nanstd(Y, axis=0), rtol=1e-9, atol=1e-15)
    assert list(np.flatnonzero(flat)) == [2]
    a, b = 1500, 2600
    held = np.array(Y, copy=True)
    held[a:b] = np.nan
    out = arm._column_stats_outside(Y, a, b)
    np.testing.assert_allclose(out[0], np.nanmean(held, axis=0), rtol=1e-12)
    np.testing.assert_allclose(out[1], np.nanstd(held, axis=0), rtol=1e-9, atol=1e-15)
    assert list(np.flatnonzero(out[2])) == [2]
    empty = np.array(building[:50], copy=True)
    empty[:, 0] = np.nan
    got = arm.ColumnMoments(empty.shape[1])
    got.add(empty[:20])
    got.add(empty[20:])
    m, sd, fl = got.stats()
    assert np.isnan(m[0]) and np.isnan(sd[0]) and fl[0] and not fl[1:].any()


def _control_system(rng, n, r):
    A = rng.normal(size=(n, n))
    A *= 1.05 / np.max(np.abs(np.linalg.eigvals(A)))  # unstable: the gain must stabilize
    B = rng.normal(size=(n, r))
    Qh = rng.normal(size=(n, n))
    Rh = rng.normal(size=(r, r))
    return A, B, Qh @ Qh.T + 1e-3 * np.eye(n), Rh @ Rh.T + 0.1 * np.eye(r)


def _nearby_equations(seed):
    """A control system's DARE solution (``start``) and a nearby equation ``(A2, B, Q2,
    R)`` with scipy's solution ``ref``: the model refitted on slightly different data."""
    rng = np.random.default_rng(seed)
    A, B, Q, R = _control_system(rng, 14, 3)
    start = linalg.solve_discrete_are(A, B, Q, R)
    A2 = A + 0.01 * rng.normal(size=A.shape) * np.abs(A).max()
    Q2 = Q * (1 + 0.02 * rng.random())
    return start, (A2, B, Q2, R), linalg.solve_discrete_are(A2, B, Q2, R)


@pytest.mark.parametrize("seed", range(4))
def test_newton_from_a_nearby_solution_equals_scipy(seed):
    start, (A2, B, Q2, R), ref = _nearby_equations(seed)
    X = solve_dare(A2, B, Q2, R, start=start)
    assert np.abs(X - ref).max() <= 1e-10 * np.abs(ref).max()


def test_newton_from_a_start_that_does_not_stabilize_falls_back():
    rng = np.random.default_rng(9)
    A, B, Q, R = _control_system(rng, 10, 2)
    ref = linalg.solve_discrete_are(A, B, Q, R)
    # zero gain: the closed loop is A itself, unstable, so Newton gives up
    assert riccati._newton(A, B, Q, R, np.zeros_like(A)) is None
    X = solve_dare(A, B, Q, R, start=np.zeros_like(A))
    assert np.abs(X - ref).max() <= 1e-8 * np.abs(ref).max()


@pytest.mark.parametrize("seed", range(4))
def test_one_newton_step_squares_the_distance_to_the_solution(seed):
    start, (A2, B, Q2, R), ref = _nearby_equations(seed)
    X = riccati.newton_step(A2, B, Q2, R, start)
    e0 = np.abs(start - ref).max() / np.abs(ref).max()
    e1 = np.abs(X - ref).max() / np.abs(ref).max()
    assert e0 > 1e-4  # the start is not the answer already
    assert e1 <= 10 * e0**2
    assert np.allclose(X, X.T, rtol=0, atol=1e-12 * np.abs(X).max())


def test_one_newton_step_from_a_start_that_does_not_stabilize_is_refused():
    rng = np.random.default_rng(9)
    A, B, Q, R = _control_system(rng, 10, 2)
    assert riccati.newton_step(A, B, Q, R, np.zeros_like(A)) is None


def test_fold_estimators_one_step_from_the_whole_model(building):
    """A fold's estimator takes its gain from one Newton step from the whole model's
    solution: within the square of the start's distance of the fold's own solution."""
    ar = fit_ar(building, 4)
    held = np.array(building, copy=True)
    held[1000:2000] = np.nan
    fold = fit_ar(held, 4)
    for j in range(ar.m):
        whole, P = solved_leave_one_out(ar, j, 16)
        fast, P1 = solved_leave_one_out(fold, j, 16, (whole.settle, whole.warmup), P)
        full, Pf = solved_leave_one_out(fold, j, 16, (whole.settle, whole.warmup))
        size = np.abs(Pf).max()
        e0, e1 = np.abs(P - Pf).max() / size, np.abs(P1 - Pf).max() / size
        assert 1e-3 < e0 < 0.3  # a fold of this short record moves the solution by ~10 %
        assert e1 <= e0**2
        for name in ("F", "G", "H", "J"):
            ref = getattr(full, name)
            np.testing.assert_allclose(
                getattr(fast, name), ref, rtol=0, atol=e0**2 * np.abs(ref).max()
            )
        assert (fast.settle, fast.warmup) == (full.settle, full.warmup)


def test_calibration_from_one_step_folds_equals_converged_folds(monkeypatch):
    """The thresholds' statistics from the cross-validation folds move by far less than
    their own sampling error (~1e-2) when the folds' gains come from one Newton step
    instead of the converged solutions (a 10-minute window, as by default; measured
    ~1e-4 at most here, ~1e-5 at 16 channels)."""
    from analyzer.detectors import kalman_bank
    from analyzer.detectors.ar_kalman import ARKalmanBank
    from analyzer.detectors.base import Dataset, RunContext

    _, Y, names = simulate_building(3, 600.0, 100.0, seed=5, sensors_per_floor=2)
    data = Dataset(Y, tuple(names), 100.0, (0, Y.shape[0]))
    fast = ARKalmanBank(order=4).fit(data, RunContext())
    converged = partial(solve_dare, check_stable=False)
    monkeypatch.setattr(kalman_bank, "newton_step", lambda a, b, q, r, start: converged(a, b, q, r))
    ref = ARKalmanBank(order=4).fit(data, RunContext())
    assert fast.calibration == ref.calibration == "5-fold out-of-sample"
    for name in ("residual_cal", "consistency_cal"):
        for a, b in zip(getattr(fast, name), getattr(ref, name), strict=True):
            assert abs(a.std - b.std) <= 1e-3 * b.std
            assert abs(a.mean - b.mean) <= 1e-3 * b.std
            for f in ("mean_sd", "logq_sd"):
                np.testing.assert_allclose(getattr(a, f), getattr(b, f), rtol=1e-3)
            # a mean near zero: on the scale of its spread
            gap = np.abs(np.subtract(a.logq_mean, b.logq_mean))
            assert np.all(gap <= 1e-3 * np.asarray(b.logq_sd))


@pytest.mark.parametrize("gaps", [False, True])
def test_fit_leaving_rows_out_equals_the_fit_of_a_copy_with_them_missing(building, gaps):
    """``exclude=(a, b)`` (a cross-validation fold) fits without the rows ``[a, b)`` and
    without copying the window: the fit of a copy with those rows set to NaN, and the
    least-squares reference of it."""
    Y = _with_gaps(building) if gaps else building
    a, b = 1500, 2700
    held = np.array(Y, copy=True)
    held[a:b] = np.nan
    got = fit_ar(Y, 5, exclude=(a, b))
    want = fit_ar(held, 5)
    _assert_fit_equals_reference(got, held, 5)
    for name in ("coefs", "sigma", "mean", "scale"):
        ref = getattr(want, name)
        np.testing.assert_allclose(getattr(got, name), ref, rtol=0, atol=1e-11 * np.abs(ref).max())
    assert got.n_train == want.n_train
    kept = _with_gaps(building) if gaps else building
    assert np.array_equal(Y, kept, equal_nan=True)  # the input is not touched


def test_lagged_gram_taken_in_pieces_equals_the_whole(building, monkeypatch):
    """A stretch longer than ``GRAM_ROWS`` regression rows is taken in pieces that overlap
    by ``p`` rows, standardized a piece at a time: the same Gram matrix and fit."""
    Y = _with_gaps(building)
    p = 4
    whole = fit_ar(Y, p)
    mean, scale = whole.mean, whole.scale
    Z = (Y - mean) / scale
    segments = arm._finite_segments(Z, p)
    G = arm._lagged_gram(Z, p, segments)
    monkeypatch.setattr(arm, "GRAM_ROWS", 333)  # many pieces, of odd lengths
    pieces = arm._lagged_gram(arm._Scaled(Y, mean, scale), p, segments)
    np.testing.assert_allclose(pieces, G, rtol=0, atol=1e-11 * np.abs(G).max())
    again = fit_ar(Y, p)
    np.testing.assert_allclose(again.coefs, whole.coefs, rtol=0, atol=1e-10)
    _assert_fit_equals_reference(again, Y, p)


def test_innovation_moments_equal_the_masked_sums():
    """:class:`~analyzer.detectors.kalman_bank.InnovationMoments` adds, per estimator,
    the count, sum and cross-products of its rows without a missing value: the sums of
    the masked rows to the last bit, with and without missing rows."""
    from analyzer.detectors.kalman_bank import InnovationMoments

    rng = np.random.default_rng(4)
    innov = rng.standard_normal((3000, 6, 5)) * rng.random((1, 6, 5))
    innov[10, 2, 3] = np.nan
    innov[40:45, 4] = np.nan
    moments = InnovationMoments(6)
    moments.add(innov)
    moments.add(innov[:700])
    for j in range(6):
        counts, totals, outers = [], [], []
        for block in (innov, innov[:700]):
            nu = block[:, j]
            nu = nu[np.isfinite(nu).all(axis=1)]
            counts.append(nu.shape[0])
            totals.append(nu.sum(axis=0))
            outers.append(nu.T @ nu)
        assert moments.count[j] == sum(counts)
        assert np.array_equal(moments.total[j], np.zeros(5) + totals[0] + totals[1])
        assert np.array_equal(moments.outer[j], np.zeros((5, 5)) + outers[0] + outers[1])
