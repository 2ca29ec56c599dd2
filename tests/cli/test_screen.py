"""``--screen NAME[,NAME...]``: the screening's detectors first, every other detector only
when they find a fault, on the same aligned archive (``pipeline._screened``)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cli_helpers import one_line_error, run_cli

from analyzer import pipeline
from analyzer.detectors import REGISTRY
from analyzer.pipeline import RunOptions
from analyzer.watch import analysis_into

SAMPLES = Path(__file__).resolve().parents[2] / "samples"
FAULTY = SAMPLES / "building_additive.mcap"
HEALTHY = SAMPLES / "building_healthy_ros2"


def _findings(out: Path) -> dict:
    return json.loads((out / "findings.json").read_text())


def _recorded(monkeypatch) -> list[list[str]]:
    """The detectors of each detection pass of the pipeline, and (``"read"``) each time an
    archive is opened."""
    calls: list[list[str]] = []
    run_detectors, run_groups, open_archive = (
        pipeline.run_detectors,
        pipeline.run_groups,
        pipeline.open_archive,
    )

    def detectors(names, *args):
        calls.append(list(names))
        return run_detectors(names, *args)

    def groups(group_list, names, *args):
        calls.append(list(names))
        return run_groups(group_list, names, *args)

    def opened(inputs, *args):
        calls.append(["read"])
        return open_archive(inputs, *args)

    monkeypatch.setattr(pipeline, "run_detectors", detectors)
    monkeypatch.setattr(pipeline, "run_groups", groups)
    monkeypatch.setattr(pipeline, "open_archive", opened)
    return calls


def test_a_screen_that_finds_a_fault_gives_the_full_analysis(tmp_path, capsys, monkeypatch):
    """The screening's fault sends the archive through every other detector: the archive
    read once, the screening's detector run once (its results kept), the faults and
    detectors those of a run without ``--screen``, and findings.json and a note say the
    screening found it."""
    code, _, _ = run_cli(["run", FAULTY, "--out", tmp_path / "plain", "--no-progress"], capsys)
    assert code == 1
    calls = _recorded(monkeypatch)
    code, _, _ = run_cli(
        [
            *("run", FAULTY, "--out", tmp_path / "screened", "--no-progress"),
            *("--screen", "equivalent_model"),
        ],
        capsys,
    )
    assert code == 1
    assert calls == [
        ["read"],
        ["equivalent_model"],
        [n for n in REGISTRY if n != "equivalent_model"],
    ]
    plain, screened = _findings(tmp_path / "plain"), _findings(tmp_path / "screened")
    assert screened["faults"] == plain["faults"]
    assert screened["detectors"] == plain["detectors"]  # models, tests, notes: all equal
    assert screened["skipped_detectors"] == plain["skipped_detectors"]
    assert screened["notes"][:-1] == plain["notes"]
    assert [d["name"] for d in screened["detectors"]] == [d["name"] for d in plain["detectors"]]
    assert len(screened["detectors"]) == 3
    assert screened["screen"] == {"detectors": ["equivalent_model"], "fault": True}
    assert plain["screen"] is None
    assert any(n.startswith("screened with equivalent_model alone") for n in screened["notes"])


def test_a_screen_that_finds_nothing_is_the_analysis(tmp_path, capsys, monkeypatch):
    """No fault in the screening: one analysis, by its detectors alone (the others never
    run), exit 0, and findings.json says so."""
    calls = _recorded(monkeypatch)
    code, _, _ = run_cli(
        ["run", HEALTHY, "--out", tmp_path, "--no-progress", "--screen", "equivalent_model"],
        capsys,
    )
    assert code == 0
    assert calls == [["read"], ["equivalent_model"]]
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
        (["--screen", "nope"], "--screen: unknown detector 'nope'"),
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
    """On a terminal the archive is read and aligned once; the screening's detectors show
    as ``screen detect``, and after a fault the other detectors' as ``detect``."""
    stages: list[str] = []

    def progress(stage: str, done: float) -> None:
        if not stages or stages[-1] != stage:
            stages.append(stage)

    options = RunOptions(screen=["equivalent_model"], progress=progress)
    assert pipeline.run([FAULTY], tmp_path, options) == 1
    assert stages[:2] == ["read", "align"] and stages.count("read") == 1
    assert stages.index("screen detect") < stages.index("detect") < stages.index("report")


def test_a_screening_that_cannot_run_leaves_the_archive_to_every_detector(tmp_path, monkeypatch):
    """When the screening's detectors raise a ``DetectorError`` (too little healthy data
    for them, say, with ``--detectors``) every detector analyzes the archive, and
    findings.json says why."""
    from analyzer.errors import DetectorError

    calls = _recorded(monkeypatch)
    recorded = pipeline.run_detectors

    def first_fails(names, *args):
        if calls == [["read"]]:
            calls.append(list(names))
            raise DetectorError("no detector could run (equivalent_model: too little data)")
        return recorded(names, *args)

    monkeypatch.setattr(pipeline, "run_detectors", first_fails)
    options = RunOptions(screen=["equivalent_model"])
    assert pipeline.run([FAULTY], tmp_path, options) == 1
    assert calls == [["read"], ["equivalent_model"], list(REGISTRY)]
    found = _findings(tmp_path)
    assert found["screen"] == {
        "detectors": ["equivalent_model"],
        "fault": None,
        "error": "no detector could run (equivalent_model: too little data)",
    }
    assert len(found["detectors"]) == 3 and found["faults"]
    assert any("they could not run" in n for n in found["notes"])


def test_a_screening_detector_that_does_not_apply_leaves_the_archive_to_the_others(
    tmp_path, capsys
):
    """On two channels the equivalent model does not apply (it needs three): the
    screening has no verdict, the other detectors analyze the archive, and the findings
    are the plain run's, the equivalent model skipped with its reason."""
    two = ["--channels", "/s3.data,/s4.data", "--no-progress"]
    code, _, _ = run_cli(["run", FAULTY, "--out", tmp_path / "plain", *two], capsys)
    assert code == 1
    code, _, _ = run_cli(
        ["run", FAULTY, "--out", tmp_path / "s", *two, "--screen", "equivalent_model"], capsys
    )
    assert code == 1
    plain, screened = _findings(tmp_path / "plain"), _findings(tmp_path / "s")
    assert screened["faults"] == plain["faults"] and screened["faults"]
    assert screened["detectors"] == plain["detectors"]
    assert screened["skipped_detectors"] == plain["skipped_detectors"]
    assert list(screened["skipped_detectors"]) == list(plain["skipped_detectors"])
    assert "equivalent_model" in screened["skipped_detectors"]
    assert screened["screen"]["fault"] is None
    assert screened["screen"]["error"].startswith("equivalent_model")


def test_a_screened_archive_of_several_channel_groups_is_the_plain_runs(tmp_path, capsys):
    """18 channels are two channel groups: the screening's results of each group are kept
    and joined with the other detectors' as a plain run joins them (detectors, their
    groups' models and tests, skip reasons in order, notes)."""
    import numpy as np

    from analyzer.simulate import inject_fault, simulate_building

    t, Y, names = simulate_building(9, 120.0, 100.0, seed=3, sensors_per_floor=2)
    Y[:, 9] = inject_fault(Y[:, 9], 100.0, "additive", 80.0, float(Y[:, 9].std()))
    archive = tmp_path / "g18.csv"
    np.savetxt(archive, np.c_[t, Y], delimiter=",", header="time," + ",".join(names), comments="")
    outs = {}
    for label, extra in (("plain", []), ("screened", ["--screen", "equivalent_model"])):
        outs[label] = tmp_path / label
        code, _, _ = run_cli(
            ["run", archive, "--out", outs[label], "--no-progress", *extra], capsys
        )
        assert code == 1
    plain, screened = _findings(outs["plain"]), _findings(outs["screened"])
    assert [f["channel"] for f in plain["faults"]] == [names[9]]
    assert screened["faults"] == plain["faults"]
    assert screened["detectors"] == plain["detectors"]
    assert all(d["model"]["groups"] == 2 for d in screened["detectors"])
    assert list(screened["skipped_detectors"]) == list(plain["skipped_detectors"])
    assert screened["notes"][:-1] == plain["notes"]
    assert screened["screen"] == {"detectors": ["equivalent_model"], "fault": True}
