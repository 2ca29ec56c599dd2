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

from analyzer.diagnosis.merge import Finding
from analyzer.paging import release, row_blocks
from analyzer.store import ChannelInfo
from analyzer.timeutil import NS_PER_S

LOST_SHARE = 0.05
"""Share of the record (and at least :data:`LOST_MIN_S`) a channel may miss at its start
or end before the run's notes say so and the others are searched again without it."""
LOST_MIN_S = 10.0


def lost_stretches(
    infos: Sequence[ChannelInfo],
    chosen: Sequence[str],
    start_ns: int,
    n: int,
    rate_hz: float,
) -> dict[str, list[tuple[int, int]]]:
    """The analyzed channels that start late or stop early by at least :data:`LOST_SHARE`
    of the record and :data:`LOST_MIN_S`, each with its missing rows of the aligned
    matrix (``n`` rows at ``rate_hz`` from ``start_ns``): ``[(0, first), (last, n)]``,
    either or both. Empty when fewer than two channels have data."""
    by = {i.name: i for i in infos}
    kept = [by[c] for c in chosen if c in by]
    if len(kept) < 2 or n <= 0 or not rate_hz > 0:
        return {}
    t0 = min(i.start_ns for i in kept)
    t1 = max(i.end_ns for i in kept)
    least = max(LOST_SHARE * (t1 - t0) / NS_PER_S, LOST_MIN_S)
    out: dict[str, list[tuple[int, int]]] = {}
    for i in kept:
        late = (i.start_ns - t0) / NS_PER_S
        early = (t1 - i.end_ns) / NS_PER_S
        rows = []
        if late >= least:
            rows.append((0, _row(i.start_ns, start_ns, rate_hz, n)))
        if early >= least:
            rows.append((min(n, _row(i.end_ns, start_ns, rate_hz, n) + 1), n))
        rows = [(a, b) for a, b in rows if b > a]
        if rows:
            out[i.name] = rows
    return out


def _row(t_ns: int, start_ns: int, rate_hz: float, n: int) -> int:
    return int(np.clip(round((t_ns - start_ns) / NS_PER_S * rate_hz), 0, n))


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
) -> list[Finding]:
    """The second search's findings ``again`` that begin while a left-out channel was
    missing and that the first search has no finding for on the same channel then (within
    ``slack_s``): those its blindness cost. Their evidence names the channels left out."""
    spans = [(a / rate_hz, b / rate_hz) for rows in lost.values() for a, b in rows]
    out = []
    for f in again:
        if not any(a <= f.onset_s < b for a, b in spans):
            continue
        end = float("inf") if f.end_s is None else f.end_s
        if any(
            g.channel == f.channel
            and g.onset_s <= end + slack_s
            and f.onset_s <= (float("inf") if g.end_s is None else g.end_s) + slack_s
            for g in findings
        ):
            continue
        f.evidence["searched_without"] = sorted(lost)
        out.append(f)
    return out


def note(lost: dict[str, list[tuple[int, int]]], added: Sequence[Finding], rate_hz: float) -> str:
    """The run's note on the second search."""
    where = "; ".join(
        f"{name} missing " + ", ".join(f"{a / rate_hz:.6g}-{b / rate_hz:.6g} s" for a, b in rows)
        for name, rows in sorted(lost.items())
    )
    left = ", ".join(sorted(lost))
    if not added:
        found = "nothing more was found there"
    else:
        found = f"{len(added)} finding(s) added from it: " + ", ".join(
            f"{f.type.value} on {f.channel} from {f.onset_s:.1f} s" for f in added
        )
    return (
        f"the other channels were searched again without {left} ({where}), fitted on the "
        f"same healthy window, where the first search had lost its view of them: {found}"
    )
