"""Options of ``analyzer run`` and ``watch`` (:class:`RunOptions`), checked before any
reading: the healthy window (``--train``), ``--screen``, each ``[detectors.NAME]`` section
of the config, ``--model`` and ``--save-model``."""

from __future__ import annotations

import contextlib
import inspect
import re
import types
import typing
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from analyzer.config import Config, load_config
from analyzer.detectors import REGISTRY, detector_class
from analyzer.errors import (
    AnalyzerError,
    ArchiveUsageError,
    ConfigError,
    ShortUsageError,
    UsageError,
)
from analyzer.findings import sha256_of
from analyzer.modelfile import SavedModel, check_model_path, load_model
from analyzer.readers import parse_renames
from analyzer.readers.base import TimeSource
from analyzer.timeutil import iso_utc, parse_time, plain_number, seconds_text, window_text
from analyzer.types import NS_PER_S

Progress = Callable[[str, float], None]


@dataclass(slots=True)
class RunOptions:
    """Options of ``analyzer run`` (and ``watch``); None means the contract's default."""

    channels: list[str] | None = None
    train: str | None = None
    config: Config = field(default_factory=Config)
    detectors: list[str] | None = None
    rate: float | None = None
    jobs: int | None = None
    scheduler: str | None = None
    time_source: TimeSource = "log"
    corrected: bool = False
    progress: Progress | None = None
    model: SavedModel | None = None
    """``--model``: fitted models to run instead of fitting on this archive."""
    model_path: str | None = None
    model_sha256: str | None = None
    """The SHA-256 of the model file as it was read (``findings.json``'s ``model``): taken
    when the file is loaded, so a watcher that runs for weeks names the model it uses,
    not a file replaced since, and a cluster worker need not see the file."""
    save_model: Path | None = None
    """``--save-model``: where to write this run's fitted models."""
    screen: list[str] | None = None
    """``--screen``: these detectors first, the others only when they find a fault
    (:func:`analyzer.pipeline.analyze_screened`)."""
    warn: Callable[[str], None] | None = None
    """Where :func:`analyzer.pipeline.run` says, once the outputs are written, what went
    wrong with the inputs (a truncated file, samples dropped): the CLI's stderr."""
    note: Callable[[str], None] | None = None
    """Where :func:`analyzer.pipeline.run` says, before its last line, what it did of its
    own accord that the user should know (:class:`~analyzer.window_note.InfoNote`: the
    record analyzed slower than it was logged at): the CLI's stderr, ``analyzer: note:``."""
    say: Callable[[str], None] | None = None
    """Where :func:`analyzer.pipeline.run` says its last line (:func:`analyzer.pipeline.
    summary_line`: what it found and where the report is): the CLI's stderr."""
    missing_values: tuple[float, ...] = ()
    """``--missing-values``: numbers the loggers write for "no reading" (``-9999``),
    whose samples are taken as gaps (:mod:`analyzer.missing_codes`)."""
    rename: tuple[tuple[str, str], ...] = ()
    """``--rename NEW=OLD`` and the config's ``[rename]`` (the option's win on one NEW
    name): each NEW channel name read as the OLD one it replaces
    (:attr:`analyzer.readers.Archive.renames`), a sensor replaced under a new name."""
    inside: Path | None = None
    """The watcher's INBOX, by its real path: nothing is read through a symbolic link
    leading out of it (:func:`analyzer.readers.open_archive`); None for ``run``, which
    reads what its user names."""
    utc: bool = False
    """``run --corrected --utc``: ``corrected.csv`` gets a last column ``utc`` of UTC
    times (its ``time`` column counts seconds from the first sample, as ``export``'s)."""


MIN_TRAIN_ROWS = 16
"""Fewer training samples than this cannot calibrate anything: a usage error naming
``--train`` (the detectors ask for more, each with its own reason)."""


TRAIN_START_SLACK_S = 1.0
"""An ISO ``--train`` start at most this far before the data's first sample (or the
resolution it is written to, when coarser: :func:`_resolution_s`) is the data's start:
people type times to the second (``inspect`` prints them to the millisecond), and a
recorder's first sample falls anywhere inside the second they name."""


def _resolution_s(text: str) -> float:
    """The unit of the last field an ISO-8601 time ``text`` writes, in seconds: a day for
    a date alone, an hour for ``T09``, a minute for ``T09:59``, a second for
    ``T09:59:13``, 1 ms for ``T09:59:13.383``."""
    clock = re.search(r"[T ](\d{2}(?::?\d{2}){0,2})(?:[.,](\d+))?", text.strip())
    if clock is None:
        return 86400.0
    if clock[2]:
        return 10.0 ** -len(clock[2])
    return {1: 3600.0, 2: 60.0}.get(len(re.findall(r"\d{2}", clock[1])), 1.0)


def parse_train(
    text: str,
    start_ns: int,
    duration_s: float,
    absolute: bool,
    notes: list[str] | None = None,
) -> tuple[float, float]:
    """``--train START:END`` in seconds from the first sample or ISO-8601 times. An ISO
    start before the first sample by at most :data:`TRAIN_START_SLACK_S` (or its own
    written resolution, when coarser: the minute of ``T09:59``), with its end after it,
    is taken as the first sample, and a line in ``notes`` says so; a start before the
    data by more, or a window wholly before it, is refused, naming where the data
    starts. An end after the data's end is its end (as before)."""
    parts = _train_parts(text)
    secs = []
    for kind, val in parts:
        if kind == "ns":
            if not absolute:
                raise ArchiveUsageError(
                    f"--train: {text!r} uses absolute times but the input has relative timestamps"
                )
            secs.append((int(val) - start_ns) / NS_PER_S)
        else:
            secs.append(float(val))
    lo, hi = secs
    if lo < 0.0 and parts[0][0] == "ns" and hi > 0.0:
        slack = max(TRAIN_START_SLACK_S, _resolution_s(_split_train(text)[0]))
        if -lo <= slack:
            if notes is not None:
                notes.append(
                    f"--train: the window {text!r} starts {seconds_text(-lo)} s before the data's "
                    f"first sample ({iso_utc(start_ns)}): it starts at that sample (a start "
                    f"{_SLACK_WORDS.get(slack, 'up to 1 s before the data')} is its start)"
                )
            lo = 0.0
    if lo < 0.0 and parts[0][0] == "ns" and lo < hi:
        # an ISO start before the data: say where the data starts, not "0 <= START"
        raise ArchiveUsageError(
            f"--train: the window {text!r} starts {seconds_text(-lo)} s before the data "
            f"(which starts at {iso_utc(start_ns)}); start it there or later"
        )
    if not (0.0 <= lo < hi):
        raise UsageError(f"--train: the window {text!r} must satisfy 0 <= START < END")
    if lo >= duration_s:
        # (in the form the window was written: an ISO start is answered with a time)
        ends = (
            f", which ends at {iso_utc(start_ns + round(duration_s * NS_PER_S))}"
            if parts[0][0] == "ns"
            else f" ends ({seconds_text(duration_s)} s)"
        )
        raise ShortUsageError(
            f"--train: the window {text!r} starts after the data{ends}"
            + ("" if absolute else _own_times(text, lo, hi, start_ns, duration_s))
        )
    return lo, min(hi, duration_s)


def _own_times(text: str, lo: float, hi: float, start_ns: int, duration_s: float) -> str:
    """Of relative times that do not start at 0 (a CSV whose times run 100-160 s), where
    ``--train``'s start (``lo``) falls inside the input's own times: the window converted,
    and why (the times count from the first sample); else empty. Seconds that fit the
    file's own times were refused as "after the data ends", and nothing said so."""
    origin = start_ns / NS_PER_S
    if origin <= 0.0 or not origin <= lo < origin + duration_s:
        return ""
    a, b = lo - origin, hi - origin
    return (
        f"; --train {text} is {window_text(a, b)} here: times count from the first sample, "
        f"{seconds_text(origin)} s in the file"
    )


_SLACK_WORDS = {
    86400.0: "a date alone, up to a day before the data,",
    3600.0: "written to the hour, up to an hour before the data,",
    60.0: "written to the minute, up to a minute before the data,",
}
"""How :func:`parse_train`'s note names a start's slack (``up to 1 s before the data``
otherwise)."""


def _split_train(text: str) -> tuple[str, str]:
    """``--train START:END``'s two halves as written."""
    if text.count(":") < 1:
        raise UsageError(f"--train: expected START:END, got {text!r}")
    # ISO times contain colons: split on the separating colon between two parseable halves
    for i, ch in enumerate(text):
        if ch != ":":
            continue
        try:
            parse_time(text[:i])
            parse_time(text[i + 1 :])
        except ValueError:
            continue
        return text[:i], text[i + 1 :]
    raise UsageError(f"--train: cannot read {text!r} as START:END (seconds or ISO-8601 times)")


def _train_parts(text: str) -> tuple[tuple[str, Any], tuple[str, Any]]:
    """The two halves of ``--train START:END`` as :func:`parse_time` reads them."""
    start, end = _split_train(text)
    return parse_time(start), parse_time(end)


def train_is_absolute(text: str) -> bool:
    """Whether ``--train`` gives a time as ISO-8601 (an absolute time), which fits only
    the archives holding it: ``analyzer watch`` refuses it (every other archive failed)."""
    return any(kind == "ns" for kind, _ in _train_parts(text))


def check_train(text: str) -> None:
    """What can be checked of ``--train`` before the data is read (its syntax and order),
    so a bad window is a usage error up front (the watcher checks it once, not per
    archive)."""
    (ka, a), (kb, b) = _train_parts(text)
    if ka == kb and not (float(a) < float(b) and (ka == "ns" or float(a) >= 0.0)):
        raise UsageError(f"--train: the window {text!r} must satisfy 0 <= START < END")


def check_model_options(
    model: SavedModel, rate: float | None, detectors: Sequence[str] | None, where: str | None
) -> None:
    """``--rate`` and ``--detectors`` against the ``--model`` they are given with (at
    ``where``), before any reading: an error every archive would get, which ``analyzer
    watch`` reported after each archive, each left in INBOX, instead of at its start."""
    where = where or ""
    if rate is not None and abs(rate - model.rate_hz) > 1e-9 * model.rate_hz:
        raise UsageError(
            f"--rate {plain_number(rate)}: the model {where} was fitted at "
            f"{plain_number(model.rate_hz, 6)} Hz; "
            "leave --rate out or fit a model at that rate"
        )
    rank = {n: i for i, n in enumerate(REGISTRY)}
    held = sorted(model.detectors(), key=lambda n: rank.get(n, len(rank)))
    absent = [d for d in detectors or () if d not in held]
    if absent:
        raise UsageError(
            f"--detectors {absent[0]}: not in the model {where} (it holds {', '.join(held)})"
        )


def load_options(config_path: str | None, **kw: Any) -> RunOptions:
    """RunOptions with the config file loaded and validated (every detector section,
    whether or not that detector runs: a typo never passes silently)."""
    scheduler = kw.get("scheduler")
    if scheduler is not None and not scheduler.strip():  # (else it silently ran locally)
        raise UsageError("--scheduler: an empty address; expected one like tcp://HOST:PORT")
    model_path = kw.pop("model", None)
    save = kw.pop("save_model", None)
    if model_path is not None:
        for option, key in (("--train", "train"), ("--channels", "channels")):
            if kw.get(key) is not None:
                raise UsageError(
                    f"{option}: not used with --model (the model was fitted on its own "
                    "channels and healthy window)"
                )
        if config_path is not None:
            raise UsageError(
                f"--config {config_path}: not used with --model (the model holds the "
                "configuration it was fitted with)"
            )
        if save is not None:
            raise UsageError("--save-model: not used with --model (nothing is fitted)")
        kw["model"] = load_model(model_path)
        kw["model_path"] = str(model_path)
        with contextlib.suppress(OSError):  # (read a moment ago: gone only in a race)
            kw["model_sha256"] = sha256_of(Path(model_path))
    if save is not None:
        kw["save_model"] = Path(save)
        check_model_path(kw["save_model"])
    cfg = load_config(config_path, set(REGISTRY))
    _check_detector_options(cfg)
    if kw.get("train") is not None:
        check_train(kw["train"])
    if kw.get("detectors"):
        kw["detectors"] = list(dict.fromkeys(kw["detectors"]))  # each detector runs once
        for name in kw["detectors"]:
            detector_class(name)  # an unknown name is a usage error before any reading
    if kw.get("model") is not None:
        check_model_options(kw["model"], kw.get("rate"), kw.get("detectors"), kw["model_path"])
    if kw.get("screen"):
        kw["screen"] = _check_screen(list(dict.fromkeys(kw["screen"])), kw)
    if kw.get("utc") and not kw.get("corrected"):
        raise UsageError(
            "--utc: adds a column of UTC times to DIR/corrected.csv, which only --corrected "
            "writes; give --corrected too"
        )
    kw["rename"] = parse_renames(kw.get("rename") or (), cfg.rename)
    return RunOptions(config=cfg, **kw)


def check_utc(absolute: bool, channels: Sequence[str]) -> None:
    """``run --corrected --utc``, once the record is read and before it is analyzed: a
    record without a date (a CSV of seconds, a bag on a simulation clock) has no UTC time
    to write, and an analyzed channel named ``utc`` would make two columns of one name."""
    if not absolute:
        raise UsageError(
            "--utc: the record has relative times (seconds with no date, or a clock before "
            "1973, a simulation's): there is no UTC time to write; run without --utc"
        )
    if "utc" in channels:
        raise UsageError(
            "--utc: an analyzed channel is named 'utc'; leave it out (--channels '!utc') or "
            "run without --utc"
        )


def _check_screen(screen: list[str], kw: dict[str, Any]) -> list[str]:
    """``--screen``'s detectors, checked before any reading: known, among those the run
    would run (``--detectors``, a ``--model``'s), not all of them, and not with
    ``--save-model`` (a screened run may fit only some of the detectors)."""
    for name in screen:
        if name not in REGISTRY:
            known = ", ".join(sorted(REGISTRY))
            raise UsageError(f"--screen: unknown detector {name!r} (known: {known})")
    if kw.get("save_model") is not None:
        raise UsageError(
            "--screen: not used with --save-model (a screened run fits only the screening's "
            "detectors when they find nothing)"
        )
    model = kw.get("model")
    held = list(model.detectors()) if model is not None else None
    full = kw.get("detectors") or held or list(REGISTRY)
    absent = [d for d in screen if d not in full]
    if absent:
        where = "--detectors" if kw.get("detectors") else "the model" if held else "the run"
        raise UsageError(f"--screen {absent[0]}: not among the detectors of {where}")
    if set(screen) >= set(full):
        raise UsageError(
            f"--screen {','.join(screen)}: every detector of the run; screen with fewer"
        )
    return screen


def _check_detector_options(cfg: Config) -> None:
    """Each ``[detectors.NAME]`` section's settings: known to the detector, of the type
    its constructor declares (a float or a boolean is not an integer, a string not a list:
    :func:`_type_error`), and accepted by it (:class:`ConfigError` naming the file, the
    section and the setting)."""
    for name, opts in cfg.detectors.items():
        cls = detector_class(name)
        params = inspect.signature(cls.__init__).parameters
        known = [k for k, p in params.items() if k != "self" and p.kind is p.POSITIONAL_OR_KEYWORD]
        if not any(p.kind is p.VAR_KEYWORD for p in params.values()):
            for key in opts:
                if key not in known:
                    raise ConfigError(
                        f"{cfg.path}: [detectors.{name}] unknown setting {key!r} "
                        f"(known: {', '.join(known)})"
                    )
        failed: Exception | None = None
        try:
            cls(**opts)  # its own checks first: they say what each setting means
        except AnalyzerError as err:
            failed = err
        except (TypeError, ValueError, AttributeError) as err:
            failed = err  # (a value of the wrong type: the check below names it)
        try:
            hints = typing.get_type_hints(cls.__init__)
        except (NameError, TypeError):  # an annotation only a type checker resolves
            hints = {}
        for key, value in opts.items():
            expected = _type_error(value, hints.get(key, Any))
            if expected and not isinstance(failed, AnalyzerError):
                raise ConfigError(
                    f"{cfg.path}: [detectors.{name}] {key}: expected {expected}, got {value!r}"
                ) from failed
        if failed is not None:
            msg = str(failed)
            where = "" if msg.startswith(f"[detectors.{name}]") else f"[detectors.{name}] "
            raise ConfigError(f"{cfg.path}: {where}{msg}") from failed


_KINDS: dict[Any, str] = {
    int: "an integer",
    float: "a number",
    str: "a string",
    bool: "true or false",
}


def _type_error(value: Any, hint: Any) -> str:
    """What a detector setting of the type ``hint`` (its constructor's annotation) should
    be, when the TOML value ``value`` is not that; empty when it is. TOML's types are
    checked strictly where Python would convert silently: ``int`` takes no float (2.5
    was truncated to 2) nor boolean (``true`` is 1), ``bool`` no string (``bool("false")``
    is True), a list no string (its characters)."""
    if hint is Any or hint is None or hint is type(None):
        return ""
    origin = typing.get_origin(hint)
    if origin in (typing.Union, types.UnionType):
        options = [h for h in typing.get_args(hint) if h is not type(None)]
        if all(_type_error(value, h) for h in options):
            return " or ".join(_type_error(value, h) for h in options)
        return ""
    if hint is bool:
        return "" if isinstance(value, bool) else _KINDS[bool]
    if hint is int:
        return "" if isinstance(value, int) and not isinstance(value, bool) else _KINDS[int]
    if hint is float:
        ok = isinstance(value, int | float) and not isinstance(value, bool)
        return "" if ok else _KINDS[float]
    if hint is str:
        return "" if isinstance(value, str) else _KINDS[str]
    args = typing.get_args(hint)
    if origin in (Mapping, dict):
        if not isinstance(value, dict):
            return "a table"
        bad = [
            _type_error(k, args[0]) or _type_error(v, args[1])
            for k, v in value.items()
            if args and (_type_error(k, args[0]) or _type_error(v, args[1]))
        ]
        return f"a table of {_describe(args[1])}" if bad else ""
    if origin in (Sequence, list, tuple):
        if not isinstance(value, list):
            return "a list"
        if args and any(_type_error(v, args[0]) for v in value):
            return f"a list of {_describe(args[0])}"
        return ""
    return ""


def _describe(hint: Any) -> str:
    """``hint`` in words (the element type of a list or table)."""
    if hint in _KINDS:
        return {int: "integers", float: "numbers", str: "strings", bool: "booleans"}[hint]
    if typing.get_origin(hint) in (Sequence, list, tuple):
        args = typing.get_args(hint)
        return "lists" + (f" of {_describe(args[0])}" if args else "")
    return str(hint)
