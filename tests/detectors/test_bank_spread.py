"""The bank under a load of another colour (EOV probe, P3): a machine's sine between
modes 1 and 2 replacing most of the broadband excitation at the same response level made
the bank report a gain of ~1.09 on a first-floor sensor, in most seeds, unconfirmed (no
estimator that takes the sensor in became inconsistent). A real fault on a sensor reaches
every estimator that takes the sensor in; this change did not, and the estimators that
take it in moved against what the fault's correction would take out of them
(:meth:`ARKalmanBank._spread`). Such a change is attributed to no sensor now; a real small
gain, offset or drift, unconfirmed as well, is still reported, its spread ratio near 1."""

import numpy as np
import pytest

from analyzer.detectors.ar_kalman import ARKalmanBank
from analyzer.detectors.base import Dataset, FaultType, RunContext
from analyzer.simulate import band_limited_noise, inject_fault, shear_building, simulate_response

RATE = 100.0
DURATION = 600.0
FLOORS = 3
TRAIN = (0, int(0.2 * DURATION * RATE))
CHANGE_S = 360.0
NAMES = tuple(f"s{i}" for i in range(2 * FLOORS))


def _building(seed: int, machine: bool) -> np.ndarray:
    """3 floors x 2 accelerometers, 10 min. With ``machine``, from 360 s the broadband
    ground acceleration drops to 0.3x and a sine between modes 1 and 2 is added, scaled
    so the top floor's response RMS equals the training window's (``sweep_eov.py``'s
    harmonic_eq case, the same draws); sensor noise 20 dB below each channel's training
    RMS, fixed in absolute terms."""
    rng = np.random.default_rng(seed)
    model = shear_building(FLOORS, 1.01, 0.02)
    n = int(DURATION * RATE)
    t = np.arange(n) / RATE
    freqs = model.frequencies_hz
    ground = band_limited_noise(n, RATE, min(0.4 * RATE, 2.0 * float(freqs[-1])), rng)
    if machine:
        on = t >= CHANGE_S
        background = np.where(on, 0.3, 1.0) * ground
        f = 0.5 * float(freqs[0] + freqs[1])
        sine = np.sqrt(2.0) * np.sin(2.0 * np.pi * f * t + rng.uniform(0.0, 2.0 * np.pi))
        load = np.where(on, sine, 0.0)
        top_b = simulate_response(model, background, RATE)[:, -1]
        top_l = simulate_response(model, load, RATE)[:, -1]
        wanted = np.var(top_b[: TRAIN[1]]) - np.var(top_b[on])
        ground = background + np.sqrt(max(wanted, 0.0) / np.var(top_l[on])) * load
    clean = np.repeat(simulate_response(model, ground, RATE), 2, axis=1)
    rms = np.sqrt(np.mean(clean[: TRAIN[1]] ** 2, axis=0))
    return clean + rng.standard_normal(clean.shape) * rms / 10.0


def _run(Y: np.ndarray):
    ds = Dataset(Y, NAMES, RATE, TRAIN)
    det, ctx = ARKalmanBank(), RunContext()
    return det.run(det.fit(ds, ctx), ds, ctx)


@pytest.mark.parametrize("seed", [0, 4])
def test_a_machine_load_at_the_same_level_is_no_sensors_gain(seed):
    """Before: a gain on s0 (seed 0: 1.09, 360.2 s) or s1 (seed 4: 1.16, 360.4 s), not
    isolated. Now no event, and a note that says why."""
    res = _run(_building(seed, machine=True))
    assert res.events == [], [(e.channel, e.type, e.onset_s, e.evidence) for e in res.events]
    against = [n for n in res.notes if "move against" in n]
    assert against, res.notes
    assert res.unattributed and all(t >= CHANGE_S - 5.0 for t, _, _ in res.unattributed)


@pytest.fixture(scope="module")
def healthy():
    return _building(1, machine=False)


@pytest.mark.parametrize(
    ("kind", "size"),
    [("multiplicative", 1.09), ("additive", 0.15), ("drift", 0.3 / 600.0)],
)
@pytest.mark.parametrize("channel", [0, 3])
def test_a_small_real_fault_is_still_reported(healthy, kind, size, channel):
    """A fault of 0.3x the isolation sweep's sizes (gain 1.09; offset 0.15 sd; drift 0.3
    sd per 10 minutes) from 360 s: reported on its sensor with its type; a gain's spread
    ratio is near 1 (offsets and drifts are not weighed: their correction is a slow step
    or ramp, :data:`SPREAD_SIGMAS`)."""
    Y = healthy.copy()
    sd = float(np.std(Y[:, channel]))
    scaled = size if kind == "multiplicative" else size * sd
    Y[:, channel] = inject_fault(Y[:, channel], RATE, kind, CHANGE_S, scaled, None)
    res = _run(Y)
    mine = [e for e in res.events if e.channel == f"s{channel}"]
    assert [e.type for e in mine][:1] == [FaultType(kind)], [
        (e.channel, e.type, e.onset_s) for e in res.events
    ]
    if kind != "multiplicative":
        assert "spread" not in mine[0].evidence
        return
    spread = mine[0].evidence["spread"]
    assert spread["se"] < 0.2
    assert abs(spread["ratio"] - 1.0) < 0.35, spread


def test_the_spread_is_computed_as_its_definition(healthy):
    """The ratio and its error against a direct computation: the other residuals'
    least-squares ratio to the change that filtering the corrected reading makes."""
    Y = healthy.copy()
    Y[:, 0] = inject_fault(Y[:, 0], RATE, "multiplicative", CHANGE_S, 1.3, None)
    ds = Dataset(Y, NAMES, RATE, TRAIN)
    det, ctx = ARKalmanBank(), RunContext()
    model = det.fit(ds, ctx)
    res = det.run(model, ds, ctx)
    (ev,) = [e for e in res.events if e.channel == "s0"]
    gain = ev.magnitude["gain"]
    # corrected from the fault's onset (the alarm interval's: a gain's is not moved)
    onset = int(round(ev.onset_s * RATE))
    before = det._bank_outputs(model, Y, None, consistency=False).resid
    fixed = Y.copy()
    fixed[onset:, 0] = Y[onset:, 0] / gain
    after = det._bank_outputs(model, fixed, None, consistency=False).resid
    sig = np.array([c.std for c in model.residual_cal])[1:]
    z = before[onset:, 1:] / sig
    d = (before[onset:, 1:] - after[onset:, 1:]) / sig
    ratio = float(np.sum(z * d) / np.sum(d * d))
    assert ev.evidence["spread"]["ratio"] == pytest.approx(ratio, abs=0.02)
    assert ratio == pytest.approx(1.0, abs=0.1)
