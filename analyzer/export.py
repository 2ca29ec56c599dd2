"""``analyzer export``: the time-aligned channels as .csv or .parquet, block by block
(memory does not grow with the archive's length).

The contract fixes the columns: ``time`` (seconds from the first sample), then one per
channel. What that leaves out is said elsewhere: a parquet file carries the record's
absolute start, the clock's rate and each channel's own rate and sample count as
key-value metadata (:func:`parquet_metadata`); ``--utc`` adds a last column ``utc`` of
UTC times; and a successful export ends with one line on stderr (:func:`summary_line`)
after a warning naming the channels whose values are mostly interpolated
(:func:`interpolation_warnings`). An export said nothing, and its file held no trace of
when the record was made (a nav2 bag of 2026-05-08 exported as seconds from 0)."""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from analyzer.errors import WARNED_LINES, ReaderError, UsageError, capped
from analyzer.missing_codes import Unread, as_gaps, no_reading_line, read_notes
from analyzer.outdir import (
    named_error,
    not_into_inputs,
    prepare_dir,
    remove_if_empty,
    spreadsheet_safe,
)
from analyzer.readers import check_renames, open_archive
from analyzer.readers.base import (
    InputInfo,
    TimeSource,
    about_selection,
    absolute_times,
    one_clock,
)
from analyzer.scratch import scratch
from analyzer.selection import no_numeric_channel, select_channels, typed_fields
from analyzer.store import AlignedSeries, ChannelInfo, ChannelStore, clock_rate
from analyzer.timeutil import (
    exact_unit,
    iso_times,
    iso_utc,
    plain_number,
    spoken_duration,
)

BLOCK = 1 << 16

INTERPOLATED = 2.0
"""A varying channel exported on a clock more than this many times its own rate is
named in a warning: at least half of its values are interpolated between its samples
(/amcl_pose at 1.4 Hz on a nav2 bag's 27.6 Hz clock: 2 625 values from 135 samples)."""

RATE_SLACK = 0.01
"""``--rate`` is "above every channel's own rate" when above the fastest by more than
this share: a measured rate of 199.98 Hz is a 200 Hz channel."""

UTC_COLUMN = "utc"


@dataclass(frozen=True, slots=True)
class Exported:
    """What an export wrote: its last line on stderr, its warnings and a parquet file's
    metadata are views of it."""

    path: Path
    rows: int
    rate_hz: float
    start_ns: int
    """The first row's time: epoch nanoseconds (UTC) when :attr:`absolute`, else the
    record's own clock."""
    absolute: bool
    channels: tuple[ChannelInfo, ...]
    """Each exported channel's raw samples (its own rate and count), in column order."""
    asked_rate: float | None = None
    """``--rate``, when given."""


def export_archive(
    inputs: Sequence[str | Path],
    out: Path,
    channels: list[str] | None = None,
    rate: float | None = None,
    time: TimeSource = "log",
    warn: Callable[[str], None] | None = None,
    utc: bool = False,
    say: Callable[[str], None] | None = None,
    missing_values: Sequence[float] = (),
    rename: Sequence[tuple[str, str]] = (),
) -> Path:
    """Write the aligned channels of ``inputs`` to ``out``; what went wrong with the
    inputs while they were read (a truncated file, samples dropped: ``inputs[].errors``
    of ``inspect``) and the channels whose values are mostly interpolated are told to
    ``warn``, a line each, once the file is written, then :func:`summary_line` to
    ``say``. ``utc``: a last column ``utc`` of ISO-8601 UTC times (``--utc``), refused
    for a record of relative times before anything is written.

    The samples that are no reading (NaN, infinite, beyond 1e30, one of
    ``missing_values``: ``--missing-values``) are dropped as they are read, as ``run``
    drops them (:func:`~analyzer.missing_codes.as_gaps`): the file holds an empty cell
    (a null) where the aligned clock has no reading there, never an infinity or a code as
    a value, and ``warn`` is told how many were dropped by channel, in ``run``'s words.

    ``rename``: ``--rename``'s ``(NEW, OLD)`` pairs (:func:`~analyzer.readers.
    parse_renames`), each NEW channel read as OLD as ``run`` reads it (one column OLD
    across the seam); a NEW name no input holds, or an input holding both names, is
    ``run``'s error, before anything is written."""
    suffix = "".join(out.suffixes[-1:]).lower()
    if suffix not in (".csv", ".parquet"):
        raise UsageError(f"--out: {out} must end in .csv or .parquet")
    if out.is_dir():
        raise UsageError(f"--out: {out} is a directory")
    # (the input was read, then replaced by its export, its absolute times lost)
    not_into_inputs(out, inputs, "--out", "export elsewhere")
    created = prepare_dir(out.parent, "--out")  # before reading: not at the end
    try:
        done = _export(inputs, out, suffix, channels, rate, time, warn, utc, missing_values, rename)
    except BaseException:
        if created:
            remove_if_empty(out.parent)
        raise
    if warn is not None:
        for line in interpolation_warnings(done):
            warn(line)
    if say is not None:
        say(summary_line(done))
    return out


def _export(
    inputs: Sequence[str | Path],
    out: Path,
    suffix: str,
    channels: list[str] | None,
    rate: float | None,
    time: TimeSource,
    warn: Callable[[str], None] | None = None,
    utc: bool = False,
    missing_values: Sequence[float] = (),
    rename: Sequence[tuple[str, str]] = (),
) -> Exported:
    archive = open_archive(inputs)
    archive.renames = dict(rename)
    unread = Unread()
    chunks = as_gaps(archive.chunks(time), missing_values, unread)
    with (
        scratch("analyzer-export-") as tmp,
        ChannelStore.from_chunks(chunks, tmp) as store,
    ):
        check_renames(archive)  # (a NEW name no input holds: the option's error)
        if channels:
            unmatched = store.unmatched_line(channels)
            if unmatched:
                raise UsageError(unmatched)
            names = store.select(channels, numeric_only=False)
        else:
            names = store.select(None, numeric_only=False)
        if not names:
            where = capped([str(i) for i in inputs], 3, what="inputs")
            what = no_reading_line(unread) or "no numeric channel to export"
            raise UsageError(no_numeric_channel(archive.inputs, what, where))
        one_clock(names, archive.inputs)
        rated = names if rate is not None else _voting(store, names, archive.inputs)
        aligned = store.align(names, _default_rate(store, rated) if rate is None else rate)
        absolute = absolute_times(archive.inputs)
        if utc:
            _check_utc(names, absolute, archive.inputs)
        infos = {i.name: i for i in store.infos()}
        every = list(infos)
        done = Exported(
            path=out,
            rows=aligned.n,
            rate_hz=aligned.rate_hz,
            start_ns=aligned.start_ns,
            absolute=absolute,
            channels=tuple(infos[n] for n in aligned.channels),
            asked_rate=rate,
        )
        tmp_out = out.with_name(f".{out.name}.part")
        try:
            if suffix == ".csv":
                _write_csv(aligned, tmp_out, utc)
            else:
                _write_parquet(aligned, tmp_out, utc, parquet_metadata(done))
            tmp_out.replace(out)
        except OSError as err:
            if err.filename not in (None, str(tmp_out)):
                raise  # (another file's error)
            # (pyarrow's words name no file: "Error writing bytes to file. Detail: [errno
            # 28] ...", a QA audit's ux59 item M1): the line names the export's file
            raise named_error(err, out) from err
        finally:
            tmp_out.unlink(missing_ok=True)
    if warn is not None:
        lines = [
            f"{i.path}: {_in_export_words(e)}"
            for i in archive.inputs
            for e in i.errors
            if about_selection(e, i, every, names)
        ]
        for line in lines[:WARNED_LINES]:
            warn(line)
        if len(lines) > WARNED_LINES:
            warn(f"{len(lines) - WARNED_LINES} more input errors (`analyzer inspect` lists them)")
        # (what was dropped as no reading, by channel; with --channels, of those it chose)
        for note in read_notes(_chosen(unread, names, every=not channels), missing_values):
            warn(f"{out}: {note}")
    return done


def _chosen(unread: Unread, names: Sequence[str], every: bool) -> Unread:
    """``unread``'s counts of the exported channels ``names``, and with ``every`` (no
    ``--channels``) of the channels dropped whole too, which no column holds (said as
    ``run`` says them: they have no reading)."""
    wanted = set(names) | (set(unread.lost()) if every else set())

    def kept(counts: dict[str, int]) -> dict[str, int]:
        return {c: n for c, n in counts.items() if c in wanted}

    return Unread(kept(unread.coded), kept(unread.absurd), kept(unread.nan), kept(unread.kept), {})


def _check_utc(names: Sequence[str], absolute: bool, inputs: Sequence[InputInfo]) -> None:
    """``--utc``: refused, before anything is written, for a record without a date (a
    CSV of seconds, a bag on a simulation clock: there is no UTC time to write) and for
    a channel named ``utc`` (two columns of one name)."""
    if not absolute:
        # (the readers decided: absolute_times; a simulation's clock is relative too)
        relative = [str(i.path) for i in inputs if not i.absolute_time]
        where = capped(relative, 3, what="inputs")
        raise UsageError(
            f"--utc: {where} has relative times (seconds with no date, or a simulation's "
            "clock): there is no UTC time to write; export without --utc"
        )
    if UTC_COLUMN in names:
        raise UsageError(
            f"--utc: a channel is named {UTC_COLUMN!r}; leave it out (--channels "
            f"'!{UTC_COLUMN}') or export without --utc"
        )


def interpolated_channels(done: Exported) -> list[ChannelInfo]:
    """The varying channels on a clock more than :data:`INTERPOLATED` times their own
    rate (:func:`slower_channels`)."""
    return slower_channels(done.channels, done.rate_hz)


def slower_channels(channels: Iterable[ChannelInfo], rate_hz: float) -> list[ChannelInfo]:
    """The varying channels of ``channels`` on a ``rate_hz`` clock more than
    :data:`INTERPOLATED` times their own rate (export's and run's). A constant channel is
    not among them: its values between samples are its value."""
    return [
        i
        for i in channels
        if not i.constant and i.rate_hz > 0 and rate_hz > INTERPOLATED * i.rate_hz
    ]


def interpolated_words(
    slow: Sequence[ChannelInfo], rate_hz: float, verb: str, fold: bool = False
) -> str:
    """``N channels VERB at more than twice their own rate on the R Hz clock, the values
    between their samples interpolated: NAME (RATE Hz), ...`` (the first four named), for
    the channels of :func:`slower_channels`; ``fold``: each named with how many times its
    own rate the clock is (``temp1 (1 Hz, 50-fold)``). Export's warning and run's note."""
    many = len(slow) > 1
    clock = f"{plain_number(rate_hz, 4)} Hz"

    def named(i: ChannelInfo) -> str:
        times = f", {plain_number(rate_hz / i.rate_hz, 3)}-fold" if fold else ""
        return f"{i.name} ({plain_number(i.rate_hz, 3)} Hz{times})"

    return (
        f"{len(slow)} channel{'s' if many else ''} {verb} at more than twice "
        f"{'their' if many else 'its'} own rate on the {clock} clock, the values between "
        f"{'their' if many else 'its'} samples interpolated: " + capped([named(i) for i in slow], 4)
    )


NOT_ANALYZED = "; not analyzed"
"""How a CSV reader's line on a column blank in every row ends (said for ``run``)."""


def _in_export_words(error: str) -> str:
    """An input error as an export says it: a CSV column blank in every row is "not
    analyzed" to ``run``, but an export analyzes nothing, and it writes no column for it
    (there is no sample to align: the ux56 audit read "not analyzed" as a channel left
    out by mistake, though ``--channels`` defaults to all)."""
    if "blank in every row" in error and error.endswith(NOT_ANALYZED):
        return error[: -len(NOT_ANALYZED)] + "; not exported (no column written for it)"
    return error


def interpolation_warnings(done: Exported) -> list[str]:
    """At most one line: ``--rate`` above every channel's own rate (the share of rows
    that are not readings of even the fastest), else the channels exported at more
    than twice their own rate, the first four named with their rates."""
    slow = interpolated_channels(done)
    fastest = max((i.rate_hz for i in done.channels), default=0.0)
    if done.asked_rate is not None and fastest > 0 and done.rate_hz > fastest * (1 + RATE_SLACK):
        share = 100.0 * (1.0 - fastest / done.rate_hz)
        more = (
            f", and {len(slow)} varying channel{'s are' if len(slow) > 1 else ' is'} at more "
            f"than twice {'their' if len(slow) > 1 else 'its'} own rate"
            if slow
            else ""
        )
        return [
            f"{done.path}: --rate {plain_number(done.asked_rate)} is above every channel's own "
            "rate (the "
            f"fastest: {plain_number(fastest, 4)} Hz): at least {share:.0f} % of the rows hold "
            f"values interpolated between samples, not readings{more} (without --rate the "
            "clock is the channels' dominant rate)"
        ]
    if not slow:
        return []
    return [f"{done.path}: {interpolated_words(slow, done.rate_hz, 'exported')}"]


def summary_line(done: Exported) -> str:
    """The line a successful export ends with (as ``run``'s): rows, channels, the
    clock's rate, the span and its start (UTC, or that the times are relative) and the
    file."""
    n = len(done.channels)
    span = spoken_duration(done.rows / done.rate_hz)
    start = f"from {iso_utc(done.start_ns)}" if done.absolute else "relative times, no date"
    return (
        f"exported {done.rows} row{'s' if done.rows != 1 else ''} of {n} "
        f"channel{'s' if n != 1 else ''} at {plain_number(done.rate_hz, 4)} Hz ({span}, "
        f"{start}) to {done.path}"
    )


def parquet_metadata(done: Exported) -> dict[bytes, bytes]:
    """A parquet file's key-value metadata (``pyarrow.parquet.read_schema(F).metadata``):
    ``analyzer.start_utc`` (ISO-8601, empty for relative times), ``analyzer.start_ns``
    (the first row's time: epoch nanoseconds, or the record's own clock),
    ``analyzer.absolute_time``, ``analyzer.time`` (what the ``time`` column holds),
    ``analyzer.rate_hz``, ``analyzer.rows``, ``analyzer.channels`` (JSON: each channel's
    ``name``, own ``rate_hz``, raw ``samples`` and ``interpolated``: more than twice its
    rate, :func:`interpolated_channels`) and ``analyzer.version``."""
    from analyzer import __version__

    slow = {i.name for i in interpolated_channels(done)}
    start = (
        str(iso_times(np.array([done.start_ns]), exact_unit(done.start_ns, done.rate_hz))[0])
        if done.absolute
        else ""
    )
    channels = [
        {"name": i.name, "rate_hz": i.rate_hz, "samples": i.samples, "interpolated": i.name in slow}
        for i in done.channels
    ]
    meta = {
        "start_utc": start,
        "start_ns": str(done.start_ns),
        "absolute_time": "true" if done.absolute else "false",
        "time": "seconds from start_utc (the first row)"
        if done.absolute
        else "seconds from the first row (relative times, no date)",
        "rate_hz": repr(float(done.rate_hz)),
        "rows": str(done.rows),
        "channels": json.dumps(channels),
        "version": __version__,
    }
    return {f"analyzer.{k}".encode(): v.encode() for k, v in meta.items()}


def _voting(store: ChannelStore, names: Sequence[str], inputs: Sequence[InputInfo]) -> list[str]:
    """The channels of ``names`` that set an export's default clock: those a default
    ``run`` analyzes (:func:`~analyzer.selection.select_channels`: not constant, not a
    flag, a copy, a channel whose meaning changes between messages, a log message's
    field or a timestamp), or all of ``names`` where it analyzes none of them (or
    refuses the archive). ``nav2_turtlebot.mcap``'s 7 ``/tf.transforms[0].*`` at 58 Hz,
    three frames interleaved (meaning changes), outvoted its 6 varying ``/odom``
    channels at 27.6 Hz, which ``run`` analyzes alone (a new user's audit)."""
    relabelled = [p for i in inputs for p in i.relabelled]
    logs = [t for i in inputs for t in i.log_topics]
    try:
        analyzed = set(
            select_channels(
                store, None, [], relabelled, log_topics=logs, typed=typed_fields(inputs)
            )
        )
    except (UsageError, ReaderError):
        return list(names)
    return [n for n in names if n in analyzed] or list(names)


def _default_rate(store: ChannelStore, names: Sequence[str]) -> float:
    """The dominant rate of the channels that vary (of all when none does).

    An export keeps the constant channels (``run`` leaves them out), but they do not
    set its clock: a ROS ``Odometry`` at 20 Hz brings 72 constant covariance fields,
    which outnumbered an IMU's varying channels at 100 Hz and made the clock 20 Hz. Nor
    do the entries of covariance arrays (:func:`analyzer.store.clock_rate`)."""
    infos = {i.name: i for i in store.infos()}
    varying = [n for n in names if not infos[n].constant]
    return clock_rate([infos[n] for n in varying or names])


def _table(aligned: AlignedSeries, a: int, blk: np.ndarray, schema: Any) -> Any:
    """Rows ``a .. a + len(blk) - 1``: ``time``, the channels and, when the schema has
    it, ``utc`` (ISO-8601 strings in a CSV, a UTC timestamp in a parquet file)."""
    import pyarrow as pa

    t = np.arange(a, a + blk.shape[0]) / aligned.rate_hz
    cols = [pa.array(t)] + [pa.array(blk[:, j], from_pandas=True) for j in range(blk.shape[1])]
    if len(schema) > len(cols):  # (the last column: utc)
        ns = aligned.times_ns(a, a + blk.shape[0])
        kind = schema.field(len(cols)).type
        if pa.types.is_timestamp(kind):
            cols.append(pa.array(ns, type=pa.int64()).cast(kind))
        else:
            cols.append(pa.array(iso_times(ns, exact_unit(aligned.start_ns, aligned.rate_hz))))
    return pa.Table.from_arrays(cols, schema=schema)


def _schema(aligned: AlignedSeries, utc: Any = None) -> Any:
    """``time``, the channels (float64) and ``utc`` of type ``utc`` when given."""
    import pyarrow as pa

    fields = [("time", pa.float64())] + [(c, pa.float64()) for c in aligned.channels]
    if utc is not None:
        fields.append((UTC_COLUMN, utc))
    return pa.schema(fields)


def _write_csv(aligned: AlignedSeries, path: Path, utc: bool = False) -> None:
    """CSV via pyarrow's writer: shortest round-trip floats, an empty cell for a gap;
    ``utc``: a last column of ISO-8601 UTC times. A channel name a spreadsheet would take
    for a formula is written with a ``'`` in front (:func:`~analyzer.outdir.spreadsheet_safe`)."""
    import pyarrow as pa
    import pyarrow.csv as pcsv

    schema = _schema(aligned, pa.string() if utc else None)
    # the header's names as text a spreadsheet does not evaluate (the cells below are numbers)
    schema = pa.schema([f.with_name(spreadsheet_safe(f.name)) for f in schema])
    with pcsv.CSVWriter(str(path), schema) as w:
        for a, blk in aligned.blocks(BLOCK):
            w.write_table(_table(aligned, a, blk, schema))


def _write_parquet(
    aligned: AlignedSeries, path: Path, utc: bool = False, meta: dict[bytes, bytes] | None = None
) -> None:
    """Parquet with ``meta`` as the file's key-value metadata; ``utc``: a last column of
    nanosecond UTC timestamps."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    schema = _schema(aligned, pa.timestamp("ns", tz="UTC") if utc else None)
    schema = schema.with_metadata(meta or {})
    with pq.ParquetWriter(str(path), schema) as w:
        for a, blk in aligned.blocks(BLOCK):
            w.write_table(_table(aligned, a, blk, schema))
