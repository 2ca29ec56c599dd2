"""A gain on one sensor of buildings logged at rates far above their modes: how often the
analysis gets it right, against the clock's ratio to the content frequency that
``analyzer/diagnosis/oversampled.py`` measures (above 40 a run without ``--rate`` aligns
the channels at a slower rate, which it names; with ``--rate`` the run notes that rate).

For each rate, floor count and seed it simulates the shear building (one sensor a floor,
``--seconds`` long), measures the content frequency of each channel over the default
training window (the frequency below which 95 % of its power lies; the median over the
channels) and puts a gain of ``--gain`` on ``s1`` from the middle of the record to its
end, writes the record as CSV and runs the whole analysis (``pipeline.analyze``,
defaults). A case is **right** with exactly one finding: on ``s1``, multiplicative, its
onset within 1 s. The table gives every case, the rate it was analyzed at and the share
right by ratio (below 40, 40-80, above 80); ``--at-note`` runs each case again at the
rate a note names (``--rate``'s advice: a run given ``--rate`` whose clock is far above
the content), ``--logged`` each case the run analyzed slower again at its logged rate
(``--rate`` that rate: the default run before it chose the clock). A script, not a timed
test (about 3 minutes for the default grid)::

    python benchmarks/sweep_oversampled.py [--rates 100,200,500,1000] [--floors 3,4,6,8]
                                           [--seeds 1:3] [--gain 0.5] [--seconds 120]
                                           [--at-note] [--logged]
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from analyzer.diagnosis.oversampled import MAX_RATIO, content_frequency  # noqa: E402
from analyzer.pipeline import RunOptions, analyze  # noqa: E402
from analyzer.selection import default_train  # noqa: E402
from analyzer.simulate import inject_fault, simulate_building  # noqa: E402


def right(analysis, onset: float) -> bool:
    f = analysis.findings
    return (
        len(f) == 1
        and f[0].channel == "s1"
        and str(f[0].type) == "multiplicative"
        and abs(f[0].onset_s - onset) < 1.0
    )


def case(
    rate: float, floors: int, seed: int, args, folder: Path
) -> tuple[float, bool, float, str, str]:
    """``(ratio, right, the rate analyzed at, right at the noted rate or "", right at the
    logged rate or "")`` of one record."""
    t, y, names = simulate_building(
        n_floors=floors, duration_s=args.seconds, rate_hz=rate, seed=seed
    )
    rows = int(default_train(args.seconds)[1] * rate)
    ratio = rate / float(
        np.median([content_frequency(y[:rows, j], rate)[0] for j in range(floors)])
    )
    onset = args.seconds / 2
    y[:, 1] = inject_fault(y[:, 1], rate, "multiplicative", onset, args.gain)
    path = folder / f"r{rate:g}_{floors}_{seed}.csv"
    np.savetxt(
        path,
        np.column_stack([t, y]),
        delimiter=",",
        header="time," + ",".join(names),
        comments="",
        fmt="%.9g",
    )
    analysis = analyze([path], RunOptions())
    again = logged = ""
    note = next((n for n in analysis.notes if "aligns the channels" in n), None)
    if args.at_note and note is not None:
        asked = float(re.search(r"--rate (\S+) aligns", note).group(1))
        again = "right" if right(analyze([path], RunOptions(rate=asked)), onset) else "wrong"
    if args.logged and analysis.slowed is not None:
        at_logged = analyze([path], RunOptions(rate=analysis.slowed.rate_hz))
        logged = "right" if right(at_logged, onset) else "wrong"
    return ratio, right(analysis, onset), analysis.rate_hz, again, logged


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rates", default="100,200,500,1000")
    ap.add_argument("--floors", default="3,4,6,8")
    ap.add_argument("--seeds", default="1:3")
    ap.add_argument("--gain", type=float, default=0.5)
    ap.add_argument("--seconds", type=float, default=120.0)
    ap.add_argument("--at-note", action="store_true")
    ap.add_argument("--logged", action="store_true")
    args = ap.parse_args()
    lo, hi = (int(v) for v in args.seeds.split(":"))
    buckets: dict[str, list[bool]] = {f"< {MAX_RATIO}": [], "40-80": [], "> 80": []}
    with tempfile.TemporaryDirectory() as tmp:
        for rate in (float(r) for r in args.rates.split(",")):
            for floors in (int(f) for f in args.floors.split(",")):
                for seed in range(lo, hi):
                    ratio, ok, at, again, logged = case(rate, floors, seed, args, Path(tmp))
                    key = (
                        f"< {MAX_RATIO}"
                        if ratio <= MAX_RATIO
                        else "40-80"
                        if ratio <= 80
                        else "> 80"
                    )
                    buckets[key].append(ok)
                    noted = "noted" if ratio > MAX_RATIO else ""
                    later = f"at the noted rate: {again}" if again else ""
                    if logged:
                        later += f" at the logged rate: {logged}"
                    print(
                        f"{rate:7g} Hz {floors} floors seed {seed}: ratio {ratio:6.1f} "
                        f"at {at:5g} Hz {'right' if ok else 'WRONG':5} {noted:5} {later}",
                        flush=True,
                    )
    print("\nratio      right / cases")
    for key, oks in buckets.items():
        print(f"{key:8} {sum(oks):5d} / {len(oks)}")


if __name__ == "__main__":
    main()
