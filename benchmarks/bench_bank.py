"""Throughput of the AR-Kalman bank against statsmodels' Kalman filter and a Python loop.

For a 6-channel and a 16-channel simulated building (``simulate_building`` with 3 and 8
floors, 2 sensors per floor, 100 Hz, AR order 7, so 42 and 112 estimator states) it fits
``ARKalmanBank`` on the first 10 minutes of a healthy ``--minutes`` record and measures,
in values per second (samples x channels of the record per second):

(a) ours: one steady-state estimator (``LiftedSystem.run`` of the estimator that leaves
    out channel 0), the raw bank (``ARKalmanBank._bank_outputs``: all m estimators) and
    the whole detector (``ARKalmanBank.run``: the bank plus alarms and diagnosis) over the
    whole record;
(b) statsmodels' ``KalmanFilter`` on the same model: state ``p m`` (companion form),
    observations the ``m - 1`` measured channels, transition ``A``, design ``C_bar``,
    selection ``C'`` with state covariance ``sigma``, observation covariance
    ``sigma[measured]`` (the Q and R of ``leave_one_out``); known initial state 0 with
    P0 = I, statsmodels' own steady-state switch (``tolerance``), no covariance, gain or
    likelihood storage. Both its conventional and univariate filters are timed and the
    faster one is the reference. It runs over the first ``--sm-samples`` samples (one
    estimator) and ``--sm-bank-samples`` samples (all m estimators);
(c) a plain Python loop, one matrix-vector step per sample
    (``analyzer.detectors.lti.simulate_reference``), over ``--py-samples`` samples.

The speedup column compares like with like: one estimator with one statsmodels filter,
the bank with m statsmodels filters. The outputs are checked: our innovations and
left-out estimates against statsmodels' one-step predictions (``y - C_bar a_pred``) and
filtered estimates (``c_j a_filt``) once its gain has converged and the start-up
difference has decayed (max abs difference, scaled units), and against the Python loop.

Last, it times the bank in its fallback form, the stacked lifted state space, at each
block length ``T`` of ``--sweep`` (the default form runs the estimators as truncated
impulse responses by FFT). Timings are the best of
``--repeat`` wall-clock runs. OPENBLAS_NUM_THREADS is set to 1 before numpy is imported
unless it is already set (``OPENBLAS_NUM_THREADS=2 python ...`` measures threaded BLAS).
A script, not a timed test::

    python benchmarks/bench_bank.py [--minutes 60] [--quick] [--repeat 3]
                                    [--sm-samples 20000] [--sm-bank-samples 4000]
                                    [--py-samples 4000] [--sweep 16,24,32,...,256]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable, Sequence  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from functools import partial  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
import numpy.typing as npt  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from analyzer.detectors.ar_kalman import ARKalmanBank, FittedBank  # noqa: E402
from analyzer.detectors.ar_model import ARModel  # noqa: E402
from analyzer.detectors.base import Dataset, RunContext  # noqa: E402
from analyzer.detectors.kalman_bank import BankFilter, LeaveOneOut, bank_block  # noqa: E402
from analyzer.detectors.lti import simulate_reference  # noqa: E402
from analyzer.simulate import simulate_building  # noqa: E402

FloatArray = npt.NDArray[np.float64]

RATE_HZ = 100.0
ORDER = 7
TRAIN_S = 600.0
SIZES = ((3, 2), (8, 2))  # (floors, sensors per floor): 6 and 16 channels
TARGET_SPEEDUP = 50.0
DEFAULT_SWEEP = (16, 24, 32, 48, 64, 96, 128, 192, 256)


@dataclass
class Row:
    method: str
    scope: str  # "one" estimator or the "bank"
    channels: int
    states: int
    samples: int
    seconds: float

    @property
    def values_per_s(self) -> float:
        return self.samples * self.channels / self.seconds


def best_time(fn: Callable[[], Any], repeat: int) -> tuple[float, Any]:
    """Best wall-clock time of ``repeat`` calls of ``fn`` and the last call's result."""
    best = np.inf
    result: Any = None
    for _ in range(max(1, repeat)):
        start = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - start)
    return best, result


def revision(root: Path | None = None) -> str:
    """The commit measured (and whether analyzer/ has uncommitted changes), or "unknown";
    of the checkout ``root`` (default: this one)."""
    root = Path(__file__).resolve().parents[1] if root is None else root
    try:
        head = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            [
                "git",
                "--no-optional-locks",
                "-C",
                str(root),
                "status",
                "--porcelain",
                "--",
                "analyzer",
            ],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + (" + local changes in analyzer/" if dirty else "")


# --------------------------------------------------------------------------- statsmodels


def statsmodels_filter(
    ar: ARModel, measured: Sequence[int], u: FloatArray, method: str = "univariate"
) -> Any:
    """statsmodels' KalmanFilter for the estimator that measures the channels ``measured``
    of ``ar``, bound to their scaled values ``u`` (N, m-1) and ready to ``filter()``;
    ``method`` is ``"conventional"`` or ``"univariate"``."""
    from statsmodels.tsa.statespace.kalman_filter import KalmanFilter

    A, C = ar.companion()
    measured = list(measured)
    n = A.shape[0]
    kf = KalmanFilter(k_endog=len(measured), k_states=n, k_posdef=ar.m)
    kf.bind(np.array(u, dtype=np.float64, order="C", copy=True))
    kf.design = C[measured]
    kf.transition = A
    kf.selection = C.T  # noise enters the newest block row (Chang et al. 2017, Eq. 8)
    kf.state_cov = ar.sigma
    kf.obs_cov = ar.sigma[np.ix_(measured, measured)]
    kf.initialize_known(np.zeros(n), np.eye(n))
    kf.set_conserve_memory(
        memory_no_filtered_cov=True,
        memory_no_predicted_cov=True,
        memory_no_forecast_cov=True,
        memory_no_gain=True,
        memory_no_likelihood=True,
        memory_no_smoothing=True,
        memory_no_std_forecast=True,
    )
    if method == "univariate":
        kf.set_filter_method(filter_conventional=False, filter_univariate=True)
    return kf


def statsmodels_outputs(ar: ARModel, est: LeaveOneOut, u: FloatArray, res: Any) -> FloatArray:
    """statsmodels' ``[innovations; estimate of the left-out channel]`` (N, m), scaled
    units, in the layout of our estimator's outputs."""
    _, C = ar.companion()
    n_obs = u.shape[0]
    a_pred = np.asarray(res.predicted_state)[:, :n_obs]  # a[k | k-1]
    a_filt = np.asarray(res.filtered_state)  # a[k | k]
    nu = u - (C[list(est.measured)] @ a_pred).T
    yhat = C[est.left_out] @ a_filt
    return np.column_stack([nu, yhat])


# --------------------------------------------------------------------------- one size


@dataclass
class SizeResult:
    rows: list[Row]
    checks: list[str]
    sweep: list[tuple[int, float, float]]  # (T, values/s of one estimator, build seconds)
    best_T: int
    bank_best: Row | None
    fit_s: float


def measure_size(
    floors: int, per_floor: int, args: argparse.Namespace, sweep_T: Sequence[int]
) -> SizeResult:
    t_s, Y, names = simulate_building(
        floors, args.minutes * 60.0, RATE_HZ, seed=floors, sensors_per_floor=per_floor
    )
    N, m = Y.shape
    train = (0, min(N, int(TRAIN_S * RATE_HZ)))
    data = Dataset(Y, tuple(names), RATE_HZ, train)
    ctx = RunContext()
    bank = ARKalmanBank(order=ORDER)
    start = time.perf_counter()
    model: FittedBank = bank.fit(data, ctx)
    fit_s = time.perf_counter() - start
    ar = model.ar
    states = ar.order * m
    est = model.estimators[0]
    one = est.system  # the estimator alone, lifted (built once here)
    assert model.bank is not None
    Z = (Y - ar.mean) / ar.scale
    u = np.ascontiguousarray(Z[:, list(est.measured)])
    print(
        f"  {m} channels, {states} states, {N:,} samples; fit {fit_s:.1f} s "
        f"(order {ar.order}, one estimator lifted at T={one.T})",
        flush=True,
    )
    rows: list[Row] = []
    checks: list[str] = []
    R = args.repeat

    # (a) ours
    t_one, (y_ours, _) = best_time(lambda: one.run(u), R)
    rows.append(Row(f"ours: LiftedSystem.run (T={one.T})", "one", m, states, N, t_one))
    t_raw, _ = best_time(lambda: bank._bank_outputs(model, Y), R)
    taps = getattr(model.bank.system, "taps", None)
    form = f"FFT, {taps} taps" if taps else f"lifted, T={model.bank.block}"
    rows.append(
        Row(
            f"ours: ARKalmanBank._bank_outputs ({form})",
            "bank",
            m,
            states,
            N,
            t_raw,
        )
    )
    t_run, result = best_time(lambda: bank.run(model, data, ctx), max(1, R - 1))
    rows.append(Row("ours: ARKalmanBank.run (+ detection)", "bank", m, states, N, t_run))
    checks.append(
        f"ARKalmanBank.run on the healthy record: {len(result.events)} event(s), "
        f"{len(result.notes)} note(s)"
    )
    print("  timed ours", flush=True)

    # (b) statsmodels, one estimator: both filter methods, checked against ours
    n_sm = min(N, args.sm_samples)
    sm_best: dict[str, float] = {}
    for method in ("conventional", "univariate"):
        kf = statsmodels_filter(ar, est.measured, u[:n_sm], method)
        t_sm, res = best_time(kf.filter, 1)
        sm_best[method] = t_sm
        rows.append(Row(f"statsmodels KalmanFilter ({method})", "one", m, states, n_sm, t_sm))
        ref = statsmodels_outputs(ar, est, u[:n_sm], res)
        k0 = min(n_sm // 2, int(res.period_converged) + est.settle)
        diff = np.abs(ref[k0:] - y_ours[k0:n_sm])
        checks.append(
            f"one estimator vs statsmodels ({method}, gain converged at sample "
            f"{int(res.period_converged)}, compared from sample {k0}): max |diff| innovations "
            f"{diff[:, :-1].max():.2e}, left-out estimate {diff[:, -1].max():.2e} (scaled units)"
        )
    fastest = min(sm_best, key=lambda k: sm_best[k])
    print(f"  timed statsmodels, one estimator (faster: {fastest})", flush=True)

    # (b) statsmodels, the bank: every estimator, the faster method
    n_smb = min(N, args.sm_bank_samples)
    total = 0.0
    worst = 0.0
    Zf = Z[:n_smb]
    # the stacked bank (what the detector runs): innovations and left-out estimates, scaled
    plain = BankFilter.build(model.estimators, model.bank.block)  # innovations not whitened
    blk = bank_block(ar.mean, ar.scale, plain, Y[:n_smb], 0, None)
    assert blk.innov is not None
    ours_bank = [
        np.column_stack([blk.innov[:, j], (blk.est[:, j] - ar.mean[j]) / ar.scale[j]])
        for j in range(m)
    ]
    for e, y_e in zip(model.estimators, ours_bank, strict=True):
        ue = np.ascontiguousarray(Zf[:, list(e.measured)])
        kf = statsmodels_filter(ar, e.measured, ue, fastest)
        t_sm, res = best_time(kf.filter, 1)
        total += t_sm
        k0 = min(n_smb // 2, int(res.period_converged) + e.settle)
        worst = max(worst, float(np.abs(statsmodels_outputs(ar, e, ue, res)[k0:] - y_e[k0:]).max()))
    rows.append(Row(f"statsmodels KalmanFilter ({fastest}) x {m}", "bank", m, states, n_smb, total))
    checks.append(
        f"bank vs statsmodels ({m} estimators, {n_smb:,} samples): max |diff| {worst:.2e}"
    )
    print("  timed statsmodels, bank", flush=True)

    # (c) plain Python loop
    n_py = min(N, args.py_samples)
    s = one
    t_py, y_py = best_time(lambda: simulate_reference(s.F, s.G, s.H, s.J, u[:n_py]), 1)
    rows.append(Row("Python loop (simulate_reference)", "one", m, states, n_py, t_py))
    checks.append(
        f"one estimator vs the Python loop ({n_py:,} samples): max |diff| "
        f"{np.abs(y_py - y_ours[:n_py]).max():.2e}"
    )
    t_pyb = 0.0
    for e in model.estimators:
        ue = np.ascontiguousarray(Zf[: min(n_py, n_smb), list(e.measured)])
        se = e.system
        t_e, _ = best_time(partial(simulate_reference, se.F, se.G, se.H, se.J, ue), 1)
        t_pyb += t_e
    rows.append(Row(f"Python loop x {m}", "bank", m, states, min(n_py, n_smb), t_pyb))
    print("  timed the Python loop", flush=True)

    # the bank's two forms: impulse responses by FFT (the default) and the stacked lifted
    # state space at each block length T of the sweep (the fallback for long memories)
    sweep: list[tuple[int, float, float]] = []
    for T in sweep_T:
        if T * T * m**3 * 8 > 2**29:  # the stacked Toeplitz matrix alone would pass 512 MB
            continue
        b0 = time.perf_counter()
        model_T = dataclasses.replace(
            model,
            bank=BankFilter.build(model.estimators, T, model.innovation_inv_cov, lifted=True),
        )
        build_s = time.perf_counter() - b0
        t_T, _ = best_time(partial(bank._bank_outputs, model_T, Y), R)
        sweep.append((T, N * m / t_T, build_s))
        del model_T
    best_T = max(sweep, key=lambda r: r[1])[0] if sweep else model.bank.block
    bank_best = None
    if sweep:
        bank_best = Row(
            f"ours: _bank_outputs, lifted form at best T={best_T}",
            "bank",
            m,
            states,
            N,
            N * m / max(v for _, v, _ in sweep),
        )
    print("  swept the block length", flush=True)
    return SizeResult(rows, checks, sweep, best_T, bank_best, fit_s)


# --------------------------------------------------------------------------- report


def print_table(rows: list[Row]) -> None:
    # the faster statsmodels variant per (scope, channels) is the reference
    reference: dict[tuple[str, int], float] = {}
    for r in rows:
        if r.method.startswith("statsmodels"):
            key = (r.scope, r.channels)
            reference[key] = max(reference.get(key, 0.0), r.values_per_s)
    print(
        f"{'method':<44}{'scope':>6}{'channels':>9}{'states':>7}{'samples':>10}"
        f"{'seconds':>10}{'values/s':>13}{'vs statsmodels':>16}"
    )
    for r in rows:
        speedup = r.values_per_s / reference[(r.scope, r.channels)]
        print(
            f"{r.method:<44}{r.scope:>6}{r.channels:>9}{r.states:>7}{r.samples:>10,}"
            f"{r.seconds:>10.3f}{r.values_per_s:>13,.0f}{speedup:>15.1f}x"
        )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=60.0, help="record length (default 60)")
    parser.add_argument("--quick", action="store_true", help="15-minute record, short baselines")
    parser.add_argument("--repeat", type=int, default=3, help="timings: best of (default 3)")
    parser.add_argument("--sm-samples", type=int, default=20_000)
    parser.add_argument("--sm-bank-samples", type=int, default=4_000)
    parser.add_argument("--py-samples", type=int, default=4_000)
    parser.add_argument(
        "--sweep",
        default=",".join(str(t) for t in DEFAULT_SWEEP),
        help="block lengths T to sweep (comma-separated; empty: no sweep)",
    )
    args = parser.parse_args(argv)
    if args.quick:
        args.minutes = min(args.minutes, 15.0)
        args.sm_samples = min(args.sm_samples, 5_000)
        args.sm_bank_samples = min(args.sm_bank_samples, 1_500)
        args.py_samples = min(args.py_samples, 1_500)
        args.repeat = min(args.repeat, 2)
        if args.sweep == parser.get_default("sweep"):
            args.sweep = "16,32,64,128"
    sweep_T = [int(t) for t in args.sweep.split(",") if t.strip()]
    print(
        f"bench_bank: {platform.machine()}, {os.cpu_count()} cores, "
        f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}, numpy {np.__version__}, "
        f"{args.minutes:g} min at {RATE_HZ:g} Hz, AR order {ORDER}, "
        f"load average {os.getloadavg()[0]:.1f}, commit {revision()}",
        flush=True,
    )
    results: list[SizeResult] = []
    for floors, per_floor in SIZES:
        results.append(measure_size(floors, per_floor, args, sweep_T))

    rows = [r for res in results for r in res.rows]
    print(f"load average at the end {os.getloadavg()[0]:.1f} (a shared machine makes rates noisy)")
    print()
    print_table(rows)
    print(
        "values/s: samples x channels of the record per second; 'one' = the estimator that "
        "leaves out channel 0, 'bank' = all m estimators; statsmodels and the Python loop "
        "ran on the first samples only (per-sample cost, so the rate extrapolates)"
    )
    for res in results:
        m = res.rows[0].channels
        bank_rows = [r for r in res.rows if r.scope == "bank"]
        sm = max(r.values_per_s for r in bank_rows if r.method.startswith("statsmodels"))
        raw = next(r for r in bank_rows if "_bank_outputs" in r.method)
        run = next(r for r in bank_rows if ".run" in r.method)
        verdict = "meets" if raw.values_per_s >= TARGET_SPEEDUP * sm else "MISSES"
        print(
            f"{m:>2} channels: raw bank {raw.values_per_s / sm:.0f}x, detector run "
            f"{run.values_per_s / sm:.0f}x statsmodels -> {verdict} the "
            f">= {TARGET_SPEEDUP:.0f}x target (fit: {res.fit_s:.1f} s, not in the rates)"
        )
    print()
    for res in results:
        for line in res.checks:
            print(f"[{res.rows[0].channels} ch] {line}")
    if sweep_T:
        print()
        print("the bank in the stacked lifted form, by block length T (values/s; build time)")
        header = "".join(f"{T:>10}" for T, _, _ in results[0].sweep)
        print(f"{'channels':<10}{header}{'best T':>9}")
        for res in results:
            cells = "".join(f"{v / 1e6:>8.1f} M" for _, v, _ in res.sweep)
            print(f"{res.rows[0].channels:<10}{cells}{res.best_T:>9}")
            builds = "".join(f"{b * 1e3:>7.0f}ms" for _, _, b in res.sweep)
            print(f"{'  build':<10}{builds}")
        for res in results:
            if res.bank_best is not None:
                raw = next(r for r in res.rows if "_bank_outputs" in r.method)
                print(
                    f"{res.rows[0].channels} ch: raw bank {raw.values_per_s / 1e6:.1f} M values/s "
                    f"({raw.method.split('(')[-1].rstrip(')')}), lifted form "
                    f"{res.bank_best.values_per_s / 1e6:.1f} M values/s at T={res.best_T}"
                )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
