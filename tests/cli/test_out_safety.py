"""Outputs never replace inputs, a slip of ``--save-model`` never destroys a recording,
and two runs never write one ``--out`` at once (a QA engineer's audit, ux56 items 1, 2,
4, 8, 11)."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import one_line_error, run_cli

from analyzer.errors import UsageError
from analyzer.simulate import simulate_building
from analyzer.writers import write_archive


def _five(path: Path, seconds: float = 30.0, seed: int = 2) -> Path:
    """A 5-floor building at 100 Hz, healthy."""
    t, y, names = simulate_building(5, seconds, 100.0, seed=seed)
    t_ns = np.round(t * 1e9).astype(np.int64)
    path.parent.mkdir(parents=True, exist_ok=True)
    data = {n: y[:, i] for i, n in enumerate(names)}
    write_archive(path, "csv", t_ns, data, start_iso="2026-01-01T00:00:00Z")
    return path


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_corrected_signals_never_replace_the_input_named_corrected_csv(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Re-auditing a corrected.csv into its own folder with ``--corrected``: the run
    wrote its corrected signals over the record it read (exit 1, not a word)."""
    record = _five(tmp_path / "fold" / "corrected.csv")
    before = _sha(record)
    argv = ["run", record, "--out", tmp_path / "fold", "--corrected", "--train", "0:12"]
    code, _, err = run_cli([*argv, "--no-progress"], capsys)
    assert code == 2
    one_line_error(err, "--out:", "would replace the input", "corrected.csv")
    assert _sha(record) == before
    assert not (tmp_path / "fold" / "findings.json").exists()


def test_a_folder_s_own_corrected_csv_is_not_replaced_but_the_analyzer_s_is(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A folder archive holding a data file named corrected.csv, analyzed with its
    outputs in the folder and ``--corrected``: refused (the file is part of the archive
    read); once the folder holds the analyzer's findings.json its corrected.csv is the
    analyzer's own output, skipped by the reader and replaced by a later run."""
    fold = tmp_path / "fold"
    _five(fold / "a.csv")
    data = _five(fold / "corrected.csv", seed=3)
    before = _sha(data)
    argv = ["run", fold, "--out", fold, "--corrected", "--train", "0:12", "--no-progress"]
    code, _, err = run_cli(argv, capsys)
    assert code == 2
    one_line_error(err, "--out:", "is a file of the input folder", "corrected.csv")
    assert _sha(data) == before
    # the outputs into the folder itself (no corrected.csv of the user's in it) go on
    data.unlink()
    code, _, err = run_cli(argv, capsys)
    assert code in (0, 1), err
    assert (fold / "corrected.csv").is_file()
    code, _, err = run_cli(argv, capsys)  # (its own earlier output: replaced)
    assert code in (0, 1), err


def test_outputs_into_the_input_s_folder_are_still_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``run data/x.csv --out data``: nothing of the input's is replaced; allowed."""
    record = _five(tmp_path / "data" / "x.csv")
    before = _sha(record)
    argv = ["run", record, "--out", tmp_path / "data", "--train", "0:12", "--no-progress"]
    code, _, err = run_cli(argv, capsys)
    assert code in (0, 1), err
    assert _sha(record) == before
    assert (tmp_path / "data" / "findings.json").is_file()


def test_save_model_refuses_to_replace_a_file_that_is_no_model(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--save-model data.csv`` (a recording, not this run's input) replaced it with a
    model and said so afterwards; now refused before any work, the file kept."""
    record = _five(tmp_path / "x.csv")
    other = _five(tmp_path / "other.csv", seed=4)
    before = _sha(other)
    argv = ["run", record, "--out", tmp_path / "o", "--train", "0:12", "--save-model", other]
    code, _, err = run_cli([*argv, "--no-progress"], capsys)
    assert code == 2
    one_line_error(err, "--save-model:", "other.csv", "is not an analyzer model")
    assert _sha(other) == before
    assert not (tmp_path / "o").exists()


def test_save_model_replaces_a_model_or_an_empty_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    record = _five(tmp_path / "x.csv")
    model = tmp_path / "m.model"
    model.write_bytes(b"")  # (touched beforehand: nothing to lose)
    argv = ["run", record, "--train", "0:12", "--save-model", model, "--no-progress"]
    code, _, err = run_cli([*argv, "--out", tmp_path / "o1"], capsys)
    assert code in (0, 1), err
    assert model.read_bytes().startswith(b"analyzer.model/")
    code, _, err = run_cli([*argv, "--out", tmp_path / "o2"], capsys)
    assert code in (0, 1), err
    assert any("replaced the file that was there" in ln for ln in err.splitlines()), err


def test_a_second_run_into_an_out_in_use_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two runs into one ``--out`` at once both exited 1 naming the same report, the
    later archive's: the folder is held while a run writes into it, in another process
    as here in this one (flock locks are per open file, so a second open conflicts)."""
    from analyzer.outdir import only_run

    record = _five(tmp_path / "x.csv")
    out = tmp_path / "o"
    out.mkdir()
    with only_run(out):
        code, _, err = run_cli(
            ["run", record, "--out", out, "--train", "0:12", "--no-progress"], capsys
        )
        assert code == 2
        one_line_error(err, "--out:", "is being written by another analyzer run")
        assert os.listdir(out) == []
    code, _, err = run_cli(
        ["run", record, "--out", out, "--train", "0:12", "--no-progress"], capsys
    )
    assert code in (0, 1), err
    assert sorted(os.listdir(out)) == ["findings.json", "report.html"]  # (no lock file left)


def test_only_run_is_released_after_an_error(tmp_path: Path) -> None:
    from analyzer.outdir import only_run

    with pytest.raises(RuntimeError), only_run(tmp_path):
        raise RuntimeError("boom")
    with only_run(tmp_path):
        pass
    with pytest.raises(UsageError), only_run(tmp_path), only_run(tmp_path):
        pass


def test_a_config_saved_with_a_byte_order_mark_is_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Windows' Notepad saves UTF-8 with a BOM: it was `not valid TOML (... line 1,
    column 1)` while a CSV with a BOM reads fine."""
    cfg = tmp_path / "bom.toml"
    cfg.write_bytes(b"\xef\xbb\xbf[train]\nstart = 0.0\nend = 12.0\n")
    record = _five(tmp_path / "x.csv")
    code, _, err = run_cli(
        ["run", record, "--out", tmp_path / "o", "--config", cfg, "--no-progress"], capsys
    )
    assert code in (0, 1), err
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    assert doc["train"]["end_s"] == pytest.approx(12.0, abs=0.02)


def test_a_kept_corrected_csv_that_is_an_input_is_said_to_be_one(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``run rb/corrected.csv --out rb`` (no ``--corrected``) kept the input but gave a
    false reason: "no findings.json ... names it", when the second run's findings.json
    did."""
    record = _five(tmp_path / "rb" / "corrected.csv")
    before = _sha(record)
    argv = ["run", record, "--out", tmp_path / "rb", "--train", "0:12", "--no-progress"]
    for _ in range(2):
        code, _, err = run_cli(argv, capsys)
        assert code in (0, 1), err
    (line,) = [ln for ln in err.splitlines() if "left as it was" in ln]
    assert "it is an input or lies beside one" in line, line
    assert _sha(record) == before
