"""Fault regeneration and corrected signals (Wang & Song 2014, Section 6.3)."""

import csv

import numpy as np
import pytest

from analyzer.detectors.base import Dataset, Event, RunContext
from analyzer.detectors.detection_filter import DetectionFilter
from analyzer.detectors.equivalent_model import EquivalentModel
from analyzer.regenerate import (
    corrected_values,
    fault_signal,
    healthy_stretch,
    result_signals,
    write_corrected_csv,
)
from analyzer.simulate import inject_fault, simulate_building
from analyzer.types import FaultType

RATE = 200.0


def _event(kind, onset, end=None, **mag):
    return Event("s1", onset, end, FaultType(kind), dict(mag), 0.9, "test")


@pytest.fixture(scope="module")
def building():
    _, Y, names = simulate_building(n_floors=4, duration_s=40.0, rate_hz=RATE, seed=11)
    return Y, names


@pytest.mark.parametrize("detector", [DetectionFilter, EquivalentModel])
def test_offset_fault_is_restored_from_a_detector_event(building, detector):
    """The finding of a detector run on an offset-faulted channel, fed back: over the
    fault period the corrected channel is within 20 % of the offset of the healthy one."""
    Y, names = building
    j = 2
    offset = float(np.std(Y[:, j]))
    Yf = Y.copy()
    Yf[:, j] = inject_fault(Y[:, j], RATE, "additive", 18.0, offset)
    det = detector()
    ctx = RunContext()
    ds = Dataset(Yf, tuple(names), RATE, (0, int(15 * RATE)))
    res = det.run(det.fit(ds, ctx), ds, ctx)
    assert len(res.events) == 1
    out, records = corrected_values(Yf, names, RATE, res.events, *result_signals([res]))
    k0 = int(18.0 * RATE)
    err = out[k0:, j] - Y[k0:, j]
    assert np.sqrt(np.mean(err**2)) < 0.2 * offset
    assert np.array_equal(out[:, [0, 1, 3]], Yf[:, [0, 1, 3]])  # other channels untouched
    (rec,) = records
    assert rec["channel"] == names[j] and rec["method"] == "offset"
    assert rec["mean_fault"] == pytest.approx(offset, rel=0.2)


def test_each_fault_model():
    rng = np.random.default_rng(0)
    y = rng.standard_normal(1000)
    ref = y.copy()
    t = np.arange(1000) / 100.0
    # additive
    yf = y.copy()
    yf[200:] += 2.0
    s, e, fs, how = fault_signal(_event("additive", 2.0, offset=2.0), yf, 100.0)
    assert (s, e, how) == (200, 1000, "offset") and np.allclose(yf[s:e] - fs, y[200:])
    # drift from its onset
    yf = y + np.where(t >= 3.0, 0.5 * (t - 3.0), 0.0)
    s, e, fs, how = fault_signal(_event("drift", 3.0, rate_per_s=0.5), yf, 100.0)
    assert how == "drift" and np.allclose(yf[s:e] - fs, y[300:])
    # multiplicative: divide by the gain over an intermittent period
    yf = y.copy()
    yf[100:400] *= 2.5
    s, e, fs, how = fault_signal(_event("multiplicative", 1.0, 4.0, gain=2.5), yf, 100.0)
    assert (s, e, how) == (100, 400, "gain") and np.allclose(yf[s:e] - fs, y[100:400])
    # dead sensor: the fault-free estimate takes over
    yf = y.copy()
    yf[500:] = 0.0
    s, e, fs, how = fault_signal(_event("multiplicative", 5.0, gain=0.0), yf, 100.0, reference=ref)
    assert how == "reference" and np.allclose(yf[s:e] - fs, ref[500:])
    # other: the residual itself is the regenerated fault (Section 6.3)
    yf = y.copy()
    yf[600:] = 7.0
    s, e, fs, how = fault_signal(_event("other", 6.0), yf, 100.0, residual=yf - ref)
    assert how == "residual" and np.allclose(yf[s:e] - fs, ref[600:])
    # nothing known
    assert fault_signal(_event("other", 6.0), yf, 100.0)[2:] == (None, "skipped")


def test_gaps_overlaps_and_unknown_channels():
    y = np.zeros((1000, 2))
    y[:, 1] = 1.0
    y[300:, 1] += 3.0
    y[500:510, 1] = np.nan
    evs = [
        Event("b", 3.0, None, FaultType.ADDITIVE, {"offset": 3.0}, 0.9, "d1"),
        # a second, less confident event of the same fault: not corrected twice
        Event("b", 3.0, None, FaultType.ADDITIVE, {"offset": 3.0}, 0.5, "d2"),
        Event("zz", 1.0, None, FaultType.ADDITIVE, {"offset": 1.0}, 0.9, "d1"),
    ]
    out, recs = corrected_values(y, ["a", "b"], 100.0, evs)
    assert np.allclose(out[:500, 1], 1.0) and np.allclose(out[510:, 1], 1.0)
    assert np.isnan(out[500:510, 1]).all()
    by = {(r["channel"], r["detector"]): r for r in recs}
    assert by[("b", "d1")]["samples"] == 690 and "gap" in by[("b", "d1")]["note"]
    assert by[("b", "d2")]["samples"] == 0
    assert by[("zz", "d1")]["method"] == "skipped"
    with pytest.raises(ValueError, match=r"expected a \(N, 3\) array"):
        corrected_values(y, ["a", "b", "c"], 100.0, [])


def test_a_reading_is_replaced_only_by_a_better_estimate():
    """With the healthy window given, an ``other`` fault is corrected by the estimate only
    where the residual's mean square over it is more than twice the healthy window's (the
    estimate's own error): a fault as small as that error is left as measured, with a
    note (a gain of 1.25 read as ``other`` doubled the error: 0.43 sd of the estimate
    for 0.24 sd of the fault). A dead sensor is always replaced: its reading says nothing."""
    rng = np.random.default_rng(3)
    truth = rng.standard_normal(4000)
    ref = truth + 0.5 * rng.standard_normal(4000)  # an estimate with an error of 0.5
    y = truth.copy()
    y[2000:] *= 1.2  # a small gain: 0.2 of the signal, under the estimate's error
    small = [Event("s", 20.0, None, FaultType.OTHER, {}, 0.9, "d")]
    out, (rec,) = corrected_values(
        y[:, None], ["s"], 100.0, small, {"s": y - ref}, {"s": ref}, healthy=(0, 1000)
    )
    assert rec["method"] == "skipped" and rec["note"].startswith("left as measured")
    assert np.array_equal(out[:, 0], y)
    y[2000:] = truth[2000:] + 3.0 * rng.standard_normal(2000)  # a noise burst of 3
    out, (rec,) = corrected_values(
        y[:, None], ["s"], 100.0, small, {"s": y - ref}, {"s": ref}, healthy=(0, 1000)
    )
    assert rec["method"] == "residual" and np.allclose(out[2000:, 0], ref[2000:])
    y[2000:] = 0.1 * truth[2000:]  # nearly dead: replaced whatever the estimate's error
    dead = [Event("s", 20.0, None, FaultType.MULTIPLICATIVE, {"gain": 0.05}, 0.9, "d")]
    out, (rec,) = corrected_values(
        y[:, None], ["s"], 100.0, dead, {"s": y - ref}, {"s": ref}, healthy=(0, 1000)
    )
    assert rec["method"] == "reference" and np.allclose(out[2000:, 0], ref[2000:])
    # without a healthy window (--model), as before
    y[2000:] = truth[2000:] * 1.2
    out, (rec,) = corrected_values(y[:, None], ["s"], 100.0, small, {"s": y - ref}, {"s": ref})
    assert rec["method"] == "residual"


def test_write_corrected_csv(tmp_path):
    t = np.arange(4) / 10.0
    data = np.array([[1.0, 2.5], [np.nan, 3.0], [0.1, -1e-9], [4.0, 5.0]])
    p = write_corrected_csv(tmp_path / "out" / "corrected.csv", t, ["s0", "/imu.x"], data)
    with p.open(newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["time", "s0", "/imu.x"]
    assert rows[2] == ["0.1", "", "3"]
    back = np.array([[float(v) if v else np.nan for v in r] for r in rows[1:]])
    assert np.allclose(back[:, 0], t)
    assert np.allclose(back[:, 1:], data, equal_nan=True)
    assert not list(tmp_path.glob("out/.*part"))
    with pytest.raises(ValueError, match=r"expected a \(4, 3\) array"):
        write_corrected_csv(tmp_path / "x.csv", t, ["a", "b", "c"], data)


def _corrected_whole(values, channels, rate, events, residuals, references):
    """The correction over whole arrays (the reference for the piecewise one)."""
    out = np.array(values, dtype=np.float64, copy=True)
    done = np.zeros(out.shape, dtype=bool)
    index = {c: j for j, c in enumerate(channels)}
    stats = []
    for ev in sorted(events, key=lambda e: -e.confidence):
        j = index[ev.channel]
        res = residuals.get(ev.channel)
        ref = references.get(ev.channel)
        start, stop, fs, _ = fault_signal(ev, values[:, j], rate, res, ref)
        col = out[start:stop, j]
        ok = np.isfinite(fs) & np.isfinite(col) & ~done[start:stop, j]
        col[ok] -= fs[ok]
        done[start:stop, j] |= ok
        stats.append((int(ok.sum()), np.mean(fs[ok]), np.sqrt(np.mean(fs[ok] ** 2))))
    return out, stats


def _long_record(n=20_000, seed=5):
    rng = np.random.default_rng(seed)
    y = rng.normal(size=(n, 3)) + np.array([1.0, 2.0, 3.0])
    y[4000:4300, 0] = np.nan
    y[9000:9050, 2] = np.nan
    ref = {"a": y[:, 0] - 0.1 * rng.normal(size=n), "c": y[:, 2] + 0.2}
    res = {"a": (y[:, 0] - ref["a"]).astype(np.float32), "b": 0.5 * y[:, 1]}
    res["a"][1000:12000] += 0.7  # the offset's residual holds it to its end (120 s)
    res["a"][6000:6100] = np.nan
    evs = [
        Event("a", 10.0, 120.0, FaultType.ADDITIVE, {"offset": 0.7}, 0.9, "d1"),
        # overlaps the first, less confident: corrected by its residual where not done
        Event("a", 50.0, None, FaultType.OTHER, {}, 0.6, "d2"),
        Event("b", 3.0, None, FaultType.DRIFT, {"rate_per_s": 0.01}, 0.8, "d1"),
        Event("c", 20.0, 150.0, FaultType.MULTIPLICATIVE, {"gain": 1.3}, 0.7, "d1"),
        Event("c", 160.0, None, FaultType.MULTIPLICATIVE, {}, 0.5, "d1"),
    ]
    return y, ref, res, evs


@pytest.mark.parametrize("piece", [1000, 4096, 1 << 16])
def test_corrected_in_pieces_equals_the_whole_arrays(tmp_path, monkeypatch, piece):
    """Corrected a piece of rows at a time, into memory-mapped buffers: the same values
    and records as the correction over whole arrays, whatever the piece."""
    import analyzer.regenerate as regen
    from analyzer.paging import buffer

    monkeypatch.setattr(regen, "RELEASE_ROWS", piece)
    y, ref, res, evs = _long_record()
    rate = 100.0
    want, stats = _corrected_whole(y, ["a", "b", "c"], rate, evs, res, ref)
    got, recs = corrected_values(
        y, ["a", "b", "c"], rate, evs, res, ref, lambda n, s, d: buffer(tmp_path, n, s, d)
    )
    assert np.array_equal(np.asarray(got), want, equal_nan=True)
    assert [r["method"] for r in recs] == ["offset", "drift", "gain", "residual", "reference"]
    for r, (count, mean, rms) in zip(recs, stats, strict=True):
        assert r["samples"] == count
        assert r["mean_fault"] == pytest.approx(mean, rel=1e-12, abs=1e-15)
        assert r["rms_fault"] == pytest.approx(rms, rel=1e-12)
    # the overlapping event (from 50 s) only corrects after the first one's end (120 s)
    assert recs[3]["samples"] == 20_000 - 12_000


def test_corrected_csv_in_pieces_is_byte_equal(tmp_path, monkeypatch):
    """The CSV written a piece at a time from a time function is byte for byte the one
    written from the whole time column in one piece."""
    import analyzer.regenerate as regen

    y, _, _, _ = _long_record(5000)
    t = np.arange(5000) / 100.0
    one = write_corrected_csv(tmp_path / "one.csv", t, ["a", "b", "c"], y)
    monkeypatch.setattr(regen, "RELEASE_ROWS", 777)
    pieces = write_corrected_csv(
        tmp_path / "pieces.csv", lambda a, b: np.arange(a, b) / 100.0, ["a", "b", "c"], y
    )
    assert one.read_bytes() == pieces.read_bytes()
    assert one.read_text().count("\n") == 5001


def test_corrected_memory_is_set_by_the_piece(tmp_path):
    """A long mapped record is corrected and written with memory set by the piece: the
    whole-array form allocated a copy of the matrix and a mask of it (36 MB here)."""
    import tracemalloc

    from analyzer.paging import buffer, mapped_file

    n = 1_000_000
    values = mapped_file(tmp_path / "values.npy", (n, 4), np.float64)
    for a in range(0, n, 1 << 16):
        values[a : a + (1 << 16)] = np.arange(a, min(n, a + (1 << 16)))[:, None] * 1e-3
    evs = [
        Event("a", 10.0, None, FaultType.ADDITIVE, {"offset": 0.7}, 0.9, "d1"),
        Event("d", 100.0, None, FaultType.MULTIPLICATIVE, {"gain": 2.0}, 0.8, "d1"),
    ]
    tracemalloc.start()
    try:
        out, recs = corrected_values(
            values, list("abcd"), 100.0, evs, buffer=lambda k, s, d: buffer(tmp_path, k, s, d)
        )
        write_corrected_csv(
            tmp_path / "c.csv", lambda a, b: np.arange(a, b) / 100.0, list("abcd"), out
        )
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 12e6, peak
    assert recs[0]["samples"] == n - 1000 and recs[1]["samples"] == n - 10_000
    assert out[5000, 0] == pytest.approx(5.0 - 0.7) and out[50_000, 3] == pytest.approx(25.0)


def test_an_offset_correction_ends_where_its_residual_does():
    """An offset finding whose end came late (the detectors' end logic while another
    sensor's gain was under way) is corrected only up to where its residual shows the
    offset gone; the record says where and why. A residual that holds the offset to the
    finding's end, or a tail too noisy to tell, keeps the finding's end."""
    rng = np.random.default_rng(5)
    n = 30000
    y = rng.standard_normal((n, 1))
    truth = y.copy()
    y[12000:22000, 0] += 3.0
    res = 0.2 * rng.standard_normal(n)
    res[12000:22000] += 3.0
    late = [Event("s", 120.0, 227.92, FaultType.ADDITIVE, {"offset": 3.0}, 0.9, "d")]
    out, (rec,) = corrected_values(y, ["s"], 100.0, late, {"s": res})
    assert rec["method"] == "offset" and rec["samples"] == 10000
    assert rec["end_s"] == pytest.approx(220.0)
    assert "227.9200" in rec["note"] and "no offset" in rec["note"]
    assert np.allclose(out[:, 0], truth[:, 0])
    # the residual holds the offset to the finding's end: nothing cut
    held = [Event("s", 120.0, 220.0, FaultType.ADDITIVE, {"offset": 3.0}, 0.9, "d")]
    out, (rec,) = corrected_values(y, ["s"], 100.0, held, {"s": res})
    assert rec["samples"] == 10000 and rec["end_s"] == 220.0 and rec["note"] == ""
    # a residual as noisy as the offset after its end: the finding's end stays
    noisy = res.copy()
    noisy[22000:] = 2.0 * rng.standard_normal(n - 22000)
    out, (rec,) = corrected_values(y, ["s"], 100.0, late, {"s": noisy})
    assert rec["samples"] == 10792 and rec["end_s"] == 227.92
    # a finding that lasts to the record's end is not cut
    lasting = [Event("s", 120.0, None, FaultType.ADDITIVE, {"offset": 3.0}, 0.9, "d")]
    out, (rec,) = corrected_values(y, ["s"], 100.0, lasting, {"s": res})
    assert rec["samples"] == n - 12000 and rec["end_s"] is None


def test_an_error_function_offset_is_trimmed_on_its_residuals_reading():
    """The error functions' residual reads an offset ``D`` as ``D * dc_gain`` (the taps'
    sum: 0.0146 on an accelerometer of the paper's chain), and their event's offset is in
    the sensor's units (``evidence["dc_gain"]``): the residual, which holds the fault to
    its end, is weighed against what it reads, not against the sensor's offset (which
    "no offset" fit better: the whole correction was cut, ``samples`` 0). Merged into a
    finding, the leading event's evidence says the same."""
    from analyzer.diagnosis.merge import merge_events

    rng = np.random.default_rng(0)
    n, rate, dc, off = 12000, 100.0, 0.0146, 0.8
    y = rng.standard_normal((n, 1))
    y[3000:9000, 0] += off
    res = 0.001 * rng.standard_normal(n)
    res[3000:9000] += dc * off
    ev = Event(
        "s",
        30.0,
        90.0,
        FaultType.ADDITIVE,
        {"offset": off},
        0.9,
        "error_function",
        evidence={"residual_magnitude": {"offset": dc * off}, "dc_gain": dc},
    )
    for given in ([ev], merge_events([ev])):
        out, (rec,) = corrected_values(y, ["s"], rate, given, {("error_function", "s"): res})
        assert rec["samples"] == 6000 and rec["end_s"] == 90.0 and rec["note"] == ""
        assert np.allclose(out[3000:9000, 0], y[3000:9000, 0] - off)
    # its residual gone 2 s before the finding's end: the correction ends there
    res[8800:9000] -= dc * off
    out, (rec,) = corrected_values(y, ["s"], rate, [ev], {("error_function", "s"): res})
    assert rec["end_s"] == pytest.approx(88.0) and rec["samples"] == 5800


@pytest.mark.parametrize("detector", ["ar_kalman_bank", "detection_filter", "equivalent_model"])
def test_a_detector_estimates_again_as_it_ran(building, detector):
    """A detector's ``estimate`` over a span after its warm-up gives the run's
    ``reference`` there (to the signals' single precision), from the record's start too;
    the bank's estimate of a sensor does not read that sensor."""
    from analyzer.detectors import detector_class

    Y, names = building
    det = detector_class(detector)()
    ctx = RunContext()
    ds = Dataset(Y, tuple(names), RATE, (0, int(15 * RATE)))
    model = det.fit(ds, ctx)
    ref = det.run(model, ds, ctx).reference
    a, b = 3000, 5000
    for j, c in enumerate(names):
        warm = det.estimate_warmup(model, j)
        assert warm is not None and 0 < warm < a
        est = det.estimate(model, Y[a - warm : b], warm, j)
        tol = 1e-5 * np.std(Y[:, j])
        assert np.allclose(est, ref[c][a:b], rtol=1e-4, atol=tol), c
        assert np.allclose(det.estimate(model, Y[:b], 0, j), ref[c][:b], rtol=1e-4, atol=tol)
    if detector == "ar_kalman_bank":
        warm = det.estimate_warmup(model, 2)
        moved = Y[a - warm : b].copy()
        moved[:, 2] += 5.0
        tol = 1e-5 * np.std(Y[:, 2])
        assert np.allclose(det.estimate(model, moved, warm, 2), ref[names[2]][a:b], atol=tol)
        assert not np.allclose(det.estimate(model, moved, warm, 1), ref[names[1]][a:b], rtol=1e-2)


def _sweep_record(tmp_path, seed, faults):
    """The 6-floor building of ``benchmarks/sweep_corrected.py`` (300 s at 100 Hz) with
    ``faults`` ``(channel, kind, onset, end, size in sd or a gain)``, analyzed with
    ``--corrected``: the truth, the faulty readings and the analysis."""
    from analyzer.pipeline import RunOptions, analyze
    from analyzer.writers import write_archive

    t, y0, names = simulate_building(6, 300.0, 100.0, seed=seed)
    y = y0.copy()
    for j, kind, onset, end, size in faults:
        scaled = size if kind == "multiplicative" else size * float(y0[:, j].std())
        y[:, j] = inject_fault(y[:, j], 100.0, kind, onset, scaled, end)
    path = tmp_path / "record.csv"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {c: y[:, i] for i, c in enumerate(names)})
    (tmp_path / "work").mkdir()
    analysis = analyze([str(path)], RunOptions(corrected=True), tmp_path / "work")
    return y0, y, names, analysis


def test_a_dead_sensor_is_regenerated_without_its_neighbours_fault(tmp_path):
    """A dead sensor (120-220 s) beside a neighbour's offset of 2 sd (150-250 s): the
    regenerated signal comes from the bank's estimate computed again with the offset
    taken out, so it is as good while the neighbour is faulty as before (the run's own
    estimate carried the offset: 5.8 times the error; ``sweep_corrected.py``
    ``two-dead-neighbour``, seed 3). The neighbour and the healthy channels keep their
    own corrections."""
    y0, y, names, analysis = _sweep_record(
        tmp_path, 3, [(3, "multiplicative", 120.0, 220.0, 0.0), (4, "additive", 150.0, 250.0, 2.0)]
    )
    out = np.asarray(analysis.corrected)
    err = out[:, 3] - y0[:, 3]
    rms = lambda a, b: float(np.sqrt(np.mean(err[int(a * 100) : int(b * 100)] ** 2)))  # noqa: E731
    before, beside = rms(121.0, 150.0), rms(151.0, 220.0)
    assert beside < 1.5 * before, (before, beside)
    (rec,) = [c for c in analysis.corrections if c["channel"] == "s3"]
    assert rec["method"] == "reference" and "estimated again" in rec["note"]
    others = [j for j in range(6) if j not in (3, 4)]
    assert np.array_equal(out[:, others], y[:, others])


def test_an_offset_ended_late_is_not_subtracted_from_healthy_readings(tmp_path):
    """An offset of 2 sd (120-220 s) while another sensor's gain of 1.5 runs 150-250 s:
    every detector ended the offset near 228 s, yet its residual is back at 0 from
    220 s; the correction stops there (``sweep_corrected.py`` ``two-offset-gain``,
    seed 7: 0.40 sd of error over the sensor's healthy readings before)."""
    y0, y, names, analysis = _sweep_record(
        tmp_path,
        7,
        [(1, "additive", 120.0, 220.0, 2.0), (4, "multiplicative", 150.0, 250.0, 1.5)],
    )
    out = np.asarray(analysis.corrected)
    sd = float(y0[:, 1].std())
    after = out[22000:, 1] - y0[22000:, 1]
    assert float(np.sqrt(np.mean(after**2))) < 0.01 * sd
    (rec,) = [c for c in analysis.corrections if c["channel"] == "s1"]
    assert rec["method"] == "offset" and abs(rec["end_s"] - 220.0) < 0.2
    inside = out[12000:22000, 1] - y0[12000:22000, 1]
    assert float(np.sqrt(np.mean(inside**2))) < 0.1 * sd


def test_fitted_estimates_find_each_channels_group():
    """The estimates of :func:`~analyzer.detector_runs.fitted_estimates` come from the
    fitted detector of the channel's group, on that group's columns of the rows; a
    detector without ``estimate``, or that has none for the channel, gives None."""
    from analyzer.detector_runs import fitted_estimates

    class Columns:
        """An "estimate" that is the column itself, times ``scale``."""

        def __init__(self, scale):
            self.scale = scale

        def estimate_warmup(self, model, j):
            return None if j == model else 7

        def estimate(self, model, rows, start, j):
            return self.scale * rows[start:, j]

    collected = {
        "-g0": {"d": (Columns(1.0), None), "plain": (object(), None)},
        "-g1": {"d": (Columns(10.0), 0)},  # (no estimate of its column 0, "a")
        "": {"error_function": (Columns(100.0), None)},
    }
    channels = ["a", "b", "c", "e"]
    est = fitted_estimates(collected, [("b", "c"), ("a", "e")], channels)
    rows = np.arange(12.0).reshape(3, 4)
    warm, f = est("d", "c")
    assert warm == 7 and np.array_equal(f(rows, 1), rows[1:, 2])
    warm, f = est("d", "e")
    assert np.array_equal(f(rows, 0), 10.0 * rows[:, 3])
    assert est("d", "a") is None and est("plain", "b") is None and est("nope", "b") is None
    warm, f = est("error_function", "a")  # (one run on every channel)
    assert np.array_equal(f(rows, 2), 100.0 * rows[2:, 0])


def test_an_other_fault_of_the_detection_filter_keeps_its_residual_beside_a_neighbour():
    """The detection filter's residual is a fault estimate of its own, not the reading
    less its estimate: its ``other`` fault is corrected by the residual whether or not
    another channel's fault is near (the review: a neighbour's offset of size 0 nearby
    switched the correction to the estimate computed again, up to 0.17 sd apart)."""
    from analyzer.detector_runs import fitted_estimates
    from analyzer.detectors import detector_class
    from analyzer.detectors.base import Dataset, Event, RunContext
    from analyzer.regenerate import result_signals
    from analyzer.simulate import simulate_building
    from analyzer.types import FaultType

    t, Y, names = simulate_building(4, 120.0, 100.0, seed=1)
    det = detector_class("detection_filter")()
    ctx = RunContext()
    ds = Dataset(Y, tuple(names), 100.0, (0, 2000))
    model = det.fit(ds, ctx)
    res, ref = result_signals([det.run(model, ds, ctx)])
    est = fitted_estimates({"": {"detection_filter": (det, model)}}, [tuple(names)], names)
    other = Event("s1", 60.0, 80.0, FaultType.OTHER, {}, 0.9, "detection_filter")
    outs = []
    for onset, end in ((100.0, 110.0), (70.0, 90.0)):  # the neighbour far, then near
        near = Event("s2", onset, end, FaultType.ADDITIVE, {"offset": 0.0}, 0.5, "detection_filter")
        out, records = corrected_values(Y, names, 100.0, [other, near], res, ref, None, None, est)
        assert records[0]["method"] == "residual" and "again" not in records[0]["note"]
        outs.append(out[6000:8000, 1])
    assert np.array_equal(outs[0], outs[1])


def _dead_record(rate=100.0, seconds=30.0, seed=5):
    """Three sensors of one smooth signal (sd about 1) with noise of 0.05, and an
    estimate of each with an error of that size."""
    rng = np.random.default_rng(seed)
    n = int(seconds * rate)
    t = np.arange(n) / rate
    s = np.sin(2 * np.pi * 0.7 * t) + 0.6 * np.sin(2 * np.pi * 1.9 * t + 1.0)
    s = s / s.std()
    Y = s[:, None] + 0.05 * rng.standard_normal((n, 3))
    return s, Y, ["c0", "c1", "c2"], rng


def test_a_dead_reading_is_regenerated_only_until_the_sensor_is_alive_again():
    """A finding of a dead sensor (10-20 s) that runs to the record's end: the readings
    after 20 s, alive again, are kept, and the correction says where it ended; a
    sensor dead to the end is regenerated to the end (``sweep_corrected.py``
    ``two-dead-neighbour`` seed 6: 0.27 sd of error over healthy readings before)."""
    rate = 100.0
    s, Y, names, rng = _dead_record(rate)
    Yf = Y.copy()
    Yf[1000:2000, 0] = 0.0  # dead from 10 s, back at 20 s
    Yf[1500:, 1] = 0.0  # dead from 15 s to the end
    refs = {c: s + 0.05 * rng.standard_normal(s.size) for c in names}
    events = [
        Event("c0", 10.0, None, FaultType.MULTIPLICATIVE, {"gain": 0.0}, 0.9, "test"),
        Event("c1", 15.0, None, FaultType.MULTIPLICATIVE, {"gain": 0.0}, 0.8, "test"),
    ]
    out, records = corrected_values(Yf, names, rate, events, None, refs, healthy=(0, 500))
    assert np.array_equal(out[2050:, 0], Yf[2050:, 0])  # alive again: as measured
    assert np.allclose(out[1000:1990, 0], refs["c0"][1000:1990])  # dead: the estimate
    assert np.allclose(out[1500:, 1], refs["c1"][1500:])
    first, second = records
    assert first["end_s"] == pytest.approx(20.0, abs=0.2)
    assert "alive again" in first["note"] and "the record's end" in first["note"]
    assert first["samples"] == pytest.approx(1000, abs=20)
    assert second["end_s"] is None and "alive" not in second["note"]


def test_two_dead_sensors_are_each_regenerated_from_the_others_estimate():
    """Two sensors dead at once (c0 10-20 s, c1 15-25 s), each estimated by the mean of
    the other two: where both are dead, the run's estimate of each carries the other's
    dead reading (half the signal missing); the dead input is replaced by its own
    estimate, refined in turns, so the regenerated signal there is as good as where one
    alone is dead."""
    rate = 100.0
    s, Y, names, _ = _dead_record(rate)
    Yf = Y.copy()
    Yf[1000:2000, 0] = 0.0
    Yf[1500:2500, 1] = 0.0
    n = Y.shape[0]

    def mean_of_others(rows, j):
        rows = np.asarray(rows)
        return np.mean(np.delete(rows, j, axis=1), axis=1)

    refs = {c: mean_of_others(Yf, j) for j, c in enumerate(names)}

    def estimates(detector, channel):
        j = names.index(channel)
        return 0, lambda rows, start: mean_of_others(rows, j)[start:]

    events = [
        Event("c0", 10.0, 20.0, FaultType.MULTIPLICATIVE, {"gain": 0.0}, 0.9, "test"),
        Event("c1", 15.0, 25.0, FaultType.MULTIPLICATIVE, {"gain": 0.0}, 0.8, "test"),
    ]
    out, records = corrected_values(
        Yf, names, rate, events, None, refs, healthy=(0, 500), estimates=estimates
    )
    rms = lambda j, a, b: float(np.sqrt(np.mean((out[a:b, j] - Y[a:b, j]) ** 2)))  # noqa: E731
    for j, (alone, both) in enumerate([((1000, 1500), (1500, 2000)), ((2000, 2500), (1500, 2000))]):
        assert rms(j, *both) < 1.5 * rms(j, *alone) < 0.1, (j, rms(j, *both), rms(j, *alone))
    assert np.array_equal(out[:, 2], Yf[:, 2])
    assert np.array_equal(out[:1000], Yf[:1000]) and np.array_equal(out[2500:n], Yf[2500:])
    assert all(r["method"] == "reference" and "estimated again" in r["note"] for r in records)


def _mean_of_others(rows, j):
    return np.mean(np.delete(np.asarray(rows), j, axis=1), axis=1)


def _dead(channel, onset, end, confidence):
    return Event(channel, onset, end, FaultType.MULTIPLICATIVE, {"gain": 0.0}, confidence, "test")


def test_a_second_dead_period_of_a_channel_still_feeds_its_partner():
    """c0 dead at 10-20 s and again at 40-50 s, c1 dead at 40-50 s: c0's regenerated
    readings at 40-50 s are c1's estimate's input there, whatever c0's first period
    (its end made every later substitute of the channel its dead reading again: c1 was
    regenerated with 0.50 of error, seven times its estimator's)."""
    rate = 100.0
    s, Y, names, _ = _dead_record(rate, seconds=60.0)
    Yf = Y.copy()
    Yf[1000:2000, 0] = 0.0
    Yf[4000:5000, :2] = 0.0
    refs = {c: _mean_of_others(Yf, j) for j, c in enumerate(names)}

    def estimates(detector, channel):
        j = names.index(channel)
        return 0, lambda rows, start: _mean_of_others(rows, j)[start:]

    rms = []
    for first in ([_dead("c0", 10.0, 20.0, 0.9)], []):
        events = [*first, _dead("c0", 40.0, 50.0, 0.85), _dead("c1", 40.0, 50.0, 0.8)]
        out, _ = corrected_values(
            Yf, names, rate, events, None, refs, healthy=(0, 500), estimates=estimates
        )
        rms.append(float(np.sqrt(np.mean((out[4000:5000, 1] - Y[4000:5000, 1]) ** 2))))
    assert rms[0] == pytest.approx(rms[1], rel=1e-9) and rms[1] < 0.1, rms


def test_a_dead_sensor_without_excitation_is_not_read_as_alive():
    """c0 dead from 15 s to the end, the signal gone from 30 s (the structure at rest):
    there the residual of the dead reading is the estimate's own error, as a live
    reading's would be, and the readings cannot tell; the regeneration runs to the
    finding's end (it ended at 30 s "where the readings are alive again" and left
    3 000 zeros)."""
    rate = 100.0
    s, _, names, rng = _dead_record(rate, seconds=60.0)
    s = np.where(np.arange(s.size) < 3000, s, 0.0)
    Y = s[:, None] + 0.05 * rng.standard_normal((s.size, 3))
    Y[1500:, 0] = 0.0
    refs = {c: s + 0.05 * rng.standard_normal(s.size) for c in names}
    out, records = corrected_values(
        Y, names, rate, [_dead("c0", 15.0, None, 0.9)], None, refs, healthy=(0, 500)
    )
    assert records[0]["end_s"] is None and "alive" not in records[0]["note"]
    assert np.array_equal(out[1500:, 0], refs["c0"][1500:])


def test_estimates_that_feed_each_other_a_growing_error_are_not_iterated():
    """Two dead sensors whose estimators weigh each other by 1.5 (a linear extrapolation
    from the neighbours): each round multiplies the error one passes to the other by
    2.25, and the rounds left 26 sd of error where the estimates from the dead readings
    left 1.5. Rounds whose changes do not shrink are dropped."""
    rate, n = 100.0, 3000
    rng = np.random.default_rng(5)
    s = np.sin(2 * np.pi * 0.7 * np.arange(n) / rate)
    Y = s[:, None] + 0.05 * rng.standard_normal((n, 3))
    Yf = Y.copy()
    Yf[1000:2000, :2] = 0.0
    names = ["c0", "c1", "c2"]
    weights = {0: (1, 1.5, 2, -0.5), 1: (0, 1.5, 2, -0.5), 2: (0, 0.5, 1, 0.5)}

    def estimate(rows, j):
        a, wa, b, wb = weights[j]
        return wa * np.asarray(rows)[:, a] + wb * np.asarray(rows)[:, b]

    refs = {c: estimate(Yf, j) for j, c in enumerate(names)}

    def estimates(detector, channel):
        j = names.index(channel)
        return 0, lambda rows, start: estimate(rows, j)[start:]

    events = [_dead("c0", 10.0, 20.0, 0.9), _dead("c1", 10.0, 20.0, 0.8)]
    out, _ = corrected_values(
        Yf, names, rate, events, None, refs, healthy=(0, 500), estimates=estimates
    )
    for j in (0, 1):
        error = np.sqrt(np.mean((out[1000:2000, j] - Y[1000:2000, j]) ** 2))
        assert error < 1.6, (j, error)


def _peak_of_two_dead(tmp_path, n):
    """The peak of traced memory of correcting two sensors dead from a tenth of ``n``
    rows to the end, with a memory-mapped ``buffer``."""
    import tracemalloc

    rate = 100.0
    rng = np.random.default_rng(0)
    s = np.sin(2 * np.pi * 0.7 * np.arange(n) / rate)
    Y = s[:, None] + 0.05 * rng.standard_normal((n, 3))
    Y[n // 10 :, :2] = 0.0
    names = ["c0", "c1", "c2"]
    refs = {c: s for c in names}

    def estimates(detector, channel):
        j = names.index(channel)
        return 0, lambda rows, start: _mean_of_others(rows, j)[start:]

    def buffer(name, shape, dtype):
        path = tmp_path / f"{n}-{name}.npy"
        return np.lib.format.open_memmap(path, mode="w+", dtype=dtype, shape=shape)

    events = [_dead("c0", n / 10 / rate, None, 0.9), _dead("c1", n / 10 / rate, None, 0.8)]
    tracemalloc.start()
    try:
        corrected_values(
            Y, names, rate, events, None, refs, buffer, healthy=(0, 5000), estimates=estimates
        )
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_two_dead_sensors_are_regenerated_in_memory_set_by_the_piece(tmp_path):
    """With a memory-mapped ``buffer``, the regenerated inputs of two sensors dead to the
    end of a long record are mapped too: the memory does not grow with the record (they
    were arrays in memory, 8 bytes a row each: 11 MB more for 700 000 more rows)."""
    small, large = (_peak_of_two_dead(tmp_path, n) for n in (500_000, 1_200_000))
    assert large < 1.2 * small, (small, large)


@pytest.mark.parametrize("seed, dead, drifting", [(7, 1, 4), (3, 3, 0)])
def test_a_dead_sensor_beside_a_drift_found_late_ends_where_it_came_back(
    tmp_path, seed, dead, drifting
):
    """A dead sensor (120-220 s) while the sensor 3 floors up drifts by 0.02 sd/s from
    150 s, a drift the detectors found only at 229 s (seed 7) or not at all (seed 3):
    the estimate that regenerates the dead sensor carries the drift, so the reading
    less the estimate stayed above the healthy spread after the sensor came back, and
    the regeneration ran on to 265.31 s or to the record's end (0.133 and 0.124 sd of
    error over its healthy readings; ``sweep_corrected.py`` ``two-dead-drift``). The
    readings' own spread says where they are alive."""
    y0, y, names, analysis = _sweep_record(
        tmp_path,
        seed,
        [(dead, "multiplicative", 120.0, 220.0, 0.0), (drifting, "drift", 150.0, None, 0.02)],
    )
    out = np.asarray(analysis.corrected)
    (rec,) = [c for c in analysis.corrections if c["channel"] == names[dead]]
    assert rec["method"] == "reference"
    assert rec["end_s"] == pytest.approx(220.0, abs=0.05)
    assert np.array_equal(out[22005:, dead], y[22005:, dead])  # alive again: as measured
    sd = float(y0[:, dead].std())
    inside = out[12000:22000, dead] - y0[12000:22000, dead]
    assert float(np.sqrt(np.mean(inside**2))) < 0.5 * sd  # (the dead readings' error: 1 sd)


def _drifting_estimate(s, rng, n, since):
    """An estimate of ``s`` with an error of 0.05 that carries, from row ``since``, a
    drift of 0.01 a row-second at 100 Hz (another sensor's fault no finding took out)."""
    drift = 0.01 * np.maximum(np.arange(n) - since, 0) / 100.0
    return s + 0.05 * rng.standard_normal(n) + drift


def test_a_revival_is_read_from_the_readings_when_the_estimate_carries_a_fault():
    """c0 dead at 10-20 s (its finding to the end), stuck at 3.0 at 40-50 s of c1's (its
    finding 40-60 s); each estimate carries a drift from 15 s (35 s for c1) that the
    residual test reads as the fault going on: both regenerations end where the
    readings move again, whatever the value a reading was stuck at."""
    rate = 100.0
    s, Y, names, rng = _dead_record(rate, seconds=60.0)
    n = s.size
    Yf = Y.copy()
    Yf[1000:2000, 0] = 0.0
    Yf[4000:5000, 1] = 3.0
    refs = {
        "c0": _drifting_estimate(s, rng, n, 1500),
        "c1": _drifting_estimate(s, rng, n, 3500),
        "c2": s,
    }
    events = [
        _dead("c0", 10.0, None, 0.9),
        Event("c1", 40.0, 60.0, FaultType.OTHER, {}, 0.8, "test"),
    ]
    out, records = corrected_values(Yf, names, rate, events, None, refs, healthy=(0, 500))
    assert records[0]["end_s"] == pytest.approx(20.0, abs=0.02), records[0]
    assert records[1]["end_s"] == pytest.approx(50.0, abs=0.02), records[1]
    assert "alive again" in records[0]["note"] and "alive again" in records[1]["note"]
    assert np.array_equal(out[2002:, 0], Yf[2002:, 0])
    assert np.array_equal(out[5002:, 1], Yf[5002:, 1])
    assert np.allclose(out[1000:1998, 0], refs["c0"][1000:1998])


def test_a_sensor_that_dies_again_is_regenerated_to_its_findings_end():
    """c0 dead at 10-20 s, alive 20-35 s, dead again from 35 s to the end, under one
    finding from 10 s: alive in between is not alive to the end, so the period's end
    is left to the residual (the readings never say the tail is alive) and the second
    dead stretch is regenerated; a sensor dead at 10-20, 30-40 and alive after is
    regenerated to 40 s."""
    rate = 100.0
    s, Y, names, rng = _dead_record(rate, seconds=60.0)
    refs = {c: s + 0.05 * rng.standard_normal(s.size) for c in names}
    Yf = Y.copy()
    Yf[1000:2000, 0] = 0.0
    Yf[3500:, 0] = 0.0
    out, records = corrected_values(
        Yf, names, rate, [_dead("c0", 10.0, None, 0.9)], None, refs, healthy=(0, 500)
    )
    assert records[0]["end_s"] is None
    assert np.array_equal(out[3500:, 0], refs["c0"][3500:])
    Yf = Y.copy()
    Yf[1000:2000, 0] = 0.0
    Yf[3000:4000, 0] = 0.0
    out, records = corrected_values(
        Yf, names, rate, [_dead("c0", 10.0, None, 0.9)], None, refs, healthy=(0, 500)
    )
    assert records[0]["end_s"] == pytest.approx(40.0, abs=0.02), records[0]
    assert np.array_equal(out[3000:3998, 0], refs["c0"][3000:3998])
    assert np.array_equal(out[4002:, 0], Yf[4002:, 0])


def _split_by_brute_force(y, start, stop, scale, least):
    """``_spread_split`` by the definition: every head and tail's variance with numpy."""
    best, got = np.inf, None
    for k in range(start + least, stop - least + 1):
        head, tail = y[start:k], y[k:stop]
        head, tail = head[np.isfinite(head)], tail[np.isfinite(tail)]
        if head.size < 2 or tail.size < 2:
            continue
        v1, v2 = max(head.var(), 1e-12 * scale), max(tail.var(), 1e-12 * scale)
        cost = head.size * np.log(v1) + tail.size * np.log(v2)
        if cost < best:
            best, got = cost, (k, v1, v2)
    return got


def test_the_spread_split_is_the_brute_force_one_across_pieces(monkeypatch):
    """The running sums carried from piece to piece (a long archive, memory-mapped) give
    the split of the definition, with gaps, heads stuck at 0 or far from the tail, and
    pieces of 1 to 8 rows."""
    import analyzer.regenerate as regenerate

    rng = np.random.default_rng(11)
    for _ in range(300):
        n = int(rng.integers(10, 80))
        y = rng.standard_normal(n)
        k0 = int(rng.integers(0, n))
        y[:k0] = rng.choice([0.05 * y[:k0], np.zeros(k0), np.full(k0, 1e6)])
        if rng.random() < 0.5:
            y[rng.random(n) < 0.2] = np.nan
        start, stop = int(rng.integers(0, 5)), n - int(rng.integers(0, 5))
        least = int(rng.integers(1, 6))
        monkeypatch.setattr(regenerate, "RELEASE_ROWS", int(rng.integers(1, 9)))
        got = regenerate._spread_split(y[:, None], 0, start, stop, 1.0, least)
        want = _split_by_brute_force(y, start, stop, 1.0, least)
        assert (got is None) == (want is None), (got, want)
        if got is not None:  # (rows apart across missing readings split them alike)
            finite = np.cumsum(np.isfinite(np.concatenate(([0.0], y))))
            assert finite[got[0]] == finite[want[0]], (got, want)
            assert np.allclose(got[1:], want[1:], rtol=1e-6, atol=1e-9), (got, want)


def _revival(Yf, names, s, rng, end_s=None, drifting=True):
    """The end of c0's regeneration (finding from 10 s to ``end_s``) with an estimate
    that carries a drift from 15 s (the residual test reads it as the fault going on)
    or not, and the corrected c0."""
    n = s.size
    refs = {c: s + 0.05 * rng.standard_normal(n) for c in names}
    if drifting:
        refs["c0"] = _drifting_estimate(s, rng, n, 1500)
    out, records = corrected_values(
        Yf, names, 100.0, [_dead("c0", 10.0, end_s, 0.9)], None, refs, healthy=(0, 500)
    )
    return records[0]["end_s"], out[:, 0]


@pytest.mark.parametrize("rows_past_a_block", [2, 3])
def test_a_revival_is_kept_when_the_record_ends_just_past_a_block(rows_past_a_block):
    """c0 dead at 10-20 s of a record 2 or 3 rows longer than 60 s: the last half-second
    block of the tail held 2 or 3 live readings, whose variance (0.0027, 0.0038) was
    under the dead-stretch bound (0.0052), so the tail was read as dead again at its
    end and the regeneration ran on to the record's end (5 002 rows instead of 1 000)."""
    s, Y, names, rng = _dead_record(100.0, seconds=60.0 + rows_past_a_block / 100.0)
    Yf = Y.copy()
    Yf[1000:2000, 0] = 0.0
    end, out = _revival(Yf, names, s, rng)
    assert end == pytest.approx(20.0, abs=0.02)
    assert np.array_equal(out[2002:], Yf[2002:, 0])


@pytest.mark.parametrize("stuck, scale", [(1e6, 1.0), (1e4, 0.01), (1e8, 1.0)])
def test_a_revival_is_read_from_a_reading_stuck_far_from_its_healthy_level(stuck, scale):
    """c0 stuck at 1e6 (or 1e8) at 10-20 s, its healthy readings of sd 1 near 0 (or at
    1e4 beside sd 0.01: a logger's error value): the split's floor on a variance was
    relative to the period's mean square about the healthy mean (2e11), so the stuck
    head read as varying by 0.2 of the live tail and the revival was lost."""
    s, Y, names, rng = _dead_record(100.0, seconds=60.0)
    s, Y = s * scale, Y * scale
    Yf = Y.copy()
    Yf[1000:2000, 0] = stuck
    n = s.size
    refs = {c: s + 0.05 * scale * rng.standard_normal(n) for c in names}
    refs["c0"] = s + scale * (_drifting_estimate(s, rng, n, 1500) - s)
    out, records = corrected_values(
        Yf, names, 100.0, [_dead("c0", 10.0, None, 0.9)], None, refs, healthy=(0, 500)
    )
    assert records[0]["end_s"] == pytest.approx(20.0, abs=0.02), records[0]
    assert np.array_equal(out[2002:, 0], Yf[2002:, 0])


def test_a_finding_that_ends_just_after_the_revival_leaves_no_dead_reading():
    """c0 dead from 10 s to 17.91 s, its finding ending 0.2-0.3 s later: the split can
    put the tail's start no later than half a second before the finding's end, so the
    tail began with dead readings and they were kept as measured (20 and 10 zeros);
    the period is then regenerated to the finding's end instead."""
    s, Y, names, rng = _dead_record(100.0, seconds=60.0)
    for late in (20, 30):
        Yf = Y.copy()
        Yf[1000:1791, 0] = 0.0
        end, out = _revival(Yf, names, s, rng, end_s=(1791 + late) / 100.0, drifting=False)
        assert not np.any(out[1000:1791] == 0.0), end


@pytest.mark.parametrize("louder", [3.5, 4.0])
def test_a_weak_reading_of_a_structure_that_moves_more_is_not_called_alive(louder):
    """c0 at a gain of 0.2 from 10 s to the end (read as ``other``) while the structure
    moves 3.5 or 4 times as much from 20 s: the readings' spread goes from 0.04 of the
    healthy window's to 0.5 or more, which the readings alone call alive, and the weak
    readings were kept as measured from 20 s (2.8 and 3.2 sd of error there); they move
    by 0.04 of the estimate, so the estimate stays."""
    s, Y, names, rng = _dead_record(100.0, seconds=60.0)
    s = s * np.where(np.arange(s.size) < 2000, 1.0, louder)
    Y = s[:, None] + 0.05 * rng.standard_normal(Y.shape)
    Yf = Y.copy()
    Yf[1000:, 0] *= 0.2
    refs = {c: s + 0.05 * rng.standard_normal(s.size) for c in names}
    event = Event("c0", 10.0, None, FaultType.OTHER, {}, 0.9, "test")
    out, records = corrected_values(Yf, names, 100.0, [event], None, refs, healthy=(0, 500))
    assert records[0]["end_s"] is None, records[0]
    assert np.allclose(out[1000:, 0], refs["c0"][1000:])


def test_the_healthy_stretch_is_the_longest_clear_of_every_finding():
    """``--model``'s stand-in for a healthy window: the longest stretch from ``start``
    on, each finding's period widened by ``margin`` rows either side (a finding to the
    record's end closes it), of at least ``least`` rows; else None."""
    rate = 100.0
    events = [_event("additive", 20.0, 30.0, offset=1.0), _event("other", 60.0, 62.0)]
    # clear: 5-17 s, 33-57 s, 65-100 s (3 s either side of each finding)
    assert healthy_stretch(events, 10_000, rate, 500, 300, 16) == (6500, 10_000)
    late = [*events, _event("drift", 90.0, None, rate_per_s=0.1)]  # to the end: 65-87 s
    assert healthy_stretch(late, 10_000, rate, 500, 300, 16) == (3300, 5700)
    assert healthy_stretch(late, 10_000, rate, 500, 300, 2401) is None
    assert healthy_stretch(late, 10_000, rate, 3400, 300, 16) == (3400, 5700)
    # a finding over the start, and none at all
    assert healthy_stretch([_event("other", 0.0, 50.0)], 10_000, rate, 500, 300, 16) == (
        5300,
        10_000,
    )
    assert healthy_stretch([], 10_000, rate, 500, 300, 16) == (500, 10_000)
    assert healthy_stretch([_event("other", 1.0, None)], 10_000, rate, 500, 300, 16) is None


def test_the_model_runs_stretch_is_named_or_its_absence_said():
    """``--model --corrected``: the stretch clears every finding by the model's warm-up
    (here its least, 1 s at 100 Hz: no fitted filters), starts after it and is at least
    that long; the note names it, or says that none calibrates the regeneration."""
    from types import SimpleNamespace

    from analyzer.pipeline import _model_stretch

    model = SimpleNamespace(rate_hz=100.0, fits={})
    found = [_event("other", 5.0, 8.0), _event("other", 9.5, 12.0)]
    got, said = _model_stretch(found, 2000, 100.0, (0, 100), model)
    assert got == (1300, 2000)
    assert "healthy stretch is 13-20 s of this record" in said
    got, said = _model_stretch(found, 1400, 100.0, (0, 100), model)  # 1-4 s beats 13-14 s
    assert got == (100, 400)
    got, said = _model_stretch([_event("other", 1.5, None)], 2000, 100.0, (0, 100), model)
    # (the duration as the notes speak it: spoken_duration's "1.0 s")
    assert got is None and "no stretch of at least 1.0 s of this record" in said
