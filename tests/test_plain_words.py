"""Durations and rates in the lines a user reads are in the unit they read best in, never
in exponent notation: the oversampling warning on a ROS 2 bag said "400 ms of a
5.81e+03-ms period" (5.8 s), and a 2 kHz clock was "2e+03 Hz"."""

from __future__ import annotations

import re
from types import SimpleNamespace

import numpy as np
import pytest

from analyzer.detector_runs import SkipReason
from analyzer.diagnosis.oversampled import oversampled_note
from analyzer.pipeline import _longer_window, _slow_clock
from analyzer.timeutil import plain_number, spoken_duration

EXPONENT = re.compile(r"\d[eE][+-]\d")


@pytest.mark.parametrize(
    "seconds, said",
    [
        (0.4, "400 ms"),
        (0.0298, "29.8 ms"),
        (5.81, "5.8 s"),
        (42.4, "42 s"),
        (100.0, "100 s"),
        (150.0, "2.5 min"),
        (725.0, "12 min"),
        (4 * 3600.0, "4.0 h"),
        (3 * 86400.0, "3.0 days"),
        (5400.0, "90 min"),
        (200_000.0, "2.3 days"),
    ],
)
def test_a_duration_reads_in_its_unit(seconds, said):
    assert spoken_duration(seconds) == said


@pytest.mark.parametrize(
    "x, said", [(2000.0, "2000"), (1234.5, "1234"), (0.172, "0.172"), (25.0, "25"), (1e12, "1e+12")]
)
def test_a_rate_has_no_exponent_in_its_range(x, said):
    assert plain_number(x) == said


def test_the_oversampling_warning_says_a_slow_period_in_seconds():
    """A 0.17-Hz sine at 25 Hz (the ROS 2 bag's battery voltage): 10 samples are 400 ms
    of a period of about 5.8 s."""
    rate = 25.0
    t = np.arange(int(300 * rate)) / rate
    rng = np.random.default_rng(3)
    y = np.column_stack(
        [np.sin(2 * np.pi * 0.15 * t + k) + 0.01 * rng.standard_normal(t.size) for k in range(3)]
    )
    note = oversampled_note(y, ["a", "b", "c"], (0, y.shape[0]), rate)
    assert note is not None
    assert not EXPONENT.search(str(note)), note
    said = re.search(r"\(400 ms of a (\d+\.\d) s period\)", str(note))
    assert said is not None, note
    assert 5.0 < float(said.group(1)) < 7.0


def test_khz_rates_in_the_clock_hints_are_plain():
    infos = [SimpleNamespace(name=f"c{k}", rate_hz=2000.0 if k < 2 else 5.0) for k in range(6)]
    hint = _slow_clock(infos, [i.name for i in infos], 5.0)  # type: ignore[arg-type]
    assert "2000 Hz" in hint and "--rate 2000," in hint and not EXPONENT.search(hint), hint
    line = _longer_window({"x": SkipReason("too little", rows=30000)}, (0.0, 1.0), 2000.0, 5.0)
    assert "at 2000 Hz" in line and not EXPONENT.search(line), line
