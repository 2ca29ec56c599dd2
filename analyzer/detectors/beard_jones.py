"""Design of the Beard-Jones detection filter for sensor faults by state augmentation
(Park, Rizzoni & Ribbens 1994), in discrete time: one filter per sensor, whose bank
:class:`~analyzer.detectors.detection_filter.DetectionFilter` runs and reads.

Augmentation (Eq. 10-14)
------------------------
A sensor fault on sensor ``i`` enters the output, ``y = C x + e_i zeta`` (Eq. 6-7). Park et
al. make it an *actuator-like* fault by adding the fault signal as a state,
``xbar = [x; zeta]``, with the fault model ``zeta[k+1] = alpha zeta[k] + xi[k]`` (the discrete
form of Eq. 13-14; ``alpha = 1``: a fault that stays until it changes, such as an offset)::

    Abar = [[A, 0], [0, alpha]],  Bbar = [[B], [0]],  Cbar = [C, e_i],  fbar = [0; 1]   (Eq. 12)

so that ``xbar[k+1] = Abar xbar + Bbar u + fbar xi`` and ``y = Cbar xbar + D u`` (Eq. 15-16):
the fault event vector is ``fbar`` and the output direction it excites is ``Cbar fbar = e_i``.

Detection gain (discrete Beard-Jones design)
--------------------------------------------
The filter ``s[k+1] = Abar s + Bbar u + D_i (y - Cbar s - D u)`` (Eq. 17-18) has the error
``e[k+1] = (Abar - D_i Cbar) e + fbar xi`` and output residual ``q = Cbar e`` (Eq. 19-20). If
``fbar`` is an eigenvector of the closed loop, ``(Abar - D_i Cbar) fbar = sigma fbar``, every
error the fault causes stays on ``fbar`` and ``q = Cbar fbar * (scalar) = e_i * (scalar)``:
the residual of a fault on sensor ``i`` keeps the fixed direction ``e_i`` whatever the fault
signal. Writing ``D_i = [D_x; d_z]`` and using ``Abar fbar = [0; alpha]``, the condition reads

    D_x e_i = 0   and   d_z e_i = alpha - sigma,

i.e. the state part of the gain must ignore sensor ``i`` (column ``i`` of ``D_x`` is zero).
Then ``Abar - D_i Cbar = [[A - D_x C, 0], [-d_z C, sigma]]`` is block lower triangular with
eigenvalues ``eig(A - D_x C) U {sigma}``, and ``D_x C = D_x' C_{-i}`` (``C`` without row ``i``).
We take the free part from the steady-state Kalman filter of ``(A, C_{-i})``: ``D_x`` is its
predictor gain (column ``i`` zero), and ``d_z = (alpha - sigma) (e_i' - N_i)`` where
``N_i`` (zero in entry ``i``) gives the filtered estimate ``yhat_i = C_i xhat + N_i q`` of
sensor ``i`` from the *other* sensors -- the fault estimate is updated with
``y_i - yhat_i - zeta``. For ``alpha = 1`` this is the first-order low-pass
``zeta[k+1] = sigma zeta + (1 - sigma) (y_i - yhat_i)`` of the measured-minus-estimated
signal. The pole ``sigma`` is the eigenvalue assigned to the fault direction.

Conditions (Theorem 4.1, Lemmas 3.1-3.2)
-----------------------------------------
The sensor fault is detectable with a fixed direction iff ``(A, C)`` is observable; checked
with the eigenvector (PBH) test of Lemma 3.1, and a non-observable pair is refused. The
eigenvalues of ``A - D_x C`` that no gain can move are the invariant zeros of
``(Abar, fbar, Cbar)``; eliminating the ``zeta`` rows and columns of the Rosenbrock matrix
shows they are exactly the unobservable modes of ``(A, C_{-i})``. The paper does not
discuss them; they must lie inside the unit circle for a stable filter, which is checked
too. Lemma 3.2's proof assumes ``alpha`` is not an eigenvalue of ``A``; away from
``lambda = alpha`` the PBH matrix of ``(Abar, Cbar)`` has full rank iff that of ``(A, C)``
has (eliminate the ``zeta`` column), so ``(Abar, Cbar)`` is tested at ``alpha`` only. There,
``[Abar - alpha I; Cbar] [v; z] = 0`` reads ``(A - alpha I) v = 0``, ``C_{-i} v = 0`` and
``z = -C_i v``: it loses rank iff ``[A - alpha I; C_{-i}]`` does, i.e. iff ``alpha`` is a
mode of ``A`` that the other sensors do not see. That equivalent test is the one made: it
needs no scale for the fault state ``zeta`` (in sensor units, unlike ``x``).

Numerical rank and scaling
--------------------------
Observability does not depend on the units of the outputs (``C -> S C``, ``S`` diagonal) or
of the states (``A -> T^-1 A T``, ``C -> C T``), but the smallest singular value of a PBH
matrix does: a model whose ``C`` holds entries around ``1e5`` (a stiffness over a mass in
SI units) had every mode flagged as unobservable against a threshold relative to
``|A| + |C|``. The rank tests therefore run on a balanced form (:func:`pbh_scaling`): each
row of ``C`` scaled to unit norm (exactly invariant to the output units), and the states
scaled by the diagonal similarity that balances the rows and columns of ``[A; C]``
(LAPACK ``gebal`` by powers of 2, as SLICOT ``TB01ID`` and MATLAB's ``ssbal`` balance a
system before structural computations; invariant to the state units up to those powers of
2). A similarity leaves the eigenvalues and the PBH rank unchanged, and being independent
of ``lambda`` it cannot lift the rounding of an exactly unobservable mode (normalizing the
columns or rows of each ``[A - lambda I; C]`` separately could). The threshold is then
relative to the balanced ``|A| + |C|``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import linalg

from analyzer.detectors.lti import ImpulseResponseBank, LiftedBank, LiftedSystem, system_bank
from analyzer.errors import DetectorError, capped

FloatArray = npt.NDArray[np.float64]
Modes = Sequence[complex] | npt.NDArray[Any]


PBH_RTOL = 1e-9
"""Relative size of the smallest singular value of ``[A - lambda I; C]`` (in the balanced
form of :func:`pbh_scaling`) below which the mode ``lambda`` counts as unobservable
(Lemma 3.1)."""

BALANCE_SWEEPS = 4
"""At most this many rounds of (normalize the rows of ``C``, balance the states) in
:func:`pbh_scaling`; it stops as soon as a round leaves the state scaling unchanged."""

Scaling = tuple[FloatArray, FloatArray]
"""``(t, s)``: state and output scalings, :func:`pbh_scaling`."""


# -- linear-algebra checks ------------------------------------------------------------------


def observer_blocks(A: FloatArray, C: FloatArray) -> FloatArray | None:
    """The blocks ``A_1 .. A_p`` (``(p, m, m)``) when ``(A, C)`` has the block
    observer-canonical structure of :func:`ar_observer_form` (``C = [I, 0]``, identities on
    the block superdiagonal and zeros elsewhere right of the first block column), else
    None. The structure is exact (zeros and ones), so the test is an exact comparison."""
    A = np.asarray(A)
    C = np.asarray(C)
    if C.ndim != 2 or A.ndim != 2:
        return None
    m, n = C.shape
    if m == 0 or n % m or A.shape != (n, n):
        return None
    if not (
        np.array_equal(C[:, :m], np.eye(m))
        and not C[:, m:].any()
        and np.array_equal(A[:, m:], np.eye(n, n - m))
    ):
        return None
    return np.asarray(A[:, :m], dtype=np.float64).reshape(n // m, m, m)


def observer_pbh_bound(
    blocks: FloatArray, modes: Modes, sensor: int | None = None
) -> npt.NDArray[np.float64]:
    """Lower bounds, at each ``lambda`` of ``modes``, on the smallest singular value of the
    PBH matrix ``[A - lambda I; C]`` of a pair in block observer form (``blocks``:
    :func:`observer_blocks`); with ``sensor = i``, of the augmented pair's
    ``[Abar - lambda I; Cbar]`` (:func:`augment`) at ``lambda = alpha``.

    Why it holds: for a unit ``x`` with ``(A - lambda I) x = r`` and ``C x = x_1 = s``,
    ``|r|^2 + |s|^2 = eps^2``, the block rows give ``x_{j+1} = lambda x_j - A_j x_1 + r_j``,
    so ``x_j = P_j x_1 + R_j`` with ``P_1 = I``, ``P_{j+1} = lambda P_j - A_j`` and
    ``|R_j| <= eps c_j``, ``c_1 = 0``, ``c_{j+1} = |lambda| c_j + 1``; then
    ``1 = sum |x_j|^2 <= eps^2 sum (|P_j| + c_j)^2``. For the augmented pair
    (``x_1 = s - e_i z``) the last block row adds ``|P_{p+1} x_1| <= eps c_{p+1}``, which
    bounds the fault state ``|z| <= eps g``, ``g = (c_{p+1} + |P_{p+1}|) / |P_{p+1} e_i|``,
    and ``1 <= eps^2 (g^2 + sum (|P_j| (1 + g) + c_j)^2)``. Frobenius norms bound the
    spectral ones. The bound costs ``p`` products of ``m x m`` matrices per mode instead of
    an SVD of the ``(n + m) x n`` PBH matrix; 0 (no bound) where ``|P_{p+1} e_i| = 0``."""
    lam = np.asarray(modes, dtype=np.complex128).reshape(-1)
    p, m, _ = blocks.shape
    P = np.repeat(np.eye(m, dtype=np.complex128)[None], lam.size, axis=0)
    c = np.zeros(lam.size)
    norms = np.empty((p, lam.size))
    cs = np.empty((p, lam.size))
    with np.errstate(all="ignore"):  # a huge mode overflows: no bound (NaN or 0) there
        for j in range(p):
            norms[j] = np.linalg.norm(P, axis=(1, 2))
            cs[j] = c
            P = lam[:, None, None] * P - blocks[j]
            c = np.abs(lam) * c + 1.0
        if sensor is None:
            bound = 1.0 / np.sqrt(((norms + cs) ** 2).sum(axis=0))
        else:
            seen = np.linalg.norm(P[:, :, sensor], axis=1)
            g = (c + np.linalg.norm(P, axis=(1, 2))) / seen
            bound = 1.0 / np.sqrt(g**2 + ((norms * (1.0 + g) + cs) ** 2).sum(axis=0))
            bound = np.where(seen > 0.0, bound, 0.0)
    return np.where(np.isfinite(bound), bound, 0.0)


def _pbh_scale_bound(A: FloatArray, C: FloatArray) -> float:
    """An upper bound (Frobenius norms) of :func:`unobservable_modes`' ``scale``."""
    return max(1.0, float(np.linalg.norm(A)) + float(np.linalg.norm(C)))


def _unit_rows(C: FloatArray) -> FloatArray:
    """``1 / |row|`` for each row of ``C``, 1 for a zero row (it stays zero)."""
    norms = np.linalg.norm(C, axis=1) if C.size else np.ones(C.shape[0])
    return np.asarray(1.0 / np.where(norms > 0.0, norms, 1.0), dtype=np.float64)


def pbh_scaling(A: FloatArray, C: FloatArray) -> Scaling:
    """The state and output scalings ``(t, s)`` under which the PBH tests of
    :func:`unobservable_modes` run on ``(T^-1 A T, S C T)``, ``T = diag(t)``,
    ``S = diag(s)`` (module docstring, "Numerical rank and scaling").

    ``s`` scales each row of ``S C T`` to unit norm, which makes the test exactly
    invariant to the units of the outputs. ``t`` (powers of 2) balances the states: LAPACK
    ``gebal`` (:func:`scipy.linalg.matrix_balance`, no permutation) of the square
    ``[[A, 0], [S C, 0]]``, whose output rows have zero columns and are left alone, so that
    each state's row of ``A`` and its column of ``[A; S C]`` have comparable norms (the
    balancing of SLICOT ``TB01ID`` with ``B = 0``); rows of ``C`` and states alternate until
    the state scaling settles (at most :data:`BALANCE_SWEEPS` rounds). A pair in block
    observer form (:func:`observer_blocks`, the detectors' AR models of standardized
    channels) is its own balanced form: its states are outputs and sums of outputs in the
    same units and ``C = [I, 0]`` has unit rows; it is left unscaled, which keeps the exact
    structure its cheap bounds (:func:`observer_pbh_bound`) rely on."""
    A = np.asarray(A, dtype=np.float64)
    n = A.shape[0]
    C = np.asarray(C, dtype=np.float64).reshape(-1, n)
    m = C.shape[0]
    t = np.ones(n)
    if observer_blocks(A, C) is not None:
        return t, np.ones(m)
    s = _unit_rows(C)
    if n == 0 or not (np.all(np.isfinite(A)) and np.all(np.isfinite(C))):
        return t, s
    M = np.zeros((n + m, n + m))
    for _ in range(BALANCE_SWEEPS):
        M[:n, :n] = A * t[None, :] / t[:, None]
        M[n:, :n] = s[:, None] * C * t[None, :]
        _, (d, _) = linalg.matrix_balance(M, permute=False, separate=True)
        step = np.asarray(d[:n], dtype=np.float64)
        t = t * step
        s = _unit_rows(C * t[None, :])
        if np.all(step == 1.0):
            break
    return t, s


def _is_identity(scaling: Scaling) -> bool:
    return bool(np.all(scaling[0] == 1.0) and np.all(scaling[1] == 1.0))


def unobservable_modes(
    A: FloatArray,
    C: FloatArray,
    rtol: float = PBH_RTOL,
    at: Modes | None = None,
    scaling: Scaling | None = None,
) -> list[complex]:
    """Eigenvalues of ``A`` whose eigenvectors ``C`` does not see (PBH test, Lemma 3.1:
    ``(A, C)`` is observable iff ``C v != 0`` for every eigenvector ``v``). Uses the smallest
    singular value of ``[A - lambda I; C]`` so repeated eigenvalues are handled too; ``at``
    restricts the test to the given eigenvalues. The test runs on the balanced pair of
    :func:`pbh_scaling` (``scaling`` may pass the ``(t, s)`` of a larger pair, with ``s``
    restricted to the rows of ``C``), so the units of the outputs and states do not change
    the answer. A pair in block observer form (:func:`observer_blocks`) skips the SVD of
    every mode whose cheap lower bound (:func:`observer_pbh_bound`) already clears the
    threshold twice over (far above the SVD's rounding): the same answer."""
    A = np.asarray(A, dtype=np.float64)
    C = np.asarray(C, dtype=np.float64).reshape(-1, A.shape[0])
    n = A.shape[0]
    if scaling is None:
        scaling = pbh_scaling(A, C)
    t, s = (np.asarray(v, dtype=np.float64).reshape(-1) for v in scaling)
    if t.shape != (n,) or s.shape != (C.shape[0],):
        raise DetectorError(
            f"expected scalings of {n} states and {C.shape[0]} outputs, got {t.size} and {s.size}"
        )
    modes = list(np.linalg.eigvals(A) if at is None else at)  # a similarity keeps them
    if not _is_identity((t, s)):
        A = A * t[None, :] / t[:, None]
        C = s[:, None] * C * t[None, :]
    blocks = observer_blocks(A, C)
    sure = np.zeros(len(modes), dtype=bool)
    if blocks is not None and modes:
        sure = observer_pbh_bound(blocks, modes) > 2.0 * rtol * _pbh_scale_bound(A, C)
    out: list[complex] = []
    smins: dict[tuple[float, float], float] = {}
    scale = 0.0
    for lam, certain in zip(modes, sure, strict=True):
        if certain:
            continue
        if not scale:
            norm_c = float(np.linalg.norm(C, 2)) if C.size else 0.0
            scale = max(1.0, float(np.linalg.norm(A, 2)) + norm_c)
        # [A - conj(lam) I; C] is the conjugate of [A - lam I; C] (A, C real): same
        # singular values, so a complex pair needs one decomposition
        key = (float(np.real(lam)), abs(float(np.imag(lam))))
        if key not in smins:
            if key[1] == 0.0:  # a real eigenvalue: a real SVD, ~3x cheaper than complex
                pbh = np.vstack([A - key[0] * np.eye(n), C])
            else:
                pbh = np.vstack([A - lam * np.eye(n), C.astype(np.complex128)])
            smins[key] = float(np.linalg.svd(pbh, compute_uv=False)[-1])
        if smins[key] <= rtol * scale:
            out.append(complex(lam))
    return out


def check_observable(A: FloatArray, C: FloatArray, eigenvalues: Modes | None = None) -> None:
    """Raise :class:`DetectorError` unless ``(A, C)`` is observable (Theorem 4.1: the
    condition for isolating sensor faults to fixed directions). ``eigenvalues`` of ``A``
    may be passed when the caller has them."""
    bad = unobservable_modes(A, C, at=eigenvalues)
    if bad:
        raise DetectorError(
            f"(A, C) is not observable (unobservable mode(s) {_fmt_modes(bad)}): by Park et al. "
            "1994, Theorem 4.1, sensor faults cannot be isolated to fixed directions"
        )


# -- the filters ----------------------------------------------------------------------------


def augment(
    A: FloatArray, B: FloatArray, C: FloatArray, sensor: int, alpha: float = 1.0
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """``(Abar, Bbar, Cbar, fbar)`` of Park et al. (1994, Eq. 10-12, 15) for a fault on
    output ``sensor`` (fault event vector ``f_s = e_sensor``, Eq. 7), discrete time."""
    n = A.shape[0]
    m = C.shape[0]
    Ab = np.zeros((n + 1, n + 1))
    Ab[:n, :n] = A
    Ab[n, n] = alpha
    Bb = np.vstack([B, np.zeros((1, B.shape[1]))])
    fs = np.zeros((m, 1))
    fs[sensor, 0] = 1.0
    Cb = np.hstack([C, fs])
    fb = np.zeros(n + 1)
    fb[n] = 1.0
    return Ab, Bb, Cb, fb


def filter_riccati(
    A: FloatArray, C: FloatArray, Q: FloatArray, R: FloatArray, S: FloatArray | None = None
) -> FloatArray:
    """Stabilizing solution ``P`` of the filtering Riccati equation
    ``P = A P A' + Q - (A P C' + S)(C P C' + R)^-1 (A P C' + S)'``.

    The cross term is removed first (``A - S R^-1 C``, ``Q - S R^-1 S'``), then the
    structure-preserving doubling algorithm (Chu, Fan & Lin 2005) converges quadratically
    with small matrix products only; scipy's QZ-based solver is the fallback when it does
    not converge."""
    n = A.shape[0]
    A = np.asarray(A, dtype=np.float64)
    C = np.asarray(C, dtype=np.float64)
    Q = np.asarray(Q, dtype=np.float64)
    R = np.asarray(R, dtype=np.float64)
    Rinv = np.linalg.inv(R)
    if S is not None:
        S = np.asarray(S, dtype=np.float64)
        Ab = A - S @ Rinv @ C
        Qb = Q - S @ Rinv @ S.T
    else:
        Ab, Qb = A, Q
    Ak = Ab.T.copy()
    Gk = C.T @ Rinv @ C
    Hk = 0.5 * (Qb + Qb.T)
    eye = np.eye(n)
    for _ in range(100):
        W = linalg.lu_factor(eye + Gk @ Hk, check_finite=False)
        WA = linalg.lu_solve(W, Ak, check_finite=False)
        WG = linalg.lu_solve(W, Gk, check_finite=False)
        H_next = Hk + Ak.T @ Hk @ WA
        Gk = Gk + Ak @ WG @ Ak.T
        Ak = Ak @ WA
        step = float(np.abs(H_next - Hk).max())
        Hk = 0.5 * (H_next + H_next.T)
        if not np.isfinite(step):
            break
        if step <= 1e-13 * max(1.0, float(np.abs(Hk).max())):
            return Hk
    return np.asarray(linalg.solve_discrete_are(A.T, C.T, Q, R, s=S), dtype=np.float64)


def kalman_gains(
    A: FloatArray, C: FloatArray, Q: FloatArray, R: FloatArray, S: FloatArray | None = None
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Steady-state Kalman gains of ``x+ = A x + w``, ``y = C x + v`` with ``cov(w) = Q``,
    ``cov(v) = R``, ``cov(w, v) = S``: returns the predictor gain
    ``L = (A P C' + S) Re^-1``, the filter gain ``M = P C' Re^-1`` and the prediction
    covariance ``P`` (:func:`filter_riccati`), ``Re = C P C' + R``."""
    P = filter_riccati(A, C, Q, R, S)
    Re = C @ P @ C.T + R
    L = np.linalg.solve(Re, (A @ P @ C.T + (0.0 if S is None else S)).T).T
    M = np.linalg.solve(Re, C @ P).T
    return np.asarray(L, dtype=np.float64), np.asarray(M, dtype=np.float64), P


@dataclass(frozen=True, slots=True)
class ParkFilter:
    """The detection filter of one sensor, as a discrete LTI system over ``v = [y; u]``.

    State ``s = [xhat; zetahat]`` (predictions), outputs ``[q (m); zeta (1); yhat (1)]``:
    the output residual ``q = y - Cbar s - D u`` (Eq. 20), the fault estimate after sample
    ``k`` (sensor units, DC gain 1 for a constant fault) and the fault-free estimate of the
    sensor from the others, ``C_i x[k|k] + D_i u``."""

    sensor: int
    Abar: FloatArray
    Cbar: FloatArray
    gain: FloatArray
    """``D_i`` of Eq. 17, ``(n + 1, m)``."""
    alpha: float
    sigma: float
    F: FloatArray
    G: FloatArray
    H: FloatArray
    J: FloatArray
    spectral_radius: float

    @property
    def n_outputs(self) -> int:
        return int(self.Cbar.shape[0])

    @property
    def closed_loop(self) -> FloatArray:
        """``Abar - D_i Cbar`` (Eq. 19)."""
        return self.Abar - self.gain @ self.Cbar

    def settle(self, tol: float = 1e-6) -> int:
        """Samples for an initial error to decay by ``tol``."""
        rho = min(max(self.spectral_radius, 1e-3), 1.0 - 1e-9)
        return int(np.ceil(np.log(tol) / np.log(rho)))

    def lifted(self, block: int = 64) -> LiftedSystem:
        return LiftedSystem.build(self.F, self.G, self.H, self.J, block)

    def run(self, y: FloatArray, u: FloatArray | None = None, block: int = 64) -> FloatArray:
        """Outputs ``(N, m + 2)`` for outputs ``y`` (N, m) and inputs ``u`` (N, r)."""
        v = _stack_inputs(y, u, self.G.shape[1] - self.n_outputs)
        out, _ = self.lifted(block).run(v)
        return out


def _stack_inputs(y: FloatArray, u: FloatArray | None, r: int) -> FloatArray:
    y = np.asarray(y, dtype=np.float64)
    if r == 0:
        return y
    if u is None:
        raise DetectorError(f"the model has {r} measured input(s) but no input data was given")
    u = np.asarray(u, dtype=np.float64).reshape(y.shape[0], r)
    return np.hstack([y, u])


def filter_bank(filters: Sequence[ParkFilter]) -> ImpulseResponseBank | LiftedBank:
    """All ``filters`` run together over one input: as impulse responses when they forget
    their past within :data:`~analyzer.detectors.lti.MAX_TAPS` samples, else as a stacked
    lifted system."""
    return system_bank([(f.F, f.G, f.H, f.J) for f in filters], 16)


def park_filter(
    A: FloatArray,
    B: FloatArray,
    C: FloatArray,
    D: FloatArray,
    sensor: int,
    Q: FloatArray,
    R: FloatArray,
    S: FloatArray | None = None,
    *,
    alpha: float = 1.0,
    sigma: float = 0.9,
    names: Sequence[str] | None = None,
    check_observability: bool = True,
    eigenvalues: Modes | None = None,
) -> ParkFilter:
    """Design the detection filter of ``sensor`` (module docstring: augmentation Eq. 10-14,
    gain with ``fbar`` as closed-loop eigenvector, Eq. 19; checks of Theorem 4.1).

    ``B``, ``D`` are the columns of the *measured* inputs (may have zero columns); ``Q``,
    ``R``, ``S`` the process, measurement and cross noise covariances that set the free part
    of the gain (the Kalman filter of ``(A, C_{-i})``); ``sigma`` the closed-loop pole of the
    fault estimate, ``0 <= sigma < alpha <= 1``. ``check_observability=False`` skips the
    test of Theorem 4.1 when the caller (a bank) has done it once for all sensors;
    ``eigenvalues`` of ``A`` may be passed likewise (computed here otherwise)."""
    A = np.asarray(A, dtype=np.float64)
    C = np.asarray(C, dtype=np.float64)
    n = A.shape[0]
    m = C.shape[0]
    if A.shape != (n, n):
        raise DetectorError(f"expected a square matrix for A, got {A.shape}")
    if C.ndim != 2 or C.shape[1] != n:
        raise DetectorError(f"expected a ({m}, {n}) matrix for C, got {C.shape}")
    B = np.asarray(B, dtype=np.float64).reshape(n, -1)
    D = np.asarray(D, dtype=np.float64).reshape(m, B.shape[1])
    label = names[sensor] if names is not None else f"output {sensor}"
    if not 0 <= sensor < m:
        raise DetectorError(f"sensor index {sensor} out of range for {m} outputs")
    if not 0.0 <= sigma < alpha <= 1.0:
        raise DetectorError(
            f"need 0 <= sigma < alpha <= 1 for the fault estimate, got sigma={sigma}, alpha={alpha}"
        )
    eig = np.linalg.eigvals(A) if eigenvalues is None else np.asarray(eigenvalues)
    if check_observability:
        check_observable(A, C, eig)
    Ab, Bb, Cb, fb = augment(A, B, C, sensor, alpha)
    blocks = observer_blocks(A, C)
    others = [j for j in range(m) if j != sensor]
    Co = C[others]
    t, s = pbh_scaling(A, C)  # the balanced form of the whole pair, for both tests below
    # Lemma 3.2: away from lambda = alpha the PBH matrix of (Abar, Cbar) has full rank iff
    # that of (A, C) has (eliminate the zeta column), and at alpha iff that of (A, C_{-i})
    # has (module docstring), so only (A, C_{-i}) at alpha needs a test; in block observer
    # form a lower bound of the augmented matrix's smallest singular value usually settles
    # it (it bounds that of [A - alpha I; C_{-i}] too: take z = -C_i v; and the threshold
    # bound of (Abar, Cbar) exceeds the threshold of (A, C_{-i}))
    certain = blocks is not None and bool(
        observer_pbh_bound(blocks, [alpha], sensor)[0] > 2.0 * PBH_RTOL * _pbh_scale_bound(Ab, Cb)
    )
    if not certain and unobservable_modes(A, Co, at=[alpha], scaling=(t, s[others])):
        raise DetectorError(
            f"the augmented pair (Abar, Cbar) for {label} is not observable: the fault pole "
            f"alpha={alpha} is a mode of A seen only by {label} (Lemma 3.2); choose another "
            "fault_pole"
        )
    fixed = unobservable_modes(
        A, Co, at=[lam for lam in eig if abs(lam) >= 1.0 - 1e-9], scaling=(t, s[others])
    )
    if fixed:
        raise DetectorError(
            f"no stable detection filter for {label}: the invariant zero(s) "
            f"{_fmt_modes(fixed)} of the augmented fault (the modes of A the other sensors do "
            "not observe) lie on or outside the unit circle"
        )
    # free part of the gain: Kalman filter of (A, C_{-i}); column `sensor` stays zero
    Lx = np.zeros((n, m))  # state predictor gain D_x
    Ny = np.zeros(m)  # filtered estimate of y_i: yhat_i[k|k] = C_i xhat + Ny (y - C xhat - D u)
    rho_x: float | None = None  # spectral radius of A - D_x C, when known without eigvals
    if others:
        R = np.asarray(R, dtype=np.float64)
        Q = np.asarray(Q, dtype=np.float64)
        reduced = None
        if blocks is not None and _innovations_form(A, Q, R, S):
            try:
                reduced = _ar_state_gain(A, blocks, R, sensor)
            except (linalg.LinAlgError, ValueError):
                reduced = None  # the general design decides (and words the error)
        if reduced is not None:
            Lx[:, others], Ny[others], rho_x = reduced
        else:
            Ro = R[np.ix_(others, others)]
            So = None if S is None else np.asarray(S, dtype=np.float64)[:, others]
            try:
                Lo, _, P = kalman_gains(A, Co, Q, Ro, So)
            except (linalg.LinAlgError, ValueError) as err:
                raise DetectorError(
                    f"the state gain of the detection filter for {label} has no stabilizing "
                    f"Riccati solution ({err})"
                ) from err
            Lx[:, others] = Lo
            Re = Co @ P @ Co.T + Ro
            # E[y_i | innovations of the others]: through the state and through the
            # measurement noise's correlation with the others' (zero for a diagonal R)
            Ny[others] = np.linalg.solve(Re, Co @ P @ C[sensor] + R[others, sensor])
    ei = np.zeros(m)
    ei[sensor] = 1.0
    dz = (alpha - sigma) * (ei - Ny)
    gain = np.vstack([Lx, dz[None, :]])
    # the Beard-Jones condition: fbar is an eigenvector of the closed loop (Eq. 19)
    cl = Ab - gain @ Cb
    if not np.allclose(cl @ fb, sigma * fb, atol=1e-9 * max(1.0, float(np.abs(cl).max()))):
        raise DetectorError("internal error: the fault direction is not a closed-loop eigenvector")
    # eig(cl) = eig(A - D_x C) U {sigma} (block triangular); with the AR reduction the
    # former are those of the p-state filter plus zeros, which a dense eigensolver returns
    # as rounding-sized values (a nilpotent block's eigenvalues move by eps^(1/p)): the
    # dense spectrum is taken when the radius is not clear of them
    rho_fast = None if rho_x is None else max(rho_x, sigma)
    if (
        rho_fast is not None
        and blocks is not None
        and rho_fast >= 4.0 * 1e-12 ** (1.0 / blocks.shape[0])
    ):
        rho = float(rho_fast)
    else:
        rho = float(np.max(np.abs(np.linalg.eigvals(cl))))
    if not rho < 1.0:
        raise DetectorError(
            f"the detection filter for {label} is unstable (spectral radius {rho:.6f})"
        )
    # LTI form over v = [y; u]
    F = cl
    G = np.hstack([gain, Bb - gain @ D])
    norm = (1.0 - sigma) / (alpha - sigma)  # DC gain of the fault estimate -> 1
    Hq = -Cb
    Jq = np.hstack([np.eye(m), -D])
    Hz = norm * cl[n : n + 1]
    Jz = norm * G[n : n + 1]
    ci = C[sensor]
    Hy = np.concatenate([ci - Ny @ C, [0.0]])[None, :]
    Jy = np.concatenate([Ny, D[sensor] - Ny @ D])[None, :]
    H = np.vstack([Hq, Hz, Hy])
    J = np.vstack([Jq, Jz, Jy])
    return ParkFilter(sensor, Ab, Cb, gain, alpha, sigma, F, G, H, J, rho)


def _innovations_form(
    A: FloatArray, Q: FloatArray, R: FloatArray, S: FloatArray | None, rtol: float = 1e-12
) -> bool:
    """Whether the noise of a pair in block observer form is that of its AR model's
    innovations (:func:`model_from_ar`): ``Q = K R K'``, ``S = K R`` with ``K`` the first
    block column of ``A`` (to ``rtol``)."""
    if S is None:
        return False
    m = R.shape[0]
    K = np.ascontiguousarray(A[:, :m])
    KR = K @ R
    S = np.asarray(S, dtype=np.float64)
    if S.shape != KR.shape or Q.shape != A.shape:
        return False

    def close(x: FloatArray, y: FloatArray) -> bool:
        return bool(np.abs(x - y).max() <= rtol * max(float(np.abs(y).max()), 1e-300))

    return close(S, KR) and close(Q, KR @ K.T)


def _ar_state_gain(
    A: FloatArray, blocks: FloatArray, R: FloatArray, sensor: int
) -> tuple[FloatArray, FloatArray, float]:
    """The free part of the gain for ``sensor`` when the model is an AR model's
    innovations form in block observer form (``A - K C`` the block shift ``Z``,
    ``Q = K R K'``, ``S = K R``): ``(D_x`` columns of the other sensors, ``N_i`` entries of
    the other sensors, spectral radius of ``A - D_x C)``, as :func:`kalman_gains` of
    ``(A, C_{-i})`` gives them, from a Riccati equation of ``p`` states instead of ``n``.

    The state is the AR prediction from the last ``p`` outputs,
    ``x[k] = sum_l Z^l K y[k-1-l]``, so knowing the other sensors exactly leaves unknown
    only the last ``p`` values of sensor ``i``, ``eta[k] = (y_i[k-1], ..., y_i[k-p])``:
    ``x = (known) + T eta`` with ``T = [K e_i, Z K e_i, ...]`` and
    ``eta[k+1] = (N + e_1 C_i T) eta + e_1 e_i[k]``, ``y_o = (known) + C_o T eta + e_o``
    (``N`` the shift, ``C T = [A_1 e_i, ..., A_p e_i]``). Its Kalman filter has the
    prediction covariance ``Pr`` with ``P = T Pr T'`` (rank ``p``), hence the gains. The
    closed loop ``A - D_x C`` maps ``range(T)`` as the reduced closed loop
    ``Fr = Ar - Lr Cr`` does (the Riccati identity ``Re = Cr Pr Cr' + R_oo``) and acts as
    the nilpotent shift ``Z`` on the rest (its gain's columns of the other sensors are
    ``K e_i w'`` modulo ``range(T)``): its eigenvalues are ``eig(Fr)`` and zeros."""
    p, m, _ = blocks.shape
    n = p * m
    others = [j for j in range(m) if j != sensor]
    CT = blocks[:, :, sensor].T  # (m, p): column l is A_{l+1} e_i
    Ar = np.eye(p, k=-1)
    Ar[0] += CT[sensor]
    Cr = CT[others]
    Qr = np.zeros((p, p))
    Qr[0, 0] = R[sensor, sensor]
    Rr = R[np.ix_(others, others)]
    Sr = np.zeros((p, m - 1))
    Sr[0] = R[sensor, others]
    Pr = filter_riccati(Ar, Cr, Qr, Rr, Sr)
    if not np.all(np.isfinite(Pr)):
        raise ValueError("no finite solution of the reduced Riccati equation")
    Re = Cr @ Pr @ Cr.T + Rr
    cross = Pr @ Cr.T  # (p, m - 1)
    col = A[:, sensor]  # K e_i; Z shifts a state up by one block
    T = np.zeros((n, p))
    for lag in range(p):
        T[: n - lag * m, lag] = col[lag * m :]
    Lo = np.linalg.solve(Re, ((A @ T) @ cross + A[:, :m] @ R[:, others]).T).T
    Lr = np.linalg.solve(Re, (Ar @ cross + Sr).T).T
    Ny = np.linalg.solve(Re, cross.T @ CT[sensor] + R[others, sensor])
    rho = float(np.max(np.abs(np.linalg.eigvals(Ar - Lr @ Cr))))
    return np.asarray(Lo, dtype=np.float64), np.asarray(Ny, dtype=np.float64), rho


def _fmt_modes(modes: Sequence[complex]) -> str:
    parts = [
        f"{z.real:.4g}" if abs(z.imag) < 1e-12 else f"{z.real:.4g}{z.imag:+.4g}j" for z in modes
    ]
    return capped(parts, 4)
