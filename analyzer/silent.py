"""Sensors that go silent: a channel that has readings and then, for the rest of the
record, explicit "no reading" marks while the other analyzed channels go on.

The marks are a CSV's blank (or ``nan``) cells on rows whose other columns have data
(:attr:`~analyzer.readers.base.InputInfo.blank_until`) and a topic that goes on
publishing NaN (its samples run on, read as NaN: the channel's last sample, NaN or not,
:attr:`~analyzer.store.store.ChannelInfo.end_ns`). Such a sensor is dead as surely as
one that reads 0 from then on, which the detectors report as a gain of 0: a note alone
let it pass as "no sensor fault found", exit 0 (the ux53 audit). A topic whose messages
simply stop leaves no mark: a node or a recorder stopped, not necessarily the sensor; its
channels keep the run's note (and a finding under way there ends with the data,
:mod:`analyzer.data_ends`).

The rule: the silence lasts from the channel's last reading to the record's last reading
(of any analyzed channel), the marks reach to within one long alarm window of that end,
and it holds at least :data:`MIN_SAMPLES` rows and :data:`MIN_WINDOWS` long alarm
windows (:func:`~analyzer.diagnosis.readings.shortest`). The finding is ``other`` from
the first missing sample, ``magnitude.no_data_s`` the seconds without a reading, detector
:data:`SILENT_CHECK`, confidence 1 (every row read).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy.typing as npt

from analyzer.diagnosis import Finding
from analyzer.diagnosis.readings import shortest
from analyzer.readers.base import InputInfo
from analyzer.reconfigure import last_rows
from analyzer.store.store import ChannelInfo
from analyzer.timeutil import json_time
from analyzer.types import FaultType

SILENT_CHECK = "silent_check"
"""The name findings.json gives the check (its findings' ``detector``)."""

MIN_SAMPLES = 100
"""Fewest rows of silence for a finding: the evidence the constant check asks of a stuck
sensor (one value on at least 100 samples), so a silent sensor and a frozen one are
judged on as much data."""

MIN_WINDOWS = 3
"""Fewest long alarm windows of silence for a finding: a detector's alarm is judged on
one; three are more than a dropped burst of rows that a logger fills in again."""


def silent_findings(
    values: npt.NDArray[Any],
    chosen: Sequence[str],
    rate_hz: float,
    start_ns: int,
    infos: Sequence[ChannelInfo],
    inputs: Sequence[InputInfo],
    dropped: Mapping[str, int] | None = None,
) -> list[Finding]:
    """A finding for each channel of ``chosen`` (the columns of the aligned matrix
    ``values``, rows at ``rate_hz`` from ``start_ns``) that went silent by the module's
    rule; ``infos``, ``inputs`` and ``dropped`` (each channel's last sample dropped as no
    reading as it was read, ns: :class:`~analyzer.missing_codes.Unread`) give where its
    explicit marks end."""
    if not rate_hz > 0 or values.shape[0] == 0:
        return []
    last = last_rows(values)
    if not bool((last >= 0).any()):
        return []
    record = int(last.max())
    window = shortest(rate_hz)
    least = max(MIN_SAMPLES, MIN_WINDOWS * window)
    marked = _marks_end(infos, inputs, dropped or {})
    out = []
    for j, name in enumerate(chosen):
        row = int(last[j])
        if row < 0 or record - row < least or name not in marked:
            continue
        mark = (marked[name] - start_ns) * rate_hz / 1e9
        if mark < record - window:
            continue  # its samples stop: no mark of silence (a node stopped)
        out.append(silent_finding(name, (row + 1) / rate_hz, (record - row) / rate_hz))
    return out


def silent_finding(name: str, onset_s: float, no_data_s: float) -> Finding:
    """The finding on ``name``, without a reading from ``onset_s`` for ``no_data_s``
    seconds, to the record's end."""
    return Finding(
        name,
        FaultType.OTHER,
        json_time(onset_s),
        None,
        {"no_data_s": json_time(no_data_s)},
        1.0,
        SILENT_CHECK,
        evidence={"detectors": [SILENT_CHECK], "tests": {}},
    )


def blank_findings(names: Sequence[str], duration_s: float) -> list[Finding]:
    """The finding on each channel of ``names``: a saved model's channel (``--model``)
    whose CSV column is there but blank in every row of a record ``duration_s`` long. A
    sensor dead before the record began, as surely as one that goes silent in it: without
    a reading from the record's start (the model's other channels audited as far as the
    model allows without it)."""
    out = [silent_finding(name, 0.0, duration_s) for name in names]
    for f in out:  # (dead when the record began: perhaps before it, as a constant one)
        f.evidence["onset_at_or_before"] = True
    return out


def _marks_end(
    infos: Sequence[ChannelInfo], inputs: Sequence[InputInfo], dropped: Mapping[str, int]
) -> dict[str, int]:
    """Of each channel with explicit "no reading" marks, the latest time they reach (ns):
    a CSV column's blank cells to its file's last row; NaN samples to the last sample;
    the samples dropped as no reading as they were read (NaN, infinite, a code:
    ``dropped``, their last), which are such marks too."""
    marked: dict[str, int] = dict(dropped)
    for info in infos:
        if info.samples > info.finite:  # NaN samples: published as no reading
            marked[info.name] = max(marked.get(info.name, info.end_ns), info.end_ns)
    for i in inputs:
        for name, at in i.blank_until.items():
            marked[name] = max(marked.get(name, at), at)
    return marked


def merged(silent: Sequence[Finding], findings: Sequence[Finding]) -> list[Finding]:
    """``findings`` with the ``silent`` ones, sorted by onset: a detector's finding on a
    silent channel from its silence on is the same fault (CONTRACT.md: one physical fault
    is one entry), its detector named in the silent finding's ``evidence.detectors``."""
    at: Mapping[str, Finding] = {f.channel: f for f in silent}
    out = []
    for f in findings:
        s = at.get(f.channel)
        if s is not None and f.onset_s >= s.onset_s:
            names = f.evidence.get("detectors", [f.detector])
            s.evidence["detectors"] = list(dict.fromkeys([*s.evidence["detectors"], *names]))
            continue
        out.append(f)
    out.extend(silent)
    return sorted(out, key=lambda f: (f.onset_s, f.channel))


__all__ = ["SILENT_CHECK", "blank_findings", "merged", "silent_finding", "silent_findings"]
