"""Healthy small buildings with one floor's sensor left out: false findings, and what a
fault on the floor next to the missing one still gives.

For each seed it simulates the 5-floor building of Chang et al. (2017) (one sensor a
floor, the default training window: the first 20 %), leaves out each case's sensor,
writes it as CSV and runs ``pipeline.analyze`` with the defaults. The healthy cases
(``--healthy``): all 5 sensors, each floor left out in turn (200 Hz, 60 s), 100 Hz with
5 sensors, and 120 s with s1 left out; a line per case gives the runs with a finding and
the findings (sensor, type, detector, onset). With ``--faults`` the building loses
``--without`` (s3) and ``--on`` (s4) gets, from 30 s to the end, an offset of 0.5 and
1 sd, a gain of 1.2 or a stuck value (its reading at 30 s): a line per fault gives how
many records have a finding on that sensor from 29 s on, and how many are elsewhere. The
default window is quieter than much of the record (its 2-s level reaches 1.6-2.7 times
its mean, the rest up to 11 times: ``analyzer.diagnosis.load``). A script, not a timed
test (about 1 s a record)::

    python benchmarks/sweep_missing_floor.py [--seeds 0:10] [--healthy] [--faults]
                                             [--without s3] [--on s4]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from sweep_scoring import analyzed  # noqa: E402

from analyzer.simulate import inject_fault, simulate_building  # noqa: E402

HEALTHY = [
    ("5 sensors", "", 200.0, 60.0),
    ("s0 out", "s0", 200.0, 60.0),
    ("s1 out", "s1", 200.0, 60.0),
    ("s2 out", "s2", 200.0, 60.0),
    ("s3 out", "s3", 200.0, 60.0),
    ("s4 out", "s4", 200.0, 60.0),
    ("100 Hz 5 sensors", "", 100.0, 60.0),
    ("120 s s1 out", "s1", 200.0, 120.0),
]
"""(label, sensor left out, rate in Hz, length in s)."""

FAULTS = [("offset 0.5 sd", "additive", 0.5), ("offset 1 sd", "additive", 1.0)]
FAULTS += [("gain 1.2", "multiplicative", 1.2), ("stuck", "other", 0.0)]
"""(label, kind, size: in sd of the sensor for an offset, the factor for a gain)."""

ONSET_S = 30.0


def _record(seed: int, drop: str, rate: float, seconds: float) -> tuple[Any, Any, list[str]]:
    t, y, names = simulate_building(5, seconds, rate, seed=seed)
    keep = [i for i, n in enumerate(names) if n != drop]
    return np.round(t * 1e9).astype(np.int64), y[:, keep].copy(), [names[i] for i in keep]


def _faulty(y: Any, names: list[str], rate: float, kind: str, size: float, on: str = "s4") -> Any:
    c = names.index(on)
    x = y[:, c]
    if kind == "additive":
        size *= float(np.std(x[: int(0.2 * x.shape[0])]))
    y[:, c] = inject_fault(x, rate, kind, ONSET_S, size)
    return y


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="0:10", help="first:stop (default 0:10)")
    ap.add_argument("--healthy", action="store_true", help="the healthy cases")
    ap.add_argument("--faults", action="store_true", help="faults on --on, --without left out")
    ap.add_argument("--without", default="s3", help="sensor left out with --faults (s3)")
    ap.add_argument("--on", default="s4", help="faulty sensor with --faults (s4)")
    args = ap.parse_args(argv)
    first, stop = (int(v) for v in args.seeds.split(":"))
    with tempfile.TemporaryDirectory() as tmp:
        if args.healthy or not args.faults:
            for case, (label, drop, rate, seconds) in enumerate(HEALTHY):
                per = []
                for seed in range(first, stop):
                    t_ns, y, names = _record(seed, drop, rate, seconds)
                    found = analyzed(Path(tmp), f"h{case}-{seed}", t_ns, y, names)
                    per.append(
                        [(f.channel, f.type.value, f.detector, round(f.onset_s, 1)) for f in found]
                    )
                print(
                    f"{label:18s} runs with findings {sum(bool(p) for p in per)}/{len(per)}, "
                    f"findings {sum(len(p) for p in per)}  "
                    + "; ".join(f"seed {first + k}: {p}" for k, p in enumerate(per) if p),
                    flush=True,
                )
        if args.faults:
            for label, kind, size in FAULTS:
                hit = elsewhere = 0
                for seed in range(first, stop):
                    t_ns, y, names = _record(seed, args.without, 200.0, 60.0)
                    y = _faulty(y, names, 200.0, kind, size, args.on)
                    found = analyzed(Path(tmp), f"f{seed}-{kind}-{size}", t_ns, y, names)
                    hit += any(f.channel == args.on and f.onset_s >= ONSET_S - 1 for f in found)
                    elsewhere += sum(f.channel != args.on for f in found)
                print(
                    f"{label:14s} {args.on} found in {hit}/{stop - first} ({args.without} left "
                    f"out), findings elsewhere {elsewhere}",
                    flush=True,
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
