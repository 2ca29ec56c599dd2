"""Alarms the reported findings do not explain: a second faulty sensor the run missed.

The bank and the detection filter isolate one fault at a time, and the equivalent
model's network names one of several sensors only when the alarms single it out. With
two faulty sensors at once a run may report one and leave the other's alarms
"attributed to no sensor" (``DetectorResult.unattributed``): the run's notes said so,
deep in the report, while the verdict, ``findings.json``'s faults and the run's last
line read "one faulty sensor". This module picks, from the anomalies the run's notes
already report (:func:`missed_clusters`, the equivalent model's second fault beside a
found one), those no finding accounts for, so that the verdict, ``findings.json``
(``unexplained_alarms``) and the run's last line can say so.

An anomaly is left out (not reported as unexplained) when:

* the run found no fault: "no sensor fault found" with an anomaly no sensor explains is
  a change of the structure or its load as often as several sensors at once, and the
  notes say so (healthy records under changing load noted such anomalies in 128 of 220
  runs of ``benchmarks/sweep_eov.py``);
* a finding on one of its sensors is under way when it begins (the equivalent model
  named "one of s4, s5" beside s1's fault where s4's own fault was found too);
* it is an anomaly no detector attributed while a finding lasted (:func:`lasting`),
  which the run's note calls "a second fault, or that one's doing": two faults found
  from one instant on a 6-channel building left such anomalies on a third sensor in 2 of
  9 records of ``sweep_isolation.py --floors 3 --onset 0.6 --second 0.6001``, where no
  third sensor was faulty;
* it begins or ends with a finding (the finding's own transient: the notes' rule);
* it begins in a stretch where the channels' response level left the training
  window's range (:func:`analyzer.diagnosis.levels.excursions`): a change of the load,
  which the level note reports.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from analyzer.detectors import DetectorResult
from analyzer.diagnosis.levels import Excursion
from analyzer.diagnosis.merge import Finding
from analyzer.timeutil import seconds_text

Anomaly = tuple[float, str, tuple[str, ...]]
"""An anomaly no sensor was found for: onset (s), the detector, the channels it named."""


@dataclass(frozen=True, slots=True)
class Unexplained:
    """Alarms no reported finding explains: on ``channels`` (a fault on one of them
    explains them, when several), beginning at ``onset_s``, seen by ``detectors``,
    while the findings on ``beside`` were under way (if any); ``seam``, where they begin
    at a seam between two files that changed what was read (samples dropped, a file
    left out, a gap: :class:`~analyzer.readers.seams.Seam`), its words, else ""."""

    channels: tuple[str, ...]
    onset_s: float
    detectors: tuple[str, ...]
    beside: tuple[str, ...]
    seam: str = ""


def missed_clusters(
    results: Sequence[DetectorResult], findings: Sequence[Finding], slack_s: float
) -> list[list[Anomaly]]:
    """The anomalies no detector attributed and that no other sensor's fault was named
    beside (``unattributed`` with an empty third item), grouped where each follows the
    previous within ``slack_s``, kept when two or more detectors saw the group and it
    neither begins nor ends with a finding (:func:`echoes`): several sensors at once, or
    a change of the structure or excitation. The run's notes name these."""
    plain = sorted(
        (onset, r.detector, channels)
        for r in results
        for onset, channels, beside in r.unattributed
        if not beside
    )
    clusters: list[list[Anomaly]] = []
    for item in plain:
        if clusters and item[0] - clusters[-1][-1][0] <= slack_s:
            clusters[-1].append(item)
        else:
            clusters.append([item])
    return [
        c
        for c in clusters
        if len({d for _, d, _ in c}) >= 2 and not echoes(findings, c[0][0], c[-1][0], slack_s)
    ]


def echoes(findings: Sequence[Finding], t0: float, t1: float, slack_s: float) -> bool:
    """Whether a finding begins or ends within ``slack_s`` of ``t0`` to ``t1``: an
    anomaly there is that finding's doing."""
    return any(
        t0 - slack_s <= f.onset_s <= t1 + slack_s
        or (f.end_s is not None and t0 - slack_s <= f.end_s <= t1 + slack_s)
        for f in findings
    )


def _under_way(findings: Sequence[Finding], t: float, slack_s: float) -> list[Finding]:
    """The findings begun by ``t`` (less ``slack_s`` early) and not ended before it."""
    return [
        f
        for f in findings
        if f.onset_s <= t + slack_s and (f.end_s is None or f.end_s >= t - slack_s)
    ]


def lasting(findings: Sequence[Finding], t0: float, t1: float, slack_s: float) -> list[Finding]:
    """Findings under way since well before an anomaly from ``t0`` to ``t1`` and past
    it: the anomaly may be their doing, or a fault of its own (a stuck s1 from 30 s,
    lasting to the end, kept an offset on s4 from 45 s, which every detector noted, out
    of the run's notes), which the run's note says as such."""
    return [
        f
        for f in findings
        if f.onset_s < t0 - slack_s and (f.end_s is None or f.end_s > t1 + slack_s)
    ]


def unexplained_alarms(
    results: Sequence[DetectorResult],
    findings: Sequence[Finding],
    slack_s: float,
    stretches: Sequence[Excursion] = (),
) -> list[Unexplained]:
    """The anomalies of the run's notes that the ``findings`` do not explain (see the
    module doc), by onset: the equivalent model's second fault beside a found one, and
    the groups of :func:`missed_clusters`. ``stretches``: where the load left the
    training window's range (anomalies beginning there are left out)."""
    if not findings:
        return []

    def load_changed(t: float) -> bool:
        return any(e.start_s - slack_s <= t <= e.end_s + slack_s for e in stretches)

    def explained(channels: Sequence[str], t: float) -> bool:
        return load_changed(t) or any(
            f.channel in channels for f in _under_way(findings, t, slack_s)
        )

    out: list[Unexplained] = []
    seen: set[tuple[tuple[str, ...], tuple[str, ...]]] = set()
    for r in results:
        for onset, channels, beside in r.unattributed:
            if not beside or (beside, channels) in seen:
                continue
            seen.add((beside, channels))
            if not explained(channels, onset):
                out.append(Unexplained(tuple(channels), onset, (r.detector,), tuple(beside)))
    for c in missed_clusters(results, findings, slack_s):
        onset = c[0][0]
        channels = tuple(sorted({ch for _, _, chs in c for ch in chs}))
        if lasting(findings, onset, c[-1][0], slack_s) or explained(channels, onset):
            continue
        out.append(Unexplained(channels, onset, tuple(sorted({d for _, d, _ in c})), ()))
    return sorted(out, key=lambda u: (u.onset_s, u.channels))


def and_joined(channels: Sequence[str]) -> str:
    """The sensors of one unexplained anomaly as a user reads them, joined by commas and
    a last "and": ``s4``, ``s4 and s5``, ``s0, s1 and s2`` (their residuals alarmed;
    with several, no detector could tell which sensor is faulty)."""
    names = list(channels)
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


PLACING_DETECTOR = "detection_filter"
"""The detector whose lone, shapeless findings :func:`unplaced` weighs."""

LEAVE_ONE_OUT = "ar_kalman_bank"
"""The detector whose isolation test weighs them: the bank of estimators that each leave
one sensor out (Chang et al. 2017, Section 2.3)."""


def _lone_shapeless(f: Finding) -> bool:
    return (
        list(f.evidence.get("detectors") or [f.detector]) == [PLACING_DETECTOR]
        and f.type.value == "other"
    )


def _ends(r: DetectorResult) -> list[float]:
    """When each of ``r``'s unattributed anomalies' alarms ended: as the detector gave
    them, or (without them) at their onsets."""
    if len(r.unattributed_end_s) == len(r.unattributed):
        return list(r.unattributed_end_s)
    return [onset for onset, _, _ in r.unattributed]


def unplaced(
    findings: Sequence[Finding], results: Sequence[DetectorResult], slack_s: float
) -> tuple[list[Finding], list[Unexplained], list[str]]:
    """``findings`` less the detection filter's lone ``other`` faults on a sensor whose
    alarms the bank saw and could not place (and on which it placed no fault), those
    alarms as unexplained, and a note for each.

    The detection filter names a sensor by the output direction its residual vector
    lies closest to; the bank by the one estimator, blind to the sensor, that stays
    consistent while those that read it degrade. Where the bank alarmed on the sensor
    during the finding's own span, left that anomaly unattributed (no
    estimator singled the sensor out: the one blind to it degraded as well, or no shape
    and no confirmation) and placed no fault on the sensor, the filter's direction is
    the nearest of the wrong ones, and no fault shape (``other``) backs it.
    A bank alarm counts when it overlaps the finding's own span, each dated to within
    ``slack_s`` at either edge: ``slack_s`` is the change detectors' long window
    (``LONG_FACTOR`` windows, the run's ``slack``), the longest stretch over which a
    detector averages a residual before it alarms, and alarm runs closer than it are one
    alarm (:func:`analyzer.diagnosis.changes.detect`). So the bank's alarm and the
    finding count as one change when they come within two long windows of each other,
    one for each detector's dating. The bank's alarm runs from its onset to its end
    (``DetectorResult.unattributed_end_s``): one begun 5 s before the finding and still
    under way counts, one on the sensor minutes before and ended since does not. Without
    the ends (a result that does not give them) an alarm is taken to end at its onset.
    A gain of 0.7 on the ground floor of a building with one sensor per floor
    (ux54 item 1) leaves the sensor's own residuals unchanged (its estimate from the other
    floors misses a sixth of its variance, which the gain scales down by as much as it
    adds ``0.3`` of the estimate: 0.90, 1.01 and 1.02 times the healthy variance in the
    three detectors), while the residuals of the floors estimated from it grow 2-9 times:
    the filter named the healthy s2 (or s1) in 9 of 10 records, the bank s0 in none. The
    alarm stands, on the sensors whose residuals raised it, as :class:`Unexplained`."""
    bank = [r for r in results if r.detector == LEAVE_ONE_OUT]
    anomalies = sorted(
        (onset, until, channels)
        for r in bank
        for (onset, channels, beside), until in zip(r.unattributed, _ends(r), strict=True)
        if not beside
    )
    kept: list[Finding] = []
    out: list[Unexplained] = []
    notes: list[str] = []
    placed = {e.channel for r in bank for e in r.events}
    refused: list[tuple[Finding, tuple[str, ...]]] = []
    reach = 2.0 * slack_s  # a long window for each detector's dating of the edges
    for f in findings:
        end = float("inf") if f.end_s is None else f.end_s
        # the bank's unplaced alarms that overlap the finding's own span, as dated
        near = [
            (onset, channels)
            for onset, until, channels in anomalies
            if onset <= end + reach and until >= f.onset_s - reach
        ]
        if (
            not _lone_shapeless(f)
            or f.channel in placed
            or not any(f.channel in channels for _, channels in near)
        ):
            kept.append(f)
            continue
        channels = tuple(sorted({f.channel, *(c for _, chs in near for c in chs)}))
        refused.append((f, channels))
    for f, channels in refused:
        # as the run's other anomalies: one while a reported fault lasts may be its doing
        # (a later find of the sensor itself: the filter's lone s2 alarms beside s0's gain
        # found 17.7 s late on a 600-s record), and each set of sensors is said once
        if not lasting(kept, f.onset_s, f.onset_s if f.end_s is None else f.end_s, slack_s) and all(
            u.channels != channels for u in out
        ):
            out.append(Unexplained(channels, f.onset_s, (LEAVE_ONE_OUT, PLACING_DETECTOR), ()))
        notes.append(
            f"{PLACING_DETECTOR}'s other fault on {f.channel} from {seconds_text(f.onset_s)} s not "
            f"reported: the {LEAVE_ONE_OUT}'s residual of {f.channel} alarmed by then and "
            f"none of its estimators (each blind to one sensor) singled {f.channel} out, "
            "and no fault shape backs the filter's choice. Alarms on "
            f"{and_joined(channels)} that no sensor's fault was placed for: a fault on a "
            "sensor whose own residual barely changes (a gain on a sensor the others "
            "estimate poorly, such as the ground floor of a building with one sensor per "
            "floor), or a change of the structure or its load"
        )
    return kept, out, notes
