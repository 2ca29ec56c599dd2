"""``analyzer inspect``: what is in an archive (channels, counts, rates, gaps)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from analyzer.coverage import SAID_SHARE, SpanGaps, gaps_line, span_gaps
from analyzer.errors import (
    ReaderError,
    StoreError,
    UsageError,
    capped,
    counted,
    one_line,
    terminal_safe,
)
from analyzer.missing_codes import Unread, as_gaps, no_reading_line, read_notes
from analyzer.readers import (
    Archive,
    applied_renames,
    check_renames,
    open_archive,
    renamed_from_json,
    renamed_words,
)
from analyzer.readers.base import (
    InputInfo,
    TimeSource,
    absolute_times,
    channel_labels,
    known_topics,
    topic_of,
    without_channels,
)
from analyzer.scratch import scratch
from analyzer.selection import (
    DURATION_FIELD,
    LOG_FIELD,
    LONG_ARRAY_WHY,
    NO_TRAINING_SAMPLES,
    TIME_FIELD,
    default_train,
    left_out,
    lone_channel,
    no_numeric_channel,
    select_channels,
    typed_fields,
    without_samples,
)
from analyzer.store import LONG_ARRAY, ChannelInfo, ChannelStore
from analyzer.timeutil import iso_utc, plain_number, seconds_text, short_seconds
from analyzer.types import NS_PER_S


def inspect_archive(
    inputs: Sequence[str | Path],
    time: TimeSource = "log",
    missing_values: Sequence[float] = (),
    rename: Sequence[tuple[str, str]] = (),
) -> dict[str, Any]:
    """The contract's ``inspect --json`` object, plus ``start`` (absolute UTC, where known)
    and ``notes``: how the archive was put together (a file not read, one given twice:
    :attr:`~analyzer.readers.Archive.notes`), as ``run`` puts them in findings.json, and,
    for an archive read without an error that holds no numeric channel (a bag of
    strings, an empty bag), :func:`nothing_numeric`'s line: listing it is no error, but
    ``run`` and ``export`` refuse it.

    The samples that are no reading (NaN, infinite, beyond 1e30, one of
    ``missing_values``: ``--missing-values``) are dropped as they are read, as ``run``
    drops them (:func:`~analyzer.missing_codes.as_gaps`): a channel's ``samples``, rate
    and gaps are its readings', and the notes count what was dropped by channel in
    ``run``'s words (before, an infinity or a -9999 was listed as a sample).

    ``rename``: ``--rename``'s ``(NEW, OLD)`` pairs (:func:`~analyzer.readers.
    parse_renames`), each NEW channel read as OLD as ``run`` reads it; a channel so
    joined has ``renamed_from`` (NEW and the inputs that held it) and a note says it. A
    NEW name no input holds, or an input holding both names, is ``run``'s error."""
    archive = open_archive(inputs)
    archive.renames = dict(rename)
    unread = Unread()
    chunks = as_gaps(archive.chunks(time), missing_values, unread)
    with (
        scratch("analyzer-inspect-") as tmp,
        ChannelStore.from_chunks(chunks, tmp) as store,
    ):
        check_renames(archive)  # (a NEW name no input holds: the option's error)
        infos = store.infos()
        renamed = applied_renames(archive)
        t0 = min((i.start_ns for i in infos), default=0)
        absolute = absolute_times(archive.inputs)
        notes = [str(n) for n in archive.notes]
        notes += [str(n) for n in read_notes(unread, missing_values)]
        notes += [rename_note(old, new) for old, new in renamed.items()]
        unread_all = no_reading_line(unread)
        if not infos and unread_all is None:
            notes.append(nothing_numeric(archive.inputs))
        textual = without_channels(archive.inputs, [i.name for i in infos]) if infos else []
        if textual:
            notes.append(textual_note(textual))
        why, defaults = (
            run_choice(store, archive, t0)
            if infos
            # (run refuses it: said as for any archive run refuses, with run's line)
            else (
                {},
                {
                    "channels": 0,
                    "refused": no_numeric_channel(
                        archive.inputs, unread_all or "no numeric channel found"
                    ),
                },
            )
        )
        holes = span_gaps(store, [i.name for i in infos])
        labels = channel_labels(archive.inputs, (i.name for i in infos))
        topics = known_topics(archive.inputs)
        return {
            "inputs": [
                {
                    "path": str(i.path),
                    "format": str(i.format),
                    "errors": list(i.errors),
                    **({"time": i.time} if i.time else {}),
                    **({"skipped": i.skipped} if i.skipped else {}),
                }
                for i in archive.inputs
            ],
            "notes": notes,
            "start": iso_utc(t0) if absolute and infos else None,
            # relative times: the input's own time that start_s 0 is (run's time_origin_s)
            "time_origin_s": round(t0 / NS_PER_S, 9) if infos and not absolute else None,
            "channels": [
                {
                    "name": i.name,
                    "samples": i.samples,
                    "start_s": (i.start_ns - t0) / NS_PER_S,
                    "end_s": (i.end_ns - t0) / NS_PER_S,
                    "rate_hz": round(i.rate_hz, 6),
                    "gaps": i.gaps,
                    # (only when so: a regular channel's entry is as it always was)
                    # (its rate_hz is the mean rate between its gaps, the rate it is
                    # aligned at; mean_rate_hz its samples over its whole span)
                    # (and its topic, which the table's legend gives the mean rate of)
                    **(
                        {
                            "irregular": True,
                            "mean_rate_hz": _mean_rate(i),
                            "topic": topic_of(i.name, topics),
                        }
                        if i.irregular
                        else {}
                    ),
                    # its two values, where it holds only two whole numbers over the
                    # record: a flag or label, which run leaves out unless named
                    **({"flag": [int(x) for x in i.levels or ()]} if i.flag else {}),
                    # whether run analyzes it by default, and if not why (run's own rule)
                    "analyzed": i.name not in why,
                    **why.get(i.name, {}),
                    # the name its message gives it (a JointState's joint), where it has one
                    **({"label": labels[i.name]} if i.name in labels else {}),
                    # (--rename: the names read as it, and the inputs that held them)
                    **(
                        {"renamed_from": renamed_from_json(renamed[i.name])}
                        if i.name in renamed
                        else {}
                    ),
                }
                for i in infos
            ],
            "run_defaults": defaults,
            # (topics decoded that gave no channel: a String, a text; only where some are)
            **(
                {
                    "topics_without_numbers": [
                        {"topic": t, "type": k, "messages": n} for t, k, n in textual
                    ]
                }
                if textual
                else {}
            ),
            # (where at least 1 % of the span has no sample of any channel)
            **({"span": holes.as_json()} if holes and holes.share >= SAID_SHARE else {}),
        }


def rename_note(old: str, new: Mapping[str, tuple[str, ...]]) -> str:
    """The note on channel ``old`` joined by ``--rename`` (:func:`~analyzer.readers.
    applied_renames`' ``new``): ``s3: read from s3b in log_02.csv (--rename s3b=s3)``."""
    given = ", ".join(f"--rename {n}={old}" for n in new)
    return f"{old}: {renamed_words(new)} ({given})"


def _mean_rate(info: ChannelInfo) -> float:
    """An irregular channel's samples over its whole span, gaps included (``inspect
    --json``'s ``mean_rate_hz``): what a user who counts the messages gets. Its
    ``rate_hz`` is the mean rate between its gaps (:func:`analyzer.store.store._irregular`:
    the steps longer than its bridge left out), the period the alignment uses: a topic
    of bursts with two pauses of 0.6 s (``tilt_laser.bag``'s ``/imu_data``: 356
    messages over 17.694 s) is 21.52 Hz between its gaps and 20.06 Hz over its span."""
    span = (info.end_ns - info.start_ns) / NS_PER_S
    return round((info.samples - 1) / span, 6) if span > 0 and info.samples > 1 else 0.0


def run_choice(
    store: ChannelStore, archive: Archive, t0: int
) -> tuple[dict[str, dict[str, str]], dict[str, Any]]:
    """What ``run`` does with this archive by default (no ``--channels``, ``--rate``,
    ``--train`` or config), from its own code: the channels it leaves out, each with
    ``{"why": ...}`` (and ``"copy_of"`` for a copy), from the notes of
    :func:`~analyzer.selection.select_channels`; and ``run_defaults``: how many it
    analyzes, the common clock's rate and start (on this listing's time axis: ``t0``)
    and the default training window, in ``--train``'s seconds from the clock's start
    (:func:`~analyzer.selection.default_train` of the clock's span, as ``run`` aligns
    it: nothing is aligned here). Where ``run`` refuses the archive, ``"refused"``: its
    error line. Two choices wait for the aligned data, and are made at run time (the
    summary line says so): a channel that does not vary in the training window, or counts
    through it (a clock: the cart-pole MCAP's ``stamp``), is left out, and a default
    window that a sensor's change crosses is cut before it. Aligning the window here
    would cost a long or fast archive's inspect seconds and memory."""
    notes: list[str] = []
    relabelled = [p for i in archive.inputs for p in i.relabelled]
    refused = None
    try:
        logs = [t for i in archive.inputs for t in i.log_topics]
        chosen = select_channels(
            store,
            None,
            notes,
            relabelled,
            log_topics=logs,
            typed=typed_fields(archive.inputs),
            sources={c: str(p) for c, p in archive.sources.items()},
        )
        lone_channel(chosen, notes)  # (run refuses one: every detector needs two)
    except (UsageError, ReaderError) as err:
        chosen, refused = [], one_line(err)
    infos = {i.name: i for i in store.infos()}
    why = left_out(notes, infos)
    if refused is not None:
        # (what run would have kept, it does not analyze either: it stops)
        why.update({c: {"why": "refused"} for c in infos if c not in why})
        return why, {"channels": 0, "refused": refused}
    try:
        clock = store.align(chosen)
    except StoreError as err:  # (a timestamp far from the others: run stops there too)
        why.update({c: {"why": "refused"} for c in chosen})
        return why, {"channels": 0, "refused": one_line(err)}
    start, end = default_train(clock.duration_s)
    # (run finds these in the aligned window, and says "no samples in the training window")
    missing = without_samples(
        store,
        chosen,
        clock.start_ns + round(start * NS_PER_S),
        clock.start_ns + round(end * NS_PER_S),
    )
    why.update({c: {"why": NO_TRAINING_SAMPLES} for c in missing})
    return why, {
        "channels": len(chosen) - len(missing),
        "rate_hz": round(clock.rate_hz, 6),
        "clock_start_s": (clock.start_ns - t0) / NS_PER_S,
        "train": {"start_s": start, "end_s": round(end, 6)},
    }


TOPICS_LISTED = 10
"""Topics without a numeric field :func:`textual_note` names one by one."""


def textual_note(topics: Sequence[tuple[str, str, int]]) -> str:
    """The note naming the topics that were read but gave no channel (topic, type,
    messages): no number in their messages (a ``std_msgs/String``, a status text), so
    nothing to analyze; they vanished from the listing without a word (ux58 #9)."""
    each = capped(
        [f"{t} ({k}, {counted(n, 'message')})" for t, k, n in topics],
        TOPICS_LISTED,
        what="topics",
    )
    return f"no numeric field in their messages, not analyzed: {each}"


def nothing_numeric(inputs: Sequence[InputInfo]) -> str:
    """The note on an archive read without an error that holds no numeric channel: why,
    where a reader could tell (:attr:`~analyzer.readers.InputInfo.no_numeric`)."""
    why = [
        f"{i.path}: {i.no_numeric}" if len(inputs) > 1 else i.no_numeric
        for i in inputs
        if i.no_numeric
    ]
    return (
        f"nothing to analyze: {capped([str(i.path) for i in inputs], 3, what='inputs')} "
        "holds no numeric channel ("
        + (
            capped(why, 3, "; ")
            if why
            else "no message has a number the readers decode: only text, images or other "
            "non-numeric fields, or no messages at all"
        )
        + "); run and export refuse it"
    )


def render_table(doc: dict[str, Any]) -> str:
    """A table for people: file and channel names with their control and format
    characters escaped (:func:`~analyzer.errors.terminal_safe`; ``--json`` has them as
    JSON escapes)."""
    safe = terminal_safe
    lines = []
    for i in doc["inputs"]:
        lines.append(f"{safe(i['path'])}  [{i['format']}]")
        if i.get("time"):
            lines.append(f"  time: {safe(i['time'])}")
        if i.get("skipped"):
            lines.append(f"  skipped: {safe(i['skipped'])}")
        for e in i["errors"]:
            lines.append(f"  ! {safe(e)}")
    for note in doc.get("notes", ()):
        lines.append(f"note: {safe(note)}")
    if doc.get("start"):
        lines.append(f"start {doc['start']}")
    elif doc.get("time_origin_s"):  # (not 0: times that start at 0 need no line)
        lines.append(origin_line(doc["time_origin_s"]))
    rows = [("channel", "samples", "start_s", "end_s", "rate_hz", "gaps")]
    for c in doc["channels"]:
        rows.append(
            (
                safe(c["name"]) + (f" ({safe(c['label'])})" if c.get("label") else "") + _mark(c),
                str(c["samples"]),
                f"{seconds_text(c['start_s'])}",
                f"{seconds_text(c['end_s'])}",
                f"{c['rate_hz']:.3f}" + ("*" if c.get("irregular") else ""),
                str(c["gaps"]),
            )
        )
    widths = [max(len(r[k]) for r in rows) for k in range(len(rows[0]))]
    for n, r in enumerate(rows):
        cells = [r[0].ljust(widths[0])] + [r[k].rjust(widths[k]) for k in range(1, len(r))]
        lines.append("  ".join(cells))
        if n == 0:
            lines.append("  ".join("-" * w for w in widths))
    lines.append(f"{len(doc['channels'])} channel(s)")
    if any(c.get("irregular") for c in doc["channels"]):
        lines.append(_irregular_legend(doc["channels"]))
    if any(c.get("flag") for c in doc["channels"]):
        lines.append(
            "[flag a/b]: only the whole numbers a and b over the record (a status flag or a "
            "label, not a measurement): run leaves it out unless --channels names it"
        )
    lines.extend(_legend(doc["channels"]))
    if doc.get("span"):
        span = doc["span"]
        lines.append(gaps_line(SpanGaps(span["span_s"], span["gaps"], span["without_data_s"])))
    if doc.get("run_defaults"):
        lines.append(defaults_line(doc["run_defaults"], len(doc["channels"])))
    return "\n".join(lines)


def _irregular_legend(channels: Sequence[dict[str, Any]]) -> str:
    """What the ``*`` after an irregular channel's rate means, and the other mean rate
    (``mean_rate_hz``) of up to three of their topics (a topic's fields share it; a CSV
    column is its own: ``topic``, :func:`~analyzer.readers.base.topic_of`)."""
    rates: dict[str, float] = {}
    for c in channels:
        if c.get("irregular"):
            rates.setdefault(str(c.get("topic", c["name"])), float(c["mean_rate_hz"]))
    shown = ", ".join(f"{terminal_safe(t)} {r:.3f} Hz" for t, r in list(rates.items())[:3])
    more = f" and {len(rates) - 3} more" if len(rates) > 3 else ""
    return (
        "* sampled at irregular times (intervals vary widely): rate_hz is the mean rate "
        "between its gaps (steps counted as gaps left out: the rate it is aligned at); "
        f"over its whole span, gaps included (--json: mean_rate_hz): {shown}{more}"
    )


def origin_line(origin_s: float) -> str:
    """What relative times count from: the first sample's own time in the input."""
    return (
        f"times in seconds from the first sample, which is at {seconds_text(origin_s)} s in the "
        f"input (its own time = start_s + {seconds_text(origin_s)})"
    )


LEGEND = {
    "constant": "[constant] one value over the whole record",
    "empty": "[empty] no value (only gaps)",
    "one sample": "[one sample] a single value",
    "copy": "[copy of X] equal to X on every sample, or an exact linear function of it "
    "(--channels naming it keeps it)",
    "meaning changes": "[meaning changes] what it measures changes between messages (see "
    "the input's errors; --channels naming it keeps it)",
    "refused": "[refused] run refuses the archive (below)",
    LOG_FIELD: "[log message field] a field of a log message (/rosout), not a measurement "
    "(--channels naming it keeps it)",
    TIME_FIELD: "[timestamp field] a time written in the message (a field of type time, "
    "or, where the message's types are unknown, seconds and nanoseconds or a stamp that "
    "never goes back), not a measurement (--channels naming it keeps it)",
    DURATION_FIELD: "[duration field] a span of time written in the message (a field of "
    "type duration, such as a trajectory point's time_from_start): a plan or a setting, "
    "not a reading (--channels naming it keeps it)",
    LONG_ARRAY_WHY: f"[long array] an element of an array field of more than {LONG_ARRAY} "
    "numbers (a laser scan's beams): one sensor's many readings, not that many sensors "
    "(--channels naming it keeps it)",
    NO_TRAINING_SAMPLES: "[no training samples] no samples in the default training window "
    "(its data lie outside it: see the notes; --train choosing a window where it has data "
    "keeps it)",
}
"""The marks of the channels ``run`` leaves out by default (:func:`_mark`), explained."""


def _mark(channel: dict[str, Any]) -> str:
    """After a channel's name: ``[flag a/b]``, or why ``run`` leaves it out by default
    (``[constant]``, ``[copy of X]``...); nothing for a channel it analyzes."""
    flag = channel.get("flag")
    if flag:
        return f" [flag {flag[0]}/{flag[1]}]"
    why = channel.get("why")
    if why is None or why == "flag":
        return ""
    if why == "copy":
        return f" [copy of {terminal_safe(channel['copy_of'])}]"
    return f" [{why}]"


def _legend(channels: Sequence[dict[str, Any]]) -> list[str]:
    """The marks shown explained (:data:`LEGEND`), in one line."""
    shown = {c["why"] for c in channels if c.get("why")}
    kinds = [text for why, text in LEGEND.items() if why in shown]
    return ["left out by run by default: " + "; ".join(kinds)] if kinds else []


def defaults_line(defaults: dict[str, Any], listed: int) -> str:
    """What ``run`` analyzes by default (:func:`run_choice`): how many channels, the
    common clock's rate and the training window, or why it refuses the archive."""
    if "refused" in defaults:
        return f"run refuses this archive by default: {terminal_safe(defaults['refused'])}"
    train = defaults["train"]
    start = defaults["clock_start_s"]
    since = f" from {seconds_text(start)} s" if start else ""
    return (
        f"run by default: {defaults['channels']} of {listed} channel(s) on a common clock of "
        f"{plain_number(defaults['rate_hz'], 4)} Hz{since} (--rate), trained on "
        f"{short_seconds(train['start_s'])}-{short_seconds(train['end_s'])} s of it (the first "
        "20 %, at most 10 "
        "minutes: --train); at run time it also leaves out any channel that does not vary "
        "in that window or counts through it (a clock), and cuts the window short before a "
        "sensor's change inside it"
    )
