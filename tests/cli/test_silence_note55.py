"""An analyzed sensor that stops for a while mid-record is said in text (the robotics
audit ux58 item 6: a 200 Hz IMU silent for 5 s while the other topics went on showed
only as ``gaps: 1`` and a mark on the coverage chart)."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np
from cli_helpers import run_to, said, schema_valid

from analyzer.readers.base import ChannelChunk
from analyzer.simulate import inject_fault, simulate_building
from analyzer.store import ChannelStore
from analyzer.writers import write_archive

RATE = 200.0


def _building(seconds: float = 120.0) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """A 4-floor building at 200 Hz with an offset on ``s2`` from 80 s."""
    t, y, names = simulate_building(n_floors=4, duration_s=seconds, seed=2)
    y[:, 2] = inject_fault(y[:, 2], RATE, "additive", 80.0, 3.0 * np.std(y[:, 2]))
    return t, y, names


def test_a_csv_column_silent_for_5_s_is_said(tmp_path, capsys):
    t, y, names = _building()
    y[(t >= 50.0) & (t < 55.0), 1] = np.nan  # blank cells: no sample
    path = tmp_path / "gap.csv"
    write_archive(
        path, "csv", np.round(t * 1e9).astype(np.int64), {n: y[:, j] for j, n in enumerate(names)}
    )
    code, err, doc, out = run_to(tmp_path, capsys, path, "--jobs", "1")
    assert code == 1, err
    schema_valid(doc)
    (line,) = [ln for ln in said(err) if "silent mid-record" in ln]
    expected = (
        "s1: no sample from 49.995 to 55.000 s (5.005 s: about 1000 samples missing at "
        "200 Hz) while s0, s2 and 1 more went on"
    )
    assert expected in line
    assert "longer than 50 sample periods or 1 % of the record" in line
    assert any(expected in n for n in doc["notes"])
    assert expected in html.unescape((out / "report.html").read_text())


def test_an_imu_topic_silent_for_5_s_is_said_by_its_topic(tmp_path, capsys):
    """A folder of two MCAPs recorded together: the IMU topics in one (silent from 50 to
    55 s), a fourth sensor in the other, which goes on."""
    t, y, names = _building()
    t_ns = 1_780_000_000_000_000_000 + np.round(t * 1e9).astype(np.int64)
    keep = (t < 50.0) | (t >= 55.0)
    folder = tmp_path / "rec"
    folder.mkdir()
    write_archive(
        folder / "imu.mcap",
        "mcap",
        t_ns[keep],
        {n: y[keep, j] for j, n in enumerate(names[:3])},
        layout="imu",
    )
    write_archive(folder / "other.mcap", "mcap", t_ns, {"s3": y[:, 3]})
    code, err, doc, _ = run_to(tmp_path, capsys, folder, "--jobs", "1")
    assert code == 1, err
    (line,) = [ln for ln in said(err) if "silent mid-record" in ln]
    assert (
        "/imu0: no sample from 49.995 to 55.000 s (5.005 s: about 1000 samples missing at "
        "200 Hz) while /s3 went on"
    ) in line, line


def test_short_dropouts_are_not_said(tmp_path, capsys):
    """Three messages lost every 2 s are gaps by the store's rule, far below a
    silence: nothing said (no flood)."""
    t, y, names = _building(60.0)
    k = np.arange(t.size)
    y[(k % 400) < 3, 1] = np.nan
    path = tmp_path / "drops.csv"
    write_archive(
        path, "csv", np.round(t * 1e9).astype(np.int64), {n: y[:, j] for j, n in enumerate(names)}
    )
    code, err, doc, _ = run_to(tmp_path, capsys, path, "--jobs", "1")
    assert code in (0, 1), err
    assert next(c for c in doc["channels"] if c["name"] == "s1")["gaps"] > 10
    assert not any("silent mid-record" in n for n in doc["notes"])


def test_many_silent_channels_are_capped(tmp_path):
    """Ten channels silent at different times: one line, ``LISTED`` named."""
    from analyzer.silence_note import LISTED, silence_note  # (new: not on the base)

    t = np.arange(0, 100 * 600, dtype=np.int64) * 10_000_000  # 600 s at 100 Hz
    chunks = []
    for c in range(10):
        keep = (t < (100 + 30 * c) * 10**9) | (t >= (110 + 30 * c) * 10**9)
        chunks.append(ChannelChunk(f"c{c}", t[keep], np.ones(int(keep.sum()))))
    with ChannelStore.from_chunks(chunks, tmp_path) as store:
        (note,) = silence_note(store, [f"c{c}" for c in range(10)], (), 0, 600.0)
    assert note.count("no sample from") == LISTED
    assert note.count("; ") == LISTED  # between the items, and before the closing clause
    assert f"and {10 - LISTED} more channels with such silences" in note
    assert "c0: no sample from 99.990 to 110.000 s (10.01 s" in note


def test_readme_states_the_rule():
    """The rule is in the README, as the note says it."""
    readme = " ".join((Path(__file__).resolve().parents[2] / "README.md").read_text().split())
    assert "silent mid-record" in readme
    assert "50 sample periods or 1 % of the record" in readme
