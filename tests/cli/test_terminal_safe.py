"""Lines on stderr hold no control or format characters of a name: a file, channel or
topic name may hold an escape sequence, a right-to-left override or a newline (an
audit's CSV header ``nul\\x01x`` reached the terminal as it was), which would recolour the
terminal, reverse the line, or split a one-line message in two."""

from __future__ import annotations

import logging

from cli_helpers import one_line_error, run_cli

from analyzer.cli import _warn
from analyzer.errors import terminal_safe
from analyzer.watch import _StderrFormatter


def test_control_and_format_characters_are_escaped_and_the_rest_kept():
    assert terminal_safe("plain /s0.data [3] é ✓") == "plain /s0.data [3] é ✓"
    assert terminal_safe("nul\x01x") == "nul\\x01x"
    assert terminal_safe("\x1b[31mred") == "\\x1b[31mred"
    assert terminal_safe("a\u202eb") == "a\\u202eb"
    assert terminal_safe("two\nlines\r") == "two\\x0alines\\x0d"


def test_the_error_line_escapes_the_file_name(tmp_path, capsys):
    name = tmp_path / "gone\x1b[2J\u202e.csv"
    code, _, err = run_cli(["run", name, "--out", tmp_path / "o"], capsys)
    assert code == 2
    one_line_error(err, "gone\\x1b[2J\\u202e.csv")
    assert "\x1b" not in err and "\u202e" not in err


def test_warnings_escape_too(capsys):
    _warn("x.csv: channel 'nul\x01x' is empty")
    err = capsys.readouterr().err
    assert err == "analyzer: warning: x.csv: channel 'nul\\x01x' is empty\n"


def test_the_watchers_log_lines_stay_one_line():
    record = logging.LogRecord(
        "analyzer.watch", logging.INFO, __file__, 1, "analyzing %s", ("in\nbox\x07.mcap",), None
    )
    line = _StderrFormatter("%(message)s").format(record)
    assert line == "analyzing in\\x0abox\\x07.mcap"


def test_inspect_escapes_the_names_in_its_table(tmp_path, capsys):
    """``inspect``'s table (a README audit: its file and channel names reached the
    terminal as they were; ``--json`` escapes them as JSON does)."""
    path = tmp_path / "odd\x1b[31m.csv"
    rows = "".join(f"{k * 0.01:.2f},{k},{2 * k}\n" for k in range(50))
    path.write_text("time,nul\x01x,rtl\u202eevil\n" + rows)
    code, out, _ = run_cli(["inspect", path], capsys)
    assert code == 0
    assert "odd\\x1b[31m.csv" in out and "nul\\x01x" in out and "rtl\\u202eevil" in out
    assert "\x1b" not in out and "\x01" not in out and "\u202e" not in out
