"""A run's outputs are put in place all together or not at all (a QA audit's ux59 items
H1 and M1): a disk that fills while ``findings.json``, ``report.html`` and
``corrected.csv`` are written leaves the folder as it was, every temporary file removed,
and the error names the file it met. Before, a full disk at ``report.html`` left a new,
valid ``findings.json`` behind exit code 2 (beside an earlier run's report, or naming a
``corrected.csv`` never written), and the error said only ``No space left on device``."""

from __future__ import annotations

import errno
import json
from pathlib import Path

import numpy as np
import pytest
from full_disk import FullDisk, snapshot

from analyzer.findings import Analysis, write_outputs
from analyzer.report.synthetic import SyntheticFault, synthetic_analysis
from analyzer.types import FaultType

OUTPUTS = ("findings.json", "report.html", "corrected.csv")


def _analysis(offset: float, corrected: bool = True) -> Analysis:
    """A small analysis with one fault of size ``offset``, and its corrected signals."""
    a = synthetic_analysis(
        120.0, 3, 50.0, [SyntheticFault(1, FaultType.ADDITIVE, 60.0, None, offset)]
    )
    if corrected:
        a.corrected = np.asarray(a.values, dtype=np.float64) - offset
    return a


@pytest.fixture
def earlier(tmp_path: Path) -> tuple[Path, dict[str, bytes]]:
    """A folder holding an earlier run's three outputs, and their bytes."""
    out = tmp_path / "out"
    out.mkdir()
    write_outputs(_analysis(1.0), out)
    files = snapshot(out)
    assert sorted(files) == sorted(OUTPUTS)
    return out, files


@pytest.mark.parametrize("fail_at", [1, 2, 3])
def test_a_full_disk_at_any_output_leaves_the_earlier_run_s_files(
    earlier: tuple[Path, dict[str, bytes]], monkeypatch: pytest.MonkeyPatch, fail_at: int
) -> None:
    out, before = earlier
    disk = FullDisk(monkeypatch, out, fail_at)
    with pytest.raises(OSError) as caught:
        write_outputs(_analysis(2.0), out)
    monkeypatch.undo()
    assert disk.failed in OUTPUTS, disk.written
    assert snapshot(out) == before, f"failed at {disk.failed} of {disk.written}"
    assert caught.value.errno == errno.ENOSPC
    # the error names the file it could not write, in the system's words (M1)
    assert caught.value.filename == str(out / disk.failed), (caught.value, disk.written)
    assert caught.value.strerror == "No space left on device"


def test_a_full_disk_leaves_no_findings_in_a_new_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The second file written fails: nothing of the run is left, not even hidden."""
    out = tmp_path / "new"
    out.mkdir()
    disk = FullDisk(monkeypatch, out, 2)
    with pytest.raises(OSError, match="No space left on device"):
        write_outputs(_analysis(2.0), out)
    assert disk.failed is not None
    assert list(out.iterdir()) == []


def test_an_interrupt_while_writing_leaves_the_earlier_run_s_files(
    earlier: tuple[Path, dict[str, bytes]], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Ctrl-C (or SIGTERM, which ``run`` unwinds the same way) between two files."""
    import analyzer.findings as findings

    out, before = earlier
    real = findings.write_corrected_csv

    def interrupted(*args: object, **kw: object) -> object:
        raise KeyboardInterrupt

    monkeypatch.setattr(findings, "write_corrected_csv", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_outputs(_analysis(2.0), out)
    assert snapshot(out) == before
    monkeypatch.setattr(findings, "write_corrected_csv", real)


def test_written_whole_the_new_outputs_replace_the_earlier(
    earlier: tuple[Path, dict[str, bytes]], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The same seam, failing nothing: the three files are this run's, and nothing
    else is left in the folder."""
    out, before = earlier
    disk = FullDisk(monkeypatch, out, 0)
    doc = write_outputs(_analysis(2.0), out)
    assert sorted(disk.written) == sorted(OUTPUTS)
    after = snapshot(out)
    assert sorted(after) == sorted(OUTPUTS)
    assert all(after[name] != before[name] for name in OUTPUTS)
    assert json.loads(after["findings.json"]) == doc
    assert doc["corrected_csv"] == "corrected.csv"
