"""Where an ``analyzer run`` spends its CPU: per task of the thread pool, or per function.

Two views of one ``analyzer run ARCHIVE`` in this process (the checkout this script is
in), a script, not a timed test:

* ``--mode threads`` (default): the run as the CLI makes it (one thread per core), each
  function handed to a thread pool wrapped to add up the CPU time of the thread that
  runs it (``time.thread_time``), exclusive of the wrapped calls inside it, and likewise
  each detector's ``fit`` and ``run``; so the table gives CPU seconds per task kind (the
  windowed tests, the bank's time blocks, ...) however the two cores interleave them,
  which the stage timings (wall time) cannot. The main thread's CPU (start-up, reading's
  own share, the outputs) is printed apart.
* ``--mode cprofile``: the run serially (``--jobs 1``: the tasks run on the main thread,
  where cProfile sees them) under cProfile, the ``--top`` functions by cumulative and by
  own time. The reading's threads are not in it.

Both call the CLI's ``main`` as the console script does: the report's figures are drawn
by worker processes (their CPU is not this process's), as in ``bench_pipeline.py``.

``--src DIR`` profiles another checkout (``git worktree add DIR COMMIT``) instead of this
one, so that a commit older than this script can be profiled the same way. The
checkout's bytecode is written first, as ``pip install`` does and ``bench_pipeline.py``
does: under ``PYTHONDONTWRITEBYTECODE`` (set on the shared machine) a checkout without
it compiles its modules again in every run, 0.3-0.4 s of the main thread's CPU that no
installed analyzer spends and that one checkout of a comparison may pay and the other
not. ``--baseline-src DIR --repeat N`` runs this checkout and DIR in turns, each in a
process of its own (threads mode, N runs each), and tables the median CPU of each task
for both and their difference: which stage a commit made dearer, in CPU seconds, which
the machine's load moves less than the wall time.

    python benchmarks/profile_run.py ARCHIVE [--mode threads|cprofile] [--top 30]
                                     [--pstats FILE] [--src DIR]
                                     [--baseline-src DIR [--repeat 2]]
                                     [-- ANALYZER RUN OPTIONS]

Set ``OPENBLAS_NUM_THREADS=1`` as the other benchmarks do (set here when unset).
"""

from __future__ import annotations

import argparse
import collections
import compileall
import concurrent.futures
import cProfile
import functools
import io
import json
import os
import pstats
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
HERE = Path(__file__).resolve().parents[1]
"""The checkout this script is in: the one profiled unless ``--src`` names another."""

MAIN = "main thread (all of it)"
OTHER = "other threads (reading, stores)"


class ThreadCPU:
    """CPU seconds of the calls of wrapped functions, per name, exclusive of the wrapped
    calls they make on the same thread (a fit that maps its tasks serially counts only
    its own part; the tasks count under their own names)."""

    def __init__(self) -> None:
        self.seconds: collections.Counter[str] = collections.Counter()
        self.calls: collections.Counter[str] = collections.Counter()
        self._local = threading.local()
        self._lock = threading.Lock()

    def wrap(self, name: str, fn: Callable[..., Any]) -> Callable[..., Any]:
        @functools.wraps(fn)
        def timed(*args: Any, **kwargs: Any) -> Any:
            stack = self._local.__dict__.setdefault("stack", [])
            stack.append(0.0)  # CPU of the wrapped calls made inside this one
            t0 = time.thread_time()
            try:
                return fn(*args, **kwargs)
            finally:
                spent = time.thread_time() - t0
                inner = stack.pop()
                if stack:
                    stack[-1] += spent
                with self._lock:
                    self.seconds[name] += spent - inner
                    self.calls[name] += 1

        return timed


def _task_name(fn: Any) -> str:
    module = (getattr(fn, "__module__", None) or "").rsplit(".", 1)[-1]
    return f"{module}.{getattr(fn, '__qualname__', type(fn).__name__)}"


def run_threads(argv: list[str]) -> dict[str, Any]:
    """The run with every thread-pool task and each detector's fit and run timed: the
    exit code, wall and process CPU seconds and each task's CPU seconds (and the main
    and other threads' under :data:`MAIN` and :data:`OTHER`), also printed."""
    cpu = ThreadCPU()
    submit = concurrent.futures.ThreadPoolExecutor.submit

    def timed_submit(pool: Any, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Any:
        return submit(pool, cpu.wrap(_task_name(fn), fn), *args, **kwargs)

    concurrent.futures.ThreadPoolExecutor.submit = timed_submit  # type: ignore[method-assign]
    from analyzer.cli import main
    from analyzer.detectors.ar_kalman import ARKalmanBank
    from analyzer.detectors.detection_filter import DetectionFilter
    from analyzer.detectors.equivalent_model import EquivalentModel

    for cls in (ARKalmanBank, DetectionFilter, EquivalentModel):
        for method in ("fit", "run"):
            setattr(cls, method, cpu.wrap(f"{cls.__name__}.{method}", getattr(cls, method)))
    main_cpu, process_cpu, wall = time.thread_time(), time.process_time(), time.perf_counter()
    rc = main(argv, figure_processes=True)  # as the console script: figures in workers
    main_cpu = time.thread_time() - main_cpu
    process_cpu, wall = time.process_time() - process_cpu, time.perf_counter() - wall
    tasks = sum(cpu.seconds.values())
    print(f"exit {rc}; wall {wall:.2f} s, CPU {process_cpu:.2f} s (this process's threads)")
    print(f"{'CPU s':>7} {'share':>6} {'calls':>6}  task (exclusive thread CPU)")
    for name, seconds in cpu.seconds.most_common():
        print(f"{seconds:7.3f} {seconds / process_cpu:6.1%} {cpu.calls[name]:6d}  {name}")
    rest = process_cpu - tasks - main_cpu
    print(f"{main_cpu:7.3f} {main_cpu / process_cpu:6.1%} {'':6}  {MAIN}")
    print(f"{rest:7.3f} {rest / process_cpu:6.1%} {'':6}  {OTHER}")
    return {
        "exit": rc,
        "wall_s": wall,
        "cpu_s": process_cpu,
        "tasks": {**cpu.seconds, MAIN: main_cpu, OTHER: rest},
    }


def run_cprofile(argv: list[str], top: int, keep: Path | None) -> None:
    """The run serially under cProfile; the top functions by cumulative and own time."""
    from analyzer.cli import main

    profile = cProfile.Profile()
    process_cpu, wall = time.process_time(), time.perf_counter()
    rc = profile.runcall(main, [*argv, "--jobs", "1"], figure_processes=True)
    process_cpu, wall = time.process_time() - process_cpu, time.perf_counter() - wall
    print(f"exit {rc}; wall {wall:.2f} s, CPU {process_cpu:.2f} s (serial, under cProfile)")
    if keep is not None:
        profile.dump_stats(str(keep))
    for order in ("cumulative", "tottime"):
        out = io.StringIO()
        pstats.Stats(profile, stream=out).sort_stats(order).print_stats(top)
        text = out.getvalue().split("\n", 3)[-1]  # from "Ordered by" on
        print(text.strip().replace(str(Path.cwd()) + "/", "") + "\n")


def byte_compile(root: Path) -> None:
    """Write the bytecode of ``root``'s analyzer package (see the module's docstring)."""
    if not compileall.compile_dir(str(root / "analyzer"), quiet=1):
        raise SystemExit(f"profile_run: {root / 'analyzer'} does not compile")


def median_tasks(runs: list[dict[str, float]]) -> dict[str, float]:
    """Each task's median CPU seconds over ``runs`` (a task missing from a run counts 0 s
    there: a commit may split or merge the tasks)."""
    names = {name for run in runs for name in run}
    return {name: statistics.median(run.get(name, 0.0) for run in runs) for name in names}


def comparison(mine: list[dict[str, Any]], theirs: list[dict[str, Any]]) -> list[str]:
    """The table of two checkouts' runs (:func:`run_threads`'s results): the median
    process CPU and each task's median CPU seconds for both, and this checkout's minus
    the baseline's; the largest differences either way first."""
    ours = median_tasks([run["tasks"] for run in mine])
    base = median_tasks([run["tasks"] for run in theirs])
    rows = [f"{'this':>7} {'base':>7} {'diff':>7}  task (median thread CPU s)"]
    cpu = [statistics.median(r["cpu_s"] for r in runs) for runs in (mine, theirs)]
    rows.append(f"{cpu[0]:7.2f} {cpu[1]:7.2f} {cpu[0] - cpu[1]:+7.2f}  the process in all")
    names = sorted(set(ours) | set(base), key=lambda n: -abs(ours.get(n, 0) - base.get(n, 0)))
    for name in names:
        a, b = ours.get(name, 0.0), base.get(name, 0.0)
        rows.append(f"{a:7.3f} {b:7.3f} {a - b:+7.3f}  {name}")
    return rows


def compare(args: argparse.Namespace, root: Path) -> None:
    """The checkout ``root`` and ``--baseline-src`` in turns, each run a process of its
    own."""
    sources = [("this", root), ("base", args.baseline_src.resolve())]
    runs: dict[str, list[dict[str, Any]]] = {label: [] for label, _ in sources}
    with tempfile.TemporaryDirectory(prefix="profile_run_") as tmp:
        for turn in range(args.repeat):  # the two take turns at going first
            for label, root in sources if turn % 2 == 0 else sources[::-1]:
                out = Path(tmp) / f"{label}{turn}.json"
                cmd = [sys.executable, __file__, str(args.archive), "--src", str(root)]
                cmd += ["--json", str(out)] + (["--", *args.run_args] if args.run_args else [])
                done = subprocess.run(cmd, capture_output=True, text=True, check=False)
                if done.returncode != 0 or not out.exists():
                    raise SystemExit(f"profile_run: the {label} run failed:\n{done.stderr}")
                runs[label].append(json.loads(out.read_text()))
                run = runs[label][-1]
                print(f"  {label} ({root}): wall {run['wall_s']:.1f} s, CPU {run['cpu_s']:.2f} s")
    print("\n".join(comparison(runs["this"], runs["base"])))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("archive", type=Path)
    parser.add_argument("--mode", choices=("threads", "cprofile"), default="threads")
    parser.add_argument("--top", type=int, default=30, help="functions listed (cprofile)")
    parser.add_argument("--pstats", type=Path, help="also save the cProfile statistics here")
    parser.add_argument("--src", type=Path, help="profile this checkout instead of this one")
    parser.add_argument(
        "--baseline-src", type=Path, help="another checkout, run in turns (threads mode)"
    )
    parser.add_argument("--repeat", type=int, default=2, help="runs each (--baseline-src)")
    parser.add_argument("--json", type=Path, help="also write the threads mode's figures here")
    parser.add_argument("run_args", nargs="*", help="more `analyzer run` options, after --")
    args = parser.parse_args()
    root = (args.src or HERE).resolve()
    byte_compile(root)
    if args.baseline_src is not None:
        byte_compile(args.baseline_src)
        print(
            f"profile_run: {root} against {args.baseline_src}, load average "
            f"{os.getloadavg()[0]:.1f}, {args.archive}"
        )
        compare(args, root)
        return
    sys.path.insert(0, str(root))  # before anything imports analyzer
    import analyzer

    if Path(analyzer.__file__).resolve().parents[1] != root:
        raise SystemExit(f"profile_run: analyzer imported from {analyzer.__file__}, not {root}")
    with tempfile.TemporaryDirectory() as out:
        argv = ["run", str(args.archive), "--out", out, "--no-progress", *args.run_args]
        print(f"profile_run: {args.mode}, load average {os.getloadavg()[0]:.1f}, {args.archive}")
        print(f"checkout: {root}")  # (checked above: the analyzer imported is this one's)
        if args.mode == "threads":
            result = run_threads(argv)
            if args.json is not None:
                args.json.write_text(json.dumps(result))
        else:
            run_cprofile(argv, args.top, args.pstats)


if __name__ == "__main__":
    main()
