"""The report's view model: everything the templates display, computed and formatted
from the analysis and its ``findings.json`` document.

Numbers shown as text come from ``doc`` (what ``findings.json`` holds) wherever it has
them; figures slice the arrays behind them out of the analysis (aligned values,
residuals, fault-free estimates). The analysis is read by duck typing (attribute
access with defaults), so any object with the :class:`analyzer.findings.Analysis`
fields renders, including a synthetic one in the benchmark.

Cost stays bounded on long archives: at most :data:`MAX_DETAILED` findings get a section
with figures, tests and evidence (the most confident ones, the earliest first among
equally confident ones: with twelve offsets all at 100 %, the first six; the verdict
table lists all, and the page says which have a section), every plotted series is
decimated to a min/max envelope, and gaps are located from a binned NaN map streamed
once over the (possibly memory-mapped) aligned matrix.

Figures are not drawn by the view: each is described as a job (:mod:`analyzer.report.jobs`)
and handed to a :class:`~analyzer.report.workers.FigureBatch` as soon as its arrays are
sliced out, so that worker processes (when the CLI started them) draw while the rest of
the view is built; the SVGs are filled in at the end, in-process where there is no
pool. Building a view therefore does not import matplotlib when a pool draws.

The view is built in parts, a module each: this one holds :func:`build_view` and the
access object with the text (the verdict, each finding's facts, test table, evidence and
corrections); :mod:`analyzer.report.view_figures` the figures and
:mod:`analyzer.report.view_tables` the archive, model, method and threshold tables, both
as bases of the access object; :mod:`analyzer.report.view_records` the records the
templates display.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from analyzer import __version__
from analyzer.diagnosis.evidence import mean_test_read
from analyzer.diagnosis.levels import LISTED
from analyzer.diagnosis.spread import GAIN_COVERAGE
from analyzer.diagnosis.unexplained import and_joined
from analyzer.errors import capped
from analyzer.evidence_label import LABEL_WORDS, LARGE, MEASURED, SMALL
from analyzer.report import format as fmt
from analyzer.report import healthy
from analyzer.report.methods import DECISION, TESTS
from analyzer.report.notes import onset_lines, sort_notes
from analyzer.report.view_figures import FigureParts, _span, onset_bound
from analyzer.report.view_records import (
    DetectorTests,
    Fact,
    FigureView,
    FindingView,
    ReportView,
    TestRow,
)
from analyzer.report.view_tables import FINDING_TEST_LABELS, MEAN_READ, TableParts, _cell
from analyzer.report.workers import FigureBatch, FigureWorkers, active_workers
from analyzer.what_to_check import channel_units, type_words, what_to_check

NEEDS_CONFIG = "needs [[group]]"
"""How a detector that runs only with a config says so (the error functions, without
``[[group]]`` reference and uncertain sensors): the normal case of a run without one,
which the page says as such, not among the detectors that could not run (every default
report's first screen listed it there, which read as a configuration error)."""

UTC_NAMES = frozenset({"Z", "UTC", "GMT", "+00:00", "+0000", "UTC+00:00"})
"""Zones a date-time may give that are UTC itself: nothing to add beside a UTC time."""

NOISE_ONLY = (
    "A gain's range marked “noise only” counts the noise of the fit only, not the error of "
    "the fault-free estimate the gain is measured against, so it is narrower than a 95 % "
    "range: in simulated records it held the true gain in {coverage} of cases, not 95 %."
)
"""What a "noise only" range is, said where a finding has one (its figure is
:data:`analyzer.diagnosis.spread.GAIN_COVERAGE`, also in findings.json's note)."""

STRENGTH_NOTE = (
    "The evidence column weighs what each finding carries, not the agreement score: weak "
    "(confirm before sending anyone) where one detector alone saw it, it is below "
    f"{SMALL:g} of the sensor's usual spread, the innovation tests point to another type, "
    "or the recorder logged a message late at its onset; strong where more detectors "
    f"agree, the tests agree with the type and its size is at least {LARGE:g} (the usual "
    "spread); moderate otherwise; one step lower where it overlaps a change of the whole "
    f"structure's response. {MEASURED}"
)
"""The sentence under the verdict table on the evidence labels (:mod:`analyzer.
evidence_label`, whose :data:`~analyzer.evidence_label.MEASURED` gives the rates)."""

MAX_DETAILED = 6
"""Findings that get a section (figures, tests, evidence); the others are rows of the
verdict table only. The most confident get one, the earliest first among equals."""
UNEXPLAINED_LISTED = 3
"""Alarms the verdict's warning names one by one; the rest are counted."""


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
    detailed = sorted(order[:MAX_DETAILED])
    coverage, coverage_note = a.coverage(faults)
    levels = a.levels(faults)
    view = ReportView(
        title=a.title(),
        version=str(doc.get("analyzer_version", __version__)),
        faulty=bool(faults),
        headline=a.headline(faults),
        saved=a.saved_text(),
        nothing_searched=a.nothing_searched(),
        unexplained=a.unexplained(faults),
        load_change=a.load_change(faults),
        verdict_facts=a.verdict_facts(),
        findings=findings,
        summarized=max(0, len(findings) - MAX_DETAILED),
        detailed=len(detailed),
        sections=_sections(detailed, len(findings)),
        checked=a.checked(),
        skipped=[
            Fact(k, str(v))
            for k, v in (doc.get("skipped_detectors") or {}).items()
            if not str(v).startswith(NEEDS_CONFIG)
        ],
        by_default=[
            Fact(k, str(v))
            for k, v in (doc.get("skipped_detectors") or {}).items()
            if str(v).startswith(NEEDS_CONFIG)
        ],
        notes=[str(n) for n in doc.get("notes") or []],
        input_errors=[
            f"{i['path']}: {e}" for i in doc.get("inputs", []) for e in i.get("errors", [])
        ],
        inputs=a.inputs(),
        channels=a.channels(),
        coverage=coverage,
        coverage_note=coverage_note,
        levels=levels,
        train=a.train_text(),
        time_source=a.time_text(),
        config=a.config_text() if doc.get("config") else "",
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
    view.utc_words = a.utc_words()
    if any(f.strength for f in findings):
        view.strength_note = STRENGTH_NOTE
    if any(f.partial for f in findings):
        view.noise_only = NOISE_ONLY.format(coverage=GAIN_COVERAGE)
    view.figure_failures = a.draw_figures()
    view.notes.extend(view.figure_failures)
    view.sorted_notes = sort_notes(
        view.notes,
        view.input_errors,
        {s.label: s.value for s in view.skipped},
        faulty={str(f["channel"]) for f in faults},
    )
    view.caveats = [*view.sorted_notes.key, *onset_lines(faults, view.notes, a.when)]
    view.time_words = a.when.words()
    view.healthy_words = a.healthy_words()
    return view


class _Access(FigureParts, TableParts):
    """The analysis and its document, with the look-ups the view needs: the text here,
    the figures and the tables in the bases."""

    def __init__(self, analysis: Any, doc: Mapping[str, Any], batch: FigureBatch) -> None:
        self.an = analysis
        self.doc = doc
        self.batch = batch
        self.pending: list[tuple[FigureView, int]] = []
        self.rate = float(doc.get("rate_hz") or getattr(analysis, "rate_hz", 1.0) or 1.0)
        # decimals of an onset or end: one sample apart must read apart (4 above 1 kHz),
        # and no more (none at 1 Hz)
        self.decimals = fmt.time_decimals(self.rate)
        self.duration = float(doc.get("duration_s") or 0.0)
        # a time from the start as the charts of the whole record give it: seconds in a
        # short record, minutes and seconds (hours, days) in a long one
        self.when = fmt.Clock.of(self.duration, self.rate)
        self.analyzed: tuple[str, ...] = tuple(getattr(analysis, "analyzed", ()) or ())
        self.values = getattr(analysis, "values", None)
        self.n = int(getattr(analysis, "n", 0) or (0 if self.values is None else len(self.values)))
        self.results = {r.detector: r for r in getattr(analysis, "results", []) or []}
        tr = doc.get("train") or {}
        self.train_s = (float(tr.get("start_s", 0.0)), float(tr.get("end_s", 0.0)))
        # with --model the shaded start is the filters' warm-up, not a training window
        self.train_label = "filters' warm-up" if doc.get("model") else "training window"
        self.reused = bool(doc.get("model"))
        # each channel's unit: at the end of its name, or from its CSV's units line
        self.units = channel_units(
            getattr(analysis, "inputs", []) or [],
            [str(c.get("name")) for c in doc.get("channels", [])]
            + [str(f.get("channel")) for f in doc.get("faults", [])],
        )

    # -- verdict ----------------------------------------------------------------------
    def title(self) -> str:
        """The inputs' names; their folder's where more than three share one (a folder
        run's title listed ``a_part0.bag, a_part1.mcap, a_part2 and 4 more``, broken
        members among them)."""
        full = [Path(str(i.get("path", ""))) for i in self.doc.get("inputs", [])]
        paths = [p.name for p in full]
        folders = {p.parent for p in full}
        if len(paths) > 3 and len(folders) == 1 and next(iter(folders)).name:
            name = f"{next(iter(folders)).name} ({len(paths)} files)"
        else:
            name = capped(paths, 3)
        return f"Sensor fault audit: {name}" if name else "Sensor fault audit"

    def headline(self, faults: Sequence[Mapping[str, Any]]) -> str:
        if self.nothing_searched():
            return "Nothing after the training window to analyze: the models were fitted only."
        if not faults:
            return "No sensor fault found."
        labels = {str(f["channel"]): f" ({f['label']})" for f in faults if f.get("label")}
        sensors = [
            c + labels.get(c, "")
            for c in sorted({str(f["channel"]) for f in faults}, key=fmt.natural_key)
        ]
        n = len(faults)
        what = "sensor fault" if n == 1 else "sensor faults"
        on = "sensor" if len(sensors) == 1 else "sensors"
        # a sensor reading one value over the whole record, said as plainly as found
        stuck = [
            f" {f['channel']} {c['said']}."
            for f in faults
            if isinstance(c := (f.get("evidence") or {}).get("constant"), Mapping) and c.get("said")
        ]
        return f"{n} {what} found on {len(sensors)} {on}: {', '.join(sensors)}." + "".join(stuck)

    def nothing_searched(self) -> bool:
        """A ``--save-model`` run whose training window reaches the record's end: no
        fault was searched (its verdict is not "no sensor fault found")."""
        saved = self.doc.get("saved_model")
        return saved is not None and saved.get("searched") is None

    def saved_text(self) -> str:
        """With ``--save-model``: where the models fitted on the training window were
        saved, what was searched after it, and the warnings its checks gave; else ""."""
        saved = self.doc.get("saved_model")
        if not saved:
            return ""
        tr = saved.get("train") or {}
        fitted = (
            f"The models fitted on the training window ({self.when(tr.get('start_s'))} "
            f"to {self.when(tr.get('end_s'))}) were saved to {saved.get('path')} "
            f"(SHA-256 {saved.get('sha256')})."
        )
        searched = saved.get("searched")
        after = (
            " The window covers the whole record: nothing after it was searched for faults."
            if searched is None
            else f" Faults were searched after it, from {self.when(searched.get('start_s'))}"
            f" to {self.when(searched.get('end_s'))}."
        )
        warned = [str(w) for w in saved.get("warnings") or []]
        warning = (
            f" The checks of the training window warned (fit again on a healthy window "
            f"before using the model): {'; '.join(warned)}."
            if warned
            else ""
        )
        return fitted + after + warning

    def unexplained(self, faults: Sequence[Mapping[str, Any]]) -> str:
        """The verdict's warning on alarms no finding explains (``unexplained_alarms``):
        on which sensors, from when (seconds, and the UTC time where the record has
        absolute times), and the run that searches the others without one of
        them (the detectors isolate one fault at a time: on a 6-floor building whose s1
        and s2 went faulty at once, ``--channels '!s0'`` found both, where leaving out
        the sensor already found, s4, found neither); empty without any. In a run that
        found no fault these are alarms the detectors could not place on a sensor, said
        without that advice: the faulty sensor there may be one they are estimated from,
        not one of those named."""
        items = list(self.doc.get("unexplained_alarms") or [])
        if not items:
            return ""
        # (to a tenth of a second at most: an alarm is not timed as a finding's onset)
        coarse = fmt.Clock(min(1, self.when.decimals), self.when.unit)
        # (the clock time too where the record has one, as the findings give it: in a
        # 24 h archive "from 7199.8 s" alone left the user to count the hours)
        shown = [
            f"on {and_joined([str(c) for c in u.get('channels') or []])} from "
            f"{coarse(u.get('onset_s'))}"
            + (f" at {u['onset']}" if u.get("onset") else "")
            + " (seen by "
            f"{', '.join(str(d) for d in u.get('detectors') or [])}"
            + (
                f"; at {u['seam']}: likely the jump where the files were joined"
                if u.get("seam")
                else ""
            )
            + ")"
            for u in items[:UNEXPLAINED_LISTED]
        ]
        more = len(items) - UNEXPLAINED_LISTED
        listed = "; ".join(shown) + (f"; and {more} more (notes)" if more > 0 else "")
        if not faults:
            # the detection filter's alarms the bank could not place (unexplained.unplaced):
            # the sensors named are those whose residuals rose, estimated from the faulty
            # one, so leaving one of them out searches the wrong ones (a 4-floor building
            # with a gain on s0: --channels '!s2' then found a fault on the healthy s1)
            return (
                "Alarms the detectors could not place on a sensor: "
                + listed
                + ". The faulty sensor may be none of these: a sensor the others are "
                "estimated from (such as the ground floor of a building with one sensor "
                "per floor) can be faulty while its own readings still match their "
                "estimate, and it raises the alarms of the others; or the structure or its "
                "load changed. The notes below say more."
            )
        found = {str(f["channel"]) for f in faults}
        named = [str(c) for c in items[0].get("channels") or []]
        leave = next((c for c in named if c not in found), named[0] if named else "")
        return (
            "Alarms these findings do not explain: "
            + listed
            + ". Another sensor may be faulty (the detectors isolate one fault at a time), "
            + "or the structure or its load changed. Run again leaving out one of these "
            + f"sensors at a time (--channels '!{leave}') to search the others without it; "
            + "the notes below say more."
        )

    def load_change(self, faults: Sequence[Mapping[str, Any]]) -> str:
        """The verdict's line on the stretches where the whole structure's response left
        the training window's range (the run's level note) that findings overlap
        (``level_change``), naming those findings: they may be that change (a load or
        the structure itself), not sensors' faults. On SKAB's anomaly-free record the
        note sat among the notes, "2 other", while the headline counted 7 faults; empty
        where no finding overlaps one."""
        stretches: dict[tuple[float, float, float], list[int]] = {}
        for i, f in enumerate(faults):
            for c in f.get("level_change") or []:
                key = (float(c["start_s"]), float(c["end_s"]), float(c["level"]))
                stretches.setdefault(key, []).append(i + 1)
        if not stretches:
            return ""
        spans = sorted(stretches)
        if len(spans) <= LISTED:
            shown = "at " + " and ".join(
                self.stretch(a, b, f"{fmt.num(level, 2)}x its training level")
                for a, b, level in spans
            )
        else:  # (SKAB's anomaly-free record: six, from 46.5 min to its end)
            low, high = min(x[2] for x in spans), max(x[2] for x in spans)
            shown = f"in {len(spans)} stretches over " + self.stretch(
                spans[0][0],
                max(x[1] for x in spans),
                f"{fmt.num(low, 2)}-{fmt.num(high, 2)}x its training level",
            )
        numbers = sorted({n for ns in stretches.values() for n in ns})
        one, them = len(numbers) == 1, "it" if len(stretches) == 1 else "them"
        change = "that change" if len(stretches) == 1 else "those changes"
        named = ", ".join(str(n) for n in numbers)
        who = (
            f"finding {named} overlaps {them} and may be {change}, not a sensor's fault "
            "(its evidence label is one step lower for it)"
            if one
            else f"findings {named} overlap {them} and may be {change}, not sensors' faults "
            "(their evidence labels are one step lower for it)"
        )
        return (
            "The whole structure's response (the load, or the structure itself) changed "
            f"beyond anything in the training window {shown}: {who}. "
            "The response-level map under Archive shows whether a sensor stands out from "
            "the others."
        )

    def stretch(self, a: float, b: float, level: str) -> str:
        """``2789.0-2822.0 s (46.5-47.0 min; 2.7x its training level)``: seconds, as the
        table gives onsets, with minutes beside them in a record of over 10 minutes (as
        the level map's axis), and ``level``."""
        minutes = f"{a / 60.0:.1f}-{b / 60.0:.1f} min; " if self.duration > 600.0 else ""
        return f"{a:.1f}-{b:.1f} s ({minutes}{level})"

    def _channel_count(self) -> int:
        """The archive's numeric channels and the analyzed ones not among them (a saved
        model's channel whose CSV column is blank in every row: "5 of 4")."""
        names = {c.get("name") for c in self.doc.get("channels", [])}
        return len(names | set(self.analyzed))

    def zones(self) -> tuple[list[str], bool]:
        """What the inputs' date-times said of their zone (:attr:`analyzer.readers.base.
        InputInfo.time_zone`): the offsets other than UTC they gave (``UTC+02:00``), and
        whether one gave none (its times read as UTC). A technician matching a site log at
        +02:00 was two hours off, and zone-less local times were called "absolute UTC"."""
        zones = [getattr(i, "time_zone", None) for i in getattr(self.an, "inputs", []) or []]
        offsets = sorted({str(z) for z in zones if z and str(z).upper() not in UTC_NAMES})
        return [f"UTC{z}" if z[:1] in "+-" else z for z in offsets], any(z == "" for z in zones)

    def zone_words(self) -> str:
        """:meth:`zones` in words beside the record's start: ``times in UTC; the input's
        clock was UTC+02:00``, ``read as UTC (the file gives no time zone)``; empty
        where the inputs' times were UTC or no date-times."""
        offsets, zoneless = self.zones()
        said = [f"times in UTC; the input's clock was {', '.join(offsets)}"] if offsets else []
        if zoneless:
            said.append("read as UTC (the file gives no time zone)")
        return "; ".join(said)

    def utc_words(self) -> str:
        """How the note under the verdict table names the times below the seconds."""
        offsets, zoneless = self.zones()
        if zoneless and not offsets:
            return "the time read as UTC (the file gives no time zone)"
        clock = f" (the input's clock was {', '.join(offsets)})" if offsets else ""
        return (
            "the time in UTC" + clock + ("; times without a zone read as UTC" if zoneless else "")
        )

    def verdict_facts(self) -> list[Fact]:
        start = self.doc.get("start")
        zone = self.zone_words() if start else ""
        return [
            Fact(
                "Record start",
                (f"{start} ({zone})" if zone else str(start))
                if start
                else "relative timestamps (no absolute time)",
            ),
            Fact("Duration", fmt.duration(self.duration) + self.logged_text()),
            Fact("Analyzed channels", f"{len(self.analyzed)} of {self._channel_count()}"),
            Fact(
                "Detectors run",
                ", ".join(r["name"] for r in self.doc.get("detectors", [])) or "none",
            ),
        ]

    def checked(self) -> list[Fact]:
        names = list(self.analyzed)
        shown = capped(names, 24)
        return [
            Fact("Channels", f"{len(names)}: {shown}"),
            Fact(
                "Detectors", ", ".join(r["name"] for r in self.doc.get("detectors", [])) or "none"
            ),
            Fact("Duration", self.duration_text()),
            Fact("Training window", self.train_text()),
            Fact("False alarms", self.false_alarms()),
            *self.smallest(),
        ]

    def smallest(self) -> list[Fact]:
        """The offset per sensor the detectors would have found (:func:`analyzer.report.
        healthy.smallest_offsets`), as a fact; none where no detector has thresholds."""
        results = list(self.results.values())
        said = healthy.smallest_words(
            healthy.smallest_offsets(results, self.analyzed),
            self.units,
            healthy.held_seconds(results, self.rate),
        )
        return [Fact("Smallest offset it would have found", said)] if said else []

    def false_alarms(self) -> str:
        """How much healthy record the detectors' settings allow per false alarm, from
        the rates their thresholds were set with (:mod:`analyzer.report.healthy`); the
        rate per sample where the analysis has no thresholds to read."""
        said = healthy.false_alarm_words(healthy.detector_rates(self.results.values()), self.rate)
        return self.far_text() if said == fmt.MISSING else said

    def healthy_words(self) -> str:
        """The healthy verdict's sentence: what was taken as healthy, not itself checked."""
        a, b = self.train_s
        train = f"the first {self.when(b)}" if a <= 0 else f"{self.when(a)} to {self.when(b)}"
        return healthy.healthy_words(train, self.reused)

    def time_text(self) -> str:
        """Which time the messages' samples were placed at (``findings.json``'s
        ``time_source``): the two can give different findings, so the report says which
        made it; nothing for CSV files alone (their own time column) or a file
        written before the key."""
        source = self.doc.get("time_source")
        if source == "log":
            return (
                "Timestamps: log times (when the recorder wrote each message; --time "
                "header places the samples at their messages' header.stamp instead)"
            )
        if source == "header":
            return (
                "Timestamps: the header.stamp of each message (--time header; its log "
                "time where it has none)"
            )
        return ""

    def duration_text(self) -> str:
        """The duration analyzed and its clock, and the rate logged where the run
        analyzed the channels slower (:meth:`logged_text`)."""
        text = f"{fmt.duration(self.duration)} at {fmt.rate(self.rate)}"
        logged = self.doc.get("logged_rate_hz")
        if logged:
            text += f" (logged at {fmt.rate(float(logged))}: see the notes about the input)"
        return text

    def logged_text(self) -> str:
        """Where the run analyzed the channels slower than they were logged
        (``findings.json``'s ``logged_rate_hz``: a clock far above what the sensors
        carry, whose note says why), both rates; else nothing."""
        logged = self.doc.get("logged_rate_hz")
        if not logged:
            return ""
        return (
            f" (analyzed at {fmt.rate(self.rate)}, logged at {fmt.rate(float(logged))}: "
            "see the notes about the input)"
        )

    def config_text(self) -> str:
        """The ``--config`` file a run read and what it set (``findings.json``'s
        ``config``), so the report says which settings made it."""
        cfg = self.doc.get("config") or {}
        said = []
        if cfg.get("train"):
            tr = cfg["train"]
            said.append(
                f"[train] {fmt.seconds(float(tr['start_s']))} to {fmt.seconds(float(tr['end_s']))}"
            )
        groups = [str(g.get("name", "?")) for g in cfg.get("groups") or []]
        if groups:
            more = " ..." if len(groups) > 4 else ""
            said.append(f"{len(groups)} [[group]] ({', '.join(groups[:4])}{more})")
        if cfg.get("model"):
            m = cfg["model"]
            said.append(
                f"[model] of {m.get('states')} states"
                + (f" from {Path(str(m['file'])).name}" if m.get("file") else "")
            )
        for name, opts in (cfg.get("detectors") or {}).items():
            settings = ", ".join(f"{k} = {v}" for k, v in opts.items()) or "no setting"
            said.append(f"[detectors.{name}] {settings}")
        said.append(f"false-alarm rate {fmt.num(float(cfg.get('false_alarm_rate', 0.0)))}")
        digest = str(cfg.get("sha256", ""))[:12]
        return f"{Path(str(cfg.get('path', ''))).name} (sha256 {digest}...): " + "; ".join(said)

    def train_text(self) -> str:
        a, b = self.train_s
        model = self.doc.get("model")
        if model:  # --model: nothing was fitted on this archive
            tr = model.get("train") or {}
            files = capped([Path(str(i.get("path", ""))).name for i in model["trained_on"]], 3)
            return (
                f"No training on this archive: the models were fitted on {files}"
                f" ({fmt.seconds(float(tr.get('start_s', 0.0)))} to "
                f"{fmt.seconds(float(tr.get('end_s', 0.0)))} of it) and loaded from "
                f"{model.get('path')}; the first {fmt.duration(b - a + 1 / self.rate)} here "
                "let the filters settle, and no fault is searched there"
            )
        return (
            f"Training (healthy reference) window: {self.when(a)} to {self.when(b)} from "
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
        # a given range beside a note counts part of the size's error (a gain's: noise only)
        partial = bool((f.get("interval_notes") or {}).get("magnitude")) and bool(
            f.get("magnitude_interval")
        )
        return FindingView(
            number=i + 1,
            anchor=f"finding-{i + 1}",
            channel=str(f["channel"]),
            label=str(f.get("label") or ""),
            strength=LABEL_WORDS.get(str(f.get("evidence_label") or ""), ""),
            strength_why="; ".join(str(w) for w in f.get("evidence_label_why") or []),
            type=str(f["type"]),
            # an upper bound (the fault was there when the search began) says so wherever
            # it is shown: "at or before 4.310 s", not an exact 4.310 s
            onset_s=onset_words(f, self.when),
            # empty without absolute time (relative timestamps): the page then omits them
            onset_utc=str(f.get("onset") or ""),
            end_s=(
                self.when(f["end_s"]) if f.get("end_s") is not None else _open_end(ev, self.when)
            ),
            end_utc=str(f.get("end") or ""),
            onset_clock=str(f.get("onset") or fmt.clock(f.get("onset_s"), self.decimals)),
            end_clock=str(f.get("end") or fmt.clock(f.get("end_s"), self.decimals)),
            onset_fact=_onset_fact(f, self.when),
            magnitude=fmt.magnitude(
                f.get("magnitude") or {},
                f.get("magnitude_interval"),
                partial,
                self.units.get(str(f["channel"]), ""),
            ),
            check=str(f.get("check") or what_to_check(f, self.units.get(str(f["channel"]), ""))),
            no_range=no_range(f),
            type_words=type_words(str(f["type"])),
            partial=partial,
            confidence=fmt.score(f.get("confidence")),
            detectors=[str(d) for d in ev.get("detectors", [f.get("detector")])],
            lead=str(f.get("detector")),
            tests_agree=_agree(ev.get("tests_agree"), str(f["type"]), str(f.get("detector"))),
            tests=self.tests_views(f),
            found=self.fault_facts(f),
            evidence=self.evidence_facts(ev),
            corrections=self.corrections(f),
            size=fmt.relative_size(f.get("size_relative"), f.get("confidence")),
            small=fmt.is_small(f.get("size_relative")),
        )

    def tests_views(self, f: Mapping[str, Any]) -> list[DetectorTests]:
        tests = (f.get("evidence") or {}).get("tests") or {}
        out = []
        for det, t in tests.items():
            before, after = t.get("before") or {}, t.get("after") or {}
            rows = [
                TestRow(
                    FINDING_TEST_LABELS[k][0],
                    FINDING_TEST_LABELS[k][1],
                    _cell(before.get(k), k),
                    _cell(after.get(k), k),
                )
                for k in FINDING_TEST_LABELS
                if k in before or k in after
            ]
            # (a findings.json of before the long-run test: no word on it)
            read = MEAN_READ[mean_test_read(after)] if "mean_long_run" in after else ""
            out.append(
                DetectorTests(
                    detector=str(det),
                    before_span=_span(t.get("before_span_s")),
                    after_span=_span(t.get("after_span_s")),
                    rows=rows,
                    consistent_with=", ".join(t.get("consistent_with") or []) or "none",
                    lead=det == f.get("detector"),
                    mean_read=read,
                )
            )
        out.sort(key=lambda d: not d.lead)
        return out

    def fault_facts(self, f: Mapping[str, Any]) -> list[Fact]:
        """The fault's own evidence beyond the detectors' (the README's
        ``evidence.onset_at_or_before``, ``frozen``, ``clipped``, ``searched_without``,
        ``searched_after``, ``after_gap_s``) in a line each: findings.json had them and the
        page did not (a dead sensor's frozen readings, a --model onset's upper bound)."""
        ev = f.get("evidence") or {}
        w = self.when
        out = []
        constant = ev.get("constant")
        if isinstance(constant, Mapping):
            # (constant_check: the channel was not analyzed, its raw samples were read)
            out.append(Fact("Reading", f"{f.get('channel')} {constant.get('said', '')}"))
            out.append(
                Fact(
                    "Onset bound",
                    "it read one value from the record's first sample to its last: there "
                    "from the start (it may have begun in an earlier record)",
                )
            )
        elif ev.get("onset_at_or_before"):
            out.append(
                Fact(
                    "Onset bound",
                    "the fault was there when the search started at "
                    f"{w(f.get('onset_s'))}, after the {self.train_label}: "
                    "from the start (not judged before then; it may have begun in an "
                    "earlier record)",
                )
            )
        if ev.get("onset_at_search_start"):
            out.append(
                Fact(
                    "Onset bound",
                    "the fault was there when the search started at "
                    f"{w(f.get('onset_s'))}, the first sample after the "
                    f"{self.train_label}: it began at or before then, perhaps inside the "
                    "window, whose data the models then took as healthy (a --train that "
                    "ends earlier tells)",
                )
            )
        after = ev.get("searched_after")
        if isinstance(after, Mapping):
            stretch = after.get("stretch_s") or []
            text = (
                f"found by a search again with the same models from "
                f"{w(after.get('search_start_s'))}, after a stretch "
                f"({_span(stretch)}) whose anomaly the detectors attributed to no sensor"
            )
            if after.get("onset_at_or_before"):
                text += "; it was there when that search began, so it may have begun in the stretch"
            out.append(Fact("Searched again", text))
        without = ev.get("searched_without")
        if without:
            out.append(
                Fact(
                    "Searched without",
                    f"{', '.join(str(c) for c in without)}: found by a second search fitted on "
                    "the healthy window without these channels (missing for long, or found "
                    "faulty beside anomalies no sensor explained)",
                )
            )
        gap = ev.get("after_gap_s")
        if isinstance(gap, Sequence) and len(gap) == 2:
            out.append(
                Fact(
                    "After a gap",
                    f"found soon after a gap in its data from {w(gap[0])} to "
                    f"{w(gap[1])}: it may have begun in the gap",
                )
            )
        frozen = ev.get("frozen")
        if isinstance(frozen, Mapping):
            out.append(
                Fact(
                    "Frozen readings",
                    f"median reading {fmt.num(frozen.get('level'))}, varying "
                    f"{fmt.num(frozen.get('std_ratio'), 3)} × their healthy spread"
                    + (f" (the residual alone gave {frozen['was']})" if frozen.get("was") else ""),
                )
            )
        clipped = ev.get("clipped")
        if isinstance(clipped, Mapping):
            out.append(Fact("Clipping", _clipped(clipped, w)))
        return out

    def evidence_facts(self, ev: Mapping[str, Any]) -> list[tuple[str, list[Fact]]]:
        known = {
            "first_alarm_s": ("first alarm", lambda v: self.when(v)),
            "peak_over_threshold": ("peak / threshold", lambda v: fmt.num(v, 3)),
            "p_value": ("p-value (healthy data this extreme)", _pvalue),
            "explained": ("share of residual explained by the fault model", fmt.percent),
            "type_weights": ("type weights", _weights),
            "noise_scale": ("residual spread / healthy spread (fitted)", lambda v: fmt.num(v, 3)),
            # "law 0; law 3 (circle)": the network's diagnosis laws (Wang & Song 2014,
            # Section 6.2) that attributed the alarm, said once ("law: law 0" before)
            "law": ("sensor-network diagnosis laws applied", _laws),
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
            # (its fault's onset: a correction from the record's start starts before it)
            onset = c.get("onset_s", c.get("start_s"))
            if abs(float(onset or 0) - float(f.get("onset_s") or 0)) > 1.0:
                continue
            out.append(
                [
                    Fact("method", str(c.get("method"))),
                    Fact(
                        "period",
                        f"{self.when(c.get('start_s'))} to "
                        + (self.when(c["end_s"]) if c.get("end_s") is not None else "the end"),
                    ),
                    Fact("samples corrected", fmt.num(c.get("samples"), 12)),
                    Fact("mean fault removed", fmt.num(c.get("mean_fault"))),
                    Fact("RMS fault removed", fmt.num(c.get("rms_fault"))),
                    *([Fact("note", str(c["note"]))] if c.get("note") else []),
                ]
            )
        return out


# -- helpers ------------------------------------------------------------------------------


def _laws(v: Any) -> str:
    """``law 0; law 3 (circle)`` as ``0; 3 (circle)``: the label names the laws."""
    return re.sub(r"\blaw (\d)", r"\1", str(v))


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


def _clipped(c: Mapping[str, Any], when: fmt.Clock) -> str:
    """A clipping sensor's evidence: ``at +4.2 (high) and -4.2 (low): 812 readings (31.5 %
    of those from the first to the last) from 720.000 s to 1200.000 s; 21 findings merged
    (additive, other)``."""
    limits = [
        f"{fmt.num(c[k])} ({side})"
        for k, side in (("clipped_high", "high"), ("clipped_low", "low"))
        if c.get(k) is not None
    ]
    text = (
        f"at {' and '.join(limits) or fmt.MISSING}: {fmt.num(c.get('readings'), 12)} readings "
        f"({fmt.percent(c.get('fraction'))} of those from the first to the last) from "
        f"{when(c.get('first_s'))} to {when(c.get('last_s'))}"
    )
    merged = c.get("findings_merged")
    if merged:
        types = ", ".join(str(t) for t in c.get("types_merged") or [])
        text += f"; {merged} findings merged" + (f" ({types})" if types else "")
    if c.get("in_healthy_window_from_s") is not None:
        text += (
            f"; it clipped in the healthy window too, from {when(c['in_healthy_window_from_s'])}"
        )
    return text


def _sections(detailed: Sequence[int], total: int) -> str:
    """Which findings have a section, when not all do: ``findings 1-6`` (indices of
    ``detailed``, 0-based, shown 1-based), for the page's text; empty when all do."""
    if len(detailed) >= total:
        return ""
    if not detailed:
        return "none"
    runs: list[list[int]] = []
    for i in detailed:
        if runs and i == runs[-1][-1] + 1:
            runs[-1].append(i)
        else:
            runs.append([i])
    parts = [f"{r[0] + 1}" if len(r) == 1 else f"{r[0] + 1}-{r[-1] + 1}" for r in runs]
    return ("finding " if len(detailed) == 1 else "findings ") + ", ".join(parts)


def _pvalue(v: Any) -> str:
    """A p-value; an underflowed 0 is shown as the bound it is."""
    return "< 1e-300" if v == 0 else fmt.num(v, 3)


def _weights(v: Any) -> str:
    if not isinstance(v, Mapping):
        return fmt.scalar(v)
    return ", ".join(f"{k} {fmt.num(x, 3)}" for k, x in v.items())


__all__ = ["MAX_DETAILED", "FigureView", "FindingView", "ReportView", "build_view"]


def _open_end(evidence: Mapping[str, Any], when: fmt.Clock | int) -> str:
    """A finding's end where it has none: to the end of the record, or of its channel's
    data where the channel stopped publishing while the fault was under way
    (``evidence.data_ends_s``: no recovery is known)."""
    ends = evidence.get("data_ends_s")
    if ends is None:
        return "to the end"
    return f"to the end of its data ({fmt.as_clock(when)(float(ends))}: the channel stops there)"


NO_RANGE: dict[str, str] = {
    "the size came from a step after": "no range: measured after the fit, which gives none",
    "the detector that sized it": "no range: its detector gives none",
}
"""Why a size has no range, in a few words for the verdict's cell, by the start of
findings.json's ``interval_notes.magnitude`` (:func:`analyzer.findings.finding_intervals`)."""


def no_range(f: Mapping[str, Any]) -> str:
    """`` (no range: measured after the fit, which gives none)`` beside a fitted size
    (an offset, a gain other than a dead sensor's 0, a drift) that has no interval: in
    a table where the next row's size has one, a reader saw no reason for the
    difference (it sat in the notes). Empty where the size has its range or is of no
    fitted shape."""
    mag = f.get("magnitude") or {}
    note = str((f.get("interval_notes") or {}).get("magnitude") or "")
    if f.get("magnitude_interval") or not note:
        return ""
    fitted = "offset" in mag or "rate_per_s" in mag or "gain" in mag
    if not fitted or fmt.num(mag.get("gain", 1.0)) == "0" or "rms" in mag or "stuck_at" in mag:
        return ""
    said = next((v for k, v in NO_RANGE.items() if note.startswith(k)), "")
    return f" ({said or 'no range: ' + note.split(':')[0]})"


def onset_words(f: Mapping[str, Any], when: fmt.Clock | int) -> str:
    """A finding's onset as the report's table says it: ``30.000 s``; ``at or before
    12.000 s`` where it is an upper bound (:func:`~analyzer.report.view_figures.
    onset_bound`: there when a search began after the training window or after a
    stretch); and for a fault there when the detectors could first judge the record
    (evidence ``onset_at_or_before``: a constant channel from its first sample,
    ``--model`` from the filters' warm-up) ``from the start``, with the time before
    which nothing was judged where that is not the first sample, as ``analyzer run``'s
    last line and the watcher's index say it. One fault present from the first sample
    read "at or before 0.000 s" from one detector and "at or before 3.600 s" from
    another (ux53 item 8); ``onset_s`` is unchanged. ``when``: the record's
    :class:`~analyzer.report.format.Clock` (or the decimals of a short record's seconds)."""
    at = f.get("onset_s")
    said = fmt.as_clock(when)
    if (f.get("evidence") or {}).get("onset_at_or_before"):
        if said(at) in (fmt.MISSING, said(0.0)):
            return "from the start"  # (at 0, or not known: it read "before n/a")
        return f"from the start (not judged before {said(at)})"
    return ("at or before " if onset_bound(f) else "") + said(at)


def _onset_fact(f: Mapping[str, Any], when: fmt.Clock | int) -> str:
    """The finding's "Onset" line: :func:`onset_words` and "from the start" with its 95 %
    interval (findings.json's ``onset_interval_s``), unless those words say the start
    already, then its UTC time where it has one, in the parenthesis those words may have
    opened (not a second one after it)."""
    words = onset_words(f, when)
    utc = str(f.get("onset") or "")
    if not words.startswith("from the start"):
        within = fmt.onset_interval(f.get("onset_interval_s"), when)
        return f"{words} from the start{within}" + (f" ({utc})" if utc else "")
    if not utc:
        return words
    return f"{words[:-1]}, {utc})" if words.endswith(")") else f"{words} ({utc})"
