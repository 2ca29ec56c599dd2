"""Size and speed of the HTML report on a long archive.

Builds a synthetic analysis (:mod:`analyzer.report.synthetic`: default 24 h x 16
channels at 100 Hz, 138 M aligned values memory-mapped on disk, with an offset, a gain
and a drift fault and a gap, thresholds and innovation tests computed by the real code),
renders ``report.html`` and prints the render time and the report's size against the
10 MB budget; with Chromium on the PATH, also the time a headless browser takes to load
and lay out the page. A script, not a timed test.

    python benchmarks/bench_report.py [--hours 24] [--channels 16] [--rate 100] [--out DIR]
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from analyzer.pipeline import findings_document  # noqa: E402
from analyzer.report import render_report  # noqa: E402
from analyzer.report.synthetic import SyntheticFault, describe, synthetic_analysis  # noqa: E402
from analyzer.types import FaultType  # noqa: E402

BUDGET_BYTES = 10 * 1000 * 1000


def chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    return None


def browser_seconds(exe: str, page: Path, work: Path) -> float:
    """Wall time of a headless Chromium loading, laying out and screenshotting the page
    (a 1200 x 3000 window), startup included."""
    profile = work / "chromium-profile"
    shot = work / "page.png"
    cmd = [
        exe,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--no-first-run",
        f"--user-data-dir={profile}",
        f"--screenshot={shot}",
        "--window-size=1200,3000",
        page.resolve().as_uri(),
    ]
    begin = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, timeout=120)
    return time.perf_counter() - begin


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=24.0)
    parser.add_argument("--channels", type=int, default=16)
    parser.add_argument("--rate", type=float, default=100.0)
    parser.add_argument("--out", type=Path, default=None, help="keep report.html here")
    parser.add_argument("--no-browser", action="store_true")
    args = parser.parse_args(argv)

    duration = args.hours * 3600.0
    m = args.channels
    faults = [
        SyntheticFault(1 % m, FaultType.ADDITIVE, 0.40 * duration, None, 0.5),
        SyntheticFault(5 % m, FaultType.MULTIPLICATIVE, 0.55 * duration, 0.80 * duration, 1.8),
        SyntheticFault(9 % m, FaultType.DRIFT, 0.70 * duration, None, 2.0 / duration),
    ]
    work = Path(tempfile.mkdtemp(prefix="bench-report-"))
    try:
        begin = time.perf_counter()
        analysis = synthetic_analysis(
            duration,
            m,
            args.rate,
            faults,
            gap=(3 % m, 0.3 * duration, 0.3 * duration + 600.0),
            workdir=work,
        )
        build_s = time.perf_counter() - begin
        info = describe(analysis)
        print(
            f"archive: {args.hours:g} h x {m} channels x {args.rate:g} Hz = "
            f"{info['values'] / 1e6:.1f} M values (memory-mapped), {info['findings']} findings;"
            f" built in {build_s:.1f} s"
        )

        begin = time.perf_counter()
        doc = findings_document(analysis)
        html = render_report(analysis, doc)
        render_s = time.perf_counter() - begin
        size = len(html.encode("utf-8"))
        figures = html.count('<figure class="plot"')
        page = (args.out or work) / "report.html"
        page.parent.mkdir(parents=True, exist_ok=True)
        page.write_text(html, encoding="utf-8")
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        verdict = "OK" if size < BUDGET_BYTES else "OVER BUDGET"
        print(
            f"report:  {size / 1e6:.2f} MB ({figures} figures), rendered in {render_s:.1f} s; "
            f"budget 10 MB: {verdict}"
        )
        print(f"peak RSS of this process: {rss:.0f} MB (memory-mapped pages included)")
        exe = None if args.no_browser else chromium()
        if exe is not None:
            secs = browser_seconds(exe, page, work)
            print(
                f"browser: headless Chromium loaded, laid out and screenshot the page in "
                f"{secs:.1f} s (startup included)"
            )
        elif not args.no_browser:
            print("browser: chromium not installed, load time not measured")
        if args.out:
            print(f"written: {page}")
        return 0 if size < BUDGET_BYTES else 1
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    raise SystemExit(main())
