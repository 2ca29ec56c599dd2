"""The indirect approach of Li, Koh & Nagarajaiah (2007), Eq. 1-25: from a known discrete
model ``(A, B, C, D)``, the inverse model that treats the uncertain sensors as inputs
(Eq. 3-9), the stacked observability and Toeplitz matrices of a window of reference
samples (Eq. 10-14), and the left null space that eliminates the state and the other
uncertain sensors (Eq. 15-21), computed by SVD (:func:`decoupling_basis`), with the
paper's own construction (Eq. 18 by pseudoinverse, then Eq. 21) as
:func:`paper_coefficients`. :class:`~analyzer.detectors.error_function.ErrorFunction`
chooses among the null space's vectors and runs the error functions."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.errors import ConfigError, DetectorError
from analyzer.stats.results import json_float

FloatArray = npt.NDArray[np.float64]

MAX_COND = 1.0 / math.sqrt(np.finfo(np.float64).eps)
"""Condition number above which ``D_d`` (Eq. 3) is treated as singular: its
pseudoinverse would amplify rounding by more than half the available digits."""


@dataclass(frozen=True, slots=True)
class InverseModel:
    """Eq. 8: ``x(k+1) = Ab x(k) + Bb v(k)``, ``y_s(k) = Cb x(k) + Db v(k)`` with
    ``v = [y_d; u_m]`` (uncertain sensors, then measured inputs) as inputs and the
    reference sensors as outputs; the unmeasured inputs are eliminated by Eq. 3."""

    Ab: FloatArray
    Bb: FloatArray
    Cb: FloatArray
    Db: FloatArray
    n_d: int
    cond_Dd: float


def _matrix(model: Mapping[str, Any], key: str) -> FloatArray:
    if key not in model:
        raise ConfigError(f"[model]: missing matrix {key}")
    try:
        a = np.atleast_2d(np.asarray(model[key], dtype=np.float64))
    except (TypeError, ValueError) as err:
        raise ConfigError(f"[model]: {key} is not a numeric matrix ({err})") from err
    if a.ndim != 2 or not np.all(np.isfinite(a)):
        raise ConfigError(f"[model]: {key} must be a finite 2-D matrix, got shape {a.shape}")
    return a


def model_matrices(
    model: Mapping[str, Any],
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, list[str], list[str]]:
    """``(A, B, C, D, outputs, inputs)`` from ``[model]``, with their shapes checked."""
    A, B, C, D = (_matrix(model, k) for k in ("A", "B", "C", "D"))
    n = A.shape[0]
    if A.shape != (n, n):
        raise ConfigError(f"[model]: expected a square matrix for A, got {A.shape}")
    if B.shape[0] != n:
        raise ConfigError(f"[model]: expected B with {n} rows, got {B.shape}")
    r = B.shape[1]
    if C.shape[1] != n:
        raise ConfigError(f"[model]: expected C with {n} columns, got {C.shape}")
    if D.shape != (C.shape[0], r):
        raise ConfigError(f"[model]: expected a {(C.shape[0], r)} matrix for D, got {D.shape}")
    outputs = [str(o) for o in model.get("outputs", [])]
    if len(outputs) != C.shape[0]:
        raise ConfigError(
            f"[model]: 'outputs' names {len(outputs)} channel(s) for the {C.shape[0]} rows of C"
        )
    inputs = [str(u) for u in model.get("inputs", [])]
    if inputs and len(inputs) != r:
        raise ConfigError(
            f"[model]: 'inputs' names {len(inputs)} channel(s) for the {r} columns of B "
            f"(leave it empty when the inputs are not measured)"
        )
    return A, B, C, D, outputs, inputs or [""] * r


def unmeasured_inputs(r: int, measured_cols: Sequence[int]) -> list[int]:
    """The columns of ``B`` (of ``r``) that are not measured: the inputs the inverse
    model eliminates (Eq. 3)."""
    measured = set(measured_cols)
    return [c for c in range(r) if c not in measured]


def inverse_model(
    A: FloatArray,
    B: FloatArray,
    C: FloatArray,
    D: FloatArray,
    uncertain_rows: Sequence[int],
    reference_rows: Sequence[int],
    measured_cols: Sequence[int] = (),
) -> InverseModel:
    """Inverse model of Eq. 3-9: the unmeasured inputs ``u = D_d^+ (y_d - C_d x - ...)``
    (Eq. 3) are substituted into the state and reference equations (Eq. 4-8). Unlike
    Eq. 9, a direct term ``Db = D_s D_d^+`` is kept (it is zero when the references are
    not collocated with an input, as in the paper).

    The uncertain sensors enter the inverse model only through that substitution: they
    stand in for the inputs it eliminates (Eq. 5, "the inputs and outputs have been
    switched"). With every input measured there is nothing to eliminate, ``y_d`` drops
    out of Eq. 4-8 and no error function could respond to its sensor: refused
    (:func:`unmeasured_inputs`)."""
    r = B.shape[1]
    mcols = list(measured_cols)
    ucols = unmeasured_inputs(r, mcols)
    if not ucols:
        raise DetectorError(
            f"the inverse model (Li et al. 2007, Eq. 3-8) needs at least one unmeasured "
            f"input to eliminate through the uncertain sensors; all {r} input(s) are measured"
        )
    Cd, Cs = C[list(uncertain_rows)], C[list(reference_rows)]
    Ddu, Dsu = D[np.ix_(uncertain_rows, ucols)], D[np.ix_(reference_rows, ucols)]
    Ddm, Dsm = D[np.ix_(uncertain_rows, mcols)], D[np.ix_(reference_rows, mcols)]
    Bu, Bm = B[:, ucols], B[:, mcols]
    n_d = len(uncertain_rows)
    sv = np.linalg.svd(Ddu, compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
    if len(sv) < len(ucols) or not cond < MAX_COND:
        raise DetectorError(
            f"D_d (uncertain sensors x unmeasured inputs, {Ddu.shape}) is singular or "
            f"ill-conditioned (condition number {cond:.3g}): the inverse model "
            f"(Li et al. 2007, Eq. 3) needs every unmeasured input to reach the "
            f"uncertain sensors directly"
        )
    Ddp = np.linalg.pinv(Ddu)
    Ab = A - Bu @ Ddp @ Cd
    Bb = np.hstack([Bu @ Ddp, Bm - Bu @ Ddp @ Ddm])
    Cb = Cs - Dsu @ Ddp @ Cd
    Db = np.hstack([Dsu @ Ddp, Dsm - Dsu @ Ddp @ Ddm])
    return InverseModel(Ab, Bb, Cb, Db, n_d, cond)


def stacked_matrices(
    inv: InverseModel, p: int
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """``(O, T, tau, Ab^p)`` of Eq. 10-12 for the window ``v(k), ..., v(k+p-1)``:
    ``y_ps(k) = O x(k) + T v_p(k)``, ``x(k+p) = Ab^p x(k) + tau v_p(k)``. ``T`` carries
    ``Db`` on its block diagonal (zero in the paper's Eq. 12)."""
    n = inv.Ab.shape[0]
    n_s, q = inv.Db.shape
    powers = [np.eye(n)]
    for _ in range(p):
        powers.append(powers[-1] @ inv.Ab)
    Ob = np.vstack([inv.Cb @ powers[j] for j in range(p)])
    markov = [inv.Db] + [inv.Cb @ powers[j] @ inv.Bb for j in range(p - 1)]
    T = np.zeros((p * n_s, p * q))
    for a in range(p):
        for b in range(a + 1):
            T[a * n_s : (a + 1) * n_s, b * q : (b + 1) * q] = markov[a - b]
    tau = np.hstack([powers[p - 1 - j] @ inv.Bb for j in range(p)])
    return Ob, T, tau, powers[p]


def decoupling_system(
    inv: InverseModel, p: int, i: int
) -> tuple[FloatArray, FloatArray, list[int]]:
    """For examined uncertain sensor ``i`` (column of ``v``): ``Z`` whose left null space
    holds the decoupled ``w = [g, h]`` (``g`` weighs ``y_s(k+p)``, ``h`` weighs
    ``y_ps(k)``; Eq. 17 and 21), and ``F`` mapping ``w`` to the FIR taps of every window
    channel (kept channels ``[i, measured inputs]``, then references; steps ``0..p``)."""
    Ob, T, tau, Ap = stacked_matrices(inv, p)
    n_s, q = inv.Db.shape
    cb_tau = inv.Cb @ tau
    elim = [j for j in range(inv.n_d) if j != i]
    kept = [i, *range(inv.n_d, q)]
    top = [inv.Cb @ Ap]
    bottom = [Ob]
    for j in elim:
        cols = [s * q + j for s in range(p)]
        top += [cb_tau[:, cols], inv.Db[:, [j]]]
        bottom += [T[:, cols], np.zeros((p * n_s, 1))]
    Z = np.vstack([np.hstack(top), np.hstack(bottom)])
    # taps: e(k+p) = sum_c sum_s tap[c, s] y_c(k+s)
    m = (len(kept) + n_s) * (p + 1)
    F = np.zeros((m, n_s * (p + 1)))
    for a, c in enumerate(kept):
        cols = [s * q + c for s in range(p)]
        base = a * (p + 1)
        F[base : base + p, :n_s] = -cb_tau[:, cols].T
        F[base : base + p, n_s:] = -T[:, cols].T
        F[base + p, :n_s] = -inv.Db[:, c]
    for a in range(n_s):
        base = (len(kept) + a) * (p + 1)
        for s in range(p):
            F[base + s, n_s + s * n_s + a] = 1.0
        F[base + p, a] = 1.0
    return Z, F, kept


def decoupling_basis(
    inv: InverseModel, p: int, i: int, ref_scale: FloatArray
) -> tuple[FloatArray, FloatArray, dict[str, Any]]:
    """Basis of all error functions of sensor ``i`` that are decoupled from the state and
    the other uncertain sensors (Eq. 17 and 21 together): the left null space of ``Z``
    by SVD, rows scaled by the references' spread ``ref_scale`` and columns to unit norm
    (neither changes the null space, both help the numerical rank). Returns
    ``(basis, F, info)``: ``F @ basis`` are the FIR taps (physical units) of the basis."""
    Z, F, _ = decoupling_system(inv, p, i)
    row_scale = np.tile(ref_scale, p + 1)
    Zs = Z * row_scale[:, None]
    norms = np.linalg.norm(Zs, axis=0)
    Zs = Zs[:, norms > 0] / norms[norms > 0]
    U, sv, _ = np.linalg.svd(Zs, full_matrices=True)
    tol = max(Zs.shape) * np.finfo(np.float64).eps * (sv[0] if sv.size else 0.0)
    rank = int(np.sum(sv > tol))
    if rank >= Zs.shape[0]:
        raise DetectorError(
            f"no error function decouples uncertain sensor {i} with p={p}: the "
            f"{Zs.shape[0]} x {Zs.shape[1]} decoupling matrix (Eq. 17) has full row rank; "
            f"increase p"
        )
    basis = U[:, rank:] * row_scale[:, None]  # back to physical w = [g, h]
    info = {
        "decoupling_rank": rank,
        "null_dim": int(Zs.shape[0] - rank),
        "singular_values_smallest": [float(v) for v in sv[max(0, rank - 8) : rank]],
        "singular_value_largest": float(sv[0]),
        "rank_tolerance": float(tol),
        "condition_number": json_float(float(sv[0] / sv[rank - 1])) if rank else None,
    }
    return basis, F, info


def paper_coefficients(inv: InverseModel, p: int, i: int) -> tuple[FloatArray, dict[str, Any]]:
    """The paper's construction: ``C_s M_i`` from Eq. 18 by truncated pseudoinverse, then
    ``N_i`` orthogonal to what Eq. 18 leaves of the other uncertain sensors (Eq. 21), and
    ``w = [N_i^T, N_i^T C_s M_i]``. The pseudoinverse's truncation rank is chosen to
    minimize the leakage of the state and the other sensors into ``e_i`` (the graded
    small singular values of ``[O T_j]`` are genuine, so neither the full inverse nor a
    fixed tolerance is reliable). Returns ``(w, info)``."""
    Ob, T, tau, Ap = stacked_matrices(inv, p)
    n_s, q = inv.Db.shape
    cb_tau = inv.Cb @ tau
    Z, _, _ = decoupling_system(inv, p, i)
    lhs_cols: list[FloatArray] = [Ob]
    rhs_cols: list[FloatArray] = [inv.Cb @ Ap]
    for j in [j for j in range(inv.n_d) if j != i]:
        for s in range(p):
            col = T[:, [s * q + j]]
            if np.any(col != 0.0):  # the paper's Eq. 18 omits the all-zero last column
                lhs_cols.append(col)
                rhs_cols.append(cb_tau[:, [s * q + j]])
    L = np.hstack(lhs_cols)
    R = -np.hstack(rhs_cols)
    scale = np.linalg.norm(L, axis=0)
    scale[scale == 0] = 1.0
    U, sv, Vt = np.linalg.svd(L / scale, full_matrices=False)
    proj = (R / scale) @ Vt.T  # n_s x rank
    znorm = np.linalg.norm(Z, axis=0)
    Zn = Z[:, znorm > 0] / znorm[znorm > 0]
    best: tuple[float, FloatArray, int] | None = None
    X = np.zeros((n_s, L.shape[0]))
    for k in range(len(sv)):
        if sv[k] <= max(L.shape) * np.finfo(np.float64).eps * sv[0]:
            break
        X = X + np.outer(proj[:, k] / sv[k], U[:, k])
        # leftover of every eliminated term, per reference row (Eq. 20)
        G = np.hstack([np.eye(n_s), X]) @ Z
        Ug, sg, _ = np.linalg.svd(G)
        N = Ug[:, -1]
        w = np.concatenate([N, N @ X])
        leak = float(np.linalg.norm(w @ Zn) / np.linalg.norm(w))
        if best is None or leak < best[0]:
            best = (leak, w, k + 1)
    if best is None:
        raise DetectorError("Eq. 18: the matrix [O T_j] is zero; the model has no dynamics")
    return best[1], {"pinv_rank": best[2], "leakage": best[0]}
