"""A sensor that clips: its reading held at a limit while the quantity goes beyond it.

A saturating sensor (an accelerometer past its range, an amplifier or ADC at full scale)
reads the true signal until it crosses the limit and the limit while it is beyond. The
residuals see a burst each time the structure's response peaks: the detectors report a
swarm of short faults on that sensor (gains below 1 where the peaks are cut, ``other``
where no shape fits), and some of them on the sensors modelled with it (a 6-channel
building whose s0 clipped at half its peak from 60 % of the record had 23 findings, two
of them on s1). The readings tell it at once: a healthy signal's tail thins out towards
its extremes, a clipped one piles up at them. Where a channel with findings has, after
the healthy window, a value that no reading goes beyond from some row on and that is
read :data:`MIN_CLIPPED` times or more from there, at least :data:`PILE_UP` times as
often as the next value inside it (continuous readings take each value once; quantized
ones still thin out at the tail), on fewer than half of its readings (more is a frozen
sensor, :mod:`analyzer.diagnosis.stuck`), and the readings are finely resolved
(:func:`_coarse`), its findings that begin between its first and last clipped readings
are one fault (where the healthy window piles up at the limit too, the sensor clipped
there already, and the note says so): type ``other``, magnitude ``clipped_high`` /
``clipped_low`` (the limits, channel units) and ``clipped_fraction``, merged before one
fault at a time so that what the clipping did to the sensors modelled with it is taken
for it. (A quantity that itself sits at a bound, a valve fully open, reads the same way:
the note says so.)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.diagnosis.changes import LONG_FACTOR, default_window
from analyzer.diagnosis.merge import Finding
from analyzer.errors import counted
from analyzer.paging import read_column
from analyzer.timeutil import seconds_text
from analyzer.types import FaultType

MIN_CLIPPED = 10
"""Readings at a limit, fewer than which say nothing about clipping."""

PILE_UP = 3.0
"""A limit is read at least this many times as often as the next value inside it."""

ECHO_WINDOWS = 2
"""How near a clipped reading (in long alarm windows: 4 s at 100 Hz) a short finding on a
sensor modelled with the clipping one lies for it to be taken for the clipping."""

COARSE = 0.1
"""Readings whose values are spaced by more than this fraction of their standard deviation
are not judged (:func:`_coarse`)."""

CANDIDATES = 3
"""Limits tried on each side (those read most often)."""

MAX_FRACTION = 0.5
"""Readings at the limits from the first on: at or beyond this share, frozen, not clipped."""


@dataclass(frozen=True, slots=True)
class Clip:
    """A channel's clipping over the rows searched: the limits it piles up at (None: not
    that side), its first and last clipped rows (absolute), the readings at the limits
    and their share of the finite readings from the first to the last."""

    high: float | None
    low: float | None
    first: int
    last: int
    count: int
    fraction: float
    rows: npt.NDArray[np.int64] = field(repr=False)
    """The clipped readings' rows (absolute)."""
    healthy_from: int | None = None
    """The first row of the healthy window that reads a limit, where that window piles up
    at it too (the sensor clipped already there: its range too small for the response);
    None where it does not."""


def _candidates(seg: npt.NDArray[np.float64], top: bool) -> list[tuple[float, int]]:
    """The values ``seg`` may clip at on one side, with the row from which no reading
    goes beyond each: the values of its running extreme from the end (``max(seg[i:])``)
    read :data:`MIN_CLIPPED` times or more from there, the :data:`CANDIDATES` read most
    often. (A quantized reading passes through its limit before it clips: the limit's
    first reading is not where the clipping starts.)"""
    back = seg[::-1]
    ext = (np.maximum if top else np.minimum).accumulate(back)[::-1]
    eq = seg == ext
    vals, counts = np.unique(seg[eq], return_counts=True)
    keep = np.flatnonzero(counts >= MIN_CLIPPED)
    keep = keep[np.argsort(-counts[keep], kind="stable")][:CANDIDATES]
    return [(float(vals[k]), int(np.argmax(ext == vals[k]))) for k in keep]


def _piles_up(after: npt.NDArray[np.float64], value: float, top: bool) -> bool:
    """``value`` is read in ``after`` at least :data:`PILE_UP` times as often as the next
    distinct value inside it."""
    at = after == value
    inside = after[~at]
    if not inside.size:
        return True
    nxt = float(np.max(inside) if top else np.min(inside))
    return bool(np.count_nonzero(at) >= PILE_UP * np.count_nonzero(after == nxt))


def _coarse(x: npt.NDArray[np.float64]) -> bool:
    """Readings too coarsely quantized to tell a limit from a level: fewer than three
    distinct values, or a median step between them over :data:`COARSE` of their standard
    deviation (SKAB's pump pressure reads 7 levels 1.1 sd apart: an offset on it moved
    its top level above all the readings before, and the next level inside was the
    unshifted one, read far less often, which looked like a pile-up)."""
    levels = np.unique(x)
    if levels.size < 3:
        return True
    return bool(float(np.median(np.diff(levels))) > COARSE * float(np.std(x)))


def find_clipping(
    values: npt.NDArray[Any], j: int, start: int, train: tuple[int, int]
) -> Clip | None:
    """Column ``j``'s clipping over rows ``start ..`` of ``values`` (the search), or None.
    A limit (:func:`_candidates`) clips when it piles up from the row no reading goes
    beyond it (:func:`_piles_up`). Where the healthy window ``train`` reads a limit
    :data:`MIN_CLIPPED` times or more, the sensor clipped there already (``healthy_from``:
    a sensor whose range is too small for the response clips from the record's start,
    and the detectors fitted on its clipped readings still reported 21 faults on it)."""
    n = values.shape[0]
    col = read_column(values, j, start, n)
    finite = np.isfinite(col)
    seg = col[finite]
    if seg.size < MIN_CLIPPED:
        return None
    rows = np.flatnonzero(finite) + start
    healthy = read_column(values, j, train[0], train[1]) if train[1] > train[0] else col[:0]
    if _coarse(healthy[np.isfinite(healthy)] if healthy.size else seg):
        return None
    limits: dict[str, float] = {}
    froms: list[int] = []
    before: list[int] = []
    for name, top in (("high", True), ("low", False)):
        for value, since in _candidates(seg, top):
            if not _piles_up(seg[since:], value, top):
                continue
            there = healthy == value
            if int(np.count_nonzero(there)) >= MIN_CLIPPED:
                before.append(train[0] + int(np.argmax(there)))
            limits[name] = value
            froms.append(since)
            break
    if not limits:
        return None
    clipped = np.isin(seg, list(limits.values()))
    clipped[: min(froms)] = False
    where = np.flatnonzero(clipped)
    span = seg[where[0] : where[-1] + 1]
    fraction = where.size / span.size
    if fraction >= MAX_FRACTION:
        return None  # frozen at a value rather than cut at it
    return Clip(
        limits.get("high"),
        limits.get("low"),
        int(rows[where[0]]),
        int(rows[where[-1]]),
        int(where.size),
        float(fraction),
        rows[where],
        min(before) if before else None,
    )


def merge_clipped(
    findings: list[Finding],
    values: npt.NDArray[Any],
    channels: Sequence[str],
    rate_hz: float,
    train: tuple[int, int],
    groups: Sequence[Sequence[str]] = (),
    slack_s: float = 1.0,
) -> tuple[list[Finding], list[str]]:
    """``findings`` with each clipping channel's findings that begin from its first clipped
    reading (less ``slack_s``) to its last (plus ``slack_s``) merged into one
    (:class:`Clip`: type ``other``, the limits as magnitude, evidence ``clipped``), and a
    note for each. Channels without findings are not read.

    A clipped burst also reaches the residuals of every sensor modelled with the clipping
    one (``groups``: the channels each detector models together): a finding on such a
    sensor that begins and ends while it clips, with a clipped reading within
    :data:`ECHO_WINDOWS` long alarm windows of it, is taken for the clipping (a note
    says so); so is one that begins that near the record's end and lasts to it. One
    that lasts beyond the clipping's last reading is its own, and so is one that its own
    sensor's clipping takes in (two sensors that clip at once), and an offset or a drift:
    a cut peak leaves a burst in the partners' residuals (a gain or ``other``), not a
    level or a trend (an offset of 300 s on a partner, which all three detectors found,
    was taken for the clipping before this: a clipped reading lies within 4 s of almost
    any moment of a sensor that clips 5 % of the time)."""
    index = {c: j for j, c in enumerate(channels)}
    start = train[1]
    out = list(findings)
    notes: list[str] = []
    clips = {
        c: clip
        for c in sorted({f.channel for f in findings} & index.keys())
        if (clip := find_clipping(values, index[c], start, train)) is not None
    }

    near = ECHO_WINDOWS * LONG_FACTOR * default_window(rate_hz) / rate_hz
    record_end = values.shape[0] / rate_hz

    def clipping_own(g: Finding) -> bool:
        own = clips.get(g.channel)
        return own is not None and (
            own.first / rate_hz - slack_s <= g.onset_s <= own.last / rate_hz + slack_s
        )

    for channel, clip in clips.items():
        t0 = clip.first / rate_hz
        last_s = clip.last / rate_hz
        # (a finding that began before the clipping, or after its last clipped reading, is
        # a fault of its own: kept as it is)
        mine = [
            f for f in out if f.channel == channel and t0 - slack_s <= f.onset_s <= last_s + slack_s
        ]
        if not mine:
            continue
        mine.sort(key=lambda f: f.onset_s)
        ends = [f.end_s for f in mine]
        # it clipped to the end unless the record went on, unclipped, for longer than its
        # longest pause between clipped readings
        pause = int(np.max(np.diff(clip.rows))) if clip.rows.size > 1 else 0
        to_end = any(e is None for e in ends) or values.shape[0] - 1 - clip.last <= pause
        end = None if to_end else max(last_s, *(e for e in ends if e is not None))
        evidence: dict[str, Any] = {
            "detectors": sorted(
                {d for f in mine for d in f.evidence.get("detectors", [f.detector])}
            ),
            "tests": dict(mine[0].evidence.get("tests", {})),
        }
        by_detector: dict[str, Any] = {}
        for f in mine:
            for d, said in f.evidence.get("by_detector", {}).items():
                by_detector.setdefault(d, said)
        if by_detector:
            evidence["by_detector"] = by_detector
        magnitude: dict[str, float] = {}
        if clip.high is not None:
            magnitude["clipped_high"] = clip.high
        if clip.low is not None:
            magnitude["clipped_low"] = clip.low
        magnitude["clipped_fraction"] = clip.fraction
        evidence["clipped"] = {
            **{k: v for k, v in magnitude.items() if k != "clipped_fraction"},
            "readings": clip.count,
            "fraction": clip.fraction,
            "first_s": t0,
            "last_s": last_s,
            "in_healthy_window_from_s": (
                None if clip.healthy_from is None else clip.healthy_from / rate_hz
            ),
            "findings_merged": len(mine),
            "types_merged": sorted({str(f.type) for f in mine}),
        }
        merged = Finding(
            channel=channel,
            type=FaultType.OTHER,
            onset_s=min(t0, mine[0].onset_s),
            end_s=end,
            magnitude=magnitude,
            confidence=max(f.confidence for f in mine),
            detector=mine[0].detector,
            evidence=evidence,
            events=[e for f in mine for e in f.events],
        )
        gone = {id(f) for f in mine}
        partners = {c for g in groups if channel in g for c in g} - {channel}
        echoes = []
        for g in out:
            if g.channel not in partners or g.onset_s < t0 - slack_s or clipping_own(g):
                continue
            if g.type in (FaultType.ADDITIVE, FaultType.DRIFT):
                continue  # a level or a trend: not what a cut peak leaves behind
            # one cut short by the record's end, within the window it takes to tell, ends
            # there (it may outlast the clipping; no one can say)
            if g.end_s is None and record_end - g.onset_s <= near:
                stop = record_end
            elif g.end_s is None or g.end_s > last_s + slack_s:
                continue
            else:
                stop = g.end_s
            if _clipped_near(clip.rows / rate_hz, g.onset_s - near, stop + near):
                echoes.append(g)
        for g in echoes:
            gone.add(id(g))
            notes.append(
                f"{g.detector}'s {g.type} fault on {g.channel} at {seconds_text(g.onset_s)} s not "
                f"reported: it began and ended while {channel} clipped, with a clipped "
                f"reading within {near:.0f} s of it, and the models that take {channel} in "
                f"see {g.channel} through it: taken for that fault"
            )
        out = [f for f in out if id(f) not in gone] + [merged]
        limits = " and ".join(f"{v:.6g}" for v in (clip.high, clip.low) if v is not None)
        notes.append(
            f"{channel} clips at {limits} from {seconds_text(t0)} s: "
            f"{counted(clip.count, 'reading')} "
            f"({clip.fraction:.1%} of those from the first to the last) "
            f"{'sits' if clip.count == 1 else 'sit'} at its extremes, "
            "a pile-up a healthy signal's tail does not make (the sensor saturates: past its "
            "range, or its amplifier's; or the quantity sits at a bound); its "
            f"{len(mine)} finding(s) from then on "
            f"({', '.join(sorted({str(f.type) for f in mine}))}) are reported as one"
            + (
                ""
                if clip.healthy_from is None
                else f". It clipped at that limit in the healthy window already, from "
                f"{seconds_text(clip.healthy_from / rate_hz)} s: its range is too small for this "
                "response (or the quantity sits at a bound), and the detectors were fitted "
                "on its clipped readings"
            )
        )
    out.sort(key=lambda f: (f.onset_s, f.channel))
    return out, notes


def _clipped_near(times: npt.NDArray[np.float64], lo: float, hi: float) -> bool:
    """Whether a clipped reading's time (sorted ``times``) lies in ``lo .. hi``."""
    k = int(np.searchsorted(times, lo))
    return k < times.size and float(times[k]) <= hi


__all__ = ["Clip", "find_clipping", "merge_clipped"]
