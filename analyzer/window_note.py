"""The notes of a run that it repeats on stderr (:class:`WindowNote` as warnings,
:class:`InfoNote` as information): in a module of its
own, importing nothing, for ``inspect`` to share :mod:`analyzer.selection` with ``run``
without the diagnosis's import time."""

from __future__ import annotations

from collections.abc import Sequence

from analyzer.types import Note


class WindowNote(Note):
    """A note of this check: a plain string to every reader of ``notes`` (findings.json,
    the report), recognisable so that ``run`` repeats its ``short`` form on stderr (it
    says the run's models were fitted on a window that was not healthy: a user who reads
    only the exit code and stderr must hear it too)."""

    short: str
    before: tuple[float, float] | None
    """The window before the change (seconds), where one is left: what a run on the
    default window trains on instead (:func:`analyzer.pipeline.analyze`)."""

    def __new__(
        cls, text: str, short: str = "", before: tuple[float, float] | None = None
    ) -> WindowNote:
        note = super().__new__(cls, text)
        note.short = short or text
        note.before = before
        return note


class InfoNote(Note):
    """A note of a run that it repeats on stderr as information (``analyzer: note:``),
    not as a warning: it says what the run did of its own accord, which the user should
    know but which is not wrong (the record analyzed at a slower rate than it was logged
    at, :func:`analyzer.diagnosis.oversampled.slower_clock_note`). Its ``short`` form is
    the stderr line."""

    short: str

    def __new__(cls, text: str, short: str = "") -> InfoNote:
        note = super().__new__(cls, text)
        note.short = short or text
        return note


def info_lines(notes: Sequence[str]) -> list[str]:
    """The short forms of the run's :class:`InfoNote` notes, for stderr."""
    return [n.short for n in notes if isinstance(n, InfoNote)]


class AnomalyNote(Note):
    """A note of an anomaly the detectors saw and attributed to no sensor (or a second
    fault beside a found one that their network cannot pin down): a plain string to every
    reader of ``notes``, recognisable so that ``watch`` counts it among the archive's
    warnings in its index (an anomaly on every sensor, an archive in another unit, was a
    plain "no fault" there: a new user's audit, ux53). ``onset_s`` and ``channels``: the
    anomaly's first alarm and sensors, where the note is one anomaly; ``more``: how many
    anomalies a "N more such anomalies" note counts (the run's last line says how many
    and from when: ux55)."""

    onset_s: float | None = None
    channels: tuple[str, ...] = ()
    more: int = 0

    @classmethod
    def at(cls, text: str, onset_s: float, channels: tuple[str, ...]) -> AnomalyNote:
        """The note ``text`` on one anomaly from ``onset_s`` on ``channels``."""
        note = cls(text)
        note.onset_s = onset_s
        note.channels = channels
        return note

    @classmethod
    def counting(cls, text: str, more: int) -> AnomalyNote:
        """The note ``text`` that counts ``more`` anomalies not named one by one."""
        note = cls(text)
        note.more = more
        return note
