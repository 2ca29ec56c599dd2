"""The common path from one channel's residual to events: calibrate on the healthy
window, detect faulty intervals, classify each. Every detector whose residual speaks
about one channel uses this, so thresholds and fault types mean the same everywhere."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.detectors.base import Event
from analyzer.diagnosis.changes import Calibration, Interval, detect, detection_confidence
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
    for iv in detect(residual, cal, search_start=search_start):
        if iv.onset < covered:
            continue  # inside a fault already extended over this stretch
        cls, end = diagnose_interval(residual, reference, cal, iv, rate_hz, tau_corr)
        covered = n if end is None else end
        onset_s = iv.onset / rate_hz + cls.onset_shift_s
        ev = {
            "first_alarm_s": iv.first_alarm / rate_hz,
            "peak_over_threshold": iv.peak,
            "p_value": iv.p_value,
            "type_weights": cls.weights,
            "explained": cls.explained,
        }
        if evidence:
            ev.update(evidence)
        out.append(
            Event(
                channel=channel,
                onset_s=float(max(0.0, onset_s)),
                end_s=None if end is None else end / rate_hz,
                type=cls.type,
                magnitude=cls.magnitude,
                confidence=float(detection_confidence(iv) * cls.confidence),
                detector=detector,
                evidence=ev,
            )
        )
    return out


def diagnose_interval(
    residual: FloatArray,
    reference: FloatArray | None,
    cal: Calibration,
    iv: Interval,
    rate_hz: float,
    tau_corr: float = 1.0,
    classify_until: int | None = None,
) -> tuple[Classification, int | None]:
    """Classify the fault that starts at ``iv`` and find where it really ends.

    The alarms of the raw residual can stop while a fault goes on: a gain fault is
    invisible while the structure is quiet. So the fitted fault shape is extended past the
    alarms and subtracted; the fault ends where that corrected residual alarms while the
    raw residual is healthy again (the sensor reads right and the correction is now
    wrong). Faults of type ``other`` have no shape to extend and end with their alarms.

    ``classify_until`` bounds the stretch the shape is fitted on (a caller that knows
    another fault begins there, which would blur this one's shape)."""
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
    raw_alarms = detect(r, cal, search_start=iv.onset)
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
