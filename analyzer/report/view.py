"""The report's view model: everything the templates display, computed and formatted
here from the analysis and its ``findings.json`` document.

Numbers shown as text come from ``doc`` (what ``findings.json`` holds) wherever it has
them; figures slice the arrays behind them out of the analysis (aligned values,
residuals, fault-free estimates). The analysis is read by duck typing (attribute
access with defaults), so any object with the :class:`analyzer.findings.Analysis`
fields renders, including a synthetic one in the benchmark.

Cost stays bounded on long archives: at most :data:`MAX_DETAILED` findings get figures
(the most confident ones; the verdict table lists all), every plotted series is
decimated to a min/max envelope, and gaps are located from a binned NaN map streamed
once over the (possibly memory-mapped) aligned matrix.

Figures are not drawn here: each is described as a job (:mod:`analyzer.report.jobs`)
and handed to a :class:`~analyzer.report.workers.FigureBatch` as soon as its arrays are
sliced out, so that worker processes (when the CLI started them) draw while the rest of
the view is built; the SVGs are filled in at the end, in-process where there is no
pool. Building a view therefore does not import matplotlib when a pool draws.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from markupsafe import Markup

from analyzer import __version__
from analyzer.report import format as fmt
from analyzer.report import jobs as fg
from analyzer.report.decimate import Clock, binned_nan_fraction, envelope, runs
from analyzer.report.methods import DECISION, DETECTORS, TESTS, Method
from analyzer.report.workers import FigureBatch, FigureWorkers, active_workers

FloatArray = npt.NDArray[np.float64]
NS_PER_S = 1_000_000_000

MAX_DETAILED = 6
"""Findings that get full figure sets; the others are summarized in tables."""
MAX_PANELS = 4
"""Detector panels in a finding's residual figure."""
MAX_TIMELINE_ROWS = 60
"""Channels drawn in the coverage timeline (analyzed channels first)."""
CLOSE_SAMPLES, CLOSE_MIN_S, CLOSE_MAX_S = 200, 1.0, 30.0
"""Close-up of the onset in the signal figure: this many samples, within bounds (s)."""
MAX_MODEL_COLUMNS = 8
"""Per-channel model columns shown per detector (the rest is in findings.json)."""
GAP_BINS = 2000
"""Time bins of the gap map of the analyzed channels."""
ZOOM_MIN_S, ZOOM_MAX_S, ZOOM_FRACTION = 5.0, 120.0, 0.15
"""Half-width of the window around an onset: this fraction of the record, within bounds."""

TEST_LABELS: dict[str, tuple[str, str]] = {
    "shewhart": ("Shewhart chart", "fraction of |z| > 3 vs. expected"),
    "anderson_darling": ("Anderson-Darling", "A²* (normality)"),
    "cramer_von_mises": ("Cramér-von Mises", "W²* (normality)"),
    "whiteness": ("Whiteness", "Ljung-Box Q, 20 lags"),
    "mean": ("Zero mean", "max |√N · mean|"),
    "covariance": ("Unit covariance", "N · variance, two-sided"),
}


# -- records the templates display ------------------------------------------------------


@dataclass(slots=True)
class FigureView:
    kind: str
    title: str
    caption: str
    svg: Markup


@dataclass(slots=True)
class Fact:
    label: str
    value: str


@dataclass(slots=True)
class TestCell:
    statistic: str
    critical: str
    reject: bool | None

    @property
    def verdict(self) -> str:
        return {True: "reject", False: "pass", None: fmt.MISSING}[self.reject]


@dataclass(slots=True)
class TestRow:
    name: str
    what: str
    before: TestCell
    after: TestCell

    @property
    def changed(self) -> bool:
        return self.before.reject is False and self.after.reject is True


@dataclass(slots=True)
class DetectorTests:
    detector: str
    before_span: str
    after_span: str
    rows: list[TestRow]
    consistent_with: str
    lead: bool


@dataclass(slots=True)
class FindingView:
    number: int
    anchor: str
    channel: str
    type: str
    onset_s: str
    onset_utc: str
    end_s: str
    end_utc: str
    onset_clock: str
    end_clock: str
    magnitude: str
    confidence: str
    detectors: list[str]
    lead: str
    tests_agree: str = ""
    detailed: bool = False
    figures: list[FigureView] = field(default_factory=list)
    tests: list[DetectorTests] = field(default_factory=list)
    evidence: list[tuple[str, list[Fact]]] = field(default_factory=list)
    corrections: list[list[Fact]] = field(default_factory=list)
    remarks: list[str] = field(default_factory=list)


@dataclass(slots=True)
class InputView:
    path: str
    format: str
    size: str
    sha256: str
    errors: list[str]


@dataclass(slots=True)
class ChannelView:
    name: str
    analyzed: bool
    samples: str
    rate: str
    start_s: str
    end_s: str
    gaps: str
    range: str


@dataclass(slots=True)
class ChannelTable:
    """A per-channel table of one detector's model: header and rows of strings."""

    header: list[str]
    rows: list[list[str]]


@dataclass(slots=True)
class ModelView:
    detector: str
    channels: str
    params: list[Fact]
    summary: list[Fact]
    per_channel: ChannelTable
    training_tests: ChannelTable
    training_rejects: str
    windowed: ChannelTable
    windowed_note: str
    notes: list[str]


@dataclass(slots=True)
class MethodView:
    method: Method
    status: str
    ran: bool


@dataclass(slots=True)
class ReportView:
    title: str
    version: str
    faulty: bool
    headline: str
    verdict_facts: list[Fact]
    findings: list[FindingView]
    summarized: int
    checked: list[Fact]
    skipped: list[Fact]
    notes: list[str]
    input_errors: list[str]
    inputs: list[InputView]
    channels: list[ChannelView]
    coverage: FigureView | None
    coverage_note: str
    train: str
    models_heading: str
    reused: bool
    models: list[ModelView]
    methods: list[MethodView]
    tests_method: Method
    decision: str
    thresholds: list[Fact]
    timings: list[Fact]

    @property
    def figure_count(self) -> int:
        own = sum(len(f.figures) for f in self.findings)
        return own + (1 if self.coverage is not None else 0)


# -- building the view ------------------------------------------------------------------


def build_view(
    analysis: Any, doc: Mapping[str, Any], workers: FigureWorkers | None = None
) -> ReportView:
    """The view of one analysis (see the module doc). Figures are drawn by ``workers``,
    by default the pool of the enclosing :func:`analyzer.report.workers.figure_workers`
    context, and in-process where there is none."""
    a = _Access(analysis, doc, FigureBatch(workers if workers is not None else active_workers()))
    faults = list(doc.get("faults", []))
    findings = [a.finding_view(i, f) for i, f in enumerate(faults)]
    order = sorted(
        range(len(findings)),
        key=lambda i: (
            -float(faults[i].get("confidence") or 0),
            float(faults[i].get("onset_s") or 0),
        ),
    )
    for i in order[:MAX_DETAILED]:
        findings[i].detailed = True
        a.add_figures(findings[i], faults[i])
    coverage, coverage_note = a.coverage(faults)
    view = ReportView(
        title=a.title(),
        version=str(doc.get("analyzer_version", __version__)),
        faulty=bool(faults),
        headline=a.headline(faults),
        verdict_facts=a.verdict_facts(),
        findings=findings,
        summarized=max(0, len(findings) - MAX_DETAILED),
        checked=a.checked(),
        skipped=[Fact(k, str(v)) for k, v in (doc.get("skipped_detectors") or {}).items()],
        notes=[str(n) for n in doc.get("notes") or []],
        input_errors=[
            f"{i['path']}: {e}" for i in doc.get("inputs", []) for e in i.get("errors", [])
        ],
        inputs=a.inputs(),
        channels=a.channels(),
        coverage=coverage,
        coverage_note=coverage_note,
        train=a.train_text(),
        models_heading=a.models_heading(),
        reused=bool(doc.get("model")),
        models=[a.model_view(r) for r in doc.get("detectors", [])],
        methods=a.methods(),
        tests_method=TESTS,
        decision=DECISION,
        thresholds=a.threshold_facts(),
        timings=[
            Fact(k, fmt.seconds(v, 2)) for k, v in (getattr(analysis, "timings", {}) or {}).items()
        ],
    )
    a.draw_figures()
    return view


class _Access:
    """The analysis and its document, with the look-ups the view needs."""

    def __init__(self, analysis: Any, doc: Mapping[str, Any], batch: FigureBatch) -> None:
        self.an = analysis
        self.doc = doc
        self.batch = batch
        self.pending: list[tuple[FigureView, int]] = []
        self.rate = float(doc.get("rate_hz") or getattr(analysis, "rate_hz", 1.0) or 1.0)
        self.duration = float(doc.get("duration_s") or 0.0)
        self.analyzed: tuple[str, ...] = tuple(getattr(analysis, "analyzed", ()) or ())
        self.values = getattr(analysis, "values", None)
        self.n = int(getattr(analysis, "n", 0) or (0 if self.values is None else len(self.values)))
        self.results = {r.detector: r for r in getattr(analysis, "results", []) or []}
        tr = doc.get("train") or {}
        self.train_s = (float(tr.get("start_s", 0.0)), float(tr.get("end_s", 0.0)))
        # with --model the shaded start is the filters' warm-up, not a training window
        self.train_label = "filters' warm-up" if doc.get("model") else "training window"

    # -- verdict ----------------------------------------------------------------------
    def title(self) -> str:
        paths = [Path(str(i.get("path", ""))).name for i in self.doc.get("inputs", [])]
        name = ", ".join(paths[:3]) + (f" and {len(paths) - 3} more" if len(paths) > 3 else "")
        return f"Sensor fault audit: {name}" if name else "Sensor fault audit"

    def headline(self, faults: Sequence[Mapping[str, Any]]) -> str:
        if not faults:
            return "No sensor fault found."
        sensors = sorted({str(f["channel"]) for f in faults})
        n = len(faults)
        what = "sensor fault" if n == 1 else "sensor faults"
        on = "sensor" if len(sensors) == 1 else "sensors"
        return f"{n} {what} found on {len(sensors)} {on}: {', '.join(sensors)}."

    def verdict_facts(self) -> list[Fact]:
        start = self.doc.get("start")
        return [
            Fact("Record start", str(start) if start else "relative timestamps (no absolute time)"),
            Fact("Duration", fmt.duration(self.duration)),
            Fact(
                "Analyzed channels", f"{len(self.analyzed)} of {len(self.doc.get('channels', []))}"
            ),
            Fact(
                "Detectors run",
                ", ".join(r["name"] for r in self.doc.get("detectors", [])) or "none",
            ),
        ]

    def checked(self) -> list[Fact]:
        names = list(self.analyzed)
        shown = ", ".join(names[:24]) + (f" and {len(names) - 24} more" if len(names) > 24 else "")
        return [
            Fact("Channels", f"{len(names)}: {shown}"),
            Fact(
                "Detectors", ", ".join(r["name"] for r in self.doc.get("detectors", [])) or "none"
            ),
            Fact("Duration", f"{fmt.duration(self.duration)} at {fmt.rate(self.rate)}"),
            Fact("Training window", self.train_text()),
            Fact("False-alarm rate", self.far_text()),
        ]

    def train_text(self) -> str:
        a, b = self.train_s
        model = self.doc.get("model")
        if model:  # --model: nothing was fitted on this archive
            tr = model.get("train") or {}
            files = ", ".join(Path(str(i.get("path", ""))).name for i in model["trained_on"][:3])
            more = len(model["trained_on"]) - 3
            return (
                f"No training on this archive: the models were fitted on {files}"
                + (f" and {more} more" if more > 0 else "")
                + f" ({fmt.seconds(float(tr.get('start_s', 0.0)))} to "
                f"{fmt.seconds(float(tr.get('end_s', 0.0)))} of it) and loaded from "
                f"{model.get('path')}; the first {fmt.duration(b - a + 1 / self.rate)} here "
                "let the filters settle, and no fault is searched there"
            )
        return (
            f"Training (healthy reference) window: {fmt.seconds(a)} to {fmt.seconds(b)} from "
            f"the start ({fmt.duration(b - a)})"
        )

    def models_heading(self) -> str:
        model = self.doc.get("model")
        if model:
            return f"Models loaded from {Path(str(model.get('path'))).name}"
        return "Models fitted on the training window"

    def far(self) -> float | None:
        for r in self.doc.get("detectors", []):
            v = (r.get("params") or {}).get("false_alarm_rate")
            if v is not None:
                return float(v)
        for r in self.results.values():
            for th in r.thresholds.values():
                if isinstance(th, dict) and th.get("false_alarm_rate") is not None:
                    return float(th["false_alarm_rate"])
        return None

    def far_text(self) -> str:
        v = self.far()
        if v is None:
            return fmt.MISSING
        return f"{fmt.num(v, 3)} per sample (shared among each detector's channels)"

    # -- findings ---------------------------------------------------------------------
    def finding_view(self, i: int, f: Mapping[str, Any]) -> FindingView:
        ev = f.get("evidence") or {}
        return FindingView(
            number=i + 1,
            anchor=f"finding-{i + 1}",
            channel=str(f["channel"]),
            type=str(f["type"]),
            onset_s=fmt.seconds(f.get("onset_s")),
            onset_utc=str(f.get("onset") or fmt.MISSING),
            end_s=fmt.seconds(f["end_s"]) if f.get("end_s") is not None else "to the end",
            end_utc=str(f.get("end") or ("" if f.get("end_s") is None else fmt.MISSING)),
            onset_clock=str(f.get("onset") or fmt.clock(f.get("onset_s"))),
            end_clock=str(f.get("end") or fmt.clock(f.get("end_s"))),
            magnitude=fmt.magnitude(f.get("magnitude") or {}),
            confidence=fmt.percent(f.get("confidence")),
            detectors=[str(d) for d in ev.get("detectors", [f.get("detector")])],
            lead=str(f.get("detector")),
            tests_agree=_agree(ev.get("tests_agree"), str(f["type"]), str(f.get("detector"))),
            tests=self.tests_views(f),
            evidence=self.evidence_facts(ev),
            corrections=self.corrections(f),
        )

    def tests_views(self, f: Mapping[str, Any]) -> list[DetectorTests]:
        tests = (f.get("evidence") or {}).get("tests") or {}
        out = []
        for det, t in tests.items():
            before, after = t.get("before") or {}, t.get("after") or {}
            rows = [
                TestRow(
                    TEST_LABELS[k][0],
                    TEST_LABELS[k][1],
                    _cell(before.get(k), k),
                    _cell(after.get(k), k),
                )
                for k in TEST_LABELS
                if k in before or k in after
            ]
            out.append(
                DetectorTests(
                    detector=str(det),
                    before_span=_span(t.get("before_span_s")),
                    after_span=_span(t.get("after_span_s")),
                    rows=rows,
                    consistent_with=", ".join(t.get("consistent_with") or []) or "none",
                    lead=det == f.get("detector"),
                )
            )
        out.sort(key=lambda d: not d.lead)
        return out

    def evidence_facts(self, ev: Mapping[str, Any]) -> list[tuple[str, list[Fact]]]:
        known = {
            "first_alarm_s": ("first alarm", lambda v: fmt.seconds(v)),
            "peak_over_threshold": ("peak / threshold", lambda v: fmt.num(v, 3)),
            "p_value": ("p-value (healthy data this extreme)", _pvalue),
            "explained": ("share of residual explained by the fault model", fmt.percent),
            "type_weights": ("type weights", _weights),
            "noise_scale": ("residual spread / healthy spread (fitted)", lambda v: fmt.num(v, 3)),
        }
        out = []
        for det, extra in (ev.get("by_detector") or {}).items():
            facts = [Fact(lab, conv(extra[k])) for k, (lab, conv) in known.items() if k in extra]
            for k, v in extra.items():
                if k in known:
                    continue
                if fmt.is_scalar(v) or fmt.is_short_list(v):
                    facts.append(Fact(k.replace("_", " "), fmt.scalar(v)))
            out.append((str(det), facts))
        return out

    def corrections(self, f: Mapping[str, Any]) -> list[list[Fact]]:
        out = []
        for c in self.doc.get("corrections") or []:
            if c.get("channel") != f.get("channel"):
                continue
            if abs(float(c.get("start_s") or 0) - float(f.get("onset_s") or 0)) > 1.0:
                continue
            out.append(
                [
                    Fact("method", str(c.get("method"))),
                    Fact(
                        "period",
                        f"{fmt.seconds(c.get('start_s'))} to "
                        + (fmt.seconds(c["end_s"]) if c.get("end_s") is not None else "the end"),
                    ),
                    Fact("samples corrected", fmt.num(c.get("samples"), 12)),
                    Fact("mean fault removed", fmt.num(c.get("mean_fault"))),
                    Fact("RMS fault removed", fmt.num(c.get("rms_fault"))),
                    *([Fact("note", str(c["note"]))] if c.get("note") else []),
                ]
            )
        return out

    # -- figures of one finding -----------------------------------------------------------
    def figure(self, kind: str, title: str, caption: str, job: fg.FigureJob) -> FigureView:
        """A figure whose SVG :meth:`draw_figures` fills in (its job is drawing meanwhile
        when there are workers)."""
        fv = FigureView(kind, title, caption, Markup(""))
        self.pending.append((fv, self.batch.add(job)))
        return fv

    def draw_figures(self) -> None:
        svgs = self.batch.results()
        for fv, i in self.pending:
            fv.svg = svgs[i]
        self.pending.clear()

    def add_figures(self, view: FindingView, f: Mapping[str, Any]) -> None:
        ch = str(f["channel"])
        onset = float(f["onset_s"])
        end = None if f.get("end_s") is None else float(f["end_s"])
        dets = [d for d in view.detectors if self._residual(d, ch) is not None]
        lead = view.lead if view.lead in dets else (dets[0] if dets else None)
        k0, k1 = self._zoom(onset, end, lead, ch)
        t = np.arange(k0, k1, dtype=np.float64) / self.rate
        key = view.anchor
        measured = self._measured(ch, k0, k1)
        if measured is not None:
            est_det = next(
                (d for d in [lead, *dets] if d and self._reference(d, ch) is not None), None
            )
            est = None if est_det is None else self._reference(est_det, ch)
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
                {"close_s": self._close_s()},
            )
            view.figures.append(
                self.figure(
                    "signal",
                    "Measured signal and fault-free estimate",
                    f"{ch} around the onset ({fmt.seconds(t[0] if t.size else 0)} to "
                    f"{fmt.seconds(t[-1] if t.size else 0)}): measured (blue) and the fault-free "
                    f"estimate of {est_det or 'no detector'} (orange); their difference is the "
                    "estimated fault. Dashed red line: identified onset"
                    + ("; dash-dot purple: end" if end is not None else "")
                    + f". Below: close-up of the onset (± {self._close_s():g} s, shaded above); "
                    "where a panel holds more samples than it has pixels, the band shows each "
                    "pixel's minimum and maximum.",
                    job,
                )
            )
        else:
            view.remarks.append(f"{ch} is not among the analyzed channels: no signal figure.")
        if lead is not None:
            view.figures.append(self._residual_figure(view, ch, onset, end, dets, lead, k0, k1))
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

    def _residual_figure(
        self,
        view: FindingView,
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
        panels = []
        for d in [lead, *[x for x in dets if x != lead]][:MAX_PANELS]:
            r = self._residual(d, ch)
            if r is None:
                continue
            th = self._threshold(d, ch)
            panels.append(fg.ResidualPanel(d, np.arange(k0, k1) / self.rate, _f64(r[k0:k1]), *th))
        job = fg.FigureJob(
            "residual_figure",
            (
                envelope(Clock(full.shape[0], self.rate), full, fg.MAX_POINTS),  # drawn of it
                lead,
                panels,
                onset,
                end,
                self.train_s,
                self.duration,
                f"{view.anchor}-residual",
                self.train_label,
            ),
        )
        bands = "; ".join(
            f"{p.detector}: {p.window}-sample mean outside {fmt.num(p.center)} ± "
            f"{fmt.num(p.half_band)}"
            for p in panels
            if p.half_band is not None
        )
        return self.figure(
            "residual",
            "Residual time history",
            "Residual (measured minus fault-free estimate, channel units). Top: the whole "
            f"record for {lead}, {self.train_label} shaded green. Below: each detector that saw "
            "the fault, around the onset, with the trailing moving mean (black) and the band "
            "it must leave to raise an alarm (red; set from the training residual and the "
            f"false-alarm rate: {bands or 'not available'}). The log-mean-square statistic, "
            "which alarms on gain changes, is not drawn.",
            job,
        )

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
        for name, span_key, test_key in (
            ("before onset", "before_span_s", "before"),
            ("after onset", "after_span_s", "after"),
        ):
            span = t.get(span_key)
            if not span:
                continue
            a = max(0, int(round(float(span[0]) * self.rate)))
            b = min(self.n, int(round(float(span[1]) * self.rate)))
            z = self._standardized(det, ch, a, b)
            if z is None or b <= a:
                continue
            segs.append(fg.Segment(name, np.arange(a, b) / self.rate, z, t.get(test_key)))
        if not segs:
            return None
        job = fg.FigureJob("tests_figure", (segs, det, f"{view.anchor}-tests"))
        return self.figure(
            "tests",
            "Innovation tests before and after the onset",
            f"Standardized residual of {det} (training mean and deviation removed), on "
            f"{' and '.join(_span(t.get(k)) for k in SPAN_KEYS if t.get(k))}."
            " Left: Shewhart chart with the ±3 limits (shaded: beyond). Middle: normal "
            "probability plot; a healthy residual follows the red N(0, 1) line. Right: "
            "autocorrelation at lags 1-20 with the ±1.96/√N band of white noise.",
            job,
        )

    # -- array access -------------------------------------------------------------------
    def _residual(self, det: str | None, ch: str) -> Any:
        r = self.results.get(det) if det else None
        return None if r is None else r.residuals.get(ch)

    def _reference(self, det: str, ch: str) -> Any:
        r = self.results.get(det)
        return None if r is None else r.reference.get(ch)

    def _threshold(self, det: str, ch: str) -> tuple[float | None, float | None, int | None]:
        """(center, half-band, window) of the short-window mean test in channel units:
        the alarm fires when the window mean of the residual leaves
        ``mean +- mean_threshold[0] * std`` (analyzer.diagnosis.changes)."""
        r = self.results.get(det)
        th = None if r is None else r.thresholds.get(ch)
        if not isinstance(th, dict):
            return None, None, None
        try:
            mean, std = float(th["mean"]), float(th["std"])
            half = float(th["mean_threshold"][0]) * std
            window = int(th["windows"][0])
        except (KeyError, IndexError, TypeError, ValueError):
            return None, None, None
        return mean, half, window

    def _standardized(self, det: str, ch: str, a: int, b: int) -> FloatArray | None:
        """``(r - mean) / std`` on ``[a, b)``, as analyzer.diagnosis.evidence.standardized
        (the same normalization the tests ran on)."""
        r = self.results.get(det)
        if r is None or r.residuals.get(ch) is None:
            return None
        res = r.residuals[ch]
        th = r.thresholds.get(ch, {}) if isinstance(r.thresholds.get(ch), dict) else {}
        mean = float(th.get("mean", 0.0))
        std = float(th.get("std", r.sigma.get(ch, 0.0)))
        if not std > 0:
            std = float(r.sigma.get(ch, 0.0))
        if not std > 0:
            return None
        return (_f64(res[a:b]) - mean) / std

    def _measured(self, ch: str, k0: int, k1: int) -> FloatArray | None:
        if self.values is None or ch not in self.analyzed:
            return None
        return _f64(self.values[k0:k1, self.analyzed.index(ch)])

    def _close_s(self) -> float:
        """Half-width of the close-up of the onset: a couple of hundred samples, at
        least a second (a few cycles of a structure's first modes), at most half a minute."""
        return float(min(max(CLOSE_SAMPLES / self.rate, CLOSE_MIN_S), CLOSE_MAX_S))

    def _zoom(self, onset: float, end: float | None, det: str | None, ch: str) -> tuple[int, int]:
        half = min(max(ZOOM_FRACTION * self.duration, ZOOM_MIN_S), ZOOM_MAX_S)
        th = None
        if det and det in self.results:
            th = self.results[det].thresholds.get(ch)
        if isinstance(th, dict) and th.get("windows"):
            half = max(half, 3.0 * float(th["windows"][-1]) / self.rate)
        right = onset + half
        if end is not None and end < onset + 3 * half:
            right = max(right, end + 0.5 * half)
        k0 = max(0, int(math.floor((onset - half) * self.rate)))
        k1 = min(self.n, int(math.ceil(right * self.rate)) + 1)
        return k0, max(k1, min(self.n, k0 + 2))

    # -- archive overview -------------------------------------------------------------------
    def inputs(self) -> list[InputView]:
        infos = list(getattr(self.an, "inputs", []) or [])
        out = []
        for i, d in enumerate(self.doc.get("inputs", [])):
            size = getattr(infos[i], "size_bytes", 0) if i < len(infos) else 0
            if not size:
                size = _disk_size(Path(str(d.get("path", ""))))
            out.append(
                InputView(
                    str(d.get("path")),
                    str(d.get("format")),
                    fmt.size(size),
                    str(d.get("sha256") or fmt.MISSING),
                    [str(e) for e in d.get("errors", [])],
                )
            )
        return out

    def _start_ns(self) -> int:
        return int(getattr(self.an, "start_ns", 0) or 0)

    def channels(self) -> list[ChannelView]:
        start = self._start_ns()
        out = []
        for c in getattr(self.an, "channels", []) or []:
            out.append(
                ChannelView(
                    name=c.name,
                    analyzed=c.name in self.analyzed,
                    samples=f"{c.samples:,}",
                    rate=fmt.rate(c.rate_hz),
                    start_s=fmt.seconds((c.start_ns - start) / NS_PER_S),
                    end_s=fmt.seconds((c.end_ns - start) / NS_PER_S),
                    gaps=str(c.gaps),
                    range=f"{fmt.num(c.minimum)} to {fmt.num(c.maximum)}",
                )
            )
        return out

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
            fl = [
                (
                    float(f["onset_s"]),
                    float(f["end_s"]) if f.get("end_s") is not None else self.duration,
                )
                for f in faults
                if f["channel"] == c.name
            ]
            rows.append(fg.CoverageRow(c.name, a, b, c.name in self.analyzed, gl, fl))
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
            f"{self.train_label} shaded green."
        )
        return self.figure("coverage", "Channel coverage", caption, job), note

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

    # -- models and method ---------------------------------------------------------------------
    def model_view(self, d: Mapping[str, Any]) -> ModelView:
        name = str(d.get("name"))
        model = dict(d.get("model") or {})
        chans = [str(c) for c in d.get("channels", [])]
        params = [
            Fact(k, fmt.scalar(v))
            for k, v in (d.get("params") or {}).items()
            if fmt.is_scalar(v) or fmt.is_short_list(v)
        ]
        summary = [
            Fact(k.replace("_", " "), fmt.scalar(v))
            for k, v in model.items()
            if k not in ("training_tests", "windowed_tests", "channels", "outputs")
            and (fmt.is_scalar(v) or fmt.is_short_list(v))
        ]
        per_channel_cols = _per_channel_columns(
            {k: v for k, v in model.items() if k not in ("training_tests", "windowed_tests")},
            set(chans),
        )
        cols = list(per_channel_cols)[:MAX_MODEL_COLUMNS]
        result = self.results.get(name)
        header = [
            "channel",
            "residual σ (training)",
            "window (samples)",
            "mean threshold (σ units)",
            "false-alarm rate",
            *[c.replace("_", " ") for c in cols],
        ]
        rows = []
        for ch in chans:
            th = result.thresholds.get(ch) if result is not None else None
            th = th if isinstance(th, dict) else {}
            sigma = result.sigma.get(ch) if result is not None else None
            rows.append(
                [
                    ch,
                    fmt.num(th.get("std", sigma)),
                    " / ".join(str(w) for w in th.get("windows", [])) or fmt.MISSING,
                    " / ".join(fmt.num(x, 3) for x in th.get("mean_threshold", [])) or fmt.MISSING,
                    fmt.num(th.get("false_alarm_rate"), 3),
                    *[per_channel_cols[c].get(ch, "") for c in cols],
                ]
            )
        tt = model.get("training_tests") or {}
        t_header = ["channel", *[TEST_LABELS[k][0] for k in TEST_LABELS]]
        t_rows, rejects = [], 0
        for ch, tests in tt.items():
            cells = [str(ch)]
            for k in TEST_LABELS:
                c = _cell(tests.get(k), k)
                rejects += bool(c.reject)
                cells.append(_compact(c, tests.get(k)))
            t_rows.append(cells)
        total = len(tt) * len(TEST_LABELS)
        windowed, windowed_note = self._windowed(model.get("windowed_tests") or {})
        return ModelView(
            detector=name,
            channels=f"{len(chans)}: {', '.join(chans[:16])}" + (" ..." if len(chans) > 16 else ""),
            params=params,
            summary=summary,
            per_channel=ChannelTable(header, rows),
            training_tests=ChannelTable(t_header, t_rows),
            training_rejects=f"{rejects} of {total} tests reject on the training window"
            if total
            else "",
            windowed=windowed,
            windowed_note=windowed_note,
            notes=[str(n) for n in d.get("notes", [])],
        )

    def _windowed(self, wt: Mapping[str, Any]) -> tuple[ChannelTable, str]:
        """The windowed tests over the whole record (``model["windowed_tests"]``): per
        channel and test, the share of windows that reject."""
        header = ["channel", *[TEST_LABELS[k][0] for k in TEST_LABELS]]
        rows, layout = [], None
        for ch, tests in wt.items():
            if not isinstance(tests, Mapping):
                continue
            layout = layout or tests.get("windows")
            cells = [str(ch)]
            for k in TEST_LABELS:
                t = tests.get(k) or {}
                if t.get("windows"):
                    cells.append(
                        f"{fmt.percent(t.get('fraction'))} ({t.get('rejected')}/{t.get('windows')})"
                    )
                else:
                    cells.append(fmt.MISSING)
            rows.append(cells)
        note = ""
        if isinstance(layout, Mapping) and layout.get("window"):
            w = int(layout["window"])
            note = (
                f"Consecutive windows of {w} samples ({fmt.seconds(w / self.rate, 2)}), "
                f"{layout.get('valid', layout.get('count'))} per channel, over the whole record "
                "(faulty stretches included). A healthy, well-modelled residual rejects in "
                "about 5 % of the windows."
            )
        return ChannelTable(header, rows), note

    def methods(self) -> list[MethodView]:
        ran = {str(r["name"]): r for r in self.doc.get("detectors", [])}
        skipped = self.doc.get("skipped_detectors") or {}
        out = []
        for name, m in DETECTORS.items():
            if name in ran:
                status = f"ran on {len(ran[name].get('channels', []))} channels"
            elif name in skipped:
                status = f"skipped: {skipped[name]}"
            else:
                status = "not run"
            out.append(MethodView(m, status, name in ran))
        for name in ran:
            if name not in DETECTORS:
                out.append(MethodView(Method(name, name, "", ""), "ran", True))
        return out

    def threshold_facts(self) -> list[Fact]:
        facts = [Fact("False-alarm rate", self.far_text())]
        windows = set()
        for r in self.results.values():
            for th in r.thresholds.values():
                if isinstance(th, dict) and th.get("windows"):
                    windows.add(tuple(int(w) for w in th["windows"]))
        for w in sorted(windows):
            secs = " / ".join(fmt.seconds(x / self.rate, 2) for x in w)
            facts.append(Fact("Windows", f"{' / '.join(map(str, w))} samples ({secs})"))
        facts.append(Fact("Test level", "5 % per innovation test"))
        return facts


# -- helpers ------------------------------------------------------------------------------


def _f64(x: Any) -> FloatArray:
    return np.asarray(x, dtype=np.float64)


def _cell(t: Mapping[str, Any] | None, test: str = "") -> TestCell:
    """One test result as display strings. The Shewhart chart's ``critical`` is the
    fraction expected beyond the limits (the decision is a binomial test of the count),
    so it is labelled as such, with the p-value where known."""
    if not t:
        return TestCell(fmt.MISSING, fmt.MISSING, None)
    crit = fmt.num(t.get("critical"), 4)
    if test == "shewhart":
        crit = f"exp. {crit}"
        if t.get("pvalue") is not None:
            crit += f", p {fmt.num(t['pvalue'], 2)}"
    if t.get("critical_low") is not None:
        crit = f"{fmt.num(t['critical_low'], 4)} to {crit}"
    reject = t.get("reject")
    return TestCell(fmt.num(t.get("statistic"), 4), crit, None if reject is None else bool(reject))


def _agree(agree: Any, kind: str, lead: str) -> str:
    if agree is None:
        return ""
    art = "an" if kind[:1] in "aeiou" else "a"
    if agree:
        return f"yes: the tests of {lead} break the way {art} {kind} fault breaks them"
    return (
        f"no: the tests of {lead} do not break the way {art} {kind} fault breaks them "
        "(the confidence was lowered accordingly)"
    )


def _compact(c: TestCell, t: Mapping[str, Any] | None) -> str:
    """``statistic / critical mark`` for the training-test table; a two-sided test that
    rejects below its upper critical value rejected on the low side and says so."""
    if c.reject is None:
        return fmt.MISSING
    low = ""
    try:
        if c.reject and t and float(t["statistic"]) < float(t["critical"]):
            low = " (low)"
    except (KeyError, TypeError, ValueError):
        pass
    return f"{c.statistic} / {c.critical} {'✗' if c.reject else '✓'}{low}"


def _per_channel_columns(
    tree: Mapping[str, Any], chans: set[str], depth: int = 3, path: str = ""
) -> dict[str, dict[str, str]]:
    """Per-channel columns of a model summary: wherever a dict is keyed by channel names,
    its scalar (or short-list) leaves, up to two levels below the channel, become columns
    named by their path (``r_squared``, ``filters: spectral radius``...). Columns whose
    value is the same on every channel say nothing per channel and are dropped."""
    cols: dict[str, dict[str, str]] = {}
    keys = set(tree)
    if keys and keys <= chans:
        for ch, v in tree.items():
            for name, val in _leaves(v, 2):
                col = ": ".join(p for p in (path, name) if p) or "value"
                cols.setdefault(col.replace("_", " "), {})[ch] = val
    elif depth > 0:
        for k, v in tree.items():
            if isinstance(v, Mapping):
                sub = _per_channel_columns(
                    v, chans, depth - 1, ": ".join(p for p in (path, k) if p)
                )
                cols.update(sub)
    return {k: v for k, v in cols.items() if len(set(v.values())) > 1 or len(chans) == 1}


def _leaves(v: Any, depth: int, path: str = "") -> list[tuple[str, str]]:
    if fmt.is_scalar(v) or fmt.is_short_list(v):
        return [(path, fmt.scalar(v))]
    if isinstance(v, Mapping) and depth > 0:
        out = []
        for k, x in v.items():
            out += _leaves(x, depth - 1, " ".join(p for p in (path, str(k)) if p))
        return out
    return []


SPAN_KEYS = ("before_span_s", "after_span_s")


def _span(s: Sequence[float] | None) -> str:
    if not s:
        return fmt.MISSING
    return f"{float(s[0]):.3f}-{float(s[1]):.3f} s"


def _pvalue(v: Any) -> str:
    """A p-value; an underflowed 0 is shown as the bound it is."""
    return "< 1e-300" if v == 0 else fmt.num(v, 3)


def _weights(v: Any) -> str:
    if not isinstance(v, Mapping):
        return fmt.scalar(v)
    return ", ".join(f"{k} {fmt.num(x, 3)}" for k, x in v.items())


def _disk_size(p: Path) -> int | None:
    try:
        if p.is_dir():
            return sum(q.stat().st_size for q in p.rglob("*") if q.is_file())
        return p.stat().st_size
    except OSError:
        return None


__all__ = ["MAX_DETAILED", "FigureView", "FindingView", "ReportView", "build_view"]
