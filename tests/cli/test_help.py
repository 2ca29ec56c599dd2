"""``--help`` says what a command does, what it writes and its exit codes before its
options, and ends with examples (a new user's audit: ``analyzer run --help`` began with
the usage and went straight to the options). The examples are real: each parses with the
command's own parser, and the files they name are the checkout's samples."""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest

from analyzer.cli import build_parser, main

REPO = Path(__file__).resolve().parents[2]
COMMANDS = ("inspect", "export", "run", "watch")
WRITES = {
    "inspect": "writes nothing",
    "export": "to FILE (.csv or .parquet)",
    "run": "Writes DIR/report.html and DIR/findings.json",
    "watch": "REPORTS gets a folder per archive",
}
"""What each command's description says it writes."""


def _help(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 0
    out, err = capsys.readouterr()
    assert err == ""
    return out


def _examples(text: str) -> list[list[str]]:
    """The command lines under the help's ``example(s):`` heading, as words."""
    lines = text.split("\nexample", 1)[1].split("\n\n", 1)[0].splitlines()[1:]
    return [shlex.split(line) for line in lines if line.strip().startswith("analyzer ")]


@pytest.mark.parametrize("command", COMMANDS)
def test_each_command_is_described_before_its_options(command, capsys):
    text = _help([command, "--help"], capsys)
    intro = text.split("\npositional arguments:", 1)[0]
    description = " ".join(intro.split("\n\n", 1)[1].split())  # (after the usage)
    assert len(description.split()) > 25
    assert "exit codes: 0 " in description and " 2 usage" in description
    assert WRITES[command] in description
    # the options are listed as they were, the examples after them
    assert text.index("options:") < text.index("\nexamples:\n")
    assert "-h, --help" in text


@pytest.mark.parametrize("command", COMMANDS)
def test_the_examples_parse_with_the_commands_options(command, capsys):
    text = _help([command, "--help"], capsys)
    examples = _examples(text)
    assert 2 <= len(examples) <= 3
    parser = build_parser()
    for words in examples:
        assert words[:2] == ["analyzer", command]
        args, extra = parser.parse_known_args(words[1:])
        assert extra == [] and args.command == command, words
        for word in words:
            if word.startswith("samples/"):  # (run from the checkout's folder)
                assert (REPO / word).exists(), word


def test_the_top_help_has_an_example_and_the_exit_codes(capsys):
    text = _help(["--help"], capsys)
    words = " ".join(text.split())
    assert "exit codes: 0 " in words and "1 at least one sensor fault" in words
    assert "130 interrupted" in words
    (example,) = _examples(text)
    args, extra = build_parser().parse_known_args(example[1:])
    assert extra == [] and args.command == "run"
    assert (REPO / args.inputs[0]).exists()


def test_the_watch_examples_run_as_written_after_the_setup_they_give(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``watch --help``'s examples stopped at "INBOX: .../inbox is not a directory" run
    as written from the checkout (a new user's audit, ux53 item 5): the help now gives the
    command that makes INBOX (with a sample in it), and its ``--once`` example then runs
    (here in a folder whose ``samples`` is the checkout's)."""
    import subprocess

    text = _help(["watch", "--help"], capsys)
    (setup,) = [ln.strip() for ln in text.splitlines() if ln.strip().startswith("mkdir ")]
    (once,) = [words for words in _examples(text) if "--once" in words]
    (tmp_path / "samples").symlink_to(REPO / "samples")
    monkeypatch.chdir(tmp_path)
    subprocess.run(["sh", "-c", setup], check=True)
    assert main(once[1:]) == 1  # (the sample's fault)
    capsys.readouterr()
    assert not any((tmp_path / "inbox").iterdir())
    assert [p.name for p in (tmp_path / "analyzed").iterdir()] == ["building_additive.mcap"]
    assert (tmp_path / "reports" / "index.html").is_file()


def test_the_jobs_help_is_each_commands_own(capsys: pytest.CaptureFixture[str]) -> None:
    """``watch --help`` described ``--jobs`` as ``run``'s threads of detectors (ux53
    item 11): watch's says archives at once, and that ``--scheduler`` leaves it unused."""
    watch_help = " ".join(_help(["watch", "--help"], capsys).split())
    run_help = " ".join(_help(["run", "--help"], capsys).split())
    assert "analyze up to N archives at once" in watch_help
    assert "not used with --scheduler" in watch_help
    assert "run the detectors (and the bank's time blocks) on N threads" in run_help
    assert "run the detectors (and the bank's time blocks)" not in watch_help


def test_corrected_says_its_file_is_at_the_rate_analyzed(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # a record the run analyzes slower than it was logged at gives corrected.csv at the
    # slower rate: the option's help says so (the review of rate54's M2)
    text = " ".join(_help(["run", "--help"], capsys).split())
    assert "corrected over their fault periods, at the rate analyzed" in text
