"""Peak memory and time of fitting on a long healthy window (``--train``, ``--save-model``).

The workflow *Fit once, audit every file* (README) fits on as long a healthy recording as
the user has: an hour, a day. Issue 9 asks that peak memory be set by the block size and
the number of channels, not by the archive's length; this script measures how a fit's
peak resident memory grows with the length of the training window itself.

It writes (or reuses, ``--keep DIR``) the continuous 16-channel, 100 Hz benchmark archive
of ``bench_pipeline.py --continuous`` (hourly MCAP files; ``--hours`` of them) and runs,
in a child process per case, ``analyzer run ARCHIVE --train 0:T --save-model FILE`` for
each ``T`` of ``--train-minutes``, every detector together (``--detectors`` to pick), as
``bench_pipeline.py`` runs its children (the CLI's own ``main``; peak RSS = the child's
``VmHWM``). It prints wall time, CPU time, peak RSS, the model file's size and the
growth of the peak per hour of training (a least-squares slope over the cases).

The baseline, in the same run: ``--baseline-src DIR``, another checkout of the analyzer
(for example ``git worktree add /tmp/before <commit>``), run the same way on the same
archive; its rows are marked ``baseline``.

``--ar-rows N`` measures the AR fit alone instead (``fit_ar``, order 7, on a synthetic
``N x 16`` window, and a cross-validation fold's fit without its second fifth), in a
child per checkout: time and the peak of numpy's allocations above the start
(``tracemalloc``), against one copy of the window. A script, not a timed test::

    python benchmarks/bench_fit_memory.py [--hours 4] [--train-minutes 10,60,240]
                                          [--keep DIR] [--baseline-src DIR]
                                          [--detectors A,B] [--jobs N] [--ar-rows N]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported

import argparse  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_pipeline as bp  # noqa: E402
from bench_bank import revision  # noqa: E402

FLOORS = 8  # 16 channels, as bench_pipeline.py
PIECE_S = 3600.0


@dataclass
class Case:
    source: str
    train_min: float
    run: bp.Run
    model_mb: float


def measure(
    archive: Path, work: Path, train_min: float, root: Path, label: str, extra: list[str]
) -> Case:
    """One child: ``analyzer run archive --train 0:T --save-model`` with ``root``'s
    analyzer first on its path."""
    tag = f"{label}-{train_min:g}"
    model = work / f"{tag}.model"
    model.unlink(missing_ok=True)
    args = ["--train", f"0:{train_min * 60.0:g}", "--save-model", str(model), *extra]
    run = bp.run_child(archive, work / f"out-{tag}", work / f"{tag}.log", extra=args, root=root)
    size = model.stat().st_size / 1e6 if model.exists() else float("nan")
    model.unlink(missing_ok=True)
    return Case(label, train_min, run, size)


AR_CHILD = r"""
import sys, time, tracemalloc
import numpy as np
import analyzer.detectors.ar_model as arm
rows, m, order = int(sys.argv[1]), 16, 7
rng = np.random.default_rng(0)
Y = np.cumsum(rng.standard_normal((rows, m)), axis=0) * 1e-3 + rng.standard_normal((rows, m))
a, b = rows // 5, 2 * rows // 5
tracemalloc.start()
for what in ("whole window", "a fold"):
    tracemalloc.reset_peak()
    base = tracemalloc.get_traced_memory()[0]
    t0 = time.perf_counter()
    if what == "whole window":
        arm.fit_ar(Y, order)
    elif "exclude" in arm.fit_ar.__code__.co_varnames:
        arm.fit_ar(Y, order, exclude=(a, b))
    else:  # before fit_ar(exclude=...): the fold's copy, as the bank made it
        held = Y.copy()
        held[a:b] = np.nan
        arm.fit_ar(held, order)
        del held
    wall = time.perf_counter() - t0
    peak = (tracemalloc.get_traced_memory()[1] - base) / 2**20
    print(f"AR {what}|{wall:.2f}|{peak:.0f}|{Y.nbytes / 2**20:.0f}")
"""


def ar_fits(rows: int, sources: list[tuple[str, Path]]) -> None:
    """``--ar-rows``: the AR fit alone, in a child per checkout (:data:`AR_CHILD`)."""
    print(f"{'source':8s} {'fit':14s} {'wall s':>7s} {'peak MB':>8s} {'one copy MB':>11s}")
    for label, root in sources:
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(root), env.get("PYTHONPATH")]))
        done = subprocess.run(
            [sys.executable, "-c", AR_CHILD, str(rows)],
            capture_output=True, text=True, env=env, cwd=root, check=True,
        )  # fmt: skip
        for line in done.stdout.splitlines():
            if line.startswith("AR "):
                what, wall, peak, copy = line[3:].split("|")
                print(f"{label:8s} {what:14s} {float(wall):7.2f} {float(peak):8.0f} {copy:>11s}")


def slope_mb_per_hour(cases: list[Case]) -> float:
    """Least-squares growth of the peak RSS per hour of training."""
    if len(cases) < 2:
        return float("nan")
    x = np.array([c.train_min / 60.0 for c in cases])
    y = np.array([c.run.peak_mb for c in cases])
    return float(np.polyfit(x, y, 1)[0])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=int, default=4, help="archive length (hourly files)")
    parser.add_argument(
        "--train-minutes", default="10,60,240", help="training window lengths, in minutes"
    )
    parser.add_argument("--keep", metavar="DIR", help="write (and reuse) the archive in DIR")
    parser.add_argument(
        "--baseline-src",
        metavar="DIR",
        help="another checkout of the analyzer, measured the same way (the baseline)",
    )
    parser.add_argument("--detectors", default=None, help="pass --detectors A,B")
    parser.add_argument("--jobs", type=int, default=None, help="pass --jobs N")
    parser.add_argument(
        "--ar-rows",
        type=int,
        default=None,
        help="measure the AR fit alone on a synthetic window of this many rows x 16",
    )
    args = parser.parse_args(argv)
    minutes = [float(x) for x in args.train_minutes.split(",") if x.strip()]
    if not minutes or max(minutes) * 60.0 > args.hours * PIECE_S:
        raise SystemExit("bench_fit_memory: --train-minutes must fit in --hours")
    extra = []
    if args.detectors:
        extra += ["--detectors", args.detectors]
    if args.jobs:
        extra += ["--jobs", str(args.jobs)]
    sources = [("this", bp.ROOT)]
    if args.baseline_src:
        base = Path(args.baseline_src).resolve()
        if not (base / "analyzer" / "__init__.py").is_file():
            raise SystemExit(f"bench_fit_memory: --baseline-src {base}: no analyzer package")
        sources.append(("baseline", base))
        print(f"# baseline: {base}, commit {revision(base)}")
    if args.ar_rows:
        print(
            f"# commit {revision()}, OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}"
        )
        ar_fits(args.ar_rows, sources)
        return 0

    with tempfile.TemporaryDirectory(prefix="bench-fit-") as tmp:
        base_dir = Path(args.keep) if args.keep else Path(tmp)
        data_dir = base_dir / f"{2 * FLOORS}ch_{PIECE_S:g}s_continuous"
        pieces, _ = bp.write_pieces(data_dir, ["mcap"], args.hours, PIECE_S, FLOORS, True)
        archive = bp.archive_dir(data_dir, "mcap", float(args.hours), pieces["mcap"], PIECE_S)
        work = Path(tmp) / "work"
        work.mkdir()
        print(
            f"# {platform.node()} {os.cpu_count()} cores, commit {revision()}, "
            f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}, "
            f"archive {args.hours} h x 16 channels at 100 Hz (MCAP)"
        )
        cases: list[Case] = []
        for train_min in minutes:  # taken in turns: the machine's speed drifts
            for label, root in sources:
                cases.append(measure(archive, work, train_min, root, label, extra))
                c = cases[-1]
                print(
                    f"  {label:8s} train {train_min:6g} min: wall {c.run.wall_s:6.1f} s, "
                    f"peak {c.run.peak_mb:7.0f} MB",
                    flush=True,
                )
        print()
        print(
            f"{'source':8s} {'train min':>9s} {'wall s':>7s} {'cpu s':>7s} "
            f"{'peak RSS MB':>11s} {'model MB':>8s} {'exit':>4s}"
        )
        for c in cases:
            print(
                f"{c.source:8s} {c.train_min:9g} {c.run.wall_s:7.1f} {c.run.cpu_s:7.1f} "
                f"{c.run.peak_mb:11.0f} {c.model_mb:8.1f} {c.run.rc:4d}"
            )
        print()
        for label, _ in sources:
            mine = [c for c in cases if c.source == label]
            print(
                f"{label}: peak RSS grows {slope_mb_per_hour(mine):.0f} MB per hour of "
                "training (least squares over the cases)"
            )
        print(f"load average at the end {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
