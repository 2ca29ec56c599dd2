"""How often a finding of each evidence label (findings.json's ``evidence_label``:
:mod:`analyzer.evidence_label`) is right: on a faulty sensor, with that sensor's injected
type, over the fault's time (within 2 s), against every other finding (another sensor,
another type, a healthy record's, a load change's).

The records come from the sweeps that make right and wrong findings (all simulated
buildings at 100 Hz, analyzed as CSV with the defaults: ``pipeline.analyze``, the first
20 % as training window):

* ``changes``: the cases of ``sweep_changes.py`` (faults that change while they last, back
  to back, the controls, a healthy record; 6 floors, 300 s);
* ``two``: the cases of ``sweep_two_faults.py`` (two faulty sensors overlapping in time);
* ``limit``: single faults near the detection limit, as the ux54 audit measured them
  (README, *Below the swept sizes*: 300 s, the fault from 180 s to the end on the seed's
  sensor, 4 floors x 1 and 3 floors x 2 sensors): offsets of 0.03, 0.06 and 0.5 sd,
  gains of 0.9, 1.05 and 1.3, a drift reaching 0.2 sd by the end; and gains of 0.7 and
  1.3 on the ground floor of 4 floors x 1, whose alarms fall on the floors above;
* ``eov``: the load changes of ``sweep_eov.py`` on healthy sensors (``burst3``,
  ``burst10``, ``quiet``, ``rise2``; 3 floors x 2, 10 minutes) and the same with its
  control offset of 2 sd (``--fault``): findings that are the load's change, not a
  sensor's fault, beside right ones.

Every finding is written, with what its label is made of, one JSON object a line to
``--out`` (the label is computed again from those lines by :func:`table` when the rule
changes: ``--table FILE`` prints the table without running anything). A script, not a
timed test (the default seeds: about 8 minutes on one core)::

    python benchmarks/sweep_evidence_label.py [--families changes,two,limit,eov]
        [--seeds 1:4] [--out /tmp/labels.jsonl] [--table FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import sweep_changes  # noqa: E402
import sweep_eov  # noqa: E402
import sweep_two_faults  # noqa: E402

from analyzer.evidence_label import LABELS, label_of  # noqa: E402
from analyzer.findings import findings_document  # noqa: E402
from analyzer.pipeline import RunOptions, analyze  # noqa: E402
from analyzer.simulate import inject_fault, simulate_building  # noqa: E402
from analyzer.writers import write_archive  # noqa: E402

RATE_HZ = 100.0
SLACK_S = 2.0

Part = tuple[str, str, float, "float | None"]
"""An injected fault: channel, type, onset s, end s (None: to the end)."""

LIMIT: dict[str, tuple[str, float]] = {
    "offset 0.03 sd": ("additive", 0.03),
    "offset 0.06 sd": ("additive", 0.06),
    "offset 0.5 sd": ("additive", 0.5),
    "gain 0.9": ("multiplicative", 0.9),
    "gain 1.05": ("multiplicative", 1.05),
    "gain 1.3": ("multiplicative", 1.3),
    "drift 0.2 sd": ("drift", 0.2),
}
"""The near-limit faults (type, size: sd, gain, or the sd a drift reaches by the end)."""
LIMIT_LAYOUTS = ((4, 1), (3, 2))
GROUND = {"ground gain 0.7": 0.7, "ground gain 1.3": 1.3}
"""Gains on the ground floor of 4 floors x 1 sensor, estimated poorly from the floors
above: their alarms fall on the floors estimated from it (README, *Below the swept
sizes*)."""
EOV_CASES = ("burst3", "burst10", "quiet", "rise2")


def right(fault: dict[str, Any], truth: Sequence[Part]) -> bool:
    """Whether ``fault`` (a findings.json fault) is on a faulty channel with the type of
    a part injected there whose time (within :data:`SLACK_S`) it overlaps."""
    a0 = float(fault["onset_s"])
    a1 = float("inf") if fault.get("end_s") is None else float(fault["end_s"])
    for channel, kind, onset, end in truth:
        b1 = float("inf") if end is None else end
        if (
            channel == fault["channel"]
            and kind == fault["type"]
            and a0 <= b1 + SLACK_S
            and onset - SLACK_S <= a1
        ):
            return True
    return False


def rows(
    tmp: Path,
    family: str,
    case: str,
    seed: int,
    t: np.ndarray,
    y: np.ndarray,
    names: Sequence[str],
    truth: Sequence[Part],
) -> list[dict[str, Any]]:
    """Each finding of the record, as findings.json gives it, with whether it is right."""
    path = tmp / f"{family}-{case.replace(' ', '_')}-{seed}.csv"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: y[:, i] for i, n in enumerate(names)})
    work = tmp / f"work-{path.stem}"
    work.mkdir()
    try:
        analysis = analyze([str(path)], RunOptions(), work)
    finally:
        path.unlink()
    doc = findings_document(analysis)
    out = []
    for f in doc["faults"]:
        ev = f.get("evidence") or {}
        out.append(
            {
                "family": family,
                "case": case,
                "seed": seed,
                "channel": f["channel"],
                "type": f["type"],
                "onset_s": f["onset_s"],
                "right": right(f, truth),
                "detectors": list(ev.get("detectors") or [f["detector"]]),
                "size_relative": f.get("size_relative"),
                "confidence": f.get("confidence"),
                "tests_agree": ev.get("tests_agree"),
                "caution": bool(f.get("caution")),
                "level_change": f.get("level_change") or [],
                "label": f.get("evidence_label"),
            }
        )
    return out


def changes(seeds: range) -> Iterator[tuple[str, str, int, Any, Any, Any, list[Part]]]:
    for seed in seeds:
        t, y0, names = simulate_building(sweep_changes.FLOORS, 300.0, RATE_HZ, seed=seed)
        channel = seed % sweep_changes.FLOORS
        sd = float(y0[:, channel].std())
        for case, parts in sweep_changes.CASES.items():
            y = y0.copy()
            for kind, onset, end, size in parts:
                scaled = size if kind == "multiplicative" else size * sd
                y[:, channel] = inject_fault(y[:, channel], RATE_HZ, kind, onset, scaled, end)
            truth = [(names[channel], k, on, end) for k, on, end, _ in parts]
            yield "changes", case, seed, t, y, names, truth


def two(seeds: range) -> Iterator[tuple[str, str, int, Any, Any, Any, list[Part]]]:
    floors = sweep_two_faults.FLOORS
    for seed in seeds:
        t, y0, names = simulate_building(floors, sweep_two_faults.SECONDS, RATE_HZ, seed=seed)
        for case, spec in sweep_two_faults.CASES.items():
            y = y0.copy()
            truth: list[Part] = []
            for up, kind, onset, end, size in spec:
                j = (seed + up) % floors
                scaled = size if kind == "multiplicative" else size * float(y0[:, j].std())
                y[:, j] = inject_fault(y[:, j], RATE_HZ, kind, onset, scaled, end)
                truth.append((names[j], kind, onset, end))
            yield "two", case, seed, t, y, names, truth


def limit(seeds: range) -> Iterator[tuple[str, str, int, Any, Any, Any, list[Part]]]:
    for floors, per in LIMIT_LAYOUTS:
        for seed in seeds:
            s = 400 + seed
            t, y0, names = simulate_building(floors, 300.0, RATE_HZ, seed=s, sensors_per_floor=per)
            k = int(np.random.default_rng(s).integers(y0.shape[1]))
            sd = float(y0[: int(60 * RATE_HZ), k].std())
            for case, (kind, size) in LIMIT.items():
                scaled = {
                    "additive": size * sd,
                    "multiplicative": size,
                    "drift": size * sd / 120.0,
                }[kind]
                y = y0.copy()
                y[:, k] = inject_fault(y[:, k], RATE_HZ, kind, 180.0, scaled)
                yield (
                    "limit",
                    f"{floors}x{per} {case}",
                    s,
                    t,
                    y,
                    names,
                    [(names[k], kind, 180.0, None)],
                )


def eov(seeds: range) -> Iterator[tuple[str, str, int, Any, Any, Any, list[Part]]]:
    for seed in seeds:
        for case in EOV_CASES:
            for fault in (False, True):
                t, y, faulty = sweep_eov.record(case, 3, seed, 10.0, fault)
                names = [f"s{i}" for i in range(y.shape[1])]
                c = sweep_eov.CASES[case]
                onset = c.change * 600.0 + c.delay_s
                truth: list[Part] = [] if faulty is None else [(faulty, "additive", onset, None)]
                yield "eov", case + (" +offset" if fault else ""), seed, t, y, names, truth


FAMILIES = {"changes": changes, "two": two, "limit": limit, "eov": eov}


def table(found: Sequence[dict[str, Any]]) -> str:
    """Per label (computed again from each row: :func:`analyzer.evidence_label.label_of`)
    and family: findings, right, wrong, and the share right."""
    counts: dict[tuple[str, str], list[int]] = {}
    for r in found:
        label = label_of(
            len(r["detectors"]),
            r["size_relative"],
            r["tests_agree"],
            r["caution"],
            r["level_change"],
        )[0]
        for family in (r["family"], "all"):
            c = counts.setdefault((label, family), [0, 0])
            c[0 if r["right"] else 1] += 1
    lines = [f"{'label':10s} {'family':8s} {'right':>6s} {'wrong':>6s} {'share right':>12s}"]
    families = sorted({r["family"] for r in found}) + ["all"]
    for label in LABELS:
        for family in families:
            ok, bad = counts.get((label, family), [0, 0])
            if ok + bad:
                lines.append(f"{label:10s} {family:8s} {ok:6d} {bad:6d} {ok / (ok + bad):12.0%}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--families", default=",".join(FAMILIES), help="default: all")
    ap.add_argument("--seeds", default="1:4", help="first:stop (default 1:4)")
    ap.add_argument("--out", default="evidence_labels.jsonl", help="one finding a line")
    ap.add_argument("--table", default=None, help="only print the table of this file")
    args = ap.parse_args(argv)
    if args.table:
        found = [json.loads(x) for x in Path(args.table).read_text().splitlines() if x]
        print(table(found))
        return 0
    first, stop = (int(x) for x in args.seeds.split(":"))
    found = []
    with tempfile.TemporaryDirectory() as tmp, open(args.out, "w") as out:
        for family in args.families.split(","):
            for fam, case, seed, t, y, names, truth in FAMILIES[family](range(first, stop)):
                began = time.perf_counter()
                got = rows(Path(tmp), fam, case, seed, t, y, names, truth)
                for r in got:
                    out.write(json.dumps(r) + "\n")
                out.flush()
                found += got
                print(
                    f"  {fam:8s} {case:22s} seed {seed:3d}: "
                    f"{sum(r['right'] for r in got)} right, "
                    f"{sum(not r['right'] for r in got)} wrong  "
                    f"{time.perf_counter() - began:4.1f} s",
                    flush=True,
                )
    print(table(found))
    return 0


if __name__ == "__main__":
    sys.exit(main())
