"""How much evidence stands behind a finding, in a word an engineer can act on
(findings.json's ``evidence_label`` and ``evidence_label_why``, the report's "evidence"
column), and the stretches of a load or structure change each finding overlaps
(``level_change``).

The agreement score (``confidence``) is not calibrated: near the detection limit
findings on the wrong sensor scored up to 1.0 (the structural engineer's audit ux60 item
3). The label is read from what each finding already carries, each a known route to a
wrong finding, not from the score:

* **weak** ("confirm before sending anyone") where any of these holds: only one detector
  saw it (nothing independent confirms it); it is small next to the sensor's usual
  spread (``size_relative`` below :data:`SMALL`: near the limit faults were put on the
  floor partner about as often as found); the lead detector's innovation tests point to
  another type; its onset coincides with a message the recorder logged late
  (``caution``).
* **strong** where none of those holds, the tests agree with the type and the fault
  moves the reading by at least its usual spread (``size_relative`` :data:`LARGE` or
  more).
* **moderate** otherwise.
* One step lower (strong to moderate, moderate to weak) where the finding overlaps a
  stretch in which the whole structure's response left the training window's range (a
  load or structure change the models were never fitted on can look like one sensor's
  fault: ``level_change``). One step, not straight to weak: on the simulated load
  changes every lasting offset of 2 sd that overlapped one (9) was right.
* A finding read from the readings themselves (a channel that reads one value over the
  whole record, ``constant_check``; one whose readings gave way to blanks,
  ``silent_check``) is **strong**: no model stands between the reading and the finding.

The bounds are round numbers with a meaning (a fault as large as the sensor's own
spread; a quarter of it, the smallest fault ``sweep_isolation.py`` sweeps), not fitted.
How often each label was right, measured on the simulated records of
``benchmarks/sweep_evidence_label.py``, is in README (*How sure is a finding*).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from analyzer.diagnosis.levels import Excursion

STRONG, MODERATE, WEAK = "strong", "moderate", "weak"
LABELS = (STRONG, MODERATE, WEAK)
"""The labels, most evidence first."""

LABEL_WORDS = {
    STRONG: "strong",
    MODERATE: "moderate",
    WEAK: "weak: confirm before sending anyone",
}
"""A label as the report's verdict table says it."""

SMALL = 0.25
"""``size_relative`` below this is weak evidence: a quarter of the sensor's healthy
standard deviation, the smallest offset ``sweep_isolation.py`` sweeps; below it faults
were put on another sensor about as often as found (README, *Below the swept sizes*)."""
LARGE = 1.0
"""``size_relative`` of at least this (the fault moves the reading by its healthy spread
or more) is needed for strong evidence."""
MEASURED = (
    "On 189 findings on simulated buildings with known faults "
    "(benchmarks/sweep_evidence_label.py), all 54 strong and 53 moderate ones were right "
    "(sensor and type), 64 of the 82 weak ones: the 18 wrong findings were all weak, two "
    "with agreement scores of 1.00 and 0.9999."
)
"""How often each label was right on the simulated records of
``benchmarks/sweep_evidence_label.py``: the report's sentence under the verdict table."""

FROM_READINGS = frozenset({"constant_check", "silent_check"})
"""Detectors that read a fault from the readings themselves, with no model."""


def level_changes(
    onset_s: float, end_s: float | None, found: Sequence[Excursion], duration_s: float
) -> list[dict[str, float]]:
    """The stretches of ``found`` (where the channels' median response level left the
    training window's range: :func:`analyzer.diagnosis.levels.excursions`) that the
    finding from ``onset_s`` to ``end_s`` (None: the record's end, ``duration_s``)
    overlaps, each ``{start_s, end_s, level}`` (``level``: the median level's extreme
    there, in training RMS; 1 decimal for the seconds, 2 significant digits for the level,
    as the run's note says them)."""
    a1 = duration_s if end_s is None else end_s
    return [
        {
            "start_s": round(e.start_s, 1),
            "end_s": round(e.end_s, 1),
            "level": float(f"{e.extreme:.2g}"),
        }
        for e in found
        if onset_s <= e.end_s and e.start_s <= a1
    ]


def label_of(
    detectors: int,
    size_relative: float | None,
    tests_agree: bool | None,
    caution: bool,
    level_change: Sequence[Any],
) -> tuple[str, list[str]]:
    """The label (see the module doc) and why, from the number of ``detectors`` that saw
    the finding, its ``size_relative`` (None: no size to weigh), whether the lead
    detector's tests agree with its type (None: not tested), whether it carries a
    recorder's ``caution`` and the load or structure changes it overlaps (each lowers
    the label one step)."""
    weak = []
    if detectors <= 1:
        weak.append("seen by one detector only")
    size = _finite(size_relative)
    if size is not None and size < SMALL:
        weak.append(f"small: {size:.2g} of the sensor's usual spread (below {SMALL:g})")
    if tests_agree is False:
        weak.append("the innovation tests point to another type")
    if caution:
        weak.append("its onset coincides with a message the recorder logged late")
    if weak:
        label, why = WEAK, weak
    else:
        short = []
        if size is None:
            short.append("no size against the sensor's usual spread to weigh")
        elif size < LARGE:
            short.append(f"{size:.2g} of the sensor's usual spread (below {LARGE:g})")
        if tests_agree is None:
            short.append("no innovation test of its type")
        label, why = (
            (MODERATE, short)
            if short
            else (
                STRONG,
                [
                    f"{detectors} detectors agree, the tests agree with the type, and it is "
                    f"{size:.2g} times the sensor's usual spread"
                ],
            )
        )
    if level_change:
        label = LABELS[min(LABELS.index(label) + 1, len(LABELS) - 1)]
        why = [*why, "it overlaps a stretch where the load or the structure changed"]
    return label, why


def fault_label(fault: Mapping[str, Any]) -> tuple[str, list[str]]:
    """:func:`label_of` of a findings.json fault (its ``level_change`` already set)."""
    ev = fault.get("evidence") or {}
    detectors = [str(d) for d in ev.get("detectors") or [fault.get("detector")]]
    if FROM_READINGS & set(detectors) or str(fault.get("detector")) in FROM_READINGS:
        return STRONG, ["read from the readings themselves (no model between them)"]
    return label_of(
        len(set(detectors)),
        fault.get("size_relative"),
        ev.get("tests_agree"),
        bool(fault.get("caution")),
        fault.get("level_change") or [],
    )


def _finite(x: Any) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


__all__ = [
    "LABELS",
    "LABEL_WORDS",
    "LARGE",
    "MEASURED",
    "SMALL",
    "fault_label",
    "label_of",
    "level_changes",
]
