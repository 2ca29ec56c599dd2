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

    python benchmarks/profile_run.py ARCHIVE [--mode threads|cprofile] [--top 30]
                                     [--pstats FILE] [-- ANALYZER RUN OPTIONS]

Set ``OPENBLAS_NUM_THREADS=1`` as the other benchmarks do (set here when unset).
"""

from __future__ import annotations

import argparse
import collections
import concurrent.futures
import cProfile
import functools
import io
import os
import pstats
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


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


def run_threads(argv: list[str]) -> None:
    """The run with every thread-pool task and each detector's fit and run timed."""
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
    print(f"{main_cpu:7.3f} {main_cpu / process_cpu:6.1%} {'':6}  main thread (all of it)")
    rest = process_cpu - tasks - main_cpu
    print(f"{rest:7.3f} {rest / process_cpu:6.1%} {'':6}  other threads (reading, stores)")


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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("archive", type=Path)
    parser.add_argument("--mode", choices=("threads", "cprofile"), default="threads")
    parser.add_argument("--top", type=int, default=30, help="functions listed (cprofile)")
    parser.add_argument("--pstats", type=Path, help="also save the cProfile statistics here")
    parser.add_argument("run_args", nargs="*", help="more `analyzer run` options, after --")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as out:
        argv = ["run", str(args.archive), "--out", out, "--no-progress", *args.run_args]
        print(f"profile_run: {args.mode}, load average {os.getloadavg()[0]:.1f}, {args.archive}")
        if args.mode == "threads":
            run_threads(argv)
        else:
            run_cprofile(argv, args.top, args.pstats)


if __name__ == "__main__":
    main()
