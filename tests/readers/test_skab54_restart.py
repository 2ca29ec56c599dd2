"""Audit follow-up of csv53a (ux55 item 2): a logger restarted in a file of relative
times was refused only where its counter started again within 2 s of the file's first
time. A counter that starts again at 5 s or 37 s (the logger's boot taking that long)
was sorted in over the stretch before, one value kept at each time. The rule now: a
run of rows that steps back more than half the way to the file's first time (nearer to
it than to the latest time read) and counts on over the times already read is a
restart, refused the same way. A smaller step back is sorted in and said, as before.
The files are written from the package's simulated building (5 floors, 50 Hz)."""

from __future__ import annotations

from pathlib import Path

import pytest
from readers_helpers import read
from test_csv_time_folds53 import _restarted
from test_two_clocks import _refused


@pytest.mark.parametrize(("again", "back"), [(5.0, "2.4 min"), (37.0, "113 s")])
def test_a_restart_past_the_first_time_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], again: float, back: str
) -> None:
    path = _restarted(tmp_path / "reboot.csv", start=0.0, again=again)
    _, info = read(path)
    said = (
        f"the time column 'time' steps back by {back} at data row 7501 "
        f"('{again:.3f}': from 149.980 s to {again:.3f} s), more than half the way back to "
        "the time of its first row (0.000 s), and counts on over the times already read: "
        "a logger restarted, its clock counting from its start again?"
    )
    assert info.set_back.startswith(said), info.set_back
    for err in _refused(path, tmp_path, capsys):
        assert err.startswith(f"analyzer: error: {path}: {said}"), err


def test_a_step_back_of_less_than_half_the_times_read_is_sorted_in(tmp_path: Path) -> None:
    """Back from 149.98 s to 100 s (a third of the times read): nearer to the latest time
    than to the first, no restart by the rule; sorted in and said, as before."""
    path = _restarted(tmp_path / "late.csv", start=0.0, again=100.0)
    _, info = read(path)
    assert info.set_back == ""
    assert any("steps back by 50 s" in e for e in info.errors), info.errors
