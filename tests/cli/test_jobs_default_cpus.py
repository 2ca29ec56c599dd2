"""``--jobs``' default is the number of CPUs the process may use (its affinity:
``taskset``, a container's cpuset), not the host's cores (a QA audit's ux59 item L4:
``taskset -c 0 analyzer watch`` on a 2-core machine ran 2 analysis processes on one CPU)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest

import analyzer.pipeline as pipeline
from analyzer.cli import build_parser, main
from analyzer.watch import WatchSettings

SAMPLE = Path(__file__).resolve().parents[2] / "samples" / "building_additive.mcap"


@pytest.fixture
def one_cpu_of_eight(monkeypatch: pytest.MonkeyPatch) -> None:
    """A process allowed CPU 3 alone of a host of 8 cores."""
    monkeypatch.setattr(os, "cpu_count", lambda: 8)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {3}, raising=False)


@pytest.mark.usefixtures("one_cpu_of_eight")
def test_watch_runs_one_analysis_at_a_time_on_one_cpu(tmp_path: Path) -> None:
    args = build_parser().parse_args(["watch", str(tmp_path), "--out", str(tmp_path / "r")])
    assert WatchSettings.from_args(args).jobs == 1
    args = build_parser().parse_args(
        ["watch", str(tmp_path), "--out", str(tmp_path / "r"), "--jobs", "3"]
    )
    assert WatchSettings.from_args(args).jobs == 3  # (given: as given)


@pytest.mark.usefixtures("one_cpu_of_eight")
def test_run_uses_one_thread_on_one_cpu(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    asked: list[Any] = []
    real = pipeline.make_executor

    def spy(jobs: Any, *args: Any, **kw: Any) -> Any:
        asked.append(jobs)
        return real(jobs, *args, **kw)

    monkeypatch.setattr(pipeline, "make_executor", spy)
    code = main(["run", str(SAMPLE), "--out", str(tmp_path / "o"), "--no-progress"])
    assert code == 1, capsys.readouterr().err
    assert asked == [1]
