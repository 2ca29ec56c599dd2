"""SKAB's labelled records scored against their labels: the route README gives for a
record too short to train on (fit on a healthy record with ``--save-model``, analyze
each labelled one with ``--model``), and what a default run says of each.

The corpus is SKAB's water-pump test bed (``benchmark/SKAB/data`` of the real-data
corpus, GPL-3.0, read from ``--corpus``, never copied): 34 labelled records of 8 sensors
at 1 Hz, 15 to 22 minutes each, whose ``anomaly`` column (0/1 per row) marks the
experiment's fault (a valve closed, a leak, a rotor imbalance, cavitation...), and the
anomaly-free run (2.8 hours). The labels name no sensor: a finding is scored by its
onset, and its sensor is printed.

1. ``analyzer run anomaly-free.csv --train 0:T --save-model`` (``T``: ``--fit-train`` of
   the record; its own findings are printed, they are the pump's slow changes).
2. ``analyzer run FILE --model`` on every labelled record. Each finding's onset is one of:

   * **warm-up**: at or before the end of the filters' warm-up (``train.end_s`` of
     findings.json, 599-600 s on these records, or ``onset_at_or_before``): present
     when the search began, so not a detected onset. It equals most labels' start (600
     s) by the records' design, not by detection: counted apart, never as detected;
   * **detected**: inside a labelled anomaly stretch, or within ``--tolerance`` seconds
     after its start (a stretch shorter than that);
   * **before**: before the first labelled anomaly (a false finding on normal data);
   * **outside**: after the warm-up, in no anomaly stretch nor its tolerance (a false
     finding on normal data between or after the stretches).

   A record is **found** when a finding is detected, **false** when one is before or
   outside, **warm-up only** when its only findings are at the warm-up's end.
3. ``analyzer run FILE`` with the defaults: what the one-line error says (the run
   stops, the default window being 20 % of a short record): ``give --train`` (a window,
   and whether it holds the labelled anomaly's start), or ``too short before its first
   change`` (the run saw a change inside the window it would need).

A script, not a timed test (about 5 s a record)::

    python benchmarks/sweep_skab_labelled.py [--corpus DIR] [--fit-train 0.2]
                                             [--tolerance 60] [--files valve1/1,...]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _corpus import default_corpus  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SKAB = Path("benchmark/SKAB/data")
FREE = SKAB / "anomaly-free" / "anomaly-free.csv"
DEFAULT_CORPUS = default_corpus()
"""``--corpus``'s default (:func:`_corpus.default_corpus`)."""
SUGGESTED = re.compile(r"give --train ([0-9.]+):([0-9.]+)")
KEYS = (
    "found",
    "false",
    "warm-up only",
    "nothing",
    "false findings on the record",
    "finding detected",
    "finding before",
    "finding outside",
    "finding warm-up",
    "default: give --train",
    "default: the window given holds the anomaly",
    "default: too short before a change",
    "default: refused: the record too short for the detectors",
)
"""The table's rows: records by verdict, findings by kind, default runs by line."""


def analyzer(*args: str | Path) -> tuple[int, str]:
    """``python -m analyzer ARGS`` from this checkout (one BLAS thread): exit code, stderr."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1")
    done = subprocess.run(
        [sys.executable, "-m", "analyzer", *map(str, args)],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
        check=False,
    )
    return done.returncode, done.stderr


def seconds_of(frame: pd.DataFrame) -> np.ndarray:
    """Each row's seconds from the first (the records miss some seconds)."""
    stamps = pd.to_datetime(frame["datetime"])
    return (stamps - stamps.iloc[0]).dt.total_seconds().to_numpy()


def stretches(frame: pd.DataFrame) -> list[tuple[float, float]]:
    """The labelled anomaly stretches, first and last second of each run of ``anomaly``
    1 (vectorized: the edges of the 0/1 column)."""
    flag = frame["anomaly"].to_numpy(dtype=np.int8)
    t = seconds_of(frame)
    edges = np.diff(np.concatenate([[0], flag, [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [(float(t[a]), float(t[b])) for a, b in zip(starts, ends, strict=True)]


def kind_of(
    onset: float, at_start: bool, warm_end: float, spans: list[tuple[float, float]], tol: float
) -> str:
    """``warm-up``, ``detected``, ``before`` or ``outside`` (module docstring)."""
    if at_start or onset <= warm_end + 1.0:  # (1 s: a sample at 1 Hz)
        return "warm-up"
    if any(a <= onset <= max(b, a + tol) for a, b in spans):
        return "detected"
    return "before" if spans and onset < spans[0][0] else "outside"


def default_line(path: Path, out: Path, spans: list[tuple[float, float]]) -> str:
    """What a default run says of the record, shortened (module docstring, 3)."""
    code, err = analyzer("run", path, "--out", out, "--no-progress")
    if code != 2:
        return f"exit {code}"
    if "too short before its first change" in err:
        at = re.search(r"changes at about ([0-9.]+) s", err)
        return f"too short before a change at {at.group(1) if at else '?'} s"
    found = SUGGESTED.search(err)
    if found is None:  # (the archive's 1135 s at 1 Hz are too short for these detectors)
        return (
            "refused: the record too short for the detectors" if "too short" in err else "refused"
        )
    end = float(found.group(2))
    holds = bool(spans) and spans[0][0] < end
    return f"give --train {found.group(1)}:{found.group(2)}" + (
        " (holds the anomaly)" if holds else ""
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corpus", type=Path, default=DEFAULT_CORPUS)
    parser.add_argument("--fit-train", type=float, default=0.2, help="healthy fraction")
    parser.add_argument("--tolerance", type=float, default=60.0, help="after a start, s")
    parser.add_argument("--files", default=None, help="e.g. valve1/1,other/9 (default: all)")
    args = parser.parse_args(argv)
    free = args.corpus / FREE
    if not free.is_file():
        raise SystemExit(f"sweep_skab_labelled: {free}: not found (give --corpus DIR)")
    if args.files:
        files = [args.corpus / SKAB / f"{f}.csv" for f in args.files.split(",")]
    else:
        files = sorted(
            p for p in (args.corpus / SKAB).glob("*/*.csv") if p.parent.name != "anomaly-free"
        )
    duration = float(seconds_of(pd.read_csv(free, sep=";"))[-1])
    fit = f"0:{args.fit_train * duration:.0f}"
    tally: Counter[str] = Counter()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        model = work / "skab.model"
        code, err = analyzer(
            "run", free, "--train", fit, "--save-model", model, "--out", work / "fit",
            "--no-progress",
        )  # fmt: skip
        if not model.is_file():
            raise SystemExit(f"sweep_skab_labelled: the fit failed (exit {code}): {err}")
        fitted = json.loads((work / "fit" / "findings.json").read_text())
        print(
            f"sweep_skab_labelled: model fitted on {FREE} --train {fit} (exit {code}), its "
            "own findings: "
            + (
                ", ".join(
                    f"{f['channel']} {f['type']} from {f['onset_s']:.0f} s"
                    for f in fitted["faults"]
                )
                or "none"
            )
        )
        print(f"  onsets within {args.tolerance:g} s after a labelled start count as detected")
        for path in files:
            frame = pd.read_csv(path, sep=";")
            spans = stretches(frame)
            name = f"{path.parent.name}/{path.stem}"
            out = work / name.replace("/", "_")
            code, err = analyzer("run", path, "--model", model, "--out", out, "--no-progress")
            doc = json.loads((out / "findings.json").read_text())
            warm_end = float(doc["train"]["end_s"])
            kinds = []
            for f in doc["faults"]:
                at_start = bool(f.get("evidence", {}).get("onset_at_or_before"))
                kind = kind_of(float(f["onset_s"]), at_start, warm_end, spans, args.tolerance)
                kinds.append((kind, f))
                tally[f"finding {kind}"] += 1
            said = Counter(k for k, _ in kinds)
            verdict = (
                "found"
                if said["detected"]
                else "false"
                if said["before"] or said["outside"]
                else "warm-up only"
                if said["warm-up"]
                else "nothing"
            )
            tally[verdict] += 1
            tally["false findings on the record"] += bool(said["before"] or said["outside"])
            default = default_line(path, work / f"{out.name}_default", spans)
            tally["default: give --train"] += default.startswith("give --train")
            tally["default: the window given holds the anomaly"] += "(holds the" in default
            tally["default: too short before a change"] += default.startswith("too short")
            tally["default: refused: the record too short for the detectors"] += (
                "record too short" in default
            )
            label = "; ".join(f"{a:.0f}-{b:.0f}" for a, b in spans)
            print(f"  {name:10s} label {label:24s} warm-up to {warm_end:.0f} s: {verdict}")
            for kind, f in kinds:
                print(
                    f"    {kind:8s} {f['channel']} {f['type']} from {f['onset_s']:.0f} s "
                    f"({', '.join(f['evidence'].get('detectors', [f['detector']]))})"
                )
            print(f"    default run: {default}")
    print()
    print(f"{len(files)} labelled records:")
    for key in KEYS:
        print(f"  {key:45s} {tally[key]:3d}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
