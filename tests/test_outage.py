"""Logger outages (analyzer.outage): every channel at one value, or repeating its values,
at the same rows is found, across the scan's blocks, and masked; slow or quantized
channels that hold their values, two channels, or one stuck sensor are not an outage."""

from __future__ import annotations

import numpy as np
import pytest

import analyzer.outage as outage
from analyzer.outage import Outage, find_outages, mask_outages, outage_note, treat_outages

N = 20_000


def _busy(m: int = 6, seed: int = 0) -> np.ndarray:
    """Vibrating channels: floating-point values that never repeat."""
    return np.random.default_rng(seed).standard_normal((N, m))


def _slow(m: int, seed: int = 1) -> np.ndarray:
    """Temperatures at 0.1 K resolution in one room, drifting slowly together: each
    holds its value for long stretches (minutes at 1 Hz), all of them at once too."""
    rng = np.random.default_rng(seed)
    common = np.cumsum(rng.standard_normal(N)) * 0.003
    walk = 20.0 + common[:, None] + np.cumsum(rng.standard_normal((N, m)) * 0.0015, axis=0)
    return np.round(walk / 0.1) * 0.1


def test_a_zero_stretch_on_every_channel_is_an_outage():
    v = _busy()
    v[5000:5570] = 0.0
    assert find_outages(v) == [Outage(5000, 5570, 0.0)]
    notes: list[str] = []
    treat_outages(v, [f"s{j}" for j in range(6)], 100.0, notes)
    assert np.isnan(v[5000:5570]).all() and np.isfinite(v[:5000]).all()
    assert np.isfinite(v[5570:]).all()
    assert notes == [
        "logger outage: all 6 channels read exactly 0.0 from 50.00 s to 55.70 s (570 rows; "
        "the data acquisition, not a sensor); treated as missing data"
    ]
    assert isinstance(notes[0], outage.OutageNote)  # repeated on stderr by `run`


def test_rows_repeated_by_a_hung_logger_are_an_outage_from_the_first_repeat():
    v = _busy()
    v[8000:8300] = v[7999]  # the last row read, written again and again
    v[100:140] = 7.5  # and a stretch at one common value that is not zero
    assert find_outages(v) == [Outage(100, 140, 7.5), Outage(8000, 8300, None)]
    note = outage_note(find_outages(v), list("abcdef"), 100.0)
    assert note.startswith("logger outages: 2 stretches in which all 6 channels")
    assert "1.00 s to 1.40 s, read exactly 7.5" in note
    assert "80.00 s to 83.00 s, repeated their values of 79.99 s exactly" in note


@pytest.mark.parametrize("block", [64, 997, 5000])
def test_stretches_across_block_boundaries_are_found_whole(monkeypatch, block):
    v = _busy()
    v[:50] = 0.0  # from the first row
    v[4990:5123] = 0.0  # across a boundary of 64- and 997-row blocks, inside 5000 rows
    v[9950:10070] = v[9949]
    v[-30:] = v[-31]  # to the last row
    whole = find_outages(v)
    assert whole == [
        Outage(0, 50, 0.0),
        Outage(4990, 5123, 0.0),
        Outage(9950, 10070, None),
        Outage(N - 30, N, None),
    ]
    monkeypatch.setattr(outage, "SCAN_VALUES", block * v.shape[1])
    assert find_outages(v) == whole


def test_the_rows_are_masked_in_a_memory_mapped_matrix(tmp_path):
    v = _busy()
    v[3000:3400] = v[2999]
    mapped = np.lib.format.open_memmap(tmp_path / "m.npy", mode="w+", shape=v.shape)
    mapped[:] = v
    found = find_outages(mapped)
    mask_outages(mapped, found)
    assert found == [Outage(3000, 3400, None)]
    assert np.isnan(mapped[3000:3400]).all()
    assert np.array_equal(mapped[:3000], v[:3000]) and np.array_equal(mapped[3400:], v[3400:])


def test_two_channels_or_some_channels_at_zero_are_no_outage():
    v = _busy(2)
    v[5000:6000] = 0.0
    assert find_outages(v) == []  # two channels: too few to tell a logger from sensors
    v = _busy()
    v[5000:6000, :2] = 0.0  # two sensors of six dead at once: sensor faults
    v[7000:8000, :5] = v[6999, :5]  # five frozen, one still moving
    assert find_outages(v) == []


def test_slow_quantized_channels_holding_together_are_no_outage():
    slow = _slow(4)
    held = np.all(slow[1:] == slow[:-1], axis=1)
    longest = np.diff(np.flatnonzero(np.r_[True, ~held, True])).max() - 1
    assert longest > 20 * outage.MIN_ROWS  # they do hold together, for long
    assert find_outages(slow) == []
    # one vibrating channel that sticks while the slow ones hold: a stuck sensor
    v = np.column_stack([_busy(1), _slow(2)])
    v[12000:, 0] = v[12000, 0]
    assert find_outages(v) == []


@pytest.mark.parametrize("noise_lsb", [0.3, 0.7, 2.0])
def test_quantized_accelerometers_repeating_counts_are_no_outage_but_a_zeros_stretch_is(
    noise_lsb,
):
    """Integer counts with noise of a fraction of a count repeat often, every channel at
    zero at once included; quiet half of the time: an outage is named only where it is
    longer than the channels ever hold by themselves."""
    rng = np.random.default_rng(3)
    x = rng.standard_normal((N, 6)) * noise_lsb
    x[N // 2 :] *= 8.0  # a lively half
    counts = np.round(x)
    assert find_outages(counts) == []
    counts[16000:16400] = 0.0
    assert find_outages(counts) == [Outage(16000, 16400, 0.0)]


def test_a_healthy_building_with_a_constant_temperature_channel_gives_no_note(tmp_path):
    from analyzer.pipeline import RunOptions, analyze
    from analyzer.simulate import simulate_building

    t, y, names = simulate_building(3, 60.0, 100.0, seed=1, sensors_per_floor=2)
    # at 0.1 K resolution: between two values in the training window, then constant
    noise = np.random.default_rng(2).standard_normal(t.shape)
    temp = np.where(t < 20.0, np.round(21.35 + 0.03 * noise, 1), 21.3)
    path = tmp_path / "healthy_temp.csv"
    header = "time," + ",".join([*names, "temp"])
    data = np.column_stack([t, y, temp])
    np.savetxt(path, data, delimiter=",", header=header, comments="", fmt="%.9g")
    a = analyze([path], RunOptions(jobs=1))
    assert "temp" in a.analyzed
    assert find_outages(np.asarray(a.values)) == []
    assert not any("logger outage" in n for n in a.notes), a.notes
    assert np.isfinite(np.asarray(a.values)).all()


@pytest.fixture(scope="module")
def building() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A healthy simulated 6-channel building, 120 s at 100 Hz: times, accelerations and
    the count of a quantized record (0.1 of each channel's healthy sd)."""
    from analyzer.simulate import simulate_building

    t, y, _ = simulate_building(3, 120.0, 100.0, seed=0, sensors_per_floor=2)
    return t, y, 0.1 * y[:2400].std(axis=0)


def _quiet_after_80_s(
    building: tuple[np.ndarray, np.ndarray, np.ndarray], quiet: float
) -> np.ndarray:
    """The quantized building with its amplitude times ``quiet`` for its last 40 s."""
    t, y, count = building
    return np.round(y * np.where(t < 80.0, 1.0, quiet)[:, None] / count) * count


@pytest.mark.parametrize("quiet", [0.02, 0.03, 0.04, 0.05])
@pytest.mark.parametrize("block", [None, 997])
def test_a_quiet_spell_of_quantized_channels_is_no_outage(monkeypatch, building, quiet, block):
    """The building quiet (amplitude x ``quiet``) for its last 40 s reads 0 counts on
    every channel at once for stretches of every length there, the longest of them its
    channels' longest runs: they were once taken out of the runs a stretch must beat,
    and 7.8 s of valid quiet data (at x0.03) became outages. Cut in blocks too."""
    values = _quiet_after_80_s(building, quiet)
    assert outage._held_stretches(values, len(values))[0].size > 0  # the channels do hold
    if block is not None:
        monkeypatch.setattr(outage, "SCAN_VALUES", block * values.shape[1])
    assert find_outages(values) == []


@pytest.mark.parametrize("block", [None, 997])
def test_a_quiet_spell_that_reads_exactly_zero_on_every_channel_is_an_outage(
    monkeypatch, building, block
):
    """Quieter still (x0.01), every channel reads exactly 0.0 from 80 s to the record's
    end: the values of a logger writing zeros, which must be found as one outage over
    that span (whole, or cut in blocks)."""
    values = _quiet_after_80_s(building, 0.01)
    assert not values[8000:].any() and values[7999].any()
    if block is not None:
        monkeypatch.setattr(outage, "SCAN_VALUES", block * values.shape[1])
    assert find_outages(values) == [Outage(8000, 12000, 0.0)]


@pytest.mark.parametrize("kind", ["zeros", "frozen"])
def test_an_outage_in_a_quantized_record_without_a_quiet_spell_is_found(building, kind):
    t, y, count = building
    values = np.round(y / count) * count
    values[4000:4200] = 0.0 if kind == "zeros" else values[3999]
    value = 0.0 if kind == "zeros" else None
    assert find_outages(values) == [Outage(4000, 4200, value)]


def test_the_runs_a_stretch_must_beat_leave_out_only_it_and_the_other_outages():
    """Per stretch and channel, the longest run of repeats with the rows of the stretch
    and of the stretches taken as outages taken out, against a plain count, for blocks
    that cut runs and stretches; one channel's run holds two stretches."""
    rng = np.random.default_rng(5)
    v = np.round(rng.standard_normal((600, 5)) * 0.4)
    v[100:400, 0] = v[99, 0]
    v[100:200, 1:] = v[99, 1:]
    v[201:380, 1:] = v[200, 1:]
    v[450:480] = 0.0
    v[-25:] = v[-26]
    starts, ends = outage._held_stretches(v, len(v))
    assert list(starts) == [100, 201, 451, 575] and list(ends) == [200, 380, 480, 600]
    every = np.arange(starts.size)
    for out in (every < 0, every % 2 == 0):
        want = np.empty((starts.size, v.shape[1]), dtype=np.int64)
        for i in every:
            eq = np.r_[np.zeros((1, v.shape[1]), bool), v[1:] == v[:-1]]
            for s, e in zip(starts[out | (every == i)], ends[out | (every == i)], strict=True):
                eq[s:e] = False
            for j in range(v.shape[1]):
                want[i, j] = (np.diff(np.flatnonzero(np.r_[True, ~eq[:, j], True])) - 1).max()
        for rows in (7, 64, 201, len(v)):
            _, longest = outage._repeats(v, starts, ends, rows, out)
            assert np.array_equal(longest, want), (rows, out)


def test_a_zero_that_rounds_from_below_is_noted_as_0_0():
    note = outage_note([Outage(10, 30, -0.0)], list("abc"), 100.0)
    assert "read exactly 0.0 from" in note and "-0" not in note
