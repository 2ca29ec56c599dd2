"""End-to-end throughput, stage times and peak memory of ``analyzer run`` on long archives.

Writes (in a temporary directory) a 16-channel, 100 Hz healthy archive as hourly files:
``simulate_building`` with 8 floors x 2 sensors, one piece per hour with its own seed
(after a discarded minute of warm-up, so no file starts from rest), the pieces stitched
in time by consecutive ``start_iso``, each written with ``write_archive`` as CSV
(ISO-8601 time column) and as MCAP (ROS 2 profile, one ``std_msgs/Float64MultiArray``
message per sample, layout ``"multiarray"``). For every format and every length of
``--hours`` (a directory holding the first hourly files) it runs ``analyzer run DIR --out
OUT`` in a child process (the CLI's own ``main``, called as the console script calls it:
the report's figures drawn by worker processes, the process ended by ``cli.end``; the
child only wraps ``pipeline.analyze`` to print ``Analysis.timings`` as JSON) and reports

* end to end values/s: samples x analyzed channels over the child's wall time
  (interpreter start, imports, reading, analysis and writing the report included),
* the stage times (read, align, detect, test, total) and the time to write the outputs,
* the child's peak resident memory (its ``VmHWM`` from ``/proc/self/status``, else
  ``os.wait4``'s ``ru_maxrss``, which also counts this script's memory when it started the
  child; the figure workers are the fork server's children, not the child's, and are not
  in it: they hold matplotlib and one figure's decimated arrays, about the same on any
  archive length),

against the targets of issue 9: >= 2 M values/s end to end from CSV, >= 5 M values/s
from MCAP, peak memory of the longest archive <= 1.5 x that of the shortest + 100 MB.

It also times the "straightforward way" in the same run: per-message decoding with the
reference decoder (``mcap`` reader + ``mcap_ros2.decoder.DecoderFactory``, first
``--reference-messages`` messages; for CSV, ``pandas.read_csv`` of the first file) plus
statsmodels' ``KalmanFilter`` for the bank's estimators (``--sm-estimators`` of the 16
estimators over ``--sm-samples`` samples). Both rates are per message / per sample per
estimator, so they are extrapolated to the whole archive and all 16 estimators; the
baseline has no fit, no detection and no report, which flatters it.

Independent pieces meet at discontinuities (a new seed is a new trajectory of the
building): the detectors see each boundary as a change of the whole structure, the bank
makes an extra pass per boundary and a detector may even report a finding there (exit 1).
``--continuous`` cuts one long simulation into the hourly files instead: a healthy archive
without boundaries, the case the targets are about. ``--fault KIND`` (with
``--continuous``) puts a sensor fault on one channel (``s5``) from the middle of the first
file (30 minutes) to the end of the archive (``inject_fault``): ``additive`` (half the
channel's healthy standard deviation), ``multiplicative`` (gain 1.3) or ``drift`` (one
standard deviation per hour): a fault that lasts, whose alarms go on for hours on its
channel and on the channels its error spreads to, the costliest case for the detectors'
isolation and diagnosis.

``--model`` first fits each format's model on its shortest archive (``analyzer run
--save-model``, not timed), then times runs with ``--model``: nothing is fitted on the
timed archives, as when an SHM system's hourly files are audited against one healthy
recording.

``--profile`` runs the longest archive of the first format once more under cProfile
and prints the top functions by own time and the analyzer functions by cumulative time.
OPENBLAS_NUM_THREADS=1 is set for this script and the children unless already set. A
script, not a timed test::

    python benchmarks/bench_pipeline.py [--hours 1,4] [--formats csv,mcap] [--quick]
                                        [--continuous] [--profile] [--keep DIR]
                                        [--jobs N] [--detectors A,B] [--model]
                                        [--fault additive|multiplicative|drift]
                                        [--repeat N] [--baseline-src DIR]

``--baseline-src DIR`` runs another checkout (``git worktree add DIR COMMIT``) the same
way, each format and length in turns with this one (the two take turns at going first),
and prints their median wall and CPU times and peaks side by side, with how many pairs
of runs listed the same faults: how a change is judged on this shared machine, whose
speed drifts within minutes.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported

import argparse  # noqa: E402
import compileall  # noqa: E402
import datetime as dt  # noqa: E402
import itertools  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import pstats  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Sequence  # noqa: E402
from dataclasses import dataclass, field  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
import numpy.typing as npt  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from analyzer.detectors.ar_model import fit_ar  # noqa: E402
from analyzer.simulate import inject_fault, simulate_building  # noqa: E402
from analyzer.writers import write_archive  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_bank import revision, statsmodels_filter  # noqa: E402

FloatArray = npt.NDArray[np.float64]

RATE_HZ = 100.0
ORDER = 7
WARMUP_S = 60.0
"""Each piece is simulated this much longer and its start dropped, so no file begins with
the building at rest (a transient the detectors would rightly flag)."""
START = dt.datetime(2026, 1, 1, tzinfo=dt.UTC)
SUFFIX = {"csv": "csv", "mcap": "mcap"}
TARGET_RATE = {"csv": 2e6, "mcap": 5e6}
MEMORY_FACTOR, MEMORY_SLACK_MB = 1.5, 100.0

DRIVER = r"""
import cProfile, importlib.abc, importlib.util, json, os, sys, time
start = time.perf_counter()
from analyzer.cli import main
captured = {}

def record(pipeline):  # records what analyze() returns and when; the CLI is unchanged
    _analyze = pipeline.analyze
    def analyze(*args, **kwargs):
        t_in = time.perf_counter()
        result = _analyze(*args, **kwargs)
        captured.update(
            timings=dict(result.timings), n=result.n, channels=len(result.analyzed),
            findings=len(result.findings), detectors=[r.detector for r in result.results],
            analyze_from_s=t_in - start, analyze_to_s=time.perf_counter() - start,
        )
        return result
    pipeline.analyze = analyze

class Hook(importlib.abc.MetaPathFinder):
    # patches analyzer.pipeline when the CLI imports it: the run keeps the entry point's
    # import order (its figure workers' server starts before the pipeline is imported)
    def find_spec(self, name, path, target=None):
        if name != "analyzer.pipeline":
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        exec_module = spec.loader.exec_module
        def exec_and_record(module):
            exec_module(module)
            record(module)
        spec.loader.exec_module = exec_and_record
        return spec

sys.meta_path.insert(0, Hook())
profile = os.environ.get("BENCH_PROFILE")
if profile:
    prof = cProfile.Profile()
    rc = prof.runcall(main, sys.argv[1:], figure_processes=True)
    prof.dump_stats(profile)
else:
    rc = main(sys.argv[1:], figure_processes=True)
captured.update(rc=rc, end_s=time.perf_counter() - start)
def proc_field(path, key, name):  # a number from a /proc/self file, where there is one
    try:
        with open(path) as f:
            for line in f:
                if line.startswith(key):
                    captured[name] = int(line.split()[1])
    except OSError:
        pass

proc_field("/proc/self/status", "VmHWM:", "vmhwm_kb")  # its own high-water mark (run_child)
proc_field("/proc/self/io", "write_bytes:", "write_bytes")  # written to files, scratch too
print("BENCH_JSON " + json.dumps(captured))
from analyzer.cli import end
end(rc)  # as the console script ends (analyzer.cli.entry)
"""


@dataclass
class Run:
    fmt: str
    hours: float
    files: int
    wall_s: float
    peak_mb: float
    cpu_s: float
    rc: int
    info: dict[str, Any] = field(default_factory=dict)
    sys_s: float = 0.0
    """The child's CPU time in the kernel (page faults on scratch files, copies into the
    page cache): part of ``cpu_s``."""

    @property
    def values(self) -> int:
        return int(self.info.get("n", 0)) * int(self.info.get("channels", 0))

    @property
    def rate(self) -> float:
        return self.values / self.wall_s if self.wall_s > 0 else 0.0


# --------------------------------------------------------------------------- archives


FAULT_CHANNEL = 5
"""Channel of ``--fault`` (``s5``, floor 3's second sensor)."""


def with_fault(Y: FloatArray, kind: str, onset_s: float) -> FloatArray:
    """``Y`` with ``--fault kind`` on :data:`FAULT_CHANNEL` from ``onset_s`` to the end
    (sizes scaled by the channel's healthy standard deviation before the onset)."""
    j = min(FAULT_CHANNEL, Y.shape[1] - 1)  # s3 of --quick's 4 channels
    k0 = int(round(onset_s * RATE_HZ))
    sd = float(np.std(Y[:k0, j]))
    size = {"additive": 0.5 * sd, "multiplicative": 1.3, "drift": sd / 3600.0}[kind]
    out = np.array(Y, copy=True)
    out[:, j] = inject_fault(Y[:, j], RATE_HZ, kind, onset_s, size)
    return out


def write_pieces(
    base: Path,
    formats: list[str],
    pieces: int,
    piece_s: float,
    floors: int,
    continuous: bool,
    fault: str | None = None,
) -> tuple[dict[str, list[Path]], dict[str, float]]:
    """``pieces`` consecutive files per format (reused when ``base`` already holds them):
    independent simulations with seeds 1000, 1001, ... or, with ``continuous``, one
    simulation (seed 1000) cut into pieces, with ``fault`` (:func:`with_fault`) when
    given."""
    paths: dict[str, list[Path]] = {f: [] for f in formats}
    spent = dict.fromkeys(formats, 0.0)
    skip = int(round(WARMUP_S * RATE_HZ))  # the start from rest is dropped
    per_piece = int(round(piece_s * RATE_HZ))
    whole: tuple[FloatArray, list[str]] | None = None
    for h in range(pieces):
        targets = {f: base / f / f"piece{h:03d}.{SUFFIX[f]}" for f in formats}
        for f, p in targets.items():
            paths[f].append(p)
        todo = [f for f, p in targets.items() if not p.exists()]
        if not todo:
            continue
        if continuous:
            if whole is None:
                _, Y_all, names = simulate_building(
                    floors, WARMUP_S + pieces * piece_s, RATE_HZ, seed=1000, sensors_per_floor=2
                )
                if fault is not None:
                    # from the middle of the first file (30 min into hourly files)
                    Y_all[skip:] = with_fault(Y_all[skip:], fault, piece_s / 2)
                whole = (Y_all, names)
            Y_all, names = whole
            Y = Y_all[skip + h * per_piece : skip + (h + 1) * per_piece]
        else:
            _, Y, names = simulate_building(
                floors, WARMUP_S + piece_s, RATE_HZ, seed=1000 + h, sensors_per_floor=2
            )
            Y = Y[skip:]
        t_ns = np.round(np.arange(Y.shape[0]) * (1e9 / RATE_HZ)).astype(np.int64)
        start_iso = (START + dt.timedelta(seconds=h * piece_s)).isoformat().replace("+00:00", "Z")
        data = {name: Y[:, i] for i, name in enumerate(names)}
        for f in todo:
            targets[f].parent.mkdir(parents=True, exist_ok=True)
            begin = time.perf_counter()
            tmp = targets[f].with_name("." + targets[f].name)
            write_archive(tmp, f, t_ns, data, layout="multiarray", start_iso=start_iso)
            tmp.rename(targets[f])  # a killed run leaves no half-written piece behind
            spent[f] += time.perf_counter() - begin
    return paths, spent


def archive_dir(base: Path, fmt: str, hours: float, pieces: list[Path], piece_s: float) -> Path:
    """A directory with hard links to the first pieces covering ``hours``."""
    count = hours * 3600.0 / piece_s
    if abs(count - round(count)) > 1e-9 or round(count) < 1:
        raise SystemExit(f"--hours {hours:g} is not a whole number of {piece_s:g}-s pieces")
    d = base / f"{fmt}_{hours:g}h"
    d.mkdir(exist_ok=True)
    for p in pieces[: int(round(count))]:
        link = d / p.name
        if not link.exists():
            os.link(p, link)
    return d


# --------------------------------------------------------------------------- the child


RUN_ARGS: list[str] = []
"""Extra ``analyzer run`` options (``--jobs N``, ``--detectors A,B``)."""


def driver_info(log: Path, archive: Path, returncode: int | None) -> dict[str, Any]:
    """What :data:`DRIVER` printed (its ``BENCH_JSON`` line) in the child's ``log``; a
    child that printed none, or whose run ended with an error (exit code 2 or more: the
    analysis may have finished and the report failed), failed: the script stops with the
    log's last lines rather than time a failed run."""
    info: dict[str, Any] = {}
    lines = log.read_text().splitlines()
    for line in lines:
        if line.startswith("BENCH_JSON "):
            info = json.loads(line[len("BENCH_JSON ") :])
    rc = info.get("rc", returncode)
    if not info or rc not in (0, 1):
        tail = " | ".join(x.strip() for x in lines if not x.startswith("BENCH_JSON ") and x.strip())
        raise SystemExit(f"analyzer run {archive} failed (exit {rc}): {tail[-600:]}")
    return info


def run_child(
    archive: Path,
    out: Path,
    log: Path,
    profile: Path | None = None,
    extra: Sequence[str] = (),
    root: Path = ROOT,
) -> Run:
    """``analyzer run archive --out out [extra]`` in a child, with the analyzer of the
    checkout ``root`` (this one by default); wall time and its own peak RSS."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(root), env.get("PYTHONPATH")]))
    if profile is not None:
        env["BENCH_PROFILE"] = str(profile)
    archive, out = archive.resolve(), out.resolve()
    cmd = [sys.executable, "-c", DRIVER, "run", str(archive), "--out", str(out), "--no-progress"]
    cmd += RUN_ARGS + list(extra)
    with log.open("w") as sink:
        begin = time.perf_counter()
        # in root: ``python -c`` puts its working directory first on sys.path, before
        # PYTHONPATH, so a child started in another checkout would import that one's
        proc = subprocess.Popen(cmd, stdout=sink, stderr=subprocess.STDOUT, env=env, cwd=root)
        _, status, usage = os.wait4(proc.pid, 0)  # this child's rusage alone
        wall = time.perf_counter() - begin
    proc.returncode = os.waitstatus_to_exitcode(status)
    info = driver_info(log, archive, proc.returncode)
    return Run(
        fmt="",
        hours=0.0,
        files=len(list(archive.iterdir())),
        wall_s=wall,
        # VmHWM of the child itself where /proc has it: ``ru_maxrss`` also counts the
        # memory of this (forking) process at the moment the child was started, so after
        # this script wrote a long archive (a 24 h one: 3.5 GB) it reported that instead
        peak_mb=float(info.get("vmhwm_kb", usage.ru_maxrss)) / 1024.0,  # kilobytes
        cpu_s=usage.ru_utime + usage.ru_stime,
        rc=int(info.get("rc", proc.returncode)),
        info=info,
        sys_s=usage.ru_stime,
    )


# --------------------------------------------------------------------------- baseline


@dataclass
class Baseline:
    decode_s_per_sample: dict[str, float]
    filter_s_per_sample: float  # all m estimators
    channels: int
    note: str


def baseline(
    pieces: dict[str, list[Path]], floors: int, messages: int, sm_samples: int, sm_est: int
) -> Baseline:
    """Seconds per sample of the straightforward way: reference decoding (per message) and
    statsmodels' Kalman filter for every estimator of the bank (extrapolated)."""
    decode: dict[str, float] = {}
    if "mcap" in pieces:
        from mcap.reader import make_reader
        from mcap_ros2.decoder import DecoderFactory

        with pieces["mcap"][0].open("rb") as handle:
            reader = make_reader(handle, decoder_factories=[DecoderFactory()])
            begin = time.perf_counter()
            count = 0
            for _, _, _, msg in itertools.islice(reader.iter_decoded_messages(), messages):
                _ = [float(v) for v in msg.data]  # the values, as a consumer reads them
                count += 1
            decode["mcap"] = (time.perf_counter() - begin) / max(count, 1)
    if "csv" in pieces:
        import pandas as pd

        begin = time.perf_counter()
        frame = pd.read_csv(pieces["csv"][0])
        pd.to_datetime(frame["time"], utc=True)
        decode["csv"] = (time.perf_counter() - begin) / max(len(frame), 1)
    # statsmodels on the model the bank fits: AR(ORDER) on 10 minutes of healthy data
    _, Y, _ = simulate_building(floors, 660.0, RATE_HZ, seed=1000, sensors_per_floor=2)
    ar = fit_ar(Y[: int(600 * RATE_HZ)], ORDER)
    Z = (Y - ar.mean) / ar.scale
    n = min(sm_samples, Z.shape[0])
    spent = 0.0
    used = min(sm_est, ar.m)
    for j in range(used):
        measured = [i for i in range(ar.m) if i != j]
        kf = statsmodels_filter(ar, measured, np.ascontiguousarray(Z[:n, measured]))
        begin = time.perf_counter()
        kf.filter()
        spent += time.perf_counter() - begin
    per_sample = spent / (used * n) * ar.m
    note = (
        f"extrapolated: decoding from the first {messages:,} messages (MCAP) / the first "
        f"file (CSV); statsmodels (univariate filter, {ar.order * ar.m} states) from "
        f"{used} of {ar.m} estimators x {n:,} samples; no fit, detection or report"
    )
    return Baseline(decode, per_sample, ar.m, note)


# --------------------------------------------------------------------------- profile


def print_profile(path: Path, top: int) -> None:
    """Top functions by own time, and analyzer functions by cumulative time."""
    stats = pstats.Stats(str(path))
    raw: Any = stats.stats  # type: ignore[attr-defined]
    entries = [(key, value) for key, value in raw.items()]
    total = max(value[3] for _, value in entries)  # the outermost call's cumulative time

    def name(key: tuple[str, int, str]) -> str:
        file, line, func = key
        short = file.split("site-packages/")[-1] if "site-packages" in file else file
        short = short.replace(str(ROOT) + "/", "")
        return f"{short}:{line}({func})"

    print(f"cProfile of the longest run: {total:.1f} s in main()")
    print(f"  top {top} by own time (tottime)")
    for key, value in sorted(entries, key=lambda e: -e[1][2])[:top]:
        print(
            f"  {value[2]:8.1f} s {100 * value[2] / total:5.1f} %  {value[1]:>7} calls  {name(key)}"
        )
    print(f"  top {2 * top} analyzer functions by cumulative time")
    ours = [(k, v) for k, v in entries if str(ROOT / "analyzer") in k[0]]
    for key, value in sorted(ours, key=lambda e: -e[1][3])[: 2 * top]:
        print(
            f"  {value[3]:8.1f} s {100 * value[3] / total:5.1f} %  {value[1]:>7} calls  {name(key)}"
        )


# --------------------------------------------------------------------------- baseline src


def faults_of(out: Path) -> Any:
    """The ``faults`` of a run's ``findings.json`` (None when it wrote none)."""
    path = out / "findings.json"
    return json.loads(path.read_text())["faults"] if path.is_file() else None


def print_against_baseline(
    tried: dict[tuple[str, str, float], list[Run]],
    same: dict[tuple[str, float], list[bool]],
    repeat: int,
) -> None:
    """Medians of this checkout's runs against the baseline's, per format and length."""

    def median(values: list[float]) -> float:
        return float(np.median(values)) if values else float("nan")

    print(f"against --baseline-src (medians of {repeat} run(s) each, in turns)")
    print(
        f"{'format':<7}{'hours':>6}{'wall s':>9}{'base':>8}{'ratio':>7}{'cpu s':>8}{'base':>8}"
        f"{'peak MB':>9}{'base':>7}   same findings"
    )
    for (label, f, h), mine in tried.items():
        if label != "this":
            continue
        theirs = tried["baseline", f, h]
        wall, base_wall = median([r.wall_s for r in mine]), median([r.wall_s for r in theirs])
        agree = same[f, h]
        print(
            f"{f:<7}{h:>6g}{wall:>9.1f}{base_wall:>8.1f}{wall / base_wall:>7.2f}"
            f"{median([r.cpu_s for r in mine]):>8.1f}{median([r.cpu_s for r in theirs]):>8.1f}"
            f"{median([r.peak_mb for r in mine]):>9.0f}{median([r.peak_mb for r in theirs]):>7.0f}"
            f"   {sum(agree)}/{len(agree)}"
        )
    print(
        "  medians of all runs (of an even count: the mean of the middle two; the main "
        "table shows the lower middle run); ratio: this checkout's median wall time over "
        "the baseline's; same findings: pairs of runs whose findings.json list the same "
        "faults (every field)"
    )


# --------------------------------------------------------------------------- main


def baseline_checkout(parser: argparse.ArgumentParser, text: str) -> Path:
    """The checkout ``--baseline-src`` names (an error of ``parser`` when it holds no
    analyzer package)."""
    other = Path(text).resolve()
    if not (other / "analyzer" / "__init__.py").is_file():
        parser.error(f"--baseline-src {other}: no analyzer package there")
    return other


def byte_compile(root: Path) -> None:
    """Write the bytecode of ``root``'s analyzer package, as ``pip install`` does: an
    editable checkout under ``PYTHONDONTWRITEBYTECODE`` (set on some machines, this one
    among them) would otherwise compile its ~26 k lines again in every run (~0.15 s in the
    run's process and as much in its figure server), a cost no installed analyzer has."""
    if not compileall.compile_dir(str(root / "analyzer"), quiet=1):
        raise SystemExit(f"bench_pipeline: {root / 'analyzer'} does not compile")


def parse_list(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", default=None, help="archive lengths in hours (default 1,4)")
    parser.add_argument("--formats", default=None, help="csv and/or mcap (default csv,mcap)")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="4 channels, 3-minute files, 0.05 h and 0.2 h archives: a smoke run",
    )
    parser.add_argument("--profile", action="store_true", help="cProfile the longest run")
    parser.add_argument(
        "--continuous",
        action="store_true",
        help="cut one long simulation into the files (default: one seed per file, so the "
        "files meet at discontinuities the detectors see)",
    )
    parser.add_argument(
        "--fault",
        choices=("additive", "multiplicative", "drift"),
        help="with --continuous: a fault on s5 from the middle of the first file (30 min) "
        "to the end of the archive",
    )
    parser.add_argument("--keep", metavar="DIR", help="write (and reuse) the archives in DIR")
    parser.add_argument("--jobs", type=int, default=None, help="pass --jobs N to analyzer run")
    parser.add_argument(
        "--detectors", default=None, help="pass --detectors A,B to analyzer run (default: all)"
    )
    parser.add_argument(
        "--model",
        action="store_true",
        help="fit once per format on the shortest archive (analyzer run --save-model, not "
        "timed), then time runs with --model: nothing is fitted on the timed archives",
    )
    parser.add_argument(
        "--repeat",
        type=int,
        default=1,
        help="runs per format and length, taken in turns (the machine's speed drifts); "
        "the table shows the run with the median wall time, all wall times are printed",
    )
    parser.add_argument(
        "--baseline-src",
        metavar="DIR",
        help="another checkout of the analyzer (git worktree add DIR COMMIT), run the same "
        "way in turns with this one; a table compares their wall time, CPU time, peak RSS "
        "and findings",
    )
    parser.add_argument("--reference-messages", type=int, default=50_000)
    parser.add_argument("--sm-samples", type=int, default=5_000)
    parser.add_argument("--sm-estimators", type=int, default=2)
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error(f"--repeat: must be >= 1, got {args.repeat}")
    if args.fault and not args.continuous:
        parser.error("--fault: needs --continuous (one simulation the fault runs through)")
    if args.jobs:
        RUN_ARGS.extend(["--jobs", str(args.jobs)])
    if args.detectors:
        RUN_ARGS.extend(["--detectors", args.detectors])
    floors = 2 if args.quick else 8
    piece_s = 180.0 if args.quick else 3600.0
    hours = [float(h) for h in parse_list(args.hours or ("0.05,0.2" if args.quick else "1,4"))]
    formats = parse_list(args.formats or "csv,mcap")
    if any(f not in SUFFIX for f in formats):
        parser.error(f"--formats: expected csv and/or mcap, got {args.formats!r}")
    if args.quick:
        args.reference_messages = min(args.reference_messages, 10_000)
        args.sm_samples = min(args.sm_samples, 2_000)
        args.sm_estimators = min(args.sm_estimators, 1)
    pieces_needed = max(math.ceil(h * 3600.0 / piece_s - 1e-9) for h in hours)
    sources = [("this", ROOT)]
    if args.baseline_src:
        sources.append(("baseline", baseline_checkout(parser, args.baseline_src)))
    print(
        f"bench_pipeline: {platform.machine()}, {os.cpu_count()} cores, "
        f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}, "
        f"{2 * floors} channels at {RATE_HZ:g} Hz, files of {piece_s / 60:g} min, "
        f"hours {', '.join(f'{h:g}' for h in hours)}, load average {os.getloadavg()[0]:.1f}, "
        f"commit {revision()}",
        flush=True,
    )
    if len(sources) > 1:
        print(f"baseline: {sources[1][1]}, commit {revision(sources[1][1])}", flush=True)
    for _, root in sources:
        byte_compile(root)

    with tempfile.TemporaryDirectory(prefix="bench_pipeline_") as tmp:
        base = Path(args.keep) if args.keep else Path(tmp)
        stitch = "continuous" if args.continuous else "seeds"
        if args.fault:
            stitch += f"_{args.fault}"
        data_dir = base / f"{2 * floors}ch_{piece_s:g}s_{stitch}"
        pieces, spent = write_pieces(
            data_dir, formats, pieces_needed, piece_s, floors, args.continuous, args.fault
        )
        for f in formats:
            size = sum(p.stat().st_size for p in pieces[f]) / 2**20
            print(f"  {f}: {len(pieces[f])} files, {size:.0f} MB, written in {spent[f]:.0f} s")
        # per checkout (a model is tied to the analyzer that wrote it) and format
        models: dict[tuple[str, str], list[str]] = {
            (label, f): [] for label, _ in sources for f in formats
        }
        if args.model:  # one fit per format (channel names differ), on the shortest archive
            for (label, root), f in itertools.product(sources, formats):
                first = archive_dir(data_dir, f, min(hours), pieces[f], piece_s)
                path = Path(tmp) / f"{label}_{f}.model"
                fit = run_child(
                    first, Path(tmp) / f"fit_{f}", Path(tmp) / f"log_fit_{f}.txt",
                    extra=["--save-model", str(path)], root=root,
                )  # fmt: skip
                models[label, f] = ["--model", str(path)]
                print(
                    f"  fitted the {f} model ({label}) on {min(hours):g} h "
                    f"({path.stat().st_size / 1e6:.0f} MB) in {fit.wall_s:.1f} s, not timed below",
                    flush=True,
                )
        tried: dict[tuple[str, str, float], list[Run]] = {
            (label, f, h): [] for label, _ in sources for f in formats for h in sorted(hours)
        }
        same: dict[tuple[str, float], list[bool]] = {(f, h): [] for f in formats for h in hours}
        for turn in range(args.repeat):  # in turns: a drift of the machine's speed hits all
            for f in formats:
                for h in sorted(hours):
                    archive = archive_dir(data_dir, f, h, pieces[f], piece_s)
                    # with a baseline, the two checkouts take turns at going first
                    for label, root in sources if turn % 2 == 0 else sources[::-1]:
                        out = Path(tmp) / f"out_{label}_{f}_{h:g}h"
                        run = run_child(
                            archive, out, Path(tmp) / f"log_{label}_{f}_{h:g}h.txt",
                            extra=models[label, f], root=root,
                        )  # fmt: skip
                        run.fmt, run.hours = f, h
                        tried[label, f, h].append(run)
                        print(
                            f"  ran {f} {h:g} h{'' if label == 'this' else ' (baseline)'}: "
                            f"{run.wall_s:.1f} s, peak {run.peak_mb:.0f} MB",
                            flush=True,
                        )
                    if len(sources) > 1:
                        same[f, h].append(
                            faults_of(Path(tmp) / f"out_this_{f}_{h:g}h")
                            == faults_of(Path(tmp) / f"out_baseline_{f}_{h:g}h")
                        )
        runs: list[Run] = []
        for (label, f, h), done in tried.items():
            if label != "this":
                continue
            ordered = sorted(done, key=lambda r: r.wall_s)
            runs.append(ordered[(len(ordered) - 1) // 2])  # the median (the lower one of two)
            if len(done) > 1:
                walls = ", ".join(f"{r.wall_s:.1f}" for r in done)
                print(f"  {f} {h:g} h wall s in turn: {walls}; the table shows the median")
        base_line = baseline(
            pieces, floors, args.reference_messages, args.sm_samples, args.sm_estimators
        )
        print("  timed the baseline", flush=True)
        profile_path = Path(tmp) / "profile.pstats"
        if args.profile:
            f, h = formats[0], max(hours)
            archive = archive_dir(data_dir, f, h, pieces[f], piece_s)
            run_child(
                archive,
                Path(tmp) / "out_profile",
                Path(tmp) / "log_profile.txt",
                profile_path,
                models["this", f],
            )

        print()
        stages = ("read", "align", "detect", "test", "total")
        print(
            f"{'format':<7}{'hours':>6}{'files':>6}{'values':>13}{'wall s':>9}{'values/s':>12}"
            + "".join(f"{s:>8}" for s in stages)
            + f"{'outputs':>9}{'startup':>9}{'peak RSS':>11}{'cpu s':>8}{'sys s':>7}"
            + f"{'written':>10}{'exit':>6}"
        )
        for r in runs:
            t = r.info.get("timings", {})
            # from the driver's own start: analyze() began and ended, main() returned
            began, ended = r.info.get("analyze_from_s", 0.0), r.info.get("analyze_to_s", 0.0)
            outputs = r.info.get("end_s", 0.0) - ended
            startup = r.wall_s - r.info.get("end_s", 0.0) + began
            print(
                f"{r.fmt:<7}{r.hours:>6g}{r.files:>6}{r.values:>13,}{r.wall_s:>9.1f}"
                f"{r.rate:>12,.0f}"
                + "".join(f"{t.get(s, float('nan')):>8.1f}" for s in stages)
                + f"{outputs:>9.1f}{startup:>9.1f}{r.peak_mb:>8.0f} MB"
                + f"{r.cpu_s:>8.1f}{r.sys_s:>7.1f}"
                + f"{r.info.get('write_bytes', float('nan')) / 1e9:>7.2f} GB{r.rc:>6}"
            )
        print(
            "values: samples x analyzed channels; values/s over the child's wall time; stage "
            "times in s from Analysis.timings; outputs = findings.json + report.html; "
            "startup = interpreter + imports until the analysis begins; cpu s = the child's "
            "user + system time (sys s: in the kernel, mostly page faults and copies of "
            "scratch files); written = bytes it wrote to files, its scratch space included "
            "(/proc/PID/io); exit 0 = no fault found"
        )
        for r in runs:  # per detector (threads: the fits overlap, the runs follow each other)
            t = r.info.get("timings", {})
            parts = [f"{k} {v:.1f}" for k, v in t.items() if k.startswith(("fit ", "run "))]
            if parts:
                print(f"  {r.fmt} {r.hours:g} h detect: " + ", ".join(parts))
        print()
        m = base_line.channels
        print(f"{'straightforward way':<34}{'decode s':>10}{'filter s':>10}{'values/s':>12}")
        for r in runs:
            n = int(r.info.get("n", 0))
            dec = base_line.decode_s_per_sample.get(r.fmt, 0.0) * n
            fil = base_line.filter_s_per_sample * n
            how = "per-message mcap_ros2" if r.fmt == "mcap" else "pandas.read_csv"
            label = f"{r.fmt} {r.hours:g} h ({how})"
            print(f"{label:<34}{dec:>10.1f}{fil:>10.1f}{n * m / (dec + fil):>12,.0f}")
        print(base_line.note)
        print()
        print(
            "targets (issue 9)"
            + (" -- with --model: the fits were made before, in another run" if args.model else "")
        )
        for f in formats:
            mine = [r for r in runs if r.fmt == f]
            longest = max(mine, key=lambda r: r.hours)
            shortest = min(mine, key=lambda r: r.hours)
            goal = TARGET_RATE[f]
            short = f" ({goal / longest.rate:.1f}x short)" if 0 < longest.rate < goal else ""
            print(
                f"  {f}: end to end {longest.rate / 1e6:.3f} M values/s on {longest.hours:g} h "
                f"(target >= {goal / 1e6:g} M): "
                f"{'meets' if longest.rate >= goal else 'MISSES'}{short}"
            )
            if longest is not shortest:
                limit = MEMORY_FACTOR * shortest.peak_mb + MEMORY_SLACK_MB
                verdict = "meets" if longest.peak_mb <= limit else "MISSES"
                print(
                    f"  {f}: peak RSS {longest.hours:g} h {longest.peak_mb:.0f} MB vs "
                    f"{shortest.hours:g} h {shortest.peak_mb:.0f} MB "
                    f"({longest.peak_mb / shortest.peak_mb:.2f}x; limit {MEMORY_FACTOR:g} x + "
                    f"{MEMORY_SLACK_MB:g} MB = {limit:.0f} MB): {verdict}"
                )
        if args.quick:
            print("  (--quick: archives this small say little about memory scaling)")
        if len(sources) > 1:
            print()
            print_against_baseline(tried, same, args.repeat)
        print(f"load average at the end {os.getloadavg()[0]:.1f}")
        if args.profile:
            print()
            print_profile(profile_path, 10)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
