"""How ``--channels``' shell-style patterns match channel names.

A channel of an array's element is named ``{field}[i]`` (``/scan.ranges[10]``,
``/imu.orientation_covariance[0]``: the contract), and a shell pattern reads ``[``
as the start of a character class: ``/imu.orientation_covariance[*]`` meant "any one of
``*``" and matched nothing, as did ``*covariance[0]`` ("a ``0``") and
``/scan.ranges[10*]`` (a new user's audit; only ``[[]10*]`` worked). So a ``[`` followed
by digits, ``*`` or ``?`` and a ``]`` (:data:`INDEX`) is an index, matched as written,
with ``*`` and ``?`` inside it standing for digits: ``[*]`` any index, ``[1?]`` ``[10]``
to ``[19]``. Every other bracket is a class as before (``[xyz]``, ``[!0]``, ``[0-9]``),
and a pattern whose index reading matches nothing is read as a shell pattern too
(``/s[12].data`` for ``/s1.data`` and ``/s2.data``, where no channel is named
``/s[12].data``)."""

from __future__ import annotations

import fnmatch
import re
from collections.abc import Iterable
from functools import lru_cache

INDEX = re.compile(r"\[([0-9*?]+)\]")
"""An array index in a pattern: ``[`` digits, ``*`` or ``?`` ``]``."""


@lru_cache(maxsize=256)
def index_regex(pattern: str) -> re.Pattern[str] | None:
    """``pattern`` as a regular expression with its indexes (:data:`INDEX`) taken
    literally, ``*`` and ``?`` inside one standing for digits; None when it holds no
    index (it is a plain shell pattern)."""
    parts: list[str] = []
    at = 0
    for index in INDEX.finditer(pattern):
        if _inside_class(pattern, index.start()):
            continue
        parts.append(_shell(pattern[at : index.start()]))
        inner = re.escape(index.group(1)).replace(r"\*", "[0-9]*").replace(r"\?", "[0-9]")
        parts.append(r"\[" + inner + r"\]")
        at = index.end()
    if not parts:
        return None
    parts.append(_shell(pattern[at:]))
    return re.compile("".join(parts) + r"\Z", re.DOTALL)


def _inside_class(pattern: str, at: int) -> bool:
    """Whether the ``[`` at ``at`` lies inside a character class opened before it
    (``[[]``'s inner ``[``): an unclosed ``[`` before it whose class ends after it."""
    i = 0
    while i < at:
        if pattern[i] == "[":
            j = i + 1
            if j < len(pattern) and pattern[j] == "!":
                j += 1
            if j < len(pattern) and pattern[j] == "]":
                j += 1
            close = pattern.find("]", j)
            if close == -1:
                return False
            if close >= at:
                return True
            i = close + 1
        else:
            i += 1
    return False


def _shell(part: str) -> str:
    """A piece of a shell pattern as a regular expression (no anchors)."""
    if not part:
        return ""
    translated = fnmatch.translate(part)  # "(?s:...)\Z" ("\z" from Python 3.14)
    inner = re.fullmatch(r"\(\?s:(.*)\)\\[Zz]", translated, re.DOTALL)
    if inner is None:  # pragma: no cover - another form of fnmatch.translate
        raise RuntimeError(f"unexpected fnmatch.translate form: {translated!r}")
    return inner.group(1)


def matches(name: str, pattern: str) -> bool:
    """Whether ``pattern`` matches the channel ``name`` with its indexes read literally
    (:func:`index_regex`), or as a plain shell pattern where it holds none."""
    if name == pattern:
        return True
    regex = index_regex(pattern)
    if regex is None:
        return fnmatch.fnmatchcase(name, pattern)
    return regex.match(name) is not None


def matching(names: Iterable[str], pattern: str) -> list[str]:
    """The ``names`` that ``pattern`` matches: with its indexes read literally, or, where
    that reading matches none, as a plain shell pattern (its brackets classes)."""
    names = list(names)
    found = [n for n in names if matches(n, pattern)]
    if found or index_regex(pattern) is None:
        return found
    return [n for n in names if fnmatch.fnmatchcase(n, pattern)]
