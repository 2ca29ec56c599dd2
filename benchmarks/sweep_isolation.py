"""Which sensor, which type, and nothing else: a sweep of single faults on simulated
buildings, end to end.

For each seed it simulates a shear building (``simulate_building``, ``--floors`` floors x
2 sensors, ``--minutes`` at 100 Hz), puts one fault on a sensor drawn at random (from the
seed) from 60 % of the record to its end (``--until F``: to ``F`` of the record), in
turn an offset (half the sensor's standard deviation), a gain (1.3) and a drift (one
standard deviation per 10 minutes), each scaled by ``--scale``, writes the
record as an MCAP file, runs the whole analysis on it (``pipeline.analyze``, default
settings: the first 20 % as training window, every default detector) and compares the
findings with the truth:

* **right**: exactly one finding, on the faulty sensor, of the injected type;
* **extra**: the faulty sensor's finding is there with its type, plus other findings;
* **wrong**: the faulty sensor's finding is missing or of another type.

With ``--until`` a right case's reported end is compared with the injected one as well
(a fault reported as lasting to the end of the record is **open**), and the table gives
the onset and end errors.

It prints one line per case and a table per fault type. A script, not a timed test (a
20-minute 16-channel case takes ~7 s)::

    python benchmarks/sweep_isolation.py [--seeds 0:45] [--floors 8] [--minutes 20]
                                         [--until F] [--scale S]
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

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from analyzer.pipeline import RunOptions, analyze  # noqa: E402
from analyzer.simulate import inject_fault, simulate_building  # noqa: E402
from analyzer.writers import write_archive  # noqa: E402

RATE_HZ = 100.0
KINDS = ("additive", "multiplicative", "drift")
MAGNITUDE = {"additive": "offset", "multiplicative": "gain", "drift": "rate_per_s"}
ONSET_FRACTION = 0.6


def case(
    seed: int, floors: int, minutes: float, folder: Path, until: float | None, scale: float
) -> tuple[str, str, str, list, tuple[float, float, float] | None]:
    """``(kind, faulty channel, verdict, findings, errors)`` of one seed; ``errors``: of
    the faulty sensor's finding, when it is there, its onset and end errors in s (end
    error NaN for an open finding or a fault that lasts to the end) and its size's
    relative error (a gain's departure from 1)."""
    rng = np.random.default_rng(1000 + seed)
    duration = 60.0 * minutes
    t, Y, names = simulate_building(floors, duration, RATE_HZ, seed=seed, sensors_per_floor=2)
    k = int(rng.integers(Y.shape[1]))
    kind = KINDS[seed % len(KINDS)]
    sd = float(np.std(Y[:, k]))
    size = {
        "additive": 0.5 * sd * scale,
        "multiplicative": 1.0 + 0.3 * scale,
        "drift": sd / 600.0 * scale,
    }[kind]
    onset = ONSET_FRACTION * duration
    end = None if until is None else until * duration
    Y[:, k] = inject_fault(Y[:, k], RATE_HZ, kind, onset, size, end)
    path = folder / f"building_{seed}.mcap"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(
        path, "mcap", t_ns, {n: Y[:, i] for i, n in enumerate(names)}, layout="multiarray"
    )
    try:
        analysis = analyze([str(path)], RunOptions())
    finally:
        path.unlink()
    found = [
        (
            f.channel,
            f.type.value,
            round(f.onset_s, 2),
            None if f.end_s is None else round(f.end_s, 2),
        )
        for f in analysis.findings
    ]
    faulty = f"/data.data[{k}]"
    mine = [
        (row, f)
        for row, f in zip(found, analysis.findings, strict=True)
        if f.channel == faulty and f.type.value == kind
    ]
    verdict = "right" if mine and len(found) == 1 else "extra" if mine else "wrong"
    errors = None
    if mine:
        (_, _, got_onset, got_end), finding = mine[0]
        late = float("nan") if end is None or got_end is None else got_end - end
        size_found = finding.magnitude.get(MAGNITUDE[kind], float("nan"))
        if kind == "multiplicative":  # the gain's departure from 1
            size_found, size = size_found - 1.0, size - 1.0
        errors = (got_onset - onset, late, size_found / size - 1.0)
        if verdict == "right" and end is not None and got_end is None:
            verdict = "open"
    return kind, faulty, verdict, found, errors


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="0:45", help="first:stop (default 0:45)")
    ap.add_argument("--floors", type=int, default=8, help="floors, 2 sensors each (default 8)")
    ap.add_argument("--minutes", type=float, default=20.0, help="record length (default 20)")
    ap.add_argument(
        "--until", type=float, default=None, help="fault ends at this fraction of the record"
    )
    ap.add_argument("--scale", type=float, default=1.0, help="fault size factor (default 1)")
    args = ap.parse_args(argv)
    if args.until is not None and not ONSET_FRACTION < args.until <= 1.0:
        ap.error(f"--until: {args.until} is not after the onset ({ONSET_FRACTION}) and <= 1")
    first, stop = (int(x) for x in args.seeds.split(":"))
    tally: dict[str, Counter[str]] = {k: Counter() for k in KINDS}
    errs: dict[str, list[tuple[float, float, float]]] = {k: [] for k in KINDS}
    span = "its end" if args.until is None else f"{args.until:.0%}"
    print(
        f"sweep_isolation: {2 * args.floors} channels, {args.minutes:g} min at "
        f"{RATE_HZ:g} Hz, fault from {ONSET_FRACTION:.0%} of the record to {span}, "
        f"size x{args.scale:g}, seeds {args.seeds}",
        flush=True,
    )
    with tempfile.TemporaryDirectory(prefix="sweep_isolation_") as tmp:
        for seed in range(first, stop):
            kind, faulty, verdict, found, e = case(
                seed, args.floors, args.minutes, Path(tmp), args.until, args.scale
            )
            tally[kind][verdict] += 1
            if e is not None:
                errs[kind].append(e)
            print(f"  seed {seed:4d} {kind:<15} {faulty:<16} {verdict:<6} {found}", flush=True)
    print(
        f"\n{'fault':<16}{'cases':>6}{'right':>7}{'open':>6}{'extra':>7}{'wrong':>7}"
        f"{'onset err s':>16}{'end err s':>16}{'size err %':>16}"
    )
    print(f"{'':<43}{'(median, max |.|)':>48}")
    for kind in KINDS:
        c = tally[kind]
        e = np.array(errs[kind], dtype=float).reshape(-1, 3)
        e[:, 2] *= 100.0
        cols = []
        for j in (0, 1, 2):
            v = e[np.isfinite(e[:, j]), j]
            cols.append(f"{np.median(v):+.1f}, {np.max(np.abs(v)):.1f}" if v.size else "-")
        print(
            f"{kind:<16}{sum(c.values()):>6}{c['right']:>7}{c['open']:>6}{c['extra']:>7}"
            f"{c['wrong']:>7}{cols[0]:>16}{cols[1]:>16}{cols[2]:>16}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
