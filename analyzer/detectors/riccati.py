"""Discrete algebraic Riccati equation by the structure-preserving doubling algorithm.

``scipy.linalg.solve_discrete_are`` solves the DARE through an ordered QZ decomposition of
a ``2n x 2n`` pencil: robust, but about 0.7 s at ``n = 160`` states, and the bank of
estimators solves one DARE per sensor (and per cross-validation fold), which made fitting
a 16-channel order-10 bank take over a minute. The doubling algorithm (Chu, Fan, Lin,
Wang, "Structure-preserving algorithms for periodic discrete-time algebraic Riccati
equations", Int. J. Control 77, 2004; Lin & Xu, "Convergence analysis of structure-
preserving doubling algorithms for Riccati-type matrix equations", SIAM J. Matrix Anal.
Appl. 28, 2006) needs only ``n x n`` products and solves and converges quadratically: each
step squares the closed loop's spectral radius, so ``k`` steps reach ``rho^(2^k)``.

Solved here, with the same arguments and meaning as scipy's::

    A' X A - X - (A' X B + S) (R + B' X B)^-1 (B' X A + S') + Q = 0

The cross term is removed first (``A <- A - B R^-1 S'``, ``Q <- Q - S R^-1 S'``); the
equation then reads ``X = A' X (I + G X)^-1 A + Q`` with ``G = B R^-1 B'``, and the
iteration is::

    W_k     = I + G_k H_k
    A_{k+1} = A_k W_k^-1 A_k
    G_{k+1} = G_k + A_k W_k^-1 G_k A_k'
    H_{k+1} = H_k + A_k' H_k W_k^-1 A_k        (H_0 = Q, H_k -> X)

Each step costs one ``n x n`` inverse and eight products.

Given the solution of a nearby equation (a cross-validation fold's model differs little
from the whole window's), Newton's method (Hewer's iteration) starts from it instead and
converges quadratically in 3-4 steps, each a Stein equation solved by Smith's squaring
(products only): at 160 states ~14 ms against ~18 ms for the doubling from scratch. The
cross-validation folds take only its first step (:func:`newton_step`): within ~1e-4 of
the fold's solution, which moves the statistics calibrated from the folds by ~1e-5.

The result is checked by its relative residual; where the iterations do not converge
(no stabilizing solution, badly conditioned ``W``), scipy's QZ solver decides, so a model
scipy accepts is never refused and a model it refuses is refused with its message.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy import linalg

FloatArray = npt.NDArray[np.float64]

MAX_STEPS = 60
"""Doubling steps before giving up (each squares the convergence factor)."""

TOLERANCE = 1e-12
"""Relative change of ``H`` at which the iteration has converged."""

RESIDUAL_LIMIT = 1e-8
"""Largest relative residual of the Riccati equation accepted from the doubling (or from
Newton's method)."""


NEWTON_STEPS = 12
"""Newton steps from a given start before falling back to the doubling."""

STEIN_ACCURACY = 1e-8
"""Relative accuracy of the Stein equation solved in each Newton step: an inexact step
still converges (linearly at this rate on top of the quadratic rate), and the converged
``X`` is exact (the residual each step corrects is computed in full)."""

STEIN_SQUARINGS = 40
"""Squarings of the closed loop before a Stein equation is given up (not stable)."""


def solve_dare(
    a: FloatArray,
    b: FloatArray,
    q: FloatArray,
    r: FloatArray,
    s: FloatArray | None = None,
    check_stable: bool = True,
    start: FloatArray | None = None,
) -> FloatArray:
    """The stabilizing solution ``X`` of the DARE (arguments as
    :func:`scipy.linalg.solve_discrete_are`). ``check_stable=False`` leaves the check of
    the closed loop's eigenvalues to a caller that computes them anyway (and falls back to
    scipy itself when they are not inside the unit circle).

    ``start``: an approximate solution, such as the solution of the same equation for a
    model fitted on nearly the same data (a cross-validation fold). Newton's method
    (:func:`_newton`) then converges from it in a few steps of products only; where it
    does not (the start's gain does not stabilize), the doubling decides, so the answer
    is the same stabilizing solution either way."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    r = np.asarray(r, dtype=np.float64)
    x = None if start is None or s is not None else _newton(a, b, q, r, start)
    if x is None or not _relative_residual(x, a, b, q, r, s) < RESIDUAL_LIMIT:
        x = _doubling(a, b, q, r, s)
        if x is None or not _relative_residual(x, a, b, q, r, s) < RESIDUAL_LIMIT:
            return solve_dare_scipy(a, b, q, r, s)
    if not check_stable or _stabilizing(x, a, b, r, s):
        return x
    return solve_dare_scipy(a, b, q, r, s)


def solve_dare_scipy(
    a: FloatArray, b: FloatArray, q: FloatArray, r: FloatArray, s: FloatArray | None = None
) -> FloatArray:
    """scipy's QZ solver (the reference, and the fallback)."""
    return np.asarray(linalg.solve_discrete_are(a, b, q, r, s=s), dtype=np.float64)


def _doubling(
    a: FloatArray, b: FloatArray, q: FloatArray, r: FloatArray, s: FloatArray | None
) -> FloatArray | None:
    n = a.shape[0]
    try:
        rc = linalg.cho_factor(r)
    except linalg.LinAlgError:
        return None  # R not positive definite: scipy decides
    Ak = a.copy()
    Hk = q.copy()
    if s is not None:
        s = np.asarray(s, dtype=np.float64)
        Ak = Ak - b @ linalg.cho_solve(rc, s.T)
        Hk = Hk - s @ linalg.cho_solve(rc, s.T)
    Gk = b @ linalg.cho_solve(rc, b.T)
    eye = np.eye(n)
    with np.errstate(all="ignore"):
        for _ in range(MAX_STEPS):
            W = eye + Gk @ Hk
            try:  # one inverse and two products: ~2x faster than two n-column solves
                Wi = linalg.inv(W, check_finite=False)
            except (linalg.LinAlgError, ValueError):
                return None
            WA = Wi @ Ak  # W^-1 A
            WG = Wi @ Gk  # W^-1 G
            H_next = Hk + Ak.T @ Hk @ WA
            Gk = Gk + Ak @ WG @ Ak.T
            Ak = Ak @ WA
            if not np.all(np.isfinite(H_next)):
                return None
            change = np.max(np.abs(H_next - Hk))
            Hk = H_next
            if change <= TOLERANCE * max(1.0, float(np.max(np.abs(Hk)))):
                return 0.5 * (Hk + Hk.T)
    return None


def _newton(
    a: FloatArray, b: FloatArray, q: FloatArray, r: FloatArray, start: FloatArray
) -> FloatArray | None:
    """Newton's method for the DARE (Hewer 1971, "An iterative technique for the
    computation of the steady state gains for the discrete optimal regulator", IEEE TAC
    16; Kleinman's iteration in discrete time) from ``start``: with the gain
    ``K = (R + B' X B)^-1 B' X A`` of the current ``X`` and its closed loop
    ``Ac = A - B K``, the step ``D = X_next - X`` solves the Stein equation::

        D - Ac' D Ac = DARE(X) = A' X A - X - A' X B K + Q

    by Smith's squaring (:func:`_stein`, products only). From a stabilizing gain the
    steps stay stabilizing and converge quadratically to the stabilizing solution;
    they stop on the doubling's criterion (relative change at most ``TOLERANCE``).
    None when a step fails (a closed loop that is not stable, a singular ``R + B' X B``):
    the caller then solves from scratch."""
    x = 0.5 * (start + start.T)
    with np.errstate(all="ignore"):
        for _ in range(NEWTON_STEPS):
            d = _newton_correction(a, b, q, r, x)
            if d is None:
                return None
            x = x + d
            change = float(np.max(np.abs(d)))
            if not np.isfinite(change):
                return None
            if change <= TOLERANCE * max(1.0, float(np.max(np.abs(x)))):
                return 0.5 * (x + x.T)
    return None


def newton_step(
    a: FloatArray, b: FloatArray, q: FloatArray, r: FloatArray, start: FloatArray
) -> FloatArray | None:
    """One step of Newton's method (:func:`_newton`) from ``start``, the solution of a
    nearby equation: the first-order correction of ``start`` to this equation's solution.

    Newton's method converges quadratically, so from a start within a relative distance
    ``e`` of the solution one step lands within about ``e^2``: for a cross-validation
    fold's model, fitted on 80 % of the training window, ``e`` is ~1e-2 and the step
    ~1e-4. The steady-state gain it gives is that close to the fold's optimal gain, and
    the innovations' variance is stationary at the optimal gain, so their statistics
    move by ~1e-8 (the calibration's, measured: ~1e-5 relative at most; see
    ``tests/detectors/test_fit_fast_paths.py``), for a third of the steps the converged
    solution takes. None when the step fails (the start's closed loop is not stable,
    ``R + B' X B`` singular): the caller then solves the equation."""
    x = 0.5 * (start + start.T)
    with np.errstate(all="ignore"):
        d = _newton_correction(a, b, q, r, x)
        if d is None:
            return None
        x = x + d
        if not np.all(np.isfinite(x)):
            return None
    return 0.5 * (x + x.T)


def _newton_correction(
    a: FloatArray, b: FloatArray, q: FloatArray, r: FloatArray, x: FloatArray
) -> FloatArray | None:
    """One Newton step's ``D = X_next - X`` from the symmetric ``x`` (:func:`_newton`),
    or None when ``R + B' X B`` is singular or the closed loop is not stable."""
    xb = x @ b
    try:
        k = np.linalg.solve(r + b.T @ xb, xb.T @ a)
    except np.linalg.LinAlgError:
        return None
    res = a.T @ (x @ a) - x - (a.T @ xb) @ k + q
    scale = max(1.0, float(np.max(np.abs(x))))
    return _stein(a - b @ k, 0.5 * (res + res.T), 0.01 * TOLERANCE * scale)


def _stein(ac: FloatArray, c: FloatArray, floor: float) -> FloatArray | None:
    """``D = sum_i Ac'^i C Ac^i`` (the solution of ``D - Ac' D Ac = C``) by Smith's
    squaring: ``D <- D + P' D P``, ``P <- P^2`` doubles the terms summed each step. It
    stops when the rest, at most ``|P|_F^2 |D|``, is below :data:`STEIN_ACCURACY` of
    ``D`` or below ``floor``; None when ``P`` does not shrink (``Ac`` not stable)."""
    d = c
    p = ac
    for _ in range(STEIN_SQUARINGS):
        d = d + p.T @ d @ p
        p = p @ p
        tail = float(np.sum(p * p))
        size = float(np.max(np.abs(d)))
        if not (np.isfinite(tail) and np.isfinite(size)):
            return None
        if tail <= STEIN_ACCURACY or tail * size <= floor:
            return d
    return None


def _stabilizing(
    x: FloatArray, a: FloatArray, b: FloatArray, r: FloatArray, s: FloatArray | None
) -> bool:
    """Whether ``A - B K`` (``K`` the gain of ``x``) has every eigenvalue inside the unit
    circle: the doubling converges to the stabilizing solution, this guards the rest."""
    axb = a.T @ x @ b if s is None else a.T @ x @ b + s
    try:
        k = np.linalg.solve(r + b.T @ x @ b, axb.T)
    except np.linalg.LinAlgError:
        return False
    return bool(np.max(np.abs(np.linalg.eigvals(a - b @ k))) < 1.0)


def _relative_residual(
    x: FloatArray,
    a: FloatArray,
    b: FloatArray,
    q: FloatArray,
    r: FloatArray,
    s: FloatArray | None,
) -> float:
    """``|DARE(x)| / (|A' X A| + |X| + |Q|)`` in the max norm."""
    axb = a.T @ x @ b if s is None else a.T @ x @ b + s
    try:
        gain = np.linalg.solve(r + b.T @ x @ b, axb.T)
    except np.linalg.LinAlgError:
        return np.inf
    axa = a.T @ x @ a
    res = axa - x - axb @ gain + q
    scale = np.max(np.abs(axa)) + np.max(np.abs(x)) + np.max(np.abs(q))
    if not np.isfinite(res).all() or scale == 0:
        return np.inf
    return float(np.max(np.abs(res)) / scale)


__all__ = ["newton_step", "solve_dare", "solve_dare_scipy"]
