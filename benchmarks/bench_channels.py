"""How ``analyzer run`` scales with the number of channels: channel groups against one group.

The multi-sensor detectors model their channels jointly (an AR model of ``p m`` states;
the bank solves one Riccati equation of that size per channel), so their cost grows like
``m^4`` and their memory like ``m^3``. ``analyzer run`` therefore analyzes at most 16
correlated channels together (:mod:`analyzer.grouping`). This script measures that, in
the same run, against the named baseline **one group of every channel** (what the
detectors did before the grouping, obtained now with a config whose single ``[[group]]``
lists every channel).

For each count of ``--channels`` it writes a CSV of a simulated shear building
(``simulate_building``, two sensors per floor, ``--minutes`` at ``--rate`` Hz) with a
fault on ``s5`` from two thirds of the record on (``--fault``: an offset of half a
standard deviation, a gain of 1.5, or a drift of one standard deviation per minute),
runs ``analyzer run`` on it in a child process (as ``bench_pipeline.py`` does: the CLI's
own ``main``, the child's own peak RSS from ``VmHWM``), and prints wall time, values/s,
peak RSS and what was found. The baseline runs only up to ``--baseline-max`` channels and
is stopped after ``--timeout`` seconds (it can take many minutes and gigabytes). A script,
not a timed test::

    python benchmarks/bench_channels.py [--channels 16,32,48] [--minutes 10] [--rate 100]
                                        [--baseline-max 48] [--timeout 900] [--keep DIR]
                                        [--fault additive|multiplicative|drift]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(HERE))

import bench_pipeline  # noqa: E402

from analyzer.simulate import simulate_building  # noqa: E402

FAULTY = 5
"""The channel given the fault (``s5``)."""


@dataclass
class Outcome:
    wall_s: float | None  # None: stopped at the timeout
    peak_mb: float
    found: str
    groups: int


FAULTS = {
    "additive": "an offset of half a standard deviation",
    "multiplicative": "a gain of 1.5",
    "drift": "a drift of one standard deviation per minute",
}


def write_csv(path: Path, channels: int, minutes: float, rate: float, fault: str) -> str:
    """The building's record with the fault (:data:`FAULTS`); returns what was injected."""
    t, Y, names = simulate_building(
        channels // 2, 60.0 * minutes, rate, seed=11, sensors_per_floor=2
    )
    onset = int(len(t) * 2 / 3)
    sd = float(Y[:onset, FAULTY].std())
    if fault == "additive":
        Y[onset:, FAULTY] += 0.5 * sd
        size = f"offset {0.5 * sd:.4g}"
    elif fault == "multiplicative":
        Y[onset:, FAULTY] *= 1.5
        size = "gain 1.5"
    else:
        Y[onset:, FAULTY] += sd * (t[onset:] - t[onset]) / 60.0
        size = f"rate {sd / 60.0:.4g} per s"
    header = "time," + ",".join(names)
    np.savetxt(path, np.column_stack([t, Y]), delimiter=",", header=header, comments="", fmt="%.6g")
    return f"{fault} {size} at {t[onset]:.2f} s"


def run(archive: Path, out: Path, extra: list[str], timeout: float) -> Outcome:
    """``analyzer run archive --out out`` in a child (``bench_pipeline.DRIVER``)."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    cmd = [sys.executable, "-c", bench_pipeline.DRIVER, "run", str(archive), "--out", str(out)]
    cmd += ["--no-progress", *extra]
    log = out.with_suffix(".log")
    with log.open("w") as sink:
        begin = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=sink, stderr=subprocess.STDOUT, env=env)
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            peak = _vmhwm_mb(proc.pid)
            proc.terminate()
            proc.wait()
            return Outcome(None, peak, "stopped", 1)
        wall = time.perf_counter() - begin
    info = bench_pipeline.driver_info(log, archive, proc.returncode)
    doc = json.loads((out / "findings.json").read_text())
    found = "; ".join(
        f"{f['channel']} {f['type']} "
        + ", ".join(f"{k} {v:.4g}" for k, v in f["magnitude"].items())
        + f" at {f['onset_s']:.2f} s"
        for f in doc["faults"]
    )
    bank = next((d for d in doc["detectors"] if d["name"] == "ar_kalman_bank"), None)
    groups = int((bank or {}).get("model", {}).get("groups", 1))
    peak = float(info.get("vmhwm_kb", 0.0)) / 1024.0
    return Outcome(wall, peak, found or "nothing", groups)


def _vmhwm_mb(pid: int) -> float:
    """The peak RSS of a running process (``VmHWM``), 0 where /proc does not say."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return 0.0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--channels", default="16,32,48")
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--rate", type=float, default=100.0)
    parser.add_argument("--baseline-max", type=int, default=48)
    parser.add_argument("--timeout", type=float, default=900.0)
    parser.add_argument("--keep", type=Path, help="keep the archives and outputs here")
    parser.add_argument("--fault", choices=sorted(FAULTS), default="additive")
    args = parser.parse_args(argv)
    counts = [int(c) for c in args.channels.split(",") if c.strip()]
    if any(c < 4 or c % 2 for c in counts):
        parser.error("--channels: even counts of at least 4 (two sensors per floor)")
    base = args.keep or Path(tempfile.mkdtemp(prefix="bench-channels-"))
    base.mkdir(parents=True, exist_ok=True)
    print(
        f"bench_channels: {os.cpu_count()} cores, OPENBLAS_NUM_THREADS="
        f"{os.environ['OPENBLAS_NUM_THREADS']}, {args.minutes:g} min at {args.rate:g} Hz, "
        f"fault: {FAULTS[args.fault]} on s{FAULTY} from 2/3 of the record"
    )
    rows = []
    for m in counts:
        folder = base / f"ch{m}-{args.fault}"
        folder.mkdir(exist_ok=True)
        csv = folder / "building.csv"
        truth = write_csv(csv, m, args.minutes, args.rate, args.fault) if not csv.exists() else None
        n_values = int(round(args.minutes * 60 * args.rate)) * m
        grouped = run(folder, base / f"out{m}-{args.fault}", [], args.timeout)
        one = None
        if m <= args.baseline_max:
            config = base / f"all{m}.toml"
            names = ", ".join(f'"s{i}"' for i in range(m))
            config.write_text(f'[[group]]\nname = "all"\nchannels = [{names}]\n')
            one = run(
                folder, base / f"one{m}-{args.fault}", ["--config", str(config)], args.timeout
            )
        rows.append((m, n_values, truth, grouped, one))
        print(f"  {m} channels done", flush=True)

    def cells(o: Outcome | None, n: int) -> str:
        if o is None:
            return f"{'not run':>10} {'':>11} {'':>9}"
        if o.wall_s is None:
            return f"{'> timeout':>10} {'':>11} {o.peak_mb:>6.0f} MB+"
        return f"{o.wall_s:>10.1f} {n / o.wall_s:>11,.0f} {o.peak_mb:>6.0f} MB"

    print()
    print(f"{'':>19}{'grouped (default)':^34}   {'one group of all (baseline)':^34}")
    print(
        f"{'channels':>8} {'values':>11} {'wall s':>10} {'values/s':>11} {'peak RSS':>9}   "
        f"{'wall s':>10} {'values/s':>11} {'peak RSS':>9}  groups"
    )
    for m, n, _, g, o in rows:
        print(f"{m:>8} {n:>11,} {cells(g, n)}   {cells(o, n)}  {g.groups}")
    print()
    for m, _, truth, g, o in rows:
        where = f" (injected: {truth})" if truth is not None else ""
        other = o.found if o else "-"
        print(f"  {m} channels{where}: grouped found {g.found}; one group found {other}")
    print(f"archives and outputs in {base}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
