"""Report figures described as jobs: which drawing function, with which arguments.

The view layer (:mod:`analyzer.report.view`) does not draw: it describes each figure as a
:class:`FigureJob` (the name of a function of :mod:`analyzer.report.figures` and picklable
arguments: numpy arrays, floats, strings and the small records below) and has them all
drawn together, by worker processes when the CLI started them
(:mod:`analyzer.report.workers`) or here, in this process, in the same order. A figure
depends only on its job (fixed style, fixed SVG hash salt, ids prefixed by the job's
key), so where it is drawn does not change a byte of the page.

This module imports neither matplotlib nor the figures module: a process that has its
figures drawn elsewhere never pays for matplotlib's import (about 0.7 s).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

FIGURES_MODULE = "analyzer.report.figures"
"""The module whose functions draw the figures (imported only where a figure is drawn)."""
PRELOAD_MODULE = "analyzer.report.preload"
"""What fork servers preload: :data:`FIGURES_MODULE`, without stopping on its errors."""
MAX_POINTS = 1000
"""Envelope bins per plotted series (a browser draws this many instantly)."""

ONSET_LABEL = "onset"
"""The onset line's legend where the onset is where the fault began."""
ONSET_BOUND_LABEL = "onset: at or before"
"""The onset line's legend where the onset is only an upper bound (the fault was there
when a search began after the training window or after a stretch)."""
FROM_START_LABEL = "from the start (not judged before)"
"""The onset line's legend for a fault there when the detectors could first judge the
record (evidence ``onset_at_or_before``: ``--model``'s offset from the first sample,
found at 4.31 s, the end of the filters' warm-up): the words of the report's table,
``from the start (not judged before 4.310 s)``, and of ``analyzer run``'s last line."""
OPEN_FAULT_LABEL = "may have begun (not judged)"
"""The legend of the span before an onset that is not where the fault began, a span not
judged (the start of the record, or a stretch left out), where it may already have
been; it read "(onset at or before)" beside a table's "from the start"."""


@dataclass(slots=True)
class CoverageRow:
    """One channel of the timeline: covered span and gaps in seconds from the start,
    fault periods, and ``open_faults``: the spans before an onset that is only an upper
    bound, where the fault may already have been (drawn hatched)."""

    name: str
    start_s: float
    end_s: float
    analyzed: bool
    gaps: list[tuple[float, float]] = field(default_factory=list)
    faults: list[tuple[float, float]] = field(default_factory=list)
    open_faults: list[tuple[float, float]] = field(default_factory=list)


START_UP_SHARE = 1 / 3
"""A whole-record residual's axis is scaled without the filters' start-up transient when
the transient would take more than this share of it (:func:`settled_limits`)."""


def settled_limits(
    t: FloatArray, lo: FloatArray, hi: FloatArray, settled_s: float
) -> tuple[float, float] | None:
    """The y-limits of a whole-record residual (``t``, ``lo``, ``hi``: its envelope) from
    its samples after ``settled_s`` (its filters' start-up, from the record's first
    sample), when the samples before it would otherwise take more than
    :data:`START_UP_SHARE` of the axis; else None (the axis as drawn). The filters start
    from a zero state: a residual of 1.0 at the first sample beside a fault's 0.03 (a
    ROS 2 bag's battery voltage) left the fault a flat line on the axis."""
    if not settled_s > 0:
        return None
    after = t >= settled_s
    a_lo, a_hi = lo[after], hi[after]
    a_lo, a_hi = a_lo[np.isfinite(a_lo)], a_hi[np.isfinite(a_hi)]
    b_lo, b_hi = lo[~after], hi[~after]
    b_lo, b_hi = b_lo[np.isfinite(b_lo)], b_hi[np.isfinite(b_hi)]
    if not (a_lo.size and a_hi.size and b_lo.size and b_hi.size):
        return None
    bottom, top = float(a_lo.min()), float(a_hi.max())
    whole = max(top, float(b_hi.max())) - min(bottom, float(b_lo.min()))
    if not whole > 0 or (top - bottom) > (1.0 - START_UP_SHARE) * whole:
        return None
    pad = 0.08 * (top - bottom) if top > bottom else 0.08 * (abs(top) or 1.0)
    return bottom - pad, top + pad


@dataclass(slots=True)
class ResidualPanel:
    """One detector's residual over the zoom window and its detection threshold: the
    ``window``-sample moving mean alarms outside ``center +- half_band`` (the window
    whose test raised the alarm, where it was a mean's). ``alarm_s``: the detector's
    first alarm (s), marked on the panel. ``rms_window``: where the alarm was raised by
    the mean-square test, its window, whose moving RMS about ``center`` is drawn with
    its bound ``rms_bound``."""

    detector: str
    t: FloatArray
    residual: FloatArray
    center: float | None = None
    half_band: float | None = None
    window: int | None = None
    alarm_s: float | None = None
    rms_window: int | None = None
    rms_bound: float | None = None


@dataclass(slots=True)
class Segment:
    """A standardized residual segment (before or after the onset) and its test dict."""

    name: str
    t: FloatArray
    z: FloatArray
    tests: dict[str, Any] | None


@dataclass(frozen=True, slots=True)
class FigureJob:
    """One figure to draw: ``figures.<figure>(*args, **kwargs)``, an inline SVG string.

    The function is named rather than referenced so that describing a job does not
    import matplotlib, and so that the job pickles to a worker process as its arguments
    only."""

    figure: str
    args: tuple[Any, ...]
    kwargs: dict[str, Any] = field(default_factory=dict)


CLOSE_MIN_POINTS = 4
"""Fewest samples for the signal figure's close-up panel of the onset (a slow record
has none within the close-up's half-minute: the panel is then not drawn)."""


def close_up(t: FloatArray, onset_s: float, close_s: float | None) -> npt.NDArray[np.bool_] | None:
    """Which samples at times ``t`` the signal figure's close-up of ``onset_s +- close_s``
    shows, or None when that panel is not drawn: the figure and its caption (the view
    layer) decide alike."""
    if close_s is None or not t.size:
        return None
    near = (t >= onset_s - close_s) & (t <= onset_s + close_s)
    return near if int(np.count_nonzero(near)) >= CLOSE_MIN_POINTS else None


def draw(job: FigureJob) -> str:
    """The SVG of ``job``, drawn in this process (the function worker processes run)."""
    figures = importlib.import_module(FIGURES_MODULE)
    return str(getattr(figures, job.figure)(*job.args, **job.kwargs))


__all__ = [
    "CLOSE_MIN_POINTS",
    "FIGURES_MODULE",
    "FROM_START_LABEL",
    "PRELOAD_MODULE",
    "MAX_POINTS",
    "ONSET_BOUND_LABEL",
    "ONSET_LABEL",
    "OPEN_FAULT_LABEL",
    "CoverageRow",
    "FigureJob",
    "ResidualPanel",
    "Segment",
    "close_up",
    "draw",
]
