"""The state-space models the detection filter is designed on: the config's ``[model]``
(:func:`model_from_config`: given matrices, its noise ratio fitted by the innovations'
likelihood on the healthy window) or, by default, a multichannel AR model identified on
the healthy window in block observer-canonical form (:func:`model_from_ar`,
:func:`ar_observer_form`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import linalg

from analyzer.detectors.ar_model import ARModel, fit_ar, select_order
from analyzer.detectors.base import Dataset
from analyzer.detectors.beard_jones import filter_riccati
from analyzer.detectors.lti import LiftedSystem
from analyzer.errors import DetectorError, TooLittleDataError

FloatArray = npt.NDArray[np.float64]


NOISE_DESIGN_MIN_SAMPLES = 50
"""Fewest finite healthy rows the ``[model]`` noise design estimates the outputs'
variances from (``R0 = diag(var(Y))``): a variance from ``n`` samples has a relative
standard error of about ``sqrt(2 / (n - 1))``, 20 % at 50. A floor set with the code
when it was first written, with no stated derivation."""


@dataclass(frozen=True, slots=True)
class StateSpaceModel:
    """The model the bank is built on, on centred (and for AR, scaled) data:
    ``x+ = A x + B u``, ``y = C x + D u`` with ``(y - mean) / scale`` per output channel."""

    A: FloatArray
    B: FloatArray
    C: FloatArray
    D: FloatArray
    Q: FloatArray
    R: FloatArray
    S: FloatArray | None
    outputs: tuple[int, ...]
    inputs: tuple[int, ...]
    y_mean: FloatArray
    y_scale: FloatArray
    u_mean: FloatArray
    summary: dict[str, Any]


def _centred(values: FloatArray, cols: Sequence[int]) -> tuple[FloatArray, FloatArray]:
    X = np.asarray(values[:, list(cols)], dtype=np.float64)
    mean = np.nanmean(X, axis=0) if X.shape[1] else np.zeros(0)
    return X - mean, mean


def innovation_nll(
    A: FloatArray,
    B: FloatArray,
    C: FloatArray,
    D: FloatArray,
    Q: FloatArray,
    R: FloatArray,
    Y: FloatArray,
    U: FloatArray,
) -> tuple[float, float]:
    """Gaussian negative log-likelihood per sample of the steady-state Kalman predictor's
    innovations on ``Y``, with the overall noise scale ``c`` (both ``Q`` and ``R`` times
    ``c``) profiled out; returns ``(nll, c)``."""
    m = C.shape[0]
    P = filter_riccati(A, C, Q, R)
    S = C @ P @ C.T + R
    M = np.linalg.solve(S, C @ P).T
    F = A - A @ M @ C
    G = np.hstack([A @ M, B - A @ M @ D])
    H = -C
    J = np.hstack([np.eye(m), -D])
    sysl = LiftedSystem.build(F, G, H, J, 32)
    e, _ = sysl.run(np.hstack([Y, U]) if U.shape[1] else Y)
    skip = min(Y.shape[0] // 4, 200)
    e = e[skip:]
    ok = np.isfinite(e).all(axis=1)
    e = e[ok]
    Sinv = np.linalg.inv(S)
    c = float(np.mean(np.einsum("ki,ij,kj->k", e, Sinv, e)) / m)
    _, logdet = np.linalg.slogdet(S)
    return 0.5 * (m * np.log(max(c, 1e-300)) + logdet + m), c


def model_from_config(model: Mapping[str, Any], data: Dataset) -> StateSpaceModel:
    """The bank's model from ``[model]``: output and input channels by name, training means
    removed (the model describes deviations), and noise covariances for the free part of
    the gain: unmeasured inputs (columns of B not named in ``inputs``) are the process noise,
    ``Q = eta Bw Bw'`` (identity when every input is measured), measurement noise
    proportional to each output's training variance, ``R = diag(var y)``; the ratio ``eta``
    maximizes the innovations' likelihood on the healthy window (grid over decades)."""
    A = np.asarray(model["A"], dtype=np.float64)
    B = np.asarray(model.get("B", np.zeros((A.shape[0], 0))), dtype=np.float64)
    C = np.asarray(model["C"], dtype=np.float64)
    D = np.asarray(model.get("D", np.zeros((C.shape[0], B.shape[1]))), dtype=np.float64)
    n = A.shape[0]
    if A.shape != (n, n):
        raise DetectorError(f"expected a square matrix for model A, got {A.shape}")
    if C.ndim != 2 or C.shape[1] != n:
        raise DetectorError(f"expected a ({C.shape[0]}, {n}) matrix for model C, got {C.shape}")
    B = B.reshape(n, -1)
    D = D.reshape(C.shape[0], B.shape[1])
    dt = model.get("dt")
    if dt is not None and abs(float(dt) * data.rate_hz - 1.0) > 1e-6:
        raise DetectorError(
            f"[model] dt = {dt} s does not match the analysis rate {data.rate_hz} Hz "
            f"(expected dt = {1.0 / data.rate_hz})"
        )
    outputs = list(model.get("outputs") or [])
    if not outputs:
        if C.shape[0] != len(data.channels):
            raise DetectorError(
                f"[model] outputs not named and C has {C.shape[0]} rows for "
                f"{len(data.channels)} channels"
            )
        outputs = list(data.channels)
    if len(outputs) != C.shape[0]:
        raise DetectorError(
            f"[model] outputs names {len(outputs)} channels but C has {C.shape[0]} rows"
        )
    inputs = list(model.get("inputs") or [])
    missing = [c for c in outputs + inputs if c not in data.channels]
    if missing:
        raise DetectorError(f"[model] names channel {missing[0]!r}, which is not analyzed")
    if inputs and len(inputs) != B.shape[1]:
        raise DetectorError(
            f"[model] inputs names {len(inputs)} channels but B has {B.shape[1]} columns"
        )
    oi = tuple(data.index(c) for c in outputs)
    ii = tuple(data.index(c) for c in inputs)
    Bm = B if inputs else np.zeros((n, 0))
    Dm = D if inputs else np.zeros((C.shape[0], 0))
    Bw = np.zeros((n, 0)) if inputs else B
    train = data.train_values()
    Y, y_mean = _centred(train, oi)
    U, u_mean = _centred(train, ii)
    ok = np.isfinite(Y).all(axis=1) & (np.isfinite(U).all(axis=1) if U.shape[1] else True)
    Y, U = Y[ok], U[ok]
    if Y.shape[0] < NOISE_DESIGN_MIN_SAMPLES:
        raise TooLittleDataError(
            f"too little healthy data for the [model] noise design: {Y.shape[0]} samples",
            Y.shape[0],
            NOISE_DESIGN_MIN_SAMPLES,
        )
    var = np.var(Y, axis=0)
    if np.any(var <= 0):
        raise DetectorError("an output channel is constant in the training window")
    R0 = np.diag(var)
    G0 = Bw @ Bw.T if Bw.shape[1] else np.eye(n)
    G0 = G0 / max(float(np.trace(G0)) / n, 1e-300)
    tiny = 1e-9 * np.eye(n)
    best: tuple[float, float, float] | None = None
    for eta in 10.0 ** np.arange(-6.0, 6.5, 1.0):
        try:
            nll, c = innovation_nll(A, Bm, C, Dm, eta * G0 + tiny, R0, Y, U)
        except (linalg.LinAlgError, ValueError):
            continue
        if np.isfinite(nll) and (best is None or nll < best[0]):
            best = (nll, float(eta), c)
    if best is None:
        raise DetectorError(
            "[model]: no noise ratio gives a stabilizing Kalman filter (is (A, C) detectable?)"
        )
    _, eta, c = best
    summary = {
        "type": "state-space",
        "source": "config [model]",
        "states": n,
        "outputs": list(outputs),
        "inputs": list(inputs),
        "unmeasured_inputs": int(Bw.shape[1]),
        "noise_ratio": eta,
        "noise_scale": c,
    }
    return StateSpaceModel(
        A,
        Bm,
        C,
        Dm,
        c * (eta * G0 + tiny),
        c * R0,
        None,
        oi,
        ii,
        y_mean,
        np.ones(len(oi)),
        u_mean,
        summary,
    )


def ar_observer_form(ar: ARModel) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(A, C, K)`` of the AR model ``y[k] = sum_l A_l y[k-l] + e[k]`` (Chang et al. 2017,
    Eq. 1) in block observer-canonical innovations form::

        x[k+1] = A x[k] + K e[k],  y[k] = C x[k] + e[k],
        A = [[A_1, I, 0, ...], [A_2, 0, I, ...], ..., [A_p, 0, ..., 0]],  C = [I, 0, ..., 0],
        K = [A_1; A_2; ...; A_p],

    with ``x_j[k] = sum_{l >= j} A_l y[k + j - 1 - l]`` (``x_1[k]`` is the one-step
    prediction). Unlike the companion form (Eq. 8), whose fast modes ``lambda`` are seen
    through ``lambda^(p-1)`` only, this realization is observable by construction, so the
    observability test of Theorem 4.1 is well conditioned."""
    p, m = ar.order, ar.m
    n = p * m
    A = np.zeros((n, n))
    for j in range(p):
        A[j * m : (j + 1) * m, :m] = ar.coefs[j]
        if j + 1 < p:
            A[j * m : (j + 1) * m, (j + 1) * m : (j + 2) * m] = np.eye(m)
    C = np.zeros((m, n))
    C[:, :m] = np.eye(m)
    K = ar.coefs.reshape(n, m).copy()
    return A, C, K


def model_from_ar(
    data: Dataset, order: int | str, max_order: int, rows: FloatArray | None = None
) -> StateSpaceModel:
    """An AR model identified on the healthy window (Chang et al. 2017, Eq. 1-5; or on
    ``rows``), on centred and scaled data, in observer-canonical innovations form
    (:func:`ar_observer_form`): ``Q = K Sigma K'``, ``R = Sigma``, ``S = K Sigma``."""
    train = np.asarray(data.train_values() if rows is None else rows, dtype=np.float64)
    p = select_order(train, order, max_order) if isinstance(order, str) else int(order)
    ar = fit_ar(train, p, data.channels)
    A, C, K = ar_observer_form(ar)
    n, m = A.shape[0], C.shape[0]
    summary = {
        "type": "AR (observer-canonical form)",
        "source": "identified on the healthy window",
        "order": ar.order,
        "order_rule": order,
        "states": n,
        "outputs": list(data.channels),
        "aic": ar.aic,
        "bic": ar.bic,
        "r_squared": {c: float(v) for c, v in zip(data.channels, ar.r_squared(), strict=True)},
    }
    Sig = ar.sigma
    return StateSpaceModel(
        A,
        np.zeros((n, 0)),
        C,
        np.zeros((m, 0)),
        K @ Sig @ K.T,
        Sig,
        K @ Sig,
        tuple(range(m)),
        (),
        ar.mean,
        ar.scale,
        np.zeros(0),
        summary,
    )
