"""Multichannel autoregressive model fitted on healthy data, and its companion
state-space form (Chang et al. 2017, Eq. 1-8)."""

from __future__ import annotations

import hashlib
import threading
import warnings
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import linalg

from analyzer.diagnosis.streamed import ColumnMoments
from analyzer.errors import LISTED, DetectorError, TooLittleDataError, capped
from analyzer.paging import finite_rows, release, row_blocks

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
    return _column_stats(Y)[2]


COLUMN_ROWS = 1 << 16
"""Rows :func:`_column_stats` reduces at once: a longer window is taken a block of rows
at a time, the blocks' moments merged (no copy of the window: ``Y.std`` and ``abs(Y)``
each made one)."""


def _column_stats(Y: FloatArray) -> tuple[FloatArray, FloatArray, npt.NDArray[np.bool_]]:
    """Mean, standard deviation and :func:`flat_channels` of the columns of ``Y``
    (ignoring NaN) in one go; a window without a NaN takes the plain reductions (the
    same sums in the same order, ~2x faster than the NaN-aware ones). A window longer
    than :data:`COLUMN_ROWS` rows is reduced a block at a time (:class:`ColumnMoments`)."""
    if Y.shape[0] > COLUMN_ROWS:
        moments = ColumnMoments(Y.shape[1])
        for _, block in row_blocks(Y, COLUMN_ROWS):
            moments.add(np.asarray(block, dtype=np.float64))
        return moments.stats()
    with np.errstate(all="ignore"):
        if np.isfinite(Y).all():
            mean = Y.mean(axis=0)
            std = Y.std(axis=0)
            level = np.abs(Y).max(axis=0, initial=0.0)
        else:
            # (a column with no finite sample gives NaN, flat: numpy warns of it, a
            # channel missing from the healthy window is no news here)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                mean = np.nanmean(Y, axis=0)
                std = np.nanstd(Y, axis=0)
                level = np.nanmax(np.abs(Y), axis=0)
        flat = ~(std > 1e-9 * np.where(np.isfinite(level), level, 0.0) + 1e-300)
    return mean, std, np.asarray(flat)


def _column_stats_outside(
    Y: FloatArray, a: int, b: int
) -> tuple[FloatArray, FloatArray, npt.NDArray[np.bool_]]:
    """:func:`_column_stats` of the rows of ``Y`` outside ``[a, b)``: the parts' blocks'
    moments merged (:class:`ColumnMoments`), with or without NaN, no copy of them."""
    moments = ColumnMoments(Y.shape[1])
    for part in (Y[:a], Y[b:]):
        for _, block in row_blocks(part, COLUMN_ROWS):
            moments.add(np.asarray(block, dtype=np.float64))
    return moments.stats()


class _Scaled:
    """``(Y - mean) / scale``, computed for the rows asked for (``Z[a:b]``): what the
    lagged Gram matrix and the residuals read a stretch at a time, so a fit holds a
    block of standardized rows, not a standardized copy of the whole window."""

    def __init__(self, Y: FloatArray, mean: FloatArray, scale: FloatArray) -> None:
        self.Y, self.mean, self.scale = Y, mean, scale

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(self.Y.shape)

    def __getitem__(self, rows: slice) -> FloatArray:
        out: FloatArray = (self.Y[rows] - self.mean) / self.scale
        release(self.Y[rows])  # a memory-mapped window: read a stretch at a time
        return out


def _scaled_rows(
    Y: FloatArray, mean: FloatArray, scale: FloatArray, exclude: tuple[int, int] | None
) -> FloatArray:
    """The whole window standardized, the rows of ``exclude`` as NaN (for the design
    matrix of a window cut by many gaps, and the singular fit's diagnosis)."""
    Z = (Y - mean) / scale
    if exclude is not None:
        Z[exclude[0] : exclude[1]] = np.nan
    return Z


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


def _design_rows(Z: FloatArray, p: int) -> tuple[FloatArray, FloatArray]:
    """:func:`_lagged` without the rows that have a NaN in any lag (no copy when none
    has)."""
    T, X = _lagged(Z, p)
    ok = np.isfinite(T).all(axis=1) & np.isfinite(X).all(axis=1)
    if not ok.all():
        T, X = T[ok], X[ok]
    return T, X


def fit_ar(
    Y: FloatArray,
    order: int,
    names: Sequence[str] | None = None,
    exclude: tuple[int, int] | None = None,
) -> ARModel:
    """Least-squares AR fit (Eq. 5, by a stable lstsq rather than an explicit
    pseudoinverse). Rows with a NaN in any lag are dropped. ``names``: the channels'
    names, for the error that says which channels make the regression singular.
    ``exclude``: rows ``[a, b)`` left out as if they were missing (a cross-validation
    fold), without a copy of the window.

    The normal equations come from lagged cross-products of the finite stretches of the
    data (:func:`_lagged_gram`, no ``(n, p m)`` design matrix), standardized a block of
    rows at a time (no scaled copy of the window), and the residuals from the same
    stretches; a window cut by many gaps, or a regression too ill-conditioned for the
    normal equations, takes the design matrix and pivoted QR instead."""
    Y = np.asarray(Y, dtype=np.float64)
    if Y.ndim != 2:
        raise DetectorError(f"expected an (n, m) training array, got shape {Y.shape}")
    n, m = Y.shape
    if order < 1:
        raise DetectorError(f"AR order must be at least 1, got {order}")
    finite = finite_rows(Y)
    if exclude is not None:
        a, b = exclude
        finite[a:b] = False
        mean, scale, flat = _column_stats_outside(Y, a, b)
    else:
        mean, scale, flat = _column_stats(Y)
    bad = [int(j) for j in np.flatnonzero(flat)]
    if bad:
        raise DetectorError(
            f"channel(s) {bad} are constant or empty in the training window: an AR model "
            "needs every channel to vary"
        )
    Z = _Scaled(Y, mean, scale)
    segments = _finite_segments(finite, order)
    design = whole = None
    if segments is None:  # many gaps: the design matrix of the rows without one
        whole = _scaled_rows(Y, mean, scale, exclude)
        design = _design_rows(whole, order)
        usable = design[0].shape[0]
    else:
        usable = sum(b - a - order for a, b in segments)
    need = required_samples(order, m)
    if usable + order < need:
        raise TooLittleDataError(
            f"too little healthy data for an order-{order} AR model of {m} channels: "
            f"{usable + order} usable training samples, need at least {need}",
            usable + order,
            need,
        )
    k = order * m
    B = EE = None
    if segments is not None:
        G = _lagged_gram(Z, order, segments)
        B = _normal_equations(G[m:, m:], G[m:, :m])
        if B is not None:
            EE = _residual_gram(G, B)
            if EE is None:  # the fit explains nearly everything: residuals by rows
                E = _ar_residuals(Z, B, order, segments)
                EE = E.T @ E
    if B is None or EE is None:  # ill-conditioned (or many gaps): QR on the design matrix
        if whole is None:
            whole = _scaled_rows(Y, mean, scale, exclude)
        T, X = design if design is not None else _design_rows(whole, order)
        B, rank = _least_squares(X, T)
        if rank < k:
            raise DetectorError(
                f"singular AR regression (rank {rank} < {k}): "
                + _dependence(whole, X, rank, names, units=(mean, scale))
            )
        E = T - X @ B
        EE = E.T @ E
    N = usable
    d = np.sqrt(np.diag(EE))
    if d.all() and m > 1:
        w = np.linalg.eigvalsh(EE / np.outer(d, d))
        if w[0] < NEAR_SINGULAR * w[-1]:
            if whole is None:
                whole = _scaled_rows(Y, mean, scale, exclude)
            raise DetectorError(
                "singular AR residual covariance: "
                + _dependence(whole, None, k, names, NEAR_SINGULAR_RANK)
            )
    sigma = EE / max(N - k, 1)
    coefs = B.T.reshape(m, order, m).transpose(1, 0, 2)  # coefs[i] = A_{i+1}
    sign, logdet = np.linalg.slogdet(EE / N)
    if sign <= 0:
        raise DetectorError("singular AR residual covariance: a channel is perfectly predictable")
    n_par = k * m
    aic = float(logdet + 2.0 * n_par / N)
    bic = float(logdet + np.log(N) * n_par / N)
    return ARModel(np.ascontiguousarray(coefs, dtype=np.float64), sigma, mean, scale, N, aic, bic)


def _dependence(
    Z: FloatArray,
    X: FloatArray | None,
    rank: int,
    names: Sequence[str] | None,
    relative: float | None = None,
    units: tuple[FloatArray, FloatArray] | None = None,
) -> str:
    """Which channels make the regression singular, for its error. A pivoted QR puts the
    columns that are combinations of others last: of the channels themselves when they
    are dependent at one instant (a duplicated sensor, a sum of others), else of the
    lagged design (a channel that is a delayed copy, a difference or a running sum of
    another). ``relative``: the tolerance on QR's diagonal relative to its largest
    (default: rounding of the regression's size); ``X`` None: the channels only.
    ``units``: the mean and scale that standardized ``Z``, for the relation of the first
    dependent channel to the others in the channels' own units (:func:`_relation`)."""
    m = Z.shape[1]
    label = list(names) if names is not None and len(names) == m else [str(i) for i in range(m)]
    rows = Z[np.isfinite(Z).all(axis=1)]

    def pivoted(M: FloatArray) -> tuple[npt.NDArray[np.intp], int]:
        R, piv = linalg.qr(M, mode="r", pivoting=True, check_finite=False)
        d = np.abs(np.diag(R))
        scale = relative if relative is not None else max(M.shape) * np.finfo(float).eps * 1e3
        tol = d.max(initial=0.0) * scale
        return np.asarray(piv), int(np.count_nonzero(d > tol))

    if relative is not None and rows.shape[0] >= m:
        # the combination itself: the channels with a weight in the correlation
        # matrix's least eigenvector (all of them are in it; leaving any one out helps)
        w, v = np.linalg.eigh(np.corrcoef(rows, rowvar=False))
        if w[0] < relative * w[-1]:
            weight = np.abs(v[:, 0])
            found = [label[j] for j in np.flatnonzero(weight > 0.05 * weight.max())]
            return (
                f"{capped(found)} are linearly dependent in the training window (one of "
                "them computed from the others, up to rounding?): leave one of them out, "
                f"for example with --channels '!{found[-1]}'"
            )
    if rows.shape[0] >= m:
        piv, r = pivoted(rows)
        if r < m:
            found = [label[j] for j in sorted(piv[r:])]
            what = "is a linear combination" if m - r == 1 else "are linear combinations"
            first = min(int(j) for j in piv[r:])
            relation = "" if units is None else _relation(rows, first, piv[:r], label, *units)
            return (
                f"{capped(found)} {what} of the other channels in the training window "
                f"({relation}duplicated or perfectly correlated sensors, or ones that move "
                f"together in that window): {_leave_out(found)}"
            )
    if X is None:
        return (
            "a channel is a linear combination of the others, up to rounding, in the training "
            "window (a channel computed from the others?)"
        )
    piv, _ = pivoted(X)
    found = [label[j] for j in sorted({int(c) % m for c in piv[rank:]})]
    verb = "follows" if len(found) == 1 else "follow"
    return (
        f"{capped(found)} {verb} the other channels' past exactly in the training "
        "window (a delayed copy, a difference or a running sum of another channel, or a "
        f"step signal): {_leave_out(found)}"
    )


def _relation(
    rows: FloatArray,
    j: int,
    others: npt.NDArray[np.intp],
    label: Sequence[str],
    mean: FloatArray,
    scale: FloatArray,
) -> str:
    """``"X = a A + b B + c: "``, channel ``j`` as the others of ``others`` give it on the
    standardized ``rows`` (least squares), in the channels' units: what the dependence
    is, which "a linear combination" alone did not say (the turtlesim teleop's
    ``cmd_vel.angular.z = -cmd_vel.linear.x + 2`` in a window where only the up and left
    keys were pressed, each message one of them at 2). Empty when the weights do not
    give the channel to within rounding (a dependence the pivoting did not isolate), or
    name more than :data:`~analyzer.errors.LISTED` channels."""
    design = np.column_stack([rows[:, others], np.ones(rows.shape[0])])
    w, *_ = np.linalg.lstsq(design, rows[:, j], rcond=None)
    misfit = np.abs(design @ w - rows[:, j]).max(initial=0.0)
    if not misfit <= 1e-6 * max(1.0, float(np.abs(rows[:, j]).max(initial=0.0))):
        return ""
    big = np.abs(w[:-1]) > 1e-9 * max(1.0, float(np.abs(w[:-1]).max(initial=0.0)))
    if not 0 < big.sum() <= LISTED:
        return ""
    gains = w[:-1][big] * scale[j] / scale[others[big]]
    shift = mean[j] + scale[j] * w[-1] - float(gains @ mean[others[big]])
    terms = [
        ("-" if g < 0 else "+", "" if abs(abs(g) - 1) < 1e-9 else f"{abs(g):.6g} ", label[i])
        for g, i in zip(gains, others[big], strict=True)
    ]
    text = " ".join(f"{sign} {gain}{name}" for sign, gain, name in terms)
    text = text[2:] if text.startswith("+ ") else "-" + text[2:]
    if abs(shift) > 1e-9 * max(1.0, abs(float(mean[j]))):
        text += f" {'-' if shift < 0 else '+'} {abs(shift):.6g}"
    return f"{label[j]} = {text}: "


def _leave_out(names: list[str]) -> str:
    """How to analyze without ``names``: the ``--channels`` exclusions that do it (the
    first :data:`~analyzer.errors.LISTED` of them and how many more, for a long list)."""
    shown = "'" + ",".join(f"!{n}" for n in names[:LISTED]) + "'"
    if len(names) > LISTED:
        shown = f"({shown} and {len(names) - LISTED} more)"
    return f"leave them out with --channels {shown}"


MAX_SEGMENTS = 64
"""Most finite stretches of a training window whose Gram matrix is summed from lagged
cross-products (a few small products per stretch); a window cut by more gaps takes the
design matrix of its rows without a gap."""


def _finite_segments(Z: npt.NDArray[Any], p: int) -> list[tuple[int, int]] | None:
    """The maximal runs ``[a, b)`` of rows of ``Z`` without a NaN that are longer than
    ``p`` (so they hold a regression row: ``t`` with ``Z[t - p .. t]`` finite, exactly
    the rows the design matrix keeps), or None when there are more than
    :data:`MAX_SEGMENTS` of them. ``Z`` may also be the rows' mask of finiteness (1-D)."""
    finite = Z if Z.ndim == 1 else np.isfinite(Z).all(axis=1)
    if finite.all():
        return [(0, Z.shape[0])] if Z.shape[0] > p else []
    edges = np.diff(np.concatenate(([0], finite.astype(np.int8), [0])))
    starts = np.flatnonzero(edges == 1)
    stops = np.flatnonzero(edges == -1)
    keep = stops - starts > p
    if int(keep.sum()) > MAX_SEGMENTS:
        return None
    return [(int(a), int(b)) for a, b in zip(starts[keep], stops[keep], strict=True)]


GRAM_ROWS = 1 << 16
"""Rows of a stretch taken at once by :func:`_lagged_gram` (and standardized at once by
:class:`_Scaled`): a longer stretch is cut into pieces of this many regression rows,
each with the ``p`` rows before it (about 8 MB at 16 channels)."""


def _lagged_gram(Z: FloatArray | _Scaled, p: int, segments: list[tuple[int, int]]) -> FloatArray:
    """Gram matrix of the regression rows' lags ``0 .. p`` (columns ``[Z[t], Z[t-1],
    ..., Z[t-p]]``, ``(p + 1) m`` square) over the rows ``t`` of ``segments``
    (:func:`_finite_segments`), without forming them. Within one stretch ``S`` of
    length ``L`` the blocks ``G(a, b) = sum_{t=p}^{L-1} S[t-a] S[t-b]'`` are shifts of
    one another::

        G(a, b) = G(a - 1, b - 1) + S[p - a] S[p - b]' - S[L - a] S[L - b]'

    so ``p + 1`` products ``G(0, b)`` over the stretch and a recursion over its ``p``
    boundary rows give all of them (``O(L p m^2)`` instead of ``O(L p^2 m^2)``; the same
    sums, rounded differently). A stretch longer than :data:`GRAM_ROWS` regression rows
    is taken in pieces that overlap by ``p`` rows: each regression row in exactly one."""
    m = Z.shape[1]
    w = p + 1
    blocks = np.zeros((w, w, m, m))
    pieces = [
        (c0, min(b0, c0 + GRAM_ROWS + p))
        for a0, b0 in segments
        for c0 in range(a0, b0 - p, GRAM_ROWS)
    ]
    for a0, b0 in pieces:
        S = Z[a0:b0]
        L = S.shape[0]
        part = np.empty((w, w, m, m))
        head = S[p:].T
        for b in range(w):
            part[0, b] = head @ S[p - b : L - b]
        part[1:, 0] = part[0, 1:].transpose(0, 2, 1)
        heads = S[p - 1 :: -1][:p]  # heads[a - 1] = S[p - a]
        tails = S[L - 1 : L - p - 1 : -1]  # tails[a - 1] = S[L - a] (L > p)
        D = heads[:, None, :, None] * heads[None, :, None, :]
        D -= tails[:, None, :, None] * tails[None, :, None, :]
        for a in range(1, w):
            part[a, 1:] = part[a - 1, :-1] + D[a - 1]
        blocks += part
    G = blocks.transpose(0, 2, 1, 3).reshape(w * m, w * m)
    return 0.5 * (G + G.T)


RESIDUAL_SHARE = 1e-3
"""Smallest share of a channel's (scaled) sum of squares left in its residual for the
residual sum of squares to be taken from the Gram matrix: ``T'T - B' X'T`` cancels that
share's digits (about 3 at this limit, leaving ~12), so a fit that explains more of a
channel takes its residuals row by row."""


def _residual_gram(G: FloatArray, B: FloatArray) -> FloatArray | None:
    """``E' E`` of the fit ``B`` (``E = T - X B``) from the Gram matrix ``G`` of
    :func:`_lagged_gram`: ``T'T - X'T' B - B' X'T + B' X'X B``, or None where it would
    cancel more than :data:`RESIDUAL_SHARE` of a diagonal's digits."""
    m = B.shape[1]
    h = G[m:, :m]
    EE = G[:m, :m] - h.T @ B - B.T @ h + B.T @ G[m:, m:] @ B
    EE = 0.5 * (EE + EE.T)
    if not np.all(np.diag(EE) >= RESIDUAL_SHARE * np.diag(G[:m, :m])):
        return None
    return np.asarray(EE, dtype=np.float64)


def _ar_residuals(
    Z: FloatArray | _Scaled, B: FloatArray, p: int, segments: list[tuple[int, int]]
) -> FloatArray:
    """``T - X B`` of the regression rows of ``segments`` (in order), stretch by stretch
    from lagged products: ``E[t] = Z[t] - sum_i Z[t - i] B_i`` (``B_i`` the rows of
    ``B`` for lag ``i``)."""
    m = Z.shape[1]
    parts = []
    for a0, b0 in segments:
        S = Z[a0:b0]
        L = S.shape[0]
        E = S[p:].copy()
        for i in range(1, p + 1):
            E -= S[p - i : L - i] @ B[(i - 1) * m : i * m]
        parts.append(E)
    return parts[0] if len(parts) == 1 else np.concatenate(parts)


NEAR_SINGULAR = 1e-10
"""Smallest eigenvalue of the AR residuals' correlation matrix, relative to its largest,
below which one channel's innovation is a combination of the others' (a channel computed
from others and written with 9 digits: ~1e-16; two sensors on one floor with independent
noise: ~1e-3)."""
NEAR_SINGULAR_RANK = 1e-6
"""The QR tolerance (relative) that names the channels of such a combination: their
rounding leaves ~1e-9 of the combined channel."""

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


def _normal_equations(G: FloatArray, h: FloatArray) -> FloatArray | None:
    """``G^-1 h`` by Cholesky for a Gram matrix ``G = X' X`` and ``h = X' T`` when ``G`` is
    well conditioned (the rule of :func:`_least_squares`), else None (the caller then
    solves by pivoted QR on ``X``)."""
    try:
        if np.linalg.cond(G) < NORMAL_EQUATIONS_COND:
            return np.asarray(linalg.cho_solve(linalg.cho_factor(G), h), dtype=np.float64)
    except (linalg.LinAlgError, ValueError):
        pass
    return None


def _triangular_factor(M: FloatArray) -> FloatArray:
    """Upper-triangular ``R`` with ``R' R = M' M``: the Cholesky factor of the Gram matrix
    (one GEMM, ~8x cheaper than a QR of a tall ``M``) when it is well conditioned (the
    rule of :func:`_least_squares`), else the R of a QR. The two agree up to the signs
    of R's rows, which cancel in every ``R' R`` product taken from it."""
    R = _cholesky_factor(M.T @ M)
    if R is not None:
        return R
    return np.asarray(linalg.qr(M, mode="r", check_finite=False)[0])


def _cholesky_factor(G: FloatArray) -> FloatArray | None:
    """Upper Cholesky factor of the Gram matrix ``G`` when it is well conditioned (the
    rule of :func:`_least_squares`), else None (QR of the matrix itself decides)."""
    try:
        if np.linalg.cond(G) < NORMAL_EQUATIONS_COND:
            return np.asarray(linalg.cholesky(G, lower=False, check_finite=False))
    except (linalg.LinAlgError, ValueError):
        pass
    return None


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
    hasher = hashlib.blake2b(digest_size=16)
    for _, block in row_blocks(Y):  # a memory-mapped window's pages are not all held
        hasher.update(block.data)
    digest = hasher.digest()
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
    logdets, N, m = _order_logdets(Y, max_order)
    best, best_val = next(iter(logdets)), np.inf
    for p, logdet in logdets.items():
        pen = 2.0 if criterion == "aic" else np.log(N)
        val = logdet + pen * p * m * m / N
        if val < best_val:
            best, best_val = p, val
    return best


def error_ratio(Y: FloatArray, order: int, other: int) -> float:
    """How much larger the one-step prediction error of the AR model of ``order`` is
    than that of ``other``, both fitted on the training window ``Y``: the geometric mean
    over the channels of the error variances' ratio (``exp`` of the log-determinants'
    difference over the channels); NaN where either order is not supported."""
    logdets, _, m = _order_logdets(Y, max(order, other))
    if order not in logdets or other not in logdets:
        return float("nan")
    return float(np.exp((logdets[order] - logdets[other]) / m))


def _order_logdets(Y: FloatArray, max_order: int) -> tuple[dict[int, float], int, int]:
    """``log det`` of the one-step error covariance of the AR fit of every order from 1
    to ``max_order`` the window supports (of standardized channels, all on the same
    rows), the rows fitted and the channels."""
    n, m = Y.shape
    orders = [p for p in range(1, max_order + 1) if required_samples(p, m) <= n]
    if not orders:
        raise TooLittleDataError(
            f"too little healthy data for any AR model of {m} channels: {n} training samples, "
            f"need at least {required_samples(1, m)}",
            n,
            required_samples(1, m),
        )
    pmax = orders[-1]
    mean, scale, _ = _column_stats(Y)
    scale[scale <= 0] = 1.0
    # standardized a stretch at a time where the Gram matrix serves (no copy)
    segments = _finite_segments(finite_rows(Y), pmax)
    k = pmax * m
    # One triangular factor R of [X T] serves every order: the lags are nested, so the
    # residual of the order-p fit is R_tt' R_tt plus the rows of R_xt beyond the first
    # p m columns (Golub & Van Loan, least squares by QR). R is the Cholesky factor of
    # the Gram matrix of [X T] from lagged products when that is well conditioned.
    R = None
    if segments is not None:
        N = sum(b - a - pmax for a, b in segments)
        G = _lagged_gram(_Scaled(Y, mean, scale), pmax, segments)
        order_xt = np.r_[m : (pmax + 1) * m, 0:m]  # lags 1 .. pmax, then lag 0
        R = _cholesky_factor(G[np.ix_(order_xt, order_xt)])
    if R is None:
        T_all, X_all = _design_rows((Y - mean) / scale, pmax)
        N = T_all.shape[0]
        R = _triangular_factor(np.hstack([X_all, T_all]))
    R_xt = R[:k, k:]
    R_tt = R[k : k + m, k:]
    out: dict[int, float] = {}
    for p in orders:
        rest = R_xt[p * m :]
        sign, logdet = np.linalg.slogdet((rest.T @ rest + R_tt.T @ R_tt) / N)
        if sign > 0:
            out[p] = float(logdet)
    if not out:  # every order singular: the first, as the search gave before
        out[orders[0]] = float("inf")
    return out, N, m
