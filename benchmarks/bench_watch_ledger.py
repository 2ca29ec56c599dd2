"""The watcher's bookkeeping over a year of hourly files: what recording one archive costs
the watcher as its state grows.

After each archive the watcher writes ``REPORTS/.watch-state.json`` (every record) and
the views ``index.json`` and ``index.html``. This script fills a :class:`Ledger` with
``N`` synthetic records (a year of hourly files by default, a fault in one archive of
50; the records' fields as the watcher writes them) and times, at a few sizes of the
state, recording one more archive:

* ``record``: :meth:`Ledger.record`, what the watcher does after each archive (the state
  at once; the views when due, which the sum below counts as often as they are due when
  an archive ends every ``--every`` seconds);
* ``save``: :meth:`Ledger.save`, the state and both views rewritten: what ``record`` did
  up to 361fe2d, the named baseline. ``--baseline-src DIR`` (a checkout of an older
  commit: ``git worktree add DIR 361fe2d``) times that checkout's ``record`` too, in a
  child process, in the same run.

Prints, per size, the seconds of one recording, and the sum over the whole year
(trapezoid over the sizes measured). A script, not a timed test.

    python benchmarks/bench_watch_ledger.py [--records 8760] [--every 8]
                                            [--baseline-src DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

if "--child" not in sys.argv:  # a child imports the checkout on its PYTHONPATH
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

SIZES = (100, 1000, 2000, 4380, 8760, 17520)
REPEAT = 5


def _fill(ledger: Any, record_cls: Any, verdict: Any, n: int) -> None:
    """Records 0 .. n - 1 straight into the ledger's dict (not timed)."""
    for i in range(len(ledger.records), n):
        ledger.records[_name(i)] = _record(record_cls, verdict, i)


def _name(i: int) -> str:
    day, hour = divmod(i, 24)
    return f"shm-{day // 365 + 2026}-{day % 365:03d}-{hour:02d}.mcap"


def _record(record_cls: Any, verdict: Any, i: int) -> Any:
    name = _name(i)
    faulty = i % 50 == 0
    when = f"2026-01-01T{i % 24:02d}:00:00.000Z"
    return record_cls(
        name=name,
        sha256=f"{i:064x}",
        verdict=verdict.FAULT if faulty else verdict.NO_FAULT,
        report=f"{name}/report.html",
        inputs=[f"/data/inbox/{name}"],
        processed=when,
        analysis_s=7.3,
        faulty_sensors=["/s5.data"] if faulty else [],
        faults=1 if faulty else 0,
        start=when,
        duration_s=3600.0,
        signature=[[name, 51_234_567, 1.7e9 + i]],
        fault_list=[{"channel": "/s5.data", "type": "additive", "onset": when, "end": None}]
        if faulty
        else [],
    )


def measure(sizes: list[int]) -> dict[str, Any]:
    """Seconds of one ``record`` (the state only, views not due), of one rewrite of the
    views, and of one full ``save`` at each size (the best of :data:`REPEAT`)."""
    from analyzer import watch_index
    from analyzer.watch_index import Ledger, Record, Verdict

    out: dict[str, Any] = {"record": {}, "views": {}, "save": {}}
    with tempfile.TemporaryDirectory() as tmp:
        ledger = Ledger(Path(tmp))
        has_views = hasattr(ledger, "refresh_views")
        for n in sizes:
            _fill(ledger, Record, Verdict, n - 1)
            best: dict[str, float] = {}
            for k in range(REPEAT):
                rec = _record(Record, Verdict, n - 1 + k)
                if has_views:
                    ledger.refresh_views(force=True)  # written just now: not due
                begin = time.perf_counter()
                ledger.record(rec)
                best["record"] = min(best.get("record", 1e9), time.perf_counter() - begin)
                del ledger.records[rec.name]
                if has_views:
                    ledger._views_stale = True
                    begin = time.perf_counter()
                    ledger.refresh_views(force=True)
                    best["views"] = min(best.get("views", 1e9), time.perf_counter() - begin)
                begin = time.perf_counter()
                ledger.save()
                best["save"] = min(best.get("save", 1e9), time.perf_counter() - begin)
            for key, value in best.items():
                out[key][n] = value
        out["interval"] = getattr(ledger, "_views_interval", None)
        out["min_interval"] = getattr(watch_index, "VIEW_INTERVAL_S", None)
    return out


def year_total(per: dict[int, float], records: int) -> float:
    """Sum over recordings 1 .. records of the cost at that size (trapezoid over the
    measured sizes, linear from 0 below the first)."""
    points = sorted((n, s) for n, s in per.items() if n <= records)
    total, last_n, last_s = 0.0, 0, 0.0
    for n, s in points:
        total += (n - last_n) * (last_s + s) / 2
        last_n, last_s = n, s
    return total


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--records", type=int, default=8760, help="archives (default: a year)")
    parser.add_argument(
        "--every", type=float, default=8.0, help="seconds between two archives' ends"
    )
    parser.add_argument("--baseline-src", type=Path, default=None)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    sizes = sorted({n for n in SIZES if n < args.records} | {args.records})
    if args.child:
        print(json.dumps(measure(sizes)))
        return 0
    here = Path(__file__).resolve()
    runs = {"this checkout": _child(here, Path(here.parents[1]), args)}
    if args.baseline_src is not None:
        runs[f"baseline {args.baseline_src}"] = _child(here, args.baseline_src, args)
    print(
        f"bench_watch_ledger: {args.records} records (a fault in 1 of 50), an archive "
        f"ending every {args.every:g} s; seconds per archive at each size of the state"
    )
    header = f"{'':34s}" + "".join(f"{n:>9d}" for n in sizes) + f"{'year s':>10s}"
    print(header)
    for label, res in runs.items():
        for key in ("record", "views", "save"):
            per = {int(n): s for n, s in res[key].items()}
            if not per:
                continue
            cells = "".join(f"{per[n]:9.4f}" for n in sizes)
            print(f"{label + ' ' + key:34s}{cells}{year_total(per, args.records):10.1f}")
    mine = runs["this checkout"]
    record = {int(n): s for n, s in mine["record"].items()}
    views = {int(n): s for n, s in mine["views"].items()}
    # the views are due every max(VIEW_INTERVAL_S, cost / VIEW_SHARE) seconds: with an
    # archive every `every` seconds, on one archive in ceil(interval / every)
    share = {
        n: views[n] / max(1.0, -(-max(mine["min_interval"], views[n] / 0.02) // args.every))
        for n in views
    }
    watcher = year_total(record, args.records) + year_total(share, args.records)
    analysis = args.records * args.every
    print(
        f"this checkout over the year: {watcher:.0f} s of the watcher's time "
        f"({100 * watcher / analysis:.2f} % of {analysis:.0f} s of archives)"
    )
    if args.baseline_src is not None:
        base = runs[f"baseline {args.baseline_src}"]
        old = year_total({int(n): s for n, s in base["record"].items()}, args.records)
        print(
            f"baseline over the year: {old:.0f} s ({100 * old / analysis:.2f} %; "
            f"x2 with --done, which records each archive again after its move)"
        )
    return 0


def _child(script: Path, src: Path, args: argparse.Namespace) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=str(src))
    cmd = [sys.executable, str(script), "--child", "--records", str(args.records)]
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True, cwd="/")
    return dict(json.loads(done.stdout.splitlines()[-1]))


if __name__ == "__main__":
    raise SystemExit(main())
