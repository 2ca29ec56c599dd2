"""How far each topic's log times depart from its messages' header stamps (``--time log``).

A recorder writes a message some time after its publisher stamped it: a transport and
queue delay of a fraction of a millisecond to a few milliseconds, nearly the same for
every message. Where that delay varies by a sizeable share of the topic's sample period
(a message written 16 ms late on a 25 Hz topic, the real ``rosbag2_test``'s
``/battery``), the default log-time axis moves that sample off its place against the
others, and a detector can take the step for a sensor's fault (the robotics audit ux58
item 3: a confident ``other`` fault at 54.84 s that ``--time header`` does not give).

:class:`LogDelays` measures this while the readers read (:class:`~analyzer.readers.
_common.TopicTracker` feeds it each batch of a topic that carries header stamps),
vectorized per batch: each message's *departure* is its delay (log time minus
header stamp) minus the median delay of the batch and the topic's last
:data:`TAIL` messages before it (a local median: a header clock that drifts slowly
against the recorder's moves the median with it). Per topic it keeps how many messages
were measured, a histogram of the departures' sizes and the :data:`KEPT` largest
departures with their log times; :mod:`analyzer.delay_note` judges them against the
channels' sample period once it is known.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

IntArray = npt.NDArray[np.int64]

TAIL = 63
"""Delays of a topic's last messages kept for the next batch's median: a batch of one
or two messages of a slow topic (a 1 Hz battery among 200 Hz topics) is measured against
its recent past, not against itself."""

KEPT = 64
"""The largest departures kept per topic, with their log times: those a finding's onset
is compared with. A topic with more messages that depart by a sizeable share of its
period is jittery throughout (:attr:`TopicDelays.late_count` says how many)."""

SAME_CLOCK_NS = 10 * 10**9
"""A batch whose median delay is larger than this (10 s, as a header clock set during
the recording: :data:`~analyzer.readers._common.WALL_CLOCK_STEP_NS`) has header stamps
on another clock (a simulation clock, a robot's unsynchronised clock): its departures
are not a recorder's delay, and it is not measured."""

EDGES_NS = np.unique(np.round(10_000 * 2.0 ** (np.arange(0, 97) / 4)).astype(np.int64))
"""Histogram edges of the departures' sizes: from 10 microseconds, in steps of a
quarter octave (19 %), to 10 000 s (:meth:`TopicDelays.over`)."""


@dataclass(slots=True)
class TopicDelays:
    """One topic's departures of log time from header stamp (:mod:`this module`)."""

    measured: int = 0
    """Messages measured (with a header stamp that is set, on the recorder's clock)."""
    counts: IntArray = field(default_factory=lambda: np.zeros(EDGES_NS.size + 1, np.int64))
    """Departures' sizes per bin of :data:`EDGES_NS` (bin ``k``: below ``EDGES_NS[k]``,
    at or above the edge before it)."""
    late_log_ns: IntArray = field(default_factory=lambda: np.zeros(0, np.int64))
    """Log times of the :data:`KEPT` largest departures."""
    late_ns: IntArray = field(default_factory=lambda: np.zeros(0, np.int64))
    """Those departures (nanoseconds; positive: logged later than its neighbours)."""
    tail: IntArray = field(default_factory=lambda: np.zeros(0, np.int64))
    """Delays of the topic's last :data:`TAIL` messages measured."""

    @property
    def largest_ns(self) -> int:
        """The largest departure's size (0 where none was measured)."""
        return int(np.abs(self.late_ns).max()) if self.late_ns.size else 0

    def over(self, limit_ns: float) -> int:
        """How many messages departed by more than ``limit_ns``: exact where at most
        :data:`KEPT` did (the kept ones), else from the histogram (the bins wholly above
        the limit, a quarter octave's rounding)."""
        kept = int(np.count_nonzero(np.abs(self.late_ns) > limit_ns))
        if kept < KEPT:
            return kept
        first = int(np.searchsorted(EDGES_NS, limit_ns, side="left"))
        return max(kept, int(self.counts[first + 1 :].sum()))

    def add(self, log_ns: IntArray, stamps: IntArray) -> None:
        """Measure a batch of messages (log times and header stamps, nanoseconds; each
        stamp set)."""
        delay = log_ns - stamps
        context = np.concatenate((self.tail, delay))
        base = int(np.median(context))
        if abs(base) > SAME_CLOCK_NS:
            return
        self.tail = context[-TAIL:]
        away = delay - base
        size = np.abs(away)
        self.measured += int(delay.size)
        self.counts += np.bincount(
            np.searchsorted(EDGES_NS, size, side="right"), minlength=self.counts.size
        )
        late = np.concatenate((self.late_ns, away))
        when = np.concatenate((self.late_log_ns, log_ns))
        if late.size > KEPT:
            keep = np.argpartition(-np.abs(late), KEPT - 1)[:KEPT]
            late, when = late[keep], when[keep]
        self.late_ns, self.late_log_ns = late, when


@dataclass(slots=True)
class LogDelays:
    """Per topic, :class:`TopicDelays`: what the readers measured of an input."""

    topics: dict[str, TopicDelays] = field(default_factory=dict)

    def add(self, topic: str, log_ns: IntArray, stamps: IntArray, unset: int) -> None:
        """Measure a batch of ``topic``'s messages whose header stamps are ``stamps``
        (``unset``: the placeholder of a message without one; a stamp of 0 is a driver
        that does not set it: neither is measured)."""
        real = (stamps != unset) & (stamps != 0)
        if not bool(real.any()):
            return
        if not bool(real.all()):
            log_ns, stamps = log_ns[real], stamps[real]
        self.topics.setdefault(topic, TopicDelays()).add(log_ns, stamps)
