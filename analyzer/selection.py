"""Which channels ``run`` analyzes by default (:func:`select_channels`) and why it leaves
the others out (the notes it writes: :class:`ConstantNote`, :class:`FlagNote`,
:class:`CopyNote`, :class:`MixedNote`), with its default training window
(:func:`default_train`): ``run`` and ``inspect`` share them, so what ``inspect`` marks
is what ``run`` does. A module of its own, light to import: ``inspect`` stays fast."""

from __future__ import annotations

from collections.abc import Collection, Sequence

from analyzer.errors import ArchiveUsageError, ReaderError, capped
from analyzer.readers.base import InputInfo
from analyzer.store import ChannelInfo, ChannelStore
from analyzer.store.copies import Copy, find_copies
from analyzer.window_note import WindowNote

DEFAULT_TRAIN_FRACTION = 0.2


DEFAULT_TRAIN_MAX_S = 600.0


def no_numeric_channel(inputs: Sequence[InputInfo]) -> str:
    """``run``'s error line for an archive read without it holding any numeric channel
    (a bag of strings, a CSV of text columns): the inputs, and why where a reader could
    tell or the inputs' errors; ``inspect`` shows the same line as ``run_defaults``'s
    ``refused``."""
    why = [i.no_numeric for i in inputs if i.no_numeric]  # (a CSV's: all text)
    why += [e for i in inputs for e in i.errors]
    bad = capped(why, 3, "; ", "input errors")
    return (
        f"{capped([str(i.path) for i in inputs], 3, what='inputs')}: "
        "no numeric channel found" + (f" ({bad})" if bad else "")
    )


def default_train(duration_s: float) -> tuple[float, float]:
    """The first 20 % of the data, at most 10 minutes (CONTRACT.md)."""
    return 0.0, min(DEFAULT_TRAIN_FRACTION * duration_s, DEFAULT_TRAIN_MAX_S)


class ConstantNote(str):
    """The note naming the constant or empty channels left out, with their ``names``."""

    names: tuple[str, ...]

    def __new__(cls, names: Sequence[str]) -> ConstantNote:
        note = super().__new__(cls, f"constant or empty channels not analyzed: {', '.join(names)}")
        note.names = tuple(names)
        return note


COPIES_LISTED = 20
"""Copies the note names one by one (the rest counted: a 1000-channel record of copies
made a note of 37 kB; the review)."""


class CopyNote(str):
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


class MixedNote(str):
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


def select_channels(
    store: ChannelStore,
    patterns: list[str] | None,
    notes: list[str],
    relabelled: Sequence[str] = (),
    drop_copies: bool = True,
    named: Collection[str] = (),
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
    says which, and how to keep them)."""
    infos = {i.name: i for i in store.infos()}
    if not infos:
        raise ReaderError("no numeric channel found in the input")
    if all(i.constant for i in infos.values()):  # (the archive's own: an input error)
        notes.append(ConstantNote(list(infos)))  # (for inspect: run stops on the error)
        raise ReaderError(
            "no channel to analyze: every numeric channel is constant or empty "
            f"({', '.join(list(infos)[:3])}{', ...' if len(infos) > 3 else ''})"
        )
    if patterns:
        unmatched = store.unmatched_line(patterns)
        if unmatched:
            raise ArchiveUsageError(unmatched)
        chosen = store.select(patterns)
        if not chosen:  # every channel a pattern matches, another leaves out
            raise ArchiveUsageError(
                f"--channels: '{','.join(patterns)}' leaves no channel to analyze (its '!' "
                "patterns leave out every channel)"
            )
        constant = [c for c in chosen if infos[c].constant]
        if constant:
            notes.append(ConstantNote(constant))
        chosen = [c for c in chosen if not infos[c].constant]
    else:
        chosen = store.select(None)
        constant = [c for c in infos if infos[c].constant]
        if constant:
            notes.append(ConstantNote(constant))
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
            if copies:
                notes.append(CopyNote(copies))
                copied = {c.channel for c in copies}
                chosen = [c for c in chosen if c not in copied]
    if not chosen and patterns:
        raise ArchiveUsageError(
            f"--channels: every channel '{','.join(patterns)}' selects is constant or empty"
        )
    if not chosen:
        raise ArchiveUsageError(
            "no channel left to analyze (all selected channels are constant or empty)"
        )
    return chosen


def lone_channel(chosen: Sequence[str], notes: Sequence[str]) -> None:
    """Raise the usage error on one channel left to analyze (``chosen``), naming those
    the selection's ``notes`` left out: every detector estimates a sensor from the others
    (said first: no training window makes up for it, the realdata audit)."""
    if len(chosen) != 1:
        return
    left = [c for n in notes if isinstance(n, ConstantNote) for c in n.names]
    copied = [c for n in notes if isinstance(n, CopyNote) for c in n.names]
    flags = [c for n in notes if isinstance(n, FlagNote) for c in n.names]
    raise ArchiveUsageError(
        f"one channel to analyze ({chosen[0]}): every detector estimates a sensor "
        "from the others and needs at least 2 channels (--channels chooses them)"
        + (f"; flags or labels not analyzed: {_few(flags)}" if flags else "")
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
