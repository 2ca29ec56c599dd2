"""Every report path the watcher printed stays valid and points to what it described:
new content under a recorded name (a late ``--group-by`` member after its group was
analyzed and moved, a file replaced) goes to the next free report folder; the earlier
result stays in the folder its lines announced. Before, the earlier folder was renamed
(``bridge-1``) and ``reports/bridge/`` then held the new analysis, so the lines already
printed ("bridge: fault (s4) ... reports/bridge/...") pointed to other data."""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path

import pytest
import test_watch_run
from test_watch_run import SETTLE, Watcher, state, write

from analyzer.watch import WatchSettings

# the fixtures of test_watch_run (found by pytest among this module's names)
folders = test_watch_run.folders
start_watcher = test_watch_run.start_watcher
_info_logs = test_watch_run._info_logs
_stop_fork_server = test_watch_run._stop_fork_server


def test_a_late_group_member_does_not_take_over_the_folder_already_announced(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    inbox, reports = folders
    done = tmp_path / "done"
    settings = WatchSettings(
        inbox,
        reports,
        settle=SETTLE,
        poll=0.1,
        done=done,
        once=True,
        group_by=re.compile(r"^(.*)_part[0-9]+\.csv$"),
    )
    write(inbox / "bridge_part0.csv", "csv", seed=1, fault=True)
    assert start_watcher(settings).join() == 1
    (line,) = [r.getMessage() for r in caplog.records if r.getMessage().startswith("bridge: fault")]
    announced = Path(line.rsplit("report: ", 1)[1])
    assert announced == reports / "bridge" / "report.html"
    before = announced.read_text()

    caplog.clear()
    write(inbox / "bridge_part1.csv", "csv", seed=2)  # (the late member, no fault)
    assert start_watcher(settings).join() == 0
    # the announced report is still the first analysis's, whole
    assert announced.read_text() == before
    first = json.loads((announced.parent / "findings.json").read_text())
    assert [Path(i["path"]).name for i in first["inputs"]] == ["bridge_part0.csv"]
    assert first["faults"]
    # the new one in the next free folder, said so on its line
    records = state(reports)
    assert records["bridge"]["report"] == "bridge-1/report.html"
    new = json.loads((reports / "bridge-1" / "findings.json").read_text())
    assert [Path(i["path"]).name for i in new["inputs"]] == ["bridge_part1.csv"]
    (kept,) = [name for name, r in records.items() if r.get("dropped_as") == "bridge"]
    assert records[kept]["report"] == "bridge/report.html"
    said = [r.getMessage() for r in caplog.records if "new content" in r.getMessage()]
    assert said == [
        f"bridge: new content; its report goes to {reports / 'bridge-1'} (the earlier "
        f"content's result stays in {reports / 'bridge'}, listed as {kept} in the index)"
    ]
    page = (reports / "index.html").read_text()
    assert "the latest result of this name" in page
    assert "dropped as bridge: an earlier content of that name" in page
