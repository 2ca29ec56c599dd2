"""``run --save-model FILE`` and ``run/watch --model FILE``: fit once on a healthy
recording, then analyze later archives whole (a fault present from their first sample
included) with the saved models, and every way a model file or its options can be wrong
(exit 2, one line naming the option)."""

from __future__ import annotations

import io
import json
import pickle
import subprocess
import sys
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import one_line_error, run_cli
from jsonschema import Draft202012Validator

from analyzer import __version__
from analyzer.detectors.network import Propagation
from analyzer.diagnosis.merge import Finding
from analyzer.diagnosis.stuck import healthy_stats, relabel_frozen
from analyzer.modelfile import MAGIC, SavedModel, _Restricted, framed, load_model, save_model
from analyzer.schema import findings_schema
from analyzer.simulate import inject_fault, simulate_building
from analyzer.types import FaultType
from analyzer.writers import write_archive

RATE = 100.0
TRAIN_S = 80.0
PIECE_S = 40.0


@pytest.fixture(scope="module")
def record() -> tuple[np.ndarray, np.ndarray, list[str]]:
    """One continuous simulated record: the training file and the later pieces are cut
    from it, as hourly files are from a monitoring system's stream (same sensors, same
    noise)."""
    t, y, names = simulate_building(5, TRAIN_S + 4 * PIECE_S, RATE, seed=11)
    return t, y, names


def _write(path: Path, t: np.ndarray, y: np.ndarray, names: list[str]) -> Path:
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: y[:, j] for j, n in enumerate(names)})
    return path


def _piece(record, k: int) -> tuple[np.ndarray, np.ndarray]:
    t, y, _ = record
    a = int((TRAIN_S + k * PIECE_S) * RATE)
    b = a + int(PIECE_S * RATE)
    return t[a:b], y[a:b].copy()


@pytest.fixture(scope="module")
def model(record, tmp_path_factory) -> Path:
    t, y, names = record
    d = tmp_path_factory.mktemp("model")
    n = int(TRAIN_S * RATE)
    src = _write(d / "train.csv", t[:n], y[:n], names)
    code = _main(["run", src, "--out", d / "out", "--train", f"0:{TRAIN_S - 1}",
                  "--save-model", d / "m.model"])  # fmt: skip
    assert code == 0
    return d / "m.model"


def _main(argv: list) -> int:
    from analyzer.cli import main

    return main([str(a) for a in argv] + ["--no-progress"])


def _faults(out: Path) -> list[dict]:
    return json.loads((out / "findings.json").read_text())["faults"]


def test_a_saved_model_holds_what_the_run_fitted(model, record):
    m = load_model(model)
    assert m.channels == tuple(record[2])
    assert m.rate_hz == RATE
    assert m.train_s == (0.0, TRAIN_S - 1)
    assert set(m.detectors()) >= {"ar_kalman_bank", "detection_filter", "equivalent_model"}
    assert m.inputs[0][0].endswith("train.csv") and len(m.inputs[0][1]) == 64
    # each channel's healthy mean and spread are those of the training window
    y = record[1][: int((TRAIN_S - 1) * RATE) + 1]
    for j, c in enumerate(m.channels):
        assert m.healthy[c][0] == pytest.approx(y[:, j].mean(), rel=1e-9, abs=1e-12)
        assert m.healthy[c][1] == pytest.approx(y[:, j].std(), rel=1e-9)
    assert m.training_tests["ar_kalman_bank"]  # shown again in later reports


@pytest.mark.parametrize(
    ("kind", "size"), [("additive", 1.0), ("multiplicative", 1.3), ("drift", 1 / 30)]
)
def test_a_fault_present_from_the_first_sample_is_found_with_the_model(
    kind, size, model, record, tmp_path
):
    """Trained on its own first minutes, the archive takes such a fault for the healthy
    state; the model trained on the earlier recording sees it, of the right type and
    size, from the end of the filters' warm-up."""
    t, y = _piece(record, 1)
    sd = float(record[1][: int(TRAIN_S * RATE), 2].std())
    amount = size if kind == "multiplicative" else size * sd
    y[:, 2] = inject_fault(y[:, 2], RATE, kind, 0.0, amount)
    src = _write(tmp_path / "faulty.csv", t, y, record[2])
    assert _main(["run", src, "--out", tmp_path / "o", "--model", model]) == 1
    faults = _faults(tmp_path / "o")
    assert [(f["channel"], f["type"]) for f in faults] == [("s2", kind)]
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    warm_end = doc["train"]["end_s"]
    assert 0 < warm_end < 0.5 * PIECE_S
    assert faults[0]["onset_s"] == pytest.approx(warm_end + 1 / RATE, abs=0.02)
    key = {"additive": "offset", "multiplicative": "gain", "drift": "rate_per_s"}[kind]
    assert faults[0]["magnitude"][key] == pytest.approx(amount, rel=0.03)
    # its onset is an upper bound: it was there when the search started
    assert faults[0]["evidence"]["onset_at_or_before"] is True
    # (in the words of the report's table: "from the start", not judged before then)
    assert any("s2" in n and ("from the start" in n or "record began" in n) for n in doc["notes"])
    if kind != "drift":  # --corrected: a constant offset or gain undone from the start
        out = tmp_path / "c"
        assert _main(["run", src, "--out", out, "--model", model, "--corrected"]) == 1
        fixed = np.loadtxt(out / "corrected.csv", delimiter=",", skiprows=1)[:, 3]
        truth = _piece(record, 1)[1][:, 2]
        assert np.abs(fixed - truth).max() < 0.05 * np.abs(truth).max()
    if kind == "additive":  # trained on its own first half, the archive cannot see it
        assert _main(["run", src, "--out", tmp_path / "own", "--train", "0:20"]) == 0


def _two_dead(model, record, piece: int, tmp_path: Path, first: int = 1, second: int = 3):
    """``--model --corrected`` on a piece of the record with s1 (``first``) dead at
    10-22 s and s3 (``second``) at 16-30 s: ``(findings, readings, truth, out folder)``."""
    t, y = _piece(record, piece)
    truth = y.copy()
    y[:, first] = inject_fault(y[:, first], RATE, "multiplicative", 10.0, 0.0, 22.0)
    y[:, second] = inject_fault(y[:, second], RATE, "multiplicative", 16.0, 0.0, 30.0)
    src = _write(tmp_path / "dead.csv", t, y, record[2])
    out = tmp_path / "c"
    assert _main(["run", src, "--out", out, "--model", model, "--corrected"]) == 1
    return json.loads((out / "findings.json").read_text()), y, truth, out


def test_a_dead_sensor_alive_again_is_kept_as_measured_with_the_model(model, record, tmp_path):
    """--model --corrected: s1 dead at 10-22 s and s3 at 16-30 s; the detectors see s1
    faulty to about 30 s (its estimate leans on the dead s3), yet its readings after
    22 s are alive and kept as measured: the regeneration takes a stretch of the record
    that no finding touches as its healthy window (the run's own window is the filters'
    warm-up). Without one, s1 was regenerated to its finding's end (``sweep_corrected.py
    --model``, ``two-dead-drift``: 0.10-0.19 sd of error over the healthy readings).
    (Its readings read zero from the onset: the finding itself ends at 22 s, where they
    move again, the detectors' end kept in its evidence; it ran on to 30.2 s before.)"""
    doc, y, truth, out = _two_dead(model, record, 1, tmp_path)
    (s1,) = [f for f in doc["faults"] if f["channel"] == "s1"]
    assert s1["end_s"] == pytest.approx(22.0, abs=0.02)  # where the readings moved again
    assert s1["evidence"]["frozen"]["alarmed_to_s"] > 23.0  # the detectors saw it past 22 s
    (fix,) = [c for c in doc["corrections"] if c["channel"] == "s1"]
    assert fix["method"] == "reference"
    assert 22.0 <= fix["end_s"] <= 22.5
    fixed = np.loadtxt(out / "corrected.csv", delimiter=",", skiprows=1)[:, 1:]
    back = int(22.5 * RATE)
    assert np.array_equal(fixed[back:, 1], y[back:, 1])  # alive again: as measured
    dead = slice(int(10 * RATE), int(22 * RATE))
    sd = float(truth[:, 1].std())
    assert float(np.sqrt(np.mean((fixed[dead, 1] - truth[dead, 1]) ** 2))) < 0.5 * sd
    # the note names the stretch, clear of every finding and after the warm-up
    (said,) = [n for n in doc["notes"] if "the regeneration's healthy stretch is" in n]
    a, b = (float(x) for x in said.split(" is ")[1].split(" s ")[0].split("-"))
    assert doc["train"]["end_s"] < a < b
    for f in doc["faults"]:
        assert b <= f["onset_s"] or (f["end_s"] is not None and a >= f["end_s"])


def test_a_dead_sensor_whose_finding_ran_on_is_not_a_gain_with_the_model(model, record, tmp_path):
    """--model --corrected: s1 dead at 10-22 s and s3 at 16-30 s of another piece; the
    detectors see s1 faulty to about 30 s (s3's fault in their residuals of s1), and the
    residual over 10-30 s, dead then alive, fitted a gain of 0.435 (at bd303ba), which
    ``--corrected`` divided s1's alive readings after 22 s by. Its readings read zero
    from the onset, as no gain does: s1 is dead, to 22 s, where they move again, and
    its readings after are kept as measured (``sweep_corrected.py --model``: gains of
    0.11-0.38, 1.0-1.9 sd of error over the healthy readings)."""
    doc, y, truth, out = _two_dead(model, record, 0, tmp_path)
    (s1,) = [f for f in doc["faults"] if f["channel"] == "s1"]
    assert (s1["type"], s1["magnitude"]) == ("multiplicative", {"gain": 0.0})
    assert s1["end_s"] == pytest.approx(22.0, abs=0.02)
    assert s1["evidence"]["frozen"]["alarmed_to_s"] > 25.0  # the detectors' end
    (fix,) = [c for c in doc["corrections"] if c["channel"] == "s1"]
    assert fix["method"] == "reference" and fix["end_s"] <= 22.05
    fixed = np.loadtxt(out / "corrected.csv", delimiter=",", skiprows=1)[:, 1:]
    back = int(22.05 * RATE)
    assert np.array_equal(fixed[back:, 1], y[back:, 1])  # alive again: as measured
    dead = slice(int(10 * RATE), int(22 * RATE))
    sd = float(truth[:, 1].std())
    assert float(np.sqrt(np.mean((fixed[dead, 1] - truth[dead, 1]) ** 2))) < 0.5 * sd


def test_a_dead_sensor_read_as_neither_shape_is_dead_to_its_revival_with_the_model(
    model, record, tmp_path
):
    """--model --corrected: s3 dead at 10-22 s and s2 at 16-30 s of the second piece; the
    detectors see s3 faulty to about 30 s, and the residual over 10-30 s, dead then
    alive, is neither shape: ``other`` (offset about 0) at edb23a8, regenerated past
    22 s (0.62 sd of error over its alive readings). Its readings read zero from the
    onset, as no fault of an alive sensor does, whatever its type: dead, to 22 s, and
    its readings after are kept as measured (``sweep_dead_pairs.py``: 28 of 160 runs)."""
    doc, y, truth, out = _two_dead(model, record, 1, tmp_path, first=3, second=2)
    (s3,) = [f for f in doc["faults"] if f["channel"] == "s3"]
    assert (s3["type"], s3["magnitude"]) == ("multiplicative", {"gain": 0.0})
    assert s3["end_s"] == pytest.approx(22.0, abs=0.02)
    assert s3["evidence"]["frozen"]["was"] == "other"
    assert s3["evidence"]["frozen"]["alarmed_to_s"] > 25.0  # the detectors' end
    fixed = np.loadtxt(out / "corrected.csv", delimiter=",", skiprows=1)[:, 1:]
    back = int(22.05 * RATE)
    assert np.array_equal(fixed[back:, 3], y[back:, 3])  # alive again: as measured
    dead = slice(int(10 * RATE), int(22 * RATE))
    sd = float(truth[:, 3].std())
    assert float(np.sqrt(np.mean((fixed[dead, 3] - truth[dead, 3]) ** 2))) < 0.5 * sd


def test_a_dead_sensor_no_detector_isolated_is_found_by_its_readings_with_the_model(
    model, record, tmp_path
):
    """--model --corrected: s0 dead at 10-22 s and s1 at 16-30 s of the second piece, a
    quiet one (the structure at 0.6-0.7 of its healthy spread). Every detector saw an
    anomaly at 9.7-10.2 s and at 15.5-16.3 s and attributed it to no sensor: no finding
    at 8419bb2 (exit 0), and ``--corrected`` kept s0's zeros (0.79 sd of error over its
    dead readings; ``sweep_dead_pairs.py``: 8 of 160 runs). Their readings read zero from
    there, as no alive sensor does: each is dead from its death to its revival, and s0's
    dead readings are regenerated (0.61 sd of error, from an estimate that takes the
    dead s1 in: the sweep's 0.43 beside s2, s3 or s4)."""
    doc, y, truth, out = _two_dead(model, record, 1, tmp_path, first=0, second=1)
    got = {f["channel"]: f for f in doc["faults"]}
    for c, (a, b) in {"s0": (10.0, 22.0), "s1": (16.0, 30.0)}.items():
        f = got[c]
        assert (f["type"], f["magnitude"]) == ("multiplicative", {"gain": 0.0})
        assert (f["onset_s"], f["end_s"]) == (
            pytest.approx(a, abs=0.02),
            pytest.approx(b, abs=0.02),
        )
        assert f["evidence"]["frozen"]["was"] == "unattributed"
        assert f["evidence"]["unattributed_s"] and f["evidence"]["detectors"]
    assert list(Draft202012Validator(findings_schema()).iter_errors(doc)) == []
    (fix,) = [c for c in doc["corrections"] if c["channel"] == "s0"]
    assert fix["method"] == "reference"
    fixed = np.loadtxt(out / "corrected.csv", delimiter=",", skiprows=1)[:, 1:]
    dead = slice(int(10 * RATE), int(22 * RATE))
    zeros = float(np.sqrt(np.mean(truth[dead, 0] ** 2)))  # the error the zeros left
    assert float(np.sqrt(np.mean((fixed[dead, 0] - truth[dead, 0]) ** 2))) < zeros
    back = int(22.05 * RATE)
    assert np.array_equal(fixed[back:, 0], y[back:, 0])  # alive again: as measured


def test_a_channel_reading_zero_when_healthy_is_not_dead_with_the_model(record, tmp_path):
    """A flow meter behind a valve (v): exact zeros while it is closed, twice for 12-15 s
    in the training recording. In the later archive it closes for 20 s while s2 and s3
    are both offset by 3 sd, an anomaly the detectors attribute to no sensor. Its zeros
    are its healthy state, as the training readings show: no finding without ``--model``,
    and none with a model saved from that recording (which keeps that v reads zero at
    rest). A model kept no training readings at 8114970, and v was reported dead (exit 1)."""
    t, y, names = record
    n, m = int(TRAIN_S * RATE), int((TRAIN_S + 120.0) * RATE)
    sd = y[:n].std(0)
    rng = np.random.default_rng(3)
    open_ = np.ones(m)
    for a, b in ((20.0, 35.0), (50.0, 62.0), (120.0, 140.0)):
        open_[int(a * RATE) : int(b * RATE)] = 0.0
    v = (1.0 + 0.5 * y[:m, 0] / sd[0] + 0.05 * rng.standard_normal(m)) * open_
    y = np.column_stack((y[:m], v))
    y[int(120 * RATE) : int(140 * RATE), 2:4] += 3.0 * sd[2:4]
    cols = [*names, "v"]
    train = _write(tmp_path / "train.csv", t[:n], y[:n], cols)
    src = _write(tmp_path / "later.csv", t[n:m], y[n:m], cols)
    saved = tmp_path / "m.model"
    code = _main(["run", train, "--out", tmp_path / "fit", "--train", f"0:{TRAIN_S - 1}",
                  "--save-model", saved])  # fmt: skip
    assert code == 0
    assert load_model(saved).zero_at_rest == ("v",)
    assert _main(["run", src, "--out", tmp_path / "o", "--model", saved]) == 0
    assert _faults(tmp_path / "o") == []


def test_healthy_pieces_give_no_finding_and_name_the_model(model, record, tmp_path):
    for k in (0, 2, 3):
        t, y = _piece(record, k)
        src = _write(tmp_path / f"p{k}.csv", t, y, record[2])
        assert _main(["run", src, "--out", tmp_path / f"o{k}", "--model", model]) == 0
    doc = json.loads((tmp_path / "o0" / "findings.json").read_text())
    assert doc["model"]["path"] == str(model)
    assert doc["model"]["trained_on"][0]["path"].endswith("train.csv")
    assert doc["model"]["train"] == {"start_s": 0.0, "end_s": TRAIN_S - 1}
    assert any("nothing was fitted on this archive" in n for n in doc["notes"])
    bank = next(d for d in doc["detectors"] if d["name"] == "ar_kalman_bank")
    assert bank["model"]["training_tests"] == load_model(model).training_tests["ar_kalman_bank"]
    html = (tmp_path / "o0" / "report.html").read_text()
    assert "nothing was fitted on this archive" in html


def test_threads_and_serial_give_the_same_findings_with_a_model(model, record, tmp_path):
    t, y = _piece(record, 2)
    y[:, 4] = inject_fault(y[:, 4], RATE, "additive", 10.0, 2.0 * y[:, 4].std())
    src = _write(tmp_path / "f.csv", t, y, record[2])
    assert _main(["run", src, "--out", tmp_path / "a", "--model", model, "--jobs", "1"]) == 1
    assert _main(["run", src, "--out", tmp_path / "b", "--model", model, "--jobs", "2"]) == 1
    assert _faults(tmp_path / "a") == _faults(tmp_path / "b")
    assert [(f["channel"], f["type"]) for f in _faults(tmp_path / "a")] == [("s4", "additive")]


def test_the_watcher_runs_each_archive_with_the_model(model, record, tmp_path):
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    t, y = _piece(record, 3)
    y[:, 0] = inject_fault(y[:, 0], RATE, "additive", 0.0, 2.0 * y[:, 0].std())
    _write(inbox / "hour.csv", t, y, record[2])
    reports = tmp_path / "reports"
    # in a process of its own: the watcher's analysis processes fork from a fork server
    # that would otherwise outlive this test
    argv = ["watch", inbox, "--out", reports, "--once", "--model", model, "--no-progress"]
    done = subprocess.run(
        [sys.executable, "-m", "analyzer", *map(str, argv)], capture_output=True, text=True
    )
    assert done.returncode == 1, done.stderr  # --once: an archive with a fault
    (doc,) = [json.loads(p.read_text()) for p in reports.rglob("findings.json")]
    assert doc["model"]["path"] == str(model)
    assert [(f["channel"], f["type"]) for f in doc["faults"]] == [("s0", "additive")]


def test_the_watcher_refuses_a_rate_or_detector_the_model_has_not_at_its_start(
    model, record, tmp_path
):
    """Errors every archive would get: the watcher stops at its start (exit 2, one
    line), where it analyzed each archive, recorded an error and left it in INBOX."""
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    t, y = _piece(record, 3)
    _write(inbox / "hour.csv", t, y, record[2])
    reports = tmp_path / "reports"
    for extra, needle in (
        (["--rate", "50"], "analyzer: error: --rate 50: the model "),
        (["--detectors", "error_function"], "analyzer: error: --detectors error_function: "),
    ):
        argv = ["watch", inbox, "--out", reports, "--once", "--model", model, *extra]
        done = subprocess.run(
            [sys.executable, "-m", "analyzer", *map(str, argv)], capture_output=True, text=True
        )
        assert done.returncode == 2, done.stderr
        assert done.stderr.startswith(needle) and done.stderr.count("\n") == 1, done.stderr
        assert not reports.exists()


# ------------------------------------------------------------------------- bad input


def test_bad_model_options_are_one_line_errors(model, record, tmp_path, capsys):
    t, y = _piece(record, 0)
    src = _write(tmp_path / "p.csv", t, y, record[2])
    out = tmp_path / "o"
    cases = [
        (["--model", tmp_path / "absent.model"], ["--model", "absent.model"]),
        (["--model", src], ["--model", "not an analyzer model"]),
        (["--model", model, "--train", "0:5"], ["--train", "--model"]),
        (["--model", model, "--channels", "s0"], ["--channels", "--model"]),
        (["--model", model, "--rate", "50"], ["--rate 50", "100 Hz"]),
        (["--model", model, "--detectors", "error_function"], ["--detectors error_function"]),
        (["--save-model", tmp_path / "no" / "m.model"], ["--save-model", "does not exist"]),
        (["--save-model", tmp_path], ["--save-model", "is a directory"]),
        (["--model", model, "--save-model", tmp_path / "x"], ["--save-model", "--model"]),
        (["--save-model", src], ["--save-model", "is an input"]),
    ]
    for extra, needles in cases:
        code, _, err = run_cli(["run", src, "--out", out, *extra], capsys)
        assert code == 2, extra
        one_line_error(err, *needles)
        assert not out.exists()
    cfg = tmp_path / "c.toml"
    cfg.write_text("[thresholds]\nfalse_alarm_rate = 1e-5\n")
    code, _, err = run_cli(["run", src, "--out", out, "--model", model, "--config", cfg], capsys)
    assert code == 2
    one_line_error(err, "--config", "--model")


def test_a_model_is_not_written_into_an_input_directory(record, tmp_path, capsys):
    archive = tmp_path / "archive"
    archive.mkdir()
    t, y = _piece(record, 0)
    _write(archive / "a.csv", t, y, record[2])
    before = sorted(p.name for p in archive.iterdir())
    code, _, err = run_cli(
        ["run", archive, "--out", tmp_path / "o", "--save-model", archive / "m.model"], capsys
    )
    assert code == 2
    one_line_error(err, "--save-model", "inside the input")
    assert sorted(p.name for p in archive.iterdir()) == before


def test_channels_beyond_the_model_are_named_in_a_note(model, record, tmp_path):
    t, y = _piece(record, 0)
    extra = np.column_stack([y, y[:, 0] * 0.5 + 1.0])
    src = _write(tmp_path / "more.csv", t, extra, [*record[2], "spare"])
    assert _main(["run", src, "--out", tmp_path / "o", "--model", model]) == 0
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    assert any("not in the model" in n and "spare" in n for n in doc["notes"]), doc["notes"]
    assert [c["name"] for c in doc["channels"] if c["analyzed"]] == record[2]


def test_channels_at_another_rate_than_the_model_are_noted(model, record, tmp_path):
    """A model fitted at 100 Hz run on a 50 Hz file: resampled onto the model's clock
    without a word; the rate the file itself was recorded at says so now."""
    t, y = _piece(record, 0)
    src = _write(tmp_path / "half.csv", t[::2], y[::2], record[2])
    assert _main(["run", src, "--out", tmp_path / "o", "--model", model]) in (0, 1)
    notes = json.loads((tmp_path / "o" / "findings.json").read_text())["notes"]
    assert any(n.startswith("the channels run at 50 Hz and the model at 100 Hz") for n in notes)
    same = _write(tmp_path / "same.csv", t, y, record[2])
    assert _main(["run", same, "--out", tmp_path / "s", "--model", model]) == 0
    notes = json.loads((tmp_path / "s" / "findings.json").read_text())["notes"]
    assert not any("the channels run at" in n for n in notes)


def test_an_archive_without_a_model_channel_is_refused(model, record, tmp_path, capsys):
    t, y = _piece(record, 0)
    src = _write(tmp_path / "p.csv", t, y[:, :4], record[2][:4])
    code, _, err = run_cli(["run", src, "--out", tmp_path / "o", "--model", model], capsys)
    assert code == 2
    one_line_error(err, "--model", "no channel s4")


def test_damaged_foreign_and_other_version_models_are_refused(model, tmp_path, capsys):
    data = model.read_bytes()
    cut = tmp_path / "cut.model"
    cut.write_bytes(data[: len(data) // 2])
    other = tmp_path / "other.model"
    save_model(other, replace(load_model(model), analyzer_version="0.0.1"))
    future = tmp_path / "future.model"
    future.write_bytes(b"analyzer.model/9\n" + data[len(MAGIC) :])
    # audit: 8 bytes flipped at 30 % of a 5.4 MB model were loaded, and the run's
    # findings changed with nothing said
    flipped = bytearray(data)
    at = int(len(data) * 0.3)
    flipped[at : at + 8] = bytes(b ^ 0x55 for b in flipped[at : at + 8])
    bad = tmp_path / "flipped.model"
    bad.write_bytes(bytes(flipped))
    for path, needle in [
        (bad, "does not match the checksum"),
        (cut, "damaged"),
        (other, "analyzer 0.0.1"),
        (future, "another format"),
    ]:
        with pytest.raises(Exception, match=needle):
            load_model(path)
        code, _, err = run_cli(["run", model, "--out", tmp_path / "o", "--model", path], capsys)
        assert code == 2
        one_line_error(err, "--model", needle)


class _Boom:
    def __reduce__(self):
        import os

        return (os.system, ("echo pwned > /dev/null",))


def test_a_model_file_cannot_run_code(tmp_path):
    """Only what a model is made of is built (``tests/cli/test_model_loader.py``): a
    pickle that would call ``os.system`` (or any function) is refused, not run."""
    evil = tmp_path / "evil.model"
    evil.write_bytes(framed(pickle.dumps(_Boom(), protocol=5)))
    with pytest.raises(Exception, match="does not hold an analyzer model: it asks to build "
                       "'(posix|os).system'"):  # fmt: skip
        load_model(evil)
    # what a model is made of goes through
    arr = np.arange(6.0).reshape(2, 3)
    back = _Restricted(io.BytesIO(pickle.dumps((arr, np.float64(2.5), Propagation.CHAINED)))).load()
    assert np.array_equal(back[0], arr) and back[1] == 2.5 and back[2] is Propagation.CHAINED
    with pytest.raises(pickle.UnpicklingError, match="refused|not part of one"):
        _Restricted(io.BytesIO(pickle.dumps(Path("x")))).load()
    # analyzer classes outside what a model is made of (a store would open files) and
    # the analyzer's enums no model holds, too
    from analyzer.config import Config

    for value, name in ((Config(), "analyzer.config.Config"), (FaultType.DRIFT, "FaultType")):
        with pytest.raises(pickle.UnpicklingError, match=f"{name}', which is not part of one"):
            _Restricted(io.BytesIO(pickle.dumps(value))).load()


def test_frozen_sensors_are_told_by_saved_healthy_stats_as_by_the_window():
    """``relabel_frozen`` with the model's per-channel mean and spread decides as with
    the training window they were taken from."""
    rng = np.random.default_rng(3)
    values = rng.standard_normal((2000, 2)) + [5.0, 0.0]
    values[1200:, 0] = 7.25  # stuck
    values[1500:, 1] = 0.0  # dead

    def findings() -> list[Finding]:
        return [
            Finding("a", FaultType.ADDITIVE, 12.0, None, {"offset": 2.0}, 0.9, "x"),
            Finding("b", FaultType.ADDITIVE, 15.0, None, {"offset": 0.1}, 0.9, "x"),
        ]

    by_window, by_stats = findings(), findings()
    notes_w = relabel_frozen(by_window, values, ["a", "b"], 100.0, (0, 1000))
    stats = healthy_stats(values, ["a", "b"], (0, 1000))
    notes_s = relabel_frozen(by_stats, values, ["a", "b"], 100.0, stats)
    assert notes_w == notes_s and len(notes_w) == 2
    assert [(f.type, f.magnitude) for f in by_window] == [(f.type, f.magnitude) for f in by_stats]
    assert by_stats[0].type is FaultType.OTHER and by_stats[0].magnitude["stuck_at"] == 7.25
    assert by_stats[1].magnitude == {"gain": 0.0}


def test_saved_model_round_trips_through_the_restricted_loader(model):
    m = load_model(model)
    assert isinstance(m, SavedModel) and m.analyzer_version == __version__
    again = Path(str(model) + ".copy")
    save_model(again, m)
    m2 = load_model(again)
    assert m2.channels == m.channels and m2.healthy == m.healthy
    again.unlink()


def test_a_file_shorter_than_twice_the_settling_says_so(model, record, tmp_path):
    """The search starts at half such a file at the latest, with a note that a finding
    there may be the filters still settling."""
    t, y = _piece(record, 0)
    n = int(4.0 * RATE)  # the model's filters settle in about 3 s
    src = _write(tmp_path / "short.csv", t[:n], y[:n], record[2])
    code = _main(["run", src, "--out", tmp_path / "o", "--model", model])
    assert code in (0, 1)
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    assert doc["train"]["end_s"] == pytest.approx(2.0 - 1 / RATE)
    assert any("longer than half this record" in n for n in doc["notes"]), doc["notes"]


def test_a_model_of_channel_groups_runs_each_group_as_fitted(tmp_path):
    """More than 16 channels are partitioned into groups at the fit; the model keeps the
    groups and each group's fitted detectors, and runs them so on a later file."""
    t, y, names = simulate_building(10, 150.0, RATE, seed=3, sensors_per_floor=2)
    n0 = int(100 * RATE)
    src = _write(tmp_path / "train.csv", t[:n0], y[:n0], names)
    model = tmp_path / "g.model"
    assert _main(["run", src, "--out", tmp_path / "fit", "--train", "0:99",
                  "--save-model", model]) == 0  # fmt: skip
    m = load_model(model)
    assert len(m.groups) > 1 and sorted(c for g in m.groups for c in g) == sorted(names)
    assert {f"-g{k}" for k in range(len(m.groups))} <= set(m.fits)
    z = y[n0:].copy()
    z[:, 7] = inject_fault(z[:, 7], RATE, "additive", 0.0, 1.5 * y[:n0, 7].std())
    later = _write(tmp_path / "later.csv", t[n0:], z, names)
    assert _main(["run", later, "--out", tmp_path / "o", "--model", model]) == 1
    assert [(f["channel"], f["type"]) for f in _faults(tmp_path / "o")] == [("s7", "additive")]


def test_a_serial_fit_saves_the_model_the_threads_save(model, record, tmp_path):
    """``--jobs 1`` (fit and run in one task per detector) and threads (fits first, kept
    as they finish) write models that give the same findings."""
    t, y, names = record
    n = int(TRAIN_S * RATE)
    src = _write(tmp_path / "train.csv", t[:n], y[:n], names)
    serial = tmp_path / "serial.model"
    code = _main(["run", src, "--out", tmp_path / "fit", "--train", f"0:{TRAIN_S - 1}",
                  "--save-model", serial, "--jobs", "1"])  # fmt: skip
    assert code == 0
    assert load_model(serial).detectors() == load_model(model).detectors()
    t2, y2 = _piece(record, 2)
    y2[:, 1] = inject_fault(y2[:, 1], RATE, "multiplicative", 0.0, 1.4)
    later = _write(tmp_path / "later.csv", t2, y2, names)
    found = []
    for m in (model, serial):
        out = tmp_path / m.stem
        assert _main(["run", later, "--out", out, "--model", m]) == 1
        found.append(_faults(out))
    assert found[0] == found[1]
    assert [(f["channel"], f["type"]) for f in found[0]] == [("s1", "multiplicative")]


def test_an_archive_in_other_units_than_the_model_is_named(tmp_path, capsys):
    """Audit: every channel 1000x the model's (mm/s^2 for m/s^2) gave exit 0 and only an
    anomaly attributed to no sensor; the spread against the model's is said now."""
    t, y, names = simulate_building(n_floors=3, duration_s=120.0, seed=5)
    t_ns = np.round(t * 1e9).astype(np.int64)
    fit = tmp_path / "fit.csv"
    write_archive(fit, "csv", t_ns, {n: y[:, j] for j, n in enumerate(names)})
    model = tmp_path / "m.model"
    argv = ["run", fit, "--out", tmp_path / "o0", "--train", "0:100", "--save-model", model]
    run_cli(argv, capsys)
    same = tmp_path / "same.csv"
    write_archive(same, "csv", t_ns, {n: 1.0 * y[:, j] for j, n in enumerate(names)})
    code, _, err = run_cli(["run", same, "--out", tmp_path / "o1", "--model", model], capsys)
    assert "spread against the model" not in err
    milli = tmp_path / "milli.csv"
    write_archive(milli, "csv", t_ns, {n: 1000.0 * y[:, j] for j, n in enumerate(names)})
    code, _, err = run_cli(["run", milli, "--out", tmp_path / "o2", "--model", model], capsys)
    assert "warning: the archive's spread against the model's healthy window: s0 1.0" in err
    assert err.count("e+03x") == 3  # every channel
    notes = json.loads((tmp_path / "o2" / "findings.json").read_text())["notes"]
    assert any(n.startswith("the archive's spread against the model's") for n in notes)


# ------------------------------------------------------------------ the readings rule


def test_a_saved_model_holds_the_residuals_healthy_statistics(model):
    """What the readings rule needs to judge a lone equivalent-model finding of a
    ``--model`` run: each residual's healthy mean, spread and correlation time on the
    training window, for the equivalent model, the bank and the detection filter."""
    m = load_model(model)
    assert set(m.reading_health) == {"equivalent_model", "ar_kalman_bank", "detection_filter"}
    for per_channel in m.reading_health.values():
        assert set(per_channel) == set(m.channels)
        for mean, sd, tau in per_channel.values():
            assert np.isfinite(mean) and sd > 0.0 and tau >= 1.0


def _pickle_without(monkeypatch, name: str) -> None:
    """Pickle a model as an analyzer that had no field ``name`` yet did: its field values
    in order, stopping short of ``name`` (the fields added after it are missing too)."""
    state = SavedModel.__getstate__
    cut = [f.name for f in fields(SavedModel)].index(name)
    monkeypatch.setattr(SavedModel, "__getstate__", lambda self: state(self)[:cut])


def test_a_model_saved_before_the_zeros_at_rest_finds_no_dead_sensor_the_detectors_did_not(
    model, record, tmp_path, monkeypatch
):
    """A model saved before it kept which channels read zero when healthy: whether a
    channel's zeros are its healthy state is not known, so a dead sensor in an anomaly
    no detector attributed is not looked for (s0 dead at 10-22 s and s1 at 16-30 s, a
    quiet piece: found with a model that keeps them, above; not with this one)."""
    m = load_model(model)
    assert m.zero_at_rest == ()
    _pickle_without(monkeypatch, "zero_at_rest")
    older = tmp_path / "older.model"
    older.write_bytes(framed(pickle.dumps(m, protocol=5)))
    monkeypatch.undo()
    assert load_model(older).zero_at_rest is None
    t, y = _piece(record, 1)
    y[:, 0] = inject_fault(y[:, 0], RATE, "multiplicative", 10.0, 0.0, 22.0)
    y[:, 1] = inject_fault(y[:, 1], RATE, "multiplicative", 16.0, 0.0, 30.0)
    src = _write(tmp_path / "dead.csv", t, y, record[2])
    _main(["run", src, "--out", tmp_path / "o", "--model", older])
    faults = _faults(tmp_path / "o")
    assert not [f for f in faults if f["evidence"].get("frozen", {}).get("was") == "unattributed"]


def test_a_model_saved_before_the_residuals_health_loads_and_runs(
    model, record, tmp_path, monkeypatch
):
    """Its lone equivalent-model findings stand as the detector reported them (the
    rule has no healthy statistics to judge them by), as before."""
    m = load_model(model)
    # pickled as an analyzer that did not yet keep reading_health did: its field values
    # in order, the ones from it on missing
    _pickle_without(monkeypatch, "reading_health")
    older = tmp_path / "older.model"
    older.write_bytes(framed(pickle.dumps(m, protocol=5)))
    monkeypatch.undo()
    loaded = load_model(older)
    assert loaded.reading_health == {} and loaded.zero_at_rest is None
    assert loaded.healthy == m.healthy
    t, y = _piece(record, 1)
    y[:, 4] = inject_fault(y[:, 4], RATE, "additive", 10.0, 2.0 * y[:, 4].std())
    src = _write(tmp_path / "f.csv", t, y, record[2])
    assert _main(["run", src, "--out", tmp_path / "o", "--model", older]) == 1
    assert [(f["channel"], f["type"]) for f in _faults(tmp_path / "o")] == [("s4", "additive")]


def test_a_model_saved_before_its_last_two_fields_loads_with_their_defaults(
    model, tmp_path, monkeypatch
):
    """A slotted dataclass keeps no class attribute for a plain default: a file whose
    pickle stops short of a field with one (``created``, ``""``) as well as of one with a
    factory (``reading_health``) loads with both defaults, not an object missing one."""
    m = load_model(model)
    _pickle_without(monkeypatch, "created")
    older = tmp_path / "older.model"
    older.write_bytes(framed(pickle.dumps(m, protocol=5)))
    monkeypatch.undo()
    loaded = load_model(older)
    assert loaded.created == "" and loaded.reading_health == {}
    assert loaded.describe()["trained_on"] == m.describe()["trained_on"]
