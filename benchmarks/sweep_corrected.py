"""How well ``--corrected`` restores the true signal of a faulty sensor (Wang & Song
2014, Section 6.3: ``S_fault_free = S_fault - f_s``), and whether it leaves the healthy
samples and channels alone.

For each seed it simulates the 6-floor building of ``sweep_isolation.py`` (one sensor a
floor, ``--seconds`` at 100 Hz, the default training window: the first 20 %), injects
each case's faults (sizes in standard deviations of that sensor, a gain as a factor),
writes it as CSV and runs ``pipeline.analyze`` with ``RunOptions(corrected=True)``; the
corrected channels are ``Analysis.corrected`` (what ``analyzer run --corrected`` writes
to ``corrected.csv``). Single faults on the seed's sensor from 120 s, either to the
record's end or ending at 220 s (``-ends``):

* ``offset``: 2 sd (``offset-half``: 1 sd);
* ``gain-up``: a gain of 1.5 (``-half``: 1.25); ``gain-down``: 0.5 (``-half``: 0.75);
* ``drift``: 0.02 sd/s (``-half``: 0.01 sd/s);
* ``dead``: a gain of 0 (the reading is replaced by the detector's fault-free estimate);
* two faults, the seed's sensor and the one 3 floors up (the next floor's for
  ``two-dead-neighbour``): ``two-offset-gain`` (2 sd 120-220 s, gain 1.5 150-250 s),
  ``two-dead-drift`` (dead 120-220 s, 0.02 sd/s from 150 s to the end),
  ``two-dead-neighbour`` (dead 120-220 s, 2 sd 150-250 s), ``two-dead`` (both dead,
  120-220 s and 150-250 s);
* ``healthy``: no fault (every corrected sample is a damaged one).

Metrics, per injected fault (truth: the record before injection):

* **left**: ``RMS(corrected - truth) / RMS(faulty - truth)`` over the true fault period,
  the share of the fault's error left (0 perfect, 1 nothing done, > 1 made worse);
* **healthy**: ``RMS(corrected - truth)`` over the faulty sensor's samples outside its
  true fault period, in sd of that sensor (0 when the corrections keep to the fault);
* **covered**: the share of the true fault period whose samples were changed;
* **altered**: runs in which a channel without a fault had a sample changed;
* **regen/floor**: for a fault regenerated from a detector's estimate (``reference`` or
  ``residual``: a dead sensor), ``RMS(corrected - truth)`` over the period divided by
  that detector's prediction error ``RMS(estimate - truth)`` for the channel over the same
  period of the healthy record (the floor a regenerated signal can reach; 1 = at it).

``--model``: each seed's records are analyzed with a model fitted once (``--save-model``,
not timed) on a healthy record of the same building simulated with seed ``seed +``
:data:`MODEL_SEED` (another excitation and noise, the whole record as its training
window), as ``analyzer run RECORD --model FILE --corrected`` (README "Fit once, audit
every file"); regen/floor's floor is then the model's estimate on the seed's healthy
record, run with the model too.

The table gives the median and the worst over the seeds. A script, not a timed test
(8 seeds: about 3 minutes)::

    python benchmarks/sweep_corrected.py [--seeds 1:9] [--cases dead,offset] [--json F]
    python benchmarks/sweep_corrected.py --model [--seeds 1:9] ...
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from analyzer.modelfile import SavedModel, load_model, save_model  # noqa: E402
from analyzer.pipeline import RunOptions, analyze  # noqa: E402
from analyzer.simulate import inject_fault, simulate_building  # noqa: E402
from analyzer.writers import write_archive  # noqa: E402

RATE_HZ = 100.0
FLOORS = 6
ONSET_S = 120.0
END_S = 220.0
MODEL_SEED = 1000
"""``--model``: the model of seed ``s`` is fitted on the healthy record of seed
``s + MODEL_SEED`` (the same building, another excitation and noise)."""

Fault = tuple[int, str, float, float | None, float]
"""(floors up from the seed's sensor, kind, onset s, end s or None, size: sd, sd per s
for a drift, or a gain)."""


def _single(kind: str, size: float) -> dict[str, list[Fault]]:
    return {"": [(0, kind, ONSET_S, None, size)], "-ends": [(0, kind, ONSET_S, END_S, size)]}


def _cases() -> dict[str, list[Fault]]:
    singles = {
        "offset": ("additive", 2.0),
        "offset-half": ("additive", 1.0),
        "gain-up": ("multiplicative", 1.5),
        "gain-up-half": ("multiplicative", 1.25),
        "gain-down": ("multiplicative", 0.5),
        "gain-down-half": ("multiplicative", 0.75),
        "drift": ("drift", 0.02),
        "drift-half": ("drift", 0.01),
        "dead": ("multiplicative", 0.0),
    }
    cases = {
        name + suffix: faults
        for name, (kind, size) in singles.items()
        for suffix, faults in _single(kind, size).items()
    }
    cases["two-offset-gain"] = [
        (0, "additive", ONSET_S, END_S, 2.0),
        (3, "multiplicative", 150.0, 250.0, 1.5),
    ]
    cases["two-dead-drift"] = [
        (0, "multiplicative", ONSET_S, END_S, 0.0),
        (3, "drift", 150.0, None, 0.02),
    ]
    cases["two-dead-neighbour"] = [
        (0, "multiplicative", ONSET_S, END_S, 0.0),
        (1, "additive", 150.0, 250.0, 2.0),
    ]
    cases["two-dead"] = [
        (0, "multiplicative", ONSET_S, END_S, 0.0),
        (3, "multiplicative", 150.0, 250.0, 0.0),
    ]
    cases["healthy"] = []
    return cases


CASES = _cases()


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x)))) if x.size else float("nan")


def _floors(work: Path, options: RunOptions) -> dict[tuple[str, str], np.ndarray]:
    """Each detector's fault-free estimate of each channel on the healthy record."""
    run = analyze([str(work / "floors.csv")], options, work / "floors")
    return {(r.detector, c): np.array(v) for r in run.results for c, v in r.reference.items()}


def _fitted(seed: int, seconds: float, work: Path) -> SavedModel:
    """``--model``: the models fitted on the whole healthy record of seed ``seed +
    MODEL_SEED`` (``run --train 0:END --save-model``), loaded as ``--model`` loads them."""
    t, y, names = simulate_building(FLOORS, seconds, RATE_HZ, seed=seed + MODEL_SEED)
    t_ns = np.round(t * 1e9).astype(np.int64)
    path = work / "fit.csv"
    write_archive(path, "csv", t_ns, {n: y[:, i] for i, n in enumerate(names)})
    (work / "fit").mkdir()
    saved = work / "building.model"
    run = analyze([str(path)], RunOptions(train=f"0:{seconds:g}", save_model=saved), work / "fit")
    assert run.saved is not None
    save_model(saved, run.saved)  # (as ``run --save-model`` writes it)
    shutil.rmtree(work / "fit")
    path.unlink()
    return load_model(saved)


def _score(
    faults: list[Fault],
    y0: np.ndarray,
    y: np.ndarray,
    corrected: np.ndarray,
    corrections: list[dict[str, Any]],
    names: list[str],
    healthy_refs: dict[tuple[str, str], np.ndarray],
) -> tuple[list[dict[str, Any]], int]:
    """Per fault: left, healthy, covered, method and regen/floor; and the number of
    samples changed on channels without a fault."""
    n = y0.shape[0]
    changed = corrected != y
    rows = []
    for j, kind, onset, end, _ in faults:
        k0 = int(round(onset * RATE_HZ))
        k1 = n if end is None else int(round(end * RATE_HZ))
        sd = float(y0[:, j].std())
        inside = np.zeros(n, dtype=bool)
        inside[k0:k1] = True
        err = corrected[:, j] - y0[:, j]
        left = _rms(err[inside]) / _rms(y[inside, j] - y0[inside, j])
        healthy = _rms(err[~inside]) / sd
        covered = float(np.mean(changed[inside, j]))
        mine = [c for c in corrections if c["channel"] == names[j]]
        methods = sorted({c["method"] for c in mine})
        ratio = None
        regen = [c for c in mine if c["method"] in ("reference", "residual")]
        if regen:
            ref = healthy_refs.get((regen[0]["detector"], names[j]))
            if ref is not None:
                ratio = _rms(err[inside]) / _rms(ref[inside] - y0[inside, j])
        rows.append(
            {
                "channel": names[j],
                "kind": kind,
                "left": left,
                "healthy_sd": healthy,
                "covered": covered,
                "methods": methods,
                "regen_floor": ratio,
            }
        )
    faulty = {j for j, *_ in faults}
    others = [j for j in range(y.shape[1]) if j not in faulty]
    return rows, int(changed[:, others].sum())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="1:9", help="first:stop (default 1:9)")
    ap.add_argument("--seconds", type=float, default=300.0, help="record length (default 300)")
    ap.add_argument("--cases", default=",".join(CASES), help="cases to run (default all)")
    ap.add_argument("--json", type=Path, help="also write every run's scores here")
    ap.add_argument(
        "--model",
        action="store_true",
        help="analyze with a model fitted on another seed's healthy record (--model)",
    )
    args = ap.parse_args(argv)
    first, stop = (int(x) for x in args.seeds.split(":"))
    cases = args.cases.split(",")
    for case in cases:
        if case not in CASES:
            ap.error(f"--cases: unknown case {case!r} (known: {', '.join(CASES)})")
    scores: dict[str, list[dict[str, Any]]] = {c: [] for c in cases}
    altered: dict[str, int] = {c: 0 for c in cases}
    runs: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(first, stop):
            t, y0, names = simulate_building(FLOORS, args.seconds, RATE_HZ, seed=seed)
            t_ns = np.round(t * 1e9).astype(np.int64)
            work = Path(tmp) / f"seed-{seed}"
            (work / "floors").mkdir(parents=True)
            write_archive(
                work / "floors.csv", "csv", t_ns, {n: y0[:, i] for i, n in enumerate(names)}
            )
            plain = RunOptions()
            if args.model:
                saved = work / "building.model"
                plain = RunOptions(model=_fitted(seed, args.seconds, work), model_path=str(saved))
            refs = _floors(work, plain)
            for case in cases:
                faults = [
                    ((seed + up) % FLOORS, kind, onset, end, size)
                    for up, kind, onset, end, size in CASES[case]
                ]
                y = y0.copy()
                for j, kind, onset, end, size in faults:
                    scaled = size if kind == "multiplicative" else size * float(y0[:, j].std())
                    y[:, j] = inject_fault(y[:, j], RATE_HZ, kind, onset, scaled, end)
                path = work / f"{case}.csv"
                write_archive(path, "csv", t_ns, {n: y[:, i] for i, n in enumerate(names)})
                began = time.perf_counter()
                out = work / case
                out.mkdir()
                analysis = analyze([str(path)], replace(plain, corrected=True), out)
                corrected = np.array(analysis.corrected, dtype=np.float64)
                rows, changed = _score(faults, y0, y, corrected, analysis.corrections, names, refs)
                scores[case].extend(rows)
                altered[case] += int(changed > 0)
                shown = ", ".join(
                    f"{c['channel']} {c['type']} {c['start_s']:.2f}-"
                    f"{'end' if c['end_s'] is None else format(c['end_s'], '.2f')} {c['method']}"
                    for c in analysis.corrections
                )
                parts = " ".join(
                    f"{r['channel']}: left {r['left']:.3f} healthy {r['healthy_sd']:.3f} sd "
                    f"covered {r['covered']:.3f}"
                    + ("" if r["regen_floor"] is None else f" regen/floor {r['regen_floor']:.2f}")
                    for r in rows
                )
                print(
                    f"  {case:22s} seed {seed:2d} {parts}"
                    f"{f' ALTERED {changed}' if changed else ''}"
                    f"  {time.perf_counter() - began:4.1f} s  [{shown}]",
                    flush=True,
                )
                runs.append(
                    {
                        "case": case,
                        "seed": seed,
                        "faults": rows,
                        "altered_samples": changed,
                        "corrections": analysis.corrections,
                        "findings": [
                            {
                                "channel": f.channel,
                                "type": f.type.value,
                                "onset_s": f.onset_s,
                                "end_s": f.end_s,
                                "magnitude": f.magnitude,
                                "detector": f.detector,
                            }
                            for f in analysis.findings
                        ],
                    }
                )
                path.unlink()
                shutil.rmtree(out)
            shutil.rmtree(work)
    if args.json is not None:
        args.json.write_text(json.dumps(runs, indent=1))
    print(
        "\ncase                    faults  left med  left max  healthy max  covered min"
        "  altered  regen/floor med/max  methods"
    )
    for case in cases:
        rows = scores[case]
        if not rows:
            print(f"{case:22s} {0:7d} {'':>9s} {'':>9s} {'':>12s} {'':>12s} {altered[case]:8d}")
            continue
        left = np.array([r["left"] for r in rows])
        healthy = np.array([r["healthy_sd"] for r in rows])
        covered = np.array([r["covered"] for r in rows])
        ratios = np.array([r["regen_floor"] for r in rows if r["regen_floor"] is not None])
        regen = f"{np.median(ratios):6.2f} / {ratios.max():5.2f}" if ratios.size else ""
        methods = ",".join(sorted({m for r in rows for m in r["methods"]}))
        print(
            f"{case:22s} {len(rows):7d} {np.median(left):9.3f} {left.max():9.3f} "
            f"{healthy.max():12.3f} {covered.min():12.3f} {altered[case]:8d}  "
            f"{regen:19s}  {methods}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
