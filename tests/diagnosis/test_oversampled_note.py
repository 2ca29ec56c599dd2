"""The note on a clock far above what the sensors carry (:mod:`analyzer.diagnosis.oversampled`)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from run_helpers import run_csv

from analyzer.config import Config
from analyzer.diagnosis.oversampled import (
    MAX_RATIO,
    MEMORY_SAMPLES,
    Oversampled,
    content_frequency,
    oversampled_note,
    slower_clock_note,
    suggested_rate,
    welch,
)
from analyzer.pipeline import _models_memory, _rate_against_model
from analyzer.simulate import simulate_building
from analyzer.store.store import ChannelInfo


@pytest.mark.parametrize(
    ("content", "rate"), [(5.5, 200.0), (3.67, 100.0), (12.6, 500.0), (10.0, 200.0), (0.3, 10.0)]
)
def test_the_suggested_rate_is_the_next_round_one_twenty_times_the_content(content, rate):
    assert suggested_rate(content) == rate


def test_the_content_of_a_sine_in_noise_is_its_frequency():
    rate = 1000.0
    t = np.arange(20_000) / rate
    x = np.sin(2 * np.pi * 7.0 * t) + 0.01 * np.random.default_rng(0).standard_normal(t.size)
    got = content_frequency(x, rate)
    assert got is not None
    assert got.peak == pytest.approx(7.0, abs=0.1)
    assert got.content == pytest.approx(7.0, abs=0.2)
    assert got.resolution == pytest.approx(rate / 20_000)  # one segment of them all


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


def _sines(hz: float, rate: float, seconds: float = 40.0, finite: int | None = None):
    """Three channels of a ``hz`` sine in a little noise at ``rate``; with ``finite``,
    only their first ``finite`` samples are data and the rest of the window a gap."""
    t = np.arange(int(seconds * rate)) / rate
    rng = np.random.default_rng(3)
    y = np.column_stack(
        [np.sin(2 * np.pi * hz * t + k) + 0.01 * rng.standard_normal(t.size) for k in range(3)]
    )
    if finite is not None:
        y[finite:] = np.nan
    return y, ["a", "b", "c"]


def test_the_peak_test_resolves_with_the_samples_a_window_with_gaps_has():
    """A window of 20 s at 1 kHz whose data is its first second (a gap after it): the
    spectrum of that second resolves 1 Hz, not the 0.05 Hz of 20 s. A 2-Hz sine's peak is
    2 of its bins above zero, which does not tell an oscillation from a trend (the note
    was given, its peak taken for 40 bins); a 7-Hz sine's 7 bins do."""
    rate = 1000.0
    y, names = _sines(2.0, rate, seconds=20.0, finite=1000)
    assert oversampled_note(y, names, (0, y.shape[0]), rate) is None
    got = content_frequency(y[:, 0], rate)
    assert got is not None and got.resolution == pytest.approx(1.0)
    y, names = _sines(7.0, rate, seconds=20.0, finite=1000)
    assert oversampled_note(y, names, (0, y.shape[0]), rate) is not None


def test_the_note_names_the_memory_the_run_sets_and_its_limit_follows():
    """An AR order of 7 set in the config: the models remember 7 samples, which span a
    quarter of a period from 28 times its frequency on (not 40); an order of 20 from 80."""
    hz = 7.0
    rate = 1.2 * 28 * hz  # 33.6 times the content: under the default's 40
    y, names = _sines(hz, rate)
    assert oversampled_note(y, names, (0, y.shape[0]), rate) is None
    note = oversampled_note(y, names, (0, y.shape[0]), rate, memory=7)
    assert note is not None
    assert "remember about 7 samples (29.8 ms of a 142 ms period)" in note
    rate = 1.2 * MAX_RATIO * hz  # 48 times: over the default's 40, under 80
    y, names = _sines(hz, rate)
    assert "remember about 10 samples" in str(oversampled_note(y, names, (0, y.shape[0]), rate))
    assert oversampled_note(y, names, (0, y.shape[0]), rate, memory=20) is None


def test_a_short_memory_names_a_rate_it_would_not_be_given_again_at():
    """An AR order of 2: the limit is 8 times the content; the rate named, at least 4
    times it rounded up, is no more than 8 times (not the default's 20 times: 200 Hz)."""
    hz = 7.0
    rate = 1000.0
    y, names = _sines(hz, rate)
    note = oversampled_note(y, names, (0, y.shape[0]), rate, memory=2)
    assert note is not None and "--rate 50 aligns" in note  # 4 x 7 = 28 -> 50 <= 56
    y50 = y[::20]
    assert oversampled_note(y50, names, (0, y50.shape[0]), 50.0, memory=2) is None


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


def test_the_runs_memory_is_the_order_its_config_sets():
    """The largest of the AR bank's and the detection filter's order among the detectors
    that ran: the order set, else the highest its criterion searches (``max_order``); the
    detection filter on the config's ``[model]`` has no AR order."""
    both = {"ar_kalman_bank", "detection_filter"}
    assert _models_memory(Config(), both) == MEMORY_SAMPLES == 10
    bank4 = {"ar_kalman_bank": {"order": 4}}
    assert _models_memory(Config(detectors=bank4), {"ar_kalman_bank"}) == 4
    assert _models_memory(Config(detectors=bank4), both) == 10  # the filter's criterion
    assert _models_memory(Config(detectors={**bank4, "detection_filter": {"order": 3}}), both) == 4
    crit = {"ar_kalman_bank": {"order": "aic", "max_order": 16}}
    assert _models_memory(Config(detectors=crit), both) == 16
    modelled = Config(detectors=bank4, model={"A": [[0.5]]})
    assert _models_memory(modelled, both) == 4
    assert _models_memory(Config(detectors=bank4), {"equivalent_model"}) == MEMORY_SAMPLES


def test_the_run_names_the_order_its_config_sets(tmp_path):
    """A 4-floor building at 500 Hz (content about 5 Hz) with the bank's order set to 4:
    at ``--rate 500`` the note says the models remember 4 samples, not 10, and names a
    rate where 4 samples span a quarter period (50 Hz); without ``--rate`` the run
    analyzes the record at that rate, and its note names the same memory."""
    t, y, names = simulate_building(n_floors=4, duration_s=30.0, rate_hz=500.0, seed=1)
    config = tmp_path / "c.toml"
    config.write_text("[detectors.ar_kalman_bank]\norder = 4\n")
    options = ("--detectors", "ar_kalman_bank", "--train", "0:15", "--config", str(config))
    for part, rate in (("asked", ("--rate", "500")), ("default", ())):
        (tmp_path / part).mkdir()
        run_csv(tmp_path / part, t, y, names, code=0, options=(*options, *rate))
    doc = json.loads((tmp_path / "asked" / "out" / "findings.json").read_text())
    (note,) = [n for n in doc["notes"] if "sampled at 500 Hz" in n]
    assert "remember about 4 samples (8 ms of a" in note and "--rate 50 aligns" in note
    doc = json.loads((tmp_path / "default" / "out" / "findings.json").read_text())
    assert (doc["rate_hz"], doc["logged_rate_hz"]) == (50.0, 500.0)
    (note,) = [n for n in doc["notes"] if n.startswith("record logged at 500 Hz, analyzed at 50")]
    assert "remember about 4 samples, 8 ms at 500 Hz" in note


def test_the_slowed_note_names_corrected_csv_only_with_corrected():
    # (the review's M2: with --corrected, the file's rate is said where the clock is)
    found = Oversampled(2000.0, 5.5, 200.0, 10)
    plain, asked = slower_clock_note(found), slower_clock_note(found, corrected=True)
    assert "corrected.csv" not in plain.short and "corrected.csv" not in str(plain)
    assert asked.short.endswith("(corrected.csv too is written at 200 Hz, low-passed)")
    assert asked.short in str(asked)


def _infos(rate: float) -> list[ChannelInfo]:
    return [ChannelInfo(f"s{k}", 1000, 0, 10**10, rate, 0, 1000, -1.0, 1.0) for k in range(3)]


def test_a_model_slower_than_the_channels_does_not_just_advise_their_rate():
    # a --save-model of a run that slowed a 2-kHz record is at 100 Hz on purpose: the
    # warning must not tell the user a model at 2 kHz fits best (the review's M3)
    (slower,) = _rate_against_model(_infos(2000.0), ["s0", "s1", "s2"], 100.0)
    assert "resampled to the model's rate" in slower
    assert not slower.endswith("(a model fitted at their own rate fits them best)"), slower
    assert "a run without --rate then analyzes them slower" in slower
    # a model faster than the channels (their samples interpolated): the advice stands
    (faster,) = _rate_against_model(_infos(50.0), ["s0", "s1", "s2"], 200.0)
    assert faster.endswith("(a model fitted at their own rate fits them best)"), faster
