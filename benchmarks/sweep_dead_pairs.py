"""Two dead sensors in a record analyzed with a saved model: what the first one's finding
is and what ``--corrected`` makes of it.

The record is the 5-floor building of ``tests/cli/test_model_file.py`` (one sensor a
floor, seed 11, 100 Hz): its first 80 s are the training file (``run --train 0:79
--save-model``), the next 160 s four pieces of 40 s. In every piece, for every ordered
pair of sensors ``(first, second)``, the first reads 0 (a gain of 0) from 10 to 22 s and
the second from 16 s to 30 s or to the piece's end: 4 x 20 x 2 = 160 runs of ``analyze``
with ``RunOptions(model=..., corrected=True)`` (``analyzer run PIECE --model FILE
--corrected``). The second sensor's fault runs on after the first revives, and the
detectors' estimate of the first leans on it, so their finding of the first tends to run
on past 22 s.

Per run, of the first sensor (truth: the piece before injection, in sd of the sensor):

* its finding: type, onset, end and magnitude (``none`` if it has none);
* **dead**: ``RMS(corrected - truth)`` over 10-22 s, in sd (the error left on the dead
  stretch; about 1.4 sd, the RMS of the signal it lost, when nothing was done);
* **alive**: ``RMS(corrected - truth)`` over 22 s to the piece's end (its readings are
  alive again there: 0 when ``--corrected`` keeps them as measured).

The summary counts the findings by type and by whether they end at the revival (within
0.1 s of 22 s), then the runs with a finding of the second sensor (and those dead from
16 s to its revival), and the findings on healthy sensors. A script, not a timed test
(about 2 minutes)::

    python benchmarks/sweep_dead_pairs.py [--pieces 0:4] [--json F]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from collections import Counter
from pathlib import Path
from typing import Any

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from analyzer.modelfile import load_model, save_model  # noqa: E402
from analyzer.pipeline import RunOptions, analyze  # noqa: E402
from analyzer.simulate import inject_fault, simulate_building  # noqa: E402
from analyzer.writers import write_archive  # noqa: E402

RATE_HZ = 100.0
FLOORS = 5
SEED = 11
TRAIN_S = 80.0
PIECE_S = 40.0
FIRST = (10.0, 22.0)
SECOND_FROM = 16.0
SECOND_TO = (30.0, None)


def _write(path: Path, t: np.ndarray, y: np.ndarray, names: list[str]) -> Path:
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: y[:, j] for j, n in enumerate(names)})
    return path


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x)))) if x.size else float("nan")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pieces", default="0:4", help="first:stop of the 4 pieces (default 0:4)")
    ap.add_argument("--json", type=Path, help="also write every run's first-sensor finding here")
    args = ap.parse_args(argv)
    first, stop = (int(x) for x in args.pieces.split(":"))
    t, y0, names = simulate_building(FLOORS, TRAIN_S + 4 * PIECE_S, RATE_HZ, seed=SEED)
    runs: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        n = int(TRAIN_S * RATE_HZ)
        src = _write(work / "train.csv", t[:n], y0[:n], names)
        (work / "fit").mkdir()
        saved = work / "m.model"
        fit = analyze(
            [str(src)], RunOptions(train=f"0:{TRAIN_S - 1:g}", save_model=saved), work / "fit"
        )
        assert fit.saved is not None
        save_model(saved, fit.saved)  # (as ``run --save-model`` writes it)
        options = RunOptions(model=load_model(saved), model_path=str(saved), corrected=True)
        for k in range(first, stop):
            a = int((TRAIN_S + k * PIECE_S) * RATE_HZ)
            b = a + int(PIECE_S * RATE_HZ)
            for i in range(FLOORS):
                for j in range(FLOORS):
                    if j == i:
                        continue
                    for to in SECOND_TO:
                        truth = y0[a:b]
                        y = truth.copy()
                        y[:, i] = inject_fault(
                            y[:, i], RATE_HZ, "multiplicative", FIRST[0], 0.0, FIRST[1]
                        )
                        y[:, j] = inject_fault(
                            y[:, j], RATE_HZ, "multiplicative", SECOND_FROM, 0.0, to
                        )
                        path = _write(work / "r.csv", t[a:b], y, names)
                        out = work / "out"
                        out.mkdir(exist_ok=True)
                        run = analyze([str(path)], options, out)
                        fixed = np.array(run.corrected, dtype=np.float64)
                        err = (fixed[:, i] - truth[:, i]) / float(truth[:, i].std())
                        d0, d1 = (int(round(s * RATE_HZ)) for s in FIRST)
                        mine = [f for f in run.findings if f.channel == names[i]]
                        f = mine[0] if mine else None
                        row = {
                            "piece": k,
                            "first": names[i],
                            "second": names[j],
                            "second_to": to,
                            "type": "none" if f is None else f.type.value,
                            "onset_s": None if f is None else f.onset_s,
                            "end_s": None if f is None else f.end_s,
                            "magnitude": None if f is None else f.magnitude,
                            "findings": len(mine),
                            "dead_sd": _rms(err[d0:d1]),
                            "alive_sd": _rms(err[d1:]),
                            "all": [
                                [g.channel, g.type.value, g.onset_s, g.end_s, g.magnitude]
                                for g in run.findings
                            ],
                        }
                        runs.append(row)
                        end = "end" if row["end_s"] is None else f"{row['end_s']:.2f}"
                        mag = {q: round(v, 3) for q, v in (row["magnitude"] or {}).items()}
                        print(
                            f"  piece {k} {names[i]} 10-22, {names[j]} 16-{to or 'end'}: "
                            f"{row['type']} {row['onset_s'] or 0:.2f}-{end} {mag}  "
                            f"dead {row['dead_sd']:.3f} alive {row['alive_sd']:.3f} sd",
                            flush=True,
                        )
    if args.json is not None:
        args.json.write_text(json.dumps(runs, indent=1))
    print(f"\n{len(runs)} runs; the first dead sensor's finding:")
    kinds = Counter(r["type"] for r in runs)
    at = Counter(
        r["type"] for r in runs if r["end_s"] is not None and abs(r["end_s"] - FIRST[1]) <= 0.1
    )
    print("type              runs  ends at 22 s  dead sd med/max  alive sd med/max")
    for kind in sorted(kinds):
        rows = [r for r in runs if r["type"] == kind]
        dead = np.array([r["dead_sd"] for r in rows])
        alive = np.array([r["alive_sd"] for r in rows])
        print(
            f"{kind:16s} {kinds[kind]:5d} {at[kind]:13d} {np.median(dead):8.3f} / {dead.max():5.3f}"
            f" {np.median(alive):9.3f} / {alive.max():5.3f}"
        )
    # the second sensor: found at all, and dead from its death to its revival
    seconds = [next((g for g in r["all"] if g[0] == r["second"]), None) for r in runs]
    dead = sum(
        1
        for r, g in zip(runs, seconds, strict=True)
        if g is not None
        and (g[1], g[4]) == ("multiplicative", {"gain": 0.0})
        and abs(g[2] - SECOND_FROM) <= 0.1
        and (
            g[3] is None
            if r["second_to"] is None
            else g[3] is not None and abs(g[3] - r["second_to"]) <= 0.1
        )
    )
    others = sum(1 for r in runs for g in r["all"] if g[0] not in (r["first"], r["second"]))
    print(
        f"the second dead sensor: found in {sum(g is not None for g in seconds)} runs, dead from "
        f"{SECOND_FROM:g} s to its revival (within 0.1 s) in {dead}; findings on healthy sensors: "
        f"{others}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
