"""``benchmarks/profile_run.py``: each wrapped call's thread CPU counted once, under its own
name, exclusive of the wrapped calls it makes."""

from __future__ import annotations

import concurrent.futures
import importlib.util
import threading
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parent.parent / "benchmarks" / "profile_run.py"
_spec = importlib.util.spec_from_file_location("profile_run", SCRIPT)
assert _spec is not None and _spec.loader is not None
profile_run = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(profile_run)


class _Clock:
    """A thread CPU clock per thread that moves only when told to."""

    def __init__(self) -> None:
        self._local = threading.local()

    def __call__(self) -> float:
        return float(getattr(self._local, "now", 0.0))

    def spend(self, seconds: float) -> None:
        self._local.now = self() + seconds


def test_nested_calls_are_counted_exclusively(monkeypatch: pytest.MonkeyPatch) -> None:
    clock = _Clock()
    monkeypatch.setattr(profile_run.time, "thread_time", clock)
    cpu = profile_run.ThreadCPU()

    def leaf() -> None:
        clock.spend(2.0)

    wrapped_leaf = cpu.wrap("leaf", leaf)

    def outer() -> str:
        clock.spend(1.0)
        wrapped_leaf()
        wrapped_leaf()
        clock.spend(0.5)
        return "done"

    assert cpu.wrap("outer", outer)() == "done"
    assert cpu.seconds == {"outer": 1.5, "leaf": 4.0}
    assert cpu.calls == {"outer": 1, "leaf": 2}


def test_a_failing_call_is_counted_and_raises(monkeypatch: pytest.MonkeyPatch) -> None:
    clock = _Clock()
    monkeypatch.setattr(profile_run.time, "thread_time", clock)
    cpu = profile_run.ThreadCPU()

    def fails() -> None:
        clock.spend(3.0)
        raise ValueError("boom")

    def outer() -> None:
        clock.spend(1.0)
        with pytest.raises(ValueError, match="boom"):
            cpu.wrap("fails", fails)()

    cpu.wrap("outer", outer)()
    assert cpu.seconds == {"outer": 1.0, "fails": 3.0}


def test_calls_on_other_threads_are_not_taken_from_the_caller(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    clock = _Clock()
    monkeypatch.setattr(profile_run.time, "thread_time", clock)
    cpu = profile_run.ThreadCPU()

    def task() -> None:
        clock.spend(5.0)

    def outer() -> None:
        clock.spend(1.0)
        with concurrent.futures.ThreadPoolExecutor(2) as pool:
            for future in [pool.submit(cpu.wrap("task", task)) for _ in range(3)]:
                future.result()

    cpu.wrap("outer", outer)()
    assert cpu.seconds == {"outer": 1.0, "task": 15.0}
    assert cpu.calls["task"] == 3


def _run(cpu_s: float, **tasks: float) -> dict[str, object]:
    return {"exit": 0, "wall_s": 2 * cpu_s, "cpu_s": cpu_s, "tasks": tasks}


def test_two_checkouts_are_compared_task_by_task_on_medians() -> None:
    mine = [_run(10.0, fit=3.0, tests=2.0), _run(12.0, fit=5.0, tests=2.2)]
    mine.append(_run(11.0, fit=4.0, tests=2.1))
    theirs = [_run(9.0, fit=3.0, tests=2.0), _run(9.5, fit=3.2, tests=2.0)]
    rows = profile_run.comparison(mine, theirs)
    assert rows[1].split() == ["11.00", "9.25", "+1.75", "the", "process", "in", "all"]
    # the largest difference first: the fit's median 4.0 against 3.1
    assert rows[2].split() == ["4.000", "3.100", "+0.900", "fit"]
    assert rows[3].split() == ["2.100", "2.000", "+0.100", "tests"]


def test_a_task_one_checkout_does_not_have_counts_as_no_cpu() -> None:
    rows = profile_run.comparison([_run(5.0, fit=1.0)], [_run(5.5, fit=1.0, folds=0.5)])
    assert rows[2].split() == ["0.000", "0.500", "-0.500", "folds"]
    assert rows[3].split() == ["1.000", "1.000", "+0.000", "fit"]


def test_the_profiled_checkout_is_compiled_before_it_runs(tmp_path: Path) -> None:
    package = tmp_path / "analyzer"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "stage.py").write_text("X = 1\n")
    profile_run.byte_compile(tmp_path)
    compiled = sorted(p.name.split(".")[0] for p in (package / "__pycache__").iterdir())
    assert compiled == ["__init__", "stage"]
    (package / "broken.py").write_text("def (:\n")
    with pytest.raises(SystemExit, match="does not compile"):
        profile_run.byte_compile(tmp_path)
