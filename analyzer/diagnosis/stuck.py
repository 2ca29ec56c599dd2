"""Stuck and dead sensors, told apart from the raw readings over a fault.

The residual shapes cannot separate a sensor frozen at some value from an offset or a
gain: a reading frozen at ``c`` leaves the residual ``c - x`` (an "offset" if the
structure is quiet, a "gain" near 0 otherwise). The readings themselves can: over the
fault they hardly vary while in the healthy window they did. Frozen at the sensor's zero
it is a dead sensor (the contract's multiplicative fault with gain 0); frozen anywhere
else it is stuck (the contract's ``other``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.diagnosis.merge import Finding
from analyzer.diagnosis.streamed import ColumnMoments
from analyzer.paging import read_column, row_blocks
from analyzer.types import FaultType

FLAT = 0.01
"""Readings vary by less than this fraction of their healthy standard deviation: frozen."""

ZERO = 0.01
"""A frozen reading within this fraction of the healthy standard deviation of zero reads
zero: a dead sensor rather than a stuck one."""

MIN_FLAT_SAMPLES = 16
"""Fewer finite samples over a fault than this say nothing about its being frozen."""


def relabel_frozen(
    findings: Sequence[Finding],
    values: npt.NDArray[Any],
    channels: Sequence[str],
    rate_hz: float,
    healthy: tuple[int, int] | Mapping[str, tuple[float, float]],
    search_start: int = 0,
) -> list[str]:
    """Set the type of each finding whose channel is frozen over the fault: ``other``
    (stuck, magnitude ``stuck_at`` and ``offset`` from the healthy mean) or
    ``multiplicative`` with gain 0 (dead); returns a note per change. ``healthy`` is the
    training window (an index range of ``values``) or each channel's healthy mean and
    standard deviation (:func:`healthy_stats`; ``--model`` brings those of its own
    training window).

    The readings decide the fault's period too. It starts where they froze
    (:func:`frozen_since`, no earlier than the row ``search_start``): the residual of a
    sensor that died while the structure was quiet moves little until the structure
    moves (a 4-floor building's sensor dead from 70.0 s was reported from 80.4 s, the
    detectors' first alarms at 81.8-83.0 s, and the detection filter put an ``other`` on
    a healthy sensor at 70.1 s). And it ends where they move again
    (:func:`frozen_until`), when that is before the end the detectors saw and the frozen
    stretch is most of the fault (:data:`FROZEN_SHARE`): a sensor dead from 150 to
    220 s, whose end the detection filter saw at 227.4 s, was not frozen over that
    period, kept the filter's gain of 0.174, and ``--corrected`` divided the healthy
    readings after 220 s by it. Its evidence ``frozen`` then has ``since_s`` and
    ``alarmed_from_s``, or ``until_s`` and ``alarmed_to_s``."""
    if not isinstance(healthy, Mapping):
        healthy = healthy_stats(values, channels, healthy)
    notes: list[str] = []
    index = {c: j for j, c in enumerate(channels)}
    n = values.shape[0]
    for f in findings:
        j = index.get(f.channel)
        stats = healthy.get(f.channel)
        if j is None or stats is None:
            continue
        mean, sd = stats
        a = max(0, int(round(f.onset_s * rate_hz)))
        b = n if f.end_s is None else min(n, int(round(f.end_s * rate_hz)))
        head = read_column(values, j, a, min(b, a + max(MIN_FLAT_SAMPLES, int(round(rate_hz)))))
        head = head[np.isfinite(head)]
        if not sd > 0 or head.size < MIN_FLAT_SAMPLES or float(np.std(head)) > FLAT * sd:
            continue
        tol = max(FROZEN_SPREAD * float(np.std(head)), FROZEN_EPS * sd)
        until = frozen_until(values, j, a, float(np.median(head)), tol, b)
        if until - a < FROZEN_SHARE * (b - a):
            continue
        seg = read_column(values, j, a, until)
        seg = seg[np.isfinite(seg)]
        if seg.size < MIN_FLAT_SAMPLES or float(np.std(seg)) > FLAT * sd:
            continue
        level, spread = float(np.median(seg)), float(np.std(seg))
        before, alarmed, alarmed_to = f.type, f.onset_s, f.end_s
        since = frozen_since(values, j, a, level, spread, sd, search_start)
        if abs(level) <= ZERO * sd:
            f.type = FaultType.MULTIPLICATIVE
            f.magnitude = {"gain": 0.0}
            what = "dead (reads 0)"
        else:
            f.type = FaultType.OTHER
            f.magnitude = {"stuck_at": level, "offset": level - mean}
            what = f"stuck at {level:.6g}"
        f.evidence["frozen"] = {"level": level, "std_ratio": spread / sd, "was": str(before)}
        moved = []
        if since < a:
            f.onset_s = since / rate_hz
            f.evidence["frozen"].update({"since_s": f.onset_s, "alarmed_from_s": alarmed})
            moved.append(f"the detectors saw it from {alarmed:.3f} s: it starts where they froze")
        if until < b:
            f.end_s = until / rate_hz
            f.evidence["frozen"].update({"until_s": f.end_s, "alarmed_to_s": alarmed_to})
            seen = "the record's end" if alarmed_to is None else f"{alarmed_to:.3f} s"
            moved.append(f"the detectors saw it to {seen}: it ends where they moved again")
        if f.type is not before or what.startswith("stuck") or moved:
            notes.append(
                f"{f.channel} from {f.onset_s:.3f} s"
                + ("" if f.end_s is None else f" to {f.end_s:.3f} s")
                + f": {what}: its readings vary by {spread / sd:.2g} of their healthy spread "
                f"(the residual alone read it as {before}" + "".join(f"; {m}" for m in moved) + ")"
            )
    return notes


FROZEN_SHARE = 0.9
"""A finding whose readings stay frozen from its onset over at least this share of its
period, and then move, is a frozen sensor that recovered before the detectors saw it
recover: a smaller share is a fault of another kind that read flat for a while."""


FROZEN_SPREAD = 4.0
"""A reading belongs to a frozen stretch when it is within this many times the stretch's
own spread of its level (:func:`frozen_since`; at least :data:`FROZEN_EPS` of the healthy
spread, for a reading frozen exactly)."""

FROZEN_EPS = 1e-6
"""The least tolerance of :func:`frozen_since`, as a share of the healthy spread: a
healthy reading comes this close to a frozen level about once in a million samples."""


def frozen_until(
    values: npt.NDArray[Any],
    j: int,
    a: int,
    level: float,
    tol: float,
    stop: int,
    block: int = 1 << 16,
) -> int:
    """The first row from ``a`` on (before ``stop``) where column ``j`` reads more than
    ``tol`` from ``level``, else ``stop``: where a frozen stretch ends. Missing readings
    do not end it. Read a block of rows at a time."""
    start = a
    while start < stop:
        hi = min(stop, start + block)
        seg = read_column(values, j, start, hi)
        moved = np.flatnonzero(np.abs(seg - level) > tol)  # (NaN compares False: kept)
        if moved.size:
            return start + int(moved[0])
        start = hi
    return stop


def frozen_since(
    values: npt.NDArray[Any],
    j: int,
    a: int,
    level: float,
    spread: float,
    sd: float,
    stop: int = 0,
    block: int = 1 << 16,
) -> int:
    """The first row of the frozen stretch of column ``j`` that goes on at row ``a``:
    back from ``a`` while the readings stay within :data:`FROZEN_SPREAD` times ``spread``
    (the frozen stretch's own standard deviation; at least :data:`FROZEN_EPS` of the
    healthy ``sd``) of ``level``, no earlier than ``stop``. Missing readings do not end
    it (a dead sensor's gaps). Read a block of rows at a time, backwards."""
    tol = max(FROZEN_SPREAD * spread, FROZEN_EPS * sd)
    start = a
    while start > stop:
        lo = max(stop, start - block)
        seg = read_column(values, j, lo, start)
        moved = np.flatnonzero(np.abs(seg - level) > tol)  # (NaN compares False: kept)
        if moved.size:
            return lo + int(moved[-1]) + 1
        start = lo
    return start


def healthy_stats(
    values: npt.NDArray[Any], channels: Sequence[str], train: tuple[int, int]
) -> dict[str, tuple[float, float]]:
    """Each channel's mean and standard deviation over the training window ``train``
    (finite samples only); a channel with fewer than 2 of them is left out."""
    moments = ColumnMoments(len(channels))
    # one pass a block of rows at a time (a long window's pages are not all held)
    for _, block in row_blocks(values[train[0] : train[1]]):
        moments.add(np.asarray(block, dtype=np.float64))
    mean, std, _ = moments.stats()
    return {c: (float(mean[j]), float(std[j])) for j, c in enumerate(channels) if moments.n[j] >= 2}
