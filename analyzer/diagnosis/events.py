"""The common path from one channel's residual to events: calibrate on the healthy
window, detect faulty intervals, classify each. Every detector whose residual speaks
about one channel uses this, so thresholds and fault types mean the same everywhere."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.detectors.base import Event
from analyzer.diagnosis.changes import (
    Calibration,
    Interval,
    alarm_statistic,
    detect,
    detection_confidence,
)
from analyzer.diagnosis.classify import Classification, classify

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
    tau_corr: float = 1.0,
    evidence: dict[str, Any] | None = None,
) -> list[Event]:
    """Events on ``channel`` from its residual (measured - estimated)."""
    out: list[Event] = []
    n = residual.shape[0]
    covered = search_start
    # one alarm statistic for the search and for every fault's end (diagnose_interval)
    stat = alarm_statistic(residual, cal, raw=True, start=search_start)
    for iv in detect(residual, cal, search_start=search_start, statistic=stat):
        if iv.onset < covered:
            continue  # inside a fault already extended over this stretch
        cls, end = diagnose_interval(
            residual, reference, cal, iv, rate_hz, tau_corr, statistic=stat
        )
        covered = n if end is None else end
        onset_s, factor, extra = bounded_onset(iv.onset, cls, rate_hz, search_start)
        ev = {
            "first_alarm_s": iv.first_alarm / rate_hz,
            "peak_over_threshold": iv.peak,
            "p_value": iv.p_value,
            "type_weights": cls.weights,
            "explained": cls.explained,
            **extra,
        }
        if evidence:
            ev.update(evidence)
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
            )
        )
    return out


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
    ``iv.onset`` on at least, when the caller has it (computed from there otherwise)."""
    n = residual.shape[0]
    limit = n if classify_until is None else max(iv.onset + 3, classify_until)
    stop = min(n if iv.end is None else iv.end, limit)
    r = np.asarray(residual, dtype=np.float64)
    ref = None if reference is None else np.asarray(reference, dtype=np.float64)

    def fit(stop: int) -> Classification:
        seg_ref = None if ref is None else ref[iv.onset : stop]
        return classify(r[iv.onset : stop] - cal.mean, seg_ref, cal.std, rate_hz, tau_corr)

    cls = fit(stop)
    tau = np.arange(n - iv.onset) / rate_hz
    shape = cls.fault_signal(tau, None if ref is None else ref[iv.onset :])
    if shape is None:
        return cls, iv.end
    corrected = r.copy()
    corrected[iv.onset :] -= shape
    end: int | None = None
    raw_alarms = detect(r, cal, search_start=iv.onset, statistic=statistic)
    corrected_alarms = detect(corrected, cal, search_start=iv.onset + cal.window)
    if iv.end is not None and any(c.onset < iv.end for c in corrected_alarms):
        # the shape does not hold even while the raw residual alarms (random data read as
        # "dead sensor plus noise", say): it cannot be trusted past the alarms either
        return cls, iv.end
    for civ in corrected_alarms:
        lo, hi = civ.onset + cal.window, civ.onset + cal.long_window
        recovered = not any(
            a.onset < hi and (n if a.end is None else a.end) > lo for a in raw_alarms
        )
        if recovered:
            end = civ.onset
            break
    if end != iv.end:
        # refit the shape over the whole fault period
        cls = fit(min(n if end is None else end, limit))
    return cls, end
