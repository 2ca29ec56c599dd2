"""Which sensor, which type, and nothing else: a sweep of single faults on simulated
buildings, end to end.

For each seed it simulates a shear building (``simulate_building``, ``--floors`` floors x
2 sensors, ``--minutes`` at 100 Hz), puts one fault on a sensor drawn at random (from the
seed) from 60 % of the record to its end, in turn an offset (half the sensor's standard
deviation), a gain (1.3) and a drift (one standard deviation per 10 minutes), writes the
record as an MCAP file, runs the whole analysis on it (``pipeline.analyze``, default
settings: the first 20 % as training window, every default detector) and compares the
findings with the truth:

* **right**: exactly one finding, on the faulty sensor, of the injected type;
* **extra**: the faulty sensor's finding is there with its type, plus other findings;
* **wrong**: the faulty sensor's finding is missing or of another type.

It prints one line per case and a table per fault type. A script, not a timed test (a
20-minute 16-channel case takes ~7 s)::

    python benchmarks/sweep_isolation.py [--seeds 0:45] [--floors 8] [--minutes 20]
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
ONSET_FRACTION = 0.6


def case(seed: int, floors: int, minutes: float, folder: Path) -> tuple[str, str, str, list]:
    """``(kind, faulty channel, verdict, findings)`` of one seed."""
    rng = np.random.default_rng(1000 + seed)
    duration = 60.0 * minutes
    t, Y, names = simulate_building(floors, duration, RATE_HZ, seed=seed, sensors_per_floor=2)
    k = int(rng.integers(Y.shape[1]))
    kind = KINDS[seed % len(KINDS)]
    sd = float(np.std(Y[:, k]))
    size = {"additive": 0.5 * sd, "multiplicative": 1.3, "drift": sd / 600.0}[kind]
    onset = ONSET_FRACTION * duration
    Y[:, k] = inject_fault(Y[:, k], RATE_HZ, kind, onset, size)
    path = folder / f"building_{seed}.mcap"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(
        path, "mcap", t_ns, {n: Y[:, i] for i, n in enumerate(names)}, layout="multiarray"
    )
    try:
        analysis = analyze([str(path)], RunOptions())
    finally:
        path.unlink()
    found = [(f.channel, f.type.value, round(f.onset_s, 2)) for f in analysis.findings]
    faulty = f"/data.data[{k}]"
    mine = [f for f in found if f[0] == faulty and f[1] == kind]
    verdict = "right" if mine and len(found) == 1 else "extra" if mine else "wrong"
    return kind, faulty, verdict, found


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="0:45", help="first:stop (default 0:45)")
    ap.add_argument("--floors", type=int, default=8, help="floors, 2 sensors each (default 8)")
    ap.add_argument("--minutes", type=float, default=20.0, help="record length (default 20)")
    args = ap.parse_args(argv)
    first, stop = (int(x) for x in args.seeds.split(":"))
    tally: dict[str, Counter[str]] = {k: Counter() for k in KINDS}
    print(
        f"sweep_isolation: {2 * args.floors} channels, {args.minutes:g} min at "
        f"{RATE_HZ:g} Hz, fault from {ONSET_FRACTION:.0%} of the record, seeds {args.seeds}",
        flush=True,
    )
    with tempfile.TemporaryDirectory(prefix="sweep_isolation_") as tmp:
        for seed in range(first, stop):
            kind, faulty, verdict, found = case(seed, args.floors, args.minutes, Path(tmp))
            tally[kind][verdict] += 1
            print(f"  seed {seed:4d} {kind:<15} {faulty:<16} {verdict:<6} {found}", flush=True)
    print(f"\n{'fault':<16}{'cases':>6}{'right':>7}{'extra':>7}{'wrong':>7}")
    for kind in KINDS:
        c = tally[kind]
        print(f"{kind:<16}{sum(c.values()):>6}{c['right']:>7}{c['extra']:>7}{c['wrong']:>7}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
