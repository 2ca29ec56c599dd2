"""Which channels ``run`` analyzes by default (:func:`select_channels`) and why it leaves
the others out (the notes it writes: :class:`ConstantNote`, :class:`FlagNote`,
:class:`CopyNote`, :class:`MixedNote`), with its default training window
(:func:`default_train`): ``run`` and ``inspect`` share them, so what ``inspect`` marks
is what ``run`` does. A module of its own, light to import: ``inspect`` stays fast."""

from __future__ import annotations

import re
from collections.abc import Collection, Iterable, Mapping, Sequence

import numpy as np

from analyzer.errors import ArchiveUsageError, ReaderError, capped
from analyzer.readers import ArchiveNote
from analyzer.readers.base import InputInfo, topic_of
from analyzer.store import LONG_ARRAY, ChannelInfo, ChannelStore, long_arrays
from analyzer.store.copies import Copy, find_copies
from analyzer.store.store import FLAG_SAMPLES
from analyzer.timeutil import short_seconds
from analyzer.types import Note
from analyzer.window_note import WindowNote

DEFAULT_TRAIN_FRACTION = 0.2


DEFAULT_TRAIN_MAX_S = 600.0


CUT_SHORT = re.compile(r"truncated|unreadable from some point on|reading stopped")
"""An input error that says the file was read only up to some point (the MCAP and
ROS 1 readers' ``truncated or damaged at byte N``, a damaged ``.gz`` CSV's
``unreadable from some point on``, a member whose reading stopped)."""


def cut_short(inputs: Sequence[InputInfo]) -> list[tuple[str, str]]:
    """(path, error) of the inputs' errors that say a file was read only up to some point
    (:data:`CUT_SHORT`), those that say where it was cut (``truncated ...``) first: a ROS
    1 bag cut short says first that its index lies past its end ("truncated?"), which is
    not where its data stops."""
    damage = [(str(i.path), e) for i in inputs for e in i.errors if CUT_SHORT.search(e)]
    return sorted(damage, key=lambda d: not d[1].startswith("truncated"))


def no_numeric_channel(
    inputs: Sequence[InputInfo], what: str = "no numeric channel found", where: str = ""
) -> str:
    """``run``'s error line for an archive read without it holding any numeric channel
    (a bag of strings, a CSV of text columns): the inputs, and why where a reader could
    tell or the inputs' errors; ``inspect`` shows the same line as ``run_defaults``'s
    ``refused``. Where a file was cut short, that comes first, as the cause (a truncated
    MCAP whose only chunk was cut said "no numeric channel found" first, and the damage
    in the parenthesis after). ``export`` says ``what`` of the inputs it was given
    (``where``)."""
    why = [i.no_numeric for i in inputs if i.no_numeric]  # (a CSV's: all text)
    why += [e for i in inputs for e in i.errors]
    damage = [d for d in cut_short(inputs) if "(truncated?)" not in d[1]]  # (a guess)
    lead = ""
    if damage:
        path, lead = damage[0]
        why.remove(lead)
        lead = (f"{path}: " if len(inputs) > 1 else "") + f"{lead}, so "
    bad = capped(why, 3, "; ", "input errors")
    where = where or capped([str(i.path) for i in inputs], 3, what="inputs")
    return f"{where}: {lead}{what}" + (f" ({bad})" if bad else "")


def default_train(duration_s: float) -> tuple[float, float]:
    """The first 20 % of the data, at most 10 minutes (CONTRACT.md)."""
    return 0.0, min(DEFAULT_TRAIN_FRACTION * duration_s, DEFAULT_TRAIN_MAX_S)


class ConstantNote(Note):
    """The note naming the constant or empty channels left out, with their ``names``."""

    names: tuple[str, ...]

    def __new__(cls, names: Sequence[str]) -> ConstantNote:
        note = super().__new__(cls, f"constant or empty channels not analyzed: {', '.join(names)}")
        note.names = tuple(names)
        return note


STUCK_SAMPLES = FLAG_SAMPLES
"""Fewest finite samples, all of one value, for a channel ``--channels`` names to be
reported as a fault (:class:`StuckNote`), and for a default run's warning on one
(:class:`ConstantSiblingNote`): as for a flag, a handful of samples tells nothing (a topic
published twice, a status read once a minute), while 100 equal readings of a sensor whose
neighbours vary are no chance (a noisy accelerometer repeats its reading to the last bit
on a few samples in a row, not on 100)."""


def one_value(info: ChannelInfo) -> str:
    """A constant channel's one value as said to a user: ``0.0``, ``2.5``, ``-1e+30``."""
    return repr(float(info.minimum)) if abs(info.minimum) < 1e15 else f"{info.minimum:.6g}"


def _samples(n: int) -> str:
    """``n`` samples, thousands spaced: ``12 000 samples``, ``1 sample``."""
    return f"{n:,}".replace(",", " ") + (" sample" if n == 1 else " samples")


def stuck_words(info: ChannelInfo) -> str:
    """What is said of a constant channel reported as a fault (:class:`StuckNote`), in
    the finding and the notes: ``reads 0.0 on every one of its 12 000 samples: dead or
    stuck, or a signal below its resolution``."""
    return (
        f"reads {one_value(info)} on every one of its {_samples(info.finite)}: dead or "
        "stuck, or a signal below its resolution"
    )


class StuckNote(ConstantNote):
    """The note naming the channels the user named (``--channels``, the config's sensors:
    :func:`select_channels`; a saved model's: :func:`model_stuck`) that read one value on
    every sample of the record (at least :data:`STUCK_SAMPLES`) beside varying ones, each
    reported as a fault of its own (:func:`analyzer.pipeline.constant_findings`). Not
    analyzed by the detectors (nothing to model), but with ``--model`` (``modelled``):
    the saved model needs each of its channels, so its detectors read it still. A
    :class:`ConstantNote`, so ``why`` says ``constant`` where the channel is left out;
    ``infos``: the channels themselves."""

    infos: tuple[ChannelInfo, ...] = ()

    def __new__(cls, text: str) -> StuckNote:
        # (built from its text, :meth:`of` adding the rest: it pickles as one, for a
        # watcher's analyses run in other processes)
        return str.__new__(cls, text)

    @classmethod
    def of(cls, infos: Sequence[ChannelInfo], modelled: bool = False) -> StuckNote:
        """The note on the constant channels ``infos`` (at least one); ``modelled``:
        channels of a saved model, which its detectors read still."""
        text = "; ".join(f"{i.name} {stuck_words(i)}" for i in infos)
        how = (
            "read by the saved model's detectors still (it needs each of its channels), "
            "and reported as one fault with what they found on it (constant_check)"
            if modelled
            else "not analyzed by the detectors (one value has nothing to model), "
            "reported as a fault (constant_check)"
        )
        note = cls(f"{text}: {how}")
        note.names = tuple(i.name for i in infos)
        note.infos = tuple(infos)
        return note


def model_stuck(
    infos: Sequence[ChannelInfo],
    channels: Sequence[str],
    inputs: Collection[str] = (),
    zero_at_rest: Collection[str] = (),
) -> list[ChannelInfo]:
    """The channels of a saved model (``channels``) that read one value on every one of
    at least :data:`STUCK_SAMPLES` samples of this record while another of them varies:
    a sensor that died after the model was saved (the model's fit left out any channel
    that did not vary in its own window, so each of its channels varied then). Not its
    measured ``inputs`` (an excitation that reads one value may be none applied), nor,
    at 0, a channel it saved as reading zero at rest (``zero_at_rest``: a flow meter
    behind a closed valve, whose zeros are no dead sensor's)."""
    named = set(channels)
    mine = [i for i in infos if i.name in named]
    if all(i.constant for i in mine):
        return []
    return [
        i
        for i in mine
        if i.constant
        and i.finite >= STUCK_SAMPLES
        and i.name not in inputs
        and not (i.minimum == 0.0 and i.name in zero_at_rest)
    ]


SIBLINGS_LISTED = 5
"""Constant siblings :class:`ConstantSiblingNote` names one by one (the rest counted)."""


def _family(name: str) -> str:
    """A channel's name with each run of digits as ``#``: ``/s3.data`` and ``/s0.data``,
    ``s3`` and ``s0``, ``/a.data[3]`` and ``/a.data[0]`` are of one family."""
    return re.sub(r"\d+", "#", name)


class ConstantSiblingNote(WindowNote):
    """The note (repeated on stderr) naming the channels a default run leaves out as
    constant (the contract's default) whose name is an analyzed channel's but for its
    digits (``/s3.data`` beside ``/s0.data`` .. ``/s2.data``): one sensor of a set that
    reads one value over the whole record is a dead or stuck sensor more often than a
    channel that means to be constant, and it was left out with a note only (a new
    user's audit: exit 0, "no sensor fault found"). ``names``: those channels."""

    names: tuple[str, ...] = ()

    @classmethod
    def of(cls, infos: Sequence[ChannelInfo]) -> ConstantSiblingNote:
        """The note on the constant siblings ``infos`` (at least one)."""
        each = capped(
            [f"{i.name} ({one_value(i)} on all {_samples(i.finite)})" for i in infos],
            SIBLINGS_LISTED,
            what="channels",
        )
        one = len(infos) == 1
        note = cls(
            f"{each} read{'s' if one else ''} one value over the whole record while the "
            f"channels named like {'it' if one else 'them'} vary: left out as constant (a dead "
            f"or stuck sensor?); name {'it' if one else 'them'} in --channels to have "
            f"{'it' if one else 'them'} reported as a fault"
        )
        note.names = tuple(i.name for i in infos)
        return note


def constant_siblings(
    infos: Mapping[str, ChannelInfo], chosen: Sequence[str], reported: Collection[str] = ()
) -> list[ChannelInfo]:
    """The constant channels of ``infos`` with at least :data:`STUCK_SAMPLES` samples
    whose name is one of ``chosen``'s but for its digits (:func:`_family`), in families
    where they are fewer than the varying ones (:func:`_few_of_many`); not those
    ``reported`` as faults already (a config's sensor: :class:`StuckNote`)."""
    candidates = [
        i
        for i in infos.values()
        if i.constant
        and i.finite >= STUCK_SAMPLES
        and i.name not in chosen
        and i.name not in reported
    ]
    return _few_of_many(candidates, chosen)


def _few_of_many(constant: Sequence[ChannelInfo], varying: Sequence[str]) -> list[ChannelInfo]:
    """Of the ``constant`` channels, those of a family (:func:`_family`) whose ``varying``
    members outnumber its constant ones: one sensor of a set that reads one value is a
    dead or stuck sensor, while a family mostly constant is a structure with constant
    entries (a ROS covariance matrix: nav2's ``/amcl_pose.pose.covariance[2]`` and 30
    more read 0.0 beside the 5 that vary, and each was warned of as a dead sensor)."""
    alive: dict[str, int] = {}
    for c in varying:
        alive[_family(c)] = alive.get(_family(c), 0) + 1
    dead: dict[str, int] = {}
    for i in constant:
        dead[_family(i.name)] = dead.get(_family(i.name), 0) + 1
    return [i for i in constant if dead[_family(i.name)] < alive.get(_family(i.name), 0)]


def _lone_constants(constant: Sequence[ChannelInfo], varying: Sequence[str]) -> list[ChannelInfo]:
    """Of the ``constant`` channels a ``--channels`` glob matched, those of no family
    (:func:`_family`: no other channel of the selection is named like them but for its
    digits): a quantity of its own (an IMU's ``angular_velocity.x``), not an entry of a
    covariance matrix or a table, whose constant entries are its structure
    (:func:`_few_of_many` judges those)."""
    count: dict[str, int] = {}
    for c in [*varying, *(i.name for i in constant)]:
        count[_family(c)] = count.get(_family(c), 0) + 1
    return [i for i in constant if count[_family(i.name)] == 1]


GLOB_CONSTANTS_LISTED = 10
"""Channels :class:`ConstantGlobNote` names one by one (the rest counted): the six axes
of an IMU and its orientation fit."""


class ConstantGlobNote(WindowNote):
    """The note (repeated on stderr) naming the channels a ``--channels`` glob matched
    that read one value over the whole record (at least :data:`STUCK_SAMPLES` samples)
    and that no finding reports: of no family (:func:`_lone_constants`), so no varying
    sibling tells a dead sensor from a quantity nothing changed (a planar robot's
    height, roll and pitch: nav2's ``/odom.*`` matches 7 such channels, each 0.0 on all
    2639 samples; a fault each would be 7 false ones). A glob is the user's choice of a
    topic, not of each of its fields: they are left out as constant, as before, but said
    where the user reads (a new user's audit: the six axes of a dead IMU, matched by
    ``/imu.*``, were left out with a note in findings.json only). ``names``: those
    channels."""

    names: tuple[str, ...] = ()

    @classmethod
    def of(cls, infos: Sequence[ChannelInfo]) -> ConstantGlobNote:
        """The note on the constant channels ``infos`` (at least one)."""
        counts = {i.finite for i in infos}
        same = len(counts) == 1
        each = capped(
            [
                f"{i.name} ({one_value(i)}{'' if same else f' on {_samples(i.finite)}'})"
                for i in infos
            ],
            GLOB_CONSTANTS_LISTED,
            what="channels",
        )
        one = len(infos) == 1
        every = (
            f" on every one of {'its' if one else 'their'} {_samples(counts.pop())}" if same else ""
        )
        note = cls(
            f"--channels: {each} read{'s' if one else ''} one value{every}: not analyzed, "
            "as constant (a dead or stuck sensor, or a quantity nothing changed in this "
            f"record); name {'it' if one else 'them'} exactly in --channels to have "
            f"{'it' if one else 'them'} reported as a fault"
        )
        note.names = tuple(i.name for i in infos)
        return note


class WindowConstantNote(WindowNote):
    """The note (repeated on stderr) naming the channels left out because they do not vary
    in the training window although they vary over the record (constant there, or one
    value in 99 % of its samples; empty there is :class:`NoSamplesNote`'s): a dead
    start, a sensor switched on late; ``names``: those channels, ``why``: ``constant in
    the training window``."""

    names: tuple[str, ...] = ()
    why = "constant in the training window"


class CounterNote(Note):
    """The note naming the channels left out as counters or clocks in the training window
    (the same step from each sample to the next), with their ``names``."""

    names: tuple[str, ...]
    why = "counter"

    def __new__(cls, text: str, names: Sequence[str] = ()) -> CounterNote:
        note = super().__new__(cls, text)
        note.names = tuple(names)
        return note


def constant_kind(info: ChannelInfo) -> str:
    """How a channel :func:`select_channels` left out as constant is constant: ``empty``
    (no finite value), ``one sample`` (one) or ``constant``."""
    return "empty" if info.finite == 0 else "one sample" if info.finite == 1 else "constant"


def left_out(notes: Sequence[str], infos: Mapping[str, ChannelInfo]) -> dict[str, dict[str, str]]:
    """Why each channel the selection's (and the training window's) ``notes`` name was
    not analyzed: ``{"why": ...}``, and ``"copy_of"`` for a copy; the vocabulary of
    ``inspect --json`` and findings.json's ``channels[]`` alike (one rule for both)."""
    why: dict[str, dict[str, str]] = {}
    for note in notes:
        if isinstance(note, ConstantNote):
            why.update({c: {"why": constant_kind(infos[c])} for c in note.names if c in infos})
        elif isinstance(note, FlagNote):
            why.update({c: {"why": "flag"} for c in note.names})
        elif isinstance(note, (CopyNote, TwinInputNote)):
            why.update({c.channel: {"why": "copy", "copy_of": c.of} for c in note.copies})
        elif isinstance(note, NotMeasuredNote):
            why.update({c: {"why": w} for c, w in note.whys.items()})
        elif isinstance(note, LongArrayNote):
            why.update({c: {"why": LONG_ARRAY_WHY} for c in note.names})
        elif isinstance(note, MixedNote):
            why.update({c: {"why": "meaning changes"} for c in note.names})
        elif isinstance(note, (WindowConstantNote, CounterNote)):
            why.update({c: {"why": note.why} for c in note.names})
        elif isinstance(note, NoSamplesNote):
            why.update({c: {"why": NO_TRAINING_SAMPLES} for c in note.names})
    return why


COPIES_LISTED = 20
"""Copies the note names one by one (the rest counted: a 1000-channel record of copies
made a note of 37 kB; the review)."""


class CopyNote(Note):
    """The note naming the channels left out as copies of others (:mod:`analyzer.store.
    copies`), with their ``names`` and the ``copies`` themselves (which each copies)."""

    names: tuple[str, ...]
    copies: tuple[Copy, ...]

    def __new__(cls, copies: Sequence[Copy]) -> CopyNote:
        note = super().__new__(
            cls,
            "copies of another channel over the whole record (equal on every sample, or "
            "an exact linear function of it: nothing the other does not carry, and "
            "together they make the models singular), not analyzed: "
            + capped([f"{c.channel} {c.relation}" for c in copies], COPIES_LISTED, what="copies")
            + "; --channels naming them analyzes them",
        )
        note.names = tuple(c.channel for c in copies)
        note.copies = tuple(copies)
        return note


class TwinInputNote(ArchiveNote):
    """The note on an input of the archive whose every analyzed channel copies one of
    another input's (:func:`twin_inputs`): the same recording twice in one folder (as
    CSV and as MCAP, or a file copied under another name), whose channels would be
    analyzed as other sensors, each fault found twice (a QA audit: "2 sensor faults
    found on 2 sensors" for one). An :class:`~analyzer.readers.ArchiveNote`, so that
    ``run`` says it on stderr; ``copies`` are the channels left out."""

    copies: tuple[Copy, ...]

    def __new__(cls, twin: str, kept: str, why: str, copies: Sequence[Copy]) -> TwinInputNote:
        shown = capped([f"{c.channel} = {c.of}" for c in copies], NAMES_SHOWN_TWIN, what="channels")
        note = super().__new__(
            cls,
            f"{twin} holds the same recording as {kept} (each of its channels equals one "
            f"of {kept}'s at the same times: {shown}): analyzed once, as {kept}'s channels "
            f"({why}); --channels naming {twin}'s channels analyzes them too",
        )
        note.copies = tuple(copies)
        return note


NAMES_SHOWN_TWIN = 3
"""Channel pairs a :class:`TwinInputNote` shows (the rest counted)."""


def twin_inputs(
    copies: Sequence[Copy], chosen: Sequence[str], sources: Mapping[str, str]
) -> tuple[list[TwinInputNote], list[Copy]]:
    """The notes on inputs whose every channel in ``chosen`` copies a channel of one
    other input (``sources``: each channel's input file), and the ``copies`` that are
    not theirs (a copy inside one file, or only some channels of a file: the
    :class:`CopyNote`'s). The copy kept is the one read first: the inputs are read in
    time order, and by file name where they start together."""
    by_input: dict[str, list[str]] = {}
    for c in chosen:
        if c in sources:
            by_input.setdefault(sources[c], []).append(c)
    of = {c.channel: c for c in copies}
    notes: list[TwinInputNote] = []
    twinned: set[str] = set()
    for path, names in by_input.items():
        if not all(n in of for n in names):
            continue
        kept = {sources.get(of[n].of) for n in names}
        if len(kept) != 1 or None in kept or path in kept:
            continue
        first = str(next(iter(kept)))
        why = "the first of the two by file name" if first < path else "the one read first"
        notes.append(TwinInputNote(path, first, why, [of[n] for n in names]))
        twinned.update(names)
    return notes, [c for c in copies if c.channel not in twinned]


FLAGS_LISTED = 20
"""Flag channels the note names one by one (the rest counted)."""


class FlagNote(WindowNote):
    """The note naming the channels left out as flags or labels, not measurements (two
    whole-number values over the whole record: :attr:`~analyzer.store.ChannelInfo.flag`),
    with their ``names``; ``run`` repeats it on stderr (a label column analyzed as a
    sensor was found faulty, and its constant zero in a training window made the AR
    regressions singular: the user who reads only stderr hears why it is gone)."""

    names: tuple[str, ...] = ()

    @classmethod
    def of(cls, infos: Sequence[ChannelInfo]) -> FlagNote:
        """The note on the flag channels ``infos`` (at least one). (Built from its text,
        as :class:`WindowNote`, it pickles as one: a watcher's analyses run in other
        processes.)"""
        note = cls(_flag_text(infos))
        note.names = tuple(i.name for i in infos)
        return note


def _two_values(info: ChannelInfo) -> str:
    """A flag channel's two values, as whole numbers: ``0 and 1``."""
    lo, hi = info.levels or (0.0, 0.0)
    return f"{int(lo)} and {int(hi)}"


def _flag_text(infos: Sequence[ChannelInfo]) -> str:
    """What :class:`FlagNote` says of the flag channels ``infos`` (at least one)."""
    if len(infos) == 1:
        return (
            f"{_flags_held(infos)}: a flag or label, not a measurement; left out of the "
            "analysis; name it in --channels to analyze it"
        )
    return (
        f"{_flags_held(infos)}: flags or labels, not measurements; left out of the analysis; "
        "name them in --channels to analyze them"
    )


def _flags_held(infos: Sequence[ChannelInfo]) -> str:
    """The flag channels ``infos`` and their values: ``anomaly holds only 0 and 1 over
    the record``."""
    pairs = {_two_values(i) for i in infos}
    if len(infos) == 1:
        return f"{infos[0].name} holds only {_two_values(infos[0])} over the record"
    if len(pairs) == 1:
        names = capped([i.name for i in infos], FLAGS_LISTED, what="channels")
        return f"{names} hold only {pairs.pop()} over the record"
    each = [f"{i.name} ({_two_values(i)})" for i in infos]
    return f"{capped(each, FLAGS_LISTED, what='channels')} hold only two whole numbers each"


def _flags(
    infos: dict[str, ChannelInfo],
    chosen: Sequence[str],
    patterns: Sequence[str] | None,
    named: Collection[str],
) -> list[ChannelInfo]:
    """The channels of ``chosen`` that are flags or labels (:attr:`~analyzer.store.
    ChannelInfo.flag`) and that neither ``--channels`` (``patterns``) names by their
    exact name nor the config (``named``): a glob (``*``, ``/robot.*``) selects sensors,
    and a label beside them is left out as by default; naming it keeps it."""
    exact = {*(patterns or ()), *named}
    return [infos[c] for c in chosen if infos[c].flag and c not in exact]


class MixedNote(Note):
    """The note naming the channels left out because what they measure changes between
    messages, with their ``names``."""

    names: tuple[str, ...]

    def __new__(cls, names: Sequence[str]) -> MixedNote:
        note = super().__new__(
            cls,
            f"not analyzed: {', '.join(names)}: what they measure changes between "
            "messages (see the input's errors); --channels naming them analyzes them",
        )
        note.names = tuple(names)
        return note


NO_TRAINING_SAMPLES = "no training samples"
"""``why`` of a channel with no sample in the training window (:class:`NoSamplesNote`),
in ``inspect --json`` and findings.json's ``channels[]`` alike."""


class NoSamplesNote(WindowNote):
    """The note (repeated on stderr) naming the channels left out because they have no
    sample in the training window (their data begin after it, end before it, or a gap
    covers it: a file of the archive that names the same sensors otherwise,
    :func:`~analyzer.readers.apart_names`, a column renamed or added in a later file,
    :func:`~analyzer.readers.renamed_columns`), with their ``names``. Not "constant or
    empty": the sensor may be alive, only not there (the audit read the old words as dead
    sensors). On stderr, for a fault on such a channel is never searched for: a renamed
    column's fault passed as "no sensor fault found", exit 0, with nothing said (ux55)."""

    names: tuple[str, ...] = ()

    def __new__(cls, text: str, short: str = "") -> NoSamplesNote:
        # (built from its text, :meth:`of` adding the rest: it pickles as one, for a
        # watcher's analyses run in other processes)
        note = super().__new__(cls, text, short)
        return note  # type: ignore[return-value]

    @classmethod
    def of(cls, names: Sequence[str], window: tuple[float, float]) -> NoSamplesNote:
        """The note on the channels ``names`` without a sample in ``window`` (seconds)."""
        span = f"{short_seconds(window[0])}-{short_seconds(window[1])} s"
        listed = capped(list(names), COPIES_LISTED, what="channels")
        one = len(names) == 1
        note = cls(
            f"no samples in the training window ({span}), not "
            f"analyzed: {listed} (their data "
            "lie outside it; --train choosing a window where they have data analyzes them)",
            f"{capped(list(names), SIBLINGS_LISTED, what='channels')} "
            f"{'has' if one else 'have'} no sample in the training window {span}: not "
            f"analyzed, so a fault on {'it' if one else 'them'} cannot be found; give "
            f"--train (or [train] in a config) a window where {'it has' if one else 'they have'}"
            " data",
        )
        note.names = tuple(names)
        return note


def without_samples(
    store: ChannelStore, chosen: Sequence[str], start_ns: int, end_ns: int
) -> list[str]:
    """The channels of ``chosen`` that have no sample from ``start_ns`` to ``end_ns``
    (a training window on the store's time axis): what ``inspect`` says ``run`` leaves out
    as :class:`NoSamplesNote` says (``run`` itself finds them in the aligned window). Two
    binary searches of each channel's times, no pass over its samples."""
    out = []
    for c in chosen:
        t, _ = store.raw(c)
        if t.shape[0] == 0:
            continue
        a = int(np.searchsorted(t, start_ns, side="left"))
        b = int(np.searchsorted(t, end_ns, side="right"))
        if b <= a:
            out.append(c)
    return out


LOG_FIELD = "log message field"
"""``why`` of a field of a log message (:data:`~analyzer.readers.base.LOG_TYPES`)."""

TIME_FIELD = "timestamp field"
"""``why`` of a part of a time written in a message (:func:`time_fields`)."""

DURATION_FIELD = "duration field"
"""``why`` of a part of a span of time written in a message, a field of ROS's type
``duration`` (``builtin_interfaces/Duration``: a trajectory point's
``time_from_start``, a marker's ``lifetime``; :func:`time_fields`). Not a time, and not
a sensor's reading either: a plan or a setting, written as whole seconds beside
nanoseconds (the nanoseconds wrap each second: neither part alone follows the span)."""

SPLIT_TIMES = (("sec", "nsec"), ("sec", "nanosec"), ("secs", "nsecs"), ("seconds", "nanos"))
"""The two fields of a time split into whole seconds and nanoseconds: ROS's
``builtin_interfaces/Time`` (and ROS 1's ``time``), Foxglove's ``Time``, protobuf's
``google.protobuf.Timestamp``."""

CLOCK_FIELDS = frozenset({"stamp", "timestamp"})
"""Names of a field that holds a time as one number; it is a clock reading where its
values never go back over the record (:func:`time_fields`)."""

_INDEX = re.compile(r"\[\d+\]")


def time_fields(
    store: ChannelStore,
    names: Sequence[str],
    typed: Mapping[str, Mapping[str, str]] | None = None,
) -> dict[str, str]:
    """The channels of ``names`` that hold a time or a span written in the message, not
    a measurement, each with its ``why`` (:data:`TIME_FIELD`, :data:`DURATION_FIELD`).
    A channel of a topic whose message definition the reader knows (``typed``:
    :attr:`~analyzer.readers.base.InputInfo.time_fields`) is one by its field's type
    (ROS's ``time`` or ``duration``) and by nothing else: a ``float64 stamp`` that rises
    is a measurement. Of the others (CSV columns, JSON and protobuf messages), by its
    name and shape: both parts of a split time (:data:`SPLIT_TIMES`: ``X.sec`` beside
    ``X.nsec``; the nanoseconds part is a sawtooth that wraps each second, the seconds
    part a staircase), and a field named ``stamp`` or ``timestamp`` whose values never
    go back over the record (a clock; :data:`CLOCK_FIELDS`). Analyzed as sensors, they
    set the common clock and the advice (Keelson's 83 ``timestamp.seconds`` and
    ``.nanos`` were a record's only default channels; a new user's audit)."""
    typed = typed or {}
    present = set(store.names)  # (the other part may be constant: left out already)
    out = {}
    for name in names:
        fields = _typed_fields(name, typed)
        if fields is not None:
            kind = fields[1].get(_INDEX.sub("[*]", fields[0]))
            if kind is not None:
                out[name] = DURATION_FIELD if kind == "duration" else TIME_FIELD
            continue
        parent, dot, leaf = name.rpartition(".")
        if not dot:
            parent, leaf = "", name
        stem = f"{parent}." if dot else ""
        if (
            any(
                (leaf == whole and f"{stem}{part}" in present)
                or (leaf == part and f"{stem}{whole}" in present)
                for whole, part in SPLIT_TIMES
            )
            or leaf in CLOCK_FIELDS
            and _never_back(store, name)
        ):
            out[name] = TIME_FIELD
    return out


def typed_fields(inputs: Sequence[InputInfo]) -> dict[str, dict[str, str]]:
    """The time and duration fields of the topics whose types the readers of ``inputs``
    know (:attr:`~analyzer.readers.base.InputInfo.time_fields`), merged by topic."""
    out: dict[str, dict[str, str]] = {}
    for info in inputs:
        for topic, fields in info.time_fields.items():
            out.setdefault(topic, {}).update(fields)
    return out


def _typed_fields(
    name: str, typed: Mapping[str, Mapping[str, str]]
) -> tuple[str, Mapping[str, str]] | None:
    """The field of the channel ``name`` (after its topic's ``.``) and its topic's time
    fields, where ``typed`` knows the topic's types (its topic by
    :func:`~analyzer.readers.base.topic_of`); else None."""
    topic = topic_of(name, typed)
    if topic not in typed or not name.startswith(f"{topic}."):
        return None
    return name[len(topic) + 1 :], typed[topic]


def _never_back(store: ChannelStore, name: str) -> bool:
    """Whether the channel ``name``'s finite values never decrease (one pass, in numpy)."""
    _, v = store.raw(name)
    finite = v[np.isfinite(v)]
    return finite.shape[0] > 1 and bool(np.all(finite[1:] >= finite[:-1]))


class NotMeasuredNote(Note):
    """The note naming the channels left out because they are not measurements: the
    fields of log messages (:data:`LOG_FIELD`), times written in messages
    (:data:`TIME_FIELD`) and spans (:data:`DURATION_FIELD`); ``names``, and ``whys``:
    each one's reason."""

    names: tuple[str, ...] = ()
    whys: dict[str, str]

    def __new__(cls, text: str) -> NotMeasuredNote:
        # (built from its text, :meth:`of` adding the rest: it pickles as one, for a
        # watcher's analyses run in other processes)
        return str.__new__(cls, text)

    @classmethod
    def of(cls, whys: Mapping[str, str]) -> NotMeasuredNote:
        """The note on the channels ``whys`` names, each with its reason."""
        logs = [c for c, w in whys.items() if w == LOG_FIELD]
        times = [c for c, w in whys.items() if w == TIME_FIELD]
        spans = [c for c, w in whys.items() if w == DURATION_FIELD]
        parts = []
        if logs:
            parts.append(f"fields of log messages: {capped(logs, COPIES_LISTED, what='channels')}")
        if times:
            parts.append(f"timestamps: {capped(times, COPIES_LISTED, what='channels')}")
        if spans:
            parts.append(
                "durations (a plan or a setting, not a reading): "
                f"{capped(spans, COPIES_LISTED, what='channels')}"
            )
        note = cls(
            f"not measurements, not analyzed: {'; '.join(parts)}; --channels naming them "
            "analyzes them"
        )
        note.names = tuple(whys)
        note.whys = dict(whys)
        return note


def not_measured(
    store: ChannelStore,
    names: Sequence[str],
    log_topics: Sequence[str],
    typed: Mapping[str, Mapping[str, str]] | None = None,
) -> dict[str, str]:
    """Of ``names``, those that are no measurement, each with why: a field of a topic of
    ``log_topics`` (a log message's: :data:`LOG_FIELD`), or a time or a span written in
    a message (:func:`time_fields`, with the readers' field types ``typed``:
    :data:`TIME_FIELD`, :data:`DURATION_FIELD`)."""
    prefixes = tuple(p for t in log_topics for p in (f"{t}.", f"{t}["))
    whys = {c: LOG_FIELD for c in names if prefixes and c.startswith(prefixes)}
    whys.update({c: w for c, w in time_fields(store, names, typed).items() if c not in whys})
    return {c: whys[c] for c in names if c in whys}


def select_channels(
    store: ChannelStore,
    patterns: list[str] | None,
    notes: list[str],
    relabelled: Sequence[str] = (),
    drop_copies: bool = True,
    named: Collection[str] = (),
    log_topics: Sequence[str] = (),
    sensors: Collection[str] = (),
    blank: Collection[str] = (),
    typed: Mapping[str, Mapping[str, str]] | None = None,
    sources: Mapping[str, str] | None = None,
) -> list[str]:
    """The channels to analyze: ``--channels``' (``patterns``), else every numeric one
    that is not constant, whose meaning does not change between messages (names
    starting with one of ``relabelled``: the readers say why in the inputs' errors) and,
    with ``drop_copies``, that does not copy an earlier one over the whole record
    (:func:`analyzer.store.copies.find_copies`: a note names them). Channels that
    ``--channels`` names are all kept, copies too (a choice the user made; where the
    copies make every detector's model singular the run is refused, naming them).
    Flags and labels (two whole-number values over the record: :func:`_flags`) are left
    out unless ``--channels`` or the config (``named``) names them exactly (a note
    says which, and how to keep them), and so are the fields of log messages (topics of
    ``log_topics``) and the times and durations written in messages (:func:`not_measured`,
    by the readers' field types ``typed`` where they know them) unless ``--channels``
    (other than ``!`` patterns alone) or the config names them. A
    constant channel of at least :data:`STUCK_SAMPLES` samples beside varying ones is
    a fault (:class:`StuckNote`) where ``--channels`` names it (exactly, or by a glob
    where its family mostly varies) or, by default, where the config names it as a
    sensor (``sensors``: its ``[[group]]``'s channels, reference and uncertain
    sensors, ``[model]`` outputs; not the measured inputs, whose constant may be no
    excitation at all). An input whose every channel copies another input's (the same
    recording twice: ``sources`` names each channel's input) is left out with its own
    note (:class:`TwinInputNote`)."""
    sources = sources or {}
    infos = {i.name: i for i in store.infos()}
    if not infos:
        raise ReaderError("no numeric channel found in the input")
    if all(i.constant for i in infos.values()):  # (the archive's own: an input error)
        notes.append(ConstantNote(list(infos)))  # (for inspect: run stops on the error)
        # (a channel of one sample is neither: cart-pole/test.mcap's, each one message)
        single = all(i.samples == 1 for i in infos.values())
        raise ReaderError(
            "no channel to analyze: every numeric channel "
            + (
                "holds one sample, nothing to follow over time "
                if single
                else "is constant or empty "
            )
            + f"({', '.join(list(infos)[:3])}{', ...' if len(infos) > 3 else ''})"
        )
    if patterns:
        unmatched = store.unmatched_line(patterns)
        dead = [p for p in patterns if p in blank and p not in infos]
        if unmatched and dead:
            # (a CSV column blank in every row, ``blank``: "matches no channel" was false)
            raise ArchiveUsageError(
                f"--channels: {', '.join(dead)} {'is' if len(dead) == 1 else 'are'} in the "
                "input but blank in every row (a dead sensor, or one not recorded): no "
                "reading to analyze"
            )
        if unmatched:
            raise ArchiveUsageError(unmatched)
        chosen = store.select(patterns)
        if not chosen:  # every channel a pattern matches, another leaves out
            raise ArchiveUsageError(
                f"--channels: '{','.join(patterns)}' leaves no channel to analyze (its '!' "
                "patterns leave out every channel)"
            )
        constant = [c for c in chosen if infos[c].constant]
        chosen = [c for c in chosen if not infos[c].constant]
        # one value on every sample of a sensor the user named, beside varying ones: a
        # fault (dead or stuck), not a note only; alone, refused as before (below)
        # (named exactly, always; matched by a glob, where its family mostly varies: a
        # glob over a message also matches its covariance's constant entries)
        exact = {*patterns, *named}
        many = [infos[c] for c in constant if infos[c].finite >= STUCK_SAMPLES] if chosen else []
        few = {i.name for i in _few_of_many([i for i in many if i.name not in exact], chosen)}
        stuck = [i for i in many if i.name in exact or i.name in few]
        rest = [c for c in constant if c not in {i.name for i in stuck}]
        if stuck:
            notes.append(StuckNote.of(stuck))
        if rest:
            notes.append(ConstantNote(rest))
        quiet = _lone_constants([i for i in many if i.name in rest], chosen)
        if quiet:
            notes.append(ConstantGlobNote.of(quiet))
    else:
        chosen = store.select(None)
        constant = [c for c in infos if infos[c].constant]
        # a sensor the config names that reads one value, beside varying channels: a
        # fault, as one --channels names exactly (a note only let it pass: exit 0)
        stuck = [
            infos[c]
            for c in constant
            if c in sensors and infos[c].finite >= STUCK_SAMPLES and chosen
        ]
        rest = [c for c in constant if c not in {i.name for i in stuck}]
        if stuck:
            notes.append(StuckNote.of(stuck))
        if rest:
            notes.append(ConstantNote(rest))
    if not patterns or all(p.startswith("!") for p in patterns):
        chosen = _measured(store, chosen, notes, log_topics, named, typed)
        chosen = _short_arrays(store, chosen, notes, named)
    # (a lone channel is refused as one, flag or not: the detectors need two)
    flags = _flags(infos, chosen, patterns, named) if len(chosen) > 1 else []
    if flags:
        notes.append(FlagNote.of(flags))
        if len(flags) == len(chosen):
            where = "--channels: every channel it selects" if patterns else "every channel"
            raise ArchiveUsageError(
                f"no channel left to analyze: {where} is a flag or label, not a measurement "
                f"({_flags_held(flags)}); name them one by one in --channels to analyze them"
            )
        left_out = {i.name for i in flags}
        chosen = [c for c in chosen if c not in left_out]
    # '!' patterns alone leave channels out of the default ones, which these are not of
    if not patterns or all(p.startswith("!") for p in patterns):
        mixed = [c for c in chosen if c.startswith(tuple(relabelled))] if relabelled else []
        if mixed:
            notes.append(MixedNote(mixed))
            left_out = set(mixed)
            chosen = [c for c in chosen if c not in left_out]
            if not chosen:
                raise ArchiveUsageError(
                    "no channel left to analyze: every varying channel changes meaning "
                    f"between messages ({', '.join(mixed[:3])}"
                    + (", ..." if len(mixed) > 3 else "")
                    + "); name them with --channels to analyze them anyway"
                )
        if drop_copies and chosen:
            copies = find_copies(store, chosen)
            twins, copies = twin_inputs(copies, chosen, sources)
            notes.extend(twins)
            if copies:
                notes.append(CopyNote(copies))
            copied = {c.channel for c in copies} | {c.channel for n in twins for c in n.copies}
            if copied:
                chosen = [c for c in chosen if c not in copied]
    if chosen and (not patterns or all(p.startswith("!") for p in patterns)):
        reported = [c for n in notes if isinstance(n, StuckNote) for c in n.names]
        siblings = constant_siblings(infos, chosen, reported)
        if siblings:
            notes.append(ConstantSiblingNote.of(siblings))
    if not chosen and patterns:
        raise ArchiveUsageError(_all_constant_line(patterns, [infos[c] for c in constant]))
    if not chosen:
        raise ArchiveUsageError(
            "no channel left to analyze (all selected channels are constant or empty)"
        )
    return chosen


def _measured(
    store: ChannelStore,
    chosen: list[str],
    notes: list[str],
    log_topics: Sequence[str],
    named: Collection[str],
    typed: Mapping[str, Mapping[str, str]] | None = None,
) -> list[str]:
    """``chosen`` without the channels that are no measurement (:func:`not_measured`)
    and that the config does not name (``named``), a note naming them; refused where
    nothing else is left."""
    measured = not_measured(store, chosen, log_topics, typed)
    whys = {c: w for c, w in measured.items() if c not in named}
    if not whys:
        return chosen
    notes.append(NotMeasuredNote.of(whys))
    kept = [c for c in chosen if c not in whys]
    if not kept:
        said = _kinds_said(whys.values(), _KINDS, "or")
        raise ArchiveUsageError(
            f"no channel left to analyze: every varying channel is {said}, not a "
            f"measurement ({_few(list(whys), 3)}); name them with --channels to analyze "
            "them anyway"
        )
    return kept


LONG_ARRAY_WHY = "long array"
"""``why`` of an element of a long array (:data:`~analyzer.store.LONG_ARRAY`: a laser
scan's beams), left out of the default channels (:func:`_short_arrays`)."""

LONG_ARRAYS_LISTED = 10
"""Long arrays :class:`LongArrayNote` names one by one (the rest counted)."""


class LongArrayNote(WindowNote):
    """The note, repeated on stderr, naming the long arrays whose elements the default
    channels leave out (:func:`_short_arrays`): ``names``, their elements; ``arrays``:
    each array's ``[*]`` pattern with its count of elements."""

    names: tuple[str, ...] = ()
    arrays: dict[str, int]

    @classmethod
    def of(cls, arrays: Mapping[str, Sequence[str]]) -> LongArrayNote:
        """The note on the long arrays ``arrays`` (pattern -> elements; at least one)."""
        each = capped(
            [f"{field} ({len(elements)} elements)" for field, elements in arrays.items()],
            LONG_ARRAYS_LISTED,
            what="arrays",
        )
        first, one = next(iter(arrays)), len(arrays) == 1
        note = cls(
            f"{each}: more than {LONG_ARRAY} numbers in one field of a message, one sensor's "
            "many readings of one kind (a laser scan's beams, a point cloud), not as many "
            "sensors: not analyzed by default, and counted as one channel for the common "
            f"clock; --channels naming them analyzes them ('{first}' names every element "
            f"of {'it' if one else 'the first'})"
        )
        note.names = tuple(c for elements in arrays.values() for c in elements)
        note.arrays = {field: len(elements) for field, elements in arrays.items()}
        return note


def _short_arrays(
    store: ChannelStore, chosen: list[str], notes: list[str], named: Collection[str]
) -> list[str]:
    """``chosen`` without the elements of long arrays (:func:`~analyzer.store.long_arrays`,
    counted over every channel of the store: an array's constant elements count too),
    but those the config names (``named``), a note naming the arrays; unless nothing
    else varies (a record of one long array, a data logger's ``Float64MultiArray`` of
    many sensors: analyzed as before, as its elements are then all it holds)."""
    arrays = long_arrays(store.names)
    members = {c for elements in arrays.values() for c in elements} - set(named)
    out = {c for c in chosen if c in members}
    if not out or len(out) == len(chosen):
        return chosen
    left = {f: [c for c in elements if c in out] for f, elements in arrays.items()}
    notes.append(LongArrayNote.of({f: elements for f, elements in left.items() if elements}))
    return [c for c in chosen if c not in out]


_KINDS = {
    LOG_FIELD: "a log message's field",
    TIME_FIELD: "a timestamp",
    DURATION_FIELD: "a duration",
}
"""How the refusal of :func:`_measured` names each ``why`` it met."""

_KINDS_MANY = {
    LOG_FIELD: "log messages' fields",
    TIME_FIELD: "timestamps",
    DURATION_FIELD: "durations",
}
"""How :func:`lone_channel` names the reasons of the channels it lists."""


def _kinds_said(whys: Iterable[str], words: Mapping[str, str], last: str) -> str:
    """The ``words`` of the ``whys`` met, in ``words``' order, joined as a list ending
    with ``last`` ("or", "and"): only what is there (a record of log messages alone was
    said to hold "a log message's field or a timestamp")."""
    met = set(whys)
    kinds = [k for w, k in words.items() if w in met]
    return ", ".join(kinds[:-1]) + f" {last} {kinds[-1]}" if len(kinds) > 1 else "".join(kinds)


def _all_constant_line(patterns: Sequence[str], infos: Sequence[ChannelInfo]) -> str:
    """The usage error when every channel ``--channels`` (``patterns``) selects is
    constant or empty (``infos``): each with its one value (or ``empty``), and that one
    value is reported as a fault only beside channels that vary. "every channel selects
    is constant or empty" named none of the six axes of a dead IMU (a new user's audit)."""
    each = capped(
        [f"{i.name} ({one_value(i) if i.finite else 'empty'})" for i in infos],
        GLOB_CONSTANTS_LISTED,
        what="channels",
    )
    return (
        f"--channels: every channel '{','.join(patterns)}' selects is constant or empty: "
        f"{each}; one value over the whole record is reported as a dead or stuck sensor "
        "only beside channels that vary (select some with them)"
    )


def lone_channel(chosen: Sequence[str], notes: Sequence[str]) -> None:
    """Raise the usage error on one channel left to analyze (``chosen``), naming those
    the selection's ``notes`` left out: every detector estimates a sensor from the others
    (said first: no training window makes up for it, the realdata audit)."""
    if len(chosen) != 1:
        return
    left = [c for n in notes if isinstance(n, ConstantNote) for c in n.names]
    copied = [c for n in notes if isinstance(n, CopyNote) for c in n.names]
    flags = [c for n in notes if isinstance(n, FlagNote) for c in n.names]
    unmeasured = [c for n in notes if isinstance(n, NotMeasuredNote) for c in n.names]
    kinds = [w for n in notes if isinstance(n, NotMeasuredNote) for w in n.whys.values()]
    raise ArchiveUsageError(
        f"one channel to analyze ({chosen[0]}): every detector estimates a sensor "
        "from the others and needs at least 2 channels (--channels chooses them)"
        + (f"; flags or labels not analyzed: {_few(flags)}" if flags else "")
        + (
            f"; {_kinds_said(kinds, _KINDS_MANY, 'and')} not analyzed: {_few(unmeasured)}"
            if unmeasured
            else ""
        )
        + (
            f"; copies of another channel over the whole record not analyzed: {_few(copied)}"
            if copied
            else ""
        )
        + (f"; constant or empty channels not analyzed: {_few(left)}" if left else "")
    )


def _few(names: Sequence[str], most: int = 5) -> str:
    """``names`` comma-separated, cut to the first ``most`` with the count."""
    shown = ", ".join(names[:most])
    return shown if len(names) <= most else f"{shown}, ... ({len(names)})"
