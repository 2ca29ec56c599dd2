"""The life cycle every detector shares: settings in the constructor, learning in
:meth:`Detector.fit` on the healthy window, then :meth:`Detector.run` over the aligned
archive, returning residuals plus events.

Conventions
-----------
* Data is the aligned archive: an (N, m) float64 array (possibly a read-only memmap) on
  the common clock, one column per channel, NaN where a channel has a gap.
* A *residual* of channel ``c`` is ``measured - estimated`` (channel units), so an additive
  offset ``+D`` on the sensor shows as a residual near ``+D``; ``reference[c]`` is the
  detector's fault-free estimate of the channel (what the sensor should have read).
* Events are per channel and per detector; :mod:`analyzer.diagnosis.merge` turns them into
  findings (one physical fault, one finding).
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar, Protocol, TypeVar

import numpy as np
import numpy.typing as npt

from analyzer.paging import buffer, mapped_file
from analyzer.types import FaultType

FloatArray = npt.NDArray[np.float64]
T = TypeVar("T")
R = TypeVar("R")


class MapExecutor(Protocol):
    """The part of :class:`analyzer.parallel.Executor` a detector uses."""

    def map(self, fn: Callable[[T], R], items: Sequence[T]) -> list[R]: ...

    def imap(self, fn: Callable[[T], R], items: Iterable[T]) -> Iterator[R]: ...

    def scatter(self, obj: T) -> Any: ...


SIGNAL_DTYPE = np.float32
"""Precision of the residuals and fault-free estimates kept after a detector has run.
Thresholds, onsets, classification and magnitudes are computed inside the detector from
float64 residuals (the per-sample consistency statistics that only feed windowed alarm
statistics are stored in float32, their sums taken in float64); what is kept serves the
evidence tests, the report and the corrected signals, where 7 significant digits are
plenty, and halves the memory that grows with the archive's length. A detector hands its
signals over in this precision itself where it can release each float64 array first."""


@dataclass(frozen=True, slots=True)
class Dataset:
    """The aligned data a detector sees: ``values[k, j]`` is channel ``channels[j]`` at
    time ``k / rate_hz`` seconds from the first sample; ``train`` is the healthy window
    as a half-open index range ``[start, stop)``, or with a model fitted on another
    archive (``--model``) the filters' warm-up, which ``healthy`` False says may hold a
    fault already (nothing is measured on it as health)."""

    values: FloatArray
    channels: tuple[str, ...]
    rate_hz: float
    train: tuple[int, int]
    healthy: bool = True
    search_from: int | None = None
    """Where the fault search starts when not at ``train``'s end: a search again after a
    stretch whose anomaly no sensor explained (:mod:`analyzer.search_after`); the healthy
    window is still ``train``."""

    @property
    def healthy_start(self) -> int | None:
        """Where the healthy window starts, None when ``train`` is no healthy window."""
        return self.train[0] if self.healthy else None

    @property
    def search_start(self) -> int:
        """The first row searched for faults: ``search_from``, else the training window's
        end."""
        return self.train[1] if self.search_from is None else max(self.train[1], self.search_from)

    @property
    def n(self) -> int:
        return int(self.values.shape[0])

    def index(self, channel: str) -> int:
        return self.channels.index(channel)

    def train_values(self) -> FloatArray:
        return self.values[self.train[0] : self.train[1]]


def map_in(
    context: RunContext | None, fn: Callable[[T], R], items: Sequence[T], shown: str = ""
) -> list[R]:
    """``context.map(fn, items, shown)``, or a plain loop when there is no context."""
    return [fn(x) for x in items] if context is None else context.map(fn, items, shown)


class _Counted:
    """``fn`` that says each finished item (``Steps``): what :meth:`RunContext.map`
    maps where its items run in this process (serially or on its threads)."""

    def __init__(self, fn: Callable[[Any], Any], steps: Steps) -> None:
        self.fn, self.steps = fn, steps

    def __call__(self, item: Any) -> Any:
        out = self.fn(item)
        self.steps.done()
        return out


class Advance:
    """The progress of a pass over the whole record: rows filtered of ``total`` (from
    every time block, on threads too), said as ``shown`` each time one more hundredth is
    done, short of the whole (the pass's end is its step's: ``detect`` says it). On a
    day's archive such a pass (the bank's, the detection filter's) is a run's longest
    step, and each left ``--progress`` silent for most of a minute (the ux55 audit)."""

    def __init__(self, context: RunContext, shown: str, total: int) -> None:
        self.context, self.shown, self.total = context, shown, max(1, total)
        self.done = 0
        self.said = 0
        self.lock = threading.Lock()

    def __call__(self, rows: int) -> None:
        with self.lock:
            self.done += rows
            hundredths = 100 * self.done // self.total
            if self.said < hundredths < 100:
                self.said = hundredths
                self.context.report(f"{self.shown} {hundredths}%", hundredths / 100)


class Steps:
    """The items of one step of a detector (time blocks, filters, observers) finished so
    far, said to the run's progress as ``shown k/n`` with the share ``k / n``, one call
    per item (never per sample), from any thread: the step a detector's fit or run spends
    its time in, which ``detect`` names inside its own share (see
    :class:`analyzer.types.Stage`)."""

    def __init__(self, context: RunContext, shown: str, total: int) -> None:
        self.context, self.shown, self.total = context, shown, max(1, total)
        self.count = 0
        self.lock = threading.Lock()

    def done(self) -> None:
        with self.lock:
            self.count += 1
            count = min(self.count, self.total)
            self.context.report(f"{self.shown} {count}/{self.total}", count / self.total)


@dataclass(slots=True)
class RunContext:
    """What the pipeline lends a detector: thresholds, scratch space, progress and an
    executor for work that splits into independent pieces (:meth:`map`)."""

    false_alarm_rate: float = 1e-6
    workdir: Path | None = None
    jobs: int = 1
    progress: Callable[[str, float], None] | None = None
    config: Mapping[str, Any] = field(default_factory=dict)
    """The whole parsed config (groups, model...), for detectors that need it."""
    explicit: bool = False
    """True when the user named the detectors (``--detectors``): a detector may then run
    with defaults it would not choose on its own."""
    map_outputs: bool = False
    """True for a long archive: per-sample outputs over the whole record go to
    memory-mapped files in ``workdir`` (:meth:`buffer`), so that what stays resident is
    set by the block being worked on, not by the archive's length."""
    executor: MapExecutor | None = None
    """Where :meth:`map` runs its items (an :class:`analyzer.parallel.Executor`); None
    runs them serially in the calling thread. ``jobs`` is its parallelism."""
    local: MapExecutor | None = None
    """Threads of this process for :meth:`map_shared` when ``executor`` is a cluster
    (None: those items run one after the other in the calling thread)."""

    def map(self, fn: Callable[[T], R], items: Sequence[T], shown: str = "") -> list[R]:
        """``[fn(x) for x in items]`` on the context's executor, results in input order.

        ``fn`` must be a module-level (picklable) function and ``items`` picklable (numpy
        arrays are fine): on a Dask cluster each item is a task. An exception raised by
        ``fn`` comes back with its type and message. ``shown`` (``time blocks``): each
        finished item advances the run's progress (:class:`Steps`); on a cluster as its
        result comes back."""
        if shown and self.progress is not None and len(items) > 1:
            steps = Steps(self, shown, len(items))
            if self.shares_memory:
                return self.map(_Counted(fn, steps), items)
            out = []
            for result in self.imap(fn, items):
                out.append(result)
                steps.done()
            return out
        if self.executor is None:
            return [fn(x) for x in items]
        return self.executor.map(fn, items)

    def imap(self, fn: Callable[[T], R], items: Iterable[T]) -> Iterator[R]:
        """:meth:`map` as an iterator, for results each consumed once and then dropped
        (time blocks' outputs written into the caller's arrays): on a cluster only a few
        items are in flight at once, so neither this process nor a worker holds more than
        a few blocks of the archive (:meth:`analyzer.parallel.Executor.imap`)."""
        if self.executor is None:
            return (fn(x) for x in items)
        return self.executor.imap(fn, items)

    def scatter(self, obj: T) -> Any:
        """A handle for a large argument of many :meth:`map`/:meth:`imap` items (a fitted
        model): ``obj`` itself in this process, on a cluster a future sent to each worker
        once; the items (tuples) carry it in place of ``obj``."""
        return obj if self.shares_memory else self.executor.scatter(obj)  # type: ignore[union-attr]

    def map_shared(self, fn: Callable[[T], R], items: Sequence[T], shown: str = "") -> list[R]:
        """:meth:`map` where the items share this process's memory (serially or on
        threads); when the executor is a cluster, on this process's own threads
        (``local``), else one after the other in this thread: for items that hold (views
        of) the archive, which a cluster would ship whole with every item. ``shown``: as
        for :meth:`map`."""
        if shown and self.progress is not None and len(items) > 1:
            fn = _Counted(fn, Steps(self, shown, len(items)))
        if self.shares_memory:
            return self.map(fn, items)
        if self.local is not None:
            return self.local.map(fn, items)
        return [fn(x) for x in items]

    @property
    def shares_memory(self) -> bool:
        """True when :meth:`map`'s items run in this process (serially or on threads), so
        they may write into the caller's arrays; False on a cluster."""
        return self.executor is None or bool(getattr(self.executor, "shares_memory", False))

    def buffer(
        self, name: str, shape: tuple[int, int], dtype: npt.DTypeLike = np.float64
    ) -> npt.NDArray[Any]:
        """A new ``(samples, channels)`` array for per-sample outputs over the whole
        record: channel-major and memory-mapped in ``workdir`` for a long archive
        (``map_outputs``; see :func:`analyzer.paging.buffer`), else in memory."""
        return buffer(self.workdir if self.map_outputs else None, name, shape, dtype)

    def allocate(self, name: str, shape: tuple[int, ...]) -> FloatArray:
        """A float64 array for a long result; memory-mapped in ``workdir`` when set, so
        peak memory does not grow with the archive's length."""
        if self.workdir is None:
            return np.zeros(shape, dtype=np.float64)
        path = self.workdir / f"{name}.f64"
        return mapped_file(path.with_suffix(".npy"), shape, np.float64)

    def report(self, stage: str, fraction: float) -> None:
        if self.progress is not None:
            self.progress(stage, fraction)


@dataclass(slots=True)
class Event:
    """One detection of one detector on one channel (before merging into findings)."""

    channel: str
    onset_s: float
    end_s: float | None
    type: FaultType
    magnitude: dict[str, float]
    confidence: float
    detector: str
    evidence: dict[str, Any] = field(default_factory=dict)
    intervals: dict[str, Any] | None = None
    """95 % intervals of the size and onset, from the fit that gave them
    (:func:`analyzer.diagnosis.spread.event_intervals`); None where the detector gives none."""


@dataclass(slots=True)
class DetectorResult:
    """What a detector run returns; every number the report shows comes from here."""

    detector: str
    channels: tuple[str, ...]
    params: dict[str, Any]
    events: list[Event]
    residuals: dict[str, FloatArray]
    """Per channel: the residual that speaks about that channel (measured - estimated)."""
    reference: dict[str, FloatArray] = field(default_factory=dict)
    """Per channel: the fault-free estimate of the channel, where the detector has one."""
    sigma: dict[str, float] = field(default_factory=dict)
    """Per channel: healthy (training) standard deviation of its residual."""
    thresholds: dict[str, Any] = field(default_factory=dict)
    model: dict[str, Any] = field(default_factory=dict)
    """JSON-friendly summary of the fitted model (order, fit quality, training tests...)."""
    notes: list[str] = field(default_factory=list)
    unattributed: list[tuple[float, tuple[str, ...], tuple[str, ...]]] = field(default_factory=list)
    """Anomalies the detector saw and attributed to no sensor (its notes say why): their
    onset in seconds, the channels whose residuals alarmed (or that may be faulty), and
    the sensors it found faulty beside them at that time (the equivalent model: a second
    fault on one of the channels), if any."""
    unattributed_end_s: list[float] = field(default_factory=list)
    """Where the detector gives them (the bank), in ``unattributed``'s order: when each of
    those anomalies' alarms ended, in seconds (the record's end while they last); empty
    otherwise. An alarm lasts: its onset alone cannot tell whether it ran into a later
    finding (:func:`analyzer.diagnosis.unexplained.unplaced`)."""
    undecided: list[tuple[float, tuple[str, ...], tuple[str, ...]]] = field(default_factory=list)
    """Alarms whose sensor's fault and that of another sensor, whose own residual had no
    data then, explain alike (the equivalent model's law 0 with blind residuals): their
    onset in seconds, the alarming sensor(s) and those blind sensors."""


class Detector(Protocol):
    """A detector: ``name`` is its registry key (used by ``--detectors``).

    Optionally also ``estimate_warmup(model, j) -> int | None`` and ``estimate(model,
    rows, start, j) -> FloatArray``: the run's ``reference`` of column ``j`` computed again
    over ``rows[start:]`` of other readings (``rows[:start]``, up to the warm-up, as its
    history), with the model as fitted; ``--corrected`` regenerates a sensor from it with
    the other sensors' faults taken out (:func:`analyzer.regenerate.corrected_values`)."""

    name: ClassVar[str]

    def applicable(self, data: Dataset, context: RunContext) -> str | None:
        """None when the detector's needs are met, else a one-line reason it cannot run
        (used to skip it when ``--detectors`` is not given, and as the error otherwise)."""
        ...

    def fit(self, data: Dataset, context: RunContext) -> Any:
        """Learn from ``data.train_values()`` only; return a frozen fitted model."""
        ...

    def run(self, model: Any, data: Dataset, context: RunContext) -> DetectorResult:
        """Apply the fitted model to the whole archive."""
        ...


def dilate_forward(mask: npt.NDArray[np.bool_], n: int) -> npt.NDArray[np.bool_]:
    """True wherever ``mask`` was True within the previous ``n`` samples (the samples a
    filter that settles in ``n`` samples still remembers a gap in); ``mask`` itself when
    it holds no True."""
    if not mask.any():
        return mask
    c = np.cumsum(np.concatenate(([0], mask.astype(np.int64))))
    k = np.arange(mask.shape[0])
    lo = np.maximum(0, k - n)
    return (c[k + 1] - c[lo]) > 0
