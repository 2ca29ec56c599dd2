"""A run's outputs put in place all or none even when a rename itself fails (the
integrator's audit, int56 item 1): out55 wrote every file under a temporary name before
renaming any, but a rename failing part-way (a disk's error, a folder made read-only)
left the files renamed already beside the earlier run's others.

The failing rename is a seam: ``os.replace`` of the ``k``-th temporary output file (a
hidden name in ``--out``) onto its place raises, as a file system's error would."""

from __future__ import annotations

import errno
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from cli_helpers import one_line_error, run_cli

from analyzer.outdir import staged


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file in ``folder`` (hidden ones too) and its bytes."""
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


class FailingRename:
    """``os.replace`` of a hidden temporary file in ``folder`` onto a visible name there
    (a staged output put in place) fails the ``fail_at``-th time with ``exc``; every
    other call is the real one. :attr:`renamed` lists the places renamed onto."""

    def __init__(
        self,
        monkeypatch: pytest.MonkeyPatch,
        folder: Path,
        fail_at: int,
        exc: Callable[[], BaseException] = lambda: OSError(errno.EIO, os.strerror(errno.EIO)),
    ) -> None:
        self.renamed: list[str] = []
        self.failed: str | None = None
        real = os.replace
        place = folder.resolve()

        def replace(src: Any, dst: Any, *args: Any, **kw: Any) -> None:
            s, d = Path(os.fspath(src)), Path(os.fspath(dst))
            if (
                self.failed is None
                and s.name.startswith(".")
                and not d.name.startswith(".")
                and s.parent.resolve() == place == d.parent.resolve()
            ):
                self.renamed.append(d.name)
                if len(self.renamed) == fail_at:
                    self.failed = d.name
                    raise exc()
            real(src, dst, *args, **kw)

        monkeypatch.setattr(os, "replace", replace)


def _no_links(monkeypatch: pytest.MonkeyPatch) -> None:
    """A file system without hard links (FAT, some network file systems)."""

    def link(*args: Any, **kw: Any) -> None:
        raise OSError(errno.EPERM, os.strerror(errno.EPERM))

    monkeypatch.setattr(os, "link", link)


def _run(src: Path, out: Path, capsys: pytest.CaptureFixture[str], *more: str) -> tuple[int, str]:
    code, _, err = run_cli(["run", src, "--out", out, "--no-progress", *more], capsys)
    return code, err


@pytest.mark.parametrize("links", [True, False], ids=["links", "no-links"])
def test_a_failed_second_rename_leaves_the_earlier_run_byte_for_byte(
    offset_csv: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    links: bool,
) -> None:
    """An earlier run's three files; the new run's second rename (``report.html``, after
    ``corrected.csv``) fails. Before: the new corrected.csv beside the earlier
    report.html and findings.json."""
    out = tmp_path / "o"
    assert _run(offset_csv, out, capsys, "--corrected", "--train", "0:15")[0] == 1
    before = snapshot(out)
    assert sorted(before) == ["corrected.csv", "findings.json", "report.html"]
    if not links:
        _no_links(monkeypatch)
    seam = FailingRename(monkeypatch, out, 2)
    code, err = _run(offset_csv, out, capsys, "--corrected", "--train", "0:16")
    monkeypatch.undo()
    assert seam.renamed == ["corrected.csv", "report.html"]
    assert code == 2, err
    one_line_error(err, f"{out / 'report.html'}: Input/output error", "keeps an earlier run's")
    assert snapshot(out) == before


def test_a_failed_rename_into_a_new_folder_leaves_nothing(
    offset_csv: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """No earlier run: the new files renamed before the failure are taken out again.
    Before: a lone corrected.csv."""
    out = tmp_path / "o"
    out.mkdir()
    FailingRename(monkeypatch, out, 2)
    code, err = _run(offset_csv, out, capsys, "--corrected", "--train", "0:15")
    monkeypatch.undo()
    assert code == 2, err
    assert snapshot(out) == {}


def test_a_failed_rename_keeps_the_earlier_corrected_csv_too(
    offset_csv: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A run without ``--corrected`` removes the earlier run's corrected.csv: with the
    renames, so a failed one (``findings.json``'s, the second) leaves it with its pair.
    Before: the new report.html beside the earlier findings.json and corrected.csv."""
    out = tmp_path / "o"
    assert _run(offset_csv, out, capsys, "--corrected", "--train", "0:15")[0] == 1
    before = snapshot(out)
    seam = FailingRename(monkeypatch, out, 2)
    code, err = _run(offset_csv, out, capsys, "--train", "0:16")
    monkeypatch.undo()
    assert seam.failed == "findings.json", seam.renamed
    assert code == 2, err
    assert snapshot(out) == before


def test_after_a_run_no_earlier_file_is_left_aside(
    offset_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The earlier files kept aside while the new ones are renamed in are removed after
    the last rename; an earlier corrected.csv a run was not asked for is gone."""
    out = tmp_path / "o"
    assert _run(offset_csv, out, capsys, "--corrected", "--train", "0:15")[0] == 1
    code, err = _run(offset_csv, out, capsys, "--train", "0:16")
    assert code == 1, err
    assert sorted(snapshot(out)) == ["findings.json", "report.html"]
    assert '"start_s": 0.0,\n    "end_s": 16.0' in (out / "findings.json").read_text()


@pytest.mark.parametrize("links", [True, False], ids=["links", "no-links"])
def test_an_interrupt_between_renames_puts_the_earlier_files_back(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, links: bool
) -> None:
    """Ctrl-C (or SIGTERM, raised as an interrupt) between two renames: the same undo."""
    (tmp_path / "a").write_text("earlier a")
    (tmp_path / "c").write_text("earlier c")
    before = snapshot(tmp_path)
    if not links:
        _no_links(monkeypatch)
    FailingRename(monkeypatch, tmp_path, 3, exc=KeyboardInterrupt)
    with pytest.raises(KeyboardInterrupt), staged() as files:
        for name in "abc":
            files.write(tmp_path / name, f"new {name}")
        files.commit()
    monkeypatch.undo()
    assert snapshot(tmp_path) == before


def test_a_reader_never_finds_an_output_missing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Where the file system has links, each earlier file stays at its name until the
    new one replaces it (kept aside as a second link): a reader polling for
    ``findings.json`` finds the earlier or the new one at every rename."""
    for name in ("report.html", "findings.json"):
        (tmp_path / name).write_text(f"earlier {name}")
    seen: list[bool] = []
    real = os.replace

    def replace(src: Any, dst: Any, *args: Any, **kw: Any) -> None:
        seen.append(all((tmp_path / n).is_file() for n in ("report.html", "findings.json")))
        real(src, dst, *args, **kw)

    monkeypatch.setattr(os, "replace", replace)
    with staged() as files:
        files.write(tmp_path / "report.html", "new")
        files.write(tmp_path / "findings.json", "new")
        files.commit()
    monkeypatch.undo()
    assert seen == [True, True]
    assert snapshot(tmp_path) == {"findings.json": b"new", "report.html": b"new"}
