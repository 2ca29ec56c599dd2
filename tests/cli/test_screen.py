"""``--screen NAME[,NAME...]``: the screening's detectors first, every detector only when
they find a fault (``analyze_screened``)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cli_helpers import one_line_error, run_cli

from analyzer import pipeline
from analyzer.pipeline import RunOptions
from analyzer.watch import analysis_into

SAMPLES = Path(__file__).resolve().parents[2] / "samples"
FAULTY = SAMPLES / "building_additive.mcap"
HEALTHY = SAMPLES / "building_healthy_ros2"


def _findings(out: Path) -> dict:
    return json.loads((out / "findings.json").read_text())


def test_a_screen_that_finds_a_fault_gives_the_full_analysis(tmp_path, capsys):
    """The screening's fault sends the archive through every detector: the faults are
    those of a run without ``--screen``, the detectors all three, and findings.json and
    a note say the screening found it."""
    code, _, _ = run_cli(["run", FAULTY, "--out", tmp_path / "plain", "--no-progress"], capsys)
    assert code == 1
    code, _, _ = run_cli(
        [
            *("run", FAULTY, "--out", tmp_path / "screened", "--no-progress"),
            *("--screen", "equivalent_model"),
        ],
        capsys,
    )
    assert code == 1
    plain, screened = _findings(tmp_path / "plain"), _findings(tmp_path / "screened")
    assert screened["faults"] == plain["faults"]
    assert [d["name"] for d in screened["detectors"]] == [d["name"] for d in plain["detectors"]]
    assert len(screened["detectors"]) == 3
    assert screened["screen"] == {"detectors": ["equivalent_model"], "fault": True}
    assert plain["screen"] is None
    assert any(n.startswith("screened with equivalent_model alone") for n in screened["notes"])


def test_a_screen_that_finds_nothing_is_the_analysis(tmp_path, capsys, monkeypatch):
    """No fault in the screening: one analysis, by its detectors alone (the others never
    run), exit 0, and findings.json says so."""
    runs: list[list[str] | None] = []
    real = pipeline.analyze

    def counted(inputs, options, workdir=None):
        runs.append(options.detectors)
        return real(inputs, options, workdir)

    monkeypatch.setattr(pipeline, "analyze", counted)
    code, _, _ = run_cli(
        ["run", HEALTHY, "--out", tmp_path, "--no-progress", "--screen", "equivalent_model"],
        capsys,
    )
    assert code == 0
    assert runs == [["equivalent_model"]]
    found = _findings(tmp_path)
    assert found["faults"] == []
    assert [d["name"] for d in found["detectors"]] == ["equivalent_model"]
    assert found["screen"] == {"detectors": ["equivalent_model"], "fault": False}
    assert any("the other detectors did not run" in n for n in found["notes"])
    assert "screened with equivalent_model alone" in (tmp_path / "report.html").read_text()


def test_the_watchers_analysis_is_screened_too(tmp_path):
    """Each archive of ``watch --screen`` goes through the same two steps."""
    out, work = tmp_path / "out", tmp_path / "work"
    out.mkdir()
    work.mkdir()
    options = RunOptions(screen=["equivalent_model"])
    assert analysis_into([str(HEALTHY)], options, out, work) == 0
    assert _findings(out)["screen"] == {"detectors": ["equivalent_model"], "fault": False}


@pytest.mark.parametrize(
    "extra, needle",
    [
        (["--screen", "nope"], "no such detector"),
        (["--screen", "equivalent_model", "--detectors", "ar_kalman_bank"], "not among"),
        (
            ["--screen", "equivalent_model,ar_kalman_bank"]
            + ["--detectors", "ar_kalman_bank,equivalent_model"],
            "every detector of the run",
        ),
        (["--screen", "equivalent_model", "--save-model", "{tmp}/m.model"], "--save-model"),
    ],
)
def test_a_screen_that_cannot_work_is_a_usage_error(extra, needle, tmp_path, capsys):
    argv = ["run", FAULTY, "--out", tmp_path / "o", *[a.format(tmp=tmp_path) for a in extra]]
    code, _, err = run_cli(argv, capsys)
    assert code == 2
    one_line_error(err, "--screen", needle)
    assert not (tmp_path / "o").exists()


def test_the_screenings_progress_stages_are_named_as_its_own(tmp_path):
    """On a terminal the screening's stages show as ``screen read``, ``screen detect``...;
    after a fault the full analysis's show under their plain names."""
    stages: list[str] = []

    def progress(stage: str, done: float) -> None:
        if not stages or stages[-1] != stage:
            stages.append(stage)

    options = RunOptions(screen=["equivalent_model"], progress=progress)
    assert pipeline.run([FAULTY], tmp_path, options) == 1
    first_plain = next(i for i, s in enumerate(stages) if not s.startswith("screen "))
    assert stages[0] == "screen read" and "screen detect" in stages[:first_plain]
    assert all(s.startswith("screen ") for s in stages[:first_plain])
    assert "read" in stages[first_plain:] and "report" in stages[first_plain:]
    assert not any(s.startswith("screen ") for s in stages[first_plain:])


def test_a_screening_that_cannot_run_leaves_the_archive_to_every_detector(tmp_path, monkeypatch):
    """When the screening's detectors cannot run on an archive (a ``DetectorError``: too
    little healthy data for them, say) the full analysis decides, and says why."""
    from analyzer.errors import DetectorError

    real = pipeline.analyze
    calls: list[list[str] | None] = []

    def first_fails(inputs, options, workdir=None):
        calls.append(options.detectors)
        if len(calls) == 1:
            raise DetectorError("no detector could run (equivalent_model: too little data)")
        return real(inputs, options, workdir)

    monkeypatch.setattr(pipeline, "analyze", first_fails)
    options = RunOptions(screen=["equivalent_model"])
    assert pipeline.run([FAULTY], tmp_path, options) == 1
    assert calls == [["equivalent_model"], None]
    found = _findings(tmp_path)
    assert found["screen"] == {
        "detectors": ["equivalent_model"],
        "fault": None,
        "error": "no detector could run (equivalent_model: too little data)",
    }
    assert len(found["detectors"]) == 3 and found["faults"]
    assert any("they could not run" in n for n in found["notes"])
