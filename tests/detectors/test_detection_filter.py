"""Park, Rizzoni & Ribbens (1994) detection filter: the fixed fault direction, the
observability condition of Theorem 4.1, and isolation on simulated buildings."""

import json

import numpy as np
import pytest

from analyzer.detectors.ar_model import fit_ar
from analyzer.detectors.base import Dataset, RunContext
from analyzer.detectors.beard_jones import augment, park_filter, unobservable_modes
from analyzer.detectors.detection_filter import DetectionFilter, direction_angles
from analyzer.detectors.lti import simulate_reference
from analyzer.detectors.state_space import ar_observer_form
from analyzer.errors import DetectorError
from analyzer.simulate import inject_fault, shear_building, simulate_building

RATE = 200.0
TRAIN = (0, int(15 * RATE))


def _random_system(seed, n=4, m=3, r=1):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    A *= 0.9 / np.max(np.abs(np.linalg.eigvals(A)))
    return A, rng.standard_normal((n, r)), rng.standard_normal((m, n)), np.zeros((m, r))


def _simulate(A, B, C, D, u):
    return simulate_reference(A, B, C, D, u)


# -- Eq. 10-16 and the fixed direction -------------------------------------------------------
def test_augmented_system_reproduces_the_faulty_output():
    """Eq. 10-16: with zeta[k+1] = alpha zeta + xi the augmented system's output equals
    the original output plus the fault on sensor i."""
    A, B, C, D = _random_system(0)
    rng = np.random.default_rng(1)
    N = 200
    u = rng.standard_normal((N, 1))
    zeta = np.cumsum(rng.standard_normal(N))  # any fault signal
    alpha = 1.0
    xi = np.empty(N)
    xi[:-1] = zeta[1:] - alpha * zeta[:-1]
    xi[-1] = 0.0
    Ab, Bb, Cb, fb = augment(A, B, C, 1, alpha)
    assert np.allclose(Cb @ fb, [0.0, 1.0, 0.0])  # the fault excites the direction e_1
    G = np.hstack([Bb, fb[:, None]])
    x0 = np.zeros(A.shape[0] + 1)
    x0[-1] = zeta[0]
    y_aug = np.empty((N, 3))
    x = x0
    for k in range(N):
        y_aug[k] = Cb @ x
        x = Ab @ x + G @ np.concatenate([u[k], [xi[k]]])
    y = _simulate(A, B, C, D, u)
    y[:, 1] += zeta
    assert np.allclose(y_aug, y)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_residual_of_a_sensor_fault_keeps_its_direction(seed):
    """Park et al., Eq. 19-20: the residual of a fault on sensor i stays along e_i (angle
    0, angles to the other sensors' directions 90 degrees), whatever the fault signal; the
    filters of the other sensors see it in several directions."""
    A, B, C, D = _random_system(seed, n=5, m=3)
    rng = np.random.default_rng(10 + seed)
    N = 400
    u = rng.standard_normal((N, 1))
    y = _simulate(A, B, C, D, u)
    k0 = 100
    f = np.zeros(N)
    f[k0:] = 1.0 + np.sin(0.05 * np.arange(N - k0)) + rng.standard_normal(N - k0) * 0.3
    m = C.shape[0]
    n = A.shape[0]
    filters = [park_filter(A, B, C, D, j, np.eye(n), np.eye(m), sigma=0.5) for j in range(m)]
    for i in range(m):
        yf = y.copy()
        yf[:, i] += f
        for j, flt in enumerate(filters):
            q = flt.run(yf, u)[:, :m]
            assert np.abs(q[:k0]).max() < 1e-9  # no fault, exact model: zero residual
            live = np.linalg.norm(q, axis=1) > 1e-9
            ang = np.degrees(direction_angles(q[live]))
            if j == i:
                assert ang[:, i].max() < 1e-5
                others = [c for c in range(m) if c != i]
                assert ang[:, others].min() > 90.0 - 1e-5
            else:
                # not confined to e_j: the fault on i is seen in other directions
                assert np.median(ang[:, j]) > 10.0


def test_fault_estimate_and_closed_loop_spectrum():
    """The fault estimate converges to a constant fault in sensor units; the closed loop is
    eig(A - L C_{-i}) plus the assigned fault pole sigma (block triangular, Eq. 19)."""
    A, B, C, D = _random_system(3, n=4, m=3)
    n, m = A.shape[0], C.shape[0]
    flt = park_filter(A, B, C, D, 2, np.eye(n), np.eye(m), sigma=0.3)
    eig = np.linalg.eigvals(flt.closed_loop)
    assert np.min(np.abs(eig - 0.3)) < 1e-9
    cl_x = flt.closed_loop[:n, :n]
    assert np.allclose(
        np.sort_complex(eig), np.sort_complex(np.append(np.linalg.eigvals(cl_x), 0.3))
    )
    assert np.allclose(flt.gain[:n, 2], 0.0)  # the state part ignores sensor 2
    N = 300
    u = np.random.default_rng(4).standard_normal((N, 1))
    y = _simulate(A, B, C, D, u)
    y[150:, 2] += 2.5
    zeta = flt.run(y, u)[:, m]
    assert np.abs(zeta[:150]).max() < 1e-9
    assert zeta[-1] == pytest.approx(2.5, abs=1e-9)


# -- Theorem 4.1, Lemmas 3.1-3.2 --------------------------------------------------------------
def _unobservable_pair(seed):
    """(A, C) with the mode 0.3 hidden from C, in random coordinates."""
    rng = np.random.default_rng(seed)
    A0 = np.diag([0.5, -0.4, 0.8, 0.3])
    C0 = np.array([[1.0, 1.0, 0.0, 0.0], [0.0, 1.0, 1.0, 0.0]])
    T = rng.standard_normal((4, 4))
    return T @ A0 @ np.linalg.inv(T), C0 @ np.linalg.inv(T)


@pytest.mark.parametrize("seed", [0, 1])
def test_unobservable_pair_is_refused(seed):
    A, C = _unobservable_pair(seed)
    modes = unobservable_modes(A, C)
    assert len(modes) == 1 and modes[0] == pytest.approx(0.3)
    with pytest.raises(DetectorError, match=r"\(A, C\) is not observable .*0\.3.*Theorem 4\.1"):
        park_filter(A, np.zeros((4, 0)), C, np.zeros((2, 0)), 0, np.eye(4), np.eye(2))


def test_detector_refuses_an_unobservable_config_model():
    A, C = _unobservable_pair(0)
    rng = np.random.default_rng(0)
    Y = rng.standard_normal((4000, 2))
    ds = Dataset(Y, ("a", "b"), 100.0, (0, 2000))
    model = {
        "A": A,
        "B": np.eye(4)[:, :1],
        "C": C,
        "D": np.zeros((2, 1)),
        "outputs": ["a", "b"],
        "inputs": [],
        "dt": 0.01,
    }
    det = DetectionFilter()
    with pytest.raises(DetectorError, match="Theorem 4.1"):
        det.fit(ds, RunContext(config={"model": model}))


@pytest.mark.parametrize("seed", range(6))
def test_lemma_3_2_augmented_pair_observable_iff_original(seed):
    rng = np.random.default_rng(seed)
    if seed % 2:
        A, C = _unobservable_pair(seed)
    else:
        A, _, C, _ = _random_system(seed, n=4, m=2)
    A = A * 0.9  # keep alpha = 1 off the spectrum (Lemma 3.2's proof needs it)
    i = int(rng.integers(0, C.shape[0]))
    Ab, _, Cb, _ = augment(A, np.zeros((4, 0)), C, i, 1.0)
    assert bool(unobservable_modes(Ab, Cb)) == bool(unobservable_modes(A, C))


def test_unstable_invariant_zero_is_refused():
    """(A, C) observable, but the mode 1.2 is seen only by sensor 0: the filter of sensor
    0 would have to run it open loop (an invariant zero of the augmented fault)."""
    A = np.diag([1.2, 0.5])
    C = np.eye(2)
    with pytest.raises(DetectorError, match="invariant zero.*1.2"):
        park_filter(A, np.zeros((2, 0)), C, np.zeros((2, 0)), 0, np.eye(2), np.eye(2))
    # sensor 1's filter leaves the stable mode 0.5 to sensor 0: fine
    flt = park_filter(A, np.zeros((2, 0)), C, np.zeros((2, 0)), 1, np.eye(2), np.eye(2))
    assert flt.spectral_radius < 1.0


def test_bad_settings_are_refused():
    with pytest.raises(DetectorError, match="fault_pole"):
        DetectionFilter(fault_pole=1.5)
    with pytest.raises(DetectorError, match="order"):
        DetectionFilter(order="aicc")
    A, B, C, D = _random_system(0)
    with pytest.raises(DetectorError, match="sigma < alpha"):
        park_filter(A, B, C, D, 0, np.eye(4), np.eye(3), alpha=0.5, sigma=0.6)


# -- the AR model used without [model] --------------------------------------------------------
def test_ar_observer_form_predicts_like_the_ar_model():
    _, Y, _ = simulate_building(n_floors=3, duration_s=20.0, seed=2)
    ar = fit_ar(Y[:2000], 4)
    A, C, K = ar_observer_form(ar)
    Z = (Y[:2000] - ar.mean) / ar.scale
    # the innovations predictor x+ = (A - K C) x + K y reproduces sum_l A_l y[k-l]
    pred = simulate_reference(A - K @ C, K, C, np.zeros((3, 3)), Z)
    direct = sum(Z[4 - lag : 2000 - lag] @ ar.coefs[lag - 1].T for lag in range(1, 5))
    assert np.allclose(pred[4:], direct, atol=1e-10)
    assert unobservable_modes(A, C) == []


# -- simulated buildings ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def buildings():
    """Fitted default detectors (AR model from the healthy window) on three buildings."""
    out = {}
    for seed in (0, 3, 5):
        _, Y, names = simulate_building(n_floors=5, duration_s=45.0, rate_hz=RATE, seed=seed)
        ds = Dataset(Y, tuple(names), RATE, TRAIN)
        det = DetectionFilter()
        ctx = RunContext()
        out[seed] = (Y, names, det, det.fit(ds, ctx), ctx)
    return out


@pytest.mark.parametrize("seed", [0, 3, 5])
def test_healthy_buildings_give_no_event(buildings, seed):
    Y, names, det, model, ctx = buildings[seed]
    res = det.run(model, Dataset(Y, tuple(names), RATE, TRAIN), ctx)
    assert res.events == []
    assert res.model["type"].startswith("AR")
    json.dumps(res.model)


@pytest.mark.parametrize("seed", [0, 3])
@pytest.mark.parametrize("floor", range(5))
def test_offset_fault_is_isolated(buildings, seed, floor):
    Y, names, det, model, ctx = buildings[seed]
    sd = float(np.std(Y[:, floor]))
    Yf = Y.copy()
    Yf[:, floor] = inject_fault(Y[:, floor], RATE, "additive", 20.0, sd)
    res = det.run(model, Dataset(Yf, tuple(names), RATE, TRAIN), ctx)
    assert [e.channel for e in res.events] == [names[floor]], res.events
    (ev,) = res.events
    assert ev.type.value == "additive"
    # measured on seeds 0-5, every floor, as here: onset within 0.04 s,
    # offset within 3.5 % of the 1 sd injected
    assert abs(ev.onset_s - 20.0) <= 0.1
    assert ev.magnitude["offset"] == pytest.approx(sd, rel=0.05)
    # the residual direction identified it: its own filter stayed on e_i, the others left
    assert ev.evidence["off_direction_violation"] < 1.0
    assert ev.evidence["confirmed"]


def test_config_model_isolates_with_the_true_building_model():
    b = shear_building(5)
    A, B, C, D = b.discrete(RATE)
    _, Y, names = simulate_building(n_floors=5, duration_s=45.0, rate_hz=RATE, seed=1)
    cfg = {
        "model": {
            "A": A,
            "B": B,
            "C": C,
            "D": D,
            "outputs": list(names),
            "inputs": [],
            "dt": 1.0 / RATE,
        }
    }
    det = DetectionFilter()
    ctx = RunContext(config=cfg)
    model = det.fit(Dataset(Y, tuple(names), RATE, TRAIN), ctx)
    assert det.run(model, Dataset(Y, tuple(names), RATE, TRAIN), ctx).events == []
    Yf = Y.copy()
    Yf[:, 2] = inject_fault(Y[:, 2], RATE, "additive", 20.0, float(np.std(Y[:, 2])))
    res = det.run(model, Dataset(Yf, tuple(names), RATE, TRAIN), ctx)
    assert [e.channel for e in res.events] == ["s2"]
    assert res.events[0].type.value == "additive" and abs(res.events[0].onset_s - 20.0) < 0.5
    assert res.model["source"] == "config [model]" and res.model["unmeasured_inputs"] == 1


def test_config_model_errors():
    b = shear_building(3)
    A, B, C, D = b.discrete(RATE)
    _, Y, names = simulate_building(n_floors=3, duration_s=12.0, rate_hz=RATE, seed=1)
    ds = Dataset(Y, tuple(names), RATE, (0, 1500))
    bad_dt = {"A": A, "B": B, "C": C, "D": D, "outputs": list(names), "inputs": [], "dt": 0.01}
    with pytest.raises(DetectorError, match=r"dt = 0.01 s does not match the analysis rate"):
        DetectionFilter().fit(ds, RunContext(config={"model": bad_dt}))
    unknown = {"A": A, "B": B, "C": C, "D": D, "outputs": ["s0", "s1", "zz"], "inputs": []}
    assert "not analyzed" in DetectionFilter().applicable(ds, RunContext(config={"model": unknown}))


def test_gap_is_no_fault(buildings):
    Y, names, det, model, ctx = buildings[0]
    Yg = Y.copy()
    Yg[int(30 * RATE) : int(31 * RATE), 2] = np.nan
    res = det.run(model, Dataset(Yg, tuple(names), RATE, TRAIN), ctx)
    assert res.events == []
    assert np.isnan(res.residuals["s2"][int(30.5 * RATE)])
    assert np.isnan(res.residuals["s0"][int(30.5 * RATE)])  # every filter measures s2


def test_needs_two_channels():
    ds = Dataset(np.zeros((100, 1)), ("a",), 10.0, (0, 50))
    assert "at least 2 channels" in DetectionFilter().applicable(ds, RunContext())
