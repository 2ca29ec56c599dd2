"""Seed 003's worked Kalman example ("Practical Case Studies", the measured temperature
signal; /work/shared/seeds/003_*.txt, lines 703-747), reproduced by the project's own
Riccati solver (the one the bank's estimators use).

The slides' model: x(t+1) = x(t) + v(t), v(t+1) = v(t) + xi(t), z(t+1) = x(t+1) +
theta(t+1), with the intensities of the plant noise xi, 8.6703e-16, and of the measurement
noise theta, 2.729e-8. They give the steady-state gain H = [0.0187, 1.7657e-4], the
covariances Sigma_p = 1e-9 [0.5202 0.0049; 0.0049 0.0001] (predicted) and Sigma = 1e-9
[0.5104 0.0048; 0.0048 0.0001] (filtered), and the innovation's variance S = 2.7810e-8.
Each is checked to the digits the slides print (half a unit of the last digit)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import linalg

from analyzer.detectors.riccati import solve_dare

# the slides' constants, as printed
PLANT_NOISE = 8.6703e-16
MEASUREMENT_NOISE = 2.729e-8
SLIDES_GAIN = (0.0187, 1.7657e-4)
SLIDES_S = 2.7810e-8
SLIDES_SIGMA_P = ((0.5202, 0.0049), (0.0049, 0.0001))  # x 1e-9
SLIDES_SIGMA = ((0.5104, 0.0048), (0.0048, 0.0001))  # x 1e-9


def _temperature_model() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(A, C, Q, R) of the slides' position-velocity random walk."""
    a = np.array([[1.0, 1.0], [0.0, 1.0]])
    c = np.array([[1.0, 0.0]])
    g = np.array([[0.0], [1.0]])  # the plant noise drives the velocity
    return a, c, PLANT_NOISE * (g @ g.T), np.array([[MEASUREMENT_NOISE]])


def _steady_state() -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """Predicted covariance, gain, innovation variance and filtered covariance from
    :func:`solve_dare` (the filter's DARE is the control one of (A^T, C^T))."""
    a, c, q, r = _temperature_model()
    sigma_p = solve_dare(a.T, c.T, q, r)
    s = float((c @ sigma_p @ c.T + r)[0, 0])
    gain = (sigma_p @ c.T / s).ravel()
    sigma = sigma_p - np.outer(gain, c @ sigma_p)
    return sigma_p, gain, s, sigma


def test_gain_and_innovation_variance_are_the_slides() -> None:
    _, gain, s, _ = _steady_state()
    # measured: 0.018704, 1.76573e-4 and 2.78102e-8
    assert gain[0] == pytest.approx(SLIDES_GAIN[0], abs=0.5e-4)
    assert gain[1] == pytest.approx(SLIDES_GAIN[1], abs=0.5e-8)
    assert s == pytest.approx(SLIDES_S, abs=0.5e-12)


def test_covariances_are_the_slides() -> None:
    sigma_p, _, _, sigma = _steady_state()
    # measured (x 1e-9): 0.520159, 0.004910, 0.0000927 and 0.510430, 0.004819, 0.0000918
    np.testing.assert_allclose(sigma_p / 1e-9, SLIDES_SIGMA_P, rtol=0, atol=0.5e-4)
    np.testing.assert_allclose(sigma / 1e-9, SLIDES_SIGMA, rtol=0, atol=0.5e-4)


def test_the_solution_is_scipys_and_stabilizing() -> None:
    """Independent of the slides: scipy's QZ solver gives the same covariance, and the
    filter's closed loop (A - A K C) is stable."""
    a, c, q, r = _temperature_model()
    sigma_p, gain, _, _ = _steady_state()
    np.testing.assert_allclose(
        sigma_p, linalg.solve_discrete_are(a.T, c.T, q, r), rtol=1e-8, atol=0
    )
    closed = a - a @ np.outer(gain, c)
    assert np.max(np.abs(np.linalg.eigvals(closed))) < 1.0
