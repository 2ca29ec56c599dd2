"""A logger outage in a run (analyzer.outage through the pipeline): a simulated 6-channel
building whose every channel reads exactly 0.0 for 2 s (the logger wrote zeros) had a
fault blamed on s2 by the equivalent model (multiplicative from 25.01 s, gain 0.008);
with the logger's last row repeated instead, an anomaly "attributed to no sensor". Now
those rows are missing data and a note says so, and the real offset on s4 from 40 s is
found as before, serially, on two threads, and memory-mapped with the outage across
two blocks of the scan."""

from __future__ import annotations

import json

import numpy as np
import pytest

from analyzer.cli import main
from analyzer.pipeline import RunOptions, analyze
from analyzer.simulate import inject_fault, simulate_building

RATE = 100.0
OUT = slice(2500, 2700)  # 25.00-27.00 s, after the default training window (0-12 s)
ZERO_NOTE = (
    "logger outage: all 6 channels read exactly 0.0 from 25.00 s to 27.00 s (200 rows; "
    "the data acquisition, not a sensor); treated as missing data"
)
FROZEN_NOTE = (
    "logger outage: all 6 channels repeated their values of 24.99 s exactly from 25.00 s "
    "to 27.00 s (200 rows; the data acquisition, not a sensor); treated as missing data"
)


def _building(tmp_path, outage: str) -> str:
    """The building with a +2 sd offset on s4 from 40 s and the outage ``zeros`` or
    ``frozen`` at 25-27 s, as a CSV."""
    t, y, names = simulate_building(3, 60.0, RATE, seed=1, sensors_per_floor=2)
    y[:, 4] = inject_fault(y[:, 4], RATE, "additive", 40.0, 2.0 * y[:, 4].std())
    if outage == "zeros":
        y[OUT] = 0.0
    else:
        y[OUT] = y[OUT.start - 1]
    path = tmp_path / f"{outage}.csv"
    header = "time," + ",".join(names)
    np.savetxt(path, np.column_stack([t, y]), delimiter=",", header=header, comments="", fmt="%.9g")
    return str(path)


def _only_the_offset_on_s4(faults) -> None:
    assert [(f["channel"], f["type"]) for f in faults] == [("s4", "additive")], faults
    assert faults[0]["onset_s"] == pytest.approx(40.0, abs=0.05)


def test_an_all_zero_outage_blames_no_sensor_and_is_noted(tmp_path, capsys):
    out = tmp_path / "out"
    code = main(["run", _building(tmp_path, "zeros"), "--out", str(out), "--no-progress"])
    doc = json.loads((out / "findings.json").read_text())
    _only_the_offset_on_s4(doc["faults"])
    assert code == 1
    assert ZERO_NOTE in doc["notes"]
    assert ZERO_NOTE in (out / "report.html").read_text()
    assert f"analyzer: warning: {ZERO_NOTE}" in capsys.readouterr().err


def test_rows_repeated_by_a_hung_logger_are_no_unattributed_anomaly(tmp_path):
    a = analyze([_building(tmp_path, "frozen")], RunOptions(jobs=1))
    _only_the_offset_on_s4(
        [{"channel": f.channel, "type": str(f.type), "onset_s": f.onset_s} for f in a.findings]
    )
    assert FROZEN_NOTE in a.notes
    assert not any("attributed to no sensor" in n for n in a.notes), a.notes
    assert np.isnan(np.asarray(a.values)[OUT]).all()
    assert np.isfinite(np.asarray(a.values)[: OUT.start]).all()


@pytest.mark.parametrize("outage", ["zeros", "frozen"])
def test_two_threads_and_a_memory_mapped_record_cut_in_blocks_give_the_serial_run(
    tmp_path, monkeypatch, findings_of, same_findings, outage
):
    import analyzer.outage
    import analyzer.pipeline as pl

    path = _building(tmp_path, outage)
    serial = analyze([path], RunOptions(jobs=1))
    threads = analyze([path], RunOptions(jobs=2))
    # the aligned matrix memory-mapped, scanned in blocks of 2600 rows: the outage
    # (rows 2500-2699) lies across the first boundary
    monkeypatch.setattr(pl, "MATERIALIZE_IN_MEMORY", 1000)
    monkeypatch.setattr(analyzer.outage, "SCAN_VALUES", 2600 * 6)
    work = tmp_path / "work"
    work.mkdir()
    paged = analyze([path], RunOptions(jobs=2), workdir=work)
    assert isinstance(paged.values, np.memmap)
    note = ZERO_NOTE if outage == "zeros" else FROZEN_NOTE
    for a in (serial, threads, paged):
        assert note in a.notes
        assert [(f.channel, str(f.type)) for f in a.findings] == [("s4", "additive")]
    same_findings(findings_of(threads), findings_of(serial))
    same_findings(findings_of(paged), findings_of(serial))
    assert np.array_equal(np.asarray(paged.values), np.asarray(serial.values), equal_nan=True)
