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
