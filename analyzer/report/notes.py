"""The report's notes, sorted for people: what the analysis noted (findings.json's
``notes``), the inputs' errors and the detectors that did not run, grouped by kind, with
the few that change how the findings read picked out for the verdict.

On real records the page showed a dozen or more notes (batched log times, channels left
out, a training window that was not steady, detectors not run) before the first finding;
the one note that said the findings might be misplaced read like the rest. Now the
verdict and the findings come first; the notes follow in a section of their own, a group
per kind (each a ``<details>``, no script), under one line that counts them; the notes
that change how to read the findings (:data:`KEY`) stay visible beside the verdict as
well. Nothing is dropped: a note of no known kind lands in :data:`OTHER`, and every note
is in exactly one group.

The notes are free text written across the analysis (readers, pipeline, diagnosis,
detectors); the kinds are read from their wording (:data:`KINDS`), first match wins, so a
new wording at worst lands in a neighbouring group or in :data:`OTHER`, never off the
page.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from analyzer.report.format import Clock, as_clock

INPUT_ERRORS = "input errors"
SKIPPED = "detectors not run"
OTHER = "other"

KINDS: tuple[tuple[str, str, re.Pattern[str]], ...] = (
    # (kind, heading, wording): the first that matches a note gives its kind
    # (a run whose detectors could not run, that reports a dead sensor alone: its
    # note quotes their reasons, which name a [[group]] or the training window)
    ("findings", "About the findings", re.compile(r"^no fault but a dead or stuck sensor")),
    (
        "training",
        "About the training window",
        re.compile(
            r"is not steady|^trained on |default window cut before|traced back to"
            r"|^fitted models from|the model's healthy window|the model was fitted on"
            r"|^--train\b"
        ),
    ),
    (
        "channels",
        "About which channels were analyzed",
        re.compile(
            r"not analyzed|not in the model|\[\[group\]\]|channels analyzed in \d+ groups"
            r"|searched again without|copies of another channel|left out of the analysis"
        ),
    ),
    (
        "input",
        "About the input",
        re.compile(
            r"distinct log times|distinct values|timestamp|--time\b|sampled at|\bgaps?\b"
            r"|outage|logger|--rate\b|quantiz|missing for|repeat|silent mid-record"
            r"|\bno reading in (?:its|their) (?:first|last) "
        ),
    ),
    (
        "alarms",
        "About alarms not reported as faults",
        re.compile(
            r"not attributed|not reported|explained by|^alarms? |^anomaly|^residual anomaly"
            r"|gain-like change|such anomalies|cannot be diagnosed"
        ),
    ),
    (
        "findings",
        "About the findings",
        re.compile(
            r"\bfault on\b|findings have a confidence|dead \(reads 0\)|\bclips at\b"
            r"|a gain of |present when the search started|is reported although"
        ),
    ),
    ("report", "About this page", re.compile(r"^report: ")),
)
"""Each kind of note: its name, its group's heading and the wording that marks it."""

HEADINGS = {
    **{kind: heading for kind, heading, _ in KINDS},
    INPUT_ERRORS: "Input errors",
    SKIPPED: "Detectors not run",
    OTHER: "Other notes",
}

COUNTED = {
    "training": "about the training window",
    "channels": "about which channels were analyzed",
    "input": "about the input",
    "alarms": "about alarms not reported as faults",
    "findings": "about the findings",
    "report": "about this page",
    OTHER: "other",
}
"""How the count line names each kind (``3 about the input``); input errors and
detectors not run are counted as such (``1 input error``)."""

ORDER = (INPUT_ERRORS, "training", "findings", SKIPPED, "channels", "input", "alarms")
"""The groups' order on the page: what bears most on the findings first."""

KEY = re.compile(
    r"is not steady|^trained on |default window cut before|traced back to"
    r"|present when the search started|findings ha(?:ve|s) a confidence below"
    r"|the archive's spread against the model's|may be missed"
    r"|^no fault but a dead or stuck sensor|may be the recorder's delay, not the sensor's"
    r"|^analyzed channels silent mid-record|\bno reading in (?:its|their) (?:first|last) "
)
"""Notes that change how to read the findings, shown beside the verdict: the training
window was not steady (the models took a change for health, faults may be missed or
misplaced) or was cut before such a change; a fault traced back into the window or to
the record's start; findings of weak confidence; an archive whose spread is not the
model's; a clock so fast for the signal that a gain or a slow change may be missed; a
run whose detectors could not run, that searched for nothing but dead or stuck sensors;
a finding whose onset coincides with a message the recorder logged late
(:func:`analyzer.delay_note.onset_cautions`); an analyzed sensor silent for a while
mid-record (:func:`analyzer.silence_note.silence_note`), or without a reading for long at
the record's start or end (:class:`analyzer.silence_note.StoppedNote`: a topic that
stopped for good, said among the other notes alone)."""

ON_A_FINDING = re.compile(r"a finding on it may be")
"""A caveat about some channels (``a finding on it may be rounding: s3``): beside the
verdict when one of the channels it names (after its last colon) has a finding."""


@dataclass(slots=True)
class NoteGroup:
    kind: str
    heading: str
    notes: list[str]
    labels: list[str] = field(default_factory=list)
    """A bold label before each note where the group has them (a detector's name before
    why it did not run); empty otherwise."""

    @property
    def items(self) -> list[tuple[str, str]]:
        """(label, note) pairs, the label empty where there is none."""
        labels = self.labels or [""] * len(self.notes)
        return list(zip(labels, self.notes, strict=True))


@dataclass(slots=True)
class Notes:
    """The notes of one report, sorted (see the module doc)."""

    groups: list[NoteGroup] = field(default_factory=list)
    key: list[str] = field(default_factory=list)
    """The notes that change how to read the findings (also in their groups)."""
    count: str = ""
    """``14 notes: 11 about the input, 2 about which channels were analyzed, 1 about the
    training window``; empty without notes."""

    @property
    def total(self) -> int:
        return sum(len(g.notes) for g in self.groups)

    @property
    def pointer(self) -> str:
        """The verdict's line about the notes: the count, whether the ones shown beside
        it are among them, and where the rest are; empty without notes."""
        if not self.count:
            return ""
        k = len(self.key)
        among = (
            ""
            if not k
            else "; the one shown above is among them"
            if k == 1
            else f"; the {k} shown above are among them"
        )
        where = "It is" if self.total == 1 else "All are"
        return f"{self.count}{among}. {where} under Notes, after the findings."


def kind_of(note: str) -> str:
    """The kind of one of the analysis's notes (:data:`KINDS`; :data:`OTHER` if none)."""
    for kind, _, pattern in KINDS:
        if pattern.search(note):
            return kind
    return OTHER


def is_key(note: str, faulty: Iterable[str] = ()) -> bool:
    """Whether ``note`` changes how to read the findings (:data:`KEY`, or
    :data:`ON_A_FINDING` naming one of the ``faulty`` channels)."""
    if KEY.search(note):
        return True
    if ON_A_FINDING.search(note):
        named = {c.strip() for c in note.rsplit(": ", 1)[-1].split(", ")}
        return bool(named & set(faulty))
    return False


def sort_notes(
    notes: Sequence[str],
    input_errors: Sequence[str] = (),
    skipped: Mapping[str, str] | None = None,
    faulty: Iterable[str] = (),
) -> Notes:
    """The notes grouped by kind, in :data:`ORDER` (then any other kind), each note once
    and in its order of writing within its group; the key ones picked out; the count
    line. ``skipped``: why each detector that did not run did not, by name."""
    skipped = dict(skipped or {})
    by_kind: dict[str, list[str]] = {
        INPUT_ERRORS: [str(e) for e in input_errors],
        SKIPPED: [str(v) for v in skipped.values()],
    }
    for n in notes:
        by_kind.setdefault(kind_of(str(n)), []).append(str(n))
    kinds = [k for k in ORDER if by_kind.get(k)]
    kinds += [k for k in by_kind if k not in kinds and by_kind[k]]
    groups = [
        NoteGroup(
            k,
            HEADINGS.get(k, HEADINGS[OTHER]),
            by_kind[k],
            labels=[str(name) for name in skipped] if k == SKIPPED else [],
        )
        for k in kinds
    ]
    chosen = set(faulty)
    key = [str(n) for n in notes if is_key(str(n), chosen)]
    return Notes(groups, key, count_line(groups))


def count_line(groups: Sequence[NoteGroup]) -> str:
    """``7 notes: 3 about the input, 2 about the training window, 1 input error, 1
    detector not run``; empty for none."""
    total = sum(len(g.notes) for g in groups)
    if not total:
        return ""
    parts = []
    for g in groups:
        n = len(g.notes)
        if g.kind == INPUT_ERRORS:
            parts.append(f"{n} input error{'s' if n != 1 else ''}")
        elif g.kind == SKIPPED:
            parts.append(f"{n} detector{'s' if n != 1 else ''} not run")
        else:
            parts.append(f"{n} {COUNTED.get(g.kind, COUNTED[OTHER])}")
    return f"{total} note{'s' if total != 1 else ''}: " + ", ".join(parts)


def onset_lines(
    faults: Sequence[Mapping[str, Any]], notes: Sequence[str], when: Clock | int = 3
) -> list[str]:
    """A line for the verdict for each finding whose onset is only an upper bound because
    the fault was there when the search began, right after the training window
    (findings.json's ``evidence.onset_at_search_start``): it may have begun inside the
    window, whose data the models then took as healthy. Only its evidence said so (an
    "at or before" in the table); with ``--model`` (``onset_at_or_before``), and where a
    note traced the fault back into the window, the analysis's own note says it already
    (:data:`KEY`). ``when``: the record's clock, or the decimals of its seconds."""
    out = []
    for i, f in enumerate(faults):
        if not (f.get("evidence") or {}).get("onset_at_search_start"):
            continue
        channel = str(f.get("channel"))
        if any(f"fault on {channel} from" in str(n) and KEY.search(str(n)) for n in notes):
            continue
        at = f.get("onset_s")
        said = "?" if at is None else as_clock(when)(float(at))
        out.append(
            f"finding {i + 1} ({channel}) was there when the search began at {said}, right "
            "after the training window: it began then or earlier, perhaps inside the "
            "window, which the models then took as healthy (a --train that ends earlier "
            "tells)"
        )
    return out


__all__ = [
    "HEADINGS",
    "KEY",
    "KINDS",
    "NoteGroup",
    "Notes",
    "count_line",
    "is_key",
    "kind_of",
    "onset_lines",
    "sort_notes",
]
