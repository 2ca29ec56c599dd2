"""``analyzer watch --once`` over a folder of hourly files, locally and with
``--scheduler`` on a local Dask cluster (each archive a task; the workers read the files):
wall time, archives per hour of machine time, the watcher's own peak memory and each
worker's, and whether the two give the same records and findings.

The files are ``bench_pipeline.py``'s (16 channels at 100 Hz, one hour each, cut from one
continuous simulation; written to ``--keep DIR`` and reused from there), hard-linked into
an inbox (the watcher never writes them). With ``--model`` one model is fitted on the
first file (``analyzer run --save-model``, not timed) and every archive is tested against
it, as a long campaign would be audited. A script, not a timed test::

    python benchmarks/bench_watch_cluster.py [--files 4] [--formats mcap] [--workers 2]
                                             [--keep DIR] [--model]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported

import argparse  # noqa: E402
import json  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_bank import revision  # noqa: E402
from bench_dask import peak_kb, require_distributed, started_cluster  # noqa: E402
from bench_pipeline import RATE_HZ, byte_compile, parse_list, write_pieces  # noqa: E402

ENV = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", PYTHONPATH=str(ROOT))


def vm_hwm_kb(pid: int) -> int:
    """Peak resident set of process ``pid`` so far (``VmHWM``), 0 once it is gone."""
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return 0


def watch_once(inbox: Path, reports: Path, extra: list[str]) -> tuple[float, float, int]:
    """``analyzer watch inbox --out reports --once [extra]`` in a child: wall seconds, the
    watcher's own peak RSS in MB (its analyses run in other processes) and the exit code."""
    cmd = [sys.executable, "-m", "analyzer", "watch", str(inbox), "--out", str(reports)]
    cmd += ["--once", "--settle", "0.5", *extra]
    begin = time.perf_counter()
    proc = subprocess.Popen(cmd, env=ENV, cwd=ROOT, stderr=subprocess.PIPE, text=True)
    peak = 0
    while proc.poll() is None:
        peak = max(peak, vm_hwm_kb(proc.pid))
        time.sleep(0.05)
    wall = time.perf_counter() - begin
    err = proc.stderr.read() if proc.stderr else ""
    if proc.returncode != 0:
        raise SystemExit(f"watch failed (exit {proc.returncode}): {err[-800:]}")
    return wall, peak / 1024.0, proc.returncode


def records(reports: Path) -> dict[str, Any]:
    """Per archive: its verdict, faulty sensors and the faults of its findings.json."""
    doc = json.loads((reports / ".watch-state.json").read_text())
    out = {}
    for name, rec in doc["archives"].items():
        findings = reports / name / "findings.json"
        faults = json.loads(findings.read_text())["faults"] if findings.is_file() else None
        out[name] = (rec["verdict"], rec.get("faulty_sensors"), faults)
    return out


def on_cluster(inbox: Path, reports: Path, extra: list[str], workers: int) -> tuple[Any, ...]:
    """:func:`watch_once` with ``--scheduler`` on a fresh local cluster
    (:func:`bench_dask.started_cluster`); also the workers' peak RSS in MB."""
    with started_cluster(ROOT, workers) as (address, client):
        wall, peak, code = watch_once(inbox, reports, [*extra, "--scheduler", address])
        peaks = sorted(v / 1024.0 for v in client.run(peak_kb).values())
    return wall, peak, code, peaks


def main(argv: list[str] | None = None) -> int:
    import bench_dask
    import cloudpickle

    cloudpickle.register_pickle_by_value(bench_dask)  # peak_kb runs on the workers
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--files", type=int, default=4, help="hourly files (default 4)")
    parser.add_argument("--formats", default="mcap", help="csv and/or mcap (default mcap)")
    parser.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--keep", metavar="DIR", help="write (and reuse) the files in DIR")
    parser.add_argument("--model", action="store_true", help="test every file against one model")
    args = parser.parse_args(argv)
    require_distributed(parser)
    if args.files < 1 or args.workers < 1:
        parser.error("--files and --workers must be >= 1")
    formats = parse_list(args.formats)
    byte_compile(ROOT)
    print(
        f"bench_watch_cluster: {os.cpu_count()} cores, local watcher with --jobs "
        f"{os.cpu_count()} vs {args.workers} workers x 1 thread, {args.files} hourly files of "
        f"16 channels at {RATE_HZ:g} Hz{', one saved model' if args.model else ''}, "
        f"commit {revision()}",
        flush=True,
    )
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench_watch_cluster_") as tmp:
        base = Path(args.keep) if args.keep else Path(tmp)
        pieces, _ = write_pieces(
            base / "16ch_3600s_continuous", formats, args.files, 3600.0, 8, True, None
        )
        for f in formats:
            inbox = Path(tmp) / f"inbox_{f}"
            inbox.mkdir()
            for k, piece in enumerate(pieces[f][: args.files]):
                target = inbox / f"hour{k:03d}{piece.suffix}"
                try:
                    os.link(piece, target)
                except OSError:
                    shutil.copy2(piece, target)
            extra: list[str] = []
            if args.model:
                model = Path(tmp) / f"{f}.model"
                subprocess.run(
                    [sys.executable, "-m", "analyzer", "run", str(pieces[f][0]), "--out",
                     str(Path(tmp) / f"fit_{f}"), "--save-model", str(model), "--no-progress"],
                    env=ENV, cwd=ROOT, check=False, capture_output=True,
                )  # fmt: skip
                extra = ["--model", str(model)]
            local, remote = Path(tmp) / f"local_{f}", Path(tmp) / f"cluster_{f}"
            wall_l, peak_l, _ = watch_once(inbox, local, extra)
            print(f"  {f} local: {wall_l:.1f} s, watcher peak {peak_l:.0f} MB", flush=True)
            wall_c, peak_c, _, workers = on_cluster(inbox, remote, extra, args.workers)
            print(
                f"  {f} cluster: {wall_c:.1f} s, watcher peak {peak_c:.0f} MB, workers "
                + ", ".join(f"{p:.0f}" for p in workers)
                + " MB",
                flush=True,
            )
            same = records(local) == records(remote)
            n = len(records(local))
            rows.append((f, n, wall_l, peak_l, wall_c, peak_c, max(workers), same))
    print()
    print(
        f"{'format':<7}{'files':>6}{'local s':>9}{'watcher MB':>12}{'cluster s':>11}"
        f"{'watcher MB':>12}{'worker MB':>11}  same records and findings"
    )
    for f, n, wl, pl, wc, pc, pw, same in rows:
        print(f"{f:<7}{n:>6}{wl:>9.1f}{pl:>12.0f}{wc:>11.1f}{pc:>12.0f}{pw:>11.0f}  {same}")
    print(
        "local: analyses in processes forked by the watcher (--jobs = cores); cluster: each "
        "archive one task, read by its worker; watcher MB: the watcher process's own peak "
        "RSS; worker MB: the largest worker's (VmHWM)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
