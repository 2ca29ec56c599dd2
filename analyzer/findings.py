"""One run's result (:class:`Analysis`) and its outputs: ``findings.json`` exactly as in
CONTRACT.md (plus extension fields), ``report.html`` and, with ``--corrected``,
``corrected.csv``."""

from __future__ import annotations

import csv
import hashlib
import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from analyzer import __version__
from analyzer.data_ends import data_end
from analyzer.detectors import DetectorResult
from analyzer.diagnosis import Finding
from analyzer.diagnosis.levels import excursions
from analyzer.diagnosis.oversampled import Oversampled
from analyzer.diagnosis.unexplained import Unexplained
from analyzer.error_file import touches_inputs
from analyzer.evidence_label import fault_label, level_changes
from analyzer.modelfile import SavedModel
from analyzer.outdir import spreadsheet_safe, staged
from analyzer.readers import renamed_from_json, renamed_successors
from analyzer.readers.base import InputInfo, channel_labels
from analyzer.regenerate import write_corrected_csv
from analyzer.selection import STUCK_SAMPLES
from analyzer.silent import MIN_SAMPLES as SILENT_SAMPLES
from analyzer.silent import MIN_WINDOWS as SILENT_WINDOWS
from analyzer.silent import SILENT_CHECK
from analyzer.store import ChannelInfo
from analyzer.timeutil import DURATION_DECIMALS, iso_utc, json_time, seconds_text
from analyzer.types import NS_PER_S, Format
from analyzer.what_to_check import channel_units, what_to_check

SCHEMA = "analyzer.findings/1"

CORRECTED_CSV = "corrected.csv"
"""What ``run --corrected`` writes beside ``findings.json``, which names it
(``corrected_csv``): how a later run into the same folder knows the file as the
analyzer's own (:func:`earlier_corrected`)."""


@dataclass(slots=True)
class Analysis:
    """Everything one run found; ``findings.json`` and the report are views of it."""

    inputs: list[InputInfo]
    channels: list[ChannelInfo]
    analyzed: tuple[str, ...]
    rate_hz: float
    start_ns: int
    absolute_time: bool
    n: int
    train: tuple[int, int]
    results: list[DetectorResult]
    findings: list[Finding]
    values: np.ndarray
    notes: list[str] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    skipped: dict[str, str] = field(default_factory=dict)
    corrected: np.ndarray | None = None
    """With ``--corrected``: the analyzed channels with every fault removed (Wang & Song
    2014, Section 6.3), same shape as ``values``."""
    corrections: list[dict[str, Any]] = field(default_factory=list)
    saved: SavedModel | None = None
    """The fitted models of this run (with ``--save-model``), or those it ran (``--model``)."""
    model_info: dict[str, Any] | None = None
    """With ``--model``: the model file and what it was trained on (``findings.json``)."""
    config_info: dict[str, Any] | None = None
    """With ``--config``: the file, its digest and its settings (``findings.json``,
    :meth:`analyzer.config.Config.info`)."""
    saved_model: dict[str, Any] | None = None
    """With ``--save-model``: the file the fitted models are saved to, its SHA-256, the
    window they were fitted on, what was searched after it (None: nothing) and the
    warnings about that window (``findings.json``'s ``saved_model``; set by
    :func:`analyzer.pipeline.run`)."""
    screen: dict[str, Any] | None = None
    """With ``--screen``: the screening's detectors and whether they found a fault
    (``findings.json``), from :func:`analyzer.pipeline.analyze_screened`."""
    settling: dict[str, int] = field(default_factory=dict)
    """Per detector, the samples from the record's start its filters take to forget
    their start state (:func:`analyzer.reuse.settling_rows`): the report's whole-record
    residual is scaled from the samples after them."""
    levels: Any = None
    """Each analyzed channel's response level over time
    (:class:`analyzer.diagnosis.levels.Levels`): the report's level map."""
    healthy: dict[str, tuple[float, float]] = field(default_factory=dict)
    """Each analyzed channel's mean and standard deviation over the healthy training
    window (:func:`analyzer.diagnosis.stuck.healthy_stats`, computed once by the fit;
    with ``--model`` the model's): the yardstick of each finding's ``size_relative``."""
    no_reading: dict[str, str] = field(default_factory=dict)
    """The channels of the inputs with no reading at all (a CSV column blank in every row,
    an MCAP field NaN in every message, every value a ``--missing-values`` code or beyond
    1e30), not analyzed, each with what its values were (``blank in every row``): they
    have no :class:`~analyzer.store.ChannelInfo`, and findings.json's ``channels[]``
    left them out, so a script never learnt a column of the file was dead (ch56)."""
    renamed: dict[str, dict[str, tuple[str, ...]]] = field(default_factory=dict)
    """The renames applied (``--rename NEW=OLD`` and the config's ``[rename]``): by OLD
    channel, each NEW name read as it and the inputs that held NEW
    (:func:`~analyzer.readers.applied_renames`): each channel's ``renamed_from`` in
    findings.json. The config's table alone was written (``config.rename``), the
    option not at all: a reader could not tell where a joined channel's samples came from."""
    left_out: dict[str, dict[str, str]] = field(default_factory=dict)
    """Why each channel not analyzed was left out: ``{"why": ...}`` (and ``"copy_of"``),
    as ``inspect --json`` says it (:func:`analyzer.selection.left_out`):
    findings.json's ``channels[]``."""
    unrun: Exception | None = None
    """Why the detectors could not run where the run reported the constant check's
    findings alone (a dead sensor the user named needs no model: :func:`analyzer.
    pipeline._constant_only_possible`); ``None`` where they ran. The watcher raises it
    again where it is a too-short archive's, which waits in INBOX to grow."""
    unexplained: list[Unexplained] = field(default_factory=list)
    """Alarms the findings do not explain (:mod:`analyzer.diagnosis.unexplained`): a
    second faulty sensor the run may have missed (``findings.json``'s
    ``unexplained_alarms``, the verdict's warning, the run's last line)."""
    slowed: Oversampled | None = None
    """Where the run chose a slower clock itself (no ``--rate``): the rate the channels
    were logged at, their content and the rate they were analyzed at (``rate_hz``;
    :func:`analyzer.diagnosis.oversampled.oversampled`): ``findings.json``'s
    ``logged_rate_hz``."""

    time_source: str | None = None
    """Which time the messages' samples were placed at: ``"log"`` (when the recorder
    wrote each message) or ``"header"`` (each message's ``header.stamp``, its log time
    where it has none), as ``--time`` chose; None where no input has messages (CSV files
    alone: their time column): :func:`time_source` (``findings.json``'s ``time_source``)."""

    cautions: dict[tuple[str, float], str] = field(default_factory=dict)
    """Per finding (its channel and ``onset_s``) whose onset coincides with a message its
    topic's recorder logged late (:func:`analyzer.delay_note.onset_cautions`): the
    caution, ``findings.json``'s ``faults[].caution``."""

    @property
    def duration_s(self) -> float:
        """``n / rate``: the time ``n`` samples cover (one sample period each)."""
        return self.n / self.rate_hz

    @property
    def faulty(self) -> bool:
        return bool(self.findings)

    def times_s(self) -> np.ndarray:
        return np.arange(self.n) / self.rate_hz

    def times_between(self, a: int, b: int) -> np.ndarray:
        """Rows ``a .. b - 1`` of :meth:`times_s`."""
        return np.arange(a, b) / self.rate_hz

    @property
    def labels(self) -> dict[str, str]:
        """The channels' labels, where their messages name them (a ``JointState``'s
        joint: :func:`~analyzer.readers.base.channel_labels`)."""
        return channel_labels(self.inputs, (c.name for c in self.channels))

    def onset_iso(self, seconds: float | None) -> str | None:
        if seconds is None or not self.absolute_time:
            return None
        return iso_utc(self.start_ns + int(round(seconds * NS_PER_S)))


MESSAGE_FORMATS = frozenset({Format.MCAP, Format.ROS1BAG, Format.ROS2BAG})
"""Input formats of messages, each with a log time and perhaps a ``header.stamp``:
those ``--time`` applies to."""


def time_source(inputs: Sequence[InputInfo], chosen: str) -> str | None:
    """``findings.json``'s ``time_source``: ``chosen`` (``--time``: ``"log"`` or
    ``"header"``) where any of ``inputs`` is an MCAP or ROS bag, whose samples it placed;
    None for CSV files alone, timed by their own time column whatever ``--time`` says.
    The two choices can give different findings (a recorder that logs a message late
    moves its sample on the log-time axis, not on the header's): a reader of the file
    alone could not tell which it was (the robotics audit ux58 item 4)."""
    return chosen if any(i.format in MESSAGE_FORMATS for i in inputs) else None


def sha256_of(path: Path) -> str:
    h = hashlib.sha256()
    if path.is_dir():
        for p in sorted(path.rglob("*")):
            if p.is_file():
                h.update(p.relative_to(path).as_posix().encode())
                _hash_file(h, p)
        return h.hexdigest()
    _hash_file(h, path)
    return h.hexdigest()


def _hash_file(h: Any, path: Path) -> None:
    with path.open("rb") as f:
        while blk := f.read(1 << 20):
            h.update(blk)


def input_digest(path: Path) -> str:
    """An input's SHA-256, or "" when it is gone."""
    return sha256_of(path) if path.exists() else ""


def findings_document(analysis: Analysis) -> dict[str, Any]:
    """``findings.json`` exactly as in CONTRACT.md (plus extension fields)."""
    doc = _document(analysis)
    unknown = [line for f in analysis.findings if (line := not_finite_note(f, analysis.labels))]
    if unknown:
        doc["notes"] = [*doc["notes"], *unknown]
    return doc


CONTRACT_NUMBERS = ("offset", "gain", "rate_per_s")
"""The sizes CONTRACT.md says are numbers (``magnitude``'s); its other keys (``rms``,
``stuck_at``, a clipping's limits...) are the analyzer's own and may be null."""

LARGEST = float(np.finfo(np.float64).max)
"""The largest finite number JSON and a double hold, written for an infinite size."""


def contract_magnitude(magnitude: Mapping[str, Any]) -> dict[str, Any]:
    """A fault's ``magnitude`` for findings.json: the contract's three sizes always
    numbers (CONTRACT.md; the schema allowed null, a QA audit's ux59 item L7), the
    others null where not finite. None of them was ever found not finite (ux59 and the
    int56 audit tried infinite, NaN, 1e300 and 1e-160 readings, values at the 1e30
    limit beyond which readings are gaps, dead sensors): should one be, an infinite
    size is written as the largest double with its sign (it is larger than any number
    findings.json can hold), one that is not a number as 0, and
    :func:`not_finite_note` says so in the notes."""
    out: dict[str, Any] = {}
    for key, value in magnitude.items():
        v = float(value)
        if key in CONTRACT_NUMBERS and not math.isfinite(v):
            v = math.copysign(LARGEST, v) if math.isinf(v) else 0.0
        out[str(key)] = v if math.isfinite(v) else None
    return out


def contract_confidence(confidence: float) -> float:
    """A fault's ``confidence`` for findings.json: 0-1 to 4 decimals, always a number
    (CONTRACT.md). One not finite (never found) is written 0, the analyzer not sure of
    the fault at all, rather than null: the fault is still listed and the exit code
    still 1; :func:`not_finite_note` says so in the notes."""
    c = float(confidence)
    return round(c, 4) if math.isfinite(c) else 0.0


def not_finite_note(f: Finding, labels: Mapping[str, str] | None = None) -> str | None:
    """The note for a fault whose contract sizes or confidence were not finite numbers
    (:func:`contract_magnitude`, :func:`contract_confidence`), None for every other."""
    bad = [k for k in CONTRACT_NUMBERS if k in f.magnitude and not _finite(f.magnitude[k])]
    if not _finite(f.confidence):
        bad.append("confidence")
    if not bad:
        return None
    name = (labels or {}).get(f.channel, f.channel)
    return (
        f"{name}'s {str(f.type)} fault at {seconds_text(f.onset_s)} s: its {', '.join(bad)} could "
        "not be computed (not a finite number); findings.json gives 0 for one that is not a "
        "number and the largest number it can hold, with its sign, for an infinite one"
    )


def _finite(x: Any) -> bool:
    try:
        return math.isfinite(float(x))
    except (TypeError, ValueError):
        return False


def _document(analysis: Analysis) -> dict[str, Any]:
    """:func:`findings_document` but for its notes of sizes not finite."""
    a = analysis
    train0, train1 = a.train
    labels = a.labels
    units = channel_units(a.inputs, {f.channel for f in a.findings})
    successors = renamed_successors(a.notes)
    # the stretches the run's level note names (the load or the structure changed)
    changed, _ = excursions(getattr(a, "levels", None))
    return {
        "schema": SCHEMA,
        "analyzer_version": __version__,
        "inputs": [
            {
                "path": str(i.path),
                "format": str(i.format),
                "sha256": i.sha256 or input_digest(Path(i.path)),
                "errors": list(i.errors),
            }
            for i in a.inputs
        ],
        "start": iso_utc(a.start_ns) if a.absolute_time else None,
        # (relative times: the file's own time of 0 s, which the *_s count from)
        "time_origin_s": None if a.absolute_time else round(a.start_ns / NS_PER_S, 9),
        "duration_s": round(a.duration_s, DURATION_DECIMALS),
        "rate_hz": a.rate_hz,
        # (log times or header stamps: which --time placed the messages' samples at)
        "time_source": getattr(a, "time_source", None),
        # (the rate the channels were logged at, where the run analyzed them slower)
        "logged_rate_hz": None if a.slowed is None else a.slowed.rate_hz,
        # (to four decimals, as onset_s: 19.980169008087802 was written)
        "train": {
            "start_s": json_time(train0 / a.rate_hz),
            "end_s": json_time((train1 - 1) / a.rate_hz),
        },
        "channels": [
            {
                "name": c.name,
                "samples": c.samples,
                "rate_hz": round(c.rate_hz, 6),
                "gaps": c.gaps,
                "analyzed": c.name in a.analyzed,
                # why not, where not (an Analysis of a caller that predates it has none)
                **({} if c.name in a.analyzed else getattr(a, "left_out", {}).get(c.name, {})),
                # the name the message gives it (a JointState's joint), where it has one
                **({"label": labels[c.name]} if c.name in labels else {}),
                **_renamed_from(a, c.name),
            }
            for c in a.channels
        ]
        + unread_channels(a),
        "faults": [
            _with_label(
                _with_check(
                    {
                        "channel": f.channel,
                        **({"label": labels[f.channel]} if f.channel in labels else {}),
                        "type": str(f.type),
                        "onset_s": json_time(f.onset_s),
                        "end_s": None if f.end_s is None else json_time(f.end_s),
                        "onset": a.onset_iso(f.onset_s),
                        "end": a.onset_iso(f.end_s),
                        # (numbers, as CONTRACT.md says, even should one not be finite)
                        "magnitude": contract_magnitude(f.magnitude),
                        "confidence": contract_confidence(f.confidence),
                        "detector": f.detector,
                        "evidence": _jsonable(f.evidence),
                        "size_relative": size_relative(
                            f.magnitude,
                            a.healthy.get(f.channel),
                            f.onset_s,
                            f.end_s if f.end_s is not None else data_end(f.evidence),
                            a.duration_s,
                        ),
                        **finding_intervals(f),
                        # (where its onset coincides with a message the recorder logged late)
                        **(
                            {"caution": said}
                            if (said := getattr(a, "cautions", {}).get((f.channel, f.onset_s)))
                            else {}
                        ),
                        # (where it overlaps a stretch of the level note: a load change)
                        **(
                            {"level_change": over}
                            if (over := level_changes(f.onset_s, f.end_s, changed, a.duration_s))
                            else {}
                        ),
                    },
                    units,
                    successors,
                )
            )
            for f in a.findings
        ],
        "detectors": [
            {
                "name": r.detector,
                "channels": list(r.channels),
                "params": _jsonable(r.params),
                "model": _jsonable(r.model),
                "notes": list(r.notes),
            }
            for r in a.results
        ]
        + _constant_check(a.findings)
        + _silent_check(a.findings),
        "model": a.model_info,
        "saved_model": a.saved_model,
        "screen": a.screen,
        "config": _jsonable(a.config_info),
        "skipped_detectors": a.skipped,
        "notes": a.notes,
        "corrections": _jsonable(a.corrections),
        "corrected_csv": CORRECTED_CSV if a.corrected is not None else None,
        "unexplained_alarms": [
            {
                "channels": list(u.channels),
                "onset_s": json_time(u.onset_s),
                "onset": a.onset_iso(u.onset_s),
                "detectors": list(u.detectors),
                "beside": list(u.beside),
                "seam": getattr(u, "seam", "") or None,
            }
            for u in a.unexplained
        ],
    }


def _with_check(
    fault: dict[str, Any],
    units: Mapping[str, str],
    successors: Mapping[str, tuple[str, ...]] | None = None,
) -> dict[str, Any]:
    """``fault`` with its ``check``: what to look at on the sensor, in plain words
    (:func:`analyzer.what_to_check.what_to_check`, with the channel's unit of ``units``,
    :func:`analyzer.what_to_check.channel_units`), and, where other channels begin in
    the file where its channel ends (``successors``, :func:`analyzer.readers.
    renamed_successors`), that it may be the same sensor renamed: findings.json alone
    said "dead sensor" of a sensor replaced under a new name (the ux62 audit)."""
    channel = str(fault["channel"])
    check = what_to_check(fault, units.get(channel, ""))
    begun = (successors or {}).get(channel, ())
    if begun:
        one = len(begun) == 1
        fix = f"give --rename {begun[0]}={channel}" if one else "give --rename NEW=OLD"
        check += (
            f" (another channel{'' if one else 's'}, {', '.join(begun)}, "
            f"{'begins' if one else 'begin'} where it ends: renamed? {fix})"
        )
    fault["check"] = check
    return fault


NO_READING = "no reading"
"""``why`` of a channel with no reading at all (:attr:`Analysis.no_reading`)."""


def unread_channels(a: Analysis) -> list[dict[str, Any]]:
    """findings.json's ``channels[]`` entries of the channels with no reading at all
    (:attr:`Analysis.no_reading`): no sample, ``why`` "no reading" and ``no_reading``
    what their values were, ``analyzed`` false. A saved model's channel blank in every
    row (``--model``) is listed so too, but ``analyzed`` true, as the model's other
    channels: its detectors take it (a column of gaps), its finding says it is dead
    (``silent_check``), ``corrected.csv`` has its column, and a note says what the model
    could audit without it (:func:`analyzer.pipeline._blank_model_note`). It was left
    out of ``channels[]`` altogether, though the same column without ``--model`` was
    listed (ch57)."""
    listed = {c.name for c in a.channels}
    return [
        {
            "name": name,
            "samples": 0,
            "rate_hz": 0.0,
            "gaps": 0,
            "analyzed": name in a.analyzed,
            "why": NO_READING,
            "no_reading": what,
            **_renamed_from(a, name),
        }
        for name, what in getattr(a, "no_reading", {}).items()
        if name not in listed
    ]


def _renamed_from(a: Analysis, name: str) -> dict[str, Any]:
    """A channel's ``renamed_from`` (:attr:`Analysis.renamed`), where it was joined by
    ``--rename`` or the config's ``[rename]``."""
    renamed = getattr(a, "renamed", {}).get(name)
    return {"renamed_from": renamed_from_json(renamed)} if renamed else {}


def _with_label(fault: dict[str, Any]) -> dict[str, Any]:
    """``fault`` with its ``evidence_label`` (strong, moderate or weak) and
    ``evidence_label_why`` (:func:`analyzer.evidence_label.fault_label`)."""
    label, why = fault_label(fault)
    fault["evidence_label"] = label
    fault["evidence_label_why"] = why
    return fault


def finding_intervals(f: Finding) -> dict[str, Any]:
    """A fault's 95 % intervals (findings.json's ``magnitude_interval``,
    ``onset_interval_s`` and, where either is null or the size's counts only part of its
    error (a gain's: noise only; a model without its sample count), ``interval_notes``
    saying why): those
    of the event whose fit gave the finding's size and onset
    (:func:`analyzer.diagnosis.spread.event_intervals`), never another fit's. A size or
    onset that came from elsewhere (another detector that gives none, a step after the
    fit) has none, and an onset that is a bound (a fault there from the record's start)
    none either."""
    sized = [
        e
        for e in f.events
        if e.intervals is not None
        and e.type is f.type
        and e.intervals["of_magnitude"] == f.magnitude
    ]
    timed = [e for e in sized if e.intervals is not None and e.intervals["of_onset_s"] == f.onset_s]
    notes: dict[str, str] = {}
    lead = (timed or sized)[0] if timed or sized else None
    magnitude: dict[str, Any] | None = None
    if lead is None or lead.intervals is None:
        given = any(e.intervals is not None for e in f.events)
        notes["magnitude"] = (
            "the size came from a step after the fitted shape, which gives no interval"
            if given
            else f"the detector that sized it ({f.detector}) gives no interval"
        )
    elif lead.intervals.get("magnitude") is None:
        notes["magnitude"] = str(lead.intervals.get("magnitude_note"))
    else:
        sizes = lead.intervals["magnitude"]
        magnitude = {"level": lead.intervals["level"], **_jsonable(sizes)}
        if lead.intervals.get("magnitude_partial"):  # (given, but it counts part of the error)
            notes["magnitude"] = str(lead.intervals["magnitude_partial"])
    onset: list[float] | None = None
    bound = (f.evidence or {}).get("onset_at_or_before")
    if bound:
        notes["onset"] = (
            "a bound, not an estimate: the fault was there when the search began "
            "(from the start, not judged before onset_s)"
        )
    elif not timed or timed[0].intervals is None:
        notes["onset"] = (
            "the onset came from a step after the detector's fit (a merge of events, a "
            "search without a sensor), which gives no interval"
        )
    elif timed[0].intervals.get("onset_s") is None:
        notes["onset"] = str(timed[0].intervals.get("onset_note"))
    else:
        lo, hi = timed[0].intervals["onset_s"]
        onset = [json_time(float(lo)), json_time(float(hi))]
    out: dict[str, Any] = {"magnitude_interval": magnitude, "onset_interval_s": onset}
    if notes:
        out["interval_notes"] = notes
    return out


def _constant_check(found: list[Finding]) -> list[dict[str, Any]]:
    """The entry of ``detectors`` for the check that reported channels reading one value
    over the whole record (:func:`analyzer.pipeline.constant_findings`), where it did."""
    stuck = [f.channel for f in found if f.detector == "constant_check"]
    if not stuck:
        return []
    return [
        {
            "name": "constant_check",
            "channels": stuck,
            "params": {"min_samples": STUCK_SAMPLES},
            "model": {},
            "notes": [],
        }
    ]


def _silent_check(found: list[Finding]) -> list[dict[str, Any]]:
    """The entry of ``detectors`` for the check that reported channels whose readings gave
    way to blank cells or NaN for the rest of the record (:mod:`analyzer.silent`), where
    it did."""
    silent = [f.channel for f in found if f.detector == SILENT_CHECK]
    if not silent:
        return []
    return [
        {
            "name": SILENT_CHECK,
            "channels": silent,
            "params": {"min_samples": SILENT_SAMPLES, "min_alarm_windows": SILENT_WINDOWS},
            "model": {},
            "notes": [],
        }
    ]


def size_relative(
    magnitude: Mapping[str, Any],
    healthy: tuple[float, float] | None,
    onset_s: float,
    end_s: float | None,
    duration_s: float,
) -> float | None:
    """A finding's size in units of its sensor's standard deviation ``sd`` over the
    healthy training window (``healthy``: that window's mean and ``sd``), 4 significant
    digits, so that a confidence of 99.9 % can be read against how much the fault moves
    the reading: ``rms / sd`` where the magnitude has an RMS (``other``: the fault
    signal's RMS, its offset included), else ``|offset| / sd`` (additive; a stuck
    sensor's distance from the healthy mean), ``|gain - 1| * sqrt(mean^2 + sd^2) / sd``
    for a gain (the RMS of the change ``(gain - 1) * reading`` over healthy readings),
    ``|rate_per_s| * (end - onset) / sd`` for a drift (the offset it has reached at its
    end, the record's end while it lasts). None where there is no such size (a clipping
    sensor's limits, no magnitude) or no spread to measure it by (a channel constant or
    missing in the window)."""
    if healthy is None:
        return None
    mean, sd = float(healthy[0]), float(healthy[1])
    if not (math.isfinite(sd) and sd > 0.0 and math.isfinite(mean)):
        return None
    size: float | None = None
    if "rms" in magnitude:
        size = abs(float(magnitude["rms"]))
    elif "offset" in magnitude:
        size = abs(float(magnitude["offset"]))
    elif "gain" in magnitude:
        size = abs(float(magnitude["gain"]) - 1.0) * math.hypot(mean, sd)
    elif "rate_per_s" in magnitude:
        end = duration_s if end_s is None else end_s
        size = abs(float(magnitude["rate_per_s"])) * max(0.0, end - onset_s)
    if size is None or not math.isfinite(size):
        return None
    return float(f"{size / sd:.4g}")


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.floating, float)):
        v = float(x)
        return v if np.isfinite(v) else None
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.bool_,)):
        return bool(x)
    if isinstance(x, (str, int, bool)) or x is None:
        return x
    return str(x)


def write_outputs(
    analysis: Analysis,
    out_dir: Path,
    warn: Callable[[str], None] | None = None,
    utc: bool = False,
    also: Sequence[tuple[Path, bytes]] = (),
) -> dict[str, Any]:
    """``out_dir/findings.json``, ``out_dir/report.html`` and, where the analysis has
    corrected signals, ``out_dir/corrected.csv``, with ``also`` (other files of the run,
    each a path and its bytes: ``--save-model``'s). All are written under temporary
    names first and renamed into place only once every one is written
    (:func:`analyzer.outdir.staged`; ``findings.json`` last): an error (a full disk, an
    interrupt) leaves every file as it was, and names the file it met (``out/report.html:
    No space left on device``). Before, a full disk left a new ``findings.json``, valid
    and naming this run's faults, behind exit code 2: beside the earlier run's report, or
    naming a ``corrected.csv`` never written (a QA audit's ux59 item H1). The report's
    figures are drawn by the worker processes of an enclosing
    :func:`analyzer.report.workers.figure_workers` context (``analyzer run`` enters one),
    else in this process; the page is the same either way. A figure that cannot be drawn
    leaves a line in its place, a note in both files and a ``warn`` line. ``utc``
    (``run --corrected --utc``): ``corrected.csv`` gets a last column ``utc``, each row's
    time as ISO-8601 UTC (for a record of absolute times: the run refused it otherwise,
    :func:`analyzer.options.check_utc`)."""
    from analyzer.report import render_view
    from analyzer.report.view import build_view

    doc = findings_document(analysis)
    stale = out_dir / CORRECTED_CSV
    earlier = analysis.corrected is None and stale.exists()
    # (asked before findings.json is replaced: the earlier one names the file)
    remove = earlier and earlier_corrected(out_dir, [i.path for i in analysis.inputs])
    if earlier and not remove:
        # not known as the analyzer's (a file of the user's, an older version's output,
        # a folder that is an input): left as it is, and not read as this run's
        why = (
            "it is an input or lies beside one (inputs are never changed)"
            if touches_inputs(stale, [i.path for i in analysis.inputs])
            else "no findings.json of the analyzer beside it names it as its output"
        )
        kept = (
            f"{stale} is not this run's (it was not asked for corrected signals, "
            f"--corrected) and was left as it was: {why}"
        )
        doc["notes"] = [*doc["notes"], kept]
        if warn is not None:
            warn(kept)
    # the page is rendered before either file is replaced: if rendering fails, the
    # folder keeps the previous run's findings.json and report.html, a matching pair,
    # rather than a new findings.json beside an old report
    view = build_view(analysis, doc)
    html = render_view(view)
    if view.figure_failures:
        doc["notes"] = [*doc["notes"], *view.figure_failures]
        if warn is not None:
            for line in view.figure_failures:
                warn(line)
    text = json.dumps(doc, indent=2, allow_nan=False) + "\n"
    # (and what a run killed while it replaced these files left: ux66 M2)
    with staged([out_dir / CORRECTED_CSV], warn) as files:
        for path, data in also:
            files.write(path, data)
        if analysis.corrected is not None:
            corrected = analysis.corrected
            files.write_with(
                out_dir / CORRECTED_CSV,
                lambda tmp: write_corrected_csv(
                    tmp,
                    analysis.times_between,
                    analysis.analyzed,
                    corrected,
                    (analysis.start_ns, analysis.rate_hz)
                    if utc and analysis.absolute_time
                    else None,
                ),
            )
        files.write(out_dir / "report.html", html)
        files.write(out_dir / "findings.json", text)  # (last: the file a reader looks for)
        if remove:
            files.remove(stale)  # (with the renames: a failed one leaves it too)
        files.commit()
    if remove and warn is not None:
        warn(
            f"removed {stale}, an earlier run's corrected signals: this run was not "
            "asked for them (--corrected)"
        )
    return doc


def earlier_corrected(out_dir: Path, inputs: Sequence[str | Path]) -> bool:
    """Whether ``out_dir/corrected.csv`` is an earlier run's, which a run without
    ``--corrected`` removes (as :func:`analyzer.error_file.remove_stale` does an earlier
    ``error.txt``) so that it is not read as this run's: the ``findings.json`` beside it
    names it (``corrected_csv``), and its header is the columns that run wrote (``time``,
    the channels it analyzed, ``utc`` perhaps). Never a file in or beside an input (the
    inputs and their folders are never changed), a link, nor a file of the user's of
    that name, whose header or folder says otherwise."""
    path = out_dir / CORRECTED_CSV
    try:
        if path.is_symlink() or not path.is_file() or touches_inputs(path, inputs):
            return False
        doc = json.loads((out_dir / "findings.json").read_text(encoding="utf-8"))
        with path.open(encoding="utf-8", newline="") as f:
            header = next(csv.reader([f.readline(1 << 20)]), [])
    except (OSError, UnicodeDecodeError, ValueError):
        return False
    if not isinstance(doc, dict) or doc.get("schema") != SCHEMA:
        return False
    if doc.get("corrected_csv") != CORRECTED_CSV:
        return False
    analyzed = [
        c.get("name") for c in doc.get("channels", []) if isinstance(c, dict) and c.get("analyzed")
    ]
    columns = header[1:-1] if header[-1:] == ["utc"] else header[1:]
    written = (spreadsheet_safe(str(name)) for name in analyzed)  # (as the header has them)
    return header[:1] == ["time"] and sorted(columns) == sorted(written)
