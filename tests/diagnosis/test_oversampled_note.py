"""The note on a clock far above what the sensors carry (:mod:`analyzer.diagnosis.oversampled`)."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.diagnosis.oversampled import (
    MAX_RATIO,
    content_frequency,
    oversampled_note,
    suggested_rate,
    welch,
)
from analyzer.simulate import simulate_building


@pytest.mark.parametrize(
    ("content", "rate"), [(5.5, 200.0), (3.67, 100.0), (12.6, 500.0), (10.0, 200.0), (0.3, 10.0)]
)
def test_the_suggested_rate_is_the_next_round_one_twenty_times_the_content(content, rate):
    assert suggested_rate(content) == rate


def test_the_content_of_a_sine_in_noise_is_its_frequency():
    rate = 1000.0
    t = np.arange(20_000) / rate
    x = np.sin(2 * np.pi * 7.0 * t) + 0.01 * np.random.default_rng(0).standard_normal(t.size)
    content, peak = content_frequency(x, rate)
    assert peak == pytest.approx(7.0, abs=0.1)
    assert content == pytest.approx(7.0, abs=0.2)


def _window(rate: float, floors: int = 4) -> tuple[np.ndarray, list[str]]:
    _, y, names = simulate_building(n_floors=floors, duration_s=20.0, rate_hz=rate, seed=1)
    return y, names


@pytest.mark.parametrize("rate", [500.0, 2000.0])
def test_a_building_logged_far_above_its_modes_gets_the_note(rate):
    y, names = _window(rate)
    note = oversampled_note(y, names, (0, y.shape[0]), rate)
    assert note is not None and f"sampled at {rate:g} Hz" in note
    assert note.short == str(note)  # repeated on stderr as it is
    assert "--rate 100 " in note or "--rate 200 " in note


@pytest.mark.parametrize("rate", [100.0, 200.0])
def test_a_building_logged_at_a_rate_its_models_suit_gets_none(rate):
    y, names = _window(rate, floors=8)
    assert oversampled_note(y, names, (0, y.shape[0]), rate) is None


def test_slow_trends_at_a_high_rate_get_none():
    # a robot's positions: random walks, all their power near zero frequency; a lower
    # clock would serve them no better
    rate = 1000.0
    y = np.cumsum(np.random.default_rng(2).standard_normal((20_000, 4)), axis=0)
    assert oversampled_note(y, ["x", "y", "z", "w"], (0, y.shape[0]), rate) is None


def test_the_threshold_is_the_models_memory_against_a_quarter_period():
    # a 7-Hz sine: the note from above 40 x 7 Hz (ten samples < a quarter period) on
    rate_ok, rate_fast = 0.9 * MAX_RATIO * 7.0, 1.2 * MAX_RATIO * 7.0
    for rate, noted in ((rate_ok, False), (rate_fast, True)):
        t = np.arange(int(40 * rate)) / rate
        rng = np.random.default_rng(3)
        y = np.column_stack(
            [np.sin(2 * np.pi * 7.0 * t + k) + 0.01 * rng.standard_normal(t.size) for k in range(3)]
        )
        assert (oversampled_note(y, ["a", "b", "c"], (0, t.size), rate) is not None) is noted


@pytest.mark.parametrize(
    ("n", "size"), [(20_000, 4096), (1000, 1000), (4097, 2048), (1001, 1001), (1001, 333)]
)
def test_welch_is_scipys(n, size):
    signal = pytest.importorskip("scipy.signal")
    rng = np.random.default_rng(n)
    x = np.cumsum(rng.standard_normal(n)) + np.sin(np.arange(n) / 7.0)
    f, p = welch(x, 250.0, size)
    f_ref, p_ref = signal.welch(x, 250.0, nperseg=size, detrend="linear")
    np.testing.assert_allclose(f, f_ref)
    np.testing.assert_allclose(p, p_ref, rtol=1e-9, atol=1e-12 * float(np.max(p_ref)))
