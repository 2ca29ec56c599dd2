"""A ``--out`` used again: an earlier run's ``corrected.csv`` is removed (and said so on
stderr) when the new run writes no such file, a file of that name the analyzer did not
write is left as it was (and said so); a run interrupted into the folder says that what
the folder holds is an earlier run's."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest
from cli_helpers import run_cli

import analyzer.pipeline

SAMPLES = Path(__file__).resolve().parents[2] / "samples"
FAULTY = SAMPLES / "building_additive.mcap"
HEALTHY = SAMPLES / "building_healthy_ros2"


@pytest.fixture(scope="module")
def corrected_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding a ``run --corrected``'s outputs, read only by the tests."""
    from analyzer.cli import main

    out = tmp_path_factory.mktemp("corrected") / "o"
    assert main(["run", str(FAULTY), "--out", str(out), "--corrected", "--no-progress"]) == 1
    return out


def _copy(src: Path, dst: Path) -> Path:
    dst.mkdir()
    for name in ("findings.json", "report.html", "corrected.csv"):
        (dst / name).write_bytes((src / name).read_bytes())
    return dst


def test_an_earlier_run_s_corrected_csv_is_removed_and_said(corrected_run, tmp_path, capsys):
    first = json.loads((corrected_run / "findings.json").read_text())
    assert first["corrected_csv"] == "corrected.csv"
    out = _copy(corrected_run, tmp_path / "o")
    code, _, err = run_cli(["run", HEALTHY, "--out", out, "--no-progress"], capsys)
    assert code == 0, err
    assert not (out / "corrected.csv").exists()
    assert f"analyzer: warning: removed {out / 'corrected.csv'}, an earlier run's" in err
    doc = json.loads((out / "findings.json").read_text())
    assert doc["corrected_csv"] is None
    assert not any("corrected.csv" in n for n in doc["notes"])


def test_a_corrected_csv_the_analyzer_did_not_write_stays(corrected_run, tmp_path, capsys):
    """The user's own file of that name (no findings.json naming it; or one naming it
    while its columns are not those the run wrote) is never removed: a warning and a
    note say it is not this run's."""
    alone = tmp_path / "alone"
    alone.mkdir()
    (alone / "corrected.csv").write_text("time,x\n0,1\n")
    replaced = _copy(corrected_run, tmp_path / "replaced")
    (replaced / "corrected.csv").write_text('"time","/s0.data"\n0,1\n')
    for out in (alone, replaced):
        code, _, err = run_cli(["run", HEALTHY, "--out", out, "--no-progress"], capsys)
        assert code == 0, err
        assert (out / "corrected.csv").is_file()
        assert f"analyzer: warning: {out / 'corrected.csv'} is not this run's" in err
        notes = json.loads((out / "findings.json").read_text())["notes"]
        assert any("was left as it was" in n for n in notes)


def test_an_interrupted_run_says_the_folder_holds_an_earlier_run_s_outputs(
    corrected_run, tmp_path, capsys, monkeypatch
):
    """Interrupted (Ctrl-C, SIGTERM), a run into a folder holding an earlier run's
    outputs leaves all three as they were, and its last line names them."""
    out = _copy(corrected_run, tmp_path / "o")
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    an_hour_ago = time.time() - 3600
    for p in out.iterdir():
        os.utime(p, (an_hour_ago, an_hour_ago))

    def interrupted(*_args, **_kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(analyzer.pipeline, "analyze_screened", interrupted)
    code, _, err = run_cli(["run", HEALTHY, "--out", out, "--no-progress"], capsys)
    assert code == 130
    assert err.splitlines()[-1] == (
        f"analyzer: interrupted ({out} keeps an earlier run's findings.json, report.html "
        "and corrected.csv, not this run's)"
    )
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
