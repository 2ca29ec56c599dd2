"""The common path from one channel's residual to events: calibrate on the healthy
window, detect faulty intervals, classify each. Every detector whose residual speaks
about one channel uses this, so thresholds and fault types mean the same everywhere."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.detectors.base import Event
from analyzer.diagnosis.changes import (
    STAT_PIECE,
    AlarmRuns,
    Calibration,
    Interval,
    SumsIndex,
    alarm_statistic,
    detect,
    detection_confidence,
    intervals,
)
from analyzer.diagnosis.classify import (
    Classification,
    ReferenceSlope,
    classify,
    reference_slope,
)
from analyzer.diagnosis.spread import event_intervals
from analyzer.paging import buffer, release
from analyzer.timeutil import seconds_text
from analyzer.types import FaultType

FloatArray = npt.NDArray[np.float64]


def events_from_residual(
    channel: str,
    residual: FloatArray,
    reference: FloatArray | None,
    cal: Calibration,
    rate_hz: float,
    detector: str,
    *,
    search_start: int = 0,
    healthy_start: int | None = None,
    healthy_stop: int | None = None,
    before_onset: bool = False,
    tau_corr: float = 1.0,
    evidence: dict[str, Any] | None = None,
    scratch: Path | None = None,
    split: bool = False,
    notes: list[str] | None = None,
    until: Sequence[int] = (),
) -> list[Event]:
    """Events on ``channel`` from its residual (measured - estimated). ``split``: a fault
    that changes inside its stretch (another level, another type) is two events, the
    second from the change (:func:`diagnose_interval`'s ``changes``; for a residual
    that follows a sensor's fault at once: the detection filter's, the observers'; not
    a windowed one, whose ramp at each edge of a fault reads as a change). ``scratch``: a
    directory for the memory-mapped buffer of a long fault's corrected residual
    (:func:`diagnose_interval`). ``healthy_start``: where the healthy window that ends at
    ``search_start`` begins; given, the residual's healthy share of the reference
    (:class:`~analyzer.diagnosis.classify.ReferenceSlope`) is measured over the window's
    second half and left out of each fault's shape. ``before_onset``: without a healthy
    window in the record (a model fitted on another archive), that share is measured on
    the residual before each fault's onset instead (:func:`slope_before`). ``healthy_stop``:
    the healthy window's end where the search starts later (default ``search_start``).

    An alarm whose residual has fewer than three finite samples (over a gap, or over the
    filters' warm-up after one) weighs no fault shape
    (:attr:`~analyzer.diagnosis.classify.Classification.weighed`): it is no event, and
    where ``notes`` is given :func:`unweighed_note` says so there (one note for the
    channel's such alarms), as the AR bank notes its own.

    ``until``: where other sensors' faults begin (samples, ascending; a caller that found
    them on residuals of their own): a fault's shape is fitted up to the first of them at
    least a part's length after its onset (:func:`first_bound`), whose fault's trace in
    this residual would bend it (an offset of 2 sd on another floor from 150 s flattened
    a drift's line from 100 s and traced it back to 89.4 s)."""
    out: list[Event] = []
    unweighed: list[float] = []  # onsets (s) of alarms too thin to weigh
    n = residual.shape[0]
    slope = None
    stop = search_start if healthy_stop is None else min(healthy_stop, search_start)
    if reference is not None and healthy_start is not None and healthy_start < stop:
        # its second half: the filters settle from their initial state in the first (an
        # observer starting at zero under a level of 1000 gave a slope of -0.98)
        settled = (healthy_start + stop) // 2
        slope = reference_slope(residual[settled:stop], reference[settled:stop])
    covered = search_start
    # the search computes the alarm statistic a piece at a time (its memory does not grow
    # with the record); each fault's end is searched on the statistic of a stretch from
    # its onset, grown as far as the answer needs (diagnose_interval)
    # the detection's running sums at points along the residual: each end search resumes
    # from them instead of summing the residual from its first sample
    index = SumsIndex()
    for first in detect(residual, cal, search_start=search_start, index=index):
        if first.onset < covered:
            continue  # inside a fault already extended over this stretch
        # the fault, and where it changes, each change the start of a fault of its own
        # (an offset that steps to another level, an offset followed by a gain)
        changes: list[int] = []
        # (measured before the fault: after a change, before the part is the fault's
        # own first part)
        if before_onset and slope is None and reference is not None:
            shape_slope = slope_before(residual, reference, search_start, first.onset, cal, rate_hz)
        else:
            shape_slope = slope
        iv: Interval | None = first
        while iv is not None:
            found = len(changes)
            cls, end = diagnose_interval(
                residual,
                reference,
                cal,
                iv,
                rate_hz,
                tau_corr,
                scratch=scratch,
                index=index,
                slope=shape_slope,
                changes=changes if split else None,
            )
            covered = n if end is None else end
            bound = first_bound(until, iv.onset, cal, rate_hz)
            if bound is not None and bound < covered and cls.type is not FaultType.OTHER:
                cls = _before_other(
                    residual,
                    reference,
                    cal,
                    (iv.onset, bound, covered),
                    cls,
                    rate_hz,
                    tau_corr,
                    shape_slope,
                )
            onset_s, factor, extra = bounded_onset(iv.onset, cls, rate_hz, search_start)
            if iv is not first:  # (its onset is the change's: no earlier)
                onset_s, extra = iv.onset / rate_hz, {**extra, "changed_at_s": iv.onset / rate_hz}
            ev = {
                "first_alarm_s": iv.first_alarm / rate_hz,
                "peak_over_threshold": iv.peak,
                "p_value": iv.p_value,
                "type_weights": cls.weights,
                "explained": cls.explained,
                "noise_scale": cls.noise_scale,
                **extra,
            }
            if evidence:
                ev.update(evidence)
            if not cls.weighed:  # too few finite residual samples to tell any fault
                unweighed.append(iv.onset / rate_hz)
            else:
                out.append(
                    Event(
                        channel=channel,
                        onset_s=onset_s,
                        end_s=None if end is None else end / rate_hz,
                        type=cls.type,
                        magnitude=cls.magnitude,
                        confidence=float(detection_confidence(iv) * cls.confidence * factor),
                        detector=detector,
                        evidence=ev,
                        intervals=event_intervals(
                            cls,
                            iv.onset_range if iv is first else None,
                            onset_s,
                            extra,
                            rate_hz,
                            cal.mean_variance(),
                        ),
                    )
                )
            iv = None
            if len(changes) > found:
                at = changes[-1]
                # (a shape refitted past the alarms may change after they ended: the
                # rest is then searched for its end from the change on)
                end = first.end if first.end is not None and first.end > at else None
                last = max(at, first.last_alarm)
                iv = replace(first, onset=at, end=end, first_alarm=at, last_alarm=last)
    if unweighed and notes is not None:
        notes.append(unweighed_note(channel, unweighed))
    return out


UNWEIGHED_LISTED = 5
"""Onsets of a channel's unweighed alarms named one by one in its note; the rest counted."""


def unweighed_note(channel: str, onsets_s: Sequence[float]) -> str:
    """The note on alarms of ``channel``'s residual that no fault shape was weighed on
    (:func:`events_from_residual`): where they began, and why they are no finding. An
    alarm over a gap (or over the filters' warm-up after one) has fewer than three finite
    residual samples, which say nothing of a sensor's fault (the realdata audit: such an
    alarm was a finding of confidence 0 and offset 0, and exit 1 for it)."""
    listed = ", ".join(f"{seconds_text(t)} s" for t in onsets_s[:UNWEIGHED_LISTED])
    more = len(onsets_s) - UNWEIGHED_LISTED
    at = f"{listed} and {more} more" if more > 0 else listed
    alarms = "alarm" if len(onsets_s) == 1 else f"{len(onsets_s)} alarms"
    return (
        f"{alarms} on {channel} at {at} not weighed: fewer than 3 finite residual "
        "samples in the alarm (over a gap in the data, or the filters' warm-up after "
        "one), too few to fit any fault shape; not reported as a sensor fault"
    )


def _before_other(
    residual: FloatArray,
    reference: FloatArray | None,
    cal: Calibration,
    span: tuple[int, int, int],
    cls: Classification,
    rate_hz: float,
    tau_corr: float,
    slope: ReferenceSlope | None,
) -> Classification:
    """``cls``, the shape fitted on a fault's stretch ``onset .. stop`` (``span``: onset,
    bound, stop), or the shape fitted before ``bound``, where another sensor's fault
    begins (``events_from_residual``'s ``until``), when that part has the same type (its
    size and onset are what the other fault's trace bends) and what it leaves steps at
    the bound: the other fault's trace, a level the long alarm window
    tells (:func:`_stepped`). Without a step there the bound was no other fault's (a
    fault's own trace in another filter's residual, say) and the whole stretch's fit,
    the longer one, stands (a single drift fitted on its first part only was traced
    4.9 s early). The end stays the one the whole stretch gave
    (:func:`diagnose_interval`)."""
    onset, bound, _ = span
    seg_ref = None if reference is None else np.asarray(reference[onset:bound], dtype=np.float64)
    part = classify(
        np.asarray(residual[onset:bound], dtype=np.float64),
        seg_ref,
        cal.std,
        rate_hz,
        tau_corr,
        shift=cal.mean,
        slope=slope,
    )
    if part.type is not cls.type or not part.weighed:
        # (the part read as another type: a lasting offset's first 35 s read as a drift
        # after a 10x burst, sweep_eov.py --fault; a fault that changes type is split
        # by diagnose_interval's changes, not here)
        return cls
    return part if _stepped(residual, reference, cal, span, part, rate_hz, slope) else cls


def _stepped(
    residual: FloatArray,
    reference: FloatArray | None,
    cal: Calibration,
    span: tuple[int, int, int],
    part: Classification,
    rate_hz: float,
    slope: ReferenceSlope | None,
) -> bool:
    """Whether what ``part``'s shape (fitted on ``onset .. bound``) leaves of the residual
    steps at ``bound``: its mean over as long a stretch after the bound as before it
    (at most to ``stop``, and :data:`STEP_S` each side: the step is the bound's, and a
    fault that lasts for days is not read whole) differs from its mean before by the long
    alarm window's threshold (the change :func:`_change_point` tells), or its share of
    the reference does, times the reference's RMS after the bound (another sensor's
    gain)."""
    onset, bound, stop = span
    length = min(bound - onset, stop - bound, max(cal.long_window, int(STEP_S * rate_hz)))
    if length < cal.long_window:
        return False
    lo, hi = bound - length, bound + length
    ref = None if reference is None else np.asarray(reference[lo:hi], dtype=np.float64)
    shape = part.fault_signal((np.arange(lo, hi) - onset) / rate_hz, ref)
    if shape is None:
        return False
    left = np.asarray(residual[lo:hi], dtype=np.float64) - cal.mean - shape
    if slope is not None and slope.slope and ref is not None:
        left = left - slope.slope * (ref - slope.level)
    before, after = left[:length], left[length:]
    if not (np.isfinite(before).any() and np.isfinite(after).any()):
        return False
    threshold = cal.z_crit * cal.mean_sd[-1] * cal.std
    if abs(float(np.nanmean(after) - np.nanmean(before))) >= threshold:
        return True
    if ref is None:
        return False
    # another sensor's gain leaves a trace that follows the response, with no mean: a
    # step of what the leftover carries of the reference, times the reference's size
    # after the bound (the review: a gain beside another sensor's gain was fitted 1.60
    # for 1.50 over the whole stretch)
    share = [_share(x, y) for x, y in ((before, ref[:length]), (after, ref[length:]))]
    if share[0] is None or share[1] is None:
        return False
    after_ref = ref[length:]
    size = float(np.sqrt(np.nanmean(after_ref * after_ref)))
    return abs(share[1] - share[0]) * size >= threshold


def _share(x: FloatArray, reference: FloatArray) -> float | None:
    """The least-squares share of ``reference`` in ``x`` (through the origin, over their
    finite samples); None without any."""
    ok = np.isfinite(x) & np.isfinite(reference)
    den = float(np.dot(reference[ok], reference[ok]))
    return float(np.dot(x[ok], reference[ok])) / den if den > 0.0 else None


def first_bound(until: Sequence[int], onset: int, cal: Calibration, rate_hz: float) -> int | None:
    """The first of ``until`` (ascending samples) at least a fault's part's length after
    ``onset`` (as long as a part before a change must be: :data:`CHANGE_MIN_S`, at least a
    long alarm window): where a fault's shape fit stops; None when there is none."""
    least = onset + max(cal.long_window, int(CHANGE_MIN_S * rate_hz))
    return next((int(b) for b in until if b >= least), None)


def _confined(
    r: FloatArray, cls: Classification, cal: Calibration, iv: Interval
) -> tuple[Classification, int | None]:
    """An ``other`` fault's end where its residual last left the healthy band, when it
    is quiet after that (the fault ended there): the alarms' end otherwise.

    The alarm statistic averages over windows (a quarter of a second and eight times
    that): a single-sample spike keeps the long window's mean square over its threshold
    long after the spike, so a 50-sd spike at 15.23 s was a fault to 16.54 s, its rms
    (5.4) that of 1.3 s of mostly healthy residual. The last sample past the per-sample
    threshold (the statistics' own z quantile) ends the fault when no short window of
    the residual after it alarms; an erratic stretch whose last large sample comes before
    its end (a noise burst) keeps the alarms' end. The magnitude is then the confined
    stretch's, from its first sample past the band: its mean offset and rms."""
    if iv.end is None or iv.end - iv.onset < 2:
        return cls, iv.end
    z = cal.standardize(r[iv.onset : iv.end])
    over = np.flatnonzero(np.abs(z) > cal.z_crit)
    if over.shape[0] == 0:
        return cls, iv.end
    end = int(over[-1]) + 1
    tail = z[end:]
    w = cal.window
    if tail.shape[0] >= w:
        # the short window's statistics over the rest, as the search computes them
        c1 = np.cumsum(np.concatenate(([0.0], np.nan_to_num(tail))))
        c2 = np.cumsum(np.concatenate(([0.0], np.nan_to_num(tail * tail))))
        m = (c1[w:] - c1[:-w]) / w
        q = np.log(np.maximum((c2[w:] - c2[:-w]) / w, 1e-300))
        if np.max(np.abs(m)) > cal.mean_threshold(0) or np.max(q) > cal.logq_threshold(0):
            return cls, iv.end
    elif tail.shape[0] > 0 and float(np.mean(tail * tail)) > np.exp(cal.logq_threshold(0)):
        return cls, iv.end
    if iv.onset + end == iv.end:
        return cls, iv.end
    # from its first sample past the band (the change point may precede it by a sample
    # or two of healthy residual, which would dilute a spike's size)
    seg = r[iv.onset + int(over[0]) : iv.onset + end] - cal.mean
    seg = seg[np.isfinite(seg)]
    magnitude = {"offset": float(np.mean(seg)), "rms": float(np.sqrt(np.mean(seg * seg)))}
    return replace(cls, magnitude=magnitude), iv.onset + end


EARLY_ONSET_FACTOR = 0.5
"""Confidence factor of a fault whose fitted shape (a drift traced back to zero) starts
inside the healthy window: the trend was already there when the data was called healthy,
so it may be the structure's own slow change rather than the sensor's."""


def bounded_onset(
    onset: int, cls: Classification, rate_hz: float, search_start: int
) -> tuple[float, float, dict[str, Any]]:
    """A fault's onset in seconds: the alarm's change point moved by the fitted shape's
    shift (a drift traced back to where it was zero), but never before ``search_start``
    (the end of the healthy window, which the analysis takes as fault-free: a shape
    traced back before it starts there). Returns the onset, a confidence factor and the
    evidence of a shape traced back into the healthy window."""
    traced = onset / rate_hz + cls.onset_shift_s
    bound = search_start / rate_hz
    if traced >= bound:
        return float(max(0.0, traced)), 1.0, {}
    return bound, EARLY_ONSET_FACTOR, {"traced_onset_s": float(traced), "starts_in_training": True}


SLOPE_WINDOWS = 4
"""Long alarm windows of searched residual a fault's onset needs before it for its
healthy slope to be measured there (:func:`slope_before`)."""
SLOPE_SECONDS = 600.0
"""At most this much of the residual before a fault's onset is read for its slope."""


def slope_before(
    residual: FloatArray,
    reference: FloatArray,
    search_start: int,
    onset: int,
    cal: Calibration,
    rate_hz: float,
) -> ReferenceSlope | None:
    """The residual's share of its reference (:func:`~analyzer.diagnosis.classify.
    reference_slope`) over the searched stretch before ``onset``, where no alarm rang: its
    last :data:`SLOPE_SECONDS` at most, none when it is shorter than
    :data:`SLOPE_WINDOWS` long alarm windows. With a model fitted on another archive
    (``--model``) the record has no healthy window of its own: an offset on a reading at
    1000 was a gain of 1.002 there still."""
    need = SLOPE_WINDOWS * cal.long_window
    if onset - search_start < need:
        return None
    lo = max(search_start, onset - max(need, int(SLOPE_SECONDS * rate_hz)))
    return reference_slope(residual[lo:onset], reference[lo:onset])


def diagnose_interval(
    residual: FloatArray,
    reference: FloatArray | None,
    cal: Calibration,
    iv: Interval,
    rate_hz: float,
    tau_corr: float = 1.0,
    classify_until: int | None = None,
    *,
    statistic: FloatArray | None = None,
    scratch: Path | None = None,
    index: SumsIndex | None = None,
    slope: ReferenceSlope | None = None,
    changes: list[int] | None = None,
) -> tuple[Classification, int | None]:
    """Classify the fault that starts at ``iv`` and find where it really ends.

    The alarms of the raw residual can stop while a fault goes on: a gain fault is
    invisible while the structure is quiet. So the fitted fault shape is extended past the
    alarms and subtracted; the fault ends where that corrected residual alarms while the
    raw residual is healthy again (the sensor reads right and the correction is now
    wrong). Faults of type ``other`` have no shape to extend and end with their alarms.

    ``classify_until`` bounds the stretch the shape is fitted on (a caller that knows
    another fault begins there, which would blur this one's shape). ``statistic``: the
    residual's :func:`~analyzer.diagnosis.changes.alarm_statistic` (``raw=True``) from
    ``iv.onset`` on at least, when the caller has it (computed from there otherwise).

    Both residuals' alarms are searched on a stretch from the onset that grows only as
    far as the answer needs (:class:`_Intervals`; a fault's end is mostly seconds after
    its onset), with the answer of the search over the whole record. The corrected
    residual is kept from the first sample the search reads to as far as it has grown:
    in memory, or past :data:`MAPPED_CORRECTION` samples memory-mapped in ``scratch``
    when given (a fault that lasts to the end of a long archive). ``index``: the running
    sums of a pass of :func:`~analyzer.diagnosis.changes.detect` over the same residual
    with the same ``cal``, from which both searches start (instead of summing the
    residual from its first sample; the same sums bit for bit). ``slope``: the healthy
    residual's share of the reference, left out of the shape's fit (:func:`classify`).

    ``changes``: where given, a fault that changes inside its stretch (another level, or
    another type: an offset of 3 sd that drops to 1 sd, an offset followed by a gain) is
    classified up to the change, which is appended to the list and is the end returned:
    the caller diagnoses the rest as a fault of its own from there
    (:func:`_change_point`). Without it, one shape is fitted over the whole stretch (an
    average level, or a staircase read as a drift)."""
    n = residual.shape[0]
    limit = n if classify_until is None else max(iv.onset + 3, classify_until)
    stop = min(n if iv.end is None else iv.end, limit)
    r = np.asarray(residual, dtype=np.float64)
    ref = None if reference is None else np.asarray(reference, dtype=np.float64)

    def fit(stop: int) -> Classification:
        seg_ref = None if ref is None else ref[iv.onset : stop]
        # the stretch as it lies (a view): classify reads it a piece at a time
        return classify(
            r[iv.onset : stop], seg_ref, cal.std, rate_hz, tau_corr, shift=cal.mean, slope=slope
        )

    def has_shape(cls: Classification) -> bool:
        # the shape is elementwise in tau and the reference: a stretch of it is the whole
        # record's shape over that stretch, bit for bit
        empty = None if ref is None else ref[iv.onset : iv.onset]
        return cls.fault_signal(np.arange(0) / rate_hz, empty) is not None

    def corrected(cls: Classification) -> _Intervals:
        """The alarms of the residual with ``cls``'s shape undone from the onset on."""
        search = iv.onset + cal.window
        record = _Corrected(r, ref, cls, iv.onset, rate_hz, cal, search, scratch, index)
        return _Intervals(record, n, cal, search)

    def changed(cls: Classification, fitted_to: int) -> tuple[Classification, int] | None:
        """Where one shape does not hold over the stretch it was fitted on: the fault's
        change inside it, and the shape before it, where that shape explains its part
        to at least :data:`LEAD_EXPLAINED` (as a fault's leading part must,
        :func:`_shaped_lead`)."""
        if changes is None or len(changes) >= MAX_CHANGES:
            return None
        # the level change of what the shape leaves: a gain's residual follows the
        # reference's own slow swings, which its shape takes in
        span = slice(iv.onset, fitted_to)
        seg_ref = None if ref is None else ref[span]
        shape = cls.fault_signal(np.arange(fitted_to - iv.onset) / rate_hz, seg_ref)
        if shape is None:
            return None
        left = r[span] - cal.mean - shape
        if slope is not None and slope.slope and seg_ref is not None:
            left = left - slope.slope * (seg_ref - slope.level)
        at = _change_point(left, cal, max(cal.long_window, int(CHANGE_MIN_S * rate_hz)))
        if at is None:
            return None
        at += iv.onset
        before = fit(at)
        if before.type is FaultType.OTHER or before.explained < LEAD_EXPLAINED:
            return None  # (no shape that stands for the part before it either)
        changes.append(at)
        return before, at

    cls = fit(stop)
    if cls.type is FaultType.OTHER and (
        lead := _shaped_lead(fit, iv.onset, stop, cal)
        or (changes is not None and _lead_to_change(fit, r, iv.onset, stop, cal, rate_hz))
    ):
        # the fault's beginning has a shape that a later change blurs: that shape, and
        # no refit past the stretch it was found on
        cls, limit = lead
    if not has_shape(cls):
        return _confined(r, cls, cal, iv)
    end: int | None = None
    raw_alarms = _Intervals(r, n, cal, iv.onset, statistic, index)
    corrected_alarms = corrected(cls)
    # the onsets of detect's intervals strictly increase: only the first corrected one
    # can begin before iv.end
    if iv.end is not None and corrected_alarms.onset(0, iv.end) is not None:
        # the shape does not hold even while the raw residual alarms (random data read as
        # "dead sensor plus noise", say): it cannot be trusted past the alarms either;
        # unless the fault changed in between (an offset, then a gain)
        return changed(cls, stop) or (cls, iv.end)
    fitted_to, refits = stop, 0
    tried = False  # (a change is looked for once per shape, where it fails inside its stretch)
    i = 0
    while (onset := corrected_alarms.onset(i, n)) is not None:
        lo, hi = onset + cal.window, onset + cal.long_window
        j = 0
        while raw_alarms.onset(j, hi) is not None and not raw_alarms.ends_after(j, lo):
            j += 1
        if raw_alarms.onset(j, hi) is None:  # no raw interval overlaps [lo, hi): recovered
            end = onset
            break
        # The fault still shows in the raw residual where its shape fails: a shape fitted
        # on too short a stretch (a slow drift's first alarms, a few seconds of a ramp:
        # its rate can come out with the wrong sign, and the corrected residual then
        # alarms only long after the fault ended). Refitted on everything up to here,
        # which is still the fault, and searched again; each refit on a stretch at least
        # REFIT_GROWTH times the last, so there are few.
        # A refit with no shape (type other over the longer stretch) is not taken, and
        # the search goes on with the last shape.
        grown = min(hi, limit)
        if refits < MAX_REFITS and grown - iv.onset >= REFIT_GROWTH * (fitted_to - iv.onset):
            fitted_to, refits = grown, refits + 1
            refit = fit(fitted_to)
            if not has_shape(refit):
                refits = MAX_REFITS
            else:
                cls = refit
                corrected_alarms = corrected(cls)
                tried = False
                i = 0
                continue
        if not tried and onset < fitted_to - cal.long_window:
            # the shape, fitted on everything up to fitted_to, fails inside it while the
            # fault goes on: one shape cannot hold a fault that changed
            tried = True
            if (split := changed(cls, fitted_to)) is not None:
                return split
        i += 1
    if (
        cls.type is FaultType.MULTIPLICATIVE
        and ref is not None
        and iv.end is not None
        and end is None
    ):
        # a gain the corrected residual's alarms do not see end: where the residual after
        # the raw alarms is health's, not the gain's (_gain_ended). Only where no end
        # was found: run past a found one, it cut a gain on s2 at 180.9 s beside an
        # offset on s5 from 150 s in the observers' residual (sweep_two_faults
        # gain-offset seed 14), whose end the other rules had right
        ended = _gain_ended(r, ref, cls, cal, slope, iv.end, n, tau_corr)
        if ended is not None:
            end = ended
    if end != iv.end:
        # refit the shape over the whole fault period
        cls = fit(min(n if end is None else end, limit))
    return cls, end


def _gain_ended(
    r: FloatArray,
    ref: FloatArray,
    cls: Classification,
    cal: Calibration,
    slope: ReferenceSlope | None,
    start: int,
    stop: int,
    tau_corr: float = 1.0,
) -> int | None:
    """Where a gain fault ``cls`` (multiplicative) ended on ``[start, stop)``, a stretch
    after its raw residual's alarms ended (``start``): the first sample from which the
    residual is decisively health's rather than the gain's; None when it is not (the
    fault goes on, in a lull of the structure, say).

    The corrected residual's alarms (:func:`diagnose_interval`) see a gain's end only where
    undoing the gain makes the healthy residual much noisier or much quieter than in
    health: after the end it is ``(e - (a - 1) y) / a``, of variance ``(1 + (a - 1)^2
    V / s2) / a^2`` times health's (``V`` the reference's variance), which a two-second
    window's log mean square sees only beyond about 2.4 times health or below 0.4 times
    it at the default false-alarm rate. A gain of 1.5 on ``s0`` from 100 to 200 s of the
    6-floor building (seed 6, ``V / s2`` 4.4-6.3 for the three detectors), fitted as 1.24
    and 1.23 by the bank and the observers on its first seconds, left 0.72 and 0.75 of
    health's variance after 200 s (0.79-0.98 undone by the true 1.5), in neither tail
    (a two-sided window test would not see it either), and ran to the record's end.

    The test here weighs both hypotheses sample by sample, as the classifier does:
    health, ``f ~ N(0, s2)``, against the gain's model, ``f ~ N((a - 1) y, k^2 s2)``,
    ``f`` the residual less its healthy mean and healthy share of the reference and ``k``
    the fit's noise scale (:attr:`~analyzer.diagnosis.classify.Classification.
    noise_scale`), for a gain above 1 at most the gain (its own model: a fit with a
    noise level of its own, fitted on a short first stretch, took 1.5-2.5 for a gain of
    1.5, and with 2.5 the sum fell inside the fault, in a lull of the structure, where
    the gain's scaled noise alone tells it: a true gain ended at 150-193 s of 100-300 s
    in 6 of 6 seeds; capped, its expected step there is ``(a^2 - 1) / 2 - log a > 0``
    whatever the noise above ``a^2``); each sample's log-likelihood ratio counts as
    ``1 / tau`` of one (coloured residuals; ``tau`` the longer of ``tau_corr`` and the
    correlation time the calibration's window-mean spreads imply, ``w sd_w^2``). Its
    cumulative sum from
    ``start`` rises while the gain goes on (in a lull too: the gain's scaled noise) and
    falls once the sensor reads right; the end is the sample after its maximum, taken
    when the sum has fallen from it by ``log(1 / false_alarm_rate)`` (Page's CUSUM, with
    the detector's own error rate as Wald's bound: 13.8 at the default 1e-6), raised by
    the log of the number of ends the sum could have fallen from before its maximum,
    ``1 + (max - start) / tau`` (each is a test at that rate: without it a fault's chance
    of a false end grew with its length; a gain of 0.75 on s3 of the 5-floor building
    from 30 min to the end of a 4-h record at 200 Hz was ended at 8286 s by a fall of
    17.8 from a maximum, against 15.4, where over the first hour the largest was 12.8;
    the sensor's neighbours were then reported with the gain's inverse, 1.32 on s4). Read
    :data:`~analyzer.diagnosis.changes.STAT_PIECE` samples at a time, and only as far as
    the answer needs."""
    gain = float(cls.params.get("gain", 1.0))
    k = min(cls.noise_scale, abs(gain)) if abs(gain) > 1.0 else cls.noise_scale
    k2 = k * k
    s2 = cal.std**2
    if not (k2 > 0.0 and s2 > 0.0 and np.isfinite(gain)):
        return None
    bound = float(np.log(1.0 / cal.false_alarm_rate))
    # (the caller's correlation time, or the one the calibration's window-mean spreads
    # imply, ``w sd_w^2``, if longer: the AR bank passes none, and its residual's
    # is 3-5 samples)
    spreads = zip(cal.windows, cal.mean_sd, strict=True)
    tau = max(tau_corr, 1.0, *(w * sd * sd for w, sd in spreads))
    weight = 1.0 / tau
    total, top, at = 0.0, 0.0, start  # the sum so far, its maximum and where it was
    for lo in range(start, stop, STAT_PIECE):
        hi = min(stop, lo + STAT_PIECE)
        y = np.asarray(ref[lo:hi], dtype=np.float64)
        f = np.asarray(r[lo:hi], dtype=np.float64) - cal.mean
        if slope is not None and slope.slope:
            f = f - slope.slope * (y - slope.level)
        llr = 0.5 * (f * f - (f - (gain - 1.0) * y) ** 2 / k2) / s2 - 0.5 * np.log(k2)
        llr = np.where(np.isfinite(llr), llr * weight, 0.0)  # a gap says nothing
        cum = total + np.cumsum(llr)
        peak = np.maximum(np.maximum.accumulate(cum), top)
        # where each sample's running maximum lies (the end it would give): its first
        # sample, a strictly new maximum, as the maximum carried between pieces (argmax;
        # across a gap the sum is flat, and a tie kept to its last sample moved an end
        # at a gap's start to its far side)
        rows = np.arange(lo + 1, hi + 1)
        before = np.concatenate(([top], peak[:-1]))
        ends = np.maximum.accumulate(np.where(cum > before, rows, 0))
        ends = np.maximum(ends, at)
        # each earlier sample is an end the sum may fall from: their count is the bound's
        # multiplicity, so a fault's length does not raise its chance of a false end
        fallen = np.flatnonzero(peak - cum > bound + np.log1p(weight * (ends - start)))
        if fallen.size:
            return int(ends[int(fallen[0])])
        if peak[-1] > top:
            top, at = float(peak[-1]), lo + int(np.argmax(cum)) + 1
        total = float(cum[-1])
    return None


MAX_CHANGES = 4
"""Changes of one fault found at most (:func:`diagnose_interval`'s ``changes``)."""


CHANGE_MIN_S = 30.0
"""Seconds a fault's part before or after a change must last at least: a detector's
residual may ring after a fault's onset (the seed's "pulse, then a constant offset"),
which is no change of the fault: the observers' 2.4-s pulse of a 0.5-sd offset was
reported as its own fault, and led the finding; under a burst of 3 to 10 times the
excitation the detection filter's rang for 5 to 9 s, and an offset from 365 s was a
drift to 373.8 s and an offset from there (12 fewer right of 325 in ``sweep_eov.py
--fault`` with 10 s)."""

STEP_S = 2 * CHANGE_MIN_S
"""Seconds each side of a bound over which :func:`_stepped` compares what a part's shape
leaves (at most: the part's length and the stretch's rest bound it too)."""


def _change_point(x: FloatArray, cal: Calibration, margin: int) -> int | None:
    """The sample of ``x`` (a stretch of residual less its healthy mean and the fault's
    fitted shape) where its level changes most: the split that
    maximizes the two parts' weighted squared mean difference (the CUSUM change point),
    at least ``margin`` samples from either end; None when the stretch is too short, when
    that split is within a long window of the range's edges (a trend, no step), or the
    two parts' means differ by less than the long alarm window's threshold (a level
    the detection would not tell from the other: the same offset, read in two pieces)."""
    if x.shape[0] <= 2 * margin:
        return None
    ok = np.isfinite(x)
    sums = np.cumsum(np.where(ok, x, 0.0))
    counts = np.cumsum(ok).astype(np.float64)
    total, k = sums[-1], counts[-1]
    a, b = sums[margin - 1 : -margin], counts[margin - 1 : -margin]
    valid = (b > 0) & (b < k)
    if not valid.any():
        return None
    b_safe = np.where(valid, b, 1.0)
    rest = np.where(valid, k - b, 1.0)
    gap = a / b_safe - (total - a) / rest
    score = np.where(valid, b_safe * rest / k * gap * gap, -1.0)
    best = int(np.argmax(score))
    if min(best, score.shape[0] - 1 - best) < cal.long_window:
        # the largest change at the edge of where one may be: a level that drifts on
        # through the stretch (a residual ringing down after a burst of load), no step
        return None
    # a change the long alarm window sees: its mean moves by the window's threshold
    if abs(gap[best]) < cal.z_crit * cal.mean_sd[-1] * cal.std:
        return None
    return margin + best


def _shaped_lead(
    fit: Callable[[int], Classification], onset: int, stop: int, cal: Calibration
) -> tuple[Classification, int] | None:
    """The shape of a fault's leading part, where its whole stretch ``onset .. stop``
    fits none (type ``other``): the longest of the stretch's first halves, quarters...
    (down to :data:`LEAD_WINDOWS` long alarm windows) that a shape explains to at least
    :data:`LEAD_EXPLAINED`, with its end; None when none does.

    A fault's stretch runs from its onset to its end, and whatever else happens in it
    is in its residual too: a second fault on a sensor the estimate uses blurs the
    first fault's shape from its own onset on. A gain of 1.3 on one of four channels
    from 480 s, with an offset on another from 840 s, was read as ``other`` (explained
    0.41) by two detectors of three and reported so; its first 360 s alone are a gain
    of 1.302, explained 0.94 (``sweep_isolation.py --floors 2 --onset 0.4 --second 0.7``,
    seed 13). A fault that is erratic throughout (a noise burst, spikes) has no
    well-explained beginning either, and stays ``other``."""
    least = LEAD_WINDOWS * cal.long_window
    length = (stop - onset) // 2
    while length >= least:
        cls = fit(onset + length)
        if cls.type is not FaultType.OTHER and cls.explained >= LEAD_EXPLAINED:
            return cls, onset + length
        length //= 2
    return None


def _lead_to_change(
    fit: Callable[[int], Classification],
    r: FloatArray,
    onset: int,
    stop: int,
    cal: Calibration,
    rate_hz: float,
) -> tuple[Classification, int] | None:
    """The shape of a fault's part before the level of its residual changes
    (:func:`_change_point` of the stretch less the healthy mean, each part at least
    :data:`CHANGE_MIN_S`), where that part is at least :data:`LEAD_WINDOWS` long alarm
    windows and a shape explains it to :data:`LEAD_EXPLAINED`; None otherwise. For a
    fault that changes where no half, quarter... of its stretch ends (:func:`_shaped_lead`):
    an offset of 2 sd from 400 to 450 s followed by a gain of 1.8 to 520 s was one
    ``other`` from 400 to 520 s (its first 60 s take in 10 s of the gain, its first 30 s
    are too short), where a change at 450 s leaves an offset's part."""
    margin = max(cal.long_window, int(CHANGE_MIN_S * rate_hz))
    at = _change_point(np.asarray(r[onset:stop], dtype=np.float64) - cal.mean, cal, margin)
    if at is None or at < LEAD_WINDOWS * cal.long_window:
        return None
    cls = fit(onset + at)
    if cls.type is FaultType.OTHER or cls.explained < LEAD_EXPLAINED:
        return None
    return cls, onset + at


LEAD_WINDOWS = 16
"""The shortest leading part of a fault :func:`_shaped_lead` fits, in long alarm windows
(32 s at 100 Hz): long enough to tell a slope from a step."""

LEAD_EXPLAINED = 0.8
"""The share of a leading part's fault energy its shape must explain to stand for the
fault (:func:`_shaped_lead`): well above the ``other`` limit (0.5), so a stretch the
shapes barely explain anywhere is not given one by picking a part of it."""

REFIT_GROWTH = 1.5
"""A fault's shape is refitted (:func:`diagnose_interval`) only on a stretch at least
this many times as long as the last fit's."""
MAX_REFITS = 12
"""At most this many refits per fault (a stretch 1.5^12 ~ 130 times the first)."""

MAPPED_CORRECTION = 1 << 20
"""Samples of a corrected residual kept in memory (8 MB); a longer one moves to a
memory-mapped buffer in the scratch directory, whose pages the search gives back after
each step (one file per fault that lasts, not per fault: creating one costs ~3 ms)."""


class _Corrected:
    """The residual of the reading with a fault's fitted shape undone from ``onset`` on
    (the residual less the shape; a gain fault's divided by the gain too:
    :attr:`~analyzer.diagnosis.classify.Classification.reading_gain`), built on demand: its
    first ``h`` samples, filled as ``h`` grows (a fault's end is usually found within
    seconds of its onset; the rest of the record is not corrected), for
    :class:`_Intervals` from ``search_start`` on.

    Only what that search reads is filled: from the earliest sample of the first window
    the alarm statistic computes (``search_start - max(windows) + 1``) on; detect reads
    nothing before ``search_start``. The statistic's running sums before that sample are
    the residual's, taken from it once (``carry``) instead of copying it."""

    def __init__(
        self,
        r: FloatArray,
        ref: FloatArray | None,
        cls: Classification,
        onset: int,
        rate_hz: float,
        cal: Calibration,
        search_start: int,
        scratch: Path | None = None,
        index: SumsIndex | None = None,
    ) -> None:
        self.r, self.ref, self.cls, self.onset, self.rate_hz = r, ref, cls, onset, rate_hz
        self.scratch = scratch
        n = r.shape[0]
        head = min(max(0, search_start), n)
        # the residual is corrected only from the onset on: before it, the raw residual's
        # running sums (from the index when there is one)
        self.carry = np.zeros(4) if index is None else index.before(head, cal)
        # the running sums up to the first window from search_start on (no statistic:
        # the record ends at search_start)
        alarm_statistic(
            r[:head], cal, raw=True, start=head, out=np.empty(0), carry=self.carry, base=head
        )
        self.first = self.filled = int(self.carry[0])
        # indexed by sample; its pages are touched only as far as it is filled
        self.buf = np.empty(n if scratch is None else min(n, self.first + MAPPED_CORRECTION))

    def upto(self, h: int) -> FloatArray:
        if h > self.buf.shape[0]:
            # a long stretch (only with scratch): on to a mapped buffer, what is filled
            # copied over
            assert self.scratch is not None
            mapped = buffer(self.scratch, "corrected-residual", (self.r.shape[0], 1))[:, 0]
            mapped[self.first : self.filled] = self.buf[self.first : self.filled]
            self.buf = mapped
        if h > self.filled:
            a = min(h, max(self.filled, self.onset))
            self.buf[self.filled : a] = self.r[self.filled : a]
            # the shape a piece at a time: its temporaries do not grow with the stretch
            for lo in range(a, h, STAT_PIECE):
                hi = min(h, lo + STAT_PIECE)
                tau = np.arange(lo - self.onset, hi - self.onset) / self.rate_hz
                shape = self.cls.fault_signal(tau, None if self.ref is None else self.ref[lo:hi])
                if shape is None:  # pragma: no cover - checked by diagnose_interval
                    raise ValueError("a fault of type other has no shape to subtract")
                np.subtract(self.r[lo:hi], shape, out=self.buf[lo:hi])
                if self.cls.reading_gain != 1.0:  # the corrected reading's residual
                    self.buf[lo:hi] /= self.cls.reading_gain
            self.filled = h
        return self.buf[:h]


class _Intervals:
    """:func:`~analyzer.diagnosis.changes.detect`'s intervals of a record from
    ``search_start`` on, found on its first ``h`` samples with ``h`` grown (by growing
    steps) as far as a question needs, not on the whole record.

    detect on the first ``h`` samples gives the whole record's intervals (onset, end,
    first and last alarm, peak; not the p-value, which counts the record's windows) for
    every interval but the last, and for the last too once it is closed: more than
    ``long_window`` (detect's merging gap) observed samples after its last alarm, so no
    later alarm joins it, and its first and last alarm a window before ``h``, where the
    change-point searches end. The alarm statistic is causal and bit-identical from any
    start, so it is computed once per sample, a stretch per step. An interval not yet
    settled begins at ``a - long_window - 2 window`` or later (detect's onset search),
    ``a`` its first alarm: the first unsettled one's, or past ``h``."""

    FIRST_STEP = 8.0
    """The first stretch, in long windows (a fault's end is mostly found in it)."""
    GROWTH = 8
    """Each step this many times the last: few steps, each a pass over the samples
    before the search (detect's runs) besides the statistic of the new samples."""

    def __init__(
        self,
        record: FloatArray | _Corrected,
        n: int,
        cal: Calibration,
        search_start: int,
        statistic: FloatArray | None = None,
        index: SumsIndex | None = None,
    ) -> None:
        self.record, self.n, self.cal = record, n, cal
        self.search_start = max(0, search_start)
        self.stat = statistic
        # without a statistic, its alarm runs, found a piece at a time as h grows (the
        # running sums carried from step to step, from the index's when there is one):
        # none of it is kept whole
        if isinstance(record, np.ndarray):
            carry = None if index is None else index.before(self.search_start, cal)
        else:
            carry = record.carry
        self.runs = AlarmRuns(cal, self.search_start, carry)
        self.found: list[Interval] = []  # detect's intervals of the first h samples
        self.settled = 0  # how many of them are the whole record's
        self.frontier = self.search_start  # no unsettled interval begins before it
        self.h = self.search_start
        self.step = max(1, int(self.FIRST_STEP * cal.long_window))

    def onset(self, i: int, before: int) -> int | None:
        """The ``i``-th interval's onset if it is before ``before``, else None (also when
        there is no such interval)."""
        while not self._onset_known(i) and self.frontier < before and self.h < self.n:
            self._grow()
        if self._onset_known(i) and self.found[i].onset < before:
            return self.found[i].onset
        return None

    def ends_after(self, i: int, lo: int) -> bool:
        """Whether the ``i``-th interval (its onset known) ends after ``lo`` (an interval
        to the end of the record does). Before it is settled its end is at least
        ``max(onset + 1, last alarm - long_window - 2 window)`` (detect's end search),
        and its last alarm only moves on as the record grows."""
        w, wl = self.cal.window, self.cal.long_window
        while i >= self.settled:
            iv = self.found[i]
            if max(iv.onset + 1, iv.last_alarm - wl - 2 * w) > lo:
                return True
            self._grow()
        end = self.found[i].end
        return end is None or end > lo

    def _onset_known(self, i: int) -> bool:
        """The ``i``-th interval's onset is the whole record's: the intervals before it
        are settled and its first alarm is a window before ``h``."""
        return i < self.settled or (
            i == self.settled
            and i < len(self.found)
            and self.found[i].first_alarm + self.cal.window <= self.h
        )

    def _grow(self) -> None:
        h = min(self.n, self.h + self.step)
        self.step *= self.GROWTH
        x = self.record[:h] if isinstance(self.record, np.ndarray) else self.record.upto(h)
        if self.stat is None:
            runs = self.runs.extend(x)
        else:
            runs = AlarmRuns.of_statistic(self.stat, self.search_start, h)
        found = intervals(x, self.cal, runs, search_start=self.search_start)
        w, wl = self.cal.window, self.cal.long_window
        settled = len(found)
        if h < self.n:
            settled = 0
            for k, iv in enumerate(found):
                if iv.first_alarm + w > h or iv.last_alarm + w > h:
                    break
                if k == len(found) - 1:
                    after = np.count_nonzero(np.isfinite(x[iv.last_alarm + 1 : h]))
                    if after <= wl:
                        break
                settled = k + 1
        self.found, self.settled, self.h = found, settled, h
        nxt = found[settled].first_alarm if settled < len(found) else h
        self.frontier = nxt - wl - 2 * w
        release(x)  # a memory-mapped record: read again only around its alarms
