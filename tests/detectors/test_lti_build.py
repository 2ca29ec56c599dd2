"""ImpulseResponseBank.build against the straightforward forms it replaces: the memory
found by a linear search over the powers of F, the Markov parameters by the tap-by-tap
recursion, their spectrum by one FFT over the first axis."""

import numpy as np
import pytest

from analyzer.detectors.lti import (
    MAX_TAPS,
    MEMORY_TOL,
    ImpulseResponseBank,
    _decay_steps,
    _Squares,
)


def linear_taps(systems, tol, max_taps, step=16):
    """Smallest multiple of ``step`` with ``||F^L||_F <= tol`` for every system, one
    product per ``step`` taps (None past ``max_taps``)."""
    taps = step
    for F, _, _, _ in systems:
        power = np.linalg.matrix_power(F, step)
        decay, length = power, step
        while np.linalg.norm(decay) > tol:
            if length >= max_taps:
                return None
            decay = decay @ power
            length += step
        taps = max(taps, length)
    return taps


def reference_spectrum(systems, taps, nfft):
    """``h_0 = J``, ``h_j = H F^(j-1) G`` by the recursion, transformed over time."""
    k = len(systems)
    q, r = systems[0][2].shape[0], systems[0][1].shape[1]
    h = np.empty((taps, k, q, r))
    for i, (F, G, H, J) in enumerate(systems):
        h[0, i] = J
        x = G
        for j in range(1, taps):
            h[j, i] = H @ x
            x = F @ x
    return np.fft.rfft(h.reshape(taps, k * q, r), n=nfft, axis=0)


def random_system(rng, n, q, r, radius, skew=0.0):
    """A stable ``(F, G, H, J)`` of spectral radius ``radius``; with ``skew``, ``F`` is
    ``radius I`` plus a strictly upper triangular part (powers that grow before they
    decay)."""
    if skew:
        F = radius * np.eye(n) + skew * np.triu(rng.uniform(0.5, 1.0, (n, n)), 1)
    else:
        F = rng.normal(size=(n, n))
        F *= radius / np.max(np.abs(np.linalg.eigvals(F)))
    return F, rng.normal(size=(n, r)), rng.normal(size=(q, n)), rng.normal(size=(q, r))


BANKS = {  # name: (seed, state, outputs, inputs, radii, skews)
    "fast": (1, 12, 4, 3, (0.5, 0.8, 0.6), (0.0, 0.0, 0.0)),
    "rising": (2, 20, 5, 4, (0.6, 0.8, 0.9, 0.95), (0.0,) * 4),
    "falling": (3, 20, 3, 6, (0.95, 0.9, 0.8, 0.6), (0.0,) * 4),
    "slow": (4, 10, 2, 2, (0.98, 0.7), (0.0, 0.0)),
    "transient": (5, 8, 3, 2, (0.6, 0.5, 0.85), (0.0, 2.0, 0.0)),
    "one_input_one_output": (6, 30, 1, 1, (0.9, 0.93), (0.0, 0.0)),
}


@pytest.mark.parametrize("name", sorted(BANKS))
def test_build_equals_the_recursion_and_one_fft(name):
    seed, n, q, r, radii, skews = BANKS[name]
    rng = np.random.default_rng(seed)
    systems = [random_system(rng, n, q, r, a, s) for a, s in zip(radii, skews, strict=True)]
    bank = ImpulseResponseBank.build(systems)
    assert bank is not None
    taps = linear_taps(systems, MEMORY_TOL, MAX_TAPS)
    nfft = max(1024, 1 << (4 * taps - 1).bit_length())
    assert (bank.taps, bank.nfft, bank.k, bank.q) == (taps, nfft, len(systems), q)
    ref = reference_spectrum(systems, taps, nfft)
    assert bank.spectrum.shape == ref.shape
    assert bank.spectrum.flags.c_contiguous
    np.testing.assert_allclose(bank.spectrum, ref, rtol=0, atol=1e-10 * np.abs(ref).max())


def test_a_bank_that_remembers_too_long_is_not_built():
    rng = np.random.default_rng(7)
    systems = [random_system(rng, 6, 2, 2, a) for a in (0.5, 0.995)]
    assert linear_taps(systems, MEMORY_TOL, MAX_TAPS) is None
    assert ImpulseResponseBank.build(systems) is None


RADII = (0.2, 0.5, 0.8, 0.9, 0.95, 0.97, 0.98, 0.985, 0.99, 0.995, 0.999)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("max_taps", [MAX_TAPS, 700, 100, 16, 1])
def test_taps_equal_the_linear_search(seed, max_taps):
    """Banks of random stable systems, from fast ones to ones near the unit circle (no
    memory within ``max_taps``: None), in random order; some with powers that grow for
    more than 16 steps (the linear search's path)."""
    rng = np.random.default_rng(100 + seed)
    for _ in range(4):
        radii = rng.choice(RADII, size=rng.integers(1, 5))
        systems = [
            random_system(rng, int(rng.integers(3, 12)), 2, 2, a, skew=1.5 * (rng.random() < 0.2))
            for a in radii
        ]
        want = linear_taps(systems, MEMORY_TOL, max_taps)
        assert ImpulseResponseBank._taps(systems, MEMORY_TOL, max_taps) == want


def test_taps_of_powers_that_grow_first_use_the_linear_search():
    """``||F^16||_F`` far above 1 (the search cannot assume the norms decrease); the same
    memory as the linear search."""
    rng = np.random.default_rng(11)
    F, G, H, J = random_system(rng, 6, 2, 2, 0.6, skew=3.0)
    assert np.linalg.norm(np.linalg.matrix_power(F, 16)) > 1e3
    for max_taps in (MAX_TAPS, 200, 16):
        want = linear_taps([(F, G, H, J)], MEMORY_TOL, max_taps)
        assert ImpulseResponseBank._taps([(F, G, H, J)], MEMORY_TOL, max_taps) == want


def test_taps_of_powers_whose_norm_oscillates_use_the_linear_search():
    """``F = S (rho R) S^-1`` with a third of a turn per 16 steps and an ill-conditioned
    ``S``: ``||F^(16 m)||_F`` swings by a factor of about 10^3 while it decays, so it falls
    under ``tol`` and rises over it again (a bisection that assumed otherwise would find
    another crossing); the memory is the first fall, as the linear search finds it."""
    rho, c = 0.95, 1e3
    turn = 2 * np.pi / 48
    R = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    S = np.diag([1.0, c])
    F = S @ (rho * R) @ np.linalg.inv(S)
    norms = [np.linalg.norm(np.linalg.matrix_power(F, 16 * m)) for m in range(1, 40)]
    assert any(b > a for a, b in zip(norms, norms[1:], strict=False))
    system = (F, np.ones((2, 1)), np.ones((1, 2)), np.zeros((1, 1)))
    for tol in (MEMORY_TOL, 1e-6, 1e-3):
        want = linear_taps([system], tol, MAX_TAPS)
        assert want is not None
        assert ImpulseResponseBank._taps([system], tol, MAX_TAPS) == want


@pytest.mark.parametrize("taps", [1, 2, 16, 17, 37, 48, 160])
def test_markov_parameters_equal_the_recursion(taps):
    """Into a buffer longer than the responses: the taps, then zeros up to the end of the
    last block of 16, then the buffer as it was."""
    rng = np.random.default_rng(taps)
    F, G, H, J = random_system(rng, 9, 3, 2, 0.9)
    out = np.full((3, 2, taps + 40), 7.0)
    ImpulseResponseBank._markov(_Squares(F), G, H, J, taps, 16, out)
    want = np.empty((3, 2, taps))
    want[:, :, 0] = J
    x = G
    for j in range(1, taps):
        want[:, :, j] = H @ x
        x = F @ x
    np.testing.assert_allclose(out[:, :, :taps], want, rtol=0, atol=1e-13 * np.abs(want).max())
    end = 1 + -(-(taps - 1) // 16) * 16
    assert np.all(out[:, :, taps:end] == 0.0)
    assert np.all(out[:, :, max(end, taps) :] == 7.0)


@pytest.mark.parametrize("first", range(1, 21))
def test_decay_steps_against_exact_norms(first):
    """``P = I / 2`` (2 x 2): ``||P^m||_F = 2^(1/2 - m)`` exactly, so the smallest ``m``
    under ``tol`` is known; every lower bound ``least`` and cut ``most``."""
    powers = _Squares(0.5 * np.eye(2))
    tol = 1.5 * np.sqrt(2) * 0.5**first  # between the norms at first - 1 and first
    for most in range(1, 25):
        for least in range(most + 1):
            want = None if first > most else max(least, first)
            assert _decay_steps(powers, tol, most, least) == want, (most, least)


def test_powers_from_squares_equal_matrix_power():
    rng = np.random.default_rng(3)
    A = rng.normal(size=(5, 5))
    A /= np.max(np.abs(np.linalg.eigvals(A)))
    squares = _Squares(A)
    for e in range(1, 70):
        want = np.linalg.matrix_power(A, e)
        np.testing.assert_allclose(squares.power(e), want, rtol=0, atol=1e-12 * np.abs(want).max())
