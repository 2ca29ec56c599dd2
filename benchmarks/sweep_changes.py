"""Faults that change while they last, and faults back to back on one sensor: whether
each part is reported, on its sensor, with its type, onset, end and size.

For each seed it simulates the 6-floor building of ``sweep_isolation.py`` (one sensor a
floor, ``--seconds`` at 100 Hz, the default training window: the first 20 %), injects
each case's faults on one sensor (sizes in standard deviations of that sensor), writes
it as CSV and runs ``pipeline.analyze`` with the defaults. The cases:

* ``drop``: an offset of 3 sd from 100 s, 1 sd from 200 s to the end;
* ``rise``: 1 sd from 100 s, 3 sd from 200 s;
* ``flip``: +2 sd from 100 to 180 s, -2 sd from 180 to 260 s;
* ``offset-gain``: +2 sd from 100 to 160 s, a gain of 1.8 from 160 to 220 s;
* ``sawtooth``: a drift of 0.05 sd/s from 100 to 160 s, a new one from 160 to 220 s;
* controls, one fault each: an offset of 2 sd, a gain of 1.5 (from 120 to 200 s), a
  drift of 0.01 sd/s from 100 s; and ``healthy``.

A part is **right** when a finding on its sensor has its type, its onset within 2 s
and its end within 2 s (or both lasting to the record's end), and **found** when a
finding on its sensor begins within 2 s of it; findings that match no part are
**extras**. A script, not a timed test (6 seeds: about 2 minutes)::

    python benchmarks/sweep_changes.py [--seeds 1:7] [--seconds 300]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from sweep_scoring import analyzed, print_totals, score, shown, tally  # noqa: E402

from analyzer.simulate import inject_fault, simulate_building  # noqa: E402

RATE_HZ = 100.0
FLOORS = 6
SLACK_S = 2.0

# (kind, onset s, end s or None, size: sd for additive, sd per s for drift, else gain),
# applied in turn to one sensor; each is a part the analysis should report
CASES: dict[str, list[tuple[str, float, float | None, float]]] = {
    "drop": [("additive", 100.0, 200.0, 3.0), ("additive", 200.0, None, 1.0)],
    "rise": [("additive", 100.0, 200.0, 1.0), ("additive", 200.0, None, 3.0)],
    "flip": [("additive", 100.0, 180.0, 2.0), ("additive", 180.0, 260.0, -2.0)],
    "offset-gain": [("additive", 100.0, 160.0, 2.0), ("multiplicative", 160.0, 220.0, 1.8)],
    "sawtooth": [("drift", 100.0, 160.0, 0.05), ("drift", 160.0, 220.0, 0.05)],
    "offset": [("additive", 120.0, 200.0, 2.0)],
    "gain": [("multiplicative", 120.0, 200.0, 1.5)],
    "drift": [("drift", 100.0, None, 0.01)],
    "healthy": [],
}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="1:7", help="first:stop (default 1:7)")
    ap.add_argument("--seconds", type=float, default=300.0, help="record length (default 300)")
    ap.add_argument("--cases", default=",".join(CASES), help="cases to run (default all)")
    args = ap.parse_args(argv)
    first, stop = (int(x) for x in args.seeds.split(":"))
    cases = args.cases.split(",")
    totals = {c: [0, 0, 0, 0] for c in cases}  # parts, right, found, extras
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(first, stop):
            t, y0, names = simulate_building(FLOORS, args.seconds, RATE_HZ, seed=seed)
            t_ns = np.round(t * 1e9).astype(np.int64)
            channel = seed % FLOORS
            sd = float(y0[:, channel].std())
            for case in cases:
                parts = CASES[case]
                y = y0.copy()
                for kind, onset, end, size in parts:
                    scaled = size if kind == "multiplicative" else size * sd
                    y[:, channel] = inject_fault(y[:, channel], RATE_HZ, kind, onset, scaled, end)
                began = time.perf_counter()
                findings = analyzed(Path(tmp), f"{case}-{seed}", t_ns, y, names)
                truth = [(names[channel], kind, onset, end) for kind, onset, end, _ in parts]
                right, found, extras = score(findings, truth, SLACK_S)
                tally(totals[case], len(parts), (right, found, extras))
                print(
                    f"  {case:12s} seed {seed:2d} {names[channel]}: right {right}/{len(parts)}, "
                    f"extras {extras}  {time.perf_counter() - began:4.1f} s  [{shown(findings)}]",
                    flush=True,
                )
    print_totals(totals, "parts")
    return 0


if __name__ == "__main__":
    sys.exit(main())
