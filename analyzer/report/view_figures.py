"""The figures of the report's view: each finding's signal, residual, innovation-test
and corrected-signal figures, and the channel coverage timeline.

:class:`FigureParts` is the figure-building part of the view's access object
(:class:`analyzer.report.view._Access` inherits it): it slices the arrays behind each
figure out of the analysis (aligned values, residuals, fault-free estimates), decimates
what is long, describes the figure as a job (:mod:`analyzer.report.jobs`) and hands it to
the view's :class:`~analyzer.report.workers.FigureBatch`; :meth:`FigureParts.draw_figures`
fills the SVGs in at the end. It is apart from the text and the tables because it is the
part that handles arrays (numpy, the decimation, the figure jobs); like the rest of the
view it does not import matplotlib.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
from markupsafe import Markup

from analyzer.diagnosis.evidence import Whitening, standardized, whitened_part
from analyzer.diagnosis.levels import response_levels
from analyzer.report import format as fmt
from analyzer.report import jobs as fg
from analyzer.report.decimate import Clock, binned_nan_fraction, envelope, runs
from analyzer.report.view_records import FigureView, FindingView
from analyzer.report.workers import FigureBatch
from analyzer.timeutil import seconds_text, short_seconds
from analyzer.types import NS_PER_S

FloatArray = npt.NDArray[np.float64]

MAX_PANELS = 4
"""Detector panels in a finding's residual figure."""
MAX_TIMELINE_ROWS = 60
"""Channels drawn in the coverage timeline (analyzed channels first)."""
CLOSE_SAMPLES, CLOSE_MIN_S, CLOSE_MAX_S = 200, 1.0, 30.0
"""Close-up of the onset in the signal figure: this many samples, within bounds (s)."""
GAP_BINS = 2000
"""Time bins of the gap map of the analyzed channels."""
ZOOM_MIN_S, ZOOM_MAX_S, ZOOM_FRACTION = 5.0, 120.0, 0.15
"""Half-width of the window around an onset: this fraction of the record, within bounds."""


class FigureParts:
    """The figures of a view (see the module doc), a base of
    :class:`analyzer.report.view._Access`, whose ``__init__`` sets the state declared
    here."""

    an: Any
    doc: Mapping[str, Any]
    units: dict[str, str]
    batch: FigureBatch
    pending: list[tuple[FigureView, int]]
    rate: float
    duration: float
    analyzed: tuple[str, ...]
    values: Any
    n: int
    results: dict[Any, Any]
    train_s: tuple[float, float]
    train_label: str
    reused: bool

    if TYPE_CHECKING:  # in TableParts (analyzer.report.view_tables)

        def _start_ns(self) -> int: ...

    # -- figures of one finding -----------------------------------------------------------
    def figure(self, kind: str, title: str, caption: str, job: fg.FigureJob) -> FigureView:
        """A figure whose SVG :meth:`draw_figures` fills in (its job is drawing meanwhile
        when there are workers)."""
        fv = FigureView(kind, title, caption, Markup(""))
        self.pending.append((fv, self.batch.add(job)))
        return fv

    def draw_figures(self) -> list[str]:
        """Fill in every pending figure; one line for each that could not be drawn."""
        svgs = self.batch.results()
        failed = []
        for fv, i in self.pending:
            fv.svg = svgs[i]
            if i in self.batch.failures:
                failed.append(
                    f"report: the figure '{fv.title}' could not be drawn "
                    f"({self.batch.failures[i]}); the page shows that line in its place"
                )
        self.pending.clear()
        return failed

    def add_figures(self, view: FindingView, f: Mapping[str, Any]) -> None:
        ch = str(f["channel"])
        onset = float(f["onset_s"])
        end = None if f.get("end_s") is None else float(f["end_s"])
        bound = onset_bound(f)  # onset_s an upper bound: the line says so
        label = onset_label(f)
        from_start = label == fg.FROM_START_LABEL
        dets = [d for d in view.detectors if self._residual(d, ch) is not None]
        lead = view.lead if view.lead in dets else (dets[0] if dets else None)
        alarm = _alarm_s(((f.get("evidence") or {}).get("by_detector") or {}).get(lead))
        k0, k1 = self._zoom(onset, end, lead, ch, alarm)
        t = np.arange(k0, k1, dtype=np.float64) / self.rate
        key = view.anchor
        measured = self._measured(ch, k0, k1)
        span = float(t[-1] - t[0]) if t.size else 0.0
        if measured is not None:
            est_det = next(
                (d for d in [lead, *dets] if d and self._reference(d, ch) is not None), None
            )
            est = None if est_det is None else self._reference(est_det, ch)
            magnitude = f.get("magnitude") or {}
            limits = [
                float(magnitude[k])
                for k in ("clipped_high", "clipped_low")
                if isinstance(magnitude.get(k), int | float)
            ]
            job = fg.FigureJob(
                "signal_figure",
                (
                    t,
                    measured,
                    None if est is None else _f64(est[k0:k1]),
                    est_det or "",
                    onset,
                    end,
                    ch,
                    f"{key}-signal",
                ),
                {
                    "close_s": self._close_s(),
                    "limits": limits,
                    "onset_label": label,
                    "units": self.units.get(ch) or "channel units",
                },
            )
            view.figures.append(
                self.figure(
                    "signal",
                    "Measured signal and fault-free estimate",
                    f"{ch} around the onset ({fmt.at(t[0] if t.size else 0, span)} to "
                    f"{fmt.at(t[-1] if t.size else 0, span)}): measured (blue) and the fault-free "
                    f"estimate of {est_det or 'no detector'} (orange); their difference is the "
                    "estimated fault. Dashed red line: "
                    + (
                        "the time before which nothing was judged (the fault was there from "
                        "the start: when the search began)"
                        if from_start
                        else "the onset's upper bound (the fault was there when the search "
                        "began, so it began at or before then)"
                        if bound
                        else "identified onset"
                    )
                    + ("; dash-dot purple: end" if end is not None else "")
                    + ("; dotted grey: the limits its readings pile up at" if limits else "")
                    + (
                        ". Below: close-up of the onset (± "
                        f"{short_seconds(self._close_s())} s, shaded "
                        "above)"
                        if fg.close_up(t, onset, self._close_s()) is not None
                        else ""
                    )
                    + "; where a panel holds more samples than it has pixels, the band shows "
                    "each pixel's minimum and maximum.",
                    job,
                )
            )
        else:
            view.remarks.append(f"{ch} is not among the analyzed channels: no signal figure.")
        without = (f.get("evidence") or {}).get("searched_without")
        if lead is not None and without:
            # the second search's residuals are not kept: the first search's, drawn here,
            # lost their view where it found the fault (NaN there), and are not what the
            # tests ran on
            view.figures.append(self._residual_figure(view, f, ch, onset, end, dets, lead, k0, k1))
            view.remarks.append(
                f"Found by the second search, without {', '.join(without)}: its residuals, "
                "which the innovation tests ran on, are not drawn (the residual figure is "
                "the first search's, blind where this fault is); the tests' results are "
                "in findings.json."
            )
        elif lead is not None:
            view.figures.append(self._residual_figure(view, f, ch, onset, end, dets, lead, k0, k1))
            seg_fig = self._tests_figure(view, ch, f, lead)
            if seg_fig is not None:
                view.figures.append(seg_fig)
        else:
            view.remarks.append("No detector residual is available for this channel.")
        corrected = getattr(self.an, "corrected", None)
        if corrected is not None and measured is not None and ch in self.analyzed:
            j = self.analyzed.index(ch)
            job = fg.FigureJob(
                "corrected_figure",
                (t, measured, _f64(corrected[k0:k1, j]), onset, end, ch, f"{key}-corrected"),
                {"onset_label": label, "units": self.units.get(ch) or "channel units"},
            )
            view.figures.append(
                self.figure(
                    "corrected",
                    "Corrected signal",
                    f"{ch} with the regenerated fault removed over the fault period (green), "
                    "against the measured signal (blue); see the correction record below.",
                    job,
                )
            )
        elif corrected is None:
            view.remarks.append(
                "Corrected signal not computed (run with --corrected to include it)."
            )

    def _own_order(self, det: str) -> str:
        """``, apart from the detector's own order-10 model of the signals`` where the
        detector ``det`` has an AR order of its own (findings.json's ``model.order``):
        the whitening filter's order and the Models section's ``order`` then differ, and a
        reader saw "AR(26)" in a caption beside "order 10" with nothing to say why."""
        for r in self.doc.get("detectors", []):
            order = (r.get("model") or {}).get("order") if r.get("name") == det else None
            if isinstance(order, int) and not isinstance(order, bool):
                return f", apart from the detector's own order-{order} model of the signals"
        return ""

    def _residual_figure(
        self,
        view: FindingView,
        f: Mapping[str, Any],
        ch: str,
        onset: float,
        end: float | None,
        dets: list[str],
        lead: str,
        k0: int,
        k1: int,
    ) -> FigureView:
        # lead is in dets: it has a residual on ch (as kept: the envelope reads a long
        # archive's a chunk at a time, no float64 copy of it, nor an array of its times)
        full = np.asarray(self._residual(lead, ch))
        panels, said = [], []
        by_det = (f.get("evidence") or {}).get("by_detector") or {}
        for d in [lead, *[x for x in dets if x != lead]][:MAX_PANELS]:
            r = self._residual(d, ch)
            if r is None:
                continue
            alarm_s = _alarm_s(by_det.get(d))
            crossed = self._alarm_tests(d, ch, alarm_s)
            th = self._threshold(d, ch, _drawn_window(crossed))
            rms = _raised(crossed, "rms")
            panels.append(
                fg.ResidualPanel(
                    d,
                    np.arange(k0, k1) / self.rate,
                    _f64(r[k0:k1]),
                    *th,
                    alarm_s=alarm_s,
                    rms_window=None if rms is None else rms.window,
                    rms_bound=None if rms is None else rms.bound,
                )
            )
            said.append(self._alarm_text(d, alarm_s, crossed, th))
        overview = envelope(Clock(full.shape[0], self.rate), full, fg.MAX_POINTS)  # drawn of it
        # the axis without the filters' start-up transient, where it would flatten the rest
        settled_s = min(getattr(self.an, "settling", {}).get(lead, 0), full.shape[0] // 2)
        settled_s /= self.rate
        clipped = fg.settled_limits(overview.t, overview.lo, overview.hi, settled_s) is not None
        job = fg.FigureJob(
            "residual_figure",
            (
                overview,
                lead,
                panels,
                onset,
                end,
                self.train_s,
                self.duration,
                f"{view.anchor}-residual",
                self.train_label,
            ),
            {
                "onset_label": onset_label(f),
                "settled_s": settled_s if clipped else 0.0,
                "units": self.units.get(ch) or "channel units",
            },
        )
        start_up = (
            f" The top panel's axis is scaled without the filters' start-up transient (the "
            f"first {fmt.duration(settled_s)}, hatched grey), which is drawn clipped."
            if clipped
            else ""
        )
        return self.figure(
            "residual",
            "Residual time history",
            "Residual (measured minus fault-free estimate, "
            f"{self.units.get(ch) or 'channel units'}). "
            "Top: the whole "
            f"record for {lead}, {self.train_label} shaded green. Below: each detector that saw "
            "the fault, around the onset, with the test that raised its alarm: the "
            "trailing moving mean (black) of that window and the band it must leave (red), "
            "or the window's moving RMS about the healthy mean (it rises with a gain "
            "change or any large step) and the bound it must cross (purple, dashed), both "
            "set from the training residual and the false-alarm rate; and its first alarm "
            "(black, dotted). Each detector tests a short and a long window, the long one "
            "for small lasting changes, each with bounds of its own. "
            + " ".join(said)
            + f"{start_up}",
            job,
        )

    def _alarm_tests(self, det: str, ch: str, alarm_s: float | None) -> list[AlarmTest]:
        """The tests of ``det``'s residual on ``ch`` at its first alarm (``alarm_s``),
        largest crossing first (:func:`alarm_tests`); empty when there is no alarm time
        or no thresholds."""
        r = self.results.get(det)
        th = None if r is None else r.thresholds.get(ch)
        res = self._residual(det, ch)
        if alarm_s is None or not isinstance(th, dict) or res is None:
            return []
        return alarm_tests(res, th, int(round(alarm_s * self.rate)))

    def _alarm_text(
        self,
        det: str,
        alarm_s: float | None,
        crossed: Sequence[AlarmTest],
        drawn: tuple[float | None, float | None, int | None],
    ) -> str:
        """One sentence of the residual figure's caption for one detector's panel: when
        it first alarmed and which window's test crossed its bound there (its value and
        the bound, in channel units), and what the panel draws."""
        center, half, window = drawn
        band = (
            f"the {window}-sample ({fmt.duration(window / self.rate)}) moving mean and its "
            f"band {fmt.num(center)} ± {fmt.num(half)}"
            if center is not None and half is not None and window
            else "no band (no thresholds)"
        )
        if alarm_s is None:
            return f"{det}: no alarm time in its evidence; drawn: {band}."
        at = fmt.seconds(alarm_s, 3)
        over = [a for a in crossed if a.ratio >= 1.0 - RATIO_SLACK]
        if not over:
            return (
                f"{det}: first alarm at {at} (dotted), where no window's test of the residual "
                f"drawn crossed its bound (its alarm came from another statistic); drawn: {band}."
            )
        text = f"{det}: first alarm at {at} (dotted), raised by " + " and by ".join(
            a.describe(self.rate) + (" (drawn)" if a is _raised(over, a.kind) else "") for a in over
        )
        if _raised(over, "mean") is None:
            # (the mean's band is drawn too: where the alarm came from the mean square
            # alone, its moving mean had not left it yet)
            text += f"; drawn beside it: {band}, not crossed then"
        return text + "."

    def _tests_figure(
        self, view: FindingView, ch: str, f: Mapping[str, Any], lead: str
    ) -> FigureView | None:
        tests = (f.get("evidence") or {}).get("tests") or {}
        det = lead if lead in tests else next(iter(tests), None)
        if det is None:
            view.remarks.append("No innovation test results (segments too short).")
            return None
        t = tests[det]
        segs = []
        whitened = []
        for name, span_key, test_key in (
            ("before onset", "before_span_s", "before"),
            ("after onset", "after_span_s", "after"),
        ):
            span = t.get(span_key)
            if not span:
                continue
            a = max(0, int(round(float(span[0]) * self.rate)))
            b = min(self.n, int(round(float(span[1]) * self.rate)))
            got = self._standardized(det, ch, a, b, t.get("whitening"))
            if got is None or b <= a:
                continue
            z, white = got
            whitened.append(white)
            segs.append(fg.Segment(name, np.arange(a, b) / self.rate, z, t.get(test_key)))
        if not segs:
            return None
        # the figure's title and axis name what it plots: the whitened residual where
        # there was a whitening (it said "standardized residual" of that too)
        white = all(whitened)
        job = fg.FigureJob(
            "tests_figure",
            (segs, det, f"{view.anchor}-tests"),
            {"what": "whitened residual" if white else "standardized residual"},
        )
        spec = t.get("whitening")
        what = (
            f"Whitened residual of {det} (training mean and deviation removed, then the "
            f"one-step error of a {spec.get('order')}-term whitening filter (an AR model of "
            f"this residual in the training window{self._own_order(det)}), "
            "in units of its healthy deviation: what the tests ran on)"
            if white and isinstance(spec, dict)
            else f"Standardized residual of {det} (training mean and deviation removed)"
        )
        return self.figure(
            "tests",
            "Innovation tests before and after the onset",
            f"{what}, on "
            f"{' and '.join(_span(t.get(k)) for k in SPAN_KEYS if t.get(k))}."
            " Left: Shewhart chart with the ±3 limits (shaded: beyond). Middle: normal "
            "probability plot; a healthy residual follows the red N(0, 1) line. Right: "
            "autocorrelation at the lags tested (1-20; N/20 on a short stretch) with the ±1.96/√N "
            "band of white noise.",
            job,
        )

    # -- array access -------------------------------------------------------------------
    def _residual(self, det: str | None, ch: str) -> Any:
        r = self.results.get(det) if det else None
        return None if r is None else r.residuals.get(ch)

    def _reference(self, det: str, ch: str) -> Any:
        r = self.results.get(det)
        return None if r is None else r.reference.get(ch)

    def _threshold(
        self, det: str, ch: str, i: int = 0
    ) -> tuple[float | None, float | None, int | None]:
        """(center, half-band, window) of the mean test of window ``i`` (0: the short
        one) in channel units: the alarm fires when the window mean of the residual
        leaves ``mean +- mean_threshold[i] * std`` (analyzer.diagnosis.changes)."""
        r = self.results.get(det)
        th = None if r is None else r.thresholds.get(ch)
        if not isinstance(th, dict):
            return None, None, None
        try:
            mean, std = float(th["mean"]), float(th["std"])
            half = float(th["mean_threshold"][i]) * std
            window = int(th["windows"][i])
        except (KeyError, IndexError, TypeError, ValueError):
            return None, None, None
        return mean, half, window

    def _standardized(
        self, det: str, ch: str, a: int, b: int, whitening: Any = None
    ) -> tuple[FloatArray, bool] | None:
        """``(r - mean) / std`` on ``[a, b)``, as analyzer.diagnosis.evidence.standardized
        (the same normalization the tests ran on), whitened by the evidence's
        ``whitening`` when it has one (:func:`analyzer.diagnosis.evidence.whitened_part`);
        and whether it was whitened."""
        r = self.results.get(det)
        if r is None or r.residuals.get(ch) is None:
            return None
        w = Whitening.from_dict(whitening)
        if w is not None and b > a and standardized(r, ch, slice(a, a + 1)) is not None:
            return whitened_part(r, ch, slice(a, b), w), True
        res = r.residuals[ch]
        th = r.thresholds.get(ch, {}) if isinstance(r.thresholds.get(ch), dict) else {}
        mean = float(th.get("mean", 0.0))
        std = float(th.get("std", r.sigma.get(ch, 0.0)))
        if not std > 0:
            std = float(r.sigma.get(ch, 0.0))
        if not std > 0:
            return None
        return (_f64(res[a:b]) - mean) / std, False

    def _measured(self, ch: str, k0: int, k1: int) -> FloatArray | None:
        if self.values is None or ch not in self.analyzed:
            return None
        return _f64(self.values[k0:k1, self.analyzed.index(ch)])

    def _close_s(self) -> float:
        """Half-width of the close-up of the onset: a couple of hundred samples, at
        least a second (a few cycles of a structure's first modes), at most half a minute."""
        return float(min(max(CLOSE_SAMPLES / self.rate, CLOSE_MIN_S), CLOSE_MAX_S))

    def _zoom(
        self, onset: float, end: float | None, det: str | None, ch: str, alarm: float | None = None
    ) -> tuple[int, int]:
        """The samples around the onset the finding's figures show: at least three long
        windows each side, to the end where it is near, and past the leading detector's
        first alarm (``alarm``, s), which a slow drift raises long after its onset."""
        half = min(max(ZOOM_FRACTION * self.duration, ZOOM_MIN_S), ZOOM_MAX_S)
        th = None
        if det and det in self.results:
            th = self.results[det].thresholds.get(ch)
        if isinstance(th, dict) and th.get("windows"):
            half = max(half, 3.0 * float(th["windows"][-1]) / self.rate)
        right = onset + half
        if end is not None and end < onset + 3 * half:
            right = max(right, end + 0.5 * half)
        if alarm is not None and alarm < onset + 3 * half:
            right = max(right, alarm + 0.25 * half)
        k0 = max(0, int(math.floor((onset - half) * self.rate)))
        k1 = min(self.n, int(math.ceil(right * self.rate)) + 1)
        return k0, max(k1, min(self.n, k0 + 2))

    # -- archive overview -------------------------------------------------------------------
    def coverage(self, faults: Sequence[Mapping[str, Any]]) -> tuple[FigureView | None, str]:
        chans = list(getattr(self.an, "channels", []) or [])
        if not chans:
            return None, ""
        start = self._start_ns()
        chans.sort(key=lambda c: c.name not in self.analyzed)
        shown = chans[:MAX_TIMELINE_ROWS]
        gaps = self._gap_map()
        rows = []
        for c in shown:
            a, b = (c.start_ns - start) / NS_PER_S, (c.end_ns - start) / NS_PER_S
            gl = [(max(x, a), min(y, b)) for x, y in gaps.get(c.name, []) if min(y, b) > max(x, a)]
            fl, since = fault_spans(faults, c.name, self.duration)
            rows.append(fg.CoverageRow(c.name, a, b, c.name in self.analyzed, gl, fl, since))
        span = max([self.duration, *[r.end_s for r in rows]])
        job = fg.FigureJob(
            "coverage_figure", (rows, span, self.train_s, "coverage", self.train_label)
        )
        note = ""
        if len(chans) > len(shown):
            note = (
                f"{len(chans) - len(shown)} more channels are not drawn; the channel table "
                "lists them all."
            )
        caption = (
            "Coverage of every channel from its first to its last raw sample (blue: "
            "analyzed, grey: not analyzed), gaps in red (for analyzed channels located "
            f"on the common clock, to within {fmt.duration(self.duration / GAP_BINS)}; "
            "for the others only counted in the table), fault periods in orange, the "
            f"{self.train_label} shaded green"
            + (
                "; hatched: before an onset that is an upper bound (the fault was there when "
                "the search began), where it may already have been"
                if any(r.open_faults for r in rows)
                else ""
            )
            + "."
        )
        return self.figure("coverage", "Channel coverage", caption, job), note

    def levels(self, faults: Sequence[Mapping[str, Any]]) -> FigureView | None:
        """The response-level map of the analyzed channels (:func:`figures.level_figure`,
        :mod:`analyzer.diagnosis.levels`): the run's, else measured here."""
        if self.values is None or not self.analyzed or self.n < 2:
            return None
        lv = getattr(self.an, "levels", None)
        if lv is None:
            k0, k1 = (int(round(x * self.rate)) for x in self.train_s)
            lv = response_levels(self.values, self.rate, None if self.reused else (k0, k1))
        if lv is None:
            return None
        names = list(self.analyzed[:MAX_TIMELINE_ROWS])
        ratio = lv.ratio[:, : len(names)]
        edges = lv.edges_s
        both = [fault_spans(faults, ch, self.duration) for ch in names]
        spans, since = [p for p, _ in both], [o for _, o in both]
        job = fg.FigureJob(
            "level_figure",
            (names, edges, ratio, self.train_s, spans, "levels"),
            {"open_faults": since, "train_label": self.train_label},
        )
        own = lv.train is not None
        reference = (
            f"its RMS in the {self.train_label}" if own else "its median level over the record"
        )
        caption = (
            "Response level: each analyzed channel's RMS about its "
            f"{'training' if own else 'median'} mean in "
            f"{fmt.duration(float(edges[1] - edges[0]))} bins, over {reference} "
            "(log colour scale: blue lower, red higher, grey no data), fault periods outlined"
            + (
                " (dashed: before an onset that is an upper bound, where the fault may "
                "already have been)"
                if any(since)
                else ""
            )
            + ". "
            "A change on every channel at once is a change of the load or of the structure, "
            "not of one sensor."
        )
        return self.figure("levels", "Response level over time", caption, job)

    def _gap_map(self) -> dict[str, list[tuple[float, float]]]:
        if self.values is None or not self.analyzed or self.n == 0:
            return {}
        frac = binned_nan_fraction(self.values, GAP_BINS)
        bins = frac.shape[0]
        edges = (np.arange(bins + 1) * self.n) // bins / self.rate
        out: dict[str, list[tuple[float, float]]] = {}
        for j, ch in enumerate(self.analyzed[: frac.shape[1]]):
            out[ch] = [(float(edges[a]), float(edges[b])) for a, b in runs(frac[:, j] > 0)]
        return out


# -- helpers ------------------------------------------------------------------------------

RATIO_SLACK = 1e-6
"""A test at its first alarm counts as crossed at this fraction below its bound: the
detectors' statistic sums the window by running sums, this by a plain sum, which may
differ in the last digits where the alarm only just crossed."""


@dataclass(frozen=True, slots=True)
class AlarmTest:
    """One window's test of a residual at a detector's first alarm: ``kind`` "mean"
    (the window mean against ``center +- bound``) or "rms" (the root mean square about
    the healthy mean against ``bound``, the log-mean-square test of gain changes), its
    ``value`` and ``bound`` in channel units, and ``ratio``, value over bound (over 1:
    crossed; for the mean, its distance from ``center`` over ``bound``)."""

    index: int
    window: int
    kind: str
    value: float
    center: float
    bound: float
    ratio: float

    def describe(self, rate_hz: float) -> str:
        """``its 400-sample (2.000 s) moving mean, 0.0664, above its band's upper edge
        0.0659 (band -0.00084 ± 0.0668)``, as the caption writes it."""
        w = f"its {self.window}-sample ({fmt.duration(self.window / rate_hz)})"
        if self.kind == "mean":
            high = self.value >= self.center
            edge = self.center + (self.bound if high else -self.bound)
            return (
                f"{w} moving mean, {fmt.num(self.value)}, "
                f"{'above' if high else 'below'} its band's {'upper' if high else 'lower'} "
                f"edge {fmt.num(edge)} (band {fmt.num(self.center)} ± {fmt.num(self.bound)})"
            )
        return (
            f"{w} RMS about the healthy mean (purple), {fmt.num(self.value)}, above its "
            f"bound {fmt.num(self.bound)}"
        )


def alarm_tests(residual: Any, th: Mapping[str, Any], at: int) -> list[AlarmTest]:
    """Each window's two tests (mean, RMS) of ``residual`` (channel units) on the window
    ending at sample ``at``, a detector's first alarm, with the thresholds ``th`` of its
    calibration (:meth:`analyzer.diagnosis.changes.Calibration.as_dict`), largest
    ``ratio`` first: the test that raised the alarm is the one over its bound, which
    may be the long window's while the short window's mean is inside its band (a small
    lasting offset or a slow drift). As the detectors' statistic
    (``_alarm_statistic_numpy``): the standardized window's sum and sum of squares over
    its length, missing samples as zeros, a window more than half missing untested."""
    try:
        mean, std = float(th["mean"]), float(th["std"])
        windows = [int(w) for w in th["windows"]]
        mthr = [float(x) for x in th["mean_threshold"]]
        lthr = [float(x) for x in th["logq_threshold"]]
    except (KeyError, TypeError, ValueError):
        return []
    if not std > 0:
        return []
    out = []
    for i, w in enumerate(windows[: min(len(mthr), len(lthr))]):
        if at - w + 1 < 0 or at >= len(residual) or w < 1:
            continue
        z = (_f64(residual[at - w + 1 : at + 1]) - mean) / std
        finite = np.isfinite(z)
        if finite.sum() <= 0.5 * w:
            continue
        z = np.where(finite, z, 0.0)
        m = float(z.sum()) / w
        ms = float(np.dot(z, z)) / w
        rms_bound = std * math.exp(0.5 * lthr[i])
        out.append(AlarmTest(i, w, "mean", mean + m * std, mean, mthr[i] * std, abs(m) / mthr[i]))
        rms = std * math.sqrt(ms)
        out.append(AlarmTest(i, w, "rms", rms, mean, rms_bound, rms / rms_bound))
    return sorted(out, key=lambda a: -a.ratio)


def _raised(crossed: Sequence[AlarmTest], kind: str) -> AlarmTest | None:
    """The test of ``kind`` ("mean" or "rms") that raised the alarm, the largest crossing
    of that kind; None when no test of that kind crossed."""
    return next((a for a in crossed if a.ratio >= 1.0 - RATIO_SLACK and a.kind == kind), None)


def _drawn_window(crossed: Sequence[AlarmTest]) -> int:
    """The window whose moving mean a residual panel draws: that of the mean test that
    raised the alarm (the largest crossing), else the short window's."""
    mean = _raised(crossed, "mean")
    return 0 if mean is None else mean.index


def _alarm_s(ev: Any) -> float | None:
    """A detector's first alarm (s) from its evidence (``first_alarm_s``), else None."""
    v = ev.get("first_alarm_s") if isinstance(ev, Mapping) else None
    return float(v) if isinstance(v, int | float) and math.isfinite(v) else None


def _f64(x: Any) -> FloatArray:
    return np.asarray(x, dtype=np.float64)


def onset_bound(f: Mapping[str, Any]) -> bool:
    """Whether a fault's ``onset_s`` is only an upper bound: it was there when a search
    began (:func:`open_since`), or at the first sample searched after the training
    window (``onset_at_search_start``: it may have begun inside the window)."""
    ev = f.get("evidence") or {}
    return open_since(f) is not None or bool(ev.get("onset_at_search_start"))


def onset_label(f: Mapping[str, Any]) -> str:
    """The legend of a finding's onset line in its figures, in the words of the report's
    table (:func:`analyzer.report.view.onset_words`): ``from the start (not judged
    before)`` for a fault there when the detectors could first judge the record
    (evidence ``onset_at_or_before``), ``onset: at or before`` for another upper bound,
    else ``onset``. The figures said "onset: at or before" where the table said "from
    the start (not judged before 4.310 s)" for the same finding."""
    if (f.get("evidence") or {}).get("onset_at_or_before"):
        return fg.FROM_START_LABEL
    return fg.ONSET_BOUND_LABEL if onset_bound(f) else fg.ONSET_LABEL


def open_since(f: Mapping[str, Any]) -> float | None:
    """Where a fault whose ``onset_s`` is only an upper bound may have begun, or None
    when ``onset_s`` is where it began. With ``--model`` a fault present when the search
    started (evidence ``onset_at_or_before``: an offset on ``/s2.data`` from the first
    sample, reported at the end of the filters' warm-up, 4.31 s) may have begun anywhere
    before, this record's start included; one present when a search again began
    (``searched_after.onset_at_or_before``) may have begun in the stretch before it. The
    report then says "at or before" and draws the span as open, not as healthy."""
    ev = f.get("evidence") or {}
    if ev.get("onset_at_or_before"):
        return 0.0
    after = ev.get("searched_after")
    if isinstance(after, Mapping) and after.get("onset_at_or_before"):
        stretch = after.get("stretch_s") or [0.0]
        return min(float(stretch[0]), float(f.get("onset_s") or 0.0))
    return None


def fault_spans(
    faults: Sequence[Mapping[str, Any]], channel: str, duration_s: float
) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    """The fault periods of ``channel`` (onset to end, or to ``duration_s``) and the spans
    before an onset that is only an upper bound where the fault may already have been
    (:func:`open_since` to the onset)."""
    periods, open_spans = [], []
    for f in faults:
        if f["channel"] != channel:
            continue
        onset = float(f["onset_s"])
        end = float(f["end_s"]) if f.get("end_s") is not None else duration_s
        periods.append((onset, end))
        since = open_since(f)
        if since is not None and since < onset:
            open_spans.append((since, onset))
    return periods, open_spans


SPAN_KEYS = ("before_span_s", "after_span_s")


def _span(s: Sequence[float] | None) -> str:
    """``10.000-20.000 s`` (in minutes, hours or days for a long span)."""
    if not s:
        return fmt.MISSING
    a, b = float(s[0]), float(s[1])
    if fmt.time_unit(b - a)[0] == "s":
        return f"{seconds_text(a)}-{fmt.seconds(b)}"
    return f"{fmt.at(a, b - a).split()[0]}-{fmt.at(b, b - a)}"


__all__ = [
    "RATIO_SLACK",
    "AlarmTest",
    "alarm_tests",
    "CLOSE_MAX_S",
    "CLOSE_MIN_S",
    "CLOSE_SAMPLES",
    "GAP_BINS",
    "MAX_PANELS",
    "MAX_TIMELINE_ROWS",
    "ZOOM_FRACTION",
    "ZOOM_MAX_S",
    "ZOOM_MIN_S",
    "FigureParts",
    "fault_spans",
    "onset_bound",
    "onset_label",
    "open_since",
]
