"""What an archive of files says at the seams between them: the rules a CSV file's own
times follow, applied where one file ends and the next begins.

Inside one CSV file, date-times without a zone (read as UTC) that step back by about an
hour are refused as local times set back at the change from summer to winter time, and
a jump forward over a whole hour of the clock is said as the change to summer time
(:mod:`analyzer.readers.csv_reader`). An archive of hourly files meets the same changes
between two files, where neither rule ran (the ux62 audit): the repeated hour's file was
dropped as "samples overlap the previous input in time", one line per channel (16 lines,
12 of them hidden behind "11 more input errors"), the jump forward read as every sensor
stopping, and the jump in the signal where the files were joined reported as "alarms not
explained", blamed on "a change of the structure or excitation".

:class:`~analyzer.readers.Archive` asks this module, file by file, what to say; the
seams where samples were dropped or left out, or where a gap begins, are kept
(:class:`Seam`) so that an alarm no finding explains beside one is tied to it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from analyzer.errors import capped
from analyzer.readers._common import DST_STEP_NS, HOUR_NS, hour_skipped
from analyzer.readers.base import Reader
from analyzer.timeutil import iso_utc, plausible_epoch, spoken_duration

SEAM_SLACK_S = 2.0
"""An alarm no finding explains that begins within this many seconds of a seam where
samples were dropped or a gap begins is tied to that seam (the jump in the signal where
two files were joined, not a change of the structure)."""

GAP_SPACINGS = 5
"""A step between two files longer than this many times the earlier file's mean sample
spacing (and than :data:`~analyzer.readers._common.REORDER_WINDOW_NS`) is a gap."""

NAMES_SHOWN = 3
"""Channel or topic names a line on dropped samples shows; more are counted."""


@dataclass(frozen=True, slots=True)
class Seam:
    """A seam between two files of an archive that changed what was read there:
    ``at_ns``, the last time read before it (where the later file's data, or a gap,
    begins); ``words``, how a note says it (``the seam of h11.csv and h12.csv, where
    6000 overlapping messages were dropped``)."""

    at_ns: int
    words: str
    gap_to_ns: int | None = None
    """Where a gap begins at the seam: the later file's first time (else None)."""
    files: tuple[str, str] = ("", "")
    """The two files' names, the earlier first."""


def zoneless(reader: Reader) -> bool:
    """Whether ``reader`` is a CSV file whose date-times give no zone (read as UTC)."""
    return reader.info.time_zone == ""


def _local(ns: int) -> str:
    """A zone-less file's time as its cells wrote it (no ``Z``: it is no UTC time)."""
    return (iso_utc(ns) or "").removesuffix("Z")


def set_back_line(reader: Reader, before: Reader, end_ns: int, start_ns: int) -> str | None:
    """The line refusing ``reader`` (its first time ``start_ns``) where it and the file
    read before it (``before``, whose last time is ``end_ns``) give date-times without
    a zone and it begins more than half an hour and at most an hour and 2 s before that
    file ends (:data:`~analyzer.readers._common.DST_STEP_NS`): the hour after a change
    to winter time, repeating the clock times of the hour before, as the CSV reader
    says of such a step inside one file; else None."""
    if not (zoneless(reader) and zoneless(before)):
        return None
    back = end_ns - start_ns
    if not DST_STEP_NS[0] < back <= DST_STEP_NS[1]:
        return None
    return (
        f"{reader.info.path}: its times begin {spoken_duration(back / 1e9)} before the last time "
        f"of {before.info.path} (from {_local(end_ns)} to {_local(start_ns)}), in times without a "
        "zone: local times set back an hour, as at the change from summer to winter time? The "
        "hour after the step repeats the times of the hour before, which cannot be told apart; "
        "write the times in UTC, or as date-times with their offset from UTC (such as +02:00 "
        "before the change and +01:00 after it)"
    )


def forward_line(
    reader: Reader, before: Reader, end_ns: int, start_ns: int, spacing_ns: float | None
) -> str | None:
    """The line on ``reader`` where it and the file before it give date-times without a
    zone and its first time (``start_ns``) follows that file's last (``end_ns``) by more
    than half an hour and at most an hour and 2 s beyond the earlier file's sample
    spacing (``spacing_ns``: a file of a row every 10 s ends at 01:59:50), over a whole
    hour of the clock (:func:`~analyzer.readers._common.hour_skipped`): local times set
    forward at the change to summer time (or that hour's file missing), as the CSV
    reader says of such a jump inside one file; else None. The reading is unchanged."""
    if not (zoneless(reader) and zoneless(before)):
        return None
    step = start_ns - end_ns - int(spacing_ns or 0)
    over = hour_skipped(np.array([start_ns], dtype=np.int64), end_ns) is not None
    if not (over or (DST_STEP_NS[0] < step <= DST_STEP_NS[1] and start_ns >= _hour_on(end_ns))):
        return None
    return (
        f"its times begin {spoken_duration((start_ns - end_ns) / 1e9)} after the "
        f"last time of {before.info.path} (from {_local(end_ns)} to {_local(start_ns)}), "
        "over a whole hour of the clock, in times without a zone: local times set forward, "
        "as at the change from winter to summer time (or that hour's file missing)? Read "
        "as UTC, that hour is a gap and every time said in UTC is the file's local time; "
        "write the times in UTC, or as date-times with their offset from UTC, for true "
        "UTC times"
    )


def _hour_on(ns: int) -> int:
    """The start of the clock hour after the one after ``ns``'s (a whole hour skipped)."""
    return (ns // HOUR_NS + 2) * HOUR_NS


def dropped_line(
    before: Reader | None,
    counts: Mapping[str, int],
    spans: Mapping[str, tuple[int, int]],
    topics: Mapping[str, str],
) -> str:
    """One line for every sample a file lost where its times overlap those already read
    from the files before it (``counts`` and ``spans``, the first and last time dropped,
    by channel; ``topics``, a channel's topic where it has one): what (the channels, or
    the topics and their messages), how much (the count, and the stretch of time), why
    (the times of ``before``, the file read before it, were read already; the earlier
    file's samples are kept). One line per file, where there was one per channel."""
    by: dict[str, int] = {}
    for name, count in counts.items():
        topic = topics.get(name, name)
        by[topic] = max(by.get(topic, 0), count)  # (a message holds one sample of each)
    unit = "samples" if all(topics.get(n, n) == n for n in counts) else "messages"
    names = sorted(by)
    first = min(spans[n][0] for n in counts)
    last = max(spans[n][1] for n in counts)
    if len(names) == 1:
        what = f"{names[0]}: {by[names[0]]} {unit}"
    else:
        kind = "topics" if unit == "messages" else "channels"
        each = len(set(by.values())) == 1
        amount = f"{max(by.values())} {unit} each" if each else f"{sum(by.values())} {unit} in all"
        what = f"{capped(names, NAMES_SHOWN, what=kind)} ({len(names)} {kind}): {amount}"
    span = spoken_duration((last - first) / 1e9) if last > first else "a time"
    source = (
        f"{span} that {Path(before.info.path).name} covers already; its samples are kept"
        if before is not None
        else f"{span} read already"
    )
    return f"{what} overlap the previous input in time ({source}); dropped"


def is_gap(step_ns: int, spacing_ns: float | None, floor_ns: int) -> bool:
    """Whether a step of ``step_ns`` from one file's last time to the next file's first
    is a gap: longer than ``floor_ns`` and than :data:`GAP_SPACINGS` times the earlier
    file's mean sample spacing (``spacing_ns``, None where unknown)."""
    return step_ns > floor_ns and (spacing_ns is None or step_ns > GAP_SPACINGS * spacing_ns)


def near_seam(seams: list[Seam], start_ns: int, onset_s: float) -> Seam | None:
    """The seam of ``seams`` within :data:`SEAM_SLACK_S` of ``onset_s`` (seconds from
    ``start_ns``, the record's start), the nearest; None where there is none."""
    best: Seam | None = None
    for seam in seams:
        at = (seam.at_ns - start_ns) / 1e9
        if abs(at - onset_s) <= SEAM_SLACK_S and (
            best is None or abs(at - onset_s) < abs((best.at_ns - start_ns) / 1e9 - onset_s)
        ):
            best = seam
    return best


def gap_between_files(seams: list[Seam], a_ns: int, b_ns: int) -> str:
    """Where a channel's silence from ``a_ns`` to ``b_ns`` is a gap between two files of
    the archive (its ends within :data:`SEAM_SLACK_S` of a seam's), the words that say
    so, with the gap's times in UTC where they are plausible dates: ``no file covers
    00:50:00-00:55:00 UTC (between h09.mcap and h11.mcap)``; else "". A missing hour's
    file was said as a sensor that stopped, in seconds from the record's start (ux62
    LOW 10)."""
    slack = SEAM_SLACK_S * 1e9
    for seam in seams:
        if seam.gap_to_ns is None:
            continue
        if abs(seam.at_ns - a_ns) <= slack and abs(seam.gap_to_ns - b_ns) <= slack:
            first, then = iso_utc(a_ns), iso_utc(b_ns)
            when = f" from {first} to {then}" if first and then and plausible_epoch(a_ns) else ""
            return f"no file covers it{when} (between {seam.files[0]} and {seam.files[1]})"
    return ""
