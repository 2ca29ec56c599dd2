"""``analyzer``: a thin shell over :mod:`analyzer.pipeline` (see CONTRACT.md).

Exit codes: 0 analyzed and no fault, 1 at least one fault, 2 usage or input error (one
line on stderr, no traceback)."""

from __future__ import annotations

import argparse
import atexit
import contextlib
import errno
import json
import math
import os
import select
import signal
import sys
import threading
import time
import traceback
import warnings
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any, NoReturn, TextIO

# One BLAS thread unless the user says otherwise: the hot paths are many small and tall
# products, which threaded BLAS on a few cores makes far slower (measured 15x on 2 cores);
# parallelism comes from --jobs. Set before numpy is first imported.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from analyzer import __version__  # noqa: E402
from analyzer.error_file import error_place, keep_whole, remove_stale  # noqa: E402
from analyzer.errors import (  # noqa: E402
    AnalyzerError,
    MachineLimit,
    ReaderError,
    UsageError,
    capped,
    clipped_line,
    one_line,
    out_of_memory_line,
    terminal_safe,
)
from analyzer.lossy_stderr import lossy_stderr  # noqa: E402
from analyzer.scratch import sweep_stale  # noqa: E402
from analyzer.time_left import TimeLeft, left_text  # noqa: E402
from analyzer.types import MSG_PATH_ENV, stage_detail  # noqa: E402


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error on one line (exit 2), as the contract asks."""

    def error(self, message: str) -> NoReturn:
        # "analyzer: error: " comes first: the top parser's message stands alone, a
        # command's is named by it ("run: --jobs: ...")
        command = self.prog.removeprefix("analyzer").strip()
        raise UsageError(f"{command}: {message}" if command else message)

    def parse_known_args(  # type: ignore[override]
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> tuple[argparse.Namespace, list[str]]:
        """As argparse's, but an option's value that starts with ``-`` (``--train
        -5:10``, ``--rate -1e3``, ``--channels -x``) is its value: argparse reads only
        negative numbers of its own pattern so (``-5``, not ``-5:10``, ``-1e3`` nor
        ``-inf``) and said ``argument --train: expected one argument``, which is not
        what is wrong; now the value is checked as any other (``--train: the window
        '-5:10' must satisfy 0 <= START < END``)."""
        given = list(sys.argv[1:] if args is None else args)
        return super().parse_known_args(_attached(given, self._option_string_actions), namespace)


def _attached(args: list[str], actions: dict[str, argparse.Action]) -> list[str]:
    """``args`` with each option that takes one value and is followed by a word that
    starts with a single ``-`` and is no option of the parser written ``--opt=word``
    (up to a ``--``, after which everything is an INPUT)."""
    out: list[str] = []
    i = 0
    while i < len(args):
        word = args[i]
        if word == "--":
            return out + args[i:]
        action = actions.get(word)
        after = args[i + 1] if i + 1 < len(args) else ""
        if (
            action is not None
            and action.nargs is None
            and after.startswith("-")
            and not after.startswith("--")
            and after not in actions
        ):
            out.append(f"{word}={after}")
            i += 2
            continue
        out.append(word)
        i += 1
    return out


def _positive_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (v > 0 and math.isfinite(v)):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text!r}")
    return v


def _missing_codes(text: str) -> tuple[float, ...]:
    from analyzer.missing_codes import parse_codes

    try:
        return parse_codes(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def _non_negative_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (v >= 0 and math.isfinite(v)):
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text!r}")
    return v


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {text!r}")
    return v


def _path_text(text: str) -> str:
    """A file or folder name: not empty (``Path("")`` is the current folder, which an
    empty shell variable would silently make an input or the output)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path")
    return text


def _csv_list(text: str) -> list[str]:
    items = [t.strip() for t in text.split(",") if t.strip()]
    if not items:
        raise argparse.ArgumentTypeError("expected a comma-separated list")
    return items


def add_msg_path(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--msg-path",
        metavar=f"DIR[{os.pathsep}DIR...]",
        help="directories of <package>/msg/<Type>.msg files, for message types a file does "
        "not define (a ROS 2 bag recorded before Iron, say); also ANALYZER_MSG_PATH",
    )


def add_missing_values(p: argparse.ArgumentParser) -> None:
    """``--missing-values``, of ``run``, ``watch``, ``inspect`` and ``export`` alike: the
    same samples are no reading to each (:func:`analyzer.missing_codes.as_gaps`)."""
    p.add_argument(
        "--missing-values",
        type=_missing_codes,
        metavar="CODE[,CODE...]",
        default=(),
        help="numbers the loggers write where they have no reading (e.g. -9999): their "
        "samples are taken as gaps, as blank cells are; default: none (read as values)",
    )


def add_rename(p: argparse.ArgumentParser, config: bool = False) -> None:
    """``--rename NEW=OLD``, of ``run``, ``watch``, ``inspect`` and ``export`` alike: a
    channel joined in ``run`` is the same channel to ``inspect`` and ``export``
    (:func:`analyzer.readers.parse_renames`); ``config``: the command's ``--config`` has a
    ``[rename]`` table too."""
    p.add_argument(
        "--rename",
        action="append",
        metavar="NEW=OLD",
        help="read channel NEW as channel OLD: a sensor replaced under a new name from one "
        "file on is joined to the one it replaces (repeatable"
        + ("; the config's [rename] too)" if config else ")"),
    )


JOBS_HELP = {
    "run": "local parallelism: run the detectors (and the bank's time blocks) on N "
    "threads, same results as serial; default: the number of CPUs it may use, 1 = serial",
    "watch": "local parallelism: analyze up to N archives at once, each in a process of "
    "its own (one archive alone gets N threads); default: the number of CPUs it may "
    "use; not used "
    "with --scheduler (the cluster's worker threads set it)",
}
"""``--jobs``'s help by command: ``watch --help`` described ``run``'s threads (a new
user's audit, ux53 item 11)."""


def add_run_options(p: argparse.ArgumentParser, command: str = "run") -> None:
    """Options shared by ``run`` and ``watch`` (``command``: whose help ``--jobs`` gets)."""
    add_msg_path(p)
    p.add_argument(
        "--channels",
        type=_csv_list,
        metavar="GLOB[,GLOB...]",
        help="channels to analyze (shell patterns; !GLOB leaves channels out); default: "
        "every non-constant numeric channel but flags or labels (two whole-number values "
        "over the record), which only their exact name selects",
    )
    p.add_argument(
        "--train",
        metavar="START:END",
        help="healthy reference window, seconds from the first sample or ISO-8601 times; "
        "default: the first 20%% of the data, at most 10 minutes",
    )
    p.add_argument(
        "--config",
        type=_path_text,
        metavar="FILE",
        help="TOML config (groups, model, detector options, thresholds)",
    )
    p.add_argument(
        "--detectors",
        type=_csv_list,
        metavar="NAME[,NAME...]",
        help="detectors to run; default: every detector whose needs are met",
    )
    p.add_argument(
        "--screen",
        type=_csv_list,
        metavar="NAME[,NAME...]",
        help="analyze with these detectors first, and with all of them only when these "
        "find a fault (faster on mostly healthy archives; what these miss is missed)",
    )
    p.add_argument(
        "--rate",
        type=_positive_float,
        metavar="HZ",
        help="rate of the common clock; default: the dominant rate of the channels, or a "
        "slower one where that runs far above what they carry (a note says which)",
    )
    add_missing_values(p)
    add_rename(p, config=True)
    p.add_argument(
        "--jobs",
        type=_positive_int,
        metavar="N",
        help=JOBS_HELP[command],
    )
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="use an existing Dask distributed cluster, e.g. tcp://host:8786 (needs the "
        "'distributed' extra): run sends it the detectors' blocks; watch sends it each "
        "archive, which the workers read themselves",
    )
    p.add_argument(
        "--time",
        choices=("log", "header"),
        default="log",
        help="timestamps: log time (default) or header.stamp where messages have one",
    )
    p.add_argument(
        "--corrected",
        action="store_true",
        help="also write DIR/corrected.csv with faulty channels corrected over their fault "
        "periods, at the rate analyzed (a record the run analyzes slower than it was logged "
        "at, or --rate, gives it at that rate)",
    )
    p.add_argument(
        "--model",
        type=_path_text,
        metavar="FILE",
        help="run the fitted models saved by --save-model instead of fitting on this "
        "archive (a fault present from its first sample is found too)",
    )


PLAIN_PROGRESS_EVERY_S = 5.0
"""Off a terminal (``--progress``), the least time between two progress lines, a stage's
first line apart: a CI log of a long run gets a line every few seconds (no "no output
for N minutes" timeout), not hundreds."""


def add_progress_options(p: argparse.ArgumentParser) -> None:
    """``--progress`` and ``--no-progress`` (``run``): one or the other, or neither (a
    bar on a terminal, nothing elsewhere)."""
    shown = p.add_mutually_exclusive_group()
    shown.add_argument(
        "--progress",
        action="store_true",
        help="show progress on stderr even when it is not a terminal (a CI log, a file): "
        "plain lines, one when a stage begins and at most one every "
        f"{PLAIN_PROGRESS_EVERY_S:g} seconds within it",
    )
    shown.add_argument("--no-progress", action="store_true", help="no progress on stderr")


INPUT_HELP = (
    "an .mcap, a ROS 1 .bag, a ROS 2 bag (folder or .db3), a CSV/TSV (.gz) or a TOA5 "
    "table, or a folder of such files (its subfolders included); several INPUTs (or a "
    "folder's files) are one archive, stitched in time order (samples of a later input "
    "that overlap an earlier one's time are dropped, with a warning; files with relative "
    "times that overlap (CSVs without dates; MCAP files and bags on a simulation clock, "
    "log times before 1973) cannot be stitched and are refused)"
)


WATCH_SETUP = (
    "INBOX must exist (REPORTS, --done and --failed are made when missing): from the\n"
    "checkout's folder, this first gives the examples a folder and an archive in it:\n"
    "  mkdir -p inbox && cp samples/building_additive.mcap inbox/"
)
"""What ``watch --help``'s examples need first: they stopped at "INBOX ... is not a
directory" run as written from the checkout (a new user's audit, ux53 item 5)."""


EXIT_CODES = (
    "exit codes: 0 no sensor fault found (run), or done; 1 at least one sensor fault\n"
    "found (run); 2 usage or input error (one line on stderr naming the file or option);\n"
    "130 interrupted"
)

HELP: dict[str, tuple[str, str]] = {
    "inspect": (
        "List what is in an archive: each channel with its number of samples, its start\n"
        "and end, its rate and its gaps, as a table (or one JSON object with --json) on\n"
        "stdout. It reads the inputs and writes nothing.\n"
        "\n"
        "exit codes: 0 listed; 2 usage or input error (one line on stderr; a line cut\n"
        "for length ends with the path of a file in TMPDIR that holds it whole)",
        "examples:\n"
        "  analyzer inspect samples/building_additive.mcap\n"
        "  analyzer inspect samples/building_healthy_ros2 --json",
    ),
    "export": (
        "Write an archive's channels aligned on one clock to FILE (.csv or .parquet): a\n"
        "first column 'time' (seconds from the first sample), then one column per\n"
        "channel, one row per tick (--utc adds a last column 'utc' of UTC times). A\n"
        "parquet file also holds the record's UTC start and each channel's own rate as\n"
        "metadata. Ends with one line on stderr: rows, channels, rate, start and FILE.\n"
        "Nothing else is written; the inputs are never changed.\n"
        "\n"
        "exit codes: 0 written; 2 usage or input error (one line on stderr; a line cut for\n"
        "length ends with the path of the file that holds it whole, FILE.error.txt)",
        "examples:\n"
        "  analyzer export samples/building_drift.bag --out drift.csv\n"
        "  analyzer export samples/building_additive.mcap --out s4.parquet --channels '/s4.*'\n"
        "  analyzer export samples/building_multiplicative.csv.gz --out slow.csv --rate 50 --utc",
    ),
    "run": (
        "Analyze an archive for faulty sensors: which sensor, what kind of fault (an\n"
        "offset, a gain, a drift, or other), when it started and ended, how large it is.\n"
        "Writes DIR/report.html and DIR/findings.json (DIR/corrected.csv with --corrected),\n"
        "then one line on stderr: what was found and where the report is. The inputs are\n"
        "never changed.\n"
        "\n"
        "exit codes: 0 no sensor fault found; 1 at least one sensor fault found; 2 usage\n"
        "or input error (one line on stderr; a line cut for length ends with the path of\n"
        "the file that holds it whole, DIR/error.txt); 130 interrupted",
        "examples:\n"
        "  analyzer run samples/building_additive.mcap --out out/\n"
        "  analyzer run samples/building_drift.bag --out drift/ --train 0:15 --jobs 1\n"
        "  analyzer run samples/building_healthy_ros2 --out healthy/ --save-model building.model",
    ),
    "watch": (
        "Watch the folder INBOX and analyze every archive that lands in it, as 'analyzer\n"
        "run' does: REPORTS gets a folder per archive (report.html and findings.json, or\n"
        "error.txt) and index.html, which lists them all. It runs until stopped (Ctrl-C),\n"
        "or with --once until what INBOX holds is analyzed.\n"
        "\n"
        "exit codes: 0 stopped, or --once and no fault found; 1 --once and a fault found;\n"
        "2 usage error (one line on stderr), or --once and an archive that could not be\n"
        "analyzed; 130 --once interrupted",
        "examples:\n"
        "  analyzer watch inbox/ --out reports/\n"
        "  analyzer watch inbox/ --out reports/ --once --done analyzed/ --failed failed/\n"
        "  analyzer watch inbox/ --out reports/ --group-by '^(.*)_part[0-9]+\\.csv$'\n"
        "\n"
        f"{WATCH_SETUP}",
    ),
}
"""Each command's ``--help``: what it does, what it writes and its exit codes first, and
examples after its options (every example runs from the checkout's folder:
``tests/cli/test_help.py`` parses them, and the samples' ones were run)."""


def _sub(sub: Any, name: str, summary: str) -> argparse.ArgumentParser:
    """The parser of command ``name``: ``summary`` in the list of commands, and its
    :data:`HELP` around its options (their lines kept as written)."""
    description, epilog = HELP[name]
    parser: argparse.ArgumentParser = sub.add_parser(
        name,
        help=summary,
        description=description,
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    return parser


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="analyzer",
        description="Audit sensor logs for faulty sensors.",
        epilog="example:\n  "
        + HELP["run"][1].splitlines()[1].strip()
        + "\n\n"
        + EXIT_CODES
        + "\n\n'analyzer COMMAND --help' describes a command, its options and examples.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"analyzer {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = _sub(sub, "inspect", "what is in an archive: channels, counts, rates, gaps")
    p.add_argument("inputs", nargs="+", type=_path_text, metavar="INPUT", help=INPUT_HELP)
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.add_argument(
        "--time",
        choices=("log", "header"),
        default="log",
        help="timestamps: log time (default) or header.stamp where messages have one",
    )
    add_missing_values(p)
    add_rename(p)
    add_msg_path(p)

    p = _sub(sub, "export", "the time-aligned channels as .csv or .parquet")
    p.add_argument("inputs", nargs="+", type=_path_text, metavar="INPUT", help=INPUT_HELP)
    p.add_argument(
        "--out", required=True, type=_path_text, metavar="FILE", help="output .csv or .parquet"
    )
    p.add_argument(
        "--channels",
        type=_csv_list,
        metavar="GLOB[,GLOB...]",
        help="channels to export (shell patterns; !GLOB leaves channels out); default: all",
    )
    p.add_argument(
        "--rate",
        type=_positive_float,
        metavar="HZ",
        help="the common clock's rate; default: the channels' dominant rate",
    )
    p.add_argument(
        "--time",
        choices=("log", "header"),
        default="log",
        help="timestamps: log time (default) or header.stamp where messages have one",
    )
    p.add_argument(
        "--utc",
        action="store_true",
        help="add a last column 'utc': each row's time as ISO-8601 UTC (refused for "
        "relative times)",
    )
    add_missing_values(p)
    add_rename(p)
    add_msg_path(p)

    p = _sub(sub, "run", "analyze; write DIR/report.html and DIR/findings.json")
    p.add_argument("inputs", nargs="+", type=_path_text, metavar="INPUT", help=INPUT_HELP)
    p.add_argument(
        "--out",
        required=True,
        type=_path_text,
        metavar="DIR",
        help="folder for report.html and findings.json (made if missing)",
    )
    add_run_options(p)
    add_progress_options(p)
    p.add_argument(
        "--save-model",
        type=_path_text,
        metavar="FILE",
        help="also write the fitted models to FILE, for --model on later archives",
    )
    p.add_argument(
        "--utc",
        action="store_true",
        help="with --corrected: add a last column 'utc' to DIR/corrected.csv, each row's "
        "time as ISO-8601 UTC (refused for relative times)",
    )

    p = _sub(sub, "watch", "analyze every archive that lands in INBOX")
    p.add_argument(
        "inbox", type=_path_text, metavar="INBOX", help="the folder archives are dropped into"
    )
    p.add_argument(
        "--out",
        required=True,
        type=_path_text,
        metavar="REPORTS",
        help="folder of the reports: one sub-folder per archive, and index.html",
    )
    add_run_options(p, "watch")
    # (accepted as run accepts it; watch shows no progress bar: one line per archive)
    p.add_argument("--no-progress", action="store_true", help="no progress bar (none is shown)")
    p.add_argument(
        "--poll",
        type=_positive_float,
        metavar="SECONDS",
        help="poll the folder every SECONDS instead of using file events",
    )
    p.add_argument(
        "--settle",
        type=_positive_float,
        default=2.0,
        metavar="SECONDS",
        help="a file is ready when unchanged for this long (default 2)",
    )
    p.add_argument(
        "--wait-unfinished",
        type=_positive_float,
        default=600.0,
        metavar="SECONDS",
        help="analyze an archive that stays stable but still looks unfinished (a truncated "
        "MCAP, an empty file) after this long anyway, with its error record (default 600)",
    )
    p.add_argument(
        "--give-up-after",
        type=_non_negative_float,
        default=3600.0,
        metavar="SECONDS",
        help="an archive too short for the training window stays in INBOX (a file still "
        "being written grows); one unchanged this long since the watcher first saw it is "
        "given up and moved to --failed, once these options have analyzed an archive "
        "(default 3600: one hour; 0: never). A logger that pauses longer than this between "
        "appends has its file cut in two: set it above the logger's longest pause",
    )
    p.add_argument("--done", type=_path_text, metavar="DIR", help="move each analyzed archive here")
    p.add_argument(
        "--failed",
        type=_path_text,
        metavar="DIR",
        help="move each archive that could not be read here",
    )
    p.add_argument(
        "--group-by",
        metavar="PATTERN",
        help="treat files whose names give the same value for this regex's first group "
        "as one archive",
    )
    p.add_argument("--once", action="store_true", help="process what is in INBOX, then exit")
    return parser


def _warn(line: str) -> None:
    """One line on stderr about an input of a run that went on (exit 0 or 1)."""
    sys.stderr.write(f"analyzer: warning: {terminal_safe(line)}\n")


def _note(line: str) -> None:
    """One line on stderr of information about a run (what it did of its own accord that
    the user should know, nothing wrong: not a warning)."""
    sys.stderr.write(f"analyzer: note: {terminal_safe(line)}\n")


def _say(line: str) -> None:
    """``run``'s last line on stderr (what it found, where the report is)."""
    sys.stderr.write(f"analyzer: {terminal_safe(line)}\n")


def _progress_printer(args: argparse.Namespace) -> Any:
    """What ``run`` shows of its progress on stderr: a bar redrawn in place on a
    terminal; plain lines (:func:`plain_progress`) with ``--progress`` elsewhere; nothing
    with ``--no-progress``, nor off a terminal without ``--progress``."""
    if getattr(args, "no_progress", False):
        return None
    if sys.stderr.isatty():
        return _progress_bar()
    if getattr(args, "progress", False):
        return plain_progress(sys.stderr, time.monotonic)
    return None


def _progress_bar() -> Any:
    """A progress bar on stderr (a terminal): the stage, its share done and the seconds
    since the run began, with the part under way before the seconds (a detector's step
    inside ``detect``: :class:`~analyzer.types.Stage`) and, once it can be said, the time
    left (:class:`~analyzer.time_left.TimeLeft`; not on the line a stage ends with),
    redrawn on one line per stage."""
    began = time.monotonic()
    estimate = TimeLeft(time.monotonic)

    def show(stage: str, fraction: float) -> None:
        width = 30
        done = int(round(width * max(0.0, min(1.0, fraction))))
        left = estimate.update(stage, fraction)
        elapsed = time.monotonic() - began
        # the part under way, blank (what was there cleared) when the stage has ended
        detail = stage_detail(stage) if fraction < 1.0 else ""
        part = f" {detail:<{BAR_DETAIL}.{BAR_DETAIL}}" if stage_detail(stage) else ""
        # (padded: a shorter estimate redrawn over a longer one leaves nothing behind;
        # blank on a stage's last line, which stays as the record of when it ended)
        said = "" if left is None or fraction >= 1.0 else left_text(left)
        sys.stderr.write(
            f"\r{stage:<16} [{'#' * done}{'.' * (width - done)}] {100 * fraction:5.1f}%{part}"
            f" {said:>{BAR_LEFT}} {elapsed:8.1f} s"
        )
        if fraction >= 1.0:
            sys.stderr.write("\n")
        sys.stderr.flush()

    return show


BAR_DETAIL = 48
"""Characters of a progress bar's detail (the part under way), padded to this width so a
shorter one redrawn over a longer one leaves nothing of it behind."""

BAR_LEFT = len("about 10.0 days left")
"""Characters of a progress bar's time left (:func:`~analyzer.time_left.left_text`),
right-aligned to this width before the seconds."""


def plain_progress(
    stream: TextIO, clock: Callable[[], float], every_s: float = PLAIN_PROGRESS_EVERY_S
) -> Any:
    """Progress for a log (not a terminal): whole lines, no carriage return nor redraw.
    A line the first time a stage is named, else at most one every ``every_s`` seconds
    of ``clock`` (stages that take turns, a detector's own inside ``detect``, do not
    add lines), each ``analyzer: progress: STAGE NN% (T s)`` with the seconds since the
    run began, or ``STAGE NN% (DETAIL; T s)`` with the part under way (a detector's step
    inside ``detect``: :class:`~analyzer.types.Stage`), and ``; about N min left`` after
    the seconds once the time left can be said (:class:`~analyzer.time_left.TimeLeft`,
    given every update, said or not): a CI log of a long run stays short and is never
    silent for long."""
    began = clock()
    lock = threading.Lock()
    seen: set[str] = set()
    last = [began]
    estimate = TimeLeft(clock)

    def show(stage: str, fraction: float) -> None:
        with lock:
            now = clock()
            left = estimate.update(stage, fraction)
            if stage in seen and now - last[0] < every_s:
                return
            seen.add(stage)
            last[0] = now
            share = 100 * max(0.0, min(1.0, fraction))
            detail = stage_detail(stage)
            said = f"{detail}; " if detail else ""
            ahead = "" if left is None else f"; {left_text(left)}"
            stream.write(
                f"analyzer: progress: {stage} {share:.0f}% ({said}{now - began:.1f} s{ahead})\n"
            )
            stream.flush()

    return show


def cmd_inspect(args: argparse.Namespace) -> int:
    from analyzer.inspect import inspect_archive, render_table
    from analyzer.readers import parse_renames

    _stdout_open()  # (before the inputs are read: nothing could show what they hold)
    rename = parse_renames(args.rename or ())  # (before reading: a typo costs no wait)
    doc = inspect_archive(
        args.inputs, time=args.time, missing_values=args.missing_values, rename=rename
    )
    errors = [f"{i['path']}: {e}" for i in doc["inputs"] for e in i["errors"]]
    if not doc["channels"] and errors:  # nothing could be read: an input error, as for run
        # (said as run says it: the reasons alone, each ending "skipped", read as warnings)
        # (each reason names its file: the inputs are not listed again before them)
        n = len(doc["inputs"])
        raise ReaderError(
            f"no channel could be read from {'the input' if n == 1 else f'any of {n} inputs'}: "
            + capped(errors, 3, "; ", "input errors")
        )
    _emit(json.dumps(doc, indent=2) if args.json else render_table(doc))
    if not doc["channels"]:  # read, and nothing numeric: listed (exit 0), and said
        _warn(doc["notes"][-1])
    return 0


def _stdout_open() -> None:
    """An :class:`OSError` naming stdout where the process has none (started with it
    closed): the command's result could not be printed anywhere."""
    if sys.stdout is None:
        raise OSError(errno.EBADF, "closed, so the result cannot be printed", "stdout")


def _emit(text: str) -> None:
    """``text`` and a newline on stdout, flushed here: a stdout that cannot take it
    (``> FILE`` on a full disk, ``> /dev/full``) is an error line naming stdout, not a
    bare ``No space left on device`` naming nothing (a closed pipe stays the
    BrokenPipeError that :func:`main` ends quietly on). A process started with stdout
    closed (``>&-``, a service without one) has none (``sys.stdout`` is None, and
    ``print`` writes nothing without a word): an error line too, where it was an
    "internal error" (a QA audit's ux59 item H2)."""
    _stdout_open()
    try:
        print(text)
        sys.stdout.flush()
    except BrokenPipeError:
        raise
    except OSError as err:
        raise OSError(err.errno, err.strerror, "stdout") from err


def cmd_export(args: argparse.Namespace) -> int:
    from analyzer.export import export_archive
    from analyzer.readers import parse_renames

    rename = parse_renames(args.rename or ())  # (before reading: a typo costs no wait)
    export_archive(
        args.inputs,
        Path(args.out),
        channels=args.channels,
        rate=args.rate,
        time=args.time,
        warn=_warn,
        utc=args.utc,
        say=_say,
        missing_values=args.missing_values,
        rename=rename,
    )
    return 0


def _run_options(args: argparse.Namespace) -> Any:
    from analyzer.options import load_options

    return load_options(
        args.config,
        channels=args.channels,
        train=args.train,
        detectors=args.detectors,
        rate=args.rate,
        jobs=args.jobs,
        scheduler=args.scheduler,
        time_source=args.time,
        corrected=args.corrected,
        progress=_progress_printer(args),
        warn=_warn,
        model=args.model,
        save_model=getattr(args, "save_model", None),
        screen=args.screen,
        say=_say if getattr(args, "command", None) == "run" else None,
        note=_note if getattr(args, "command", None) == "run" else None,
        utc=getattr(args, "utc", False),
        missing_values=getattr(args, "missing_values", ()),
        rename=getattr(args, "rename", None) or (),
    )


def cmd_run(args: argparse.Namespace) -> int:
    """From the real entry point, the report's figures are drawn by worker processes
    whose server starts first and imports matplotlib while this process imports the
    pipeline (a second of start-up on one core: the other is idle), see
    :mod:`analyzer.report.workers`; called in-process (tests, embedding), they are
    drawn in-process, with the same result."""
    if not getattr(args, "figure_processes", False):
        from analyzer.pipeline import run

        return run(args.inputs, Path(args.out), _run_options(args))
    from analyzer.paging import tune_heap

    if not args.scheduler:  # (a cluster's client frees the blocks it sends: let them go)
        tune_heap()  # the process is the run's own: glibc may keep what it frees for reuse
    with contextlib.ExitStack() as stack:
        with _sigterm_after_imports():
            from analyzer.report.workers import figure_workers

            stack.enter_context(figure_workers())
            from analyzer.pipeline import run

            options = _run_options(args)
        return run(args.inputs, Path(args.out), options)
    raise AssertionError("unreachable")  # pragma: no cover - for mypy


@contextlib.contextmanager
def _sigterm_after_imports() -> Iterator[None]:
    """A SIGTERM during the block (the start-up imports) is acted on at its end: a
    KeyboardInterrupt raised inside an import can leave a module lock held (seen: a
    later import in a detector thread then deadlocks) or be swallowed by the imported
    code. The process still stops within the block's second, with exit code 130."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    seen: list[int] = []
    previous = {
        signum: signal.signal(signum, lambda signum, frame: seen.append(signum))
        for signum in STOPPING
        if signal.getsignal(signum) is not signal.SIG_IGN
    }
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    if seen:
        raise KeyboardInterrupt


def cmd_watch(args: argparse.Namespace) -> int:
    try:
        from analyzer.watch import watch_main
    except ImportError as err:  # pragma: no cover - until the watcher lands
        raise UsageError(f"watch: not available in this build ({err})") from err
    return int(watch_main(args, _run_options(args)))


COMMANDS = {"inspect": cmd_inspect, "export": cmd_export, "run": cmd_run, "watch": cmd_watch}


def _terminate(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt  # unwinds like Ctrl-C: scratch files and partial outputs go


STOPPING = (signal.SIGTERM, signal.SIGHUP)
"""The signals that stop ``run``, ``inspect`` and ``export`` as Ctrl-C does (exit 130,
"interrupted", scratch space and partial outputs removed): SIGTERM (a timeout, ``kill``)
and SIGHUP (the terminal closed, an ssh session dropped). A SIGHUP ended ``run`` with 129,
nothing said, its scratch folder and an empty new ``--out`` left (ux66 L1)."""


def _stop_on_signals() -> dict[int, Any]:
    """:func:`_terminate` as the handler of :data:`STOPPING`, and the handlers it
    replaced. A signal ignored when the command started stays ignored: ``nohup`` ignores
    SIGHUP so that the run goes on after its terminal is closed."""
    return {
        signum: signal.signal(signum, _terminate)
        for signum in STOPPING
        if signal.getsignal(signum) is not signal.SIG_IGN
    }


def _naming_inputs(message: str, inputs: Sequence[str]) -> str:
    """``message`` prefixed with the inputs it is about, unless it names an input or an
    option already (the contract: an error names the file or the option)."""
    head = message.split(":", 1)[0].strip()
    if not inputs or head.startswith(("--", "[")) or (head and os.path.exists(head)):
        return message  # an option, a config section, or a file (the config) first
    for i in inputs:
        if i in message or Path(i).name in message:
            return message
    return f"{capped(list(inputs), what='inputs')}: {message}"


def _named_end(line: str, inputs: Sequence[str]) -> int:
    """Where the first file or option ``line`` names ends (0: none): what
    :func:`~analyzer.errors.clipped_line` keeps whole, however long the path."""
    head = line.split(":", 1)[0].strip()
    if head.startswith(("--", "[")) or (head and os.path.exists(head)):
        return line.index(head) + len(head)
    ends = [
        at + len(name)
        for i in inputs
        for name in (i, Path(i).name)
        if name and (at := line.find(name)) >= 0
    ]
    return min(ends, default=0)


def _cut(line: str, args: argparse.Namespace | None, inputs: Sequence[str]) -> str:
    """``line`` cut to :data:`~analyzer.errors.LINE_MOST` characters after the inputs it
    names (one readable line), ended with the path of the file that keeps it whole
    (:mod:`analyzer.error_file`): ``run``'s ``--out DIR/error.txt``, ``export``'s
    ``FILE.error.txt``, else a file in TMPDIR. A line about ``--out`` itself (a folder
    that cannot be made) is kept in TMPDIR too."""
    keep = _named_end(line, inputs)
    cut = clipped_line(line, keep=keep)
    if cut == line:
        return line
    command = getattr(args, "command", None) or "command"
    out = None if line.startswith("--out") else getattr(args, "out", None)
    where = keep_whole(line, command, error_place(command, out), inputs)
    return cut if where is None else clipped_line(line, keep=keep, where=where)


def _raised_here(err: BaseException) -> bool:
    """Whether ``err`` was raised in the analyzer's own code (a ``print`` to stdout is
    C, so its innermost Python frame is the analyzer's caller), not in a library's pipe
    (multiprocessing's connection to a worker, say)."""
    tb = err.__traceback__
    last = None
    while tb is not None:
        last = tb.tb_frame.f_code.co_filename
        tb = tb.tb_next
    return last is not None and Path(last).resolve().is_relative_to(Path(__file__).parent)


def _stdout_gone() -> bool:
    """Whether stdout is a pipe whose reader has closed it (poll reports an error on
    its write end)."""
    try:
        poller = select.poll()
        poller.register(sys.stdout.fileno(), select.POLLOUT)
        return any(ev & (select.POLLERR | select.POLLHUP) for _, ev in poller.poll(0))
    except (OSError, ValueError, AttributeError):
        return False


def _earlier(args: argparse.Namespace | None, started: float) -> str:
    """For a ``run`` that failed: the end of its error line when ``--out`` holds an
    earlier run's outputs, which a failed run leaves as they were (the folder may be the
    user's; nothing in it is deleted), so that a script reading ``findings.json`` after
    the exit code 2 is told it is not this run's."""
    if args is None or getattr(args, "command", None) != "run" or not args.out:
        return ""
    out = Path(args.out)
    names = ("findings.json", "report.html", "corrected.csv")
    earlier = [n for n in names if _older(out / n, started)]
    if not earlier:
        return ""
    listed = ", ".join(earlier[:-1]) + " and " + earlier[-1] if len(earlier) > 1 else earlier[0]
    return f" ({out} keeps an earlier run's {listed}, not this run's)"


def _older(path: Path, started: float) -> bool:
    """Whether ``path`` exists and was last written before ``started``."""
    try:
        return path.stat().st_mtime < started
    except OSError:
        return False


def _error(message: str) -> int:
    print(f"analyzer: error: {terminal_safe(one_line(message))}", file=sys.stderr)
    return 2


_UNWOUND = False
"""Set when :func:`main` stopped a command other than ``watch`` on an interrupt."""

_ONE_SHOT = False
"""Set when :func:`main` ran a command other than ``watch`` (its work is done on return)."""


def entry() -> NoReturn:
    """The console script and ``python -m analyzer``: :func:`main`'s return value as the
    exit status. After an interrupt of ``run``, ``inspect`` or ``export`` (status 130) the
    process ends as soon as its output is flushed: the unwinding has already removed its
    scratch space and partial outputs, and the interpreter's own shutdown would wait for
    pool threads still inside a compiled kernel; once in CI it even ended the process by
    SIGINT instead of status 130.

    After any other end of those commands the process ends once its output is flushed
    and the ``atexit`` handlers have run (multiprocessing's clean-up, finalizers of
    temporary files): every file is written and closed by then, and the interpreter's
    teardown of the modules a run imports (scipy, numba, pyarrow...) only took time,
    0.3-0.4 s of every run. The watcher, whose worker processes need their normal
    shutdown, exits as usual."""
    end(main(figure_processes=True))


def end(code: int) -> NoReturn:
    """End the process after :func:`main` returned ``code``, as :func:`entry` does."""
    if code == 130 and _UNWOUND:
        _flush_std()
        _multiprocessing_exit()
        os._exit(130)
    if _ONE_SHOT:
        _flush_std()
        atexit._run_exitfuncs()
        _flush_std()
        os._exit(code)
    sys.exit(code)


def _flush_std() -> None:
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError, AttributeError):  # closed: nothing
            stream.flush()


def _multiprocessing_exit() -> None:
    """What multiprocessing does at a normal exit and ``os._exit`` skips: remove its
    temporary folder in TMPDIR (the figure workers' server had its socket there) and
    release its semaphores (else its resource tracker reports them as leaked). Its
    worker processes are gone by now (the unwinding stopped them)."""
    util = sys.modules.get("multiprocessing.util")
    exit_function = getattr(util, "_exit_function", None)
    if exit_function is not None:
        with contextlib.suppress(Exception):
            exit_function()


def _use_msg_path(option: str | None) -> None:
    """``--msg-path`` into the environment (the readers, and the watcher's analyses, read
    it there), and the path checked before any reading: a missing directory or an
    unparsable ``.msg`` is a usage error naming the option (or the variable)."""
    if option is not None:
        os.environ[MSG_PATH_ENV] = option
    spec = os.environ.get(MSG_PATH_ENV, "")
    if not spec:
        return
    from analyzer.readers.rostypes import MessagePathError, user_store

    user_store.cache_clear()  # read when the command starts (a test may run several)
    try:
        user_store(spec)
    except MessagePathError as err:
        raise UsageError(f"{'--msg-path' if option is not None else MSG_PATH_ENV}: {err}") from None


def _cluster_failure(err: BaseException, args: argparse.Namespace | None) -> str | None:
    """One line naming ``--scheduler`` for an error of the Dask cluster itself (a
    connection closed, a task the scheduler cancelled, a worker's stream gone) that the
    executor could not work around; None for anything else. A task's own exception keeps
    its type, which is never one of Dask's (nor tornado's, whose streams Dask uses)."""
    address = getattr(args, "scheduler", None)
    module = type(err).__module__ or ""
    if not address or not module.startswith(("distributed.", "tornado.")):
        return None
    text = " ".join(str(err).split())[:200]
    return (
        f"--scheduler {address}: the cluster failed during the run "
        f"({type(err).__name__}{': ' + text if text else ''})"
    )


def main(argv: Sequence[str] | None = None, *, figure_processes: bool = False) -> int:
    """``analyzer ARGV``: the exit code. ``figure_processes`` (the real entry point only)
    lets ``run`` draw the report's figures in worker processes of its own. stderr may be
    lost (closed, a pipe whose reader has gone, a full non-blocking pipe): what would
    have been said is dropped, and the files and the exit code are the same
    (:mod:`analyzer.lossy_stderr`)."""
    with lossy_stderr():
        return _main(argv, figure_processes=figure_processes)


def _main(argv: Sequence[str] | None, *, figure_processes: bool) -> int:
    """:func:`main`, with stderr that cannot fail."""
    args = None
    previous: dict[int, Any] = {}
    started = time.time()
    try:
        parsed, extra = build_parser().parse_known_args(argv)
        if extra:  # named by the command they were given to, not the top parser
            given = list(argv if argv is not None else sys.argv[1:])
            after = getattr(parsed, "command", None) in given and given.index(
                parsed.command
            ) < given.index(extra[0])
            command = f"{parsed.command}: " if after else ""
            raise UsageError(f"{command}unrecognized arguments: {' '.join(extra)}")
        args = parsed
        args.figure_processes = figure_processes
        global _ONE_SHOT
        _ONE_SHOT = args.command != "watch"
        if args.command != "watch" and threading.current_thread() is threading.main_thread():
            # SIGTERM (timeout, kill) unwinds as Ctrl-C does, so nothing is left behind;
            # the watcher handles its own signals. Set as soon as the command is known:
            # before, a SIGTERM while the stale scratch folders were swept ended the
            # process by the signal (143, nothing said; ux59 item L1). One while Python
            # itself starts still does: no handler can be set before (README).
            previous = _stop_on_signals()
        # what runs killed outright (kill -9, the OOM killer) left in TMPDIR: their
        # scratch directories, gigabytes for a long archive (see analyzer.scratch)
        sweep_stale()
        # (an earlier run's or export's error file there would contradict this one's end)
        remove_stale(error_place(args.command, getattr(args, "out", None)))
        _use_msg_path(getattr(args, "msg_path", None))
        with warnings.catch_warnings():
            # numerical warnings on degenerate stretches (all-NaN windows...) are handled
            # by the code that meets them; stderr carries only the one-line verdicts
            warnings.simplefilter("ignore", RuntimeWarning)
            return COMMANDS[args.command](args)
    except AnalyzerError as err:
        inputs = [str(i) for i in getattr(args, "inputs", None) or []]
        line = _naming_inputs(one_line(str(err)), inputs)
        return _error(_cut(line, args, inputs) + _earlier(args, started))
    except KeyboardInterrupt:
        print(terminal_safe(f"analyzer: interrupted{_earlier(args, started)}"), file=sys.stderr)
        global _UNWOUND
        _UNWOUND = args is not None and args.command != "watch"
        return 130
    except BrokenPipeError as err:
        if not (_stdout_gone() and _raised_here(err)):  # another pipe's (a worker's)
            return _error(f"internal error: BrokenPipeError: {err} (please report it)")
        # stdout closed by its reader (``analyzer inspect X | head``): nothing more to
        # say, and nothing to say it to; the status a process killed by SIGPIPE gives
        with contextlib.suppress(OSError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 128 + signal.SIGPIPE
    except OSError as err:  # the file system refused (disk full, permissions...)
        lost = _cluster_failure(err, args)  # (or the cluster's connection closed)
        if lost is not None:
            return _error(lost + _earlier(args, started))
        where = f"{err.filename}: " if getattr(err, "filename", None) else ""
        if err.errno == errno.ENOMEM and not isinstance(err, MachineLimit):
            # (mapping a scratch file beyond ``ulimit -v``: "Cannot allocate memory")
            return _error(out_of_memory_line() + _earlier(args, started))
        return _error(f"{where}{err.strerror or err}{_earlier(args, started)}")
    except MemoryError:
        return _error(out_of_memory_line() + _earlier(args, started))
    except Exception as err:  # a bug: still one line and exit 2, never 1 ("fault found")
        lost = _cluster_failure(err, args)
        if lost is not None:
            return _error(lost + _earlier(args, started))
        if os.environ.get("ANALYZER_DEBUG"):
            traceback.print_exc()  # the traceback, and still exit 2 (raising gave 1)
        return _error(
            f"internal error: {type(err).__name__}: {err} (please report it; set "
            f"ANALYZER_DEBUG=1 for the traceback){_earlier(args, started)}"
        )
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
