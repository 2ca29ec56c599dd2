"""The records the report's templates display: plain dataclasses of display strings,
figures and nested records, one per part of the report (a finding, its figures and test
tables, an input, a channel, a detector's model, a method, the whole report).

:mod:`analyzer.report.view` builds them from the analysis with its figure and table parts
(:mod:`analyzer.report.view_figures`, :mod:`analyzer.report.view_tables`). All three
construct these records and the first imports the other two, so the records are a module
of their own, below all of them, rather than part of :mod:`analyzer.report.view`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from markupsafe import Markup

from analyzer.report import format as fmt
from analyzer.report.methods import Method
from analyzer.report.notes import Notes

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
    mean_read: str = ""
    """Which mean test the type vote read (``MEAN_READ``), "" without the long-run one."""


@dataclass(slots=True)
class FindingView:
    number: int
    anchor: str
    channel: str
    type: str
    onset_s: str
    """The onset as the table says it: ``30.000 s``, ``at or before 12.000 s``, or, for a
    fault there when the detectors could first judge the record, ``from the start (not
    judged before 3.600 s)`` (:func:`~analyzer.report.view.onset_words`)."""
    onset_utc: str
    end_s: str
    end_utc: str
    onset_clock: str
    end_clock: str
    onset_fact: str
    """The onset as the finding's "Onset" line says it: ``30.000 s from the start``, or
    :attr:`onset_s` where that already says the start."""
    magnitude: str
    confidence: str
    detectors: list[str]
    lead: str
    tests_agree: str = ""
    detailed: bool = False
    figures: list[FigureView] = field(default_factory=list)
    tests: list[DetectorTests] = field(default_factory=list)
    found: list[Fact] = field(default_factory=list)
    """The fault's own evidence beyond the detectors' (onset bound, frozen readings,
    clipping, a second search), a line each."""
    evidence: list[tuple[str, list[Fact]]] = field(default_factory=list)
    corrections: list[list[Fact]] = field(default_factory=list)
    remarks: list[str] = field(default_factory=list)
    size: str = ""
    """The size against the sensor's spread in the training window
    (:func:`analyzer.report.format.relative_size`); empty where there is none."""
    small: bool = False
    """Below :data:`analyzer.report.format.SMALL_SIZE` of that spread."""
    no_range: str = ""
    """Why the magnitude has no range, where a fitted size has none (`` (no range:
    ...)``, :func:`analyzer.report.view.no_range`)."""
    check: str = ""
    """What to look at on the sensor (findings.json's ``check``,
    :func:`analyzer.what_to_check.what_to_check`)."""
    type_words: str = ""
    """The type as a reader says it: ``offset (zero shift)``, ``gain (scale error)``."""
    partial: bool = False
    """The magnitude's range counts noise only (a gain's): :attr:`ReportView.noise_only`
    says what that means."""
    label: str = ""
    """The name the channel's message gives it (a ``JointState``'s joint:
    findings.json's ``label``), shown beside it; empty where there is none."""
    strength: str = ""
    """How much evidence stands behind it, in words: ``strong``, ``moderate``, ``weak:
    confirm before sending anyone`` (findings.json's ``evidence_label``,
    :mod:`analyzer.evidence_label`)."""
    strength_why: str = ""
    """Why that label (``evidence_label_why``, joined)."""


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
    renamed: str = ""
    """Where ``--rename`` (or the config's ``[rename]``) joined another name to it: what
    it was read from (``read from s3b in log_02.csv``, :func:`~analyzer.readers.
    renamed_words`), under its name."""


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
    """Findings listed in the verdict table only (past :data:`~analyzer.report.view.
    MAX_DETAILED`)."""
    detailed: int
    """Findings with a section of their own (the page says how many)."""
    checked: list[Fact]
    skipped: list[Fact]
    by_default: list[Fact]
    """Detectors not run because they run only with a config (:data:`~analyzer.report.
    view.NEEDS_CONFIG`): the normal case without one."""
    notes: list[str]
    input_errors: list[str]
    inputs: list[InputView]
    channels: list[ChannelView]
    coverage: FigureView | None
    coverage_note: str
    train: str
    config: str
    """The ``--config`` file and what it set (empty without one)."""
    models_heading: str
    reused: bool
    models: list[ModelView]
    methods: list[MethodView]
    tests_method: Method
    decision: str
    thresholds: list[Fact]
    timings: list[Fact]
    figure_failures: list[str] = field(default_factory=list)
    """One line per figure that could not be drawn (also among :attr:`notes`)."""
    levels: FigureView | None = None
    """Every analyzed channel's response level over time (:func:`figures.level_figure`)."""
    sections: str = ""
    """Which findings have a section (``findings 1-6``) when not all do, else empty."""
    sorted_notes: Notes = field(default_factory=Notes)
    """:attr:`notes`, :attr:`input_errors` and :attr:`skipped` grouped by kind, with the
    count line (:func:`analyzer.report.notes.sort_notes`)."""
    small_size: str = fmt.num(fmt.SMALL_SIZE)
    """Below what share of the sensor's usual spread a finding is called small."""
    time_source: str = ""
    """Which time the messages' samples were placed at (``findings.json``'s
    ``time_source``), said in the Archive section; empty for CSV files alone."""
    caveats: list[str] = field(default_factory=list)
    """What changes how to read the findings, shown beside the verdict: the key notes
    and each onset that is only a bound (:func:`analyzer.report.notes.onset_lines`)."""
    saved: str = ""
    """With ``--save-model``: where the fitted models went, what was searched after the
    training window and the warnings about it (:meth:`~analyzer.report.view._Access.
    saved_text`)."""
    nothing_searched: bool = False
    """A ``--save-model`` run whose training window is the whole record: nothing was
    searched, and the verdict does not say "no sensor fault found"."""
    utc_words: str = "the time in UTC"
    """How the page names the absolute times below the seconds: in UTC, with the offset
    the input's clock used, or read as UTC where the file gives no zone
    (:meth:`analyzer.report.view._Access.zone_words`)."""
    healthy_words: str = ""
    """The healthy verdict's sentence (:mod:`analyzer.report.healthy`): what was taken
    as healthy and was not itself checked."""
    time_words: str = "seconds"
    """What the verdict table's onsets and ends are written in (:meth:`analyzer.report.
    format.Clock.words`): ``seconds``, or ``minutes and seconds`` in a long record."""
    noise_only: str = ""
    """Why a range marked "noise only" (a gain's) is narrower than a 95 % one and how
    often it held the true gain, where a finding has such a range; else empty."""
    load_change: str = ""
    """The verdict's line on a change of the whole structure's response that findings
    overlap (their ``level_change``): they may be that change, not sensors; else empty."""
    strength_note: str = ""
    """What the evidence labels mean and how often each was right in the sweeps, under
    the verdict table."""
    unexplained: str = ""
    """The verdict's warning: alarms the findings do not explain (``findings.json``'s
    ``unexplained_alarms``: a second faulty sensor the run may have missed), else empty."""


__all__ = [
    "ChannelTable",
    "ChannelView",
    "DetectorTests",
    "Fact",
    "FigureView",
    "FindingView",
    "InputView",
    "MethodView",
    "ModelView",
    "ReportView",
    "TestCell",
    "TestRow",
]
