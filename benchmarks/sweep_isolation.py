"""Which sensor, which type, and nothing else: a sweep of single (or paired) faults on
simulated buildings, end to end.

For each seed it simulates a shear building (``simulate_building``, ``--floors`` floors x
2 sensors, ``--minutes`` at 100 Hz), puts one fault on a sensor drawn at random (from the
seed) from 60 % of the record (``--onset``) to its end (``--until F``: to ``F`` of the
record), in turn an offset (half the sensor's standard deviation), a gain (1.3) and a
drift (one standard deviation per 10 minutes), each scaled by ``--scale``, writes the
record as an MCAP file, runs the whole analysis on it (``pipeline.analyze``, default
settings: the first 20 % as training window, every default detector) and compares the
findings with the truth:

* **right**: exactly one finding, on the faulty sensor, of the injected type;
* **extra**: the faulty sensor's finding is there with its type, plus other findings;
* **wrong**: the faulty sensor's finding is missing or of another type.

With ``--second F`` each record has a second fault, on another sensor (drawn from
the seed apart from the first), of the next type (shifted every three seeds, so that nine
seeds make every pair of types), from ``F`` of the record to its end, while the first
lasts or after it ended (``--onset``: where the first begins, default 60 %). A case is
then right with exactly two findings, each on its sensor with its type; the table counts
the cases by the first fault's type and gives the errors of both faults by their type.

With ``--healthy`` the records have no fault, and the sweep counts those with any
finding (false alarms).

With ``--detectors A,B`` only those detectors run (``analyzer run --detectors``): what a
screening with fewer of them finds and misses, beside its speed (``bench_pipeline.py
--detectors``).

With ``--until`` a right case's reported end is compared with the injected one as well
(a fault reported as lasting to the end of the record is **open**), and the table gives
the onset and end errors.

It prints one line per case and a table per fault type. A script, not a timed test (a
20-minute 16-channel case takes ~7 s)::

    python benchmarks/sweep_isolation.py [--seeds 0:45] [--floors 8] [--minutes 20]
                                         [--until F] [--scale S] [--onset F]
                                         [--second F] [--healthy]
                                         [--detectors A,B]
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

from analyzer.pipeline import Analysis, RunOptions, analyze  # noqa: E402
from analyzer.simulate import inject_fault, simulate_building  # noqa: E402
from analyzer.writers import write_archive  # noqa: E402

RATE_HZ = 100.0
KINDS = ("additive", "multiplicative", "drift")
MAGNITUDE = {"additive": "offset", "multiplicative": "gain", "drift": "rate_per_s"}
ONSET_FRACTION = 0.6
DETECTORS: list[str] | None = None
"""``--detectors``: the detectors every case runs (None: the defaults)."""


def _analyze(path: Path, t: np.ndarray, Y: np.ndarray, names: list[str]) -> Analysis:
    """The record written as MCAP at ``path``, analyzed with the defaults (but
    :data:`DETECTORS`; the file is removed afterwards)."""
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(
        path, "mcap", t_ns, {n: Y[:, i] for i, n in enumerate(names)}, layout="multiarray"
    )
    try:
        return analyze([str(path)], RunOptions(detectors=DETECTORS))
    finally:
        path.unlink()


def _size(kind: str, sd: float, scale: float) -> float:
    return {
        "additive": 0.5 * sd * scale,
        "multiplicative": 1.0 + 0.3 * scale,
        "drift": sd / 600.0 * scale,
    }[kind]


def case(
    seed: int,
    floors: int,
    minutes: float,
    folder: Path,
    until: float | None,
    scale: float,
    onset_fraction: float = ONSET_FRACTION,
    second: float | None = None,
) -> tuple[str, str, str, list, list[tuple[str, tuple[float, float, float]]]]:
    """``(kind, faulty channels, verdict, findings, errors)`` of one seed; ``errors``: of
    each faulty sensor's finding that is there, its kind with its onset and end errors in
    s (end error NaN for an open finding or a fault that lasts to the end) and its size's
    relative error (a gain's departure from 1). ``second``: a second fault, on another
    sensor, of the next type, from that fraction of the record to its end."""
    rng = np.random.default_rng(1000 + seed)
    duration = 60.0 * minutes
    t, Y, names = simulate_building(floors, duration, RATE_HZ, seed=seed, sensors_per_floor=2)
    k = int(rng.integers(Y.shape[1]))
    kind = KINDS[seed % len(KINDS)]
    end = None if until is None else until * duration
    faults = [(k, kind, onset_fraction * duration, end)]
    if second is not None:
        # its own draws: the first fault is the same as without a second
        others = [i for i in range(Y.shape[1]) if i != k]
        k2 = int(np.random.default_rng(5000 + seed).choice(others))
        # the next type, shifted every three seeds: each pair of types in nine seeds
        kind2 = KINDS[(seed + 1 + seed // len(KINDS)) % len(KINDS)]
        faults.append((k2, kind2, second * duration, None))
    truth = []
    for i, fault_kind, onset, stop in faults:
        size = _size(fault_kind, float(np.std(Y[:, i])), scale)
        Y[:, i] = inject_fault(Y[:, i], RATE_HZ, fault_kind, onset, size, stop)
        truth.append((f"/data.data[{i}]", fault_kind, onset, stop, size))
    analysis = _analyze(folder / f"building_{seed}.mcap", t, Y, names)
    found = [
        (
            f.channel,
            f.type.value,
            round(f.onset_s, 2),
            None if f.end_s is None else round(f.end_s, 2),
        )
        for f in analysis.findings
    ]
    errors = []
    hits = 0
    open_end = False
    for faulty, fault_kind, onset, stop, size in truth:
        mine = [
            (row, f)
            for row, f in zip(found, analysis.findings, strict=True)
            if f.channel == faulty and f.type.value == fault_kind
        ]
        if not mine:
            continue
        hits += 1
        (_, _, got_onset, got_end), finding = mine[0]
        late = float("nan") if stop is None or got_end is None else got_end - stop
        size_found = finding.magnitude.get(MAGNITUDE[fault_kind], float("nan"))
        if fault_kind == "multiplicative":  # the gain's departure from 1
            size_found, size = size_found - 1.0, size - 1.0
        errors.append((fault_kind, (got_onset - onset, late, size_found / size - 1.0)))
        open_end |= stop is not None and got_end is None
    all_found = hits == len(truth)
    verdict = (
        "right" if all_found and len(found) == len(truth) else "extra" if all_found else "wrong"
    )
    if verdict == "right" and open_end:
        verdict = "open"
    faulty = ", ".join(f"{c} {k}" if second is not None else c for c, k, *_ in truth)
    return kind, faulty, verdict, found, errors


def healthy_case(seed: int, floors: int, minutes: float, folder: Path) -> list:
    """The findings on the seed's building with no fault (``--healthy``)."""
    t, Y, names = simulate_building(floors, 60.0 * minutes, RATE_HZ, seed=seed, sensors_per_floor=2)
    analysis = _analyze(folder / f"healthy_{seed}.mcap", t, Y, names)
    return [(f.channel, f.type.value, round(f.onset_s, 2)) for f in analysis.findings]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="0:45", help="first:stop (default 0:45)")
    ap.add_argument("--floors", type=int, default=8, help="floors, 2 sensors each (default 8)")
    ap.add_argument("--minutes", type=float, default=20.0, help="record length (default 20)")
    ap.add_argument(
        "--until", type=float, default=None, help="fault ends at this fraction of the record"
    )
    ap.add_argument("--scale", type=float, default=1.0, help="fault size factor (default 1)")
    ap.add_argument(
        "--onset",
        type=float,
        default=ONSET_FRACTION,
        help=f"the fault begins at this fraction of the record (default {ONSET_FRACTION})",
    )
    ap.add_argument(
        "--second",
        type=float,
        default=None,
        metavar="F",
        help="a second fault, on another sensor, of the next type, from F of the record on",
    )
    ap.add_argument(
        "--healthy",
        action="store_true",
        help="no fault: count the records with any finding (false alarms)",
    )
    ap.add_argument(
        "--detectors",
        default=None,
        metavar="A,B",
        help="run only these detectors (analyzer run --detectors; default: the defaults)",
    )
    args = ap.parse_args(argv)
    global DETECTORS
    DETECTORS = args.detectors.split(",") if args.detectors else None
    which = f", detectors {args.detectors}" if args.detectors else ""
    if not 0.2 < args.onset < 1.0:
        ap.error(f"--onset: {args.onset} is not after the training window (0.2) and < 1")
    if args.until is not None and not args.onset < args.until <= 1.0:
        ap.error(f"--until: {args.until} is not after the onset ({args.onset}) and <= 1")
    if args.second is not None and not args.onset < args.second < 1.0:
        ap.error(f"--second: {args.second} is not after the onset ({args.onset}) and < 1")
    first, stop = (int(x) for x in args.seeds.split(":"))
    if args.healthy:
        print(
            f"sweep_isolation: {2 * args.floors} channels, {args.minutes:g} min at "
            f"{RATE_HZ:g} Hz, no fault, seeds {args.seeds}{which}",
            flush=True,
        )
        alarmed = 0
        with tempfile.TemporaryDirectory(prefix="sweep_isolation_") as tmp:
            for seed in range(first, stop):
                found = healthy_case(seed, args.floors, args.minutes, Path(tmp))
                alarmed += bool(found)
                verdict = "extra" if found else "right"
                print(f"  seed {seed:4d} healthy {verdict:<6} {found}", flush=True)
        print(f"\nhealthy records with a finding: {alarmed} of {stop - first}")
        return 0
    tally: dict[str, Counter[str]] = {k: Counter() for k in KINDS}
    errs: dict[str, list[tuple[float, float, float]]] = {k: [] for k in KINDS}
    span = "its end" if args.until is None else f"{args.until:.0%}"
    also = (
        ""
        if args.second is None
        else f", a second fault on another sensor from {args.second:.0%} to its end"
    )
    print(
        f"sweep_isolation: {2 * args.floors} channels, {args.minutes:g} min at "
        f"{RATE_HZ:g} Hz, fault from {args.onset:.0%} of the record to {span}{also}, "
        f"size x{args.scale:g}, seeds {args.seeds}{which}",
        flush=True,
    )
    with tempfile.TemporaryDirectory(prefix="sweep_isolation_") as tmp:
        for seed in range(first, stop):
            kind, faulty, verdict, found, e = case(
                seed,
                args.floors,
                args.minutes,
                Path(tmp),
                args.until,
                args.scale,
                args.onset,
                args.second,
            )
            tally[kind][verdict] += 1
            for fault_kind, errors in e:
                errs[fault_kind].append(errors)
            print(f"  seed {seed:4d} {kind:<15} {faulty:<16} {verdict:<6} {found}", flush=True)
    print(
        f"\n{'fault':<16}{'cases':>6}{'right':>7}{'open':>6}{'extra':>7}{'wrong':>7}"
        f"{'onset err s':>16}{'end err s':>16}{'size err %':>16}"
    )
    print(f"{'':<43}{'(median, max |.|)':>48}")
    if args.second is not None:
        print("(cases by the first fault's type; errors of both faults, by their type)")
    for kind in KINDS:
        c = tally[kind]
        e = np.array(errs[kind], dtype=float).reshape(-1, 3)
        e[:, 2] *= 100.0
        cols = []
        for j in (0, 1, 2):
            v = e[np.isfinite(e[:, j]), j]
            cols.append(f"{np.median(v):+.1f}, {np.max(np.abs(v)):.1f}" if v.size else "-")
        print(
            f"{kind:<16}{sum(c.values()):>6}{c['right']:>7}{c['open']:>6}{c['extra']:>7}"
            f"{c['wrong']:>7}{cols[0]:>16}{cols[1]:>16}{cols[2]:>16}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
