"""A search again after a stretch whose load the models were not fitted on.

Where the channels' response level leaves the training window's range (a storm, traffic,
a gust: :mod:`analyzer.diagnosis.levels`), every residual alarms at once and the
detectors rightly attribute the anomaly to no sensor. But a sensor's fault that begins
in that stretch and outlasts it is carried in the same alarms, and left unattributed
with them: a 2-sd offset from 5 s into a 45 s burst of 10x the excitation, lasting 195 s
past it, was found in 9 of 15 simulated buildings (``benchmarks/sweep_eov.py --cases
burst10 --fault``; 1 of 5 on 4 channels). The run now searches the record again from the
end of such a stretch (:data:`SETTLE_S` after it), with the detectors it fitted (no
second fit) and the same healthy window: what that search finds and the first has no
finding for on the same channel is added, its evidence ``searched_after`` giving the
stretch and where the search began (an onset there is an upper bound: the fault may have
begun in the stretch), and a note says so.

A stretch is searched again when an anomaly the detectors attributed to no sensor began
in it (or within one long alarm window before it), the record goes on for at least
:data:`MIN_AFTER_S` after the search's start, and a residual of the first search still
alarms after it (within :data:`SCREEN_S` of the search's start and before the next
stretch; the detectors' own test and thresholds: where none alarms, the search again
could begin nothing there, and a burst alone costs nothing); at most
:data:`MAX_SEARCHES` such stretches, the first ones, each costing one more run of the
detectors over the record (not their fits)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from analyzer.detectors import DetectorResult
from analyzer.diagnosis.changes import Calibration, detect
from analyzer.diagnosis.levels import Excursion
from analyzer.diagnosis.merge import Finding, found_already
from analyzer.paging import release

SETTLE_S = 10.0
"""Seconds after a stretch's end (a level bin's edge) before the search again begins: the
structure's response and the filters settle from the change first."""
MIN_AFTER_S = 30.0
"""The record must go on this long after the search's start for a stretch to be searched."""
MAX_SEARCHES = 3
"""Stretches searched again at most (the first ones in time); the rest are counted."""
SCREEN_S = 60.0
"""Seconds after a stretch's search start in which a residual of the first search must
alarm for the stretch to be searched again (a fault that began in the stretch and
outlasts it alarms from the start)."""


@dataclass(frozen=True, slots=True)
class Stretch:
    """A stretch to search again after: the excursion and the row the search starts at."""

    start_s: float
    end_s: float
    search_row: int
    search_s: float


def stretches(
    found: Sequence[Excursion],
    results: Sequence[DetectorResult],
    n: int,
    rate_hz: float,
    slack_s: float,
) -> tuple[list[Stretch], int]:
    """The excursions ``found`` in which an anomaly no detector attributed began (plain:
    no fault found beside it) and after which a residual still alarms
    (:func:`alarms_after`), with the row the search again starts at, at most
    :data:`MAX_SEARCHES` of them; and how many more there were."""
    out: list[Stretch] = []
    onsets = sorted(onset for r in results for onset, _, beside in r.unattributed if not beside)
    for k, e in enumerate(found):
        if not any(e.start_s - slack_s <= t <= e.end_s for t in onsets):
            continue
        row = int(round((e.end_s + SETTLE_S) * rate_hz))
        if (n - row) / rate_hz < MIN_AFTER_S:
            continue
        if out and row <= out[-1].search_row:
            continue
        later = [int(round(x.start_s * rate_hz)) for x in found[k + 1 :]]
        stop = min([n, row + int(round(SCREEN_S * rate_hz)), *[r for r in later if r > row]])
        if not alarms_after(results, row, stop):
            continue
        out.append(Stretch(e.start_s, e.end_s, row, row / rate_hz))
    return out[:MAX_SEARCHES], max(0, len(out) - MAX_SEARCHES)


def alarms_after(results: Sequence[DetectorResult], row: int, stop: int) -> bool:
    """Whether any residual of ``results`` alarms in rows ``row .. stop - 1`` by its
    detector's own test and thresholds (:func:`~analyzer.diagnosis.changes.detect`, its
    windows reaching back before ``row``); a residual without thresholds counts as
    alarming (the search is not left out for want of them)."""
    for r in results:
        for ch, res in r.residuals.items():
            cal = Calibration.from_dict(r.thresholds.get(ch))
            if cal is None or not cal.std > 0:
                return True
            b = min(stop, res.shape[0])
            if b - row < cal.window:
                continue
            lo = max(0, row - cal.long_window)
            seg = np.asarray(res[lo:b], dtype=np.float64)
            release(res)
            if detect(seg, cal, search_start=row - lo):
                return True
    return False


def found_after(
    again: Sequence[Finding],
    findings: Sequence[Finding],
    stretch: Stretch,
    rate_hz: float,
    slack_s: float,
) -> list[Finding]:
    """The search again's findings ``again`` (from ``stretch.search_row`` on) that the
    first search (``findings``, with those already added) has no finding for on the same
    channel at that time (within ``slack_s``). Each one's evidence gets
    ``searched_after``; an event whose shape was traced back before the search's start is
    told so (``starts_before_search``: not the healthy window, as the first search's
    ``starts_in_training`` would say)."""
    start_s = stretch.search_s
    out = []
    for f in again:
        if f.onset_s < start_s - 1.5 / rate_hz:
            continue
        if found_already(f, findings, slack_s):
            continue
        at_start = f.onset_s <= start_s + 1.5 / rate_hz
        f.evidence["searched_after"] = {
            "stretch_s": [round(stretch.start_s, 3), round(stretch.end_s, 3)],
            "search_start_s": round(start_s, 3),
            "onset_at_or_before": at_start,
        }
        for ev in f.events:
            if ev.evidence.pop("starts_in_training", None):
                ev.evidence["starts_before_search"] = True
        out.append(f)
    return out


def note(searched: Sequence[tuple[Stretch, list[Finding]]], more: int) -> str:
    """The run's note on the searches again after stretches of another load."""
    parts = []
    for s, added in searched:
        what = (
            "nothing more was found"
            if not added
            else f"{len(added)} finding(s) added: "
            + ", ".join(
                f"{f.type.value} on {f.channel} from {f.onset_s:.1f} s"
                + (
                    " (there when the search began: it may have begun in the stretch)"
                    if f.evidence["searched_after"]["onset_at_or_before"]
                    else ""
                )
                for f in added
            )
        )
        parts.append(f"after {s.start_s:.1f}-{s.end_s:.1f} s (from {s.search_s:.1f} s): {what}")
    rest = f"; {more} more such stretches not searched again" if more else ""
    return (
        "the response level left the training window's range and the detectors attributed "
        "the anomaly there to no sensor, so the record was searched again from "
        f"{SETTLE_S:g} s after each such stretch, with the same models (a sensor's fault "
        f"that began there and outlasted it is otherwise left in that anomaly): "
        + "; ".join(parts)
        + rest
    )


__all__ = [
    "MAX_SEARCHES",
    "MIN_AFTER_S",
    "SCREEN_S",
    "SETTLE_S",
    "Stretch",
    "alarms_after",
    "found_after",
    "note",
    "stretches",
]
