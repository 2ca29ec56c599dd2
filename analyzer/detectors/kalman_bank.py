"""The bank of steady-state Kalman estimators of Chang et al. (2017): estimator ``j``
measures every sensor but ``j`` (Eq. 10, Table 1), its gain from the discrete Riccati
equation of the AR model in companion form (:func:`leave_one_out`); the bank run over a
block of rows, after a warm-up from a zero state, gives each sensor's residual against
its estimate from the others, those estimates, and each estimator's consistency
(normalized innovation squares: :func:`bank_block`, :func:`estimator_consistency`).
The detector that fits and reads the bank is
:class:`~analyzer.detectors.ar_kalman.ARKalmanBank`."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import linalg

from analyzer.detectors.ar_model import ARModel
from analyzer.detectors.base import (
    dilate_forward,
)
from analyzer.detectors.lti import (
    ImpulseResponseBank,
    LiftedBank,
    LiftedSystem,
    StackedLiftedSystem,
    run_chunked,
    system_bank,
)
from analyzer.detectors.riccati import newton_step, solve_dare, solve_dare_scipy
from analyzer.errors import DetectorError
from analyzer.paging import (
    Released,
    finite_rows,
    write_rows,
)

FloatArray = npt.NDArray[np.float64]

WARMUP_DECAY = 1e-12
"""Factor by which an estimator's initial state has faded after its warm-up: a time block
filtered from a zero state that far before it equals the whole-record run to rounding."""


NIS_DTYPE = np.float32
"""Precision of the per-sample consistency kept over the archive: it is only compared with
thresholds through its windowed alarm statistic (sums in float64), so single precision
(relative rounding 6e-8) halves its memory without moving a decision."""


FOLD_DECAY = 1e-5
"""What a cross-validation fold's estimator must have forgotten of its state within the
whole model's warm-up to take over its times (:func:`forgets_within`)."""


@dataclass(frozen=True, slots=True)
class LeaveOneOut:
    """Steady-state estimator that measures every channel but ``left_out``.

    State recursion ``x[k+1] = F x[k] + G ybar[k]`` (one-step predictions), outputs
    ``[nu; yhat_j] = H x[k] + J ybar[k]``: the innovations of the measured channels and the
    filtered estimate of the left-out channel (scaled units)."""

    left_out: int
    measured: tuple[int, ...]
    F: FloatArray
    G: FloatArray
    H: FloatArray
    J: FloatArray
    settle: int
    """Samples for the filter to forget its state to 1e-6 (used after gaps)."""
    block: int = 64
    warmup: int = 0
    """Samples for the filter to forget its state to ``WARMUP_DECAY``: a run that starts
    this far before a time block matches, on the block, a run over the whole record."""

    @property
    def system(self) -> LiftedSystem:
        """This estimator alone in lifted form (for tests and benchmarks; the bank runs
        all estimators together in :class:`BankFilter`)."""
        return LiftedSystem.build(self.F, self.G, self.H, self.J, self.block)


@dataclass(frozen=True, slots=True)
class BankFilter:
    """All ``m`` estimators of the bank on the shared (scaled) input: estimator ``j`` has
    zero input columns for channel ``j``. Outputs per estimator: ``m - 1`` innovations (in
    the order of ``measured``) then the estimate of the left-out channel. The estimators
    forget their past within a few hundred samples, so they run as truncated impulse
    responses by FFT (:class:`~analyzer.detectors.lti.ImpulseResponseBank`, about ten
    times fewer operations than the lifted form at 16 channels); a bank with a longer
    memory runs as one stacked lifted system of block length ``block``.

    ``whitened``: the innovation outputs are premultiplied by ``S_j^-1/2`` (``S_j`` the
    estimator's healthy innovation covariance), so the consistency ``nu' S^-1 nu`` is a
    plain sum of squares of the outputs.

    ``estimates``: the same impulse responses restricted to each estimator's estimate of
    its left-out channel (``m`` of the ``m^2`` outputs; None for the lifted form). The
    residuals, and so the alarms, need only these; the consistency is needed only around
    alarms, where :meth:`ARKalmanBank.run` recomputes it over the few rows it asks for."""

    system: ImpulseResponseBank | LiftedBank
    block: int
    measured: tuple[tuple[int, ...], ...]
    settle: tuple[int, ...]
    warmup: int
    whitened: bool = False
    estimates: ImpulseResponseBank | None = None

    @classmethod
    def build(
        cls,
        estimators: tuple[LeaveOneOut, ...],
        block: int,
        inv_covs: list[FloatArray] | tuple[FloatArray, ...] | None = None,
        lifted: bool = False,
    ) -> BankFilter:
        """The bank; with ``inv_covs`` (one inverse innovation covariance per estimator)
        its innovation outputs are whitened; ``lifted`` forces the stacked lifted form
        (benchmarks and tests compare the two forms)."""
        m = len(estimators)
        systems = []
        for j, e in enumerate(estimators):
            cols = list(e.measured)
            G = np.zeros((e.F.shape[0], m))
            G[:, cols] = e.G
            J = np.zeros((e.H.shape[0], m))
            J[:, cols] = e.J
            H = e.H
            if inv_covs is not None:
                W = _sqrt_psd(np.asarray(inv_covs[j]))
                H = np.vstack([W @ H[:-1], H[-1:]])
                J[:-1] = W @ J[:-1]
            systems.append((e.F, G, H, J))
        system = (
            LiftedBank(StackedLiftedSystem.build(systems, block))
            if lifted
            else system_bank(systems, block)
        )
        estimates = None
        if isinstance(system, ImpulseResponseBank):  # the estimate: each one's last output
            estimates = system.select([system.q - 1])
        return cls(
            system,
            block,
            tuple(e.measured for e in estimators),
            tuple(e.settle for e in estimators),
            max(e.warmup for e in estimators),
            inv_covs is not None,
            estimates,
        )


def _sqrt_psd(a: FloatArray) -> FloatArray:
    """Symmetric square root of a positive semi-definite matrix."""
    w, V = np.linalg.eigh(0.5 * (a + a.T))
    return np.asarray((V * np.sqrt(np.clip(w, 0.0, None))) @ V.T, dtype=np.float64)


@dataclass(slots=True)
class BankOutputs:
    """What the bank yields per sample and channel ``j`` (all (N, m)): the residual of
    sensor ``j`` against its estimate from the others, that estimate (raw units), and the
    consistency of estimator ``j`` (normalized innovation squared, NaN where masked; None
    when not computed, see :meth:`ARKalmanBank.run`)."""

    resid: FloatArray
    est: FloatArray
    nis: npt.NDArray[Any] | None


def _filter_gain(
    solver: Callable[..., FloatArray],
    A: FloatArray,
    Cb: FloatArray,
    Q: FloatArray,
    R: FloatArray,
    horizon: int | None = None,
    start: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, float, FloatArray]:
    """Steady-state filter gain ``M = P Cb' S^-1`` from the DARE solved by ``solver``, the
    closed loop ``F = A (I - M Cb)``, its spectral radius and the DARE's solution ``P``.
    With a ``horizon`` the radius is not computed: 0 when ``F`` is shown to forget its
    state within it (:func:`forgets_within`), else NaN. ``start``: the solution of a
    nearby equation (the whole window's, for a cross-validation fold); ``P`` is then one
    Newton step from it (:func:`~analyzer.detectors.riccati.newton_step`), or the
    ``solver``'s where that step fails."""
    P = None if start is None else newton_step(A.T, Cb.T, Q, R, start)
    if P is None:
        P = solver(A.T, Cb.T, Q, R)
    S = Cb @ P @ Cb.T + R
    M = np.asarray(np.linalg.solve(S, Cb @ P).T, dtype=np.float64)
    F = A - (A @ M) @ Cb  # A (I - M Cb) without an n x n x n product
    if horizon is not None:
        return M, F, 0.0 if forgets_within(F, horizon) else np.nan, P
    return M, F, _spectral_radius(F), P


def _spectral_radius(F: FloatArray) -> float:
    return float(np.max(np.abs(np.linalg.eigvals(F))))


def forgets_within(F: FloatArray, horizon: int) -> bool:
    """Whether some power ``F^(2^k)`` with ``2^k <= horizon`` has Frobenius norm at most
    :data:`FOLD_DECAY`. That proves every eigenvalue of ``F`` inside the unit circle and
    ``rho(F)^horizon <= FOLD_DECAY`` (``rho(F)^L <= |F^L|``): a fold's estimator that is
    no slower than this forgets its state within the whole model's warm-up, and a few
    small products stand in for an eigenvalue problem that costs ~15x more at 160
    states. An estimator that forgets more slowly (a fold that changed the model) fails
    the test and gets its own radius."""
    P = F
    length = 1
    with np.errstate(all="ignore"):
        while length <= horizon:
            norm = float(np.linalg.norm(P))
            if norm <= FOLD_DECAY:
                return True
            if not np.isfinite(norm):
                return False
            P = P @ P
            length *= 2
    return False


def leave_one_out(
    ar: ARModel,
    j: int,
    block: int = 64,
    times: tuple[int, int] | None = None,
    start: FloatArray | None = None,
) -> LeaveOneOut:
    """Estimator ``j`` of the bank (Eq. 10) with the gain from the DARE.

    ``times``: the ``(settle, warmup)`` of the same estimator of a model fitted on nearly
    the same data (for a cross-validation fold: the whole window's model). They are taken
    over when the fold's closed loop provably forgets its state within that warm-up
    (:func:`forgets_within`, a few squarings instead of its eigenvalues); otherwise the
    fold's estimator gets its own times, as without ``times``. ``start``: that
    estimator's DARE solution; this one's gain then comes from one Newton step from it
    (:func:`~analyzer.detectors.riccati.newton_step`), which is within ~1e-4 of the
    converged solution's for a fold."""
    return solved_leave_one_out(ar, j, block, times, start)[0]


def solved_leave_one_out(
    ar: ARModel,
    j: int,
    block: int = 64,
    times: tuple[int, int] | None = None,
    start: FloatArray | None = None,
) -> tuple[LeaveOneOut, FloatArray]:
    """:func:`leave_one_out` and its DARE's solution ``P`` (where the same estimator of
    the cross-validation folds starts from: their models differ little from the whole
    window's, so one Newton step from ``P`` lands within ~1e-4 of the fold's solution,
    for a third of the products that converging from it takes)."""
    A, C = ar.companion()
    m = ar.m
    measured = tuple(i for i in range(m) if i != j)
    Cb = C[list(measured)]
    K = C.T  # noise enters the newest block row (Eq. 8)
    Q = K @ ar.sigma @ K.T
    R = ar.sigma[np.ix_(measured, measured)]
    n = A.shape[0]
    horizon = None if times is None else times[1]
    dare = partial(solve_dare, check_stable=False)
    try:
        M, F, rho, P = _filter_gain(dare, A, Cb, Q, R, horizon, start)
        if horizon is not None and not rho < 1.0:  # not shown to forget in time: measure
            horizon = None
            rho = _spectral_radius(F)
        if not rho < 1.0:  # the iterations gave a non-stabilizing solution: QZ decides
            M, F, rho, P = _filter_gain(solve_dare_scipy, A, Cb, Q, R)
    except (linalg.LinAlgError, ValueError) as err:
        raise DetectorError(
            f"the Kalman estimator without channel {j} has no stabilizing solution "
            f"(singular model: {err})"
        ) from err
    I_MC = np.eye(n) - M @ Cb
    G = A @ M
    cj = C[j : j + 1]
    H = np.vstack([-Cb, cj @ I_MC])
    J = np.vstack([np.eye(len(measured)), cj @ M])
    if not rho < 1.0:
        raise DetectorError(
            f"the Kalman estimator without channel {j} is unstable (spectral radius {rho:.4f})"
        )
    if times is not None and horizon is not None:
        return LeaveOneOut(j, measured, F, G, H, J, times[0], block, times[1]), P
    settle = int(np.ceil(np.log(1e-6) / np.log(max(rho, 1e-3))))
    warmup = int(np.ceil(np.log(WARMUP_DECAY) / np.log(max(rho, 1e-3))))
    return LeaveOneOut(j, measured, F, G, H, J, settle, block, warmup), P


def solved_leave_one_out_task(item: tuple[ARModel, int, int]) -> tuple[LeaveOneOut, FloatArray]:
    """:func:`solved_leave_one_out` on one tuple of arguments (what an executor maps)."""
    return solved_leave_one_out(*item)


@dataclass(slots=True)
class InnovationMoments:
    """Running mean and covariance of each estimator's innovations (finite rows only)."""

    m: int
    count: npt.NDArray[np.int64] | None = None
    total: FloatArray | None = None
    outer: FloatArray | None = None

    def add(self, innov: FloatArray) -> None:
        """``innov``: (L, m, m - 1), NaN where masked."""
        if self.count is None:
            d = innov.shape[2]
            self.count = np.zeros(self.m, dtype=np.int64)
            self.total = np.zeros((self.m, d))
            self.outer = np.zeros((self.m, d, d))
        assert self.total is not None and self.outer is not None
        for j in range(self.m):
            # one contiguous copy of the estimator's rows (a strided test of them and a
            # masked copy took ~1.4x as long), masked only where a row is missing
            nu = np.ascontiguousarray(innov[:, j])
            ok = np.isfinite(nu).all(axis=1)
            if not ok.all():
                nu = nu[ok]
            self.count[j] += nu.shape[0]
            self.total[j] += nu.sum(axis=0)
            self.outer[j] += nu.T @ nu

    def merge(self, other: InnovationMoments) -> None:
        """Add the rows ``other`` has seen (as if they were added here)."""
        if other.count is None:
            return
        assert other.total is not None and other.outer is not None
        if self.count is None:
            self.count = np.zeros_like(other.count)
            self.total = np.zeros_like(other.total)
            self.outer = np.zeros_like(other.outer)
        assert self.total is not None and self.outer is not None
        self.count += other.count
        self.total += other.total
        self.outer += other.outer

    def inverse_covariances(self) -> list[FloatArray]:
        assert self.count is not None and self.total is not None and self.outer is not None
        inv = []
        for j in range(self.m):
            n = int(self.count[j])
            if n < 2:
                raise DetectorError(
                    "too little finite training data to estimate the "
                    f"innovation covariance of the estimator without channel {j}"
                )
            mu = self.total[j] / n
            cov = (self.outer[j] - n * np.outer(mu, mu)) / (n - 1)
            inv.append(np.asarray(np.linalg.pinv(np.atleast_2d(cov)), dtype=np.float64))
        return inv


@dataclass(slots=True)
class BankBlock:
    """Bank outputs over one time block (see :class:`BankOutputs`); ``innov`` (L, m, m-1)
    instead of ``nis`` when no innovation covariance was given."""

    resid: FloatArray
    est: FloatArray
    nis: npt.NDArray[Any] | None
    innov: FloatArray | None = None


def bank_block(
    mean: FloatArray,
    scale: FloatArray,
    bank: BankFilter,
    Y: FloatArray,
    warm: int,
    inv_covs: list[FloatArray] | tuple[FloatArray, ...] | None,
    into: BankOutputs | None = None,
    at: int = 0,
    consistency: bool = True,
    innov_moments: InnovationMoments | None = None,
    moments_from: int = 0,
    advanced: Callable[[int], None] | None = None,
) -> BankBlock:
    """Bank outputs for ``Y[warm:]`` (raw units), every estimator filtered from a zero
    state at ``Y[0]``, written to rows ``at ..`` of ``into`` when given. Works through
    ``Y`` in chunks of :data:`analyzer.detectors.lti.CHUNK` rows (an impulse-response
    bank needs only its taps of history before a chunk), so temporary memory is set by
    the chunk length, not by the block's length. Where an estimator's inputs are missing
    (NaN), its outputs are masked for its settling time after the gap.

    The consistency ``nu' S^-1 nu / (m - 1)`` is returned in ``nis`` for a whitened
    bank, or given ``inv_covs`` (one inverse innovation covariance per estimator); else
    the innovations themselves (``innov``) and ``nis`` is NaN; or, given
    ``innov_moments``, the innovations of the output rows from ``moments_from`` on are
    added to it chunk by chunk instead (``innov`` None: a long window's innovations,
    ``m - 1`` values per estimator and sample, are not held). Without ``consistency``
    (or when ``into`` has no ``nis``) only the residuals and estimates are computed,
    by the estimate outputs alone where the bank has them (``nis`` is None).
    ``advanced``: called with the rows each chunk wrote (a run's progress: one call a
    chunk, no per-sample work)."""
    N, m = Y.shape
    L = N - warm
    if into is None:
        resid, est = np.empty((L, m)), np.empty((L, m))
        nis = np.empty((L, m)) if consistency else None
    else:
        resid, est = into.resid[at : at + L], into.est[at : at + L]
        nis = None if into.nis is None else into.nis[at : at + L]
    system = bank.system if nis is not None or bank.estimates is None else bank.estimates
    innov = None
    if nis is not None and inv_covs is None and not bank.whitened:
        if innov_moments is None:
            innov = np.empty((L, m, m - 1))
        nis[:] = np.nan
    inv_stack = None if inv_covs is None else np.stack([np.asarray(c) for c in inv_covs])
    # whether the block has gaps at all, a piece at a time (a boolean copy of the block,
    # or its memory-mapped pages all at once, would grow with the block: a quarter of
    # the archive on two threads); the masks are then made chunk by chunk
    gaps = not bool(finite_rows(Y).all())
    look = max(bank.settle) if gaps else 0  # the rows a chunk's masks look back

    def missing(lo: int, hi: int) -> npt.NDArray[np.bool_] | None:
        """Where each estimator misses data over rows ``lo .. hi - 1``: when any channel
        but its own is missing, and for its settling time after (None: nowhere)."""
        if not gaps:
            return None
        w0 = max(0, lo - look)  # each estimator's settling time back: the whole-block mask
        gap = ~np.isfinite(np.asarray(Y[w0:hi]))
        if not gap.any():
            return None
        n_gap = gap.sum(axis=1)
        out = np.empty((hi - lo, m), dtype=bool)
        for j in range(m):  # estimator j misses data when any channel but j is missing
            out[:, j] = dilate_forward((n_gap - gap[:, j]) > 0, bank.settle[j])[lo - w0 :]
        return out

    def scaled(a: int, b: int) -> FloatArray:  # the bank's input, gaps as 0
        rows = np.asarray(Y[a:b], dtype=np.float64)
        return np.where(~np.isfinite(rows), 0.0, (rows - mean) / scale)

    read = Released(Y)  # what the pass is done with, given back behind it
    written = Released(est, resid)
    for lo, out in run_chunked(system, scaled, N, warm):
        e0 = lo + out.shape[2]
        y = out.transpose(2, 0, 1)  # (c, m, m): innovations, then the estimate
        nu = y[:, :, :-1]
        yhat = y[:, :, -1]
        b = missing(lo, e0)
        if b is not None:
            if nis is not None:
                nu[b] = np.nan
            yhat[b] = np.nan
        rows = slice(lo - warm, e0 - warm)
        estimate = yhat * scale + mean
        write_rows(est, rows.start, estimate)  # a long archive's: by pwrite, not the map
        measured = np.asarray(Y[lo:e0], dtype=np.float64)
        write_rows(resid, rows.start, np.where(~np.isfinite(measured), np.nan, measured - estimate))
        h = system.history  # the rows this chunk read: done with them, but the history
        read.upto(e0 if h is None else max(0, e0 - h), final=e0 == N)
        written.upto(rows.stop, final=e0 == N)  # and the rows it wrote (memory-mapped)
        if advanced is not None:
            advanced(rows.stop - rows.start)
        if nis is None:
            continue
        if bank.whitened:
            nis[rows] = np.einsum("cjq,cjq->cj", nu, nu) / (m - 1)
        elif innov is not None:
            innov[rows] = nu
        elif innov_moments is not None and inv_covs is None:
            innov_moments.add(nu[max(0, moments_from - rows.start) :])
        else:
            assert inv_stack is not None
            nt = nu.transpose(1, 0, 2)  # (m, c, m - 1)
            nis[rows] = (np.matmul(nt, inv_stack) * nt).sum(axis=2).T / (m - 1)
    return BankBlock(resid, est, nis, innov)


def estimator_consistency(
    mean: FloatArray,
    scale: FloatArray,
    bank: BankFilter,
    system: ImpulseResponseBank,
    j: int,
    Y: FloatArray,
    warm: int,
) -> npt.NDArray[Any]:
    """Estimator ``j``'s consistency for ``Y[warm:]`` (raw units) from a zero state at
    ``Y[0]``: :func:`bank_block`'s ``nis[:, j]`` of a whitened ``bank`` to rounding, from
    ``system = bank.system.subset([j])`` (its ``m`` outputs, not the bank's ``m^2``),
    masked where one of its inputs is missing and for its settling time after."""
    N, m = Y.shape
    gap = ~np.isfinite(np.asarray(Y))
    bad = None
    if gap.any():
        others = gap.sum(axis=1) - gap[:, j]  # estimator j misses any channel but j
        bad = dilate_forward(others > 0, bank.settle[j])
    nis = np.empty(N - warm, NIS_DTYPE)

    def scaled(a: int, b: int) -> FloatArray:  # the bank's input, gaps as 0
        return np.where(gap[a:b], 0.0, (np.asarray(Y[a:b], dtype=np.float64) - mean) / scale)

    for lo, out in run_chunked(system, scaled, N, warm):
        e0 = lo + out.shape[2]
        nu = out.transpose(2, 0, 1)[:, :, :-1]  # (c, 1, m - 1): the whitened innovations
        val = np.einsum("cjq,cjq->cj", nu, nu)[:, 0] / (m - 1)
        if bad is not None:
            val[bad[lo:e0]] = np.nan
        nis[lo - warm : e0 - warm] = val
    return nis
