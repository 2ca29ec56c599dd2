"""A slow drift's rate as reported: each detector's and the finding's, over the truth.

For each seed it simulates the 5-floor building of Chang et al. (2017) (one sensor a
floor, ``--seconds`` at ``--rate`` Hz, the default training window: the first 20 %) and,
for each drift rate of ``--drifts`` (in RMS of the sensor per second), injects a drift
from ``--onset`` s to the end on sensor ``(seed + k) % 5`` (``k``: the rate's place, so
ten seeds put each rate on every floor twice), writes it as CSV and runs
``pipeline.analyze`` with the defaults. A line per record gives the finding on the
drifting sensor (type, onset, the detector that leads it) with its rate over the truth,
and each of its detectors' drift rates over the truth (``*``: the detector did not
confirm the sensor, evidence ``isolated: false``); the table, per detector, the median,
least and largest ratio and how many are within 25 % of 1. A script, not a timed test
(10 seeds, 4 rates, 200 Hz: about 4 minutes)::

    python benchmarks/sweep_drift_rate.py [--seeds 1:11] [--drifts 0.005,0.01,0.02,0.05]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from sweep_scoring import analyzed  # noqa: E402

from analyzer.simulate import inject_fault, simulate_building  # noqa: E402

FLOORS = 5
WITHIN = 0.25


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="1:11", help="first:stop (default 1:11)")
    ap.add_argument("--drifts", default="0.005,0.01,0.02,0.05", help="RMS per s, comma-separated")
    ap.add_argument("--rate", type=float, default=200.0, help="sampling rate, Hz (default 200)")
    ap.add_argument("--seconds", type=float, default=300.0, help="record length (default 300)")
    ap.add_argument("--onset", type=float, default=180.0, help="drift onset, s (default 180)")
    args = ap.parse_args(argv)
    first, stop = (int(x) for x in args.seeds.split(":"))
    drifts = [float(x) for x in args.drifts.split(",")]
    ratios: dict[str, list[float]] = {}
    records = missed = extras = 0
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(first, stop):
            t, y0, names = simulate_building(FLOORS, args.seconds, args.rate, seed=seed)
            t_ns = np.round(t * 1e9).astype(np.int64)
            for k, drift in enumerate(drifts):
                channel = (seed + k) % FLOORS
                truth = drift * float(np.sqrt(np.mean(y0[:, channel] ** 2)))
                y = y0.copy()
                y[:, channel] = inject_fault(y[:, channel], args.rate, "drift", args.onset, truth)
                findings = analyzed(Path(tmp), f"{seed}-{k}", t_ns, y, names)
                records += 1
                mine = [f for f in findings if f.channel == names[channel]]
                extras += len(findings) - min(1, len(mine))
                head = f"  seed {seed:2d} {names[channel]} {drift:.3f} sd/s:"
                if not mine:
                    missed += 1
                    print(f"{head} no finding  [{len(findings)} elsewhere]", flush=True)
                    continue
                f = mine[0]
                lead = f.magnitude.get("rate_per_s", float("nan")) / truth
                ratios.setdefault("finding", []).append(lead)
                parts = []
                for e in f.events:
                    if e.type.value != "drift":
                        continue
                    r = e.magnitude["rate_per_s"] / truth
                    ratios.setdefault(e.detector, []).append(r)
                    mark = "*" if e.evidence.get("isolated") is False else ""
                    parts.append(f"{e.detector} {r:.3f}{mark}")
                print(
                    f"{head} {f.type.value} from {f.onset_s:.1f} s, {f.detector} leads: "
                    f"{lead:.3f}  [{', '.join(parts)}]  {len(findings) - 1} elsewhere",
                    flush=True,
                )
    print(
        f"\n{records} records, {missed} without a finding on the drifting sensor, {extras} extras"
    )
    print(f"{'rate / truth':18s}   n  median   least  largest  within")
    for name, v in ratios.items():
        a = np.array(v)
        near = int(np.sum(np.abs(a - 1.0) <= WITHIN))
        print(
            f"{name:18s} {a.size:3d} {np.median(a):7.3f} {a.min():7.3f} {a.max():8.3f} "
            f"{near:4d}/{a.size}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
