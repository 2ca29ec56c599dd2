"""A slow drift whose copy in a neighbour's bank residual is the larger: the bank names
the sensor whose leave-out estimator stays consistent over the fault, and reports the
drift's own rate.

The bank's estimator of a sensor's neighbour uses the drifting sensor, so the neighbour's
residual carries the drift amplified and sign-turned (a drift of 0.0185/s on s3 of the
5-floor building showed as -0.021/s on s4). At the onset no estimator is inconsistent yet,
and the strongest residual was the neighbour's: the bank reported the drift there,
unconfirmed, and its correction took most of the drift out of s3's residual (0.0074/s
reported for 0.0185/s, and false drifts on s2 and s1). Over the fault period, only the
estimator that leaves s3 out stays consistent.

Reference: the injected rate (units per second); a reported rate within 25 % of it."""

from __future__ import annotations

import numpy as np
import pytest
from run_helpers import run_csv

from analyzer.simulate import inject_fault, simulate_building

RATE_HZ = 200.0
ONSET_S = 180.0


def _record(seed: int, channel: int, sd_per_s: float):
    """The 5-floor building, 300 s at 200 Hz, with a drift of ``sd_per_s`` of the channel's
    RMS per second on ``channel`` from 180 s: times, values, names, the rate injected."""
    t, y, names = simulate_building(5, 300.0, RATE_HZ, seed=seed)
    rate = sd_per_s * float(np.sqrt(np.mean(y[:, channel] ** 2)))
    y[:, channel] = inject_fault(y[:, channel], RATE_HZ, "drift", ONSET_S, rate)
    return t, y, names, rate


@pytest.mark.parametrize(
    ("seed", "channel", "sd_per_s"), [(1, 3, 0.02), (3, 3, 0.005), (2, 4, 0.02)]
)
def test_the_bank_reports_a_drift_on_its_sensor_at_its_rate(tmp_path, seed, channel, sd_per_s):
    """The bank alone: one finding, the drift on its sensor, at its rate (at ff22576: on
    s3 at 0.36-0.38 of the rate, unconfirmed, beside false drifts on its neighbours)."""
    t, y, names, rate = _record(seed, channel, sd_per_s)
    faults = run_csv(tmp_path, t, y, names, options=("--detectors", "ar_kalman_bank"))
    assert [(f["channel"], f["type"]) for f in faults] == [(names[channel], "drift")]
    assert faults[0]["magnitude"]["rate_per_s"] == pytest.approx(rate, rel=0.25)
    assert abs(faults[0]["onset_s"] - ONSET_S) < 2.0


def test_the_reported_rate_is_the_drifts_with_every_detector(tmp_path):
    """With the defaults the finding's rate is the drift's (at ff22576 the bank's 0.36 of
    it led: the votes tied and its traced onset was the earlier)."""
    t, y, names, rate = _record(3, 3, 0.005)
    faults = run_csv(tmp_path, t, y, names)
    assert [(f["channel"], f["type"]) for f in faults] == [("s3", "drift")]
    assert faults[0]["magnitude"]["rate_per_s"] == pytest.approx(rate, rel=0.25)


def test_two_drifts_are_not_moved_to_a_healthy_sensor(tmp_path):
    """Drifts of 0.01 RMS/s on s3 from 180 s and on s2 from 181 s, seed 1: the bank first
    takes them as s4's (unconfirmed) and corrects s4; over the next fault's period healthy
    s1's estimator then stayed the quietest (0.71, the others 1.35-3.57), and the move
    named s1 alone, as confirmed: with the defaults only an s1 drift was reported, both
    real faults lost. After a guessed correction no fault moves (at ff22576: s4, s3, s2)."""
    t, y, names = simulate_building(5, 300.0, RATE_HZ, seed=1)
    for channel, onset in ((3, 180.0), (2, 181.0)):
        rate = 0.01 * float(np.sqrt(np.mean(y[:, channel] ** 2)))
        y[:, channel] = inject_fault(y[:, channel], RATE_HZ, "drift", onset, rate)
    channels = {f["channel"] for f in run_csv(tmp_path, t, y, names)}
    assert "s1" not in channels
    assert channels & {"s2", "s3"}
