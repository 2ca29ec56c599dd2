"""The innovation tests behind each finding, measured against known truth: how often the
healthy stretch before a true onset rejects each test (5 % if the tests' assumptions
held), and how often the after-onset tests point to the right type (``tests_agree``).

For each seed and each layout (``FLOORSxSENSORS``: floors times sensors a floor) it
simulates the building (``--seconds`` at 100 Hz, the default training window), injects
one fault of each kind on one sensor from ``--onset`` s (an offset of 0.5 sd, a gain of
1.3 and one of 0.7, a drift reaching 1 sd in 120 s; the sensor turns with the seed) and
runs ``pipeline.analyze`` with the defaults. Only findings on the faulty sensor, of its
type, whose onset is no later than the truth's (+ 0.05 s) are scored, so their
``before`` stretch is healthy. Every detector's ``before`` counts once per test;
``tests_agree`` is the lead detector's. A script, not a timed test (4 kinds x 3 layouts
x 10 seeds: about 6 minutes)::

    python benchmarks/sweep_evidence.py [--seeds 500:510] [--layouts 4x1,3x2,2x2]
"""

from __future__ import annotations

import argparse
import collections
import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from sweep_scoring import analyzed  # noqa: E402

from analyzer.simulate import inject_fault, simulate_building  # noqa: E402

RATE_HZ = 100.0
TESTS = ("shewhart", "anderson_darling", "cramer_von_mises", "whiteness", "mean", "covariance")
# (label, type, size: sd for additive, sd per s for drift, else gain)
KINDS = (
    ("offset 0.5 sd", "additive", 0.5),
    ("gain 1.3", "multiplicative", 1.3),
    ("gain 0.7", "multiplicative", 0.7),
    ("drift 1 sd / 120 s", "drift", 1.0 / 120.0),
)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="500:510", help="first:stop (default 500:510)")
    ap.add_argument("--layouts", default="4x1,3x2,2x2", help="FLOORSxSENSORS, comma-separated")
    ap.add_argument("--seconds", type=float, default=300.0, help="record length (default 300)")
    ap.add_argument("--onset", type=float, default=180.0, help="fault onset, s (default 180)")
    args = ap.parse_args(argv)
    first, stop = (int(x) for x in args.seeds.split(":"))
    before: dict[str, collections.Counter[str]] = {}
    agree: dict[str, list[int]] = {label: [0, 0] for label, _, _ in KINDS}
    with tempfile.TemporaryDirectory() as tmp:
        for layout in args.layouts.split(","):
            floors, per_floor = (int(x) for x in layout.split("x"))
            counts = before.setdefault(layout, collections.Counter())
            for seed in range(first, stop):
                t, y0, names = simulate_building(
                    floors, args.seconds, RATE_HZ, seed=seed, sensors_per_floor=per_floor
                )
                t_ns = np.round(t * 1e9).astype(np.int64)
                channel = seed % len(names)
                sd = float(y0[: int(0.2 * y0.shape[0]), channel].std())
                for label, kind, size in KINDS:
                    y = y0.copy()
                    scaled = size if kind == "multiplicative" else size * sd
                    y[:, channel] = inject_fault(y[:, channel], RATE_HZ, kind, args.onset, scaled)
                    found = analyzed(Path(tmp), f"{layout}-{seed}-{kind}-{size}", t_ns, y, names)
                    right = [
                        f
                        for f in found
                        if f.channel == names[channel]
                        and f.type.value == kind
                        and f.onset_s <= args.onset + 0.05
                    ]
                    for f in right:
                        if "tests_agree" in f.evidence:
                            agree[label][0] += bool(f.evidence["tests_agree"])
                            agree[label][1] += 1
                        for tests in f.evidence.get("tests", {}).values():
                            if tests.get("before"):
                                counts["stretches"] += 1
                                for name in TESTS:
                                    counts[name] += bool(tests["before"][name]["reject"])
                    print(
                        f"  {layout} seed {seed} {names[channel]} {label}: "
                        f"{len(right)} right of {len(found)}",
                        flush=True,
                    )
    print("healthy stretches before a true onset, share rejected (nominal 5 %):")
    for layout, c in before.items():
        n = c["stretches"]
        shares = ", ".join(f"{k} {c[k]}/{n} ({c[k] / max(n, 1):.0%})" for k in TESTS)
        print(f"  {layout}: {n} stretches: {shares}")
    print("lead detector's tests agree with the (right) type:")
    for label, (yes, n) in agree.items():
        print(f"  {label}: {yes}/{n}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
