"""``analyzer run`` ends with one line on stderr, terminal or not: what it found (or that
it found nothing) and where the report is. It said nothing at all when stderr was no
terminal (CI, ``| tee``, cron) and ended with exit code 1, which reads as a failure."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

from cli_helpers import run_cli

from analyzer.diagnosis import Finding
from analyzer.pipeline import summary_line
from analyzer.types import FaultType

SAMPLES = Path(__file__).resolve().parents[2] / "samples"


def test_a_run_that_finds_a_fault_says_which_and_where_the_report_is(tmp_path, capsys):
    out = tmp_path / "o"
    code, stdout, err = run_cli(["run", SAMPLES / "building_additive.mcap", "--out", out], capsys)
    assert code == 1
    assert stdout == ""
    last = err.splitlines()[-1]
    assert last == (
        "analyzer: 1 sensor fault found on 1 sensor: /s4.data additive from 16.000 s; "
        f"report: {out / 'report.html'}"
    )


def test_a_run_that_finds_nothing_says_so(tmp_path, capsys):
    out = tmp_path / "o"
    code, stdout, err = run_cli(["run", SAMPLES / "building_healthy_ros2", "--out", out], capsys)
    assert code == 0
    assert err.splitlines()[-1] == (
        f"analyzer: no sensor fault found; report: {out / 'report.html'}"
    )


def _finding(channel: str, onset_s: float) -> Finding:
    return Finding(channel, FaultType.DRIFT, onset_s, None, {}, 0.9, "ar_kalman_bank")


def test_the_line_names_three_findings_and_counts_the_rest():
    found = [_finding(f"/s{k % 4}.data", 10.0 * k) for k in range(5)]
    line = summary_line(SimpleNamespace(findings=found), Path("out"))  # type: ignore[arg-type]
    assert line == (
        "5 sensor faults found on 4 sensors: /s0.data drift from 0.000 s, /s1.data drift "
        "from 10.000 s, /s2.data drift from 20.000 s and 2 more; report: out/report.html"
    )
