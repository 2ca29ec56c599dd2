"""The one protocol every reader speaks.

A reader turns one input (file or ROS 2 bag directory) into a stream of
:class:`ChannelChunk`: a channel name, integer-nanosecond timestamps and float64 values.
Chunks of one channel arrive in non-decreasing time order within one input; a channel
may be split over many chunks. Readers decode in bulk (a chunk holds many samples), never
one Python object per sample on the hot path.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Collection, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Literal, Protocol

import numpy as np
import numpy.typing as npt

from analyzer.errors import MachineLimit, ReaderError, limit_line
from analyzer.readers.delays import TopicDelays
from analyzer.types import Format

if TYPE_CHECKING:
    from analyzer.readers.quaternions import Flips

TimeSource = Literal["log", "header"]

DAMAGE: tuple[type[Exception], ...] = (
    OSError,
    EOFError,
    ValueError,
    OverflowError,
    IndexError,
    MemoryError,
    struct.error,
    zlib.error,
)
"""What the standard library and numpy raise on a damaged or foreign file: a short read,
a length or offset out of range, bytes that do not decode (``UnicodeDecodeError``, a
``ValueError``), a broken deflate stream; an index past a short buffer's end (``IndexError``: the
readers' own decoders index the bytes they were given) and a declared size too large to
hold (``MemoryError``), so that one such input of several is skipped, as the contract asks,
rather than ending the run. Each reader adds its libraries' own error
classes (:func:`damage_of`). Only these count as the file's damage where reading is
caught (one damaged input of several does not stop the others): a ``TypeError``,
``AttributeError`` or ``KeyError`` is a bug of ours, and reaches the CLI's "internal
error" line instead of reading as a damaged file."""


def check_limit(err: BaseException) -> None:
    """Raise :class:`~analyzer.errors.MachineLimit` (from ``err``) where ``err``, or an
    exception it was raised from, is the machine's limit rather than the file's damage:
    too many open files (EMFILE, ENFILE) or no memory for a buffer the system was asked
    for (an ``OSError`` ENOMEM). Every handler that would record or raise ``err`` as an
    input's damage calls it first (:data:`DAMAGE` holds ``OSError``). A bare
    ``MemoryError`` stays damage: it is what a damaged file's declared size too large to
    hold raises, and one such input of several is skipped."""
    seen: set[int] = set()
    cause: BaseException | None = err
    while cause is not None and id(cause) not in seen:
        seen.add(id(cause))
        if isinstance(cause, MachineLimit):
            raise cause
        if isinstance(cause, OSError) and (line := limit_line(cause.errno)) is not None:
            raise MachineLimit(cause.errno, line) from err
        cause = cause.__cause__ or cause.__context__


def damage_of(reader: object) -> tuple[type[Exception], ...]:
    """The exceptions by which ``reader`` (a reader or its class) says its file is damaged
    or foreign: :data:`DAMAGE`, :class:`~analyzer.errors.ReaderError` and the classes its
    ``damage`` attribute names (its parsing libraries' errors)."""
    return (ReaderError, *DAMAGE, *getattr(reader, "damage", ()))


@dataclass(frozen=True, slots=True)
class ChannelChunk:
    """Samples of one channel: ``t_ns`` int64 nanoseconds, ``values`` float64, same length."""

    name: str
    t_ns: npt.NDArray[np.int64]
    values: npt.NDArray[np.float64]

    def __len__(self) -> int:
        return int(self.t_ns.shape[0])


@dataclass(slots=True)
class InputInfo:
    """What the report and ``findings.json`` say about one input."""

    path: Path
    format: Format
    size_bytes: int = 0
    sha256: str = ""
    errors: list[str] = field(default_factory=list)
    absolute_time: bool = True
    """True when timestamps are nanoseconds since the Unix epoch (UTC); False for relative
    times (a CSV without dates; an MCAP or bag whose log times end before 1973, a
    simulation clock: :data:`~analyzer.timeutil.EPOCH_LINE_NS`), which an archive does
    not stitch where they overlap (:func:`absolute_times`)."""
    units: dict[str, str] = field(default_factory=dict)
    """Of a CSV with a units line under its header: each column's unit (``s2`` ->
    ``m/s^2``) where it gives one; the report writes it after sizes and on axes."""
    time_zone: str | None = None
    """Of a CSV's date-times: the zone its first time gave (``+02:00``, ``Z``), ""
    where it gave none (read as UTC); None where the reader read no date-times. The
    report says it beside the UTC times it prints."""
    time: str = ""
    """Where its times come from, for people, where the reader chose (a CSV's time column
    and how its cells were read); ``inspect`` shows it."""
    blank_until: dict[str, int] = field(default_factory=dict)
    """Of a CSV's columns blank in its last rows (or in every row): the time of the file's
    last row (ns), to which the column was written as "no reading" (blank or ``nan``
    cells on rows whose other columns have data). A sensor that went silent there, not
    a column that was never written: :func:`analyzer.silent.silent_findings` tells it
    from a topic that stops publishing (a node stopped), which leaves no such mark."""
    relabelled: list[str] = field(default_factory=list)
    """Prefixes of channel names whose meaning changes between messages (an array's
    element named by a string that changes, ``/tf.transforms[0].``; a ``JointState``'s
    ``position[``): said in ``errors``, and not analyzed unless ``--channels`` names them."""
    labels: dict[str, str] = field(default_factory=dict)
    """The names a message gives its numeric arrays' elements, where they do not change
    between messages (:meth:`~analyzer.readers._common.TopicTracker.labels`): a channel
    name, or the prefix of an element's channels, -> the name (``/joint_states.
    velocity[4]`` -> ``right_wheel``, from ``JointState.name``; ``/tf.transforms[0]`` ->
    its ``child_frame_id``). The channel keeps its contract name (``[i]``); the label is
    shown beside it (:func:`channel_label`)."""
    topics: dict[str, tuple[str, int]] = field(default_factory=dict)
    """Of a bag or MCAP: each topic decoded -> its message type and messages decoded
    (:func:`add_topics`), a topic without a numeric field too: ``inspect`` names those
    that gave no channel (:func:`without_channels`), which vanished from its listing."""
    log_topics: list[str] = field(default_factory=list)
    """Topics whose message type is a log message (:data:`LOG_TYPES`: ``/rosout``): their
    numbers (a level, a source line, the message's own time) measure nothing, and
    ``run`` leaves them out unless ``--channels`` names them."""
    time_fields: dict[str, dict[str, str]] = field(default_factory=dict)
    """Of each topic whose message definition the reader knows (ROS 1 and ROS 2 bags,
    MCAP with ``ros1msg``, ``ros2msg`` or ``ros2idl`` schemas): its fields that hold a
    time (``"time"``: ROS's ``time``, ``builtin_interfaces/Time``) or a span
    (``"duration"``), named as its channels are after the topic's ``.``, each array
    index written ``[*]`` (:func:`~analyzer.readers.rosdecode.time_fields`); empty for a
    topic with none. ``run`` leaves them out unless ``--channels`` names them; a topic
    listed here is judged by its types only, not by names
    (:func:`analyzer.selection.time_fields`)."""
    no_numeric: str = ""
    """Why the input holds no numeric channel, where its reader can tell while opening
    it (a CSV whose columns besides the time are all text): listing it is no error
    (``inspect`` says this in its note), analyzing or exporting it is."""
    sign_flips: dict[str, Flips] = field(default_factory=dict)
    """The quaternions whose sign changed between messages and was made continuous
    (:mod:`analyzer.readers.quaternions`), by the prefix of their channels' names
    (``/imu.orientation``): the run's note says which, when their channels are analyzed."""
    clocks: dict[str, str] = field(default_factory=dict)
    """With ``--time header``, where its topics' times come from two clocks (header
    stamps on a simulation clock beside log times on the wall clock, or the other way
    round; or header stamps that are Unix times far from the others'): each topic's,
    ``"header"`` (timed by header stamps on a clock of their own) or the other clock's
    ``"log"`` (log times) or ``"stamped"`` (header stamps); else empty. Said in
    ``errors``; an analysis or export of channels of both is refused (:func:`one_clock`)."""
    clock_spans: dict[str, tuple[int, int]] = field(default_factory=dict)
    """Of each topic of :attr:`clocks`: the first and last time its clock gave it (ns)."""
    clock_steps: dict[str, str] = field(default_factory=dict)
    """With ``--time header``, the topics whose header clock was set during the recording
    (their stamps jump by more than 10 s, an hour on a simulation clock, where their
    log times do not): each with what its clock did. Said in ``errors``; an analysis
    or export of their channels is refused (:func:`one_clock`)."""
    skipped: str = ""
    """Columns a reader left out as no channel by what they are (a LabVIEW ``.lvm``'s
    ``Comment`` column, blank in every row): ``inspect`` says it once; ``run`` says
    nothing (they were called dead sensors at every run)."""
    set_back: str = ""
    """Of a CSV whose time column, or an MCAP or ROS bag whose log times, step back by
    more than an hour for more than a few rows or messages (a clock set back while
    recording, :class:`~analyzer.readers._common.LogClock`): where and by how much, as
    a line without the path. Said in ``errors`` (``inspect`` lists the file); an
    analysis or export of the input is refused (:func:`one_clock`): its rows or
    messages cannot be placed among those before. Of one input of several, never set:
    its reading stops there instead (``Reader``'s ``stop_at_set_back``), a damaged
    file, the others analyzed."""
    log_delays: dict[str, TopicDelays] = field(default_factory=dict)
    """With ``--time log``, of each topic whose messages carry header stamps: how far
    its log times depart from them (:mod:`~analyzer.readers.delays`), for the note on
    log times that jitter by a sizeable share of a sample period (:mod:`analyzer.
    delay_note`)."""


LOG_TYPES = frozenset(
    {
        "rosgraph_msgs/msg/Log",  # ROS 1's /rosout
        "rcl_interfaces/msg/Log",  # ROS 2's /rosout
        "foxglove.Log",  # Foxglove's schema (JSON, protobuf, flatbuffer)
        "foxglove_msgs/msg/Log",  # the same as a ROS message
        "foxglove_msgs/msg/LogMessage",
    }
)
"""Message types of log messages (a text, its severity, where in the source it was
written): not measurements, whatever numbers they hold."""


def add_log_topics(info: InputInfo, topics: dict[str, str]) -> None:
    """Add to ``info.log_topics`` those of ``topics`` (topic to message type, spelled
    ``pkg/Type`` or ``pkg/msg/Type``) whose type is a log message's (:data:`LOG_TYPES`)."""
    from analyzer.readers.rostypes import normalize_msgtype

    for topic, msgtype in topics.items():
        if normalize_msgtype(msgtype) in LOG_TYPES and topic not in info.log_topics:
            info.log_topics.append(topic)


def add_topics(info: InputInfo, types: Mapping[str, str], messages: Mapping[str, int]) -> None:
    """Set ``info.topics`` of the topics of ``types`` (topic to message type) that
    ``messages`` counts (messages decoded per topic)."""
    for topic, msgtype in types.items():
        if messages.get(topic):
            info.topics[topic] = (msgtype, int(messages[topic]))


def absolute_times(inputs: Iterable[InputInfo]) -> bool:
    """Whether the times of the archive of ``inputs`` are Unix times (UTC), so that a run
    gives a ``start`` date: each input's reader decided
    (:attr:`InputInfo.absolute_time`, by :data:`~analyzer.timeutil.EPOCH_LINE_NS`), and
    ``run``, ``inspect`` and ``export`` take that decision as it is. (They each judged
    the first sample's time again by a later line, 1990: a CSV of dates from 1980, a
    logger's clock never set, was "seconds since 1970 (UTC)" in ``inspect``'s time line
    and relative, without its date, everywhere else.)"""
    return all(i.absolute_time for i in inputs)


def known_topics(inputs: Iterable[InputInfo]) -> frozenset[str]:
    """The topics the readers of ``inputs`` decoded (:attr:`InputInfo.topics`): none for
    a CSV, whose columns are channels of no topic. :func:`topic_of`'s ``topics``."""
    return frozenset(t for info in inputs for t in getattr(info, "topics", {}))


def topic_of(channel: str, topics: Collection[str]) -> str:
    """The topic of the channel ``channel``: the longest of ``topics`` (the record's,
    :func:`known_topics`) that it is, or that its name begins with before a ``.`` or a
    ``[`` (``/imu/data.linear_acceleration.y`` is ``/imu/data``; an MCAP's topic may hold
    dots, ``imu.front.x`` is ``imu.front`` where that is a topic); the channel itself
    where none is (a CSV column: ``acc.x`` is a column, not a field of a topic ``acc``).
    The one rule of the notes that speak of topics (silences, delays, channels that
    stop), of ``inspect`` and of the selection's typed time fields: the name's text alone
    cannot tell a topic's dot from a field's."""
    if channel in topics:
        return channel
    for at in range(len(channel) - 1, 0, -1):
        if channel[at] in ".[" and channel[:at] in topics:
            return channel[:at]
    return channel


def without_channels(
    inputs: Sequence[InputInfo], channels: Iterable[str]
) -> list[tuple[str, str, int]]:
    """The topics of ``inputs`` decoded without giving any of ``channels`` (a
    ``std_msgs/String``, a topic of text): (topic, type, messages), in input order."""
    topics = known_topics(inputs)
    heads = {topic_of(name, topics) for name in channels}
    out: dict[str, tuple[str, str, int]] = {}
    for info in inputs:
        for topic, (msgtype, count) in getattr(info, "topics", {}).items():
            if topic in heads or topic in out:
                continue
            out[topic] = (topic, msgtype, count)
    return list(out.values())


def add_time_fields(info: InputInfo, decoders: Iterable[tuple[str, object]]) -> None:
    """Add to ``info.time_fields`` the time and duration fields of each topic of
    ``decoders`` (topic and its decoder) decoded by its message definition (a
    :class:`~analyzer.readers.rosdecode.RosBatchDecoder`; other decoders know no types)."""
    from analyzer.readers.rosdecode import RosBatchDecoder

    for topic, decoder in decoders:
        if isinstance(decoder, RosBatchDecoder):
            info.time_fields.setdefault(topic, {}).update(decoder.time_fields())


TWO_CLOCKS = "--time header: two clocks: "
"""How the line of :func:`~analyzer.readers._common.two_clocks` begins."""


def about_selection(
    line: str, info: InputInfo, channels: Collection[str], selected: Collection[str]
) -> bool:
    """Whether the input error ``line`` of ``info`` bears on the ``selected`` channels
    (of all its archive's ``channels``), for a run or export that chose channels: a line
    about a topic (``/tf: ...``) none of whose channels is selected does not, nor the
    two-clocks line of ``--time header`` where the selected topics run on one clock (it
    told the user to choose such topics: repeated after they did, it read as unheeded;
    a new user's audit). The line stays in findings.json's ``inputs[].errors``."""

    def holds(topic: str, names: Collection[str]) -> bool:
        return any(c.startswith((f"{topic}.", f"{topic}[")) for c in names)

    if line.startswith(TWO_CLOCKS) and info.clocks:
        used = {t: source for t, source in info.clocks.items() if holds(t, selected)}
        return len({source == "header" for source in used.values()}) > 1
    topic = line.removeprefix("--time header: ").split(": ", 1)[0]
    return not holds(topic, channels) or holds(topic, selected)


class Reader(Protocol):
    """One input. Construction validates the file (raising ``ReaderError`` with the path
    and the problem); :meth:`chunks` streams its numeric channels. Problems found while
    streaming that leave the rest readable (a truncated tail, an undecodable topic) are
    appended to ``info.errors`` instead of raised.

    A reader may also keep ``fraction_read``: the share of its input that
    :meth:`chunks` has got through so far (0 to 1, rising, approximate), which the
    archive turns into the reading stage's progress; one without it counts as read
    when its chunks end. And ``stop_at_set_back``: set by the archive where it holds
    several inputs, a clock set back by hours while recording (:attr:`InputInfo.set_back`)
    stops the reading there, raised as damage (the contract: one damaged file of a
    multi-file archive does not stop the analysis of the others). And ``damage``: the
    error classes its parsing libraries raise on a damaged file, beyond :data:`DAMAGE`
    (:func:`damage_of`)."""

    info: InputInfo

    def chunks(self, time: TimeSource = "log") -> Iterator[ChannelChunk]: ...

    def start_ns(self) -> int | None:
        """First timestamp, cheaply (from a summary or index) where possible; used to
        stitch the files of a directory archive in time order."""
        ...


def one_clock(channels: Sequence[str], inputs: Sequence[InputInfo]) -> None:
    """Raise :class:`~analyzer.errors.ReaderError` when ``channels`` (message-path
    names, ``{topic}.{field}``) hold topics of an input timed by two clocks
    (:attr:`InputInfo.clocks`), naming both sides and what to do, or a topic whose
    header clock was set during the recording (:attr:`InputInfo.clock_steps`), or an
    input whose times step back by hours (:attr:`InputInfo.set_back`: a CSV's time
    column, a recorder's log times), whatever its channels chosen."""
    from analyzer.readers._common import clock_step_refusal, two_clocks

    def holds(topic: str) -> bool:
        return any(c.startswith(f"{topic}.") or c.startswith(f"{topic}[") for c in channels)

    for info in inputs:
        if info.set_back:
            raise ReaderError(f"{info.path}: {info.set_back}")
        stepped = {topic: text for topic, text in info.clock_steps.items() if holds(topic)}
        if stepped:
            raise ReaderError(f"{info.path}: {clock_step_refusal(stepped)}")
        if not info.clocks:
            continue
        used = {topic: source for topic, source in info.clocks.items() if holds(topic)}
        if len({source == "header" for source in used.values()}) > 1:
            spans = info.clock_spans
            raise ReaderError(f"{info.path}: {two_clocks(used, spans)}")


def channel_label(labels: Mapping[str, str], name: str) -> str | None:
    """The label of the channel ``name`` in ``labels`` (:attr:`InputInfo.labels`): its
    own, or its element's (``/tf.transforms[0]`` for ``/tf.transforms[0].transform.x``)."""
    if name in labels:
        return labels[name]
    head = name
    while "]." in head:
        head = head[: head.rindex("].") + 1]
        if head in labels:
            return labels[head]
    return None


def channel_labels(inputs: Iterable[InputInfo], names: Iterable[str]) -> dict[str, str]:
    """The labels of the channels ``names`` that have one (:func:`channel_label`), from
    the ``inputs``' readers; a name two inputs label differently is left without."""
    merged: dict[str, str] = {}
    clash: set[str] = set()
    for info in inputs:
        for key, label in getattr(info, "labels", {}).items():  # (an older pickle: none)
            if merged.setdefault(key, label) != label:
                clash.add(key)
    for key in clash:
        del merged[key]
    out = {}
    for name in names:
        label = channel_label(merged, name) if merged else None
        if label:
            out[name] = label
    return out
