"""``detect``'s progress is one stage whose share never goes back, advanced inside each
detector's fit and run by its own steps (time blocks, filters, observers: one call per
item, none per sample) and naming the detector and step as the stage's detail. Before,
the bank's steps were stages of their own (``detect 33%`` then ``ar_kalman_bank 6%``)
and the detection filter's and the equivalent model's fits and runs were one silent
step each: a day's run said nothing for 45-51 s (the ux55 audit, item 8)."""

from __future__ import annotations

import io
from pathlib import Path

import pytest

from analyzer.options import RunOptions
from analyzer.pipeline import analyze

SAMPLE = Path(__file__).resolve().parents[1] / "samples" / "building_additive.mcap"


def _calls(jobs: int) -> list[tuple[str, str, float]]:
    seen: list[tuple[str, str, float]] = []

    def progress(stage: str, share: float) -> None:
        seen.append((str(stage), getattr(stage, "detail", ""), share))  # (Stage's detail)

    analyze([SAMPLE], RunOptions(jobs=jobs, progress=progress))
    return seen


@pytest.mark.parametrize("jobs", [1, 2])
def test_detect_is_one_rising_stage_with_each_detectors_steps_in_its_detail(jobs):
    seen = _calls(jobs)
    stages = [s for s, _, _ in seen]
    first, last = stages.index("detect"), len(stages) - 1 - stages[::-1].index("detect")
    # between detect's first and last call no other stage (a detector's own) is named
    assert set(stages[first : last + 1]) == {"detect"}, sorted(set(stages[first:last]))
    assert stages.index("tests") > last
    shares = [f for s, _, f in seen if s == "detect"]
    assert all(b >= a for a, b in zip(shares, shares[1:], strict=False)), shares
    assert shares[-1] == 1.0
    details = [d for s, d, _ in seen if s == "detect"]
    assert all(details), "every detect call names its detector and step"
    # each detector's fit and run advance detect by steps of their own, counted by item
    for name in ("ar_kalman_bank", "detection_filter", "equivalent_model"):
        for phase in ("fit", "run"):
            steps = [d for d in details if d.startswith(f"{name} {phase}: ") and "done" not in d]
            assert len(steps) >= 2, (name, phase, details)
    observers = [d for d in details if d.startswith("equivalent_model run: observers run ")]
    counts = [d.rsplit(" ", 1)[1] for d in observers]  # "k/n", k rising to n
    n = counts[-1].split("/")[1]
    assert counts[-1] == f"{n}/{n}" and len(counts) == int(n)
    # the detection filter's pass over the whole record: a few steps, never per sample
    record = [d for d in details if d.startswith("detection_filter run: whole record")]
    assert 2 <= len(record) <= 99
    # the bank's steps after its pass: the alarm search by channel, and a fault's
    # stretch filtered again piece by piece once corrected (a day's run: a silent minute)
    assert any(d.startswith("ar_kalman_bank run: channels searched for alarms ") for d in details)
    assert any(
        d.startswith("ar_kalman_bank run: fault 1 corrected and filtered again: ") for d in details
    )
    # the share reaches each detector's fit and run ends: 2 of 2 x detectors
    assert shares.count(1.0) >= 1 and max(shares[:-1]) <= 1.0


def test_a_detectors_steps_keep_the_again_prefix_and_their_detail():
    """A prefixed stage (``again detect``) keeps the part under way."""
    from analyzer.types import Stage, prefixed, stage_detail

    shown = prefixed("again ", Stage("detect", "detection_filter run: whole record 40%"))
    assert shown == "again detect"
    assert stage_detail(shown) == "detection_filter run: whole record 40%"
    assert stage_detail(prefixed("again ", "detect")) == ""


def test_plain_progress_says_the_step_under_way_and_adds_no_line_for_it():
    """The step inside a stage is said in the line's parentheses; a new step of the same
    stage within 5 s of the clock adds no line (counted with a fake clock)."""
    from analyzer.cli import plain_progress

    class Stage(str):  # (analyzer.types.Stage: a name with the part under way)
        def __new__(cls, name: str, detail: str) -> Stage:
            stage = super().__new__(cls, name)
            stage.detail = detail
            return stage

    now = [0.0]
    out = io.StringIO()
    show = plain_progress(out, lambda: now[0], every_s=5.0)
    for k in range(100):
        now[0] = k * 0.1
        show(Stage("detect", f"detection_filter run: time blocks {k + 1}/100"), k / 100)
    show("tests", 0.5)
    assert out.getvalue().splitlines() == [
        "analyzer: progress: detect 0% (detection_filter run: time blocks 1/100; 0.0 s)",
        "analyzer: progress: detect 50% (detection_filter run: time blocks 51/100; 5.0 s)",
        "analyzer: progress: tests 50% (9.9 s)",
    ]


GROUPS = """\
[[group]]
name = "low"
channels = ["/s0.data", "/s1.data", "/s2.data"]

[[group]]
name = "high"
channels = ["/s3.data", "/s4.data"]
"""


def test_channel_groups_are_parts_of_one_rising_detect_stage(tmp_path: Path) -> None:
    """With channel groups each group was a stage of its own (``detect group 0``,
    ``detect group 1``, ...), each first said at its own early share: a 500-channel run
    showed ``detect group N 17%`` for 55 s and never said how many groups there were
    (the ux56 audit, item 5). Now one ``detect`` stage whose share only rises, each
    group named with its number of all in the step under way."""
    from analyzer.config import load_config

    cfg = tmp_path / "groups.toml"
    cfg.write_text(GROUPS)
    seen: list[tuple[str, str, float]] = []

    def progress(stage: str, share: float) -> None:
        seen.append((str(stage), getattr(stage, "detail", ""), share))

    analyze([SAMPLE], RunOptions(jobs=1, progress=progress, config=load_config(cfg)))
    stages = {s for s, _, _ in seen}
    assert not any(s.startswith("detect group") for s in stages), stages
    shares = [f for s, _, f in seen if s == "detect"]
    assert all(b >= a for a, b in zip(shares, shares[1:], strict=False)), shares
    assert shares[-1] == 1.0
    details = [d for s, d, _ in seen if s == "detect"]
    assert any(d.startswith("group 1/2 (/s0.data../s2.data): ") for d in details), details
    assert any(d.startswith("group 2/2 (/s3.data../s4.data): ") for d in details), details
