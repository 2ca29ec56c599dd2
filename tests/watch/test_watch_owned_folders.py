"""Audit of the watcher: publishing a report replaced whatever folder of REPORTS had the
archive's name, and deleted it: a user's folder with notes, or, with INBOX inside
REPORTS (``watch inbox --out .``), the archives of INBOX itself. An output folder inside
an archive folder of INBOX left that archive silently unanalyzed and wrote into it."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

from analyzer.cli import main
from analyzer.watch_index import publish


def _scratch(reports: Path, text: str) -> Path:
    scratch = reports / f".tmp-{text}"
    scratch.mkdir()
    (scratch / "report.html").write_text(text)
    (scratch / "findings.json").write_text("{}")
    return scratch


def test_a_folder_that_is_no_report_is_never_replaced(tmp_path: Path) -> None:
    reports = tmp_path / "reports"
    (reports / "precious").mkdir(parents=True)
    (reports / "precious" / "notes.txt").write_text("my notes")
    first = publish(_scratch(reports, "one"), reports, "precious")
    assert first == reports / "precious-report"
    assert (reports / "precious" / "notes.txt").read_text() == "my notes"
    # the archive's next report replaces its own folder, named by its record
    again = publish(_scratch(reports, "two"), reports, "precious", previous="precious-report")
    assert again == first and (first / "report.html").read_text() == "two"
    # a folder of report files only is one of the watcher's: replaced as before
    (reports / "other").mkdir()
    (reports / "other" / "error.txt").write_text("old")
    assert publish(_scratch(reports, "three"), reports, "other") == reports / "other"
    assert not (reports / "other" / "error.txt").exists()
    assert sorted(p.name for p in reports.iterdir()) == ["other", "precious", "precious-report"]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["{inbox}", "--out", "{tmp}"], r"INBOX: .* is inside REPORTS"),
        (["{inbox}", "--out", "{inbox}/proj/reports"], r"--out: .* inside the archive folder"),
        (
            ["{inbox}", "--out", "{tmp}/r", "--done", "{inbox}/proj/done"],
            r"--done: .* inside the archive folder .*/proj of INBOX",
        ),
    ],
)
def test_folders_that_would_take_an_archive_s_place_are_refused(
    argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    inbox = tmp_path / "inbox"
    (inbox / "proj").mkdir(parents=True)
    (inbox / "proj" / "a.csv").write_text("time,a\n0,1\n")
    args = [a.format(inbox=inbox, tmp=tmp_path) for a in argv]
    assert main(["watch", *args, "--once"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and re.search(message, err), err
    assert sorted(p.name for p in (inbox / "proj").iterdir()) == ["a.csv"]


def test_a_move_to_another_file_system_is_all_or_none(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Audit: ``--done`` on a full file system left a truncated copy of the archive's
    second file in done/, and split the archive (its first file moved, the second left
    in INBOX, then analyzed alone as the archive)."""
    import errno
    import tempfile

    from analyzer import watch

    shm = Path("/dev/shm")
    if not shm.is_dir() or os.stat(shm).st_dev == os.stat(tmp_path).st_dev:
        monkeypatch.setattr(watch, "_other_fs", lambda paths, folder: True)  # (as if)
        shm = tmp_path
    inbox = tmp_path / "in"
    inbox.mkdir()
    files = [inbox / "day1_h0.csv", inbox / "day1_h1.csv"]
    for i, f in enumerate(files):
        f.write_text(f"time,a\n0,{i}\n")
    with tempfile.TemporaryDirectory(dir=shm) as folder:
        done = Path(folder)
        copy = watch._copy_file

        def full_on_second(src: Path, dst: Path, cancel: object) -> None:
            if src.name == "day1_h1.csv":
                dst.write_text("time,")  # (what a full disk leaves)
                raise OSError(errno.ENOSPC, "No space left on device", str(dst))
            copy(src, dst, cancel)  # type: ignore[arg-type]

        monkeypatch.setattr(watch, "_copy_file", full_on_second)
        with pytest.raises(OSError):
            watch._move_all(files, done)
        assert list(done.iterdir()) == [] and all(f.is_file() for f in files)
        monkeypatch.setattr(watch, "_copy_file", copy)
        moved = watch._move_all(files, done)
        assert [p.name for p in moved] == ["day1_h0.csv", "day1_h1.csv"]
        assert not any(f.exists() for f in files) and moved[1].read_text() == "time,a\n0,1\n"


def test_a_link_is_moved_as_a_link_and_a_source_that_stays_keeps_no_copy(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Review: the file system was told by the link's target (a link in INBOX on another
    file system than its target failed with EXDEV), and a source that could not be
    removed left its copy in done/ and the other copies as hidden ``.partial-`` files."""
    import errno
    import tempfile

    from analyzer import watch

    shm = Path("/dev/shm")
    if not shm.is_dir() or os.stat(shm).st_dev == os.stat(tmp_path).st_dev:
        pytest.skip("no second file system to move to")
    done = tmp_path / "done"
    done.mkdir()
    with tempfile.TemporaryDirectory(dir=shm) as folder:
        inbox = Path(folder)
        data = tmp_path / "data.csv"
        data.write_text("time,a\n0,1\n")
        (inbox / "a.csv").symlink_to(data)
        (moved,) = watch._move_all([inbox / "a.csv"], done)
        assert moved.is_symlink() and moved.read_text() == "time,a\n0,1\n"
        assert not os.path.lexists(inbox / "a.csv")
        paths = [inbox / "run_a.csv", inbox / "run_b.csv"]
        for p in paths:
            p.write_text("time,a\n0,1\n")
        unlink = Path.unlink

        def read_only(self: Path, missing_ok: bool = False) -> None:
            if self.parent == inbox:
                raise OSError(errno.EROFS, "Read-only file system", str(self))
            unlink(self, missing_ok=missing_ok)

        monkeypatch.setattr(Path, "unlink", read_only)
        with pytest.raises(OSError):
            watch._move_all(paths, done)
        monkeypatch.setattr(Path, "unlink", unlink)
        assert sorted(p.name for p in done.iterdir()) == ["a.csv"]
        assert all(p.is_file() for p in paths)


@pytest.mark.parametrize("name", ["_" + "a" * 254, "a" * 250])
def test_a_report_folder_name_fits_the_file_system(tmp_path: Path, name: str) -> None:
    """Review: ``_`` + a 255-byte name, or ``NAME-report`` of a 250-byte one, was too
    long a folder name: the report could not be written, at every start."""
    reports = tmp_path / "reports"
    reports.mkdir()
    if not name.startswith("_"):
        (reports / name).mkdir()
        (reports / name / "notes.txt").write_text("a user's")
    final = publish(_scratch(reports, "x"), reports, name)
    assert len(os.fsencode(final.name)) <= 255 and (final / "report.html").is_file()
    assert final.name.lstrip("_").startswith(name.lstrip("_")[:200])
