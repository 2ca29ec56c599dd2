"""The fast DARE solvers on their own, against scipy's QZ solver: :func:`solve_dare`
falls back to scipy wherever its own answer's residual is too large, so a broken doubling
or Newton iteration gave scipy's answer and every test through ``solve_dare`` still passed
(test audit ux65 D3: ``A' H W^-1 A`` made ``A H W^-1 A`` cost only time, about 10x)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import linalg

from analyzer.detectors import riccati


def _system(seed: int, n: int, r: int, radius: float):
    """A random ``(A, B, Q, R)`` with ``A``'s spectral radius ``radius`` (over 1: unstable
    modes the input reaches), ``Q`` and ``R`` positive definite."""
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, n))
    a *= radius / np.max(np.abs(np.linalg.eigvals(a)))
    b = rng.normal(size=(n, r))
    qh = rng.normal(size=(n, n))
    rh = rng.normal(size=(r, r))
    return a, b, qh @ qh.T + 1e-3 * np.eye(n), rh @ rh.T + 0.1 * np.eye(r)


SYSTEMS = [(0, 4, 1, 0.9), (1, 12, 3, 1.05), (2, 30, 5, 0.98), (3, 80, 4, 1.02)]


def _close(x: np.ndarray | None, ref: np.ndarray) -> None:
    assert x is not None
    assert np.abs(x - ref).max() <= 1e-8 * np.abs(ref).max()


@pytest.mark.parametrize(("seed", "n", "r", "radius"), SYSTEMS)
def test_doubling_alone_equals_scipy(seed: int, n: int, r: int, radius: float) -> None:
    a, b, q, rr = _system(seed, n, r, radius)
    _close(riccati._doubling(a, b, q, rr, None), linalg.solve_discrete_are(a, b, q, rr))


@pytest.mark.parametrize("seed", [4, 5])
def test_doubling_alone_with_a_cross_term_equals_scipy(seed: int) -> None:
    a, b, q, rr = _system(seed, 10, 2, 1.05)
    s = 0.05 * np.random.default_rng(seed + 100).normal(size=(10, 2))
    ref = linalg.solve_discrete_are(a, b, q, rr, s=s)
    _close(riccati._doubling(a, b, q, rr, s), ref)


@pytest.mark.parametrize(("seed", "n", "r", "radius"), SYSTEMS)
def test_newton_from_a_nearby_solution_alone_equals_scipy(
    seed: int, n: int, r: int, radius: float
) -> None:
    """From the solution of the same system with ``Q`` and ``R`` 2 % larger (as a
    cross-validation fold's model is near the whole window's): Newton's method and one
    Newton step, each without the fallback."""
    a, b, q, rr = _system(seed, n, r, radius)
    ref = linalg.solve_discrete_are(a, b, q, rr)
    start = linalg.solve_discrete_are(a, b, 1.02 * q, 1.02 * rr)
    _close(riccati._newton(a, b, q, rr, start), ref)
    step = riccati.newton_step(a, b, q, rr, start)
    assert step is not None
    # one step from a start within ~2e-2 lands within about its square
    far = np.abs(start - ref).max()
    assert np.abs(step - ref).max() <= 0.1 * far


@pytest.mark.parametrize("with_start", [False, True])
@pytest.mark.parametrize(("seed", "n", "r", "radius"), SYSTEMS)
def test_solve_dare_does_not_fall_back_to_scipy(
    monkeypatch: pytest.MonkeyPatch, seed: int, n: int, r: int, radius: float, with_start: bool
) -> None:
    a, b, q, rr = _system(seed, n, r, radius)
    ref = linalg.solve_discrete_are(a, b, q, rr)
    start = linalg.solve_discrete_are(a, b, 1.02 * q, 1.02 * rr) if with_start else None

    def refused(*args: object, **kwargs: object) -> np.ndarray:
        raise AssertionError("solve_dare fell back to scipy's QZ solver")

    monkeypatch.setattr(riccati, "solve_dare_scipy", refused)
    _close(riccati.solve_dare(a, b, q, rr, start=start), ref)
