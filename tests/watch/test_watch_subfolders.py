"""A folder dropped into the inbox holding day folders is one archive, and the analysis
reads the subfolders' files: a half-copied file in one of them makes the archive
unfinished, as it does at the top (the structure check looked at the top level only)."""

from pathlib import Path

from analyzer.watch_inbox import incomplete_reason
from tests.watch.test_watch_inbox import small_archive


def test_a_half_written_file_in_a_day_folder_is_unfinished(tmp_path: Path) -> None:
    drop = tmp_path / "site_a"
    (drop / "2026-03-29").mkdir(parents=True)
    (drop / "2026-03-30").mkdir()
    (drop / "empty_for_later").mkdir()
    small_archive(drop / "2026-03-29" / "h00.mcap", "mcap")
    full = small_archive(drop / "2026-03-30" / "h00.mcap", "mcap")
    assert incomplete_reason(drop) is None
    data = full.read_bytes()
    full.write_bytes(data[: len(data) // 2])
    assert incomplete_reason(drop) == (
        "2026-03-30/h00.mcap: MCAP file without its closing magic (still being written?)"
    )


def test_a_folder_with_nothing_in_it_is_still_being_filled(tmp_path: Path) -> None:
    (tmp_path / "d" / "sub").mkdir(parents=True)
    assert incomplete_reason(tmp_path / "d" / "sub") == "empty directory"
    assert incomplete_reason(tmp_path / "d") is None  # a folder with an empty folder


def test_links_to_a_parent_folder_are_walked_once(tmp_path: Path) -> None:
    """Two links to a parent made the walk exponential: `watch` hung, deaf to SIGTERM
    (review of this change)."""
    day = tmp_path / "drop" / "day1"
    day.mkdir(parents=True)
    small_archive(day / "h00.mcap", "mcap")
    (day / "up").symlink_to("..")
    (day / "up2").symlink_to("..")
    (tmp_path / "drop" / "old.bak").mkdir()
    (tmp_path / "drop" / "old.bak" / "half.mcap").write_bytes(b"\x89MCAP0\r\n")
    assert incomplete_reason(tmp_path / "drop") is None
