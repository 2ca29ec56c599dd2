"""What ``sweep_changes.py`` and ``sweep_two_faults.py`` share: a record's findings scored
against the faults injected in it, and the table of totals. Not a script."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from analyzer.pipeline import RunOptions, analyze
from analyzer.writers import write_archive

Truth = tuple[str, str, float, "float | None"]
"""An injected fault (or part of one): channel, type, onset s, end s (None: to the end)."""


def analyzed(
    tmp: Path, label: str, t_ns: np.ndarray, y: np.ndarray, names: Sequence[str]
) -> list[Any]:
    """The findings of ``pipeline.analyze`` with the defaults on the record (times ``t_ns``,
    one column of ``y`` per channel of ``names``) written as CSV in ``tmp`` under
    ``label`` (removed after; the run's scratch in a folder of its own there)."""
    path = tmp / f"{label}.csv"
    write_archive(path, "csv", t_ns, {n: y[:, i] for i, n in enumerate(names)})
    work = tmp / f"work-{label}"
    work.mkdir()
    findings = analyze([str(path)], RunOptions(), work).findings
    path.unlink()
    return findings


def tally(row: list[int], count: int, scored: tuple[int, int, int]) -> None:
    """Add a record's ``count`` faults and its :func:`score` to a case's ``row`` of
    totals (count, right, found, extras)."""
    for k, v in enumerate((count, *scored)):
        row[k] += v


def score(findings: Sequence[Any], truth: Sequence[Truth], slack_s: float) -> tuple[int, int, int]:
    """``(right, found, extras)``: a fault is **found** when a finding on its channel, not
    taken by another, begins within ``slack_s`` of it, and **right** when that finding
    also has its type and its end within ``slack_s`` (or both last to the record's end);
    findings that match no fault are **extras**."""
    used: set[int] = set()
    right = found = 0
    for channel, kind, onset, end in truth:
        for k, f in enumerate(findings):
            if k in used or f.channel != channel or abs(f.onset_s - onset) > slack_s:
                continue
            used.add(k)
            found += 1
            if end is None or f.end_s is None:
                ends = end is None and f.end_s is None
            else:
                ends = abs(f.end_s - end) <= slack_s
            right += int(f.type.value == kind and ends)
            break
    return right, found, len(findings) - len(used)


def shown(findings: Sequence[Any]) -> str:
    """The findings as ``s3 additive 100.0-200.0, ...`` (``end``: to the record's end)."""
    return ", ".join(
        f"{f.channel} {f.type.value} {f.onset_s:.1f}-"
        f"{'end' if f.end_s is None else f'{f.end_s:.1f}'}"
        for f in findings
    )


def print_totals(totals: dict[str, list[int]], unit: str) -> None:
    """The table of ``totals`` (case: [count, right, found, extras]) and their sum, the
    count headed ``unit`` (``parts``, ``faults``)."""
    print(f"\ncase         {unit:>7s}  right  found  extras")
    for case, (n, right, found, extras) in totals.items():
        print(f"{case:12s} {n:7d} {right:6d} {found:6d} {extras:7d}")
    all_ = [sum(v[i] for v in totals.values()) for i in range(4)]
    print(f"{'all':12s} {all_[0]:7d} {all_[1]:6d} {all_[2]:6d} {all_[3]:7d}")
