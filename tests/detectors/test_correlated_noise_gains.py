"""Kalman and detection-filter gains when the noises are correlated: a cross-covariance
``S = cov(w, v)`` between process and measurement noise, and a measurement covariance
``R`` that is not diagonal.

The tool's own models pass ``S = None`` and a diagonal ``R``; these are the library API's
cases. References: the stabilizing solution ``P`` of the filter Riccati equation from
``scipy.linalg.solve_discrete_are(A.T, C.T, Q, R, s=S)``, and the textbook gains of the
one-step predictor with correlated noise, ``L = (A P C' + S)(C P C' + R)^-1``, and filter
``M = P C' (C P C' + R)^-1``; the filtered estimate of a sensor from the others'
innovations ``eps_o = C_o (x - xhat) + v_o`` is ``E[y_i - C_i xhat | eps_o] = N eps_o`` with
``N' = (C_o P C_o' + R_oo)^-1 (C_o P C_i' + R_oi)``."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import linalg

from analyzer.detectors.beard_jones import kalman_gains, park_filter


def _system(seed: int, n: int = 3, m: int = 3):
    """A stable ``A`` (spectral radius 0.8), a generic ``C`` and a joint noise covariance
    ``[[Q, S], [S', R]]`` (positive definite, every block dense)."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    A *= 0.8 / np.max(np.abs(np.linalg.eigvals(A)))
    C = rng.normal(size=(m, n))
    G = rng.normal(size=(n + m, n + m))
    W = G @ G.T + 0.5 * np.eye(n + m)
    return A, C, W[:n, :n], W[n:, n:], W[:n, n:]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kalman_gains_with_cross_covariance_are_the_textbook_ones(seed):
    """``kalman_gains(A, C, Q, R, S)`` returns scipy's Riccati solution and the gains
    built from it, the ``S`` term included, to 1e-8."""
    A, C, Q, R, S = _system(seed)
    P_ref = linalg.solve_discrete_are(A.T, C.T, Q, R, s=S)
    Re = C @ P_ref @ C.T + R
    L_ref = (A @ P_ref @ C.T + S) @ np.linalg.inv(Re)
    M_ref = P_ref @ C.T @ np.linalg.inv(Re)
    L, M, P = kalman_gains(A, C, Q, R, S)
    np.testing.assert_allclose(P, P_ref, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(L, L_ref, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(M, M_ref, rtol=1e-8, atol=1e-10)
    # the cross term matters here: without it the gain is another one
    assert np.abs(S @ np.linalg.inv(Re)).max() > 0.05


@pytest.mark.parametrize("sensor", [0, 1, 2])
def test_detection_filter_estimate_of_a_sensor_uses_the_noise_correlation(sensor):
    """The detection filter of ``sensor`` (no inputs, ``S = None``, ``R = I + 1.5`` in every
    entry: measurement noises with a common part): its fault-free estimate of the sensor
    reads the others' innovations through ``N``, the conditional expectation above, the
    measurement-noise correlation ``R_oi`` included (the last row of ``J`` is ``[N, ...]``,
    zero at the sensor itself), to 1e-8."""
    A, C, Q, _, _ = _system(3)
    m = C.shape[0]
    R = np.eye(m) + 1.5
    others = [j for j in range(m) if j != sensor]
    flt = park_filter(A, np.zeros((3, 0)), C, np.zeros((m, 0)), sensor, Q, R, sigma=0.5)
    Co, Roo = C[others], R[np.ix_(others, others)]
    P = linalg.solve_discrete_are(A.T, Co.T, Q, Roo)
    N_ref = np.zeros(m)
    N_ref[others] = np.linalg.solve(Co @ P @ Co.T + Roo, Co @ P @ C[sensor] + R[others, sensor])
    np.testing.assert_allclose(flt.J[-1, :m], N_ref, rtol=1e-8, atol=1e-10)
    # and the noise correlation moves it
    without = np.linalg.solve(Co @ P @ Co.T + Roo, Co @ P @ C[sensor])
    assert np.abs(N_ref[others] - without).max() > 0.05
