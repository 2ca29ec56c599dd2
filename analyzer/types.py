"""Closed sets and small records shared by every stage."""

from __future__ import annotations

from enum import StrEnum
from typing import Any


class Format(StrEnum):
    """Input formats, as written in ``findings.json`` ``inputs[].format``."""

    MCAP = "mcap"
    ROS1BAG = "ros1bag"
    ROS2BAG = "ros2bag"
    CSV = "csv"


class FaultType(StrEnum):
    """Fault types of the contract (Chang et al. 2017, Eq. 11-13, plus ``other``)."""

    ADDITIVE = "additive"
    MULTIPLICATIVE = "multiplicative"
    DRIFT = "drift"
    OTHER = "other"


NS_PER_S = 1_000_000_000

MSG_PATH_ENV = "ANALYZER_MSG_PATH"
"""Environment variable holding the message path (``--msg-path`` sets it, so the
watcher's analyses inherit it): directories, separated by ``os.pathsep``, below which
each ``<package>/msg/<Type>.msg`` defines ``package/msg/Type`` for the files that embed
no definition of it (ROS 2 sqlite bags recorded before Iron, say; see
:func:`analyzer.readers.rostypes.user_store`)."""


def _note_again(cls: type, text: str, state: dict[str, Any]) -> Any:
    """A :class:`Note` of class ``cls`` rebuilt from its ``text`` and attributes."""
    note: Any = str.__new__(cls, text)
    for name, value in state.items():
        object.__setattr__(note, name, value)
    return note


class Note(str):
    """A string that carries attributes beside its text (a run's notes: the channels it
    names, an onset), pickled as its text and attributes: a subclass whose ``__new__``
    builds the text from other arguments (``ConstantNote(names)``) was unpickled by
    calling that ``__new__`` with the text, which garbled it (``ConstantNote`` came back
    as "constant or empty channels not analyzed: c, o, n, s, ...") or failed
    (``UnreadNote``); notes cross processes (``--jobs``, a Dask cluster, the watcher's
    analyses)."""

    __slots__ = ()

    def __reduce__(self) -> tuple[Any, ...]:
        state = dict(getattr(self, "__dict__", {}))
        for cls in type(self).__mro__:
            for name in getattr(cls, "__slots__", ()):
                if hasattr(self, name):
                    state[name] = getattr(self, name)
        return (_note_again, (type(self), str(self), state))


class Stage(Note):
    """A progress stage's name as the run reports it (``detect``, ``again detect``): a
    caller that compares or prints stages sees the name alone, as before; ``detail`` says
    which part of the stage is under way (``detection_filter run: time blocks 3/8``), for
    the progress printers to add. Inside ``detect`` each detector's fit and run, and the
    blocks and filters they split into, advance the one stage with its detector named
    there, so its share never goes back (before, a detector's own steps were stages of
    their own, which went back from ``detect 33%`` to ``ar_kalman_bank 6%``)."""

    detail: str

    def __new__(cls, name: str, detail: str = "") -> Stage:
        stage = super().__new__(cls, name)
        stage.detail = detail
        return stage


def stage_detail(stage: str) -> str:
    """The part of ``stage`` under way (:class:`Stage`), or "" for a plain name."""
    return str(getattr(stage, "detail", ""))


def prefixed(prefix: str, stage: str) -> str:
    """``prefix + stage`` (``again detect``, ``screen detect``) keeping ``stage``'s
    detail (a plain ``+`` would drop it)."""
    return Stage(prefix + stage, stage_detail(stage))
