"""``analyzer inspect``: what is in an archive (channels, counts, rates, gaps)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from analyzer.errors import capped, terminal_safe
from analyzer.readers import open_archive
from analyzer.readers.base import InputInfo, TimeSource
from analyzer.scratch import scratch
from analyzer.store import ChannelStore
from analyzer.timeutil import iso_utc, plausible_epoch
from analyzer.types import NS_PER_S


def inspect_archive(inputs: Sequence[str | Path], time: TimeSource = "log") -> dict[str, Any]:
    """The contract's ``inspect --json`` object, plus ``start`` (absolute UTC, where known)
    and ``notes``: how the archive was put together (a file not read, one given twice:
    :attr:`~analyzer.readers.Archive.notes`), as ``run`` puts them in findings.json, and,
    for an archive read without an error that holds no numeric channel (a bag of
    strings, an empty bag), :func:`nothing_numeric`'s line: listing it is no error, but
    ``run`` and ``export`` refuse it."""
    archive = open_archive(inputs)
    with (
        scratch("analyzer-inspect-") as tmp,
        ChannelStore.from_chunks(archive.chunks(time), tmp) as store,
    ):
        infos = store.infos()
        t0 = min((i.start_ns for i in infos), default=0)
        absolute = all(i.absolute_time for i in archive.inputs) and plausible_epoch(t0)
        notes = [str(n) for n in archive.notes]
        if not infos:
            notes.append(nothing_numeric(archive.inputs))
        return {
            "inputs": [
                {
                    "path": str(i.path),
                    "format": str(i.format),
                    "errors": list(i.errors),
                    **({"time": i.time} if i.time else {}),
                }
                for i in archive.inputs
            ],
            "notes": notes,
            "start": iso_utc(t0) if absolute and infos else None,
            "channels": [
                {
                    "name": i.name,
                    "samples": i.samples,
                    "start_s": (i.start_ns - t0) / NS_PER_S,
                    "end_s": (i.end_ns - t0) / NS_PER_S,
                    "rate_hz": round(i.rate_hz, 6),
                    "gaps": i.gaps,
                    # (only when so: a regular channel's entry is as it always was)
                    **({"irregular": True} if i.irregular else {}),
                    # its two values, where it holds only two whole numbers over the
                    # record: a flag or label, which run leaves out unless named
                    **({"flag": [int(x) for x in i.levels or ()]} if i.flag else {}),
                }
                for i in infos
            ],
        }


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
        for e in i["errors"]:
            lines.append(f"  ! {safe(e)}")
    for note in doc.get("notes", ()):
        lines.append(f"note: {safe(note)}")
    if doc.get("start"):
        lines.append(f"start {doc['start']}")
    rows = [("channel", "samples", "start_s", "end_s", "rate_hz", "gaps")]
    for c in doc["channels"]:
        flag = c.get("flag")
        rows.append(
            (
                safe(c["name"]) + (f" [flag {flag[0]}/{flag[1]}]" if flag else ""),
                str(c["samples"]),
                f"{c['start_s']:.3f}",
                f"{c['end_s']:.3f}",
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
        lines.append("* sampled at irregular times: the mean rate (intervals vary widely)")
    if any(c.get("flag") for c in doc["channels"]):
        lines.append(
            "[flag a/b]: only the whole numbers a and b over the record (a status flag or a "
            "label, not a measurement): run leaves it out unless --channels names it"
        )
    return "\n".join(lines)
