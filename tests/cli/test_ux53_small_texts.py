"""Small texts a new user's audit (ux53, items 7, 10, 12, 13) found wrong: a warning that
said a detector "did not run" and that the search "ran with" it "alone"; a saved model's
training window said two ways (fitted on 0-19.990 s, then 0-20.000 s); ``--save-model``
replacing an existing model without a word; a Python list ending an error line."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import one_line_error, run_cli

from analyzer.simulate import simulate_building
from analyzer.writers import write_archive

GROUPS = """\
[[group]]
name = "low"
channels = ["s0", "s1", "s2"]

[[group]]
name = "high"
channels = ["s3", "s4"]
"""


def _five(path: Path, seconds: float = 40.0, seed: int = 2) -> Path:
    """A 5-floor building at 100 Hz, healthy."""
    t, y, names = simulate_building(5, seconds, 100.0, seed=seed)
    t_ns = np.round(t * 1e9).astype(np.int64)
    data = {n: y[:, i] for i, n in enumerate(names)}
    write_archive(path, "csv", t_ns, data, start_iso="2026-01-01T00:00:00Z")
    return path


def test_a_detector_skipped_on_one_group_is_not_said_not_to_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Groups of 3 and 2 channels: the equivalent model cannot run on the pair (it needs
    3 channels) and runs on the trio; the line says so, and who searched the pair."""
    cfg = tmp_path / "groups.toml"
    cfg.write_text(GROUPS)
    argv = ["run", _five(tmp_path / "five.csv"), "--out", tmp_path / "o", "--train", "0:12"]
    code, _, err = run_cli([*argv, "--config", cfg, "--no-progress"], capsys)
    assert code in (0, 1), err
    (line,) = [ln for ln in err.splitlines() if "did not run" in ln]
    assert (
        "equivalent_model did not run on some channel groups, which ar_kalman_bank and "
        "detection_filter searched without it (equivalent_model (s3..s4): needs at least 3 "
        "channels"
    ) in line, line
    assert " alone" not in line and "ran with" not in line, line


def test_a_saved_model_s_window_and_replacing_a_model_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # (a window over the whole 20 s file, as the audit's 0:120 of a 120 s file: its last
    # sample at 19.99 s)
    healthy = _five(tmp_path / "healthy.csv", seconds=20.0, seed=3)
    model = tmp_path / "b.model"
    fit = ["run", healthy, "--train", "0:20", "--save-model", model, "--no-progress"]
    code, _, err = run_cli([*fit, "--out", tmp_path / "fit"], capsys)
    assert code in (0, 1), err
    assert "replaced" not in err  # (a new file)
    assert "(fitted on 0-19.99 s)" in err.splitlines()[-1], err
    saved = json.loads((tmp_path / "fit" / "findings.json").read_text())["saved_model"]
    assert saved["train"] == {"start_s": 0.0, "end_s": 19.99}
    later = _five(tmp_path / "later.csv", seconds=20.0, seed=4)
    code, _, err = run_cli(["run", later, "--out", tmp_path / "o", "--model", model], capsys)
    assert code in (0, 1), err
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    # the window the fit run said (before: 0-20.000 s here)
    assert doc["model"]["train"] == saved["train"]
    assert any("healthy window 0.000-19.990 s)" in n for n in doc["notes"]), doc["notes"]
    # a fit onto it: said, with the replaced file's SHA-256 (before: not a word)
    before = hashlib.sha256(model.read_bytes()).hexdigest()
    other = ["run", healthy, "--train", "0:15", "--save-model", model, "--no-progress"]
    code, _, err = run_cli([*other, "--out", tmp_path / "fit3"], capsys)
    assert code in (0, 1), err
    (line,) = [ln for ln in err.splitlines() if "replaced" in ln]
    assert line == (
        f"analyzer: warning: --save-model {model}: replaced the file that was there "
        f"(its SHA-256 was {before}; it is not kept)"
    )
    assert hashlib.sha256(model.read_bytes()).hexdigest() != before


def test_a_scheduler_error_has_no_python_list(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Dask's "known schemes: ['inproc', 'tcp', ...]" ended the line as a list's repr."""
    pytest.importorskip("distributed")
    archive = _five(tmp_path / "a.csv", seconds=20.0)
    code, _, err = run_cli(
        ["run", archive, "--out", tmp_path / "o", "--scheduler", "http://127.0.0.1:1"], capsys
    )
    assert code == 2
    line = one_line_error(err, "--scheduler http://127.0.0.1:1", "known schemes: ")
    assert "[" not in line and "'tcp'" not in line, line
    assert "tcp" in line
