"""What ``run --save-model`` and ``run --model`` say: a fit-only run names the model it
saved and that nothing was searched (stderr, ``findings.json``'s ``saved_model``, the
report's verdict), and not as a clean bill when the window's checks warned; a file at
another rate than the model's is resampled with a warning; a model's channels the
archive lacks are refused with the archive's channels; a correction from the record's
start starts there; a file cut short that is too short to analyze says it was cut short
(the audit of fit-once/audit-many and of damaged inputs)."""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import one_line_error, run_cli
from jsonschema import Draft202012Validator

from analyzer.cli import main
from analyzer.schema import findings_schema
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

RATE = 100.0
TRAIN_S = 60.0
PIECE_S = 40.0
SAMPLES = Path(__file__).resolve().parents[2] / "samples"


@pytest.fixture(scope="module")
def record() -> tuple[np.ndarray, np.ndarray, list[str]]:
    """A training record and a later piece of the same simulated building."""
    t, y, names = simulate_building(5, TRAIN_S + PIECE_S, RATE, seed=11)
    return t, y, names


def _write(path: Path, t: np.ndarray, y: np.ndarray, names: list[str]) -> Path:
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: y[:, j] for j, n in enumerate(names)})
    return path


def _training(record, folder: Path) -> Path:
    t, y, names = record
    n = int(TRAIN_S * RATE)
    return _write(folder / "train.csv", t[:n], y[:n], names)


def _piece(record) -> tuple[np.ndarray, np.ndarray]:
    t, y, _ = record
    a = int(TRAIN_S * RATE)
    return t[a:], y[a:].copy()


@pytest.fixture(scope="module")
def fit_only(record, tmp_path_factory) -> tuple[Path, Path, str]:
    """``run train.csv --train 0:60 --save-model m.model``, the window the whole file:
    the model, the run's folder and its stderr."""
    d = tmp_path_factory.mktemp("fit")
    src = _training(record, d)
    argv = ["run", src, "--out", d / "out", "--train", f"0:{TRAIN_S}",
            "--save-model", d / "m.model", "--no-progress"]  # fmt: skip
    return d / "m.model", d / "out", _stderr_of(argv)


def _stderr_of(argv: list) -> str:
    """``analyzer ARGV``'s stderr (exit 0), for a module's fixture (no ``capsys``)."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        assert main([str(a) for a in argv]) == 0
    return err.getvalue()


def test_a_fit_only_run_says_the_model_was_saved_and_nothing_was_searched(fit_only):
    """Before, its last line was "no sensor fault found", findings.json had ``model:
    null`` and no file named the model, and the verdict said no residual had left its
    band after the window, after which nothing came."""
    model, out, err = fit_only
    last = err.strip().splitlines()[-1]
    assert last.startswith(
        f"analyzer: nothing after the training window to analyze; model saved to {model} "
    ), last
    assert "no sensor fault found" not in last and "warning" not in last
    doc = json.loads((out / "findings.json").read_text())
    saved = doc["saved_model"]
    assert saved["path"] == str(model)
    assert saved["sha256"] == hashlib.sha256(model.read_bytes()).hexdigest()
    assert saved["searched"] is None and saved["warnings"] == []
    assert saved["train"] == doc["train"]
    assert list(Draft202012Validator(findings_schema()).iter_errors(doc)) == []
    page = (out / "report.html").read_text()
    assert "Nothing after the training window to analyze" in page
    assert "None of the detectors found a residual" not in page
    assert str(model) in page


def test_a_model_saved_by_a_run_that_searched_after_its_window_says_both(record, tmp_path, capsys):
    src = _training(record, tmp_path)
    argv = ["run", src, "--out", tmp_path / "o", "--train", "0:40",
            "--save-model", tmp_path / "m.model", "--no-progress"]  # fmt: skip
    code, _, err = run_cli(argv, capsys)
    assert code == 0
    last = err.strip().splitlines()[-1]
    assert last.startswith("analyzer: no sensor fault found after the training window; "), last
    assert f"model saved to {tmp_path / 'm.model'} (fitted on 0-40 s)" in last
    saved = json.loads((tmp_path / "o" / "findings.json").read_text())["saved_model"]
    assert saved["searched"]["start_s"] == pytest.approx(40.0 + 1 / RATE)
    assert saved["searched"]["end_s"] == pytest.approx(TRAIN_S)


def test_a_model_fitted_on_a_window_that_was_warned_about_is_not_a_clean_bill(tmp_path, capsys):
    """``building_additive.mcap --train 0:60``: /s4.data steps inside the window, "the
    models were fitted on it"; the last line said "no sensor fault found"."""
    argv = ["run", SAMPLES / "building_additive.mcap", "--out", tmp_path / "o", "--train",
            "0:60", "--save-model", tmp_path / "bad.model", "--no-progress"]  # fmt: skip
    code, _, err = run_cli(argv, capsys)
    assert code == 0
    lines = err.strip().splitlines()
    assert any("/s4.data" in ln and "the models were fitted on it" in ln for ln in lines[:-1])
    assert "fitted on a window with" in lines[-1] and "see above" in lines[-1], lines[-1]
    assert "no sensor fault found" not in lines[-1]
    saved = json.loads((tmp_path / "o" / "findings.json").read_text())["saved_model"]
    assert any("/s4.data" in w for w in saved["warnings"])
    page = (tmp_path / "o" / "report.html").read_text()
    assert "The checks of the training window warned" in page


def test_a_file_at_another_rate_than_the_model_is_resampled_with_a_warning(
    fit_only, record, tmp_path, capsys
):
    """Before, only findings.json's notes said so; stderr said "no sensor fault found"."""
    t, y = _piece(record)
    src = _write(tmp_path / "half.csv", t[::2], y[::2], record[2])
    code, _, err = run_cli(
        ["run", src, "--out", tmp_path / "o", "--model", fit_only[0], "--no-progress"], capsys
    )
    assert code in (0, 1)
    warned = [ln for ln in err.splitlines() if ln.startswith("analyzer: warning:")]
    assert any(
        "50 Hz" in ln and "100 Hz" in ln and "resampled to the model's rate" in ln for ln in warned
    ), err
    same = _write(tmp_path / "same.csv", t, y, record[2])
    code, _, err = run_cli(
        ["run", same, "--out", tmp_path / "s", "--model", fit_only[0], "--no-progress"], capsys
    )
    assert code == 0 and "resampled" not in err


@pytest.mark.parametrize(
    ("names", "needles"),
    [
        (["a0", "a1", "a2", "a3", "a4"], ["the archive's channels: a0, a1, a2, a3 and 1 more"]),
        (
            ["/s0.data", "/s1.data", "/s2.data", "/s3.data", "/s4.data"],
            ["did you mean /s0.data for s0?", "the archive's channels: /s0.data, /s1.data"],
        ),
    ],
)
def test_the_model_channel_error_shows_the_archive_channels(
    names, needles, fit_only, record, tmp_path, capsys
):
    t, y = _piece(record)
    src = _write(tmp_path / "renamed.csv", t, y, names)
    code, _, err = run_cli(
        ["run", src, "--out", tmp_path / "o", "--model", fit_only[0], "--no-progress"], capsys
    )
    assert code == 2
    one_line_error(err, "--model", "this archive has no channel s0, s1, s2 and 2 more", *needles)


def test_a_correction_from_the_record_start_starts_at_zero(fit_only, record, tmp_path):
    """An offset present from the first sample, found with ``--model`` after the filters'
    warm-up and corrected from the record's start: ``start_s`` was the warm-up's end (3.6 s
    of 60 s in the audit) while every sample from 0 s was corrected."""
    t, y = _piece(record)
    sd = float(record[1][: int(TRAIN_S * RATE), 2].std())
    y[:, 2] = inject_fault(y[:, 2], RATE, "additive", 0.0, 1.0 * sd)
    src = _write(tmp_path / "offset.csv", t, y, record[2])
    out = tmp_path / "c"
    argv = ["run", src, "--out", out, "--model", fit_only[0], "--corrected", "--no-progress"]
    assert main([str(a) for a in argv]) == 1
    doc = json.loads((out / "findings.json").read_text())
    (fault,) = doc["faults"]
    (fix,) = doc["corrections"]
    assert fault["onset_s"] > 1.0 and fault["evidence"]["onset_at_or_before"] is True
    assert fix["samples"] == len(t)
    assert fix["start_s"] == 0.0
    assert fix["onset_s"] == fault["onset_s"]
    assert list(Draft202012Validator(findings_schema()).iter_errors(doc)) == []
    # the report still shows the correction with its finding, from 0 s
    page = (out / "report.html").read_text()
    assert "corrected from the record&#39;s start" in page


def test_a_file_cut_short_too_short_to_analyze_says_it_was_cut_short(tmp_path, capsys):
    """``head -c 900000 building_additive.mcap``: the error said only that the training
    window was too short ("give --train 0:12"), and the damage was named only by a run
    that got further. (The file ends inside a chunk, whose complete messages are read.)"""
    cut = tmp_path / "trunc.mcap"
    cut.write_bytes((SAMPLES / "building_additive.mcap").read_bytes()[:900_000])
    code, _, err = run_cli(["run", cut, "--out", tmp_path / "o", "--no-progress"], capsys)
    assert code == 2
    line = one_line_error(
        err,
        "truncated inside the zstd-compressed chunk that starts at byte 691894 (the file ends "
        "at byte 900000): only 41.1 s of data were read",
    )
    # the damage first (a long line is cut at its end), the reason the run stopped after
    assert line.index("truncated") < line.index("too short")
