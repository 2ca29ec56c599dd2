"""A gain fault on a record sampled far above its content (a 4-floor building, content
below ~12 Hz, logged at 2 kHz).

The detectors' models have a memory counted in samples (the AR bank's order of at most 10,
the equivalent model's lags, the detection filter's AR order): at 2 kHz 10 samples are
5 ms, against modes of 1-6 Hz. Their one-step innovations are then mostly measurement
noise, a sensor whose readings shrink stays consistent with its own history, and the
leave-one-out estimates from the other sensors are poor (the AR bank's healthy residual
of a sensor is 0.45 of its spread at 2 kHz, 0.13 at 200 Hz). The fault is missed or
blamed on a neighbour; aligned at 200 Hz (``--rate 200``, the store's low-pass and
decimation) the same record is found by all three detectors.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from run_helpers import run_csv

from analyzer.simulate import inject_fault, simulate_building

RATE = 2000.0
ONSET = 30.0


def _record() -> tuple[np.ndarray, np.ndarray, list[str]]:
    t, y, names = simulate_building(n_floors=4, duration_s=60.0, rate_hz=RATE, seed=3)
    y[:, 2] = inject_fault(y[:, 2], RATE, "multiplicative", ONSET, 0.5)
    return t, y, names


def _gain_on_s2(faults: list[dict]) -> None:
    assert [(f["channel"], f["type"]) for f in faults] == [("s2", "multiplicative")], faults
    assert abs(faults[0]["onset_s"] - ONSET) < 1.0
    assert faults[0]["magnitude"]["gain"] == pytest.approx(0.5, abs=0.05)


def test_the_run_names_the_rate_at_which_the_gain_is_found(tmp_path: Path, capsys) -> None:
    # the workaround until the detectors' memory follows the clock: the run's note
    # (and stderr) names a --rate, at which the same record shows the gain
    t, y, names = _record()
    for part in ("first", "second"):
        (tmp_path / part).mkdir()
    run_csv(tmp_path / "first", t, y, names, code=0)
    doc = json.loads((tmp_path / "first" / "out" / "findings.json").read_text())
    (note,) = [n for n in doc["notes"] if "sampled at 2000 Hz" in n]
    rate = re.search(r"--rate (\S+) aligns", note)
    assert rate is not None and rate.group(1) == "200", note
    assert "--rate 200" in capsys.readouterr().err
    _gain_on_s2(run_csv(tmp_path / "second", t, y, names, options=("--rate", rate.group(1))))


@pytest.mark.xfail(
    strict=True,
    reason="known miss: the detectors' model memory is counted in samples, so at 2 kHz "
    "it spans 5 ms of a structure whose modes are 1-6 Hz (exit 0, one unattributed anomaly)",
)
def test_a_gain_on_an_oversampled_record_is_found_at_its_own_rate(tmp_path: Path) -> None:
    t, y, names = _record()
    _gain_on_s2(run_csv(tmp_path, t, y, names))
