"""Sensor faults injected into a real healthy record: the same verdicts as
``sweep_isolation.py``, on a background the simulator did not make.

The record is SKAB's anomaly-free run of a water-pump test bed (``benchmark/SKAB/data/
anomaly-free/anomaly-free.csv`` of the real-data corpus, 8 sensors at 1 Hz, 9 405 rows
over 2.8 hours, GPL-3.0, read from ``--corpus``, never copied). Real, so unlike the
simulated buildings it is not stationary: the pump warms up over the run (the
thermocouple rises by 2.4 degrees, about 50 of its 400-second standard deviations), its
RMS vibrations creep, one second in 17 is missing. Each case puts one fault on one
sensor from ``--onset`` (a fraction of the record) to its end with ``inject_fault``:

* ``additive``: ``--offset`` x the sensor's standard deviation in the training window,
* ``multiplicative``: a gain of ``--gain``,
* ``drift``: ``--drift`` x that standard deviation per hour,

writes the record as a CSV (its ``datetime`` column and the 8 sensors) in a temporary
directory and runs the whole analysis on it (``pipeline.analyze``, every default
detector) with the first ``--train`` of the record as the healthy window. (The default
window, the first 20 % but at most 10 minutes, holds 600 rows at 1 Hz: too few for the
bank's and the detection filter's calibration, so only the equivalent model would run.)

The untouched record is analyzed first: what it reports is the **background** (the
pump's own slow changes, which the methods, fitted on a stationary healthy window, take
for sensor faults). A finding of a fault case that the background has too (same sensor,
same type, onset within ``--slack`` seconds) is left out of the verdict, which is then
``sweep_isolation.py``'s:

* **right**: exactly one finding beyond the background, on the faulty sensor, of the
  injected type;
* **extra**: that finding plus others beyond the background;
* **wrong**: the faulty sensor's finding is missing or of another type (its type and
  the findings are printed).

The table also counts the cases whose faulty sensor is **named** beyond the background,
whatever the type (isolation apart from classification), and those **flagged**: with any
finding at all, background included, which is what ``--screen`` passes on to every
detector. ``--detectors A,B`` runs only those (a screening's sensitivity on a real
record).

A script, not a timed test (about 3 s a case)::

    python benchmarks/sweep_real_background.py [--corpus DIR] [--onset 0.5]
                                               [--train 0.2] [--offset 1] [--gain 1.2]
                                               [--drift 1] [--channels A,B]
                                               [--detectors A,B]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from collections import Counter
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _corpus import default_corpus  # noqa: E402

from analyzer.pipeline import RunOptions, analyze  # noqa: E402
from analyzer.simulate import inject_fault  # noqa: E402

KINDS = ("additive", "multiplicative", "drift")
MAGNITUDE = {"additive": "offset", "multiplicative": "gain", "drift": "rate_per_s"}
RECORD = Path("benchmark/SKAB/data/anomaly-free/anomaly-free.csv")
DEFAULT_CORPUS = default_corpus()
"""``--corpus``'s default (:func:`_corpus.default_corpus`)."""

Finding = tuple[str, str, float, float | None, dict[str, float]]
"""channel, type, onset s, end s (None: to the end), magnitude."""


def load(corpus: Path) -> tuple[pd.DataFrame, np.ndarray]:
    """The record and each row's seconds from the first."""
    path = corpus / RECORD
    if not path.is_file():
        raise SystemExit(f"sweep_real_background: {path}: not found (give --corpus DIR)")
    frame = pd.read_csv(path, sep=";")
    stamps = pd.to_datetime(frame["datetime"])
    seconds = (stamps - stamps.iloc[0]).dt.total_seconds().to_numpy()
    return frame, seconds


def run_case(
    frame: pd.DataFrame, workdir: Path, train: str, detectors: list[str] | None = None
) -> list[Finding]:
    """The findings of ``analyze`` on ``frame`` written as a CSV (``detectors``: only
    those run, ``--detectors``)."""
    path = workdir / "record.csv"
    frame.to_csv(path, index=False)
    analysis = analyze([path], RunOptions(train=train, detectors=detectors))
    return [
        (f.channel, f.type.value, float(f.onset_s), f.end_s, dict(f.magnitude))
        for f in analysis.findings
    ]


def faulty(
    frame: pd.DataFrame, seconds: np.ndarray, channel: str, kind: str, onset_s: float, size: float
) -> pd.DataFrame:
    """A copy of ``frame`` with the fault on ``channel`` from ``onset_s`` on. The record's
    rows are not evenly spaced (missing seconds): the fault is applied on the rows' own
    times (a drift grows with the time elapsed, not the rows counted)."""
    out = frame.copy()
    y = out[channel].to_numpy(dtype=np.float64)
    if kind == "drift":
        after = seconds >= onset_s
        y = y.copy()
        y[after] += size * (seconds[after] - onset_s)
    else:
        first = int(np.searchsorted(seconds, onset_s))
        y = inject_fault(y, 1.0, kind, float(first), size)
    out[channel] = y
    return out


def beyond(found: list[Finding], background: list[Finding], slack: float) -> list[Finding]:
    """The findings the untouched record does not have (same sensor and type, onset within
    ``slack`` s)."""
    return [
        f
        for f in found
        if not any(f[0] == b[0] and f[1] == b[1] and abs(f[2] - b[2]) <= slack for b in background)
    ]


def verdict(found: list[Finding], channel: str, kind: str) -> str:
    hits = [f for f in found if f[0] == channel and f[1] == kind]
    if not hits:
        return "wrong"
    return "right" if len(found) == 1 else "extra"


def short(found: list[Finding]) -> str:
    return ", ".join(
        f"{c} {t} {o:.0f}-{'end' if e is None else f'{e:.0f}'} "
        + " ".join(f"{k} {v:.4g}" for k, v in m.items())
        for c, t, o, e, m in found
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, default=DEFAULT_CORPUS)
    parser.add_argument("--onset", type=float, default=0.5, help="fault onset, fraction")
    parser.add_argument("--train", type=float, default=0.2, help="healthy window, fraction")
    parser.add_argument("--offset", type=float, default=1.0, help="offset, training std")
    parser.add_argument("--gain", type=float, default=1.2)
    parser.add_argument("--drift", type=float, default=1.0, help="training std per hour")
    parser.add_argument("--slack", type=float, default=300.0, help="background match, s")
    parser.add_argument("--channels", default=None, help="sensors to fault (default: all)")
    parser.add_argument(
        "--detectors", default=None, metavar="A,B", help="run only these (default: the defaults)"
    )
    args = parser.parse_args(argv)
    detectors = args.detectors.split(",") if args.detectors else None
    if not 0.0 < args.train < args.onset < 1.0:
        parser.error("need 0 < --train < --onset < 1")
    frame, seconds = load(args.corpus)
    sensors = [c for c in frame.columns if c != "datetime"]
    chosen = sensors if args.channels is None else args.channels.split(",")
    unknown = sorted(set(chosen) - set(sensors))
    if unknown:
        parser.error(f"--channels: not in the record: {', '.join(unknown)}")
    duration = float(seconds[-1])
    train_end = args.train * duration
    train = f"0:{train_end:.0f}"
    onset = args.onset * duration
    healthy = seconds <= train_end
    print(
        f"sweep_real_background: {RECORD} ({len(frame)} rows, {duration:.0f} s, "
        f"{len(sensors)} sensors), training 0-{train_end:.0f} s, faults from {onset:.0f} s "
        f"to the end: offset {args.offset:g} std, gain {args.gain:g}, drift {args.drift:g} "
        "std per hour" + (f", detectors {args.detectors}" if args.detectors else "")
    )
    tally: dict[str, Counter[str]] = {k: Counter() for k in KINDS}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        background = run_case(frame, work, train, detectors)
        print(f"  background (no fault injected): {short(background) or 'no finding'}")
        for channel in chosen:
            std = float(np.nanstd(frame[channel].to_numpy(dtype=np.float64)[healthy]))
            sizes = {
                "additive": args.offset * std,
                "multiplicative": args.gain,
                "drift": args.drift * std / 3600.0,
            }
            for kind in KINDS:
                case = faulty(frame, seconds, channel, kind, onset, sizes[kind])
                everything = run_case(case, work, train, detectors)
                tally[kind]["flagged"] += bool(everything)  # what a --screen would pass on
                found = beyond(everything, background, args.slack)
                v = verdict(found, channel, kind)
                tally[kind][v] += 1
                tally[kind]["named"] += any(f[0] == channel for f in found)
                print(
                    f"  {channel:22s} {kind:15s} {MAGNITUDE[kind]} {sizes[kind]:<10.4g} "
                    f"{v:6s} {short(found)}"
                )
    print()
    print(
        f"{'fault':15s} {'cases':>5s} {'right':>5s} {'extra':>5s} {'wrong':>5s} {'named':>5s}"
        f" {'flagged':>7s}"
    )
    for kind in KINDS:
        t = tally[kind]
        cases = t["right"] + t["extra"] + t["wrong"]
        print(
            f"{kind:15s} {cases:5d} {t['right']:5d} {t['extra']:5d} {t['wrong']:5d} {t['named']:5d}"
            f" {t['flagged']:7d}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
