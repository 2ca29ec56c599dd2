"""Two faulty sensors whose faults overlap in time: whether each is reported, on its
sensor, with its type, onset and end (the end of the first not taken for the second's).

For each seed it simulates the 6-floor building of ``sweep_isolation.py`` (one sensor a
floor, ``--seconds`` at 100 Hz, the default training window: the first 20 %), puts each
case's faults on the seed's sensor and on another (sizes in standard deviations of each
sensor), writes it as CSV and runs ``pipeline.analyze`` with the defaults. The cases
(the first sensor, then the one 3 floors up, or the next floor's for ``neighbour``):

* ``overlap``: an offset of 2 sd from 100 to 200 s, and one from 150 to 250 s;
* ``abut``: 2 sd from 100 to 200 s, and from 200 to 260 s;
* ``nested``: 2 sd from 100 to 250 s, and from 150 to 200 s;
* ``gain-offset``: a gain of 1.5 from 100 to 200 s, an offset of 2 sd from 150 to 250 s;
* ``drift-offset``: a drift of 0.02 sd/s from 100 to 200 s, the offset from 150 to 250 s;
* ``neighbour``: ``overlap`` on the next floor's sensor.

A fault is **right** when a finding on its sensor has its type, its onset within 2 s
and its end within 2 s, and **found** when a finding on its sensor begins within 2 s of
it; findings that match no fault are **extras**. A script, not a timed test (10 seeds:
about 6 minutes)::

    python benchmarks/sweep_two_faults.py [--seeds 1:11] [--cases overlap,abut]
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
SECONDS = 300.0
SLACK_S = 2.0

# (floors up from the seed's sensor, kind, onset s, end s, size: sd, sd per s, or gain)
CASES: dict[str, list[tuple[int, str, float, float, float]]] = {
    "overlap": [(0, "additive", 100.0, 200.0, 2.0), (3, "additive", 150.0, 250.0, 2.0)],
    "abut": [(0, "additive", 100.0, 200.0, 2.0), (3, "additive", 200.0, 260.0, 2.0)],
    "nested": [(0, "additive", 100.0, 250.0, 2.0), (3, "additive", 150.0, 200.0, 2.0)],
    "gain-offset": [
        (0, "multiplicative", 100.0, 200.0, 1.5),
        (3, "additive", 150.0, 250.0, 2.0),
    ],
    "drift-offset": [(0, "drift", 100.0, 200.0, 0.02), (3, "additive", 150.0, 250.0, 2.0)],
    "neighbour": [(0, "additive", 100.0, 200.0, 2.0), (1, "additive", 150.0, 250.0, 2.0)],
}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="1:11", help="first:stop (default 1:11)")
    ap.add_argument("--cases", default=",".join(CASES), help="cases to run (default all)")
    args = ap.parse_args(argv)
    first, stop = (int(x) for x in args.seeds.split(":"))
    cases = args.cases.split(",")
    totals = {c: [0, 0, 0, 0] for c in cases}  # faults, right, found, extras
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(first, stop):
            t, y0, names = simulate_building(FLOORS, SECONDS, RATE_HZ, seed=seed)
            t_ns = np.round(t * 1e9).astype(np.int64)
            for case in cases:
                faults = [
                    ((seed + up) % FLOORS, kind, onset, end, size)
                    for up, kind, onset, end, size in CASES[case]
                ]
                y = y0.copy()
                for j, kind, onset, end, size in faults:
                    scaled = size if kind == "multiplicative" else size * float(y0[:, j].std())
                    y[:, j] = inject_fault(y[:, j], RATE_HZ, kind, onset, scaled, end)
                began = time.perf_counter()
                findings = analyzed(Path(tmp), f"{case}-{seed}", t_ns, y, names)
                truth = [(names[j], kind, onset, end) for j, kind, onset, end, _ in faults]
                right, found, extras = score(findings, truth, SLACK_S)
                tally(totals[case], len(faults), (right, found, extras))
                print(
                    f"  {case:12s} seed {seed:2d} {names[faults[0][0]]}+{names[faults[1][0]]}: "
                    f"right {right}/{len(faults)}, extras {extras}  "
                    f"{time.perf_counter() - began:4.1f} s  [{shown(findings)}]",
                    flush=True,
                )
    print_totals(totals, "faults")
    return 0


if __name__ == "__main__":
    sys.exit(main())
