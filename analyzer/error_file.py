"""The whole message of an error line that was cut.

The contract's error is one line on stderr (exit 2), and :func:`~analyzer.errors.clipped_line`
cuts a long one (several detectors' reasons and their advice) to
:data:`~analyzer.errors.LINE_MOST` characters. The cut part was lost: the line said how
long the message had been and nowhere to read the rest. Now the whole message is kept in
a file and the line ends with its path:

* ``run --out DIR``: ``DIR/error.txt`` (DIR made if missing, as the run makes it for
  its report);
* ``export --out FILE``: ``FILE.error.txt`` beside FILE (its folder made if missing, as
  the export makes it);
* ``inspect`` and ``watch`` (no output of their own), an ``--out`` that cannot be
  written or that is an input or lies beside or inside one (inputs are never modified,
  nor are files added beside them): a new file ``analyzer-error-*.txt`` in the system's
  temporary folder (TMPDIR).

A later ``run`` or ``export`` into the same place removes the file an earlier one left
there before it starts (:func:`remove_stale`), so that a report is never beside an error
file that contradicts it; a file of that name the analyzer did not write (its first line
says who wrote it: :data:`HEAD`) is never touched.
"""

from __future__ import annotations

import contextlib
import os
import re
import tempfile
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path

from analyzer.errors import terminal_safe
from analyzer.outdir import write_atomic

ERROR_FILE = "error.txt"
"""The name of the file ``run`` keeps the whole message in, in its ``--out`` DIR."""

HEAD = "analyzer {command}: error (exit code 2), {when}"
"""The first line of an error file: which command wrote it and when (UTC). The second
line is the whole message, as the cut line on stderr began."""

_OURS = re.compile(r"analyzer [a-z]+: error \(exit code 2\), ")
"""How :func:`remove_stale` knows an error file as the analyzer's own."""


def error_place(command: str | None, out: str | None) -> Path | None:
    """Where ``command`` keeps the whole message of a cut error line: in ``run``'s
    ``--out`` DIR, or beside ``export``'s ``--out`` FILE; None for the commands without
    an output (``inspect``) or of their own (``watch``, whose report folders hold the
    whole message already: ``REPORTS/<archive>/error.txt``)."""
    if not out:
        return None
    if command == "run":
        return Path(out) / ERROR_FILE
    if command == "export":
        path = Path(out)
        return path.with_name(f"{path.name}.{ERROR_FILE}")
    return None


def remove_stale(place: Path | None) -> None:
    """Remove the error file an earlier ``run`` or ``export`` left at ``place``, if the
    analyzer wrote it: this command writes a report or a new error file there, and the
    old message would contradict it. Anything else at ``place`` stays."""
    if place is None:
        return
    with contextlib.suppress(OSError, UnicodeDecodeError):
        if not place.is_file() or place.is_symlink():
            return
        with place.open(encoding="utf-8") as f:
            first = f.readline(200)
        if _OURS.match(first):
            place.unlink()


def keep_whole(
    message: str, command: str, place: Path | None, inputs: Sequence[str | Path]
) -> str | None:
    """Write ``message`` (the uncut line) to ``place``, or where ``place`` cannot be
    written or touches the inputs to a new file in the system's temporary folder; the
    path written, as the line should say it, or None if no file could be written (the
    line is then cut as before, with no path)."""
    text = HEAD.format(command=command, when=_now()) + "\n" + terminal_safe(message) + "\n"
    if place is not None and not touches_inputs(place, inputs):
        try:
            place.parent.mkdir(parents=True, exist_ok=True)
            write_atomic(place, text)
            return str(place)
        except OSError:
            pass  # (--out unwritable, or a file where its folder would be): TMPDIR
    try:
        fd, name = tempfile.mkstemp(prefix="analyzer-error-", suffix=".txt")
        with os.fdopen(fd, "w", encoding="utf-8", errors="backslashreplace") as f:
            f.write(text)
    except OSError:
        return None
    return name


def touches_inputs(place: Path, inputs: Sequence[str | Path]) -> bool:
    """Whether ``place`` is an input, or lies in an input folder or in the folder of an
    input file: the error file is never written there."""
    target = place.resolve()
    for i in inputs:
        src = Path(i).resolve()
        if target == src or src in target.parents:
            return True
        if src.is_file() and src.parent == target.parent:
            return True
    return False


def _now() -> str:
    return datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


__all__ = ["ERROR_FILE", "HEAD", "error_place", "keep_whole", "remove_stale", "touches_inputs"]
