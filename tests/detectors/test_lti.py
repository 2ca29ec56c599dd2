import numpy as np
import pytest

from analyzer.detectors.lti import LiftedSystem, simulate_reference


@pytest.mark.parametrize("T", [1, 7, 32])
@pytest.mark.parametrize("N", [1, 31, 500])
def test_lifted_equals_recursion(T, N):
    rng = np.random.default_rng(T * 1000 + N)
    n, r, q = 12, 3, 4
    F = rng.normal(size=(n, n))
    F *= 0.9 / np.max(np.abs(np.linalg.eigvals(F)))
    G, H, J = rng.normal(size=(n, r)), rng.normal(size=(q, n)), rng.normal(size=(q, r))
    u = rng.normal(size=(N, r))
    y, _ = LiftedSystem.build(F, G, H, J, T).run(u, chunk=64)
    np.testing.assert_allclose(y, simulate_reference(F, G, H, J, u), rtol=1e-9, atol=1e-9)


def test_state_carries_across_calls():
    rng = np.random.default_rng(5)
    n, r, q = 6, 2, 2
    F = np.diag(rng.uniform(-0.9, 0.9, n))
    G, H, J = rng.normal(size=(n, r)), rng.normal(size=(q, n)), np.zeros((q, r))
    u = rng.normal(size=(300, r))
    sys_ = LiftedSystem.build(F, G, H, J, 16)
    whole, _ = sys_.run(u)
    first, x = sys_.run(u[:137])
    second, _ = sys_.run(u[137:], x0=x)
    np.testing.assert_allclose(np.vstack([first, second]), whole, atol=1e-12)
