"""Stuck and dead sensors, told apart from the raw readings over a fault.

The residual shapes cannot separate a sensor frozen at some value from an offset or a
gain: a reading frozen at ``c`` leaves the residual ``c - x`` (an "offset" if the
structure is quiet, a "gain" near 0 otherwise). The readings themselves can: over the
fault they hardly vary while in the healthy window they did. Frozen at the sensor's zero
it is a dead sensor (the contract's multiplicative fault with gain 0); frozen anywhere
else it is stuck (the contract's ``other``).
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.detectors.base import DetectorResult
from analyzer.diagnosis.changes import LONG_FACTOR, default_window
from analyzer.diagnosis.merge import Finding
from analyzer.diagnosis.streamed import ColumnMoments
from analyzer.paging import read_column, row_blocks
from analyzer.timeutil import seconds_text
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
    train: tuple[int, int] | None = None,
    zero_at_rest: Collection[str] | None = None,
) -> list[str]:
    """:func:`frozen_notes`' notes, in the findings' order."""
    return list(
        frozen_notes(
            findings, values, channels, rate_hz, healthy, search_start, train, zero_at_rest
        ).values()
    )


def frozen_notes(
    findings: Sequence[Finding],
    values: npt.NDArray[Any],
    channels: Sequence[str],
    rate_hz: float,
    healthy: tuple[int, int] | Mapping[str, tuple[float, float]],
    search_start: int = 0,
    train: tuple[int, int] | None = None,
    zero_at_rest: Collection[str] | None = None,
) -> dict[int, str]:
    """Set the type of each finding whose channel is frozen over the fault: ``other``
    (stuck, magnitude ``stuck_at`` and ``offset`` from the healthy mean) or
    ``multiplicative`` with gain 0 (dead); returns a note per change, by the finding's
    ``id``. ``healthy`` is the training window (an index range of ``values``) or each
    channel's healthy mean and standard deviation (:func:`healthy_stats`; ``--model``
    brings those of its own training window), the training window then given as
    ``train`` where the record has one (the pipeline's case), or else the channels that
    read zero when healthy given as ``zero_at_rest`` (:func:`zero_channels`, saved with a
    ``--model``'s model; with neither, they are not known).

    Frozen: the readings over the fault vary by at most :data:`FLAT` of their healthy
    spread, or at least :data:`FROZEN_SHARE` of them lie within that of their median
    (the fault's period may overrun the frozen stretch). The readings then decide the
    fault's period too. It starts where they froze (:func:`frozen_since`, no earlier than
    the row ``search_start``): the residual of a sensor that died while the structure was
    quiet moves little until the structure moves (a 4-floor building's sensor dead from
    70.0 s was reported from 80.4 s, the detectors' first alarms at 81.8-83.0 s, and the
    detection filter put an ``other`` on a healthy sensor at 70.1 s). And it ends where
    they move again (:func:`frozen_until`), when that is before the end the detectors saw
    and the frozen stretch is most of the fault: a sensor dead from 150 to 220 s, whose
    end the detection filter saw at 227.4 s, kept that filter's gain of 0.174, and
    ``--corrected`` divided the healthy readings after 220 s by it. Its evidence
    ``frozen`` then has ``since_s`` and ``alarmed_from_s``, or ``until_s`` and
    ``alarmed_to_s``. A frozen stretch begins and ends with :data:`FROZEN_RUN` readings
    in a row off its level, so a stuck sensor's noise or a dead one's single flicker does
    not end it. A finding frozen for less of its period is a fault of another kind,
    unless it read dead from its onset (:func:`_dead_from_onset`): a dead sensor, to
    where its readings moved again, whatever shape the residual gave it; but a finding
    of another shape than a gain only when its readings after the revival sit at the
    healthy mean (:func:`_alive_after`: else it is a dead spell then a lasting fault,
    which the finding is) and its channel's healthy readings never read zero for long
    (:func:`reads_zero_for_long`: a quiet channel on a coarse converter; with
    ``--model``, as its model saved them, not known in a model saved before)."""
    if not isinstance(healthy, Mapping):
        train = healthy
        healthy = healthy_stats(values, channels, healthy)
    notes: dict[int, str] = {}
    index = {c: j for j, c in enumerate(channels)}
    n = values.shape[0]
    # channels whose healthy readings read zero for long (no evidence of death there);
    # with ``--model`` as saved, unknown in an older model (the guard after the revival
    # holds)
    shaped = {f.channel for f in findings if f.type is not FaultType.MULTIPLICATIVE}
    zeros = {
        j: reads_zero_for_long(values, j, train, healthy[c][1], rate_hz)
        if train is not None
        else c in (zero_at_rest or ())
        for c, j in index.items()
        if (train is not None or zero_at_rest is not None) and c in shaped and c in healthy
    }
    for f in findings:
        j = index.get(f.channel)
        stats = healthy.get(f.channel)
        if j is None or stats is None:
            continue
        mean, sd = stats
        a = onset = max(0, int(round(f.onset_s * rate_hz)))
        b = n if f.end_s is None else min(n, int(round(f.end_s * rate_hz)))
        seg = read_column(values, j, a, b)
        seg = seg[np.isfinite(seg)]
        if not sd > 0 or seg.size < MIN_FLAT_SAMPLES:
            continue
        level, tol = float(np.median(seg)), FLAT * sd
        near = np.abs(seg - level) <= tol
        frozen = float(np.std(seg)) <= tol or float(np.mean(near)) >= FROZEN_SHARE
        until = frozen_until(values, j, a, level, tol, b) if frozen else a
        if until - a < FROZEN_SHARE * (b - a):
            # frozen for a while only: a fault of another kind, unless it read dead
            # from its onset (no fault of an alive sensor reads flat at zero)
            dead = _dead_from_onset(values, j, a, b, sd, rate_hz)
            if dead is None:
                # or dead from a little after it: the onset traced back before the freeze
                froze = _froze_after_onset(values, j, a, b, sd, rate_hz)
                if froze is not None:
                    a, dead = froze, _dead_from_onset(values, j, froze, b, sd, rate_hz)
            if (
                dead is not None
                and f.type is not FaultType.MULTIPLICATIVE
                and (zeros.get(j) or not _alive_after(values, j, dead[1], b, mean, sd))
            ):
                # a shape of its own: dead only if it was the dead readings and alive
                # ones taken for one fault, not a fault that went on after them, and
                # only on a channel that does not read zero when healthy
                dead = None
            if dead is None:
                continue
            level, until = dead
            seg = read_column(values, j, a, until)
            seg = seg[np.isfinite(seg)]
            near = np.abs(seg - level) <= tol
        spread = float(np.std(seg[near]))
        before, alarmed, alarmed_to = f.type, f.onset_s, f.end_s
        # where they froze: after the traced onset (:func:`_froze_after_onset`), or
        # before it
        since = a if a > onset else frozen_since(values, j, a, level, tol, search_start)
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
        if since < onset or a > onset:
            f.onset_s = since / rate_hz
            f.evidence["frozen"].update({"since_s": f.onset_s, "alarmed_from_s": alarmed})
            moved.append(
                f"the detectors saw it from {seconds_text(alarmed)} s: it starts where they froze"
            )
        if until < b:
            f.end_s = until / rate_hz
            f.evidence["frozen"].update({"until_s": f.end_s, "alarmed_to_s": alarmed_to})
            seen = "the record's end" if alarmed_to is None else f"{seconds_text(alarmed_to)} s"
            moved.append(f"the detectors saw it to {seen}: it ends where they moved again")
        if f.type is not before or what.startswith("stuck") or moved:
            notes[id(f)] = (
                f"{f.channel} from {seconds_text(f.onset_s)} s"
                + ("" if f.end_s is None else f" to {seconds_text(f.end_s)} s")
                + f": {what}: its readings vary by {spread / sd:.2g} of their healthy spread "
                f"(the residual alone read it as {before}" + "".join(f"; {m}" for m in moved) + ")"
            )
    return notes


def _dead_from_onset(
    values: npt.NDArray[Any],
    j: int,
    a: int,
    b: int,
    sd: float,
    rate_hz: float,
) -> tuple[float, int] | None:
    """A fault whose readings (column ``j``) are dead from its onset row ``a``: frozen
    at the sensor's zero (within :data:`ZERO` of the healthy ``sd``) for at least a long
    alarm window (:data:`~analyzer.diagnosis.changes.LONG_FACTOR` windows of
    :func:`~analyzer.diagnosis.changes.default_window`, the span the detectors judge a
    change by) before its end row ``b``: their level and the row where they move again
    (:func:`frozen_until`); None otherwise.

    No fault of an alive sensor reads flat at zero that long: an offset ``c`` or a drift
    adds to the reading ``y``, which varies with the structure, and a gain ``a`` makes it
    ``a y``, which for one of at least :data:`~analyzer.diagnosis.classify.MIN_GAIN`
    (below it a gain is read as a dead sensor anyway) varies by about a tenth of the
    healthy spread or more, ten times :data:`FLAT`. A shape fitted over such a stretch
    is the dead readings and the alive ones after them taken for one fault, whatever
    shape the residual made of them: a sensor dead from 120 to 220 s whose finding ran
    on to 248 s (another sensor's fault, which the detectors model it with, in its
    residual until 250 s) or to the record's end was fitted gains of 0.11-0.38 with
    ``--model`` (``sweep_corrected.py``), and ``--corrected`` divided the alive readings
    after 220 s by them; one dead from 10 to 22 s whose finding ran on to the second
    dead sensor's revival or the record's end was ``other`` (offset about 0) in 28 of
    160 runs of ``sweep_dead_pairs.py``, regenerated past its revival (0.5 sd of error
    there). The dead stretch is the fault; the readings after it are alive. (A stuck
    sensor reads flat away from zero; a healthy one reads zero only at rest.)"""
    least = max(MIN_FLAT_SAMPLES, LONG_FACTOR * default_window(rate_hz))
    if b - a <= least:
        return None
    head = read_column(values, j, a, a + least)
    head = head[np.isfinite(head)]
    if head.size < MIN_FLAT_SAMPLES:
        return None
    level, tol = float(np.median(head)), FLAT * sd
    if abs(level) > ZERO * sd:
        return None
    until = frozen_until(values, j, a, level, tol, b)
    if until - a < least:
        return None
    # missing readings do not end a frozen stretch, nor do they read zero: the window's
    # count of finite ones (a few zeros before an outage are no dead sensor)
    finite = int(np.count_nonzero(np.isfinite(read_column(values, j, a, until))))
    return (level, until) if finite >= least else None


def _froze_after_onset(
    values: npt.NDArray[Any], j: int, a: int, b: int, sd: float, rate_hz: float
) -> int | None:
    """The row where the readings of column ``j`` froze at the sensor's zero (within
    :data:`FLAT` of the healthy ``sd``, for at least a long alarm window) when that is
    after the fault's onset row ``a`` by no more than a long alarm window (before its end
    row ``b``); None otherwise.

    A change-point fit traces a fault's onset back from its alarms, and the span it
    judges a change by is a long alarm window (:data:`~analyzer.diagnosis.changes.
    LONG_FACTOR` windows of :func:`~analyzer.diagnosis.changes.default_window`): an onset
    that far before the freeze is the same fault (:func:`dead_unattributed` pairs a dead
    stretch with an anomaly within that window too). A sensor dead from 150 to 200 s
    was given an onset of 148.29 s by the equivalent model, its readings alive for the
    first 1.71 s of the finding, and the dead-sensor rule, which asked for zeros from the
    onset on, did not fire. Where they froze is found as :func:`frozen_since` finds it,
    from inside the first such stretch."""
    window = LONG_FACTOR * default_window(rate_hz)
    least = max(MIN_FLAT_SAMPLES, window)
    seg = read_column(values, j, a, min(b, a + window + least))
    begins = _zero_stretches(seg, FLAT * sd, least)
    begins = begins[(begins > 0) & (begins <= window)]
    if not begins.size:
        return None
    inside = a + int(begins[0]) + 2 * FROZEN_RUN
    since = frozen_since(values, j, inside, 0.0, FLAT * sd, a)
    return since if a < since < b else None


ALIVE_MEAN = 0.15
"""The readings after a dead stretch, to the end of its finding, are alive and healthy
when their mean is within this fraction of the healthy standard deviation of the healthy
mean (:func:`_alive_after`)."""


def _alive_after(
    values: npt.NDArray[Any], j: int, until: int, b: int, mean: float, sd: float
) -> bool:
    """Whether the readings of column ``j`` from the revival row ``until`` to the
    finding's end row ``b`` sit at the healthy ``mean``: within :data:`ALIVE_MEAN` of
    ``sd`` (fewer than :data:`MIN_FLAT_SAMPLES` finite ones say nothing against it).

    A finding that read dead from its onset and is an offset, a drift or ``other`` is
    either the dead readings and the healthy ones after them taken for one fault (the
    residual's shape is an artefact: the detectors' estimate leant on another faulty
    sensor) or a dead spell followed by a lasting fault of that shape (an offset,
    a drift, a sensor stuck away from zero), which the finding is about. The readings
    after the revival tell them apart: a healthy sensor's average at its healthy mean,
    a lasting offset or stuck level off it by its size, a drift by half its rise. The
    bound lies between the two: the revived readings of the 35 such findings of
    ``sweep_dead_pairs.py`` (8 to 18 s of them) strayed from the mean by at most 0.075
    of the spread, half the bound, and the smallest offsets the project's sweeps inject
    (``sweep_isolation.py --scale 0.5``) are 0.25 of it, 0.1 above it (a 1-sd offset
    after a 4-s dead spell was otherwise lost to a dead finding). Where a short or
    unsettled revival strays further, the finding keeps the residual's shape: a
    revived sensor's readings regenerated, the lesser harm than a real fault lost. A
    gain is not asked: a dead sensor's residual fitted as one is the case the rule was
    made for, and a gain keeps the mean."""
    rest = read_column(values, j, until, b)
    rest = rest[np.isfinite(rest)]
    if rest.size < MIN_FLAT_SAMPLES:
        return True
    return abs(float(np.mean(rest)) - mean) <= ALIVE_MEAN * sd


def reads_zero_for_long(
    values: npt.NDArray[Any], j: int, train: tuple[int, int], sd: float, rate_hz: float
) -> bool:
    """Whether the healthy readings of column ``j`` over the training rows ``train`` read
    frozen at zero (within :data:`FLAT` of ``sd``, no :data:`FROZEN_RUN` readings in a
    row off it) for a long alarm window somewhere: exact zeros are then a healthy state
    of that channel (a coarse converter on a quiet channel, a structure at rest), and
    reading zero from a finding's onset says nothing of its being dead. Vectorised over
    the window (its rows are read once)."""
    least = max(MIN_FLAT_SAMPLES, LONG_FACTOR * default_window(rate_hz))
    seg = read_column(values, j, train[0], train[1])
    if seg.size < least:
        return False
    return _zero_stretches(seg, FLAT * sd, least).size > 0


def zero_channels(
    values: npt.NDArray[Any],
    channels: Sequence[str],
    train: tuple[int, int],
    healthy: Mapping[str, tuple[float, float]],
    rate_hz: float,
) -> tuple[str, ...]:
    """The channels whose healthy readings over the training rows ``train`` read zero for
    long (:func:`reads_zero_for_long`), saved with a model (``SavedModel.zero_at_rest``)
    for the frozen checks of a ``--model`` run, which has no training readings."""
    return tuple(
        c
        for j, c in enumerate(channels)
        if c in healthy
        and healthy[c][1] > 0
        and reads_zero_for_long(values, j, train, healthy[c][1], rate_hz)
    )


def _zero_stretches(seg: npt.NDArray[Any], tol: float, least: int) -> npt.NDArray[np.int64]:
    """Where the stretches of ``seg`` frozen at zero (within ``tol``, no
    :data:`FROZEN_RUN` readings in a row off it) that hold at least ``least`` finite
    readings begin (indices into ``seg``; the first may go on from before it)."""
    moved = np.abs(seg) > tol  # (NaN: False, as in :func:`frozen_until`)
    counts = np.cumsum(np.concatenate(([0], moved.astype(np.int64))))
    starts = np.flatnonzero(counts[FROZEN_RUN:] - counts[:-FROZEN_RUN] == FROZEN_RUN)
    # the stretches between runs off zero (and before the first, after the last), by
    # their finite readings (an outage is not zero)
    begins = np.concatenate(([0], starts + FROZEN_RUN))
    ends = np.concatenate((starts, [seg.size]))
    finite = np.cumsum(np.concatenate(([0], np.isfinite(seg).astype(np.int64))))
    keep = ends > begins
    return begins[keep][finite[ends[keep]] - finite[begins[keep]] >= least]


def dead_unattributed(
    results: Sequence[DetectorResult],
    findings: Sequence[Finding],
    values: npt.NDArray[Any],
    channels: Sequence[str],
    rate_hz: float,
    healthy: Mapping[str, tuple[float, float]],
    train: tuple[int, int] | None = None,
    search_start: int = 0,
    inputs: Collection[str] = (),
    zero_at_rest: Collection[str] | None = None,
) -> tuple[list[Finding], list[str]]:
    """Dead sensors in anomalies the detectors attributed to no sensor
    (``DetectorResult.unattributed``): a finding, and a note, for each channel whose
    readings went dead (:func:`_dead_from_onset`: frozen at its zero for a long alarm
    window) within a long alarm window of such an anomaly's onset, with no finding of
    its own over that stretch. ``healthy`` is each channel's healthy mean and standard
    deviation; ``train`` the training rows when the record has them (a channel whose
    healthy readings read zero for long, :func:`reads_zero_for_long`, is left alone:
    its zeros are no evidence), else ``zero_at_rest`` those channels (:func:`zero_channels`,
    saved with a ``--model``'s model); with neither, no channel is judged (a flow meter
    behind a valve closed for long reads exact zeros, healthy); ``search_start`` the first
    row searched; ``inputs`` the measured inputs (excitation), no sensors under test.

    A dead sensor is found by the residuals it leaves, and they can fail to isolate it:
    on a quiet stretch (the structure at 0.6-0.7 of its healthy spread), a sensor dead
    from 10 to 22 s beside another dead from 16 s left all three detectors an anomaly
    at 9.7-10.2 s they attributed to no sensor ("several sensors at once, or a change of
    the structure"), and no finding of either (8 of the 160 runs of
    ``sweep_dead_pairs.py``, exit 0, its readings left as zeros by ``--corrected``).
    The readings tell what the residuals could not: no alive sensor reads flat at zero
    for that long (the argument of :func:`_dead_from_onset`) while the structure moves
    (:func:`_structure_moves`: at rest a coarse channel reads exact zeros, alive), and
    an anomaly began with it. The finding is the dead sensor's (multiplicative, gain 0)
    from where its readings froze to where they moved again; its evidence names the
    detectors whose anomalies it explains (``unattributed_s``: their onsets, each once)
    and its lead is the one of them nearest its onset that estimates the channel (none
    does: the first detector that ran that does), whose estimate ``--corrected`` puts in
    place of the dead readings. Its confidence here is 1: exact zeros for a long alarm
    window are no chance peak of healthy data (the pipeline then attaches the lead's
    tests, and lowers it as for any finding whose tests point to another type)."""
    window = LONG_FACTOR * default_window(rate_hz)
    least = max(MIN_FLAT_SAMPLES, window)
    n = values.shape[0]
    anomalies = sorted((onset, r.detector) for r in results for onset, _, _ in r.unattributed)
    if not anomalies or (train is None and zero_at_rest is None):
        return [], []
    estimated = {r.detector: {*r.reference, *r.residuals} for r in results}
    zeros: dict[int, bool] = {}
    found: list[Finding] = []
    notes: list[str] = []
    for j, c in enumerate(channels):
        stats = healthy.get(c)
        if c in inputs or stats is None or not stats[1] > 0:
            continue
        sd = stats[1]
        tol = FLAT * sd
        tried: set[int] = set()
        for onset, _ in anomalies:
            row = int(round(onset * rate_hz))
            lo, hi = max(search_start, row - window), min(n, row + window)
            if lo >= hi:
                continue
            seg = read_column(values, j, lo, min(n, hi + least))
            begins = _zero_stretches(seg, tol, least)
            begins = begins[begins < hi - lo]
            if not begins.size:
                continue
            first = lo + int(begins[0])
            head = read_column(values, j, first, first + least)
            level = float(np.median(head[np.isfinite(head)]))
            since = _frozen_since_from(values, j, first, level, tol, search_start, row - window)
            if since is None or since in tried:
                continue  # dead before this anomaly began (or judged already)
            tried.add(since)
            dead = _dead_from_onset(values, j, since, n, sd, rate_hz)
            if dead is None:
                continue
            level, until = dead
            t0, t1 = since / rate_hz, (None if until >= n else until / rate_hz)
            if any(
                g.channel == c
                and g.onset_s <= (n / rate_hz if t1 is None else t1)
                and (g.end_s is None or g.end_s >= t0)
                for g in [*findings, *found]
            ):
                continue
            if j not in zeros:
                zeros[j] = (
                    reads_zero_for_long(values, j, train, sd, rate_hz)
                    if train is not None
                    else c in (zero_at_rest or ())
                )
            if zeros[j]:
                break
            if not _structure_moves(results, values, channels, j, (since, until), inputs):
                continue  # at rest: an alive sensor reads zero too (a coarse converter)
            # the anomalies it explains: those within a long alarm window of its onset
            near = [(t, d) for t, d in anomalies if abs(t - t0) <= window / rate_hz] or [
                (onset, d) for t, d in anomalies if t == onset
            ]
            lead = min(near, key=lambda a: (c not in estimated.get(a[1], ()), abs(a[0] - t0)))[1]
            if c not in estimated.get(lead, ()):
                # none of them estimates it: a detector that does leads (its estimate is
                # what ``--corrected`` puts in place of the dead readings), if one ran
                lead = next((r.detector for r in results if c in estimated[r.detector]), lead)
            seg = read_column(values, j, since, until)
            seg = seg[np.isfinite(seg)]
            spread = float(np.std(seg[np.abs(seg - level) <= tol]))
            f = Finding(
                c,
                FaultType.MULTIPLICATIVE,
                t0,
                t1,
                {"gain": 0.0},
                1.0,
                lead,
                evidence={
                    "detectors": sorted({d for _, d in near}),
                    "tests": {},
                    "frozen": {"level": level, "std_ratio": spread / sd, "was": "unattributed"},
                    "unattributed_s": sorted({t for t, _ in near}),
                },
            )
            found.append(f)
            notes.append(
                f"{c} from {seconds_text(t0)} s"
                + ("" if t1 is None else f" to {seconds_text(t1)} s")
                + f": dead (reads 0): its readings vary by {spread / sd:.2g} of their healthy "
                f"spread (the anomaly {', '.join(sorted({d for _, d in near}))} attributed to "
                f"no sensor at {seconds_text(near[0][0])} s began with it)"
            )
    return found, notes


def _frozen_since_from(
    values: npt.NDArray[Any], j: int, a: int, level: float, tol: float, stop: int, cut: int
) -> int | None:
    """``frozen_since(values, j, a, level, tol, stop)`` when it is at row ``cut`` or later,
    else None, read back no further than that takes: a channel zero for hours was read back
    to its first zero once per anomaly in it (400 anomalies in a 4 h stretch: 7.2 s).
    Searched back to ``cut - 2 * FROZEN_RUN``: a run off the level found there is the one
    the whole search finds; none found, the stretch began before ``cut`` when
    :data:`FROZEN_RUN` readings at the level follow ``FROZEN_RUN - 1`` rows after that
    bound (the stretch then begins there at the latest); else the whole search."""
    bound = max(stop, cut - 2 * FROZEN_RUN)
    since = frozen_since(values, j, a, level, tol, bound)
    if since == bound and bound > stop:
        head = read_column(values, j, bound + FROZEN_RUN - 1, bound + 2 * FROZEN_RUN - 1)
        if np.any(np.abs(head - level) > tol):  # (NaN: at the level, as in frozen_since)
            since = frozen_since(values, j, a, level, tol, stop)
        else:
            return None
    return since if since >= cut else None


def _structure_moves(
    results: Sequence[DetectorResult],
    values: npt.NDArray[Any],
    channels: Sequence[str],
    j: int,
    rows: tuple[int, int],
    inputs: Collection[str] = (),
) -> bool:
    """Whether most of the other channels (not column ``j``, nor the measured
    ``inputs``) move over the rows ``rows``: their readings vary by more than their noise
    there, taken as the largest healthy residual spread a detector has for them (what no
    estimate of them explains: a sensor's noise and more). More than their noise: the
    variance of the readings is at least twice the noise's, the structure's share of it
    at least the noise's own.

    A dead sensor reads zero while the structure moves; at rest, every sensor reads its
    noise alone, and one whose noise lies below its converter's step reads exactly zero,
    alive: the 5-floor building at rest for 30 s, its s2 quantized to exact zeros there,
    was a dead sensor to :func:`dead_unattributed` (its neighbours' readings varied by
    0.24-1.27 of each detector's healthy residual spread of them there; beside two
    sensors dead on a quiet stretch of ``sweep_dead_pairs.py``, by 5.3-10)."""
    judged = moving = 0
    for k, c in enumerate(channels):
        noise = max((r.sigma[c] for r in results if c in r.sigma), default=0.0)
        if k == j or c in inputs or not noise > 0:
            continue
        seg = read_column(values, k, rows[0], rows[1])
        seg = seg[np.isfinite(seg)]
        if seg.size < MIN_FLAT_SAMPLES:
            continue
        judged += 1
        moving += float(np.var(seg)) > 2.0 * noise * noise
    return moving * 2 > judged


FROZEN_SHARE = 0.9
"""Frozen over a fault: at least this share of its readings within :data:`FLAT` of their
median, and of its period before they move (:func:`frozen_notes`): a smaller share is a
fault of another kind that read flat for a while."""

FROZEN_RUN = 5
"""Readings in a row off a frozen level that end (or, backwards, begin) its stretch
(:func:`frozen_until`, :func:`frozen_since`): fewer are a stuck sensor's noise or a dead
one's flicker; a healthy signal leaves a level within a sample."""


def _first_run(moved: npt.NDArray[np.bool_], run: int) -> int | None:
    """The first index that begins ``run`` True values in a row, or None."""
    if moved.size < run:
        return None
    counts = np.cumsum(np.concatenate(([0], moved.astype(np.int64))))
    full = np.flatnonzero(counts[run:] - counts[:-run] == run)
    return int(full[0]) if full.size else None


def frozen_until(
    values: npt.NDArray[Any],
    j: int,
    a: int,
    level: float,
    tol: float,
    stop: int,
    block: int = 1 << 16,
) -> int:
    """Where the frozen stretch of column ``j`` that goes on at row ``a`` ends: the first
    of :data:`FROZEN_RUN` readings in a row more than ``tol`` from ``level``, else
    ``stop``. Missing readings do not end it. Read a block of rows at a time."""
    start, carry = a, np.zeros(0, dtype=bool)
    while start < stop:
        hi = min(stop, start + block)
        seg = read_column(values, j, start, hi)
        moved = np.concatenate((carry, np.abs(seg - level) > tol))  # (NaN: False)
        first = _first_run(moved, FROZEN_RUN)
        if first is not None:
            return start - carry.size + first
        carry = moved[-(FROZEN_RUN - 1) :]
        start = hi
    return stop


def frozen_since(
    values: npt.NDArray[Any],
    j: int,
    a: int,
    level: float,
    tol: float,
    stop: int = 0,
    block: int = 1 << 16,
) -> int:
    """Where the frozen stretch of column ``j`` that goes on at row ``a`` begins: just
    after the last of :data:`FROZEN_RUN` readings in a row more than ``tol`` from
    ``level`` before ``a``, no earlier than ``stop``. Missing readings do not end it (a
    dead sensor's gaps). Read a block of rows at a time, backwards."""
    end, carry = a, np.zeros(0, dtype=bool)
    while end > stop:
        lo = max(stop, end - block)
        seg = read_column(values, j, lo, end)
        moved = np.concatenate((np.abs(seg - level) > tol, carry))  # (NaN: False)
        last = _first_run(moved[::-1], FROZEN_RUN)
        if last is not None:
            k = moved.size - last
            # where :data:`FROZEN_RUN` readings in a row at the level begin: a healthy
            # reading that passed the level just before it froze is not frozen yet
            # (past ``a`` it is frozen)
            after = np.concatenate((moved[k:], np.zeros(FROZEN_RUN, dtype=bool)))
            return lo + k + (_first_run(np.logical_not(after), FROZEN_RUN) or 0)
        carry = moved[: FROZEN_RUN - 1]
        end = lo
    return end


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


def dead_again(
    findings: Sequence[Finding],
    results: Sequence[DetectorResult],
    values: npt.NDArray[Any],
    channels: Sequence[str],
    rate_hz: float,
    healthy: Mapping[str, tuple[float, float]],
    train: tuple[int, int] | None = None,
    zero_at_rest: Collection[str] | None = None,
) -> tuple[list[Finding], list[str]]:
    """The dead spells that follow a revival inside a finding's period as the detectors
    saw it: a finding (multiplicative, gain 0), and a note, for each stretch of the
    channel's readings frozen at its zero for a long alarm window (as
    :func:`_dead_from_onset` asks) between where :func:`frozen_notes` cut a dead finding
    at its readings' revival (evidence ``frozen.until_s``) and the end the detectors saw
    (``alarmed_to_s``; the record's end for none), not already another finding's.

    The detectors merge alarms closer together than their long window (8 windows, 2 s
    at 250 Hz) into one event: Li et al.'s sensor 2, reading zero at 4-6 s and again at
    8-10 s, was one event from 4 to 10 s, and the dead-sensor rule cut it at 6 s, where
    its readings first moved again; the second dead spell was then reported nowhere (no
    finding, no unexplained alarm). What follows a revival is judged from the readings,
    as the first spell was: no alive sensor reads flat at zero for a long alarm window
    while the structure moves (:func:`_structure_moves`), and a channel whose healthy
    readings read zero for long (``train``: :func:`reads_zero_for_long`; with
    ``--model``, ``zero_at_rest``; with neither, not judged) is left alone. Each spell runs
    from where its readings froze to where they moved again (:func:`frozen_until`, past
    the detectors' end if the readings stay dead); it keeps the finding's detector,
    confidence and events (the detectors' one event it came from), and its evidence is
    its own stretch's (:func:`_again_evidence`).

    Its limit: a spell shorter than that long alarm window (1.98 s at 250 Hz), or broken
    by missing readings, is not found, and the rest of the event after the cut is not
    made an unexplained alarm either (an event also goes on past a revival into healthy
    readings, as far as the detectors' windows lag, or into a gain: :func:`revived_gains`;
    no rule tells those apart yet); the first spell's note says where the detectors'
    event ended (``frozen.alarmed_to_s``)."""
    least = max(MIN_FLAT_SAMPLES, LONG_FACTOR * default_window(rate_hz))
    index = {c: j for j, c in enumerate(channels)}
    n = values.shape[0]
    found: list[Finding] = []
    notes: list[str] = []
    for f in findings:
        frozen = f.evidence.get("frozen", {})
        j = index.get(f.channel)
        stats = healthy.get(f.channel)
        if j is None or stats is None or not stats[1] > 0 or "until_s" not in frozen:
            continue
        if abs(float(frozen.get("level", np.inf))) > ZERO * stats[1]:
            continue  # stuck away from zero, not dead: not this rule's
        seen = frozen.get("alarmed_to_s")
        b = n if seen is None else min(n, int(round(seen * rate_hz)))
        a = int(round(frozen["until_s"] * rate_hz))
        tol = FLAT * stats[1]
        if train is not None:
            if reads_zero_for_long(values, j, train, stats[1], rate_hz):
                continue
        elif zero_at_rest is None or f.channel in zero_at_rest:
            continue
        revived = a
        while b - a > least:
            begins = _zero_stretches(read_column(values, j, a, b), tol, least)
            begins = begins[begins > 0]  # (the first goes on from before: the revival's)
            if not begins.size:
                break
            start = a + int(begins[0])
            dead = _dead_from_onset(values, j, start, n, stats[1], rate_hz)
            if dead is None:
                break
            level, until = dead
            t0, t1 = start / rate_hz, (None if until >= n else until / rate_hz)
            taken = any(
                g.channel == f.channel
                and g.onset_s < (n / rate_hz if t1 is None else t1)
                and (g.end_s is None or g.end_s > t0)
                and g is not f
                for g in [*findings, *found]
            )
            if not taken and _structure_moves(results, values, channels, j, (start, until)):
                seg = read_column(values, j, start, until)
                seg = seg[np.isfinite(seg)]
                spread = float(np.std(seg[np.abs(seg - level) <= tol]))
                g = Finding(
                    f.channel,
                    FaultType.MULTIPLICATIVE,
                    t0,
                    t1,
                    {"gain": 0.0},
                    f.confidence,
                    f.detector,
                    evidence=_again_evidence(f, level, spread / stats[1], revived / rate_hz),
                    events=list(f.events),
                )
                found.append(g)
                notes.append(
                    f"{f.channel} from {seconds_text(t0)} s"
                    + ("" if t1 is None else f" to {seconds_text(t1)} s")
                    + f": dead (reads 0) again: its readings vary by {spread / stats[1]:.2g} "
                    "of their healthy spread (after its dead spell from "
                    f"{seconds_text(f.onset_s)} s ended at {seconds_text(revived / rate_hz)} s, "
                    "inside the anomaly the detectors saw as one)"
                )
            if until >= b:
                break
            a = revived = until
    return found, notes


def _again_evidence(
    f: Finding, level: float, std_ratio: float, previous_end_s: float
) -> dict[str, Any]:
    """The evidence of a dead spell again after ``f``'s revival: only what is true of its
    own stretch. The detectors that saw the one event it came from, and its readings:
    ``frozen`` with their ``level``, ``std_ratio`` and ``previous_end_s``, where the dead
    spell before it ended. Not ``f``'s by-detector evidence, test spans or ``frozen.was``:
    those describe ``f``'s onset (the tests are computed for its own stretch afterwards,
    as for every finding: :func:`analyzer.diagnosis.evidence.attach_evidence`)."""
    evidence: dict[str, Any] = {
        "frozen": {"level": level, "std_ratio": std_ratio, "previous_end_s": previous_end_s}
    }
    if "detectors" in f.evidence:
        evidence["detectors"] = list(f.evidence["detectors"])
    return evidence


def revived_gains(
    findings: Sequence[Finding], results: Sequence[DetectorResult], rate_hz: float, n: int
) -> tuple[list[Finding], list[str]]:
    """The gains that go on after a dead spell: a finding each, and a note, for each gain
    that :func:`frozen_notes` made a dead sensor to where its readings moved again
    (evidence ``frozen`` with ``until_s``, ``was`` multiplicative) whose lead detector's
    residual from there to the end it saw is a gain fault of its own.

    A sensor dead from its fault's onset and alive again before the fault's end is a
    dead sensor to its revival (:func:`_dead_from_onset`); the readings after are the
    healthy ones the detectors took for the same fault, or a lasting fault that follows
    the dead spell. An offset, drift or stuck level after it keeps the whole finding
    (:func:`_alive_after`: its readings leave the healthy mean), a gain does not (a gain
    keeps the mean): a sensor dead from 120 to 124 s, then at a gain of 0.5 to the
    record's end, was reported dead to 124.03 s only, its gain lost (0.62 sd of error in
    its corrected readings after 124 s), while all three detectors had seen a gain of
    0.45-0.49 from 120 s to the end. The residual over the revived readings, against the
    detector's fault-free estimate, tells them apart as the detectors classify every
    fault (:func:`~analyzer.diagnosis.classify.classify`, with the channel's healthy
    residual spread) from a long alarm window after the revival (the filters fed the
    dead readings settle first), over at least one more, up to the first finding of
    another sensor under way (the estimate takes the other sensors in: a sensor dead
    120-220 s beside one dead 150-250 s, its finding run on to 249.9 s, read a gain of
    1.13 over its healthy revived readings): a gain explains it, or, over healthy
    readings, nothing does. The gain's finding begins at the revival and ends
    where the detectors saw the fault end; it keeps the detectors' events (the same
    fault, seen from its onset)."""
    from analyzer.diagnosis.classify import MIN_GAIN, classify

    window = max(MIN_FLAT_SAMPLES, LONG_FACTOR * default_window(rate_hz))
    found: list[Finding] = []
    notes: list[str] = []
    for f in findings:
        frozen = f.evidence.get("frozen", {})
        if frozen.get("was") != str(FaultType.MULTIPLICATIVE) or "until_s" not in frozen:
            continue
        lead = next((r for r in results if r.detector == f.detector), None)
        if lead is None or f.channel not in lead.residuals or f.channel not in lead.reference:
            continue
        sigma = lead.sigma.get(f.channel)
        a = int(round(frozen["until_s"] * rate_hz))
        end = frozen.get("alarmed_to_s")
        b = n if end is None else min(n, int(round(end * rate_hz)))
        # judged from a long alarm window after the revival, over one at least: the
        # filters fed the dead readings settle first (gains of 1.05-1.16 over the first
        # 0.4-3 s of healthy revived readings, where the detectors' fault ran on)
        c = a + window
        # and only while no other sensor's finding is under way: the estimate takes the
        # other sensors in (a dead one's estimate of a healthy one is off; law 0)
        # (nor past the next finding of its own: a second dead spell, :func:`dead_again`)
        stop = b
        for g in findings:
            if g.channel != f.channel and (g.end_s is None or g.end_s * rate_hz > c):
                stop = min(stop, max(a, int(round(g.onset_s * rate_hz))))
            elif g.channel == f.channel and g.onset_s * rate_hz >= a and g is not f:
                stop = min(stop, int(round(g.onset_s * rate_hz)))
        if stop - c < window or sigma is None or not sigma > 0:
            continue
        # (views: the classification reads them a piece at a time)
        got = classify(
            lead.residuals[f.channel][c:stop], lead.reference[f.channel][c:stop], sigma, rate_hz
        )
        gain = got.magnitude.get("gain")
        if got.type is not FaultType.MULTIPLICATIVE or gain is None or abs(gain) < MIN_GAIN:
            continue
        g = Finding(
            f.channel,
            FaultType.MULTIPLICATIVE,
            a / rate_hz,
            None if b >= n else b / rate_hz,
            {"gain": float(gain)},
            f.confidence,
            f.detector,
            evidence={k: v for k, v in f.evidence.items() if k not in ("frozen",)}
            | {"revived_s": [f.onset_s, a / rate_hz]},
            events=list(f.events),
        )
        found.append(g)
        notes.append(
            f"{f.channel} from {seconds_text(g.onset_s)} s"
            + ("" if g.end_s is None else f" to {seconds_text(g.end_s)} s")
            + f": a gain of {gain:.3g} after its dead spell from {seconds_text(f.onset_s)} s (the "
            f"residual of {f.detector} over its readings alive again)"
        )
    return found, notes
