"""``run --progress``: progress on a stderr that is not a terminal (a CI log), as plain
lines, few of them; ``--progress`` with ``--no-progress`` is a usage error."""

from __future__ import annotations

import io
from pathlib import Path

from cli_helpers import one_line_error, run_cli

SAMPLES = Path(__file__).resolve().parents[2] / "samples"


def test_progress_off_a_terminal_is_plain_lines_for_each_stage(tmp_path, capsys):
    """With ``--progress`` and a stderr that is no terminal (pytest's capture), each
    stage of the run gets a whole line, with no carriage return; the run's last line
    stays last. Without it, nothing (as before)."""
    argv = ["run", SAMPLES / "building_additive.mcap", "--out", tmp_path / "a", "--progress"]
    code, _, err = run_cli(argv, capsys)
    assert code == 1
    assert "\r" not in err
    lines = err.splitlines()
    assert lines[-1].startswith("analyzer: 1 sensor fault found"), err
    shown = [ln.removeprefix("analyzer: progress: ") for ln in lines if "progress:" in ln]
    assert all(ln.startswith("analyzer: progress: ") for ln in lines[:-1]), err
    first = []
    for line in shown:
        stage = line.split()[0]
        if stage not in first:
            first.append(stage)
    for stage in ("read", "align", "detect", "tests", "report"):
        assert stage in first, (stage, err)
    order = [first.index(s) for s in ("read", "align", "detect", "tests", "report")]
    assert order == sorted(order)
    code, _, err = run_cli(
        ["run", SAMPLES / "building_additive.mcap", "--out", tmp_path / "b"], capsys
    )
    assert code == 1 and "progress:" not in err


def test_plain_progress_writes_one_line_per_stage_and_few_within_one():
    """A thousand updates of one stage over 10 s of the clock make a line at its start
    and one 5 s later; stages that take turns (a detector's own inside ``detect``) add
    a line each the first time only, then share the 5 s."""
    from analyzer.cli import plain_progress

    now = [0.0]
    out = io.StringIO()
    show = plain_progress(out, lambda: now[0], every_s=5.0)
    for k in range(1000):
        now[0] = k * 0.01
        show("detect", k / 1000)
    for k in range(600):
        now[0] = 10.5 + k * 0.01
        show("detect" if k % 2 else "ar_kalman_bank", k / 600)
    lines = out.getvalue().splitlines()
    assert lines == [
        "analyzer: progress: detect 0% (0.0 s)",
        "analyzer: progress: detect 50% (5.0 s)",
        "analyzer: progress: ar_kalman_bank 0% (10.5 s)",
        "analyzer: progress: ar_kalman_bank 83% (15.5 s)",
    ]


def test_progress_and_no_progress_together_are_a_usage_error(tmp_path, capsys):
    argv = ["run", SAMPLES / "building_additive.mcap", "--out", tmp_path, "--progress"]
    code, _, err = run_cli([*argv, "--no-progress"], capsys)
    assert code == 2
    one_line_error(err, "--progress", "--no-progress")
    assert not (tmp_path / "findings.json").exists()
