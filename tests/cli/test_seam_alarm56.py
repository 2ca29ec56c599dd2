"""An alarm at a seam where the tool dropped samples is tied to that seam (ux62 MEDIUM
5): a file written 20 s early lost its overlap, the signal jumped where the files were
joined, and the run said "alarms not explained", blamed on "a change of the structure or
excitation" in its notes, with one stderr line per channel for what was dropped."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path

import numpy as np
import pytest

from analyzer.cli import main
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

RATE_HZ = 100.0
PIECE_S = 60.0
PIECES = 5
EARLY_S = 20.0  # the third file's clock: this far early (its first 20 s overlap)
START = dt.datetime(2026, 10, 1, tzinfo=dt.UTC)


def _archive(folder: Path) -> Path:
    """Five MCAP files of one minute (a 6-sensor building at 100 Hz, an offset of one
    standard deviation on s1 in the last), the third stamped :data:`EARLY_S` early."""
    folder.mkdir()
    _, y, names = simulate_building(3, 20 + PIECES * PIECE_S, RATE_HZ, seed=7, sensors_per_floor=2)
    y = y[int(20 * RATE_HZ) :]
    y[:, 1] = inject_fault(
        y[:, 1], RATE_HZ, "additive", (PIECES - 1) * PIECE_S + 10, np.std(y[:, 1])
    )
    per = int(PIECE_S * RATE_HZ)
    t_ns = np.round(np.arange(per) * (1e9 / RATE_HZ)).astype(np.int64)
    for k in range(PIECES):
        begin = START + dt.timedelta(seconds=k * PIECE_S - (EARLY_S if k == 2 else 0.0))
        part = y[k * per : (k + 1) * per]
        write_archive(
            folder / f"h{k:02d}.mcap",
            "mcap",
            t_ns,
            {n: part[:, i] for i, n in enumerate(names)},
            layout="multiarray",
            start_iso=begin.isoformat().replace("+00:00", "Z"),
        )
    return folder


def test_alarm_at_a_seam_with_dropped_samples_is_tied_to_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    archive = _archive(tmp_path / "site")
    code = main(["run", str(archive), "--out", str(tmp_path / "out"), "--no-progress"])
    err = capsys.readouterr().err
    assert code == 1
    dropped = [line for line in err.splitlines() if "overlap the previous input" in line]
    assert dropped == [
        f"analyzer: warning: {archive / 'h02.mcap'}: /data: 2000 messages overlap the previous "
        "input in time (20 s that h01.mcap covers already; its samples are kept); dropped"
    ]
    # the third file ends 20 s before the fourth begins: a gap between files, said as one
    # (it read as a sensor that stopped, in seconds only: ux62 LOW 10)
    (silent,) = [line for line in err.splitlines() if "silent mid-record" in line]
    assert (
        "/data: no sample from 159.990 to 180.000 s (20.01 s: about 2000 samples missing at "
        "100 Hz; no file covers it from 2026-10-01T00:02:39.990Z to 2026-10-01T00:03:00.000Z "
        "(between h02.mcap and h03.mcap))"
    ) in silent
    seam = "the seam of h01.mcap and h02.mcap, where 2000 overlapping messages were dropped"
    last = err.splitlines()[-1]
    assert "additive from 250.000 s" in last
    assert (
        f"alarms not explained at 120.0 s (2026-10-01T00:02:00.000Z), on 4 sensors, at {seam}"
        in (last)
    )
    doc = json.loads((tmp_path / "out" / "findings.json").read_text())
    (alarm,) = doc["unexplained_alarms"]
    assert alarm["seam"] == seam
    said = [n for n in doc["notes"] if n.startswith("anomaly at 120.0 s")]
    assert said and all(seam in n and "structure or excitation" not in n for n in said)
