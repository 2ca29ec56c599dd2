"""A sensor that clips (saturates) from part-way through a record: how many findings the
analysis reports, on which sensors, and whether it names the clipping.

For each seed it simulates the shear building of ``sweep_isolation.py`` (``--floors`` x 2
accelerometers, ``--minutes`` at 100 Hz), clips one sensor drawn from the seed at
``--limit`` times its largest absolute reading, from ``--onset`` of the record to its end
(``numpy.clip``: the reading held at the limit while the response is beyond it), writes
the record as CSV and runs the whole analysis on it (``pipeline.analyze``, defaults). A
case is **right** with exactly one finding, on the clipped sensor, that names the
clipping (``magnitude.clipped_high`` or ``clipped_low``); the table also gives the
findings on the clipped sensor and on the others. A script, not a timed test (a
20-minute 6-channel case takes ~4 s)::

    python benchmarks/sweep_clipping.py [--floors 3] [--seeds 0:9] [--limit 0.5]
                                        [--onset 0.6] [--minutes 20]
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

from analyzer.pipeline import RunOptions, analyze  # noqa: E402
from analyzer.simulate import simulate_building  # noqa: E402
from analyzer.writers import write_archive  # noqa: E402

RATE_HZ = 100.0


def case(seed: int, floors: int, minutes: float, limit: float, onset: float, folder: Path):
    """``(clipped channel, share of readings clipped, findings)`` of one seed."""
    t, Y, _ = simulate_building(floors, 60.0 * minutes, RATE_HZ, seed=seed, sensors_per_floor=2)
    k = int(np.random.default_rng(2000 + seed).integers(Y.shape[1]))
    on = int(onset * len(t))
    lim = limit * float(np.max(np.abs(Y[:, k])))
    Y[on:, k] = np.clip(Y[on:, k], -lim, lim)
    share = float(np.mean(np.abs(Y[on:, k]) >= lim))
    path = folder / f"clip_{seed}.csv"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {f"s{i}": Y[:, i] for i in range(Y.shape[1])})
    try:
        analysis = analyze([str(path)], RunOptions())
    finally:
        path.unlink()
    return f"s{k}", share, analysis.findings


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--floors", type=int, default=3)
    ap.add_argument("--seeds", default="0:9", help="first:stop (default 0:9)")
    ap.add_argument("--limit", type=float, default=0.5, help="x the largest |reading|")
    ap.add_argument("--onset", type=float, default=0.6, help="fraction of the record")
    ap.add_argument("--minutes", type=float, default=20.0)
    args = ap.parse_args(argv)
    first, stop = (int(x) for x in args.seeds.split(":"))
    right = on_it = others = 0
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(first, stop):
            channel, share, found = case(
                seed, args.floors, args.minutes, args.limit, args.onset, Path(tmp)
            )
            mine = [f for f in found if f.channel == channel]
            rest = [f for f in found if f.channel != channel]
            named = [f for f in mine if {"clipped_high", "clipped_low"} & set(f.magnitude)]
            ok = len(found) == 1 and bool(named)
            right += ok
            on_it += len(mine)
            others += len(rest)
            print(
                f"  seed {seed:3d} {channel:4s} clipped {share:6.1%}  "
                f"{'right' if ok else 'wrong':5s}  on it {len(mine):2d}, others {len(rest):2d}"
                + (f" ({', '.join(sorted({f.channel for f in rest}))})" if rest else "")
            )
    n = stop - first
    print(
        f"\n{args.floors * 2} channels, limit {args.limit:g} x peak from {args.onset:.0%}: "
        f"right {right} of {n}; findings on the clipped sensor {on_it}, on others {others}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
