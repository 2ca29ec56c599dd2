"""The PBH tests of the detection filter (Park et al. 1994, Lemma 3.1, Lemma 3.2, and the
invariant zeros of the augmented fault) do not depend on the units of the outputs or of
the states: a [model] in SI units (Li et al.'s chain: ``C`` entries about ``1e5``) had its
fault pole ``alpha = 1`` flagged as "seen only by" each sensor and the detection filter
was skipped."""

import numpy as np
import pytest

from analyzer.detectors import beard_jones as bjm
from analyzer.detectors.base import Dataset, RunContext
from analyzer.detectors.beard_jones import augment, park_filter, pbh_scaling, unobservable_modes
from analyzer.detectors.detection_filter import DetectionFilter
from analyzer.errors import DetectorError
from analyzer.simulate import inject_fault
from analyzer.simulate_mdof import chain_model, simulate_chain
from analyzer.types import FaultType

CHAIN_RATE = 250.0
SCALES = (1.0, 1e5, 1e-5)


def _chain():
    """Li et al.'s chain, discretized at 250 Hz: x = [displacements (m), velocities
    (m/s)], y = accelerations (m/s^2), C holding the stiffness 1e5 N/m over 1 kg."""
    return chain_model().discrete(CHAIN_RATE)


def _hidden_pair(seed):
    """(A, C) with the mode 0.3 hidden from C and a complex pair seen, random coordinates."""
    rng = np.random.default_rng(seed)
    A0 = np.zeros((5, 5))
    A0[:2, :2] = [[0.5, -0.4], [0.4, 0.5]]
    A0[2, 2], A0[3, 3], A0[4, 4] = 0.3, -0.6, 0.8
    C0 = np.array([[1.0, 0.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 0.0, 1.0]])
    T = rng.standard_normal((5, 5))
    return T @ A0 @ np.linalg.inv(T), C0 @ np.linalg.inv(T)


def _state_scaled(A, C, d):
    """The same system in other state units: x' = diag(d)^-1 x."""
    D = np.diag(d)
    return np.linalg.solve(D, A @ D), C @ D


# -- unobservable_modes (Lemma 3.1) -----------------------------------------------------------
@pytest.mark.parametrize("scale", SCALES)
def test_chain_model_is_observable_in_any_output_units(scale):
    A, _, C, _ = _chain()
    assert unobservable_modes(A, C * scale) == []
    rows = np.array([1e5, 1.0, 1e-3, 10.0])[:, None]  # each sensor in units of its own
    assert unobservable_modes(A, C * scale * rows) == []


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_scaled_outputs_give_the_same_unobservable_modes_as_unscaled(seed):
    A, C = _hidden_pair(seed)
    base = unobservable_modes(A, C)
    assert len(base) == 1 and base[0] == pytest.approx(0.3)
    for scale in SCALES[1:]:
        assert unobservable_modes(A, C * scale) == base
    assert unobservable_modes(A, C * np.array([[1e6], [1e-4]])) == base
    # and restricted to some modes, as the detection filter asks
    modes = np.linalg.eigvals(A)
    for scale in SCALES:
        assert unobservable_modes(A, C * scale, at=modes[:2]) == unobservable_modes(
            A, C, at=modes[:2]
        )


@pytest.mark.parametrize("seed", [0, 1])
def test_scaled_states_give_the_same_unobservable_modes(seed):
    A, C = _hidden_pair(seed)
    d = np.array([1e-4, 1e3, 1.0, 1e5, 1e-2])
    for scale in SCALES:
        As, Cs = _state_scaled(A, C * scale, d)
        got = unobservable_modes(As, Cs)
        assert len(got) == 1 and got[0] == pytest.approx(0.3, abs=1e-9)
    A, _, C, _ = _chain()
    d = np.array([1e-6, 1e-6, 1e-6, 1e-6, 1e-3, 1e-3, 1e-3, 1e-3])  # um and mm/s
    As, Cs = _state_scaled(A, C, d)
    assert unobservable_modes(As, Cs) == []


def test_the_balanced_form_is_a_similarity_and_unit_rows():
    """``pbh_scaling``: powers of 2 on the states (exact, the eigenvalues unchanged),
    unit rows of the scaled C; the output scaling absorbs the units of C exactly; a pair
    in block observer form is left as it is."""
    A, _, C, _ = _chain()
    t, s = pbh_scaling(A, C)
    assert np.all(np.log2(t) == np.round(np.log2(t)))
    Cb = s[:, None] * C * t[None, :]
    np.testing.assert_allclose(np.linalg.norm(Cb, axis=1), 1.0, rtol=1e-12)
    Ab = A * t[None, :] / t[:, None]
    assert np.abs(Ab).max() < 10.0  # |A| was 256 in the SI units
    for scale in SCALES[1:]:
        t2, s2 = pbh_scaling(A, C * scale)
        np.testing.assert_array_equal(t2, t)
        np.testing.assert_allclose(s2 * scale, s, rtol=1e-12)
    Ao = np.zeros((6, 6))
    Ao[:, :3] = 0.1 * np.arange(18).reshape(6, 3) / 18
    Ao[:3, 3:] = np.eye(3)
    Co = np.hstack([np.eye(3), np.zeros((3, 3))])
    assert bjm.observer_blocks(Ao, Co) is not None
    to, so = pbh_scaling(Ao, Co)
    assert np.all(to == 1.0) and np.all(so == 1.0)
    with pytest.raises(DetectorError, match="expected scalings of 8 states and 4 outputs"):
        unobservable_modes(A, C, scaling=(t[:3], s))


# -- Lemma 3.2 and the invariant zeros ---------------------------------------------------------
@pytest.mark.parametrize("scale", SCALES)
def test_chain_model_gets_a_detection_filter_for_every_sensor(scale):
    """Lemma 3.2 at alpha = 1 (not a mode of the chain): every sensor's filter is
    designed, in any output units, and its fault estimate reads a constant offset."""
    A, B, C, D = _chain()
    C, D = C * scale, D * scale
    m = C.shape[0]
    rng = np.random.default_rng(0)
    u = rng.standard_normal((4000, B.shape[1]))
    x = np.zeros(A.shape[0])
    y = np.empty((4000, m))
    for k in range(4000):
        y[k] = C @ x + D @ u[k]
        x = A @ x + B @ u[k]
    R = np.diag(np.var(y, axis=0)) * 1e-4
    for i in range(m):
        flt = park_filter(A, B, C, D, i, np.eye(A.shape[0]) * 1e-12, R, sigma=0.9)
        assert flt.spectral_radius < 1.0
        yf = y.copy()
        yf[2000:, i] += 0.5 * scale
        zeta = flt.run(yf, u)[:, m]
        assert zeta[-1] == pytest.approx(0.5 * scale, rel=1e-6)


@pytest.mark.parametrize("scale", SCALES)
def test_lemma_3_2_refuses_a_fault_pole_seen_by_one_sensor_in_any_units(scale):
    """alpha = 1 is a mode of A that only sensor 0 sees: its filter is refused (Lemma
    3.2), whatever the units; sensor 1's is not concerned."""
    A = np.diag([1.0, 0.5, 0.2])
    C = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 1.0]]) * np.array([[scale], [1.0 / scale]])
    args = (np.zeros((3, 0)), C, np.zeros((2, 0)))
    with pytest.raises(DetectorError, match=r"alpha=1\.0 is a mode of A seen only by output 0"):
        park_filter(A, args[0], args[1], args[2], 0, np.eye(3), np.eye(2))
    with pytest.raises(DetectorError, match="invariant zero"):  # a stable pole: no escape
        park_filter(A, args[0], args[1], args[2], 0, np.eye(3), np.eye(2), alpha=0.99)


@pytest.mark.parametrize("seed", range(4))
def test_augmented_pair_at_alpha_loses_rank_iff_the_other_sensors_miss_alpha(seed):
    """The test the design makes for Lemma 3.2, ``[A - alpha I; C_{-i}]``, agrees with the
    PBH test of the augmented pair ``(Abar, Cbar)`` at ``alpha`` (module docstring)."""
    rng = np.random.default_rng(seed)
    alpha = 0.7
    A0 = np.diag([alpha, 0.4, -0.5, 0.1])
    C0 = rng.standard_normal((3, 4))
    i = int(rng.integers(0, 3))
    hidden = seed % 2 == 1
    if hidden:  # the mode alpha seen by sensor i only
        C0[[j for j in range(3) if j != i], 0] = 0.0
    T = rng.standard_normal((4, 4))
    A, C = T @ A0 @ np.linalg.inv(T), C0 @ np.linalg.inv(T)
    Ab, _, Cb, _ = augment(A, np.zeros((4, 0)), C, i, alpha)
    others = [j for j in range(3) if j != i]
    reduced = bool(unobservable_modes(A, C[others], at=[alpha]))
    assert reduced == hidden
    assert bool(unobservable_modes(Ab, Cb, at=[alpha])) == hidden


# -- the detector with a [model] in SI units ---------------------------------------------------
def test_detection_filter_runs_on_the_chain_model_and_finds_a_gain():
    """The probe's case: the chain's [model] with the forces as its measured inputs; the
    filter is not skipped, and the gain of 0.5 on s2 from 100 s is found."""
    chain = chain_model()
    t, Y, U = simulate_chain(120.0, CHAIN_RATE, model=chain, noise=0.01, seed=3)
    Y = Y.copy()
    Y[:, 1] = inject_fault(Y[:, 1], CHAIN_RATE, "multiplicative", 100.0, 0.5)
    A, B, C, D = chain.discrete(CHAIN_RATE)
    names = ("s1", "s2", "s3", "s4", "u1", "u2")
    ds = Dataset(np.column_stack([Y, U]), names, CHAIN_RATE, (0, int(60 * CHAIN_RATE)))
    model = {
        "A": A,
        "B": B,
        "C": C,
        "D": D,
        "outputs": ["s1", "s2", "s3", "s4"],
        "inputs": ["u1", "u2"],
        "dt": 1.0 / CHAIN_RATE,
    }
    ctx = RunContext(config={"model": model})
    det = DetectionFilter()
    fitted = det.fit(ds, ctx)
    result = det.run(fitted, ds, ctx)
    assert set(result.channels) == {"s1", "s2", "s3", "s4"}
    gains = [e for e in result.events if e.channel == "s2"]
    assert gains, [(e.channel, e.type, e.onset_s) for e in result.events]
    ev = gains[0]
    assert ev.type is FaultType.MULTIPLICATIVE
    assert ev.onset_s == pytest.approx(100.0, abs=0.5)
    assert ev.magnitude["gain"] == pytest.approx(0.5, abs=0.05)
    assert not [e for e in result.events if e.channel != "s2" and e.onset_s < 99.0]
