"""A gain's end where the residual after it is no noisier than health: undoing the gain
there leaves ``(e - (a - 1) y) / a``, of variance ``(1 + (a - 1)^2 V / s2) / a^2`` times
health's, which the corrected residual's alarm windows do not tell from health (below 1
for a gain of 1.5 where ``V < 5 s2``); the end is where the residual is health's rather
than the gain's (:func:`~analyzer.diagnosis.events._gain_ended`)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from analyzer.diagnosis.changes import calibrate
from analyzer.diagnosis.classify import Classification
from analyzer.diagnosis.events import _gain_ended, events_from_residual
from analyzer.types import FaultType

RATE = 100.0
START = 6000  # the healthy window: the first 60 s
N = 30_000


def _record(seed: int, v: float) -> tuple[np.ndarray, np.ndarray]:
    """A coloured healthy residual of variance ~1 and a reference of variance ``v``: a
    lightly damped 1.3-Hz response to white noise (a floor's motion)."""
    rng = np.random.default_rng(seed)
    e = lfilter([1.0], [1.0, -0.6], rng.standard_normal(N)) * 0.8
    w = 2 * np.pi * 1.3 / RATE
    y = lfilter([1.0], [1.0, -2 * 0.995 * np.cos(w), 0.995**2], rng.standard_normal(N))
    y *= np.sqrt(v) / y.std()
    return e, y


LATE = pytest.mark.xfail(
    strict=True,
    raises=AssertionError,
    reason="open: the corrected residual's alarms end the gain late (270.8 s, 212.4 s), "
    "and the gain's end test, run only where no end was found, does not overrule them "
    "(run past a found end, it cut a gain beside another sensor's offset at 180.9 s, "
    "sweep_two_faults gain-offset seed 14)",
)


@pytest.mark.parametrize(
    "seed, v",
    [
        (1, 2.0),
        (2, 2.0),
        (3, 2.0),
        (1, 4.0),
        pytest.param(2, 4.0, marks=LATE),
        pytest.param(3, 4.0, marks=LATE),
    ],
)
def test_a_gain_whose_corrected_residual_is_quieter_after_it_ends_where_it_ended(seed, v):
    """A gain of 1.5 from 100 to 200 s: after 200 s the corrected residual has 0.67 (``V =
    2``) or 0.89 (``V = 4``) of health's variance. It ran to the record's end (the two44
    classifier, which makes it a gain); at bd303ba it was ``other``."""
    e, y = _record(seed, v)
    a = 1.5
    r = e.copy()
    fault = slice(10_000, 20_000)
    r[fault] = (a - 1.0) * y[fault] + a * e[fault]
    s2 = float(np.var(e[:START]))
    assert (1 + (a - 1) ** 2 * v / s2) / a**2 < 1.0
    cal = calibrate(r[:START], 25)
    events = events_from_residual("s0", r, y, cal, RATE, "t", search_start=START, healthy_start=0)
    gains = [ev for ev in events if ev.type is FaultType.MULTIPLICATIVE]
    assert gains and gains[0].onset_s == pytest.approx(100.0, abs=1.0)
    assert gains[-1].end_s is not None and gains[-1].end_s == pytest.approx(200.0, abs=1.0)
    assert gains[-1].magnitude["gain"] == pytest.approx(a, abs=0.1)


def _gain_through_a_lull(seed: int, a: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A record's healthy residual, its reference quiet from 150 s (1 % of its size),
    and the residual of a gain ``a`` from 100 s to the end: ``(e, y, r)``."""
    e, y = _record(seed, 4.0)
    y[15_000:] *= 0.01
    r = e.copy()
    r[10_000:] = (a - 1.0) * y[10_000:] + a * e[10_000:]
    return e, y, r


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_gain_that_goes_on_through_a_lull_is_not_ended_there(seed):
    """A gain of 1.5 from 100 s to the record's end whose structure falls quiet from 150 s
    (the reference 1 % of its size): the raw residual's alarms stop there (its noise,
    2.25 times health's, is under the long window's threshold), the gain's scaled noise
    still tells it from health, and the fault goes on to the end."""
    e, y, r = _gain_through_a_lull(seed, 1.5)
    cal = calibrate(r[:START], 25)
    events = events_from_residual("s0", r, y, cal, RATE, "t", search_start=START, healthy_start=0)
    assert events and events[0].type is FaultType.MULTIPLICATIVE
    assert events[0].onset_s == pytest.approx(100.0, abs=1.0)
    assert events[-1].end_s is None


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5, 6])
@pytest.mark.parametrize("noise", [2.0, 2.5])
def test_a_gain_fitted_with_a_larger_noise_of_its_own_goes_on_through_a_lull(seed, noise):
    """The end test's gain model with the noise level of the classification's fit: a fit
    with a noise of its own, on a short first stretch, may take 2-2.5 times health's for
    a gain of 1.5. With that noise the sum fell inside the fault, in a quiet stretch of
    the structure (the gain's scaled noise the only evidence there: an expected step of
    ``a^2 (1 - 1 / k^2) / 2 - log k``, 0.03 for ``k`` 2.5), and ended a gain that went
    on (3 and 6 of 6 seeds, at 150-193 s); the model's noise is at most the gain's."""
    from analyzer.diagnosis.classify import Classification
    from analyzer.diagnosis.events import _gain_ended

    a = 1.5
    e, y, r = _gain_through_a_lull(seed, a)
    cal = calibrate(r[:START], 25)
    cls = Classification(
        FaultType.MULTIPLICATIVE, {"gain": a}, 1.0, params={"gain": a}, noise_scale=noise
    )
    assert _gain_ended(r, y, cls, cal, None, 15_000, N) is None
    ended = e.copy()  # the same gain ending at 150 s, in the lull: ended there
    ended[10_000:15_000] = (a - 1.0) * y[10_000:15_000] + a * e[10_000:15_000]
    got = _gain_ended(ended, y, cls, cal, None, 15_000, N)
    assert got is not None and 150.0 <= got / RATE <= 160.0


def _narrow_band(rng: np.random.Generator, n: int) -> np.ndarray:
    """A lightly damped 1.3-Hz response to white noise, of unit variance."""
    w = 2 * np.pi * 1.3 / RATE
    y = lfilter([1.0], [1.0, -2 * 0.995 * np.cos(w), 0.995**2], rng.standard_normal(n))
    return y / y.std()


@pytest.mark.parametrize("seconds", [1_000.0, 10_000.0])
@pytest.mark.parametrize("seed", range(1, 9))
def test_a_long_gain_is_not_ended_by_the_length_of_its_record(seed, seconds):
    """A gain of 0.75 from 100 s to the record's end, the healthy residual carrying a
    share of 0.3 sd at the structure's frequency (the model's error: the reference's own
    band, independent of it). Its product with the reference swings slowly, and over a
    long fault the end test's sum falls by its bound somewhere: at 93f9147 a record of
    10,000 s was ended at 7866 s (seed 3) and 5603 s (seed 8), one of 1,000 s never (a
    4-h record of the 5-floor building was ended at 8286 s, and the gain's inverse then
    reported on the sensor's neighbours). The same gain ending halfway is ended there."""
    n = int(seconds * RATE)
    rng = np.random.default_rng(seed)
    e = lfilter([1.0], [1.0, -0.6], rng.standard_normal(n)) * 0.8 + 0.3 * _narrow_band(rng, n)
    y = 2.0 * _narrow_band(rng, n)
    a = 0.75
    r = e.copy()
    r[10_000:] = (a - 1.0) * y[10_000:] + a * e[10_000:]
    cal = calibrate(r[:START], 25)
    cls = Classification(
        FaultType.MULTIPLICATIVE, {"gain": a}, 1.0, params={"gain": a}, noise_scale=a
    )
    assert _gain_ended(r, y, cls, cal, None, 12_000, n) is None
    ended = r.copy()
    ended[n // 2 :] = e[n // 2 :]
    got = _gain_ended(ended, y, cls, cal, None, 12_000, n)
    assert got is not None and got / RATE == pytest.approx(n // 2 / RATE, abs=2.0)


@pytest.mark.parametrize("seed", [1, 3])
def test_an_end_at_a_gaps_start_stays_there(seed):
    """Across a gap the evidence sum is flat, so its maximum is tied over the gap: the end
    is its first sample (a strictly new maximum, as ``argmax`` gives for the maximum
    carried between pieces), not the gap's far side (the review of the fiftieth
    session's bound: a gain to 300 s before a 30-s gap was ended at 330.0 s on seed 3).
    (Seeds 2 and 4 end past the gap on either rule: their sums rise after it.)"""
    n, a = 60_000, 0.75
    rng = np.random.default_rng(seed)
    e = lfilter([1.0], [1.0, -0.6], rng.standard_normal(n)) * 0.8
    y = 2.0 * _narrow_band(rng, n)
    r = e.copy()
    r[10_000:30_000] = (a - 1) * y[10_000:30_000] + a * e[10_000:30_000]
    r[30_000:33_000] = np.nan  # a 30-s gap right where the gain ends
    cal = calibrate(r[:6000], 25)
    cls = Classification(
        FaultType.MULTIPLICATIVE, {"gain": a}, 1.0, params={"gain": a}, noise_scale=a
    )
    got = _gain_ended(r, y, cls, cal, None, 12_000, n)
    assert got is not None and abs(got / RATE - 300.0) <= 0.5, got
