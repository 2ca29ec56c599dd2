"""The healthy verdict in plain words: what was taken as healthy, and how often the
detectors' settings let a healthy record raise a false alarm.

The report said "None of the detectors found a residual that left its threshold band
after the training window" and "False-alarm rate 1e-06 per sample (shared among each
detector's channels)": right, and read by a statistician only (ux60 item 10). The
false-alarm rate is turned into how much healthy record the settings allow per false
alarm, from the rates the detectors' thresholds were actually set with: each detector
gives each residual it watches its own rate (``thresholds[channel]["false_alarm_rate"]``
of its result), the run's rate split among its channels by the bank, the detection
filter and the equivalent model, the whole rate for each sensor by the error
functions; each residual's rate bounds the share of its samples at which a statistic
of healthy data crosses its threshold (:func:`analyzer.diagnosis.changes.calibrate`).
Summed over the residuals and the detectors, times the samples per hour, it bounds the
false alarms per hour (crossings come in runs, so alarms are rarer still: the figure
is an upper bound, "at most about").
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from analyzer.report import format as fmt

HOUR_S = 3600.0


def detector_rates(results: Iterable[Any]) -> dict[str, float]:
    """Each detector's false-alarm rate per sample of the record: the sum of the rates
    its residuals' thresholds were set with (those with one); detectors without
    thresholds are left out."""
    out: dict[str, float] = {}
    for r in results:
        rates = [
            float(th["false_alarm_rate"])
            for th in (getattr(r, "thresholds", None) or {}).values()
            if isinstance(th, Mapping) and th.get("false_alarm_rate") is not None
        ]
        if rates:
            out[str(getattr(r, "detector", "?"))] = sum(rates)
    return out


def hours_per_false_alarm(rates: Mapping[str, float], rate_hz: float) -> float | None:
    """Hours of healthy record per false alarm the settings allow at most: one over the
    detectors' summed rate per sample times the samples per hour; None without rates
    or without a sampling rate."""
    per_sample = sum(rates.values())
    if not per_sample > 0 or not rate_hz > 0:
        return None
    return 1.0 / (per_sample * rate_hz * HOUR_S)


def spoken_hours(hours: float) -> str:
    """A length of record for people, to two significant digits: ``56 minutes``,
    ``19 hours``, ``39 days``, ``11 years``."""
    for limit, scale, unit in (
        (1.0, 1 / 60, "minutes"),
        (72.0, 1.0, "hours"),
        (2 * 365 * 24.0, 24.0, "days"),
    ):
        if hours < limit:
            return f"{_two_digits(hours / scale)} {unit}"
    return f"{_two_digits(hours / (365 * 24.0))} years"


def _two_digits(v: float) -> str:
    """``v`` to two significant digits, without powers of ten: 19, 1.9, 190."""
    said = float(f"{v:.2g}")
    return f"{said:.0f}" if said >= 10 else f"{said:g}"


def false_alarm_words(rates: Mapping[str, float], rate_hz: float) -> str:
    """The "What was checked" line on false alarms: ``at most about one false alarm per
    19 hours of healthy record at these settings (3 detectors, each allowed 1e-06 false
    alarms per sample of the record, shared among its sensors, at 100 Hz)``; ``n/a``
    without rates."""
    hours = hours_per_false_alarm(rates, rate_hz)
    if hours is None:
        return fmt.MISSING
    each = {fmt.num(v, 3) for v in rates.values()}
    n = len(rates)
    if len(each) == 1:
        who = "1 detector, allowed" if n == 1 else f"{n} detectors, each allowed"
        allowed = f"{who} {each.pop()} false alarms per sample of the record, shared among"
    else:  # (the error functions allow the rate for each sensor, the others in all)
        listed = ", ".join(f"{d} {fmt.num(v, 3)}" for d, v in rates.items())
        allowed = f"{listed} false alarms per sample of the record, over"
    return (
        f"at most about one false alarm per {spoken_hours(hours)} of healthy record at "
        f"these settings ({allowed} the sensors each watches, at {fmt.rate(rate_hz)})"
    )


HELD_WINDOWS = 5
"""Long windows (the detectors' longer watch, :data:`analyzer.diagnosis.changes.
LONG_FACTOR` times the short one) an offset must last for :func:`smallest_offsets`'
figure to hold. Measured on simulated 6-floor buildings (``simulate_building``, 300 s
at 100 Hz, long window 2 s; offsets on s0, s1, s2 or s4 from 150 s, 10 seeds): lasting
10 s (5 long windows), offsets of 0.5, 1 and 2 times the figure were found on their
sensor in 1, 20 and 20 of 20 records (the half-size ones on s0 were placed on s1 in 5
of 10), and none of the 10 healthy records gave a finding; lasting 150 s, half-size
offsets were found in 6 of 10 (s1, s4): a longer fault is seen smaller, so the figure
is said with its duration."""


def smallest_offsets(results: Iterable[Any], channels: Iterable[str]) -> dict[str, float]:
    """Per channel, the offset (in its units) at which its residual's mean over the
    detectors' long window reaches the threshold, for the detector that sees it
    smallest: the residual's training deviation times its long-window mean threshold
    (``std`` and ``mean_threshold[-1]`` of the result's thresholds, the latter in units
    of that deviation). An offset passes into the residual of the leave-one-out
    estimators one to one. Channels no detector has a threshold for are left out."""
    wanted = set(channels)
    out: dict[str, float] = {}
    for r in results:
        for ch, th in (getattr(r, "thresholds", None) or {}).items():
            if ch not in wanted or not isinstance(th, Mapping):
                continue
            try:
                v = float(th["std"]) * float(th["mean_threshold"][-1])
            except (KeyError, IndexError, TypeError, ValueError):
                continue
            if v > 0 and v == v:
                out[str(ch)] = min(v, out.get(str(ch), v))
    return out


def held_seconds(results: Iterable[Any], rate_hz: float) -> float | None:
    """How long an offset must last for :func:`smallest_offsets` to hold:
    :data:`HELD_WINDOWS` of the longest window the detectors watch; None without one."""
    longest = [
        int(th["windows"][-1])
        for r in results
        for th in (getattr(r, "thresholds", None) or {}).values()
        if isinstance(th, Mapping) and th.get("windows")
    ]
    if not longest or not rate_hz > 0:
        return None
    return HELD_WINDOWS * max(longest) / rate_hz


def smallest_words(
    offsets: Mapping[str, float], units: Mapping[str, str], held_s: float | None, limit: int = 24
) -> str:
    """The "Smallest offset found" line: ``s1 0.071, s2 0.078 m/s2 (...)`` with what it
    means; empty without figures."""
    if not offsets or held_s is None:
        return ""
    names = list(offsets)
    said = [
        f"{ch} {fmt.num(offsets[ch], 2)}" + (f" {units[ch]}" if units.get(ch) else "")
        for ch in names[:limit]
    ]
    more = f" and {len(names) - limit} more" if len(names) > limit else ""
    return (
        f"{', '.join(said)}{more}: an offset (zero shift) this large or larger on that "
        f"sensor, lasting {_spoken_seconds(held_s)} or more, would have been found; smaller "
        "ones may be missed, the longer they last the less so (from the detectors' "
        "thresholds; checked on simulated records)"
    )


def _spoken_seconds(x: float) -> str:
    """``10 s``, ``10 min 40.0 s``: a length of time without false precision."""
    return f"{fmt.num(x, 3)} s" if x < 120 else fmt.duration(x)


def healthy_words(train: str, reused: bool) -> str:
    """The sentence under "What was checked" in a run that found no fault: what was
    taken as healthy (``train``: the training window, or with ``--model`` the record
    the models were fitted on) and that it was not itself checked."""
    if reused:
        return (
            "No sensor behaved differently from the healthy record the models were fitted "
            "on (taken as healthy and not checked here). The first samples here, while the "
            "filters settled, were not checked either."
        )
    return (
        f"No sensor behaved differently from the training window ({train}). That window "
        "was taken as healthy and was not itself checked: a fault present all through it "
        "would read as the sensor's normal behaviour."
    )


__all__ = [
    "HELD_WINDOWS",
    "detector_rates",
    "false_alarm_words",
    "healthy_words",
    "held_seconds",
    "hours_per_false_alarm",
    "smallest_offsets",
    "smallest_words",
    "spoken_hours",
]
