"""The Newey-West sums of a fault's size interval do not reach across a gap in the
record (the aligned rows where the channel, or its estimate, has no value: NaN): a lag
pairs two samples of one contiguous run only. Before, the sums paired the samples on the
two sides of a gap as if they were neighbours, so a level that stepped while the channel
was silent (the two sides differing) changed the interval through products of samples
that were never next to each other."""

from __future__ import annotations

import numpy as np
import pytest
import statsmodels.api as sm
from scipy.signal import lfilter

from analyzer.diagnosis import classify, correlation_time
from analyzer.stats.moments import bartlett_sum
from analyzer.types import FaultType

RATE = 100.0


def _coloured(n: int, seed: int, phi: float = 0.6, scale: float = 0.3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return lfilter([1.0], [1.0, -phi], rng.normal(scale=scale, size=n))


def _runs(ok: np.ndarray) -> np.ndarray:
    """Each valid row's run number (a run: contiguous valid rows)."""
    rows = np.flatnonzero(ok)
    return np.concatenate(([0], np.cumsum(np.diff(rows) > 1)))


def _brute(d: np.ndarray, rows: np.ndarray, max_lag: int) -> np.ndarray:
    """The within-run lagged products, pair by pair (the reference: short series only)."""
    top = min(max_lag, d.shape[0] - 1)
    out = np.zeros(top + 1)
    for k in range(top + 1):
        for t in range(d.shape[0] - k):
            if rows[t + k] - rows[t] == k:
                out[k] += d[t] * d[t + k]
    return out


def _stepped_offset() -> tuple[np.ndarray, np.ndarray]:
    """An offset stretch of 30 s at 100 Hz with a 4 s gap (NaN) in the middle, the level
    0.06 higher after it than before (hidden in the gap), AR(1) noise."""
    n = 3000
    noise = _coloured(n, 7)
    f = 0.8 + noise
    f[1600:] += 0.06
    f[1200:1600] = np.nan
    return f, noise


def test_the_offsets_error_sums_each_run_alone_as_statsmodels_hac_panel():
    """The offset's standard error over a stretch with a gap is statsmodels' HAC with
    each run a group (``hac-panel``: no lag across a group's end) at the same lags, and
    the hand-built per-run Newey-West sum; the sum across the gap is not."""
    f, noise = _stepped_offset()
    c = classify(f, None, float(np.nanstd(noise)), RATE, correlation_time(noise[:1200]))
    assert c.type is FaultType.ADDITIVE and c.spread is not None
    ok = np.isfinite(f)
    y = f[ok]
    lags = c.spread.lags
    assert lags >= 2
    ref = sm.OLS(y, np.ones((y.shape[0], 1))).fit(
        cov_type="hac-panel",
        cov_kwds={"groups": _runs(ok), "maxlags": lags, "use_correction": False},
    )
    assert c.magnitude["offset"] == pytest.approx(float(ref.params[0]), rel=1e-12)
    assert c.spread.se["offset"] == pytest.approx(float(ref.bse[0]), rel=1e-8)
    # by hand: each run's Bartlett-weighted sum of its own products, added
    e = y - c.magnitude["offset"]
    cut = int(np.count_nonzero(ok[:1200]))
    runs = (e[:cut], e[cut:])
    s = sum(
        bartlett_sum(np.array([r[: r.shape[0] - k] @ r[k:] for k in range(lags + 1)])) for r in runs
    )
    assert c.spread.se["offset"] == pytest.approx(np.sqrt(s) / y.shape[0], rel=1e-10)
    # (the two sides joined as neighbours: what the sums gave before)
    joined = sm.OLS(y, np.ones((y.shape[0], 1))).fit(
        cov_type="HAC", cov_kwds={"maxlags": lags, "use_correction": False}
    )
    assert abs(float(joined.bse[0]) / c.spread.se["offset"] - 1.0) > 1e-6


def test_the_drifts_error_sums_each_run_alone():
    """A drift's rate over a stretch with a gap: statsmodels' per-run HAC of the line."""
    n = 4000
    noise = _coloured(n, 3)
    tau = np.arange(n) / RATE
    f = 0.2 * (tau + 1.5) + noise
    f[1500:1800] = np.nan
    c = classify(f, None, float(np.nanstd(noise)), RATE, correlation_time(noise[:1500]))
    assert c.type is FaultType.DRIFT and c.spread is not None
    ok = np.isfinite(f)
    x = np.column_stack((np.ones(n), tau))[ok]
    ref = sm.OLS(f[ok], x).fit(
        cov_type="hac-panel",
        cov_kwds={"groups": _runs(ok), "maxlags": c.spread.lags, "use_correction": False},
    )
    assert c.spread.se["rate_per_s"] == pytest.approx(float(ref.bse[1]), rel=1e-8)


@pytest.mark.parametrize("gaps", ["few", "many", "between blocks"])
def test_run_lagged_sums_pair_samples_of_one_run_only(gaps):
    """Block by block, with gaps inside blocks and between them (few: the runs laid out
    apart; many: more gaps than :data:`SPACED_GROWTH` allows, summed lag by lag), the
    sums equal the pair-by-pair reference."""
    from analyzer.diagnosis.spread import SPACED_GROWTH, RunLaggedSums

    rng = np.random.default_rng(5)
    n = 700
    missing = {
        "few": np.r_[100:130, 301, 450:452],
        "many": np.arange(0, n, 3),
        "between blocks": np.r_[97:99, 294],  # (blocks of 97 samples: gaps at their ends)
    }[gaps]
    ok = np.ones(n, dtype=bool)
    ok[missing] = False
    rows = np.flatnonzero(ok)
    d = rng.normal(size=rows.shape[0])
    max_lag = 40
    if gaps == "many":  # (the lag-by-lag path is taken: the layout would be too long)
        assert rows.shape[0] + 200 * max_lag > SPACED_GROWTH * rows.shape[0]
    sums = RunLaggedSums(max_lag)
    for a in range(0, rows.shape[0], 97):
        block = rows[a : a + 97]
        if block[-1] - block[0] == block.shape[0] - 1:  # (contiguous: rows not given)
            sums.add(d[a : a + 97], int(block[0]))
        else:
            sums.add(d[a : a + 97], int(block[0]), block)
    assert sums.values() == pytest.approx(_brute(d, rows, max_lag), rel=1e-9, abs=1e-9)


def test_without_gaps_the_sums_are_the_gapless_ones_to_the_bit():
    """A stretch with no gap: the same sums as the gapless :class:`LaggedSums` (the
    findings of records without gaps keep their intervals to the bit)."""
    from analyzer.diagnosis.spread import RunLaggedSums
    from analyzer.diagnosis.streamed import LaggedSums

    d = np.random.default_rng(2).normal(size=5000)
    runs, plain = RunLaggedSums(200), LaggedSums(200)
    for a in range(0, 5000, 1234):
        runs.add(d[a : a + 1234], a)
        plain.add(d[a : a + 1234])
    assert np.array_equal(runs.values(), plain.values())
