"""An estimate of the time a ``run`` has left, for its progress on stderr (the bar and
``--progress``'s plain lines; the operator's audit ux62 LOW 7: a month's run said its
stages' shares and seconds but not when it would end, where ``watch --once`` said
``about 32 s left``); :func:`left_text` words it for both commands.

How it is computed (:class:`TimeLeft`): each stage is a known share of a run's work,
from the benchmarks' per-stage seconds (:data:`STAGE_WEIGHTS`); the work done is the
shares of the stages seen, each times how far it got. Nothing is said until ``read`` has
ended (reading's speed says little of detecting's) and :data:`LEAST_SHARE_SEEN` of the
work after it is done; then the time left is the rest of the work at the rate measured
since ``read`` ended, smoothed over :data:`SMOOTHING_S` seconds of the clock so that
one fast or slow step does not make it jump, counting down between steps, never below
0. ``screen detect`` and ``again detect`` (the second search after a faulty sensor) are
known only when they begin: each adds a ``detect``'s share to the work then.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from analyzer.timeutil import spoken_digits

STAGE_WEIGHTS: dict[str, float] = {
    "read": 1.5,
    "align": 0.2,
    "detect": 6.6,
    "tests": 0.4,
    "report": 0.3,
}
"""Seconds of each stage on the benchmarks' 4-hour, 16-channel MCAP archive
(benchmarks/README.md, ``bench_pipeline.py``: read 1.5, align 0.2, detect 6.6, tests
0.4, outputs 0.3 s), used as each stage's share of a run's work. A stage named with a
prefix (``again detect``, a group's ``screen detect``) weighs as its last word."""

LEAST_SHARE_SEEN = 0.1
"""The share of the work after ``read`` that must be done before an estimate is said:
a rate measured over less (the alignment alone, a detector's first step) is no basis."""

SMOOTHING_S = 10.0
"""The time constant (seconds of the clock) over which a new estimate replaces the
last one: a step that was fast or slow moves it a little, a lasting change fully."""


def _weight(stage: str) -> float:
    """``stage``'s share of a run's work (:data:`STAGE_WEIGHTS`, by its last word); 0
    for a stage not in the table (no part of the estimate)."""
    words = str(stage).split()
    return STAGE_WEIGHTS.get(words[-1], 0.0) if words else 0.0


class TimeLeft:
    """The time a run has left, from the progress events it is given (``update``) and
    ``clock`` (seconds; :func:`time.monotonic` in a run, a fake clock in tests)."""

    def __init__(self, clock: Callable[[], float]) -> None:
        self.clock = clock
        self.reached: dict[str, float] = {}  # stage -> the largest share it reached
        self.extra = 0.0  # the work of stages beyond the plain five (again detect)
        self.base: tuple[float, float] | None = None  # (time, work done) when read ended
        self.said: tuple[float, float] | None = None  # (time, estimate) last given

    def update(self, stage: str, fraction: float) -> float | None:
        """Take ``stage`` at ``fraction`` done; the seconds left, or None while no
        estimate can be said (read not ended, too little done since)."""
        name = str(stage)
        now = self.clock()
        if name not in self.reached and name not in STAGE_WEIGHTS:
            self.extra += _weight(name)
        done_share = max(0.0, min(1.0, float(fraction)))
        self.reached[name] = max(self.reached.get(name, 0.0), done_share)
        done = sum(_weight(s) * f for s, f in self.reached.items())
        if self.base is None:
            # (align begins only once read has ended, should read not say its 100 %)
            if self.reached.get("read", 0.0) >= 1.0 or "align" in self.reached:
                self.base = (now, done)
            return None
        total = sum(STAGE_WEIGHTS.values()) + self.extra
        if done >= total:  # (every stage at 100 %: nothing left, whatever was said)
            self.said = (now, 0.0)
            return 0.0
        return self._smoothed(now, self._raw(now, done, total))

    def _raw(self, now: float, done: float, total: float) -> float | None:
        """The seconds left at the rate since read ended, or None on too little basis."""
        assert self.base is not None
        began, done_then = self.base
        since = done - done_then
        if since < LEAST_SHARE_SEEN * (total - done_then) or now <= began:
            return None
        return max(0.0, (total - done) * (now - began) / since)

    def _smoothed(self, now: float, raw: float | None) -> float | None:
        """``raw`` blended into the last estimate, counted down since it was given."""
        if self.said is None:
            if raw is not None:
                self.said = (now, raw)
            return raw
        then, last = self.said
        counted = max(0.0, last - (now - then))
        if raw is None:
            return counted
        keep = math.exp(-max(0.0, now - then) / SMOOTHING_S)
        estimate = max(0.0, keep * counted + (1.0 - keep) * raw)
        self.said = (now, estimate)
        return estimate


def left_text(seconds: float) -> str:
    """The time left as a line says it, rounded as an estimate is: ``less than a
    minute left``, ``about 3 min left``, ``about 2.5 h left``, ``about 13 h left``,
    ``about 3.2 days left`` (not ``2.97 min`` nor ``13.2 h``: the estimate is not that
    precise). The one wording of a time left, ``run``'s progress and ``watch --once``'s
    (``[2/3, less than a minute left]``): the watcher said 20 s as ``about 20 s left``
    and 0.5 s as ``under 1 s left`` where ``run`` said ``less than a minute left``,
    digits its estimate (from the rate of a few analyses) does not have; ``run``'s was
    measured off by up to half (README)."""
    s = max(0.0, float(seconds))
    if s < 60.0:
        return "less than a minute left"
    if s < 90 * 60.0:
        return f"about {max(1, round(s / 60.0))} min left"
    if s < 48 * 3600.0:
        return f"about {spoken_digits(s / 3600.0)} h left"
    return f"about {spoken_digits(s / 86400.0)} days left"
