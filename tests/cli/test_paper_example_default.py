"""Li et al. 2007's example through ``analyzer run`` with the default settings (ux57 item
1a): sensor 1 gives random data at 2-4 s and 6-8 s, sensor 2 reads zero at 4-6 s and
8-10 s (from the end of a 20 s training window).

With the default detection window (0.25 s at 250 Hz) the shared detector watches a long
window of 2 s, the paper's spacing: each sensor's two failures are one anomaly to it. The
dead-sensor rule cut sensor 2's at its first revival, and its second dead spell was
reported nowhere; it is now a finding of its own (:func:`analyzer.diagnosis.stuck.
dead_again`). Sensor 1's two bursts stay one finding at the default window (``other``,
2-8 s): a detection window of 0.1 s (``[detectors.error_function] window = 25``) keeps
them apart, as ``tests/detectors/test_error_function.py::test_paper_example`` runs it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import run_cli, schema_valid

from analyzer.simulate_mdof import chain_archive
from analyzer.writers import write_archive

TOL_S = 0.05
TRAIN_S = 20.0


def _run(tmp_path: Path, capsys: pytest.CaptureFixture[str], seed: int) -> list[dict]:
    arch = chain_archive(noise=0.01, seed=seed)
    t = np.arange(arch.values.shape[0]) / arch.rate_hz
    csv = tmp_path / "chain.csv"
    stamps = np.round(t * 1e9).astype(np.int64)
    write_archive(csv, "csv", stamps, {c: arch.values[:, j] for j, c in enumerate(arch.channels)})
    cfg = tmp_path / "c.toml"
    cfg.write_text(
        '[[group]]\nname = "chain"\nchannels = ["s1", "s2", "s3", "s4"]\n'
        'reference = ["s3", "s4"]\nuncertain = ["s1", "s2"]\ninputs = []\n'
    )
    argv = ["run", csv, "--out", tmp_path / "o", "--config", cfg, "--train", "0:20"]
    code, _, err = run_cli([*argv, "--detectors", "error_function", "--no-progress"], capsys)
    assert code == 1, err
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    schema_valid(doc)
    faults: list[dict] = doc["faults"]
    return faults


@pytest.mark.parametrize("seed", [0, 1])
def test_both_dead_spells_of_sensor_2_are_findings(tmp_path, capsys, seed):
    faults = _run(tmp_path, capsys, seed)
    dead = sorted(
        (f["onset_s"] - TRAIN_S, f["end_s"] - TRAIN_S) for f in faults if f["channel"] == "s2"
    )
    assert len(dead) == 2, dead
    for (onset, end), (a, b) in zip(dead, [(4.0, 6.0), (8.0, 10.0)], strict=True):
        assert abs(onset - a) <= TOL_S and abs(end - b) <= TOL_S, dead
    for f in faults:
        if f["channel"] == "s2":
            assert f["type"] == "multiplicative" and f["magnitude"]["gain"] == 0.0
    # sensor 1's random data: one shapeless finding over both bursts at this window
    s1 = [f for f in faults if f["channel"] == "s1"]
    assert [f["type"] for f in s1] == ["other"], s1
    assert abs(s1[0]["onset_s"] - TRAIN_S - 2.0) <= TOL_S
    assert abs(s1[0]["end_s"] - TRAIN_S - 8.0) <= TOL_S


def test_the_second_dead_spell_carries_evidence_of_its_own_stretch(tmp_path, capsys):
    """The second spell's finding does not copy the first's evidence (review rli54 M3):
    every time in it lies in its own spell, or is where the spell before it ended."""
    faults = _run(tmp_path, capsys, 0)
    first, second = sorted((f for f in faults if f["channel"] == "s2"), key=lambda f: f["onset_s"])
    ev = second["evidence"]
    lo, hi = second["onset_s"], second["end_s"]
    assert "by_detector" not in ev and "was" not in ev["frozen"], ev
    assert ev["frozen"]["previous_end_s"] == pytest.approx(first["end_s"], abs=TOL_S)
    assert ev["detectors"] == ["error_function"]
    spans = [t["after_span_s"] for t in ev.get("tests", {}).values()]
    for a, b in spans:
        assert lo - 1e-9 <= a <= b <= hi + 1e-9, (spans, lo, hi)
