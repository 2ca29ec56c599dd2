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
from analyzer.parallel import usable_cpus
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


# --- a cgroup's CPU-time quota (the integrator's audit, int56 item 3) ---------------

V2_MOUNTS = "30 23 0:26 / /sys/fs/cgroup rw,nosuid - cgroup2 cgroup2 rw,nsdelegate\n"
V1_MOUNTS = (
    "31 23 0:28 / /sys/fs/cgroup rw - tmpfs tmpfs rw,mode=755\n"
    "32 31 0:29 / /sys/fs/cgroup/cpu,cpuacct rw - cgroup cgroup rw,cpu,cpuacct\n"
    "33 31 0:30 / /sys/fs/cgroup/memory rw - cgroup cgroup rw,memory\n"
)


def _tree(root: Path, cgroup: str, mounts: str, files: dict[str, str]) -> Path:
    """A fake ``/proc/self`` and cgroup folders under ``root``."""
    (root / "proc/self").mkdir(parents=True)
    (root / "proc/self/cgroup").write_text(cgroup)
    (root / "proc/self/mountinfo").write_text(mounts)
    for name, text in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)
    return root


@pytest.fixture
def eight_cpus(monkeypatch: pytest.MonkeyPatch) -> None:
    """A process allowed all 8 CPUs of its host."""
    monkeypatch.setattr(os, "cpu_count", lambda: 8)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(range(8)), raising=False)


def _use(monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    import analyzer.cgroup_cpus as cgroup_cpus

    monkeypatch.setattr(cgroup_cpus, "CGROUP_ROOT", root)


@pytest.mark.usefixtures("eight_cpus")
@pytest.mark.parametrize(
    ("quota", "expected"),
    [("200000 100000\n", 2), ("150000 100000\n", 2), ("50000 100000\n", 1), ("max 100000\n", 8)],
)
def test_a_cgroup_v2_quota_bounds_the_default(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, quota: str, expected: int
) -> None:
    """``cpu.max`` of the process's own cgroup (``docker run --cpus``): its quota over its
    period, rounded up, at least 1; ``max`` is no limit. Before: 8 in every case."""
    root = _tree(
        tmp_path,
        "0::/ci/job7\n",
        V2_MOUNTS,
        {"sys/fs/cgroup/ci/job7/cpu.max": quota, "sys/fs/cgroup/cpu.max": "max 100000\n"},
    )
    _use(monkeypatch, root)
    args = build_parser().parse_args(["watch", str(tmp_path), "--out", str(tmp_path / "r")])
    assert WatchSettings.from_args(args).jobs == expected
    assert usable_cpus() == expected


@pytest.mark.usefixtures("eight_cpus")
def test_a_parent_cgroup_s_quota_counts_too(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A limit set on a parent cgroup holds for its children (systemd's slices)."""
    root = _tree(
        tmp_path,
        "0::/ci.slice/job7\n",
        V2_MOUNTS,
        {
            "sys/fs/cgroup/ci.slice/cpu.max": "300000 100000\n",
            "sys/fs/cgroup/ci.slice/job7/cpu.max": "max 100000\n",
        },
    )
    _use(monkeypatch, root)
    assert usable_cpus() == 3


@pytest.mark.usefixtures("eight_cpus")
def test_a_cgroup_v1_quota_bounds_the_default(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """cgroup v1: ``cpu.cfs_quota_us`` over ``cpu.cfs_period_us`` in the hierarchy that
    has the ``cpu`` controller; ``run``'s default too."""
    root = _tree(
        tmp_path,
        "4:memory:/docker/abc\n3:cpu,cpuacct:/docker/abc\n0::/\n",
        V1_MOUNTS,
        {
            "sys/fs/cgroup/cpu,cpuacct/docker/abc/cpu.cfs_quota_us": "200000\n",
            "sys/fs/cgroup/cpu,cpuacct/docker/abc/cpu.cfs_period_us": "100000\n",
            "sys/fs/cgroup/cpu,cpuacct/cpu.cfs_quota_us": "-1\n",
            "sys/fs/cgroup/cpu,cpuacct/cpu.cfs_period_us": "100000\n",
        },
    )
    _use(monkeypatch, root)
    assert usable_cpus() == 2
    asked: list[Any] = []
    real = pipeline.make_executor

    def spy(jobs: Any, *args: Any, **kw: Any) -> Any:
        asked.append(jobs)
        return real(jobs, *args, **kw)

    monkeypatch.setattr(pipeline, "make_executor", spy)
    code = main(["run", str(SAMPLE), "--out", str(tmp_path / "o"), "--no-progress"])
    assert code == 1, capsys.readouterr().err
    assert asked == [2]


@pytest.mark.usefixtures("one_cpu_of_eight")
def test_the_affinity_wins_when_it_is_smaller(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    root = _tree(tmp_path, "0::/j\n", V2_MOUNTS, {"sys/fs/cgroup/j/cpu.max": "400000 100000"})
    _use(monkeypatch, root)
    assert usable_cpus() == 1


@pytest.mark.usefixtures("eight_cpus")
@pytest.mark.parametrize(
    "files",
    [
        {},  # (no cpu.max: the cpu controller not enabled for the group)
        {"sys/fs/cgroup/j/cpu.max": "garbage"},
        {"sys/fs/cgroup/j/cpu.max": "0 100000"},
    ],
)
def test_no_readable_quota_is_no_limit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, files: dict[str, str]
) -> None:
    _use(monkeypatch, _tree(tmp_path, "0::/j\n", V2_MOUNTS, files))
    assert usable_cpus() == 8


@pytest.mark.usefixtures("eight_cpus")
def test_no_proc_is_no_limit(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """No ``/proc`` (macOS, a sandbox): the affinity alone."""
    _use(monkeypatch, tmp_path)
    assert usable_cpus() == 8


@pytest.mark.usefixtures("eight_cpus")
def test_a_cgroup_namespace_s_own_root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """In a cgroup namespace (a container's usual view) the process's cgroup is ``/``
    and the mount's root is its own group: the mount point's ``cpu.max``."""
    root = _tree(tmp_path, "0::/\n", V2_MOUNTS, {"sys/fs/cgroup/cpu.max": "100000 100000"})
    _use(monkeypatch, root)
    assert usable_cpus() == 1
