"""``analyzer run --scheduler`` on a local Dask cluster: wall time and the peak memory of
the run's own process and of each worker, against the same run without a cluster.

The archives are ``bench_pipeline.py``'s (16 channels at 100 Hz, hourly files, cut from
one continuous simulation; written to ``--keep DIR`` and reused from there). For every
format and length of ``--hours`` it runs, in turns:

* ``local``: ``analyzer run ARCHIVE`` (threads, as by default);
* ``dask``: ``analyzer run ARCHIVE --scheduler ADDRESS`` against a fresh
  local cluster (a ``dask scheduler`` and ``--workers`` worker processes with one thread
  each, ``OPENBLAS_NUM_THREADS=1``, all importing the checkout being measured), started
  for that run alone so each worker's peak belongs to it;

and prints their wall time, the run's peak RSS (its ``VmHWM``), each worker's peak RSS
(``VmHWM`` asked of the worker after the run) and whether the two runs listed the same
faults. ``--baseline-src DIR`` adds the same cluster run with another checkout (``git
worktree add DIR COMMIT``; its workers import it too), to compare two designs in one
run. On one machine a cluster only adds transfers: the point is what each process holds,
which on a cluster must not grow with the archive. A script, not a timed test::

    python benchmarks/bench_dask.py [--hours 1,4] [--formats mcap] [--workers 2]
                                    [--keep DIR] [--repeat N] [--baseline-src DIR]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported

import argparse  # noqa: E402
import contextlib  # noqa: E402
import socket  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from collections.abc import Iterator  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_bank import revision  # noqa: E402
from bench_pipeline import (  # noqa: E402
    RATE_HZ,
    archive_dir,
    baseline_checkout,
    faults_of,
    parse_list,
    run_child,
    write_pieces,
)


def peak_kb() -> int:  # (sent by value: the workers cannot import this script)
    """This process's peak resident set (``VmHWM``), in kB: run on each worker."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1])
    import resource

    return int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)


def require_distributed(parser: argparse.ArgumentParser) -> None:
    """A usage error of ``parser`` when the ``distributed`` extra is not installed."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        parser.error("needs the distributed extra: pip install -e '.[distributed]'")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextlib.contextmanager
def started_cluster(root: Path, workers: int) -> Iterator[tuple[str, Any]]:
    """A fresh local cluster for one measurement: a scheduler and ``workers`` worker
    processes of one thread each, started as ``dask scheduler`` / ``dask worker`` would
    be, all importing ``root``'s analyzer (the scheduler unpickles the task graph too, so
    it must run the same checkout as the run); yields its address and a client, and
    stops every process at the end."""
    from distributed import Client

    env = dict(os.environ)
    env.update(
        OPENBLAS_NUM_THREADS="1",
        OMP_NUM_THREADS="1",
        PYTHONPATH=os.pathsep.join(filter(None, [str(root), os.environ.get("PYTHONPATH")])),
    )
    address = f"tcp://127.0.0.1:{free_port()}"
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "env": env, "cwd": root}
    procs = [
        subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
             "--port", address.rsplit(":", 1)[1], "--dashboard-address", ":0"],
            **quiet,
        )
    ]  # fmt: skip
    try:
        with Client(address, timeout=60) as client:
            procs.append(
                subprocess.Popen(
                    [sys.executable, "-m", "distributed.cli.dask_worker", address,
                     "--nworkers", str(workers), "--nthreads", "1", "--no-dashboard"],
                    **quiet,
                )
            )  # fmt: skip
            client.wait_for_workers(workers, timeout=120)
            yield address, client
    finally:
        for proc in reversed(procs):
            proc.terminate()
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()


def cluster_run(archive: Path, out: Path, log: Path, root: Path, workers: int):
    """``archive`` analyzed on a fresh local cluster (:func:`started_cluster`): the run
    and the workers' peak RSS in MB."""
    with started_cluster(root, workers) as (address, client):
        run = run_child(archive, out, log, extra=["--scheduler", address], root=root)
        peaks = sorted(v / 1024.0 for v in client.run(peak_kb).values())
    return run, peaks


def main(argv: list[str] | None = None) -> int:
    import cloudpickle

    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--hours", default="1,4", help="archive lengths in hours (default 1,4)")
    parser.add_argument("--formats", default="mcap", help="csv and/or mcap (default mcap)")
    parser.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--keep", metavar="DIR", help="write (and reuse) the archives in DIR")
    parser.add_argument("--repeat", type=int, default=1, help="runs of each kind, in turns")
    parser.add_argument("--baseline-src", metavar="DIR", help="another checkout's cluster run")
    args = parser.parse_args(argv)
    require_distributed(parser)
    if args.workers < 1 or args.repeat < 1:
        parser.error("--workers and --repeat must be >= 1")
    hours = [float(h) for h in parse_list(args.hours)]
    formats = parse_list(args.formats)
    kinds = [("local", ROOT), ("dask", ROOT)]
    if args.baseline_src:
        kinds.append(("dask baseline", baseline_checkout(parser, args.baseline_src)))
    print(
        f"bench_dask: {os.cpu_count()} cores, {args.workers} workers x 1 thread, 16 channels "
        f"at {RATE_HZ:g} Hz, commit {revision()}"
        + (f", baseline commit {revision(kinds[2][1])}" if args.baseline_src else ""),
        flush=True,
    )
    piece_s = 3600.0
    with tempfile.TemporaryDirectory(prefix="bench_dask_") as tmp:
        base = Path(args.keep) if args.keep else Path(tmp)
        data_dir = base / f"16ch_{piece_s:g}s_continuous"
        needed = max(int(-(-h // 1)) for h in hours)
        pieces, _ = write_pieces(data_dir, formats, needed, piece_s, 8, True, None)
        rows = []
        for f in formats:
            for h in hours:
                archive = archive_dir(data_dir, f, h, pieces[f], piece_s)
                seen: dict[str, list] = {k: [] for k, _ in kinds}
                for turn in range(args.repeat):
                    for kind, root in kinds if turn % 2 == 0 else kinds[::-1]:
                        out = Path(tmp) / f"out_{kind.replace(' ', '_')}_{f}_{h:g}"
                        log = Path(tmp) / f"log_{kind.replace(' ', '_')}_{f}_{h:g}.txt"
                        try:
                            if kind == "local":
                                run, peaks = run_child(archive, out, log, root=root), []
                            else:
                                run, peaks = cluster_run(archive, out, log, root, args.workers)
                        except SystemExit as failed:  # run_child: exit 2, or a crash
                            print(f"  {f} {h:g} h {kind}: {failed}", flush=True)
                            seen[kind].append(None)
                            continue
                        seen[kind].append((run, peaks, faults_of(out)))
                        workers = ", ".join(f"{p:.0f}" for p in peaks)
                        print(
                            f"  {f} {h:g} h {kind}: {run.wall_s:.1f} s, run peak "
                            f"{run.peak_mb:.0f} MB" + (f", workers {workers} MB" if peaks else ""),
                            flush=True,
                        )
                local = [x for x in seen["local"] if x is not None]
                local_faults = local[0][2] if local else None
                for kind, _ in kinds:
                    done = [x for x in seen[kind] if x is not None]
                    failed = len(seen[kind]) - len(done)
                    if not done:
                        rows.append((f, h, kind, None, None, None, 0, failed))
                        continue
                    rows.append(
                        (
                            f,
                            h,
                            kind,
                            statistics.median(r.wall_s for r, _, _ in done),
                            statistics.median(r.peak_mb for r, _, _ in done),
                            max((max(p) for _, p, _ in done if p), default=float("nan")),
                            sum(fa == local_faults for _, _, fa in done),
                            failed,
                        )
                    )
        print()
        print(
            f"{'format':<7}{'hours':>6}  {'run':<14}{'wall s':>8}{'run peak':>11}"
            f"{'worker peak':>13}  same faults as local"
        )
        for f, h, kind, wall, peak, wpeak, same, failed in rows:
            if wall is None:
                print(f"{f:<7}{h:>6g}  {kind:<14}  failed ({failed} of {args.repeat} runs)")
                continue
            worker = f"{wpeak:>10.0f} MB" if wpeak == wpeak else f"{'-':>13}"
            note = f" ({failed} failed)" if failed else ""
            print(
                f"{f:<7}{h:>6g}  {kind:<14}{wall:>8.1f}{peak:>8.0f} MB{worker}  "
                f"{same}/{args.repeat - failed}{note}"
            )
        print(
            "medians over the runs; run peak: VmHWM of the analyzer's process; worker peak: "
            "the largest VmHWM of the cluster's workers after the run (each run has its own "
            "cluster)"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
