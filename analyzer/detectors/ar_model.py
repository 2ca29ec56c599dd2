"""Multichannel autoregressive model fitted on healthy data, and its companion
state-space form (Chang et al. 2017, Eq. 1-8)."""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import linalg

from analyzer.errors import DetectorError

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class ARModel:
    """``y[k] = sum_i A_i y[k-i] + e[k]`` on centred, scaled data (Eq. 1).

    ``coefs[i-1]`` is ``A_i`` (m x m); ``sigma`` the covariance of ``e`` (scaled units);
    data are ``(raw - mean) / scale`` per channel."""

    coefs: FloatArray
    sigma: FloatArray
    mean: FloatArray
    scale: FloatArray
    n_train: int
    aic: float
    bic: float

    @property
    def order(self) -> int:
        return int(self.coefs.shape[0])

    @property
    def m(self) -> int:
        return int(self.coefs.shape[1])

    def companion(self) -> tuple[FloatArray, FloatArray]:
        """``(A_d, C)`` of Eq. 8 with state ``[y[k-p+1]; ...; y[k]]``."""
        p, m = self.order, self.m
        A = np.zeros((p * m, p * m))
        A[: (p - 1) * m, m:] = np.eye((p - 1) * m)
        for i in range(p):  # last block row: [A_p, A_{p-1}, ..., A_1]
            A[(p - 1) * m :, i * m : (i + 1) * m] = self.coefs[p - 1 - i]
        C = np.zeros((m, p * m))
        C[:, (p - 1) * m :] = np.eye(m)
        return A, C

    def r_squared(self) -> FloatArray:
        """Share of each channel's (scaled) variance the model explains in training."""
        return np.clip(1.0 - np.diag(self.sigma), 0.0, 1.0)


def flat_channels(Y: FloatArray) -> npt.NDArray[np.bool_]:
    """Columns of ``Y`` that do not vary: empty, or a spread below 1e-9 of their level
    (a constant written through float arithmetic keeps a rounding-noise spread)."""
    with np.errstate(all="ignore"):
        std = np.nanstd(Y, axis=0)
        level = np.nanmax(np.abs(Y), axis=0)
        return np.asarray(~(std > 1e-9 * np.where(np.isfinite(level), level, 0.0) + 1e-300))


def required_samples(order: int, m: int) -> int:
    """Training samples needed for an order-``order`` AR model of ``m`` channels: the
    paper asks ``n >= p + m - 1`` and recommends 2-3 times that (Section 2.3); least
    squares also needs more equations than the ``p m`` unknowns of each row. We require
    the larger of ``3 (p + m - 1)`` and ``2 p m``, plus the ``p`` initial lags."""
    return order + max(3 * (order + m - 1), 2 * order * m)


def _lagged(Z: FloatArray, p: int) -> tuple[FloatArray, FloatArray]:
    """Regression pairs of Eq. 2-4 as rows: targets (n-p, m), regressors (n-p, p m) with
    lags 1..p in that order."""
    n = Z.shape[0]
    Y = Z[p:]
    X = np.hstack([Z[p - i : n - i] for i in range(1, p + 1)])
    return Y, X


def fit_ar(Y: FloatArray, order: int) -> ARModel:
    """Least-squares AR fit (Eq. 5, by a stable lstsq rather than an explicit
    pseudoinverse). Rows with a NaN in any lag are dropped."""
    Y = np.asarray(Y, dtype=np.float64)
    if Y.ndim != 2:
        raise DetectorError(f"expected an (n, m) training array, got shape {Y.shape}")
    n, m = Y.shape
    if order < 1:
        raise DetectorError(f"AR order must be at least 1, got {order}")
    mean = np.nanmean(Y, axis=0)
    scale = np.nanstd(Y, axis=0)
    bad = [int(j) for j in np.flatnonzero(flat_channels(Y))]
    if bad:
        raise DetectorError(
            f"channel(s) {bad} are constant or empty in the training window: an AR model "
            "needs every channel to vary"
        )
    Z = (Y - mean) / scale
    T, X = _lagged(Z, order)
    ok = np.isfinite(T).all(axis=1) & np.isfinite(X).all(axis=1)
    need = required_samples(order, m)
    if int(ok.sum()) + order < need:
        raise DetectorError(
            f"too little healthy data for an order-{order} AR model of {m} channels: "
            f"{int(ok.sum()) + order} usable training samples, need at least {need}"
        )
    if not ok.all():  # rows with a gap in a lag drop out (no copy when there is none)
        T, X = T[ok], X[ok]
    B, rank = _least_squares(X, T)
    if rank < X.shape[1]:
        raise DetectorError(
            f"singular AR regression (rank {rank} < {X.shape[1]}): channels are linearly "
            "dependent in the training window (duplicated or perfectly correlated sensors)"
        )
    E = T - X @ B
    N = T.shape[0]
    k = X.shape[1]
    sigma = (E.T @ E) / max(N - k, 1)
    coefs = B.T.reshape(m, order, m).transpose(1, 0, 2)  # coefs[i] = A_{i+1}
    sign, logdet = np.linalg.slogdet((E.T @ E) / N)
    if sign <= 0:
        raise DetectorError("singular AR residual covariance: a channel is perfectly predictable")
    n_par = k * m
    aic = float(logdet + 2.0 * n_par / N)
    bic = float(logdet + np.log(N) * n_par / N)
    return ARModel(np.asarray(coefs, dtype=np.float64), sigma, mean, scale, N, aic, bic)


NORMAL_EQUATIONS_COND = 1e8
"""Largest condition number of ``X' X`` solved by Cholesky (about 8 of 16 digits kept);
a worse-conditioned regression is solved by pivoted QR, which also finds its rank."""


def _least_squares(X: FloatArray, T: FloatArray) -> tuple[FloatArray, int]:
    """``argmin |X B - T|`` and the rank of ``X``. The normal equations by Cholesky cost one
    GEMM (5-10x less than a QR of a tall ``X``) and are exact enough when ``X' X`` is well
    conditioned; otherwise pivoted QR (``gelsy``) decides."""
    G = X.T @ X
    try:
        if np.linalg.cond(G) < NORMAL_EQUATIONS_COND:
            return linalg.cho_solve(linalg.cho_factor(G), X.T @ T), X.shape[1]
    except (linalg.LinAlgError, ValueError):
        pass
    B, _, rank, _ = linalg.lstsq(X, T, lapack_driver="gelsy", check_finite=False)
    return B, int(rank)


def _triangular_factor(M: FloatArray) -> FloatArray:
    """Upper-triangular ``R`` with ``R' R = M' M``: the Cholesky factor of the Gram matrix
    (one GEMM, ~8x cheaper than a QR of a tall ``M``) when it is well conditioned (the
    rule of :func:`_least_squares`), else the R of a QR. The two agree up to the signs
    of R's rows, which cancel in every ``R' R`` product taken from it."""
    G = M.T @ M
    try:
        if np.linalg.cond(G) < NORMAL_EQUATIONS_COND:
            return np.asarray(linalg.cholesky(G, lower=False, check_finite=False))
    except (linalg.LinAlgError, ValueError):
        pass
    return np.asarray(linalg.qr(M, mode="r", check_finite=False)[0])


_ORDERS: OrderedDict[tuple[object, ...], int] = OrderedDict()
_ORDERS_LOCK = threading.Lock()
_ORDERS_KEPT = 8


def select_order(Y: FloatArray, criterion: str = "bic", max_order: int = 12) -> int:
    """AR order minimizing AIC or BIC (Akaike 1974) among the orders the training window
    supports, all fitted on the same rows so the criteria are comparable.

    The answer is remembered for the last few training windows (by content): the bank and
    the detection filter select their order on the same window, often at the same time
    on two threads, and the second then waits for the first instead of repeating it."""
    if criterion not in ("aic", "bic"):
        raise DetectorError(f"order criterion must be 'aic' or 'bic', got {criterion!r}")
    Y = np.ascontiguousarray(Y, dtype=np.float64)
    digest = hashlib.blake2b(Y.data, digest_size=16).digest()
    key = (Y.shape, criterion, int(max_order), digest)
    with _ORDERS_LOCK:
        if key in _ORDERS:
            _ORDERS.move_to_end(key)
            return _ORDERS[key]
        order = _select_order(Y, criterion, max_order)
        _ORDERS[key] = order
        while len(_ORDERS) > _ORDERS_KEPT:
            _ORDERS.popitem(last=False)
        return order


def _select_order(Y: FloatArray, criterion: str, max_order: int) -> int:
    n, m = Y.shape
    orders = [p for p in range(1, max_order + 1) if required_samples(p, m) <= n]
    if not orders:
        raise DetectorError(
            f"too little healthy data for any AR model of {m} channels: {n} training samples, "
            f"need at least {required_samples(1, m)}"
        )
    pmax = orders[-1]
    mean = np.nanmean(Y, axis=0)
    scale = np.nanstd(Y, axis=0)
    scale[scale <= 0] = 1.0
    Z = (Y - mean) / scale
    T_all, X_all = _lagged(Z, pmax)
    ok = np.isfinite(T_all).all(axis=1) & np.isfinite(X_all).all(axis=1)
    if not ok.all():
        T_all, X_all = T_all[ok], X_all[ok]
    N = T_all.shape[0]
    # One triangular factor R of [X T] serves every order: the lags are nested, so the
    # residual of the order-p fit is R_tt' R_tt plus the rows of R_xt beyond the first
    # p m columns (Golub & Van Loan, least squares by QR).
    R = _triangular_factor(np.hstack([X_all, T_all]))
    k = X_all.shape[1]
    R_xt = R[:k, k:]
    R_tt = R[k : k + m, k:]
    best, best_val = orders[0], np.inf
    for p in orders:
        rest = R_xt[p * m :]
        sign, logdet = np.linalg.slogdet((rest.T @ rest + R_tt.T @ R_tt) / N)
        if sign <= 0:
            continue
        pen = 2.0 if criterion == "aic" else np.log(N)
        val = logdet + pen * p * m * m / N
        if val < best_val:
            best, best_val = p, val
    return best
