"""A finding whose onset is the first sample searched, right after the training window,
was there when the search began: findings.json (``evidence.onset_at_search_start``), the
report and the run's last line say it began at or before then. SKAB's pump: an onset of
719.000 s, the first sample after ``--train 0:718``, read as a fact ("since 17:39:18")
for a change the run's own note put at 581 s."""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_helpers import run_cli
from jsonschema import Draft202012Validator

from analyzer.schema import findings_schema
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

RATE = 50.0


def _archive(path, at_s: float):
    t, y, names = simulate_building(3, 60.0, RATE, seed=1)
    y[:, 1] = inject_fault(y[:, 1], RATE, "additive", at_s, 3.0 * float(np.std(y[:, 1])))
    write_archive(
        path, "csv", np.round(t * 1e9).astype(np.int64), dict(zip(names, y.T, strict=True))
    )
    return path


@pytest.mark.parametrize("at_s, bound", [(14.9, True), (36.0, False)])
def test_an_onset_at_the_search_start_is_an_upper_bound(tmp_path, capsys, at_s, bound):
    """An offset from 14.9 s with ``--train 0:15``: found from 15.020 s, the first
    sample searched; one from 36 s is found where it began, and said as it is."""
    out = tmp_path / "o"
    code, _, err = run_cli(
        ["run", _archive(tmp_path / "b.csv", at_s), "--train", "0:15", "--out", out], capsys
    )
    assert code == 1, err
    doc = json.loads((out / "findings.json").read_text())
    assert not list(Draft202012Validator(findings_schema()).iter_errors(doc))
    (f,) = doc["faults"]
    assert f["channel"] == "s1"
    assert bool(f["evidence"].get("onset_at_search_start")) is bound
    onset = f"{f['onset_s']:.3f} s"
    html = (out / "report.html").read_text()
    last = err.splitlines()[-1]
    if bound:
        assert f["onset_s"] == pytest.approx(15.02)
        # (the report rounds to the sample period, 2 decimals at 50 Hz; the run's line 3)
        assert f"at or before {f['onset_s']:.2f} s" in html
        assert "the first sample after the training window" in html
        assert f"s1 additive from {onset} or earlier;" in last
    else:
        assert "at or before" not in html
        assert f"s1 additive from {onset};" in last
