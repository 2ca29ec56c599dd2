"""Fit once, audit every later file: ``run --save-model`` on a healthy recording, then
``run --model`` on later pieces of the same monitoring stream, healthy and with a fault
present from their first sample.

One continuous simulated building (``simulate_building``: ``--floors`` floors,
``--per-floor`` accelerometers each, ``--rate`` Hz, seed ``--seed``) is cut as a
monitoring system cuts its stream into files: the first ``--train-s`` seconds are the
training recording (fitted whole, as ``--train 0:END``), then ``--pieces`` files of
``--piece-s`` seconds follow. Each piece is analyzed

* untouched, with the model: any finding is a false alarm;
* with one fault on one sensor from its first sample (sensors in turn; additive
  ``--offset`` x the sensor's training standard deviation, gain ``--gain``, drift
  ``--drift`` x that deviation per minute, types in turn), with the model: **right**
  when the only finding is on that sensor, of that type; its size error is printed;
* the same faulty piece trained on its own first 20 % (the default), for comparison:
  such a fault is then part of the "healthy" state.

``--skab`` takes a real record instead: SKAB's anomaly-free water-pump run (8 sensors
at 1 Hz, 2.8 hours, read from ``--corpus``, never copied), its first ``--train-frac``
fitted and the rest cut into ``--pieces`` files; that record is not stationary (the
pump warms up), so its untouched files may have findings of their own, and a faulty
file's findings that its untouched copy has too are left out of its score.

A script, not a timed test (about 2 s a run)::

    python benchmarks/sweep_model_reuse.py [--train-s 300] [--pieces 10] [--piece-s 60]
    python benchmarks/sweep_model_reuse.py --skab --pieces 8 --offset 3 --gain 1.5 --drift 0.3
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from analyzer.cli import main
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

sys.path.insert(0, str(Path(__file__).resolve().parent))
from sweep_real_background import DEFAULT_CORPUS, load  # noqa: E402

KINDS = ("additive", "multiplicative", "drift")
KEY = {"additive": "offset", "multiplicative": "gain", "drift": "rate_per_s"}


def _skab(corpus: Path) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """SKAB's anomaly-free record as ``sweep_real_background.py`` reads it (from the
    corpus, never copied): seconds from its first row, the 8 sensors, their names."""
    frame, seconds = load(corpus)
    sensors = frame.drop(columns="datetime")
    return seconds, sensors.to_numpy(dtype=np.float64), list(sensors.columns)


def _write(path: Path, t: np.ndarray, y: np.ndarray, names: list[str]) -> Path:
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: y[:, j] for j, n in enumerate(names)})
    return path


def _run(argv: list[object]) -> tuple[int, list[dict]]:
    out = Path(str(argv[argv.index("--out") + 1]))
    with contextlib.redirect_stderr(io.StringIO()):  # a file too short to train on: exit 2
        code = main([str(a) for a in argv] + ["--no-progress"])
    faults = json.loads((out / "findings.json").read_text())["faults"] if code in (0, 1) else []
    return code, faults


def _beyond(found: list[dict], background: list[dict], slack_s: float = 5.0) -> list[dict]:
    """The findings the untouched file does not have (same sensor and type, onset within
    ``slack_s``)."""
    return [
        f
        for f in found
        if not any(
            f["channel"] == b["channel"]
            and f["type"] == b["type"]
            and abs(f["onset_s"] - b["onset_s"]) <= slack_s
            for b in background
        )
    ]


def main_(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--floors", type=int, default=5)
    ap.add_argument("--per-floor", type=int, default=2)
    ap.add_argument("--rate", type=float, default=100.0)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--train-s", type=float, default=300.0)
    ap.add_argument("--pieces", type=int, default=10)
    ap.add_argument("--piece-s", type=float, default=60.0)
    ap.add_argument("--offset", type=float, default=1.0)
    ap.add_argument("--gain", type=float, default=1.3)
    ap.add_argument("--drift", type=float, default=2.0)
    ap.add_argument(
        "--skab",
        action="store_true",
        help="a real record instead: SKAB's anomaly-free pump run from --corpus, its first "
        "--train-frac fitted, the rest cut into --pieces files",
    )
    ap.add_argument("--corpus", type=Path, default=DEFAULT_CORPUS)
    ap.add_argument("--train-frac", type=float, default=0.45)
    args = ap.parse_args(argv)

    if args.skab:
        t, y, names = _skab(args.corpus)
        n0 = int(args.train_frac * len(t))
        step = (len(t) - n0) // args.pieces
        what = f"SKAB anomaly-free ({len(names)} sensors, 1 Hz, rows {len(t)})"
    else:
        total_s = args.train_s + args.pieces * args.piece_s
        t, y, names = simulate_building(
            args.floors, total_s, args.rate, seed=args.seed, sensors_per_floor=args.per_floor
        )
        n0 = int(round(args.train_s * args.rate))
        step = int(round(args.piece_s * args.rate))
        what = f"{len(names)} channels at {args.rate:g} Hz, seed {args.seed}"
    sd = y[:n0].std(axis=0)
    print(
        f"sweep_model_reuse: {what}; model fitted on {t[n0 - 1] - t[0]:g} s, {args.pieces} "
        f"pieces of {t[n0 + step - 1] - t[n0]:g} s"
    )
    false_alarms = right = own_right = 0
    errors: dict[str, list[float]] = {k: [] for k in KINDS}
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        src = _write(d / "train.csv", t[:n0], y[:n0], names)
        model = d / "m.model"
        last = t[n0 - 1] - t[0]
        code, found = _run(
            ["run", src, "--out", d / "fit", "--train", f"0:{last}", "--save-model", model]
        )
        if code != 0:
            print(f"the training recording itself has findings ({code}): {found}")
        print(f"{'piece':>5}  {'healthy':<10} {'fault from the first sample':<36} "
              f"{'with --model':<34} {'own training (first 20 %)'}")  # fmt: skip
        for k in range(args.pieces):
            a, b = n0 + k * step, n0 + (k + 1) * step
            piece = _write(d / "p.csv", t[a:b], y[a:b], names)
            _, healthy = _run(["run", piece, "--out", d / "h", "--model", model])
            false_alarms += bool(healthy)
            j = k % len(names)
            kind = KINDS[k % len(KINDS)]
            size = {
                "additive": args.offset * sd[j],
                "multiplicative": args.gain,
                "drift": args.drift * sd[j] / 60.0,
            }[kind]
            z = y[a:b].copy()
            if kind == "drift":  # on the rows' own times (a real record misses some)
                z[:, j] += size * (t[a:b] - t[a])
            else:
                z[:, j] = inject_fault(z[:, j], 1.0, kind, 0.0, size)
            faulty = _write(d / "f.csv", t[a:b], z, names)
            _, with_model = _run(["run", faulty, "--out", d / "m", "--model", model])
            with_model = _beyond(with_model, healthy)  # the untouched file's own findings out
            code, own = _run(["run", faulty, "--out", d / "o"])
            ok = [(f["channel"], f["type"]) for f in with_model] == [(names[j], kind)]
            right += ok
            own_right += [(f["channel"], f["type"]) for f in own] == [(names[j], kind)]
            if ok:
                errors[kind].append(abs(with_model[0]["magnitude"][KEY[kind]] / size - 1.0))

            def show(fs: list[dict]) -> str:
                return (
                    "; ".join(
                        f"{f['channel']} {f['type']} {f['onset_s']:.2f} s "
                        + " ".join(f"{v:.4g}" for v in f["magnitude"].values())
                        for f in fs
                    )
                    or "none"
                )

            print(
                f"{k:>5}  {('none' if not healthy else show(healthy)):<10} "
                f"{f'{names[j]} {kind} {size:.4g}':<36} {show(with_model):<34} "
                + (show(own) if code in (0, 1) else "cannot train (exit 2)")
            )
    print(
        f"healthy pieces with a finding: {false_alarms}/{args.pieces}; faults from the first "
        f"sample right with --model: {right}/{args.pieces}, trained on their own first "
        f"20 %: {own_right}/{args.pieces}"
    )
    for kind, errs in errors.items():
        if errs:
            print(f"  {kind}: size error at most {100 * max(errs):.2f} % ({len(errs)} cases)")
    return 0


if __name__ == "__main__":
    sys.exit(main_())
