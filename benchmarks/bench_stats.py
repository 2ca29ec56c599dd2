"""Throughput and peak memory of the windowed innovation tests.

Runs :func:`analyzer.stats.windowed_tests` over a long white residual (default 1e7
samples, windows of 1000 every 1000) and compares it with testing window by window:
``scipy.stats.anderson`` + ``scipy.stats.cramervonmises`` + statsmodels'
``acorr_ljungbox`` (and the scalar :func:`analyzer.stats.run_all`) on a subset of
windows, extrapolated to all of them. Prints a table; a script, not a timed test.

    python benchmarks/bench_stats.py [--samples 10000000] [--window 1000] [--step 1000]
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
import tracemalloc
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import numpy.typing as npt
from scipy import stats
from statsmodels.stats.diagnostic import acorr_ljungbox

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import analyzer.stats as st  # noqa: E402

FloatArray = npt.NDArray[np.float64]


def scipy_per_window(segment: FloatArray, lags: int) -> float:
    """The reference: one window through scipy and statsmodels; returns Ljung-Box Q."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)  # scipy >= 1.17 anderson `method`
        stats.anderson(segment, "norm")
    stats.cramervonmises(segment, "norm")
    return float(acorr_ljungbox(segment, lags=[lags])["lb_stat"].iloc[0])


def time_subset(
    z: FloatArray, starts: npt.NDArray[np.int64], window: int, run: Callable[[FloatArray], object]
) -> float:
    """Seconds per window of ``run`` over the windows starting at ``starts``."""
    begin = time.perf_counter()
    for start in starts:
        run(z[start : start + window])
    return (time.perf_counter() - begin) / starts.shape[0]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=10_000_000)
    parser.add_argument("--window", type=int, default=1000)
    parser.add_argument("--step", type=int, default=None)
    parser.add_argument("--lags", type=int, default=20)
    parser.add_argument("--subset", type=int, default=200, help="windows timed per window")
    parser.add_argument("--repeat", type=int, default=3, help="best of this many runs")
    args = parser.parse_args(argv)

    z = np.random.default_rng(0).normal(size=args.samples)
    step = args.step or args.window
    print(
        f"residual: {args.samples:,} samples, window {args.window}, step {step}, lags {args.lags}"
    )

    seconds = []
    for _ in range(args.repeat):
        begin = time.perf_counter()
        result = st.windowed_tests(z, args.window, step, lags=args.lags)
        seconds.append(time.perf_counter() - begin)
    vectorized = min(seconds)
    n_windows = result.n_windows
    values = n_windows * args.window

    tracemalloc.start()
    st.windowed_tests(z, args.window, step, lags=args.lags)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()

    picks = np.linspace(0, n_windows - 1, min(args.subset, n_windows)).astype(np.int64)
    starts = result.start[picks]
    reference = time_subset(z, starts, args.window, lambda s: scipy_per_window(s, args.lags))
    scalar = time_subset(z, starts, args.window, lambda s: st.run_all(s, lags=args.lags))

    q_ref = np.array([scipy_per_window(z[s : s + args.window], args.lags) for s in starts])
    q_err = float(np.max(np.abs(result.whiteness.statistic[picks] - q_ref) / q_ref))

    rows = [
        ("analyzer windowed_tests (all 6 tests)", vectorized, "measured"),
        ("analyzer run_all per window (6 tests)", scalar * n_windows, f"{len(starts)} windows"),
        (
            "scipy AD + CvM + statsmodels LB per window",
            reference * n_windows,
            f"{len(starts)} windows",
        ),
    ]
    print("values/s: window values tested per second (= residual samples/s when step = window)")
    print(
        f"\n{'method':<44} {'seconds':>9} {'values/s':>12} {'samples/s':>12} {'speedup':>8}  timing"
    )
    for name, sec, how in rows:
        print(
            f"{name:<44} {sec:>9.2f} {values / sec:>12.3g} {args.samples / sec:>12.3g} "
            f"{sec / vectorized:>7.1f}x  {how}"
        )
    print(
        f"\nwindows: {n_windows:,}; peak traced memory of windowed_tests: {peak / 2**20:.1f} MiB "
        f"(input residual {z.nbytes / 2**20:.0f} MiB); process max RSS "
        f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**10:.0f} MiB"
    )
    print(f"windowed Ljung-Box Q vs statsmodels on the subset: max relative difference {q_err:.1e}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
