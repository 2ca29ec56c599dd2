"""How often the 95 % intervals of findings.json hold the true size and onset.

For each seed and layout it simulates a building (``--layouts``: floors x sensors a floor,
``--seconds`` at 100 Hz, the default training window: the first 20 %), injects one fault
on one sensor (sizes in standard deviations of that sensor over the training window; a
gain is the factor), writes it as CSV and runs ``pipeline.analyze`` with the defaults.
The cases: offsets of 1 and 3 sd, gains of 0.7 and 1.5, drifts of 0.01 and 0.03 sd/s,
each from ``--onset`` s to the record's end.

A fault counts when a finding on its sensor has its type and begins within 2 s of it.
Of those, the table gives the share whose ``magnitude_interval`` holds the true size and
whose ``onset_interval_s`` holds the true onset (of those with one: ``onset null`` counts
the findings whose onset is a bound), and the intervals' median widths. The intervals are
not widened to reach 95 %: a share far below it is the estimator's bias or a too narrow
profile, which README says. A script, not a timed test (3 layouts x 6 cases x 10 seeds:
3-5 minutes on a shared 2-core machine, 2026-12-07)::

    python benchmarks/sweep_intervals.py [--seeds 1:11] [--seconds 200]
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

from analyzer.findings import finding_intervals  # noqa: E402
from analyzer.simulate import inject_fault, simulate_building  # noqa: E402

RATE_HZ = 100.0
SLACK_S = 2.0
KEY = {"additive": "offset", "multiplicative": "gain", "drift": "rate_per_s"}

# (kind, size: sd for additive, sd per s for drift, else the gain)
CASES: dict[str, tuple[str, float]] = {
    "offset 1 sd": ("additive", 1.0),
    "offset 3 sd": ("additive", 3.0),
    "gain 0.7": ("multiplicative", 0.7),
    "gain 1.5": ("multiplicative", 1.5),
    "drift 0.01 sd/s": ("drift", 0.01),
    "drift 0.03 sd/s": ("drift", 0.03),
}


def truth_size(kind: str, size: float, sd: float) -> float:
    """The size findings.json should report: an offset or a rate in channel units, a gain
    as the factor."""
    return size if kind == "multiplicative" else size * sd


def matched(findings: list[Any], channel: str, kind: str, onset: float) -> Any | None:
    """The finding on ``channel`` of type ``kind`` that begins within :data:`SLACK_S` of
    ``onset``, if any."""
    for f in findings:
        if f.channel == channel and f.type.value == kind and abs(f.onset_s - onset) <= SLACK_S:
            return f
    return None


def tally(row: dict[str, list[float]], f: Any, kind: str, size: float, onset: float) -> str:
    """Add a found fault's intervals to its case's ``row``; a line for the log."""
    iv = finding_intervals(f)
    row["found"].append(1.0)
    size_iv = (iv["magnitude_interval"] or {}).get(KEY[kind])
    if size_iv is not None:
        lo, hi = size_iv
        row["size_in"].append(float(lo <= size <= hi))
        row["size_w"].append(hi - lo)
    onset_iv = iv["onset_interval_s"]
    if onset_iv is None:
        row["onset_null"].append(1.0)
    else:
        lo_o, hi_o = onset_iv
        row["onset_in"].append(float(lo_o <= onset <= hi_o))
        row["onset_w"].append(hi_o - lo_o)
    got = f.magnitude.get(KEY[kind], float("nan"))
    return f"size {got:.4g} in {size_iv} (true {size:.4g}); onset {f.onset_s:.2f} in {onset_iv}"


def share(x: list[float]) -> str:
    return f"{np.mean(x):5.2f}" if x else "    -"


def median(x: list[float]) -> str:
    return f"{np.median(x):9.4g}" if x else "        -"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="1:11", help="first:stop (default 1:11)")
    ap.add_argument("--seconds", type=float, default=200.0, help="record length (default 200)")
    ap.add_argument("--onset", type=float, default=100.0, help="fault onset, s (default 100)")
    ap.add_argument(
        "--layouts", default="6x1,4x2,3x1", help="floors x sensors a floor (default 6x1,4x2,3x1)"
    )
    ap.add_argument("--cases", default=",".join(CASES), help="cases to run (default all)")
    args = ap.parse_args(argv)
    first, stop = (int(x) for x in args.seeds.split(":"))
    cases = args.cases.split(",")
    layouts = [tuple(int(v) for v in lay.split("x")) for lay in args.layouts.split(",")]
    keys = ("runs", "found", "size_in", "size_w", "onset_in", "onset_w", "onset_null")
    rows = {c: {k: [] for k in keys} for c in cases}  # type: dict[str, dict[str, list[float]]]
    train = int(0.2 * args.seconds * RATE_HZ)
    with tempfile.TemporaryDirectory() as tmp:
        for floors, per_floor in layouts:
            for seed in range(first, stop):
                t, y0, names = simulate_building(
                    floors, args.seconds, RATE_HZ, seed=seed, sensors_per_floor=per_floor
                )
                t_ns = np.round(t * 1e9).astype(np.int64)
                channel = seed % len(names)
                sd = float(y0[:train, channel].std())
                for case in cases:
                    kind, size = CASES[case]
                    true = truth_size(kind, size, sd)
                    y = y0.copy()
                    y[:, channel] = inject_fault(y[:, channel], RATE_HZ, kind, args.onset, true)
                    label = f"{floors}x{per_floor}-{seed}-{case.replace(' ', '_').replace('/', '')}"
                    findings = analyzed(Path(tmp), label, t_ns, y, names)
                    rows[case]["runs"].append(1.0)
                    f = matched(findings, names[channel], kind, args.onset)
                    line = (
                        "not found" if f is None else tally(rows[case], f, kind, true, args.onset)
                    )
                    print(f"  {floors}x{per_floor} seed {seed:2d} {case:16s}: {line}", flush=True)
    print(
        "\ncase             runs found  size in  median width   onset in  median width (s)  "
        "onset null"
    )
    for case, r in rows.items():
        print(
            f"{case:16s} {len(r['runs']):4d} {len(r['found']):5d}  {share(r['size_in'])}  "
            f"{median(r['size_w'])}      {share(r['onset_in'])}  {median(r['onset_w'])}"
            f"          {len(r['onset_null']):4d}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
