"""A run's notes cross processes (``--jobs``, a Dask cluster, the watcher's analyses):
each keeps its text and attributes through pickle. ``ConstantNote`` came back as
"constant or empty channels not analyzed: c, o, n, s, ..." (its ``__new__`` called with
its text) and ``UnreadNote`` failed to load."""

from __future__ import annotations

import importlib
import inspect
import pickle
import pkgutil
from enum import Enum

import analyzer
from analyzer.missing_codes import UnreadNote
from analyzer.selection import ConstantNote
from analyzer.types import Note, Stage


def _round_trip(note: str) -> str:
    return pickle.loads(pickle.dumps(note))  # type: ignore[no-any-return]


def test_notes_keep_their_text_and_attributes() -> None:
    for note in (
        ConstantNote(["a", "b"]),
        UnreadNote({"s2": ("infinite", 5)}),
        Stage("detect", "detection_filter run: time blocks 3/8"),
    ):
        again = _round_trip(note)
        assert type(again) is type(note)
        assert again == note
        assert vars(again) == vars(note)


def test_every_string_class_with_its_own_constructor_is_a_note() -> None:
    """A str subclass whose ``__new__`` is its own must pickle as a :class:`Note` does."""
    missing = []
    for info in pkgutil.walk_packages(analyzer.__path__, "analyzer."):
        module = importlib.import_module(info.name)
        for name, cls in vars(module).items():
            if not (inspect.isclass(cls) and issubclass(cls, str)) or issubclass(cls, Enum):
                continue
            if cls.__module__ != module.__name__ or cls is Note:
                continue
            own = any("__new__" in vars(b) for b in cls.__mro__ if b not in (str, object))
            if own and not issubclass(cls, Note):
                missing.append(f"{module.__name__}.{name}")
    assert not missing, missing
