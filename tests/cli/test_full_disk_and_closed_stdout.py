"""The command line on a disk that fills while it writes, and with stdout closed (a QA
audit's ux59 items H1, H2 and M1): one line naming the file, exit code 2, and ``--out``
as it was.

The full disk is a seam (:mod:`full_disk` of the report tests): the ``k``-th output file
written into the folder meets ``No space left on device``, as on a real full file system,
without one (no root, no tmpfs)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from cli_helpers import one_line_error, run_cli

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "report"))
from full_disk import FullDisk, snapshot  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "samples" / "building_additive.mcap"


def _run(src: Path, out: Path, capsys: pytest.CaptureFixture[str], *more: str) -> tuple[int, str]:
    code, _, err = run_cli(
        ["run", src, "--out", out, "--train", "0:15", "--no-progress", *more], capsys
    )
    return code, err


def test_run_on_a_full_disk_leaves_the_earlier_pair_and_names_the_file(
    offset_csv: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """An earlier run's outputs in ``--out``; the second file of the new run meets a full
    disk. Before: the new findings.json beside the earlier report.html, and a line that
    named no file."""
    out = tmp_path / "o"
    assert _run(offset_csv, out, capsys, "--corrected")[0] == 1
    before = snapshot(out)
    disk = FullDisk(monkeypatch, out, 2)
    code, err = _run(offset_csv, out, capsys, "--corrected", "--train", "0:16")
    monkeypatch.undo()
    assert code == 2, err
    line = one_line_error(err, f"{out / str(disk.failed)}: No space left on device")
    assert "keeps an earlier run's" in line  # (all three: none was replaced)
    assert snapshot(out) == before


def test_run_corrected_on_a_full_disk_leaves_no_findings(
    offset_csv: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``--corrected`` into a new folder, ``corrected.csv`` (pyarrow's writer) meeting the
    full disk. Before: a findings.json naming a corrected.csv that was never written, and
    pyarrow's words ("Error writing bytes to file. Detail: [errno 28] ...") naming none."""
    out = tmp_path / "o"

    disk = FullDisk(monkeypatch, out, name="corrected.csv")
    code, err = _run(offset_csv, out, capsys, "--corrected")
    monkeypatch.undo()
    assert disk.failed == "corrected.csv", disk.written
    assert code == 2, err
    one_line_error(err, f"{out / 'corrected.csv'}: No space left on device")
    assert "Error writing bytes" not in err
    assert not out.exists() or list(out.iterdir()) == []


def test_run_save_model_on_a_full_disk_writes_nothing(
    offset_csv: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``--save-model`` into ``--out``: the model is one of the run's outputs, put in
    place with the others or not at all. Before, it was written after findings.json and
    report.html: a full disk at the model left both, naming a model file not there."""
    out = tmp_path / "o"
    out.mkdir()

    disk = FullDisk(monkeypatch, out, name="m.model")
    code, err = _run(offset_csv, out, capsys, "--save-model", str(out / "m.model"))
    monkeypatch.undo()
    assert disk.failed == "m.model", disk.written
    assert code == 2, err
    one_line_error(err, f"{out / 'm.model'}: No space left on device")
    assert list(out.iterdir()) == []


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_export_on_a_full_disk_names_its_file(
    offset_csv: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    suffix: str,
) -> None:
    """Before: ``analyzer: error: Error writing bytes to file. Detail: [errno 28] No
    space left on device`` (pyarrow's words), no file named."""
    target = tmp_path / "x" / f"e{suffix}"
    target.parent.mkdir()
    FullDisk(monkeypatch, target.parent, 1)
    code, _, err = run_cli(["export", offset_csv, "--out", target], capsys)
    assert code == 2, err
    one_line_error(err, f"analyzer: error: {target}: No space left on device")
    assert list(target.parent.iterdir()) == []


@pytest.mark.parametrize("form", [[], ["--json"]])
def test_inspect_with_stdout_closed_says_so(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, form: list[str]
) -> None:
    """A process started with stdout closed has ``sys.stdout`` None. Before: "internal
    error: AttributeError: 'NoneType' object has no attribute 'flush'"."""
    monkeypatch.setattr(sys, "stdout", None)
    code, _, err = run_cli(["inspect", SAMPLE, *form], capsys)
    assert code == 2, err
    line = one_line_error(err, "analyzer: error: stdout: closed")
    assert "internal error" not in line


def test_inspect_started_with_stdout_closed(tmp_path: Path) -> None:
    """The same, as a shell starts it (``>&-``)."""
    done = subprocess.run(
        f"'{sys.executable}' -m analyzer inspect '{SAMPLE}' --json >&-",
        shell=True,
        capture_output=False,
        stderr=subprocess.PIPE,
        text=True,
        cwd=REPO,
        timeout=120,
    )
    assert done.returncode == 2, done.stderr
    one_line_error(done.stderr, "analyzer: error: stdout: closed")
