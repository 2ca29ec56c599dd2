"""The report's figures, drawn from arrays the view layer slices out of the analysis.

The view layer describes each figure as a job (:mod:`analyzer.report.jobs`: this module's
function name and its arguments), drawn in a worker process or in-process; the records
the functions take (:class:`CoverageRow`, :class:`ResidualPanel`, :class:`Segment`) live
there too, so describing a figure does not import matplotlib.

Every series goes through :func:`analyzer.report.decimate.envelope` first (the view
decimates the whole-record residual itself before shipping it), so a figure holds at
most a few thousand points whatever the archive's length. Conventions follow
the seed papers' figures: the identified onset is a vertical line (red, dashed), the end
another (purple, dash-dot); the healthy training window is shaded green.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import matplotlib as mpl
import numpy as np
import numpy.typing as npt
from markupsafe import Markup
from matplotlib.axes import Axes
from matplotlib.patches import Patch
from scipy import special

from analyzer.report import format as fmt
from analyzer.report.decimate import Envelope, envelope, moving_mean
from analyzer.report.jobs import (
    MAX_POINTS,
    ONSET_LABEL,
    OPEN_FAULT_LABEL,
    CoverageRow,
    ResidualPanel,
    Segment,
    close_up,
    settled_limits,
)
from analyzer.report.svg import (
    grid,
    label,
    new_figure,
    shown_name,
    shown_names,
    style,
    text_width_in,
    to_svg,
)
from analyzer.timeutil import short_seconds
from analyzer.what_to_check import unit_of

FloatArray = npt.NDArray[np.float64]

PROB_POINTS = 200
"""Quantiles shown in a normal probability plot."""
MIN_MARK = 0.003
"""Narrowest gap or fault mark in the coverage timeline, as a fraction of the record."""
WIDTH_IN = 9.0

C_MEASURED = "#1f4e79"
C_ESTIMATE = "#e07b00"
C_CORRECTED = "#2e7d32"
C_RESIDUAL = "#7f7f7f"
C_MEAN = "#111111"
C_BAND = "#d62728"
C_ONSET = "#c00000"
C_END = "#7030a0"
C_TRAIN = "#2ca02c"
C_GAP = "#d62728"
C_COVER = "#4f81bd"
C_FAULT = "#ff9f1c"
C_RMS = "#6a3d9a"


@dataclass(frozen=True, slots=True)
class TimeAxis:
    """Seconds shown in a readable unit: ``x_display = seconds / scale``."""

    unit: str
    scale: float

    @classmethod
    def for_span(cls, span_s: float) -> TimeAxis:
        """The axis for a plotted span of ``span_s`` seconds (:func:`format.time_unit`)."""
        return cls(*fmt.time_unit(span_s))

    @classmethod
    def for_times(cls, t: FloatArray) -> TimeAxis:
        """The axis for the times ``t`` (seconds, sorted)."""
        return cls.for_span(float(t[-1] - t[0])) if t.size else cls("s", 1.0)

    def label(self) -> str:
        return f"time from start ({self.unit})"


def _plot_series(
    ax: Axes, t: FloatArray, y: FloatArray, axis: TimeAxis, color: str, name: str, lw: float = 0.8
) -> None:
    """A line, or its min/max envelope as a filled band when decimated."""
    _plot_envelope(ax, envelope(t, y, MAX_POINTS), axis, color, name, lw)


def _plot_envelope(
    ax: Axes, env: Envelope, axis: TimeAxis, color: str, name: str, lw: float = 0.8
) -> None:
    """:func:`_plot_series` of a series already decimated to ``MAX_POINTS`` bins."""
    x = env.t / axis.scale
    if env.decimated:
        # the outline keeps a flat stretch (lo == hi, e.g. a stuck sensor) visible
        ax.fill_between(
            x,
            env.lo,
            env.hi,
            facecolor=color,
            edgecolor=color,
            alpha=0.7,
            lw=0.4,
            label=label(name),
        )
    else:
        ax.plot(x, env.lo, color=color, lw=lw, label=label(name))


def _plot_statistic(
    ax: Axes, t: FloatArray, values: FloatArray, axis: TimeAxis, color: str, label: str
) -> None:
    """A moving statistic of a residual panel (its mean, its RMS) as one line through
    the middle of its envelope (:func:`envelope`: at most :data:`MAX_POINTS` drawn)."""
    env = envelope(t, values, MAX_POINTS)
    ax.plot(env.t / axis.scale, 0.5 * (env.lo + env.hi), color=color, lw=1.0, label=label)


def _mark_onset(
    ax: Axes, onset_s: float, end_s: float | None, axis: TimeAxis, label: str = ONSET_LABEL
) -> None:
    """The onset (red, dashed) and the end (purple, dash-dot); ``label``: the onset's
    legend (:data:`ONSET_LABEL`, :data:`ONSET_BOUND_LABEL`, :data:`FROM_START_LABEL`)."""
    ax.axvline(onset_s / axis.scale, color=C_ONSET, ls="--", lw=1.2, label=label)
    if end_s is not None:
        ax.axvline(end_s / axis.scale, color=C_END, ls="-.", lw=1.2, label="end")


def _legend(
    ax: Axes, ncols: int = 5, inside: Literal["upper left", "upper right"] | None = None
) -> None:
    """Legend above the axes, right-aligned (titles are left-aligned), so it never hides
    data; or ``inside`` at that location for the small test panels."""
    handles, _ = ax.get_legend_handles_labels()
    if not handles:
        return
    if inside is not None:
        ax.legend(loc=inside, framealpha=0.85, ncols=1)
    else:
        ax.legend(
            loc="lower right",
            bbox_to_anchor=(1.0, 1.0),
            ncols=ncols,
            frameon=False,
            borderaxespad=0.1,
            columnspacing=1.2,
            handlelength=1.6,
        )


# -- archive overview -------------------------------------------------------------------


def coverage_figure(
    rows: Sequence[CoverageRow],
    duration_s: float,
    train: tuple[float, float],
    key: str,
    train_label: str = "training window",
) -> Markup:
    """Every channel's coverage as a bar, gaps in red, fault periods in orange, the
    training window (``train_label``: with ``--model``, the filters' warm-up) shaded."""
    axis = TimeAxis.for_span(duration_s)
    n = len(rows)
    names = [label(n) for n in shown_names([r.name for r in reversed(rows)])]
    with style():
        fig = new_figure(WIDTH_IN, 0.9 + 0.24 * max(n, 1), constrained=False)
        # fixed margins instead of a constrained layout (which draws the figure twice):
        # the longest channel name, the tick (3.5 pt) and its pad (3.5 pt) on the left;
        # the one-row legend above; tick labels and the axis label below
        size = float(mpl.rcParams["ytick.labelsize"])
        widest = max((text_width_in(t, size) for t in names), default=0.0)
        ax = grid(fig, 1, left=widest + 11.0 / 72.0, right=0.2, top=0.32, bottom=0.45)[0, 0]
        ax.axvspan(
            train[0] / axis.scale,
            train[1] / axis.scale,
            color=C_TRAIN,
            alpha=0.15,
            lw=0,
            label=train_label,
        )
        min_w = MIN_MARK * max(duration_s, 1e-9)  # a one-sample gap must still show
        for i, r in enumerate(rows):
            y = n - 1 - i
            color = C_COVER if r.analyzed else "#b0b0b0"
            ax.broken_barh(
                [(r.start_s / axis.scale, (r.end_s - r.start_s) / axis.scale)],
                (y - 0.32, 0.64),
                color=color,
                lw=0,
            )
            if r.gaps:
                ax.broken_barh(
                    [(a / axis.scale, max(b - a, min_w) / axis.scale) for a, b in r.gaps],
                    (y - 0.4, 0.8),
                    color=C_GAP,
                    lw=0,
                )
            if r.faults:
                ax.broken_barh(
                    [(a / axis.scale, max(b - a, min_w) / axis.scale) for a, b in r.faults],
                    (y - 0.18, 0.36),
                    color=C_FAULT,
                    lw=0,
                )
            if r.open_faults:
                ax.broken_barh(
                    [(a / axis.scale, max(b - a, min_w) / axis.scale) for a, b in r.open_faults],
                    (y - 0.18, 0.36),
                    facecolor="none",
                    edgecolor=C_FAULT,
                    hatch="////",
                    lw=0.8,
                )
        ax.set_yticks(range(n), names)
        ax.set_ylim(-0.7, n - 0.3)
        first = min([0.0, *[r.start_s for r in rows]])  # channels may start before the clock
        last = max([duration_s, *[r.end_s for r in rows]])
        ax.set_xlim(first / axis.scale, max(last, first + 1e-9) / axis.scale)
        ax.set_xlabel(axis.label())
        ax.grid(axis="y", visible=False)
        handles = [
            Patch(color=C_COVER, label="analyzed"),
            Patch(color="#b0b0b0", label="not analyzed"),
            Patch(color=C_GAP, label="gap"),
            Patch(color=C_FAULT, label="fault period"),
            Patch(color=C_TRAIN, alpha=0.15, label=train_label),
        ]
        if any(r.open_faults for r in rows):
            handles.insert(
                4, Patch(facecolor="none", edgecolor=C_FAULT, hatch="////", label=OPEN_FAULT_LABEL)
            )
        ax.legend(
            handles=handles,
            loc="lower center",
            bbox_to_anchor=(0.5, 1.0),
            ncols=len(handles),
            frameon=False,
        )
        return to_svg(fig, key)


LEVEL_RANGE = 8.0
"""The level figure's colours run from 1/8 to 8 times the reference level (log scale)."""


def level_figure(
    names: Sequence[str],
    edges_s: FloatArray,
    ratio: FloatArray,
    train: tuple[float, float],
    faults: Sequence[Sequence[tuple[float, float]]],
    key: str,
    open_faults: Sequence[Sequence[tuple[float, float]]] = (),
    train_label: str = "training window",
) -> Markup:
    """Each channel's response level over time as a colour map: ``ratio`` (bins x
    channels) is a bin's RMS over the channel's reference RMS, drawn on a log scale from
    1/:data:`LEVEL_RANGE` (blue) through 1 (white) to :data:`LEVEL_RANGE` (red), empty
    bins grey; ``faults`` (per channel) outlined in black, ``open_faults`` (the spans
    before an onset that is only an upper bound) dashed, the training window
    (``train_label``: with ``--model``, the filters' warm-up, as the other figures call it)
    marked above the map."""
    m = len(names)
    axis = TimeAxis.for_span(float(edges_s[-1]))
    shown = [label(n) for n in shown_names(list(names))]
    with style():
        fig = new_figure(WIDTH_IN, 1.1 + 0.22 * max(m, 1), constrained=False)
        size = float(mpl.rcParams["ytick.labelsize"])
        widest = max((text_width_in(t, size) for t in shown), default=0.0)
        ax = grid(fig, 1, left=widest + 11.0 / 72.0, right=1.1, top=0.32, bottom=0.45)[0, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            logs = np.log2(np.asarray(ratio, dtype=np.float64).T)
        image = ax.imshow(
            np.ma.masked_invalid(logs),
            aspect="auto",
            interpolation="nearest",
            cmap=mpl.colormaps["RdBu_r"].with_extremes(bad="#b0b0b0"),
            vmin=-np.log2(LEVEL_RANGE),
            vmax=np.log2(LEVEL_RANGE),
            extent=(edges_s[0] / axis.scale, edges_s[-1] / axis.scale, m - 0.5, -0.5),
        )
        for ls, per_channel in (("-", faults), ("--", open_faults)):
            for i, spans in enumerate(per_channel):
                for a, b in spans:
                    ax.add_patch(
                        mpl.patches.Rectangle(
                            (a / axis.scale, i - 0.45),
                            max(b - a, MIN_MARK * float(edges_s[-1])) / axis.scale,
                            0.9,
                            fill=False,
                            ec="black",
                            ls=ls,
                            lw=1.0,
                        )
                    )
        ax.plot(
            [train[0] / axis.scale, train[1] / axis.scale],
            [-0.5, -0.5],
            color=C_TRAIN,
            lw=4,
            solid_capstyle="butt",
            clip_on=False,
            label=train_label,
        )
        ax.set_yticks(range(m), shown)
        ax.set_xlabel(axis.label())
        ax.grid(visible=False)
        bar = fig.colorbar(image, ax=ax, fraction=0.04, pad=0.02)
        top = int(round(np.log2(LEVEL_RANGE)))
        ticks = [float(t) for t in range(-top, top + 1)]
        bar.set_ticks(ticks, labels=[f"{2.0**t:g}" if t >= 0 else f"1/{2.0**-t:g}" for t in ticks])
        bar.set_label("level / reference")
        handles = [
            Patch(color=C_TRAIN, label=train_label),
            Patch(fill=False, ec="black", label="fault period"),
        ]
        if any(open_faults):
            handles.append(Patch(fill=False, ec="black", ls="--", label=OPEN_FAULT_LABEL))
        ax.legend(
            handles=handles,
            loc="lower center",
            bbox_to_anchor=(0.5, 1.0),
            ncols=len(handles),
            frameon=False,
        )
        return to_svg(fig, key)


# -- per finding ------------------------------------------------------------------------


def value_label(channel: str) -> str:
    """A value axis's label: the unit ``channel``'s name ends in (``m/s2`` of
    ``s2 (m/s2)``), else "channel units"."""
    return unit_of(channel) or "channel units"


def signal_figure(
    t: FloatArray,
    measured: FloatArray,
    estimate: FloatArray | None,
    estimate_name: str,
    onset_s: float,
    end_s: float | None,
    channel: str,
    key: str,
    close_s: float | None = None,
    limits: Sequence[float] = (),
    onset_label: str = ONSET_LABEL,
    units: str = "",
) -> Markup:
    """The measured signal around the onset with the detector's fault-free estimate (the
    gap between them is the estimated fault). With ``close_s``, a second panel shows
    ``onset +- close_s`` closely enough to see the waveforms (shaded grey above).
    ``limits``: the values a clipping sensor's readings pile up at, drawn as dotted lines.
    ``onset_label``: the onset line's legend (:func:`_mark_onset`)."""
    axis = TimeAxis.for_times(t)
    close = close_up(t, onset_s, close_s)
    with style():
        fig = new_figure(WIDTH_IN, 3.0 if close is None else 5.6, constrained=False)
        axes = grid(fig, 1 if close is None else 2, top=0.3, hgap=0.55)[:, 0]
        views: list[tuple[Axes, npt.NDArray[np.bool_] | slice]] = [(axes[0], slice(None))]
        if close is not None:
            views.append((axes[1], close))
        for i, (ax, sel) in enumerate(views):
            tt = t[sel]
            _plot_series(ax, tt, measured[sel], axis, C_MEASURED, f"measured {shown_name(channel)}")
            if estimate is not None:
                _plot_series(
                    ax,
                    tt,
                    estimate[sel],
                    axis,
                    C_ESTIMATE,
                    f"fault-free estimate ({shown_name(estimate_name)})",
                )
            _mark_onset(ax, onset_s, end_s, axis, onset_label)
            for k, level in enumerate(limits):
                ax.axhline(
                    level,
                    color="#555555",
                    lw=0.9,
                    ls=":",
                    label="clipping limit" if k == 0 else None,
                )
            if tt.size:
                ax.set_xlim(tt[0] / axis.scale, tt[-1] / axis.scale)
            ax.set_ylabel(units or value_label(channel))
            if i == 0:
                _legend(ax)
                if close is not None and close_s is not None:
                    ax.axvspan(
                        (onset_s - close_s) / axis.scale,
                        (onset_s + close_s) / axis.scale,
                        color="#000000",
                        alpha=0.06,
                        lw=0,
                    )
            else:
                ax.set_title(f"close-up: onset ± {short_seconds(close_s or 0.0)} s", loc="left")
        axes[-1].set_xlabel(axis.label())
        return to_svg(fig, key)


def corrected_figure(
    t: FloatArray,
    measured: FloatArray,
    corrected: FloatArray,
    onset_s: float,
    end_s: float | None,
    channel: str,
    key: str,
    onset_label: str = ONSET_LABEL,
    units: str = "",
) -> Markup:
    """Measured and corrected signal (fault removed, Wang & Song 2014, Section 6.3);
    ``onset_label``: the onset line's legend (:func:`_mark_onset`)."""
    axis = TimeAxis.for_times(t)
    with style():
        fig = new_figure(WIDTH_IN, 2.6, constrained=False)
        ax = grid(fig, 1, top=0.3)[0, 0]
        _plot_series(ax, t, measured, axis, C_MEASURED, f"measured {shown_name(channel)}")
        _plot_series(ax, t, corrected, axis, C_CORRECTED, "corrected")
        _mark_onset(ax, onset_s, end_s, axis, onset_label)
        if t.size:
            ax.set_xlim(t[0] / axis.scale, t[-1] / axis.scale)
        ax.set_xlabel(axis.label())
        ax.set_ylabel(units or value_label(channel))
        _legend(ax)
        return to_svg(fig, key)


def residual_figure(
    overview: Envelope,
    overview_name: str,
    panels: Sequence[ResidualPanel],
    onset_s: float,
    end_s: float | None,
    train: tuple[float, float],
    duration_s: float,
    key: str,
    train_label: str = "training window",
    onset_label: str = ONSET_LABEL,
    settled_s: float = 0.0,
    units: str = "channel units",
) -> Markup:
    """Top: the leading detector's residual over the whole archive with the training
    window (``train_label``) and the onset; ``overview`` is its ``envelope(t, r,
    MAX_POINTS)``, computed by the caller (a 4-hour record at 100 Hz is 1.44 M samples:
    their envelope is what this figure would draw anyway, and it ships to a worker
    process in 24 kB); its axis scaled from the samples after ``settled_s``, its filters'
    start-up, where the transient before would flatten the rest (:func:`settled_limits`;
    the start-up shaded grey and hatched, the transient clipped). Below, per detector
    that saw the fault: its residual around the onset, its moving mean and the threshold
    band that mean must leave (of the window whose test raised the alarm, as the caller
    chose it), the moving RMS and its bound where the mean-square test raised the alarm
    (purple), and its first alarm (black, dotted). ``onset_label``: the onset line's legend
    (:func:`_mark_onset`)."""
    # one unit on every panel, the whole record's: the SKAB record's top panel read
    # minutes (onset at 12.0) above panels in seconds (onset at 719)
    axis = TimeAxis.for_span(duration_s)
    with style():
        # (up to three legend lines above each detector's panel: residual, mean, band,
        # RMS, its bound, onset and first alarm do not fit beside its title on one)
        fig = new_figure(WIDTH_IN, 2.3 + 2.35 * len(panels), constrained=False)
        axes = grid(fig, 1 + len(panels), top=0.3, hgap=1.2)[:, 0]
        ax = axes[0]
        ax.axvspan(
            train[0] / axis.scale,
            train[1] / axis.scale,
            color=C_TRAIN,
            alpha=0.15,
            lw=0,
            label=train_label,
        )
        _plot_envelope(ax, overview, axis, C_RESIDUAL, f"residual ({shown_name(overview_name)})")
        limits = settled_limits(overview.t, overview.lo, overview.hi, settled_s)
        if limits is not None:
            ax.set_ylim(*limits)
            ax.axvspan(
                0.0,
                settled_s / axis.scale,
                facecolor="#888888",
                edgecolor="#555555",
                alpha=0.18,
                hatch="//",
                lw=0,
                label="filters' start-up (clipped)",
            )
        _mark_onset(ax, onset_s, end_s, axis, onset_label)
        ax.set_xlim(0, max(duration_s, 1e-9) / axis.scale)
        ax.set_title("whole record", loc="left")
        ax.set_ylabel(units)
        ax.set_xlabel(axis.label())
        _legend(ax)
        for ax, p in zip(axes[1:], panels, strict=True):
            _plot_series(ax, p.t, p.residual, axis, C_RESIDUAL, "residual")
            if p.window and p.window > 1:
                mm = moving_mean(p.residual, p.window)
                _plot_statistic(ax, p.t, mm, axis, C_MEAN, f"{p.window}-sample moving mean")
            if p.center is not None and p.half_band is not None:
                ax.axhspan(
                    p.center - p.half_band,
                    p.center + p.half_band,
                    color=C_BAND,
                    alpha=0.12,
                    lw=0,
                    label="no-alarm band of the mean",
                )
                for s in (-1.0, 1.0):
                    ax.axhline(p.center + s * p.half_band, color=C_BAND, lw=0.8, ls=":")
            if p.rms_window and p.rms_bound is not None and p.center is not None:
                rms = np.sqrt(moving_mean((p.residual - p.center) ** 2, p.rms_window))
                _plot_statistic(ax, p.t, rms, axis, C_RMS, f"{p.rms_window}-sample RMS")
                ax.axhline(p.rms_bound, color=C_RMS, lw=0.9, ls="--", label="bound of the RMS")
            _mark_onset(ax, onset_s, end_s, axis, onset_label)
            if p.alarm_s is not None:
                ax.axvline(
                    p.alarm_s / axis.scale,
                    color=C_MEAN,
                    lw=1.0,
                    ls=(0, (1, 1.5)),
                    label="first alarm",
                )
            if p.t.size:
                ax.set_xlim(p.t[0] / axis.scale, p.t[-1] / axis.scale)
            ax.set_title(label(f"{shown_name(p.detector)}: around the onset"), loc="left")
            ax.set_ylabel(units)
            _legend(ax, ncols=3)
        axes[-1].set_xlabel(axis.label())
        return to_svg(fig, key)


def _shewhart(ax: Axes, seg: Segment, what: str, sec: TimeAxis) -> None:
    sh = (seg.tests or {}).get("shewhart", {})
    k = float(sh.get("k") or 3.0)
    _plot_series(ax, seg.t, seg.z, sec, C_MEASURED, "z", lw=0.5)
    for s in (-k, k):
        ax.axhline(s, color=C_BAND, lw=0.9, ls="--")
    finite = seg.z[np.isfinite(seg.z)]
    top = max(k + 1.0, float(np.max(np.abs(finite))) * 1.05) if finite.size else k + 1.0
    ax.axhspan(k, top, color=C_BAND, alpha=0.08, lw=0)
    ax.axhspan(-top, -k, color=C_BAND, alpha=0.08, lw=0)
    ax.set_ylim(-top, top)
    ax.axhline(0.0, color="#555555", lw=0.6)
    count, n = sh.get("count"), sh.get("n")
    sub = f"{count} of {n} beyond ±{k:g}" if count is not None and n else ""
    ax.set_title(label(f"{shown_name(seg.name)}: Shewhart chart\n{sub}"), loc="left")
    ax.set_xlabel(sec.label())
    ax.set_ylabel(f"{what} z")


def _probability(ax: Axes, seg: Segment) -> None:
    z = seg.z[np.isfinite(seg.z)]
    ax.set_title("normal probability plot", loc="left")
    ax.set_xlabel("standard normal quantile")
    ax.set_ylabel("ordered z")
    if z.size < 3:
        return
    zs = np.sort(z)
    n = zs.size
    pick = np.unique(np.round(np.linspace(0, n - 1, min(n, PROB_POINTS))).astype(np.int64))
    # Blom plotting positions, strictly inside (0, 1): their normal quantiles are ndtri's
    # (what scipy.stats.norm.ppf returns there, without importing scipy.stats)
    q = special.ndtri((pick + 1 - 0.375) / (n + 0.25))
    ax.plot(q, zs[pick], ".", ms=3, color=C_MEASURED, label="data")
    lim = float(np.max(np.abs(q)))
    ax.plot([-lim, lim], [-lim, lim], color=C_BAND, lw=1.0, label="N(0, 1)")
    _legend(ax, inside="upper left")


def _acf(ax: Axes, seg: Segment) -> None:
    wh = (seg.tests or {}).get("whiteness", {})
    acf = np.asarray([np.nan if v is None else v for v in wh.get("acf") or []], dtype=float)
    band = wh.get("band")
    ax.set_title("autocorrelation", loc="left")
    ax.set_xlabel("lag (samples)")
    ax.set_ylabel("r(lag)")
    if acf.size:
        lags = np.arange(1, acf.size + 1)
        ax.vlines(lags, 0.0, acf, color=C_MEASURED, lw=1.6)
        ax.plot(lags, acf, "o", ms=2.5, color=C_MEASURED)
    if band is not None:
        ax.axhspan(-band, band, color=C_BAND, alpha=0.12, lw=0, label="±1.96/√N")
        ax.axhline(band, color=C_BAND, lw=0.8, ls="--")
        ax.axhline(-band, color=C_BAND, lw=0.8, ls="--")
    ax.axhline(0.0, color="#555555", lw=0.6)
    ax.set_ylim(min(-0.2, float(np.nanmin(acf)) - 0.05) if acf.size else -1, 1.05)
    _legend(ax, inside="upper right")


def tests_figure(
    segments: Sequence[Segment], detector: str, key: str, what: str = "standardized residual"
) -> Markup:
    """Seed 003's innovation tests, one row per segment (before / after the onset):
    Shewhart chart with the +-k limits, normal probability plot against N(0, 1), and the
    autocorrelation with its 95 % white-noise band. ``what`` the segments are, for the
    title and the axis: the whitened residual where the evidence has a whitening (the
    tests ran on it, and it is what the view hands in), else the standardized one."""
    with style():
        fig = new_figure(WIDTH_IN, 2.6 * max(1, len(segments)) + 0.3, constrained=False)
        axes = grid(
            fig,
            max(1, len(segments)),
            3,
            top=0.75,
            hgap=1.05,
            wgap=0.75,
            width_ratios=[1.6, 1.0, 1.0],
        )
        # one time unit for the segments' charts, the longest's (a short stretch before
        # the onset read seconds above one of hours after it)
        spans = [float(s.t[-1] - s.t[0]) for s in segments if s.t.size]
        sec = TimeAxis.for_span(max(spans, default=0.0))
        for row, seg in zip(axes, segments, strict=False):
            _shewhart(row[0], seg, what, sec)
            _probability(row[1], seg)
            _acf(row[2], seg)
        fig.suptitle(
            label(f"{what} of {shown_name(detector)}"),
            x=0.01,
            ha="left",
            fontsize=9.5,
        )
        return to_svg(fig, key)


__all__ = [
    "MAX_POINTS",
    "CoverageRow",
    "ResidualPanel",
    "Segment",
    "TimeAxis",
    "corrected_figure",
    "coverage_figure",
    "level_figure",
    "residual_figure",
    "value_label",
    "signal_figure",
    "tests_figure",
]
