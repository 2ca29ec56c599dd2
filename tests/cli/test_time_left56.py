"""``run``'s estimate of the time left (ux62 LOW 7): nothing until read has ended and
a tenth of the work after it is done, then the rest at the rate since, smoothed, never
below 0, rounded as an estimate; the plain ``--progress`` lines carry it past read.
(Imported inside the tests: the CLI test runs, and fails, on a base without it.)"""

from __future__ import annotations

import io
from pathlib import Path

from cli_helpers import run_cli

SAMPLES = Path(__file__).resolve().parents[2] / "samples"


def _run(events):
    """Each (time, stage, fraction) given to a TimeLeft on a fake clock: its answers."""
    from analyzer.time_left import TimeLeft

    now = [0.0]
    estimate = TimeLeft(lambda: now[0])
    answers = []
    for t, stage, fraction in events:
        now[0] = t
        answers.append(estimate.update(stage, fraction))
    return answers


def _steady(seconds_per_weight: float, steps: int = 20):
    """A run whose every stage takes its table weight times ``seconds_per_weight``,
    each said in ``steps`` even steps: (time, stage, fraction) events."""
    from analyzer.time_left import STAGE_WEIGHTS

    events, t = [], 0.0
    for stage, weight in STAGE_WEIGHTS.items():
        for k in range(steps + 1):
            events.append((t + weight * seconds_per_weight * k / steps, stage, k / steps))
        t += weight * seconds_per_weight
    return events, t


def test_no_estimate_while_reading_nor_on_too_little_after_it():
    """Reading (at any share) and the alignment alone give no estimate: no wild number
    at 1 %."""
    events, _ = _steady(10.0)
    answers = _run(events)
    stages = [stage for _, stage, _ in events]
    for stage, answer in zip(stages, answers, strict=True):
        if stage in ("read", "align"):
            assert answer is None, stage
    assert answers[-1] is not None


def test_a_steady_run_is_estimated_right_and_ends_at_zero():
    """At the rate the table expects, the estimate at a quarter, half and three quarters
    of detect is within 15 % of the true time left (smoothing lags a little), and the
    last answer is 0."""
    events, end = _steady(10.0)
    answers = _run(events)
    for (t, stage, fraction), answer in zip(events, answers, strict=True):
        if stage == "detect" and fraction in (0.25, 0.5, 0.75):
            assert answer is not None
            assert abs(answer - (end - t)) <= 0.15 * (end - t), (fraction, answer, end - t)
    assert answers[-1] == 0.0


def test_a_slower_detect_raises_the_estimate_smoothly_and_it_counts_down_between_steps():
    """A detect three times slower than the table: the estimate grows toward the true
    time left, never by more than the smoothing allows in one step; between two steps
    far apart it counts down by the time passed, never below 0."""
    events = [(0.0, "read", 0.0), (15.0, "read", 1.0), (15.0, "align", 0.0), (17.0, "align", 1.0)]
    for k in range(1, 41):  # detect: 6.6 weight at 30 s per weight, in 40 steps
        events.append((17.0 + 198.0 * k / 40, "detect", k / 40))
    answers = _run(events)
    said = [(t, a) for (t, _, _), a in zip(events, answers, strict=True) if a is not None]
    assert said, answers
    for (t0, a0), (t1, a1) in zip(said, said[1:], strict=False):
        assert a1 >= 0.0
        assert abs(a1 - a0) <= 0.5 * max(a0, 1.0) + (t1 - t0), (t0, a0, t1, a1)
    from analyzer.time_left import TimeLeft

    now = [0.0]
    estimate = TimeLeft(lambda: now[0])
    for t, stage, fraction in events[:30]:
        now[0] = t
        before = estimate.update(stage, fraction)
    assert before is not None
    now[0] += 1e6  # (a step far later, with no new progress: a restart of the same share)
    assert estimate.update(*events[29][1:]) >= 0.0


def test_again_detect_adds_a_detect_to_the_work():
    """A second search (``again detect``) begun after the five stages' work adds its own
    share: the estimate is not 0 while it runs."""
    events, end = _steady(10.0)
    events = [e for e in events if e[1] != "report"]
    events += [(end + 10.0 * k, "again detect", k / 10) for k in range(1, 6)]
    answers = _run(events)
    assert answers[-1] is not None and answers[-1] > 0.0


def test_left_text_rounds_as_an_estimate():
    from analyzer.time_left import left_text

    assert left_text(-5.0) == "less than a minute left"
    assert left_text(59.0) == "less than a minute left"
    assert left_text(178.0) == "about 3 min left"
    assert left_text(89 * 60.0) == "about 89 min left"
    assert left_text(2.5 * 3600) == "about 2.5 h left"
    assert left_text(13.19 * 3600) == "about 13 h left"  # (two digits, not 13.2)
    assert left_text(9.97 * 3600) == "about 10 h left"  # (not 10.0)
    assert left_text(3.2 * 86400) == "about 3.2 days left"
    assert left_text(12.4 * 86400) == "about 12 days left"


def test_watch_once_words_the_time_left_as_run_does(monkeypatch):
    """``watch --once``'s ``[done/total, ...]`` says the time left in ``run``'s words
    (:func:`~analyzer.time_left.left_text`): it said 20 s as ``about 20 s left`` and
    0.5 s as ``under 1 s left`` where run's progress said ``less than a minute left``."""
    from types import SimpleNamespace

    from analyzer import watch as watch_module
    from analyzer.time_left import left_text

    monkeypatch.setattr(watch_module.time, "monotonic", lambda: 1000.0)
    # one of two analyzed, begun `took` seconds ago: the other takes as long
    for took in (0.5, 20.0, 59.0, 178.0, 13.19 * 3600, 3.2 * 86400):
        state = SimpleNamespace(
            expected=frozenset("ab"), results=range(1), skipped=set(), begun=1000.0 - took
        )
        said = watch_module._Runner.progress(state)
        assert said == f" [1/2, {left_text(took)}]", (took, said)
    state = SimpleNamespace(expected=frozenset("ab"), results=range(1), skipped=set(), begun=980.0)
    assert watch_module._Runner.progress(state) == " [1/2, less than a minute left]"


def test_plain_progress_lines_say_the_time_left_once_past_read():
    """With a fake clock: lines while reading say no time left; past read (once a
    tenth of the work after it is done) they end ``; about N min left)``."""
    from analyzer.cli import plain_progress

    now = [0.0]
    out = io.StringIO()
    show = plain_progress(out, lambda: now[0], every_s=5.0)
    events, _ = _steady(60.0)
    for t, stage, fraction in events:
        now[0] = t
        show(stage, fraction)
    lines = out.getvalue().splitlines()
    read = [ln for ln in lines if ln.startswith("analyzer: progress: read ")]
    assert read and not any("left" in ln for ln in read)
    half = [ln for ln in lines if ln.startswith("analyzer: progress: detect 50% (")]
    # (at half of detect, 198 s of detect and 42 s after it are left: about 4 min)
    assert half == ["analyzer: progress: detect 50% (300.0 s; about 4 min left)"], lines


def test_run_progress_lines_say_the_time_left_past_read(tmp_path, capsys):
    """``run --progress`` on a sample: no line of read says a time left; the lines of
    tests and report (past a tenth of the work after read) do; ``--no-progress``
    says none."""
    argv = ["run", SAMPLES / "building_additive.mcap", "--out", tmp_path / "a", "--progress"]
    code, _, err = run_cli(argv, capsys)
    assert code == 1
    lines = [ln.removeprefix("analyzer: progress: ") for ln in err.splitlines()]
    assert not any("left" in ln for ln in lines if ln.startswith("read "))
    past = [ln for ln in lines if ln.split(" ")[0] in ("tests", "report")]
    assert past and all(ln.endswith(" left)") for ln in past), err
    code, _, err = run_cli(
        ["run", SAMPLES / "building_additive.mcap", "--out", tmp_path / "b", "--no-progress"],
        capsys,
    )
    assert code == 1 and " left" not in err


def test_progress_bar_says_the_time_left_past_read(tmp_path, monkeypatch, capsys):
    """On a terminal the bar of a stage past read says the time left before its
    seconds, and the line a stage ends with does not (it keeps ``100.0% ... T s``)."""
    import sys

    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    argv = ["run", SAMPLES / "building_additive.mcap", "--out", tmp_path / "a"]
    code, _, err = run_cli(argv, capsys)
    assert code == 1
    draws = [d for line in err.split("\n") for d in line.split("\r") if d.strip()]
    assert any(d.startswith("tests ") and " left " in d for d in draws), err
    assert not any(d.startswith("read ") and " left " in d for d in draws), err
    assert not any("100.0%" in d and " left " in d for d in draws), err
