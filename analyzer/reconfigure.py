"""A second search without the channels that go missing for a long stretch.

The bank of Kalman estimators and the detection filter model the analyzed channels
together: while one of them has no data (a sensor that died at 48 s of a 120 s record,
one that was switched on late), they lose their view of the others too: the bank keeps
only its estimator that leaves the missing channel out, which detects but cannot
isolate, and the detection filter's directions need every output. A 2-sd offset on
another sensor 24 s after the loss went unreported in 5 of 6 simulated buildings (exit 0,
a note naming ``--channels '!X'``, which found all five). The run now does what the note
asked of the user: it fits the detectors again on the same healthy window without the
missing channels (a reconfigured sensor set, as fault-tolerant monitoring does after a
sensor is declared failed) and searches the stretches where they were missing; what it
finds there that the first search did not is added, its evidence naming the channels
left out (``searched_without``).

The stretches are those the run's notes already name (:data:`LOST_SHARE` of the record
and at least :data:`LOST_MIN_S` at its start or end); the second search costs a second
fit and run of the detectors, and only when a channel is missing that long."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.detectors import DetectorResult
from analyzer.diagnosis.merge import Finding, found_already
from analyzer.paging import RELEASE_ROWS, release, row_blocks

LOST_SHARE = 0.05
"""Share of the record (and at least :data:`LOST_MIN_S`) a channel may miss at its start
or end before the run's notes say so and the others are searched again without it."""
LOST_MIN_S = 10.0
SEARCH_AGAIN_MIN = 3
"""Channels the second search needs left: with two, the bank's estimators each see one
other sensor and isolate nothing (a healthy 3-channel building whose s2 stopped halfway
got a false gain on s1 from the two left), and the equivalent model's network needs
three."""


def lost_stretches(values: npt.NDArray[Any], rate_hz: float) -> list[list[tuple[int, int]]]:
    """For each column of the aligned matrix ``values``, its rows without a reading at
    the record's start or end when they last at least :data:`LOST_SHARE` of the record
    and :data:`LOST_MIN_S`: ``[(0, first)]``, ``[(last, n)]``, both or none. The record
    runs from the first row any column has a reading in to the last.

    From the values, not the channels' first and last samples: a sensor that died may
    stop publishing, or go on publishing NaN (a 100 Hz MCAP topic of NaN from 30 s had
    its last sample at the record's end, and the run said nothing). A pass from each end
    a block of rows at a time until every column has met a finite value (a block, for a
    channel that ends with the others)."""
    n, m = values.shape
    first = _first_finite(values, range(0, n, RELEASE_ROWS), n)
    last = _first_finite(
        values, range(((n - 1) // RELEASE_ROWS) * RELEASE_ROWS, -1, -RELEASE_ROWS), n, True
    )
    seen = first < n
    if seen.sum() < 2 or not rate_hz > 0:
        return [[] for _ in range(m)]
    t0, t1 = int(first[seen].min()), int(last[seen].max()) + 1
    least = max(LOST_SHARE * (t1 - t0), LOST_MIN_S * rate_hz)
    out: list[list[tuple[int, int]]] = []
    for j in range(m):
        rows = []
        if seen[j] and first[j] - t0 >= least:
            rows.append((0, int(first[j])))
        if seen[j] and t1 - (last[j] + 1) >= least:
            rows.append((int(last[j]) + 1, n))
        out.append(rows)
    return out


def last_rows(values: npt.NDArray[Any]) -> npt.NDArray[np.int64]:
    """Each column's last row with a finite value (-1: none), read from the end a block
    of rows at a time (:func:`_first_finite`)."""
    n = values.shape[0]
    return _first_finite(
        values, range(((n - 1) // RELEASE_ROWS) * RELEASE_ROWS, -1, -RELEASE_ROWS), n, True
    )


def _first_finite(
    values: npt.NDArray[Any], starts: range, n: int, backwards: bool = False
) -> npt.NDArray[np.int64]:
    """Each column's first row with a finite value (``n``: none), the blocks of rows
    from ``starts`` read in that order; ``backwards``: its last such row (-1: none),
    the blocks read from the end."""
    m = values.shape[1]
    found = np.full(m, -1 if backwards else n, dtype=np.int64)
    todo = np.ones(m, dtype=bool)
    for lo in starts:
        block = np.asarray(values[lo : lo + RELEASE_ROWS])
        fin = np.isfinite(block)
        release(values[lo : lo + RELEASE_ROWS])
        has = todo & fin.any(axis=0)
        if has.any():
            cols = np.flatnonzero(has)
            sub = fin[:, cols]
            at = (
                (sub.shape[0] - 1 - np.argmax(sub[::-1], axis=0))
                if backwards
                else np.argmax(sub, axis=0)
            )
            found[cols] = lo + at
            todo[cols] = False
        if not todo.any():
            break
    return found


def columns(
    values: npt.NDArray[Any], chosen: Sequence[str], keep: Sequence[str], path: Path | None
) -> npt.NDArray[np.float64]:
    """The columns ``keep`` of ``values`` (whose columns are ``chosen``) as a matrix of
    their own: in memory, or written a block of rows at a time into a memory-mapped
    ``path`` (a long archive's matrix is not held twice)."""
    idx = [list(chosen).index(c) for c in keep]
    n = values.shape[0]
    if path is None:
        return np.ascontiguousarray(np.asarray(values)[:, idx], dtype=np.float64)
    out = np.lib.format.open_memmap(path, mode="w+", dtype=np.float64, shape=(n, len(idx)))
    for a, block in row_blocks(values):
        out[a : a + block.shape[0]] = np.asarray(block)[:, idx]
        release(block)
        release(out[a : a + block.shape[0]])
    out.flush()
    return out


def found_again(
    again: Sequence[Finding],
    findings: Sequence[Finding],
    lost: dict[str, list[tuple[int, int]]],
    rate_hz: float,
    slack_s: float,
    suspects: dict[str, list[tuple[int, int]]] | None = None,
    detectors: int = 1,
) -> list[Finding]:
    """The second search's findings ``again`` that begin where a left-out channel was
    missing (``lost``) or found faulty (``suspects``, :func:`beside_faults`) and that the
    first search has no finding for on the same channel then (within ``slack_s``): those
    its blindness or its one fault at a time cost. Their evidence names the channels left
    out.

    Beside a fault found, the second search's finding needs two of its ``detectors`` (all
    it ran, if fewer): anomalies no sensor explained may be the monitored system's own
    (on SKAB's pump, a real record, the second search added findings that one detector
    alone saw, beside the fault injected), while a second sensor fault stands out in the
    reconfigured models of each (all three, in the simulated pairs)."""
    suspects = suspects or {}
    blind = [(a / rate_hz, b / rate_hz) for rows in lost.values() for a, b in rows]
    beside = [(a / rate_hz, b / rate_hz) for rows in suspects.values() for a, b in rows]
    left = sorted({*lost, *suspects})
    need = min(2, detectors)
    out = []
    for f in again:
        seen_by = len(f.evidence.get("detectors", ())) or 1
        if not (
            any(a <= f.onset_s < b for a, b in blind)
            or (seen_by >= need and any(a <= f.onset_s < b for a, b in beside))
        ):
            continue
        if found_already(f, findings, slack_s) and not seen_late(f, findings, slack_s):
            continue
        f.evidence["searched_without"] = left
        out.append(f)
    return out


def seen_late(f: Finding, findings: Sequence[Finding], slack_s: float) -> list[Finding]:
    """The findings of the first search on ``f``'s channel that overlap ``f`` (a second
    search's), when each begins more than ``slack_s`` after ``f`` and ends within
    ``slack_s`` of it (or both last to the end): the same fault, its beginning lost to one
    fault at a time, which ``f`` replaces; else none. An offset on s1 from 100 to 200 s
    and one on s4 from 150 to 250 s: every detection filter left its direction while
    both lasted, and the filter named s4 from 200.1 s, where s1's fault ended; searched
    again without s1, s4's fault was found from 150.0 s."""
    over = [g for g in findings if g.channel == f.channel and found_already(f, [g], slack_s)]
    if not over or f.end_s is None and any(g.end_s is not None for g in over):
        return []
    for g in over:
        if g.onset_s <= f.onset_s + slack_s:
            return []
        if f.end_s is not None and (g.end_s is None or abs(g.end_s - f.end_s) > slack_s):
            return []
    return over


def beside_faults(
    findings: Sequence[Finding],
    results: Sequence[DetectorResult],
    n: int,
    rate_hz: float,
    slack_s: float,
) -> dict[str, list[tuple[int, int]]]:
    """The findings that lasted at least :data:`LOST_MIN_S` while anomalies no sensor
    explained came and went beside them: their channels, each with the rows from its
    onset (less ``slack_s``) to its end.

    The bank and the detection filter isolate one faulty sensor at a time, and the
    equivalent model's network names one of several only when the alarms single it out:
    two sensors faulty from one instant gave one finding in 5 of 9 six-channel buildings,
    the other fault's alarms left "attributed to no sensor". Searched again without the
    sensor found faulty, the others' model is healthy again, and the second fault stands
    out. Beside means: the equivalent model's network named the finding's sensor with
    another fault it could not place, or two detectors left an anomaly unattributed within
    ``slack_s`` of each other while the finding lasted (one detector alone is not enough:
    the detection filter leaves single-channel alarms unattributed beside most single
    faults)."""
    out: dict[str, list[tuple[int, int]]] = {}
    for f in findings:
        end = float("inf") if f.end_s is None else f.end_s
        if end - f.onset_s < LOST_MIN_S:
            continue
        near = [
            (onset, r.detector, beside)
            for r in results
            for onset, _, beside in r.unattributed
            if f.onset_s - slack_s <= onset <= end + slack_s
        ]
        named = any(f.channel in beside for _, _, beside in near)
        plain = sorted((onset, d) for onset, d, beside in near if not beside)
        paired = any(
            d1 != d2 and t2 - t1 <= slack_s
            for i, (t1, d1) in enumerate(plain)
            for t2, d2 in plain[i + 1 :]
        )
        if named or paired:
            a = max(0, int(round((f.onset_s - slack_s) * rate_hz)))
            b = n if f.end_s is None else min(n, int(round(f.end_s * rate_hz)))
            out.setdefault(f.channel, []).append((a, b))
    return out


def note(
    lost: dict[str, list[tuple[int, int]]],
    suspects: dict[str, list[tuple[int, int]]],
    added: Sequence[Finding],
    rate_hz: float,
    slack_s: float = 0.0,
) -> str:
    """The run's note on the second search: ``lost``, the channels missing for long,
    ``suspects``, those found faulty with anomalies beside (:func:`beside_faults`, whose
    rows begin ``slack_s`` before the fault's onset).

    A suspect's rows are named by both times: the note said "big_Pa faulty from 28.0 s"
    of a fault whose finding (and findings.json) has its onset at 30.0 s, 28.0 s being
    where the rows left out begin, the onset less the 2 s slack."""
    parts = [
        f"{name} missing " + ", ".join(f"{a / rate_hz:.6g}-{b / rate_hz:.6g} s" for a, b in rows)
        for name, rows in sorted(lost.items())
    ] + [
        f"{name} faulty from "
        + ", ".join(_left_out(a, rate_hz, slack_s) for a, _ in rows)
        + " with anomalies beside its fault that no sensor explained"
        for name, rows in sorted(suspects.items())
    ]
    left = ", ".join(sorted({*lost, *suspects}))
    if not added:
        found = "nothing more was found there"
    else:
        found = f"{len(added)} finding(s) added from it: " + ", ".join(
            f"{f.type.value} on {f.channel} from {f.onset_s:.1f} s" for f in added
        )
    why = "lost its view of them" + (" or isolated one fault at a time" if suspects else "")
    return (
        f"the other channels were searched again without {left} ({'; '.join(parts)}), "
        f"fitted on the same healthy window, where the first search had {why}: {found}"
    )


def _left_out(a: int, rate_hz: float, slack_s: float) -> str:
    """A suspect's onset and the first row left out, ``slack_s`` before it
    (:func:`beside_faults`): ``30.0 s (left out from 28.0 s)``; a fault within
    ``slack_s`` of the start was left out from the start, its onset unknown here."""
    start = a / rate_hz
    if a == 0 and slack_s > 0:
        return f"within {slack_s:.3g} s of the start (left out from 0.0 s)"
    if slack_s <= 0:
        return f"{start:.1f} s"
    return f"{start + slack_s:.1f} s (left out from {start:.1f} s)"
