"""``--model`` on a record whose column of one of the model's channels is there but blank
in every row (the ux53 audit, item 2): the archive was refused as a whole, exit 2, the
healthy sensors not audited. Now that channel is a dead sensor's finding (``other``,
``magnitude.no_data_s``, detector ``silent_check``, from the record's start, exit 1),
the others are audited as far as the model allows without it, and a note says how far.
A column truly absent keeps the refusal."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from analyzer.simulate import simulate_building
from analyzer.writers import write_archive
from tests.cli.cli_helpers import run_cli, run_to, said, schema_valid

RATE = 100.0
START = "2026-03-03T14:00:00Z"


def _building() -> tuple[np.ndarray, np.ndarray, list[str]]:
    t, y, names = simulate_building(3, 60.0, RATE, seed=3, sensors_per_floor=2)
    return np.round(t * 1e9).astype(np.int64), y, list(names)


def _csv(path: Path, t_ns: np.ndarray, columns: dict[str, np.ndarray]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    write_archive(path, "csv", t_ns, columns, start_iso=START)
    return path


@pytest.fixture(scope="module")
def model(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[str]]:
    """A model saved on a healthy record of six sensors, and their names."""
    from analyzer.cli import main

    tmp = tmp_path_factory.mktemp("fit")
    t_ns, y, names = _building()
    fit = _csv(tmp / "fit.csv", t_ns, {n: y[:, i] for i, n in enumerate(names)})
    saved = tmp / "b.model"
    code = main(
        ["run", str(fit), "--out", str(tmp / "o"), "--no-progress"]
        + [
            "--save-model",
            str(saved),
        ]
    )
    assert code in (0, 1)
    return saved, names


def test_a_blank_model_channel_is_a_finding_and_the_rest_audited(tmp_path, capsys, model):
    """s3's column blank in every row: exit 1, its finding from 0 s to the record's end,
    the archive analyzed with the model (not refused), a note saying what the model's
    detectors could audit without it."""
    saved, names = model
    t_ns, y, _ = _building()
    dead = names[3]
    y[:, 3] = np.nan
    day = _csv(tmp_path / "day" / "b.csv", t_ns, {n: y[:, i] for i, n in enumerate(names)})
    code, err, doc, _ = run_to(tmp_path, capsys, day, "--model", saved)
    assert code == 1, err
    assert "has no channel" not in err and "error" not in err
    schema_valid(doc)
    (f,) = [f for f in doc["faults"] if f["channel"] == dead]
    assert (f["type"], f["detector"], f["onset_s"], f["end_s"]) == (
        "other",
        "silent_check",
        0.0,
        None,
    )
    assert f["magnitude"]["no_data_s"] == pytest.approx(60.0, abs=0.05)
    assert f["evidence"]["onset_at_or_before"] is True
    assert doc["model"] is not None  # (analyzed with the model)
    report = (tmp_path / "o" / "report.html").read_text()
    assert f"{len(names)} of {len(names)}" in report  # (it said "6 of 5")
    note = next(n for n in doc["notes"] if n.startswith(f"{dead} is blank in every row"))
    assert "without it" in note and f"--channels '!{dead}'" in note
    # each detector the model ran is named in it (none had all its residuals)
    for d in doc["detectors"]:
        if d["name"] != "silent_check":
            assert d["name"] in note, (d["name"], note)


def test_a_channel_absent_from_the_archive_is_still_refused(tmp_path, capsys, model):
    """No s3 column at all: the model's channel set is not this archive's: refused,
    one line, exit 2, as before."""
    saved, names = model
    t_ns, y, _ = _building()
    day = _csv(
        tmp_path / "day" / "b.csv",
        t_ns,
        {n: y[:, i] for i, n in enumerate(names) if i != 3},
    )
    code, _, err = run_cli(["run", day, "--out", tmp_path / "o", "--model", saved], capsys)
    assert code == 2
    assert f"this archive has no channel {names[3]}" in err


@pytest.mark.parametrize(("fmt", "words"), [("csv", "blank in every row"), ("mcap", "NaN")])
def test_a_blank_model_channel_is_listed_in_channels(tmp_path, capsys, fmt, words):
    """A model saved on four channels, run on a record whose s2 has no reading at all
    (a CSV column blank in every row, an MCAP field NaN in every message): s2 is in
    ``channels[]`` (it was missing: listed without --model, not with it) with samples 0,
    why "no reading" and what its values were; it stays analyzed, as the model's other
    channels (its finding, silent_check; corrected.csv's column); the run warns what the
    model lost with it; the report's channel table has its row (ch57)."""
    t, y, _ = simulate_building(4, 60.0, RATE, seed=4)
    t_ns = np.round(t * 1e9).astype(np.int64)
    fit = tmp_path / f"fit.{fmt}"
    names = write_archive(fit, fmt, t_ns, {f"s{j}": y[:, j] for j in range(4)}, start_iso=START)
    saved = tmp_path / "four.model"
    code, _, err = run_cli(
        ["run", fit, "--out", tmp_path / "fit", "--no-progress", "--save-model", saved], capsys
    )
    assert code == 0, err
    dead = names["s2"]
    y[:, 2] = np.nan
    day = tmp_path / "day" / f"b.{fmt}"
    day.parent.mkdir()
    write_archive(day, fmt, t_ns, {f"s{j}": y[:, j] for j in range(4)}, start_iso=START)
    code, err, doc, out = run_to(tmp_path, capsys, day, "--model", saved, "--corrected")
    assert code == 1, err
    schema_valid(doc)
    (entry,) = [c for c in doc["channels"] if c["name"] == dead]
    assert (entry["samples"], entry["why"], entry["analyzed"]) == (0, "no reading", True), entry
    assert words in entry["no_reading"], entry
    assert sorted(c["name"] for c in doc["channels"]) == sorted(names.values())
    assert sorted(c["name"] for c in doc["channels"] if c["analyzed"]) == sorted(
        doc["model"]["channels"]
    )
    (f,) = doc["faults"]
    assert (f["channel"], f["detector"]) == (dead, "silent_check")
    header = (out / "corrected.csv").read_text().splitlines()[0].replace('"', "").split(",")
    assert sorted(header[1:]) == sorted(doc["model"]["channels"])
    (warned,) = [w for w in said(err) if "the model's detectors need it" in w]
    state = "is blank in every row" if fmt == "csv" else "has no reading at all"
    assert warned.startswith(f"analyzer: warning: {dead} {state} (a dead sensor"), warned
    assert 'listed in channels with why "no reading"' in warned, warned
    html = (out / "report.html").read_text()
    assert f"no reading: {entry['no_reading']}" in html
