"""The error functions (Li et al. 2007) in a run with other detectors: a reference
sensor's fault reaches every error function it feeds (one fault at a time, not three),
offsets and drifts read in the sensor's units and timed as the sensor saw them (not by
the taps' window), and the indirect approach refused up front when every input is
measured."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from analyzer.cli import main
from analyzer.detector_runs import coupled
from analyzer.detectors import Dataset, RunContext
from analyzer.detectors.base import DetectorResult, Event
from analyzer.detectors.decoupling import inverse_model
from analyzer.detectors.error_function import (
    ErrorFunction,
    ErrorFunctionModel,
    SensorFunction,
    _edge_fit,
    _in_sensor_units,
    apply_taps,
)
from analyzer.errors import ConfigError, DetectorError
from analyzer.simulate import inject_fault, simulate_building
from analyzer.simulate_mdof import chain_model, simulate_chain
from analyzer.types import FaultType
from analyzer.writers import write_archive

RATE = 100.0
CHANNELS = ["s0", "s1", "s2", "s3", "s4", "s5"]
GROUP = {
    "name": "bldg",
    "channels": CHANNELS,
    "reference": ["s0", "s1", "s4", "s5"],
    "uncertain": ["s2", "s3"],
}


def _building(duration_s: float = 120.0, seed: int = 5) -> np.ndarray:
    """A 3-floor building, 2 accelerometers per floor, 100 Hz (the probe's data)."""
    _, y, _ = simulate_building(
        n_floors=3, duration_s=duration_s, rate_hz=RATE, seed=seed, sensors_per_floor=2
    )
    return y


def _fit_run(
    values: np.ndarray, p: int | None = 50, train_s: float = 36.0
) -> tuple[ErrorFunction, ErrorFunctionModel, DetectorResult]:
    """The error functions of GROUP fitted on the first ``train_s`` seconds and run over
    ``values``."""
    data = Dataset(values, tuple(CHANNELS), RATE, (0, int(train_s * RATE)))
    ctx = RunContext(config={"group": [GROUP]})
    det = ErrorFunction(p=p)
    model = det.fit(data, ctx)
    return det, model, det.run(model, data, ctx)


# ------------------------------------------------------------ reference faults


def test_a_reference_is_coupled_to_the_error_functions_it_feeds() -> None:
    """``coupled`` reads the error functions' reach: a reference feeds every uncertain
    sensor's function; the uncertain sensors stay decoupled from each other (before:
    only the uncertain sensors counted, so s4 reached neither)."""
    _, _, res = _fit_run(_building(60.0), p=None, train_s=40.0)
    test = coupled([res])
    for unc in ("s2", "s3"):
        for ref in ("s0", "s1", "s4", "s5"):
            assert test("error_function", unc, ref)
    assert not test("error_function", "s2", "s3")
    assert not test("error_function", "s3", "s2")
    assert res.model["reach"]["s3"] == ["s3", "s0", "s1", "s4", "s5"]


def test_the_equivalent_models_network_still_limits_its_coupling() -> None:
    """The detectors with a sensor network keep their reach; those without any keep the
    whole group."""
    net = {"sensors": ["a", "b", "c"], "assistants": {"a": ["b"], "b": ["c"], "c": ["b"]}}
    eq = DetectorResult("equivalent_model", ("a", "b", "c"), {}, [], {}, model={"network": net})
    bank = DetectorResult("ar_kalman_bank", ("a", "b", "c"), {}, [], {})
    test = coupled([eq, bank])
    assert test("equivalent_model", "a", "b")
    assert not test("equivalent_model", "a", "c")
    assert test("ar_kalman_bank", "a", "c")
    assert not test("error_function", "a", "b")


def test_a_drift_on_a_reference_is_one_finding(tmp_path: Path) -> None:
    """The probe's case: a drift on reference s4 with [[group]] configured gave the s4
    drift and false drifts on the healthy uncertain s2 and s3 (error_function alone,
    confidence 1.0), which ``--corrected`` then "corrected". Now one finding, and s2, s3
    left as measured (the two uncertain sensors' functions, which alarm together, are
    attributed to neither)."""
    y = _building(120.0)
    sd = y.std(axis=0)
    y[:, 4] = inject_fault(y[:, 4], RATE, "drift", 70.0, 2.0 * sd[4] / 60.0)
    t_ns = np.round(np.arange(y.shape[0]) / RATE * 1e9).astype(np.int64)
    write_archive(tmp_path / "d.csv", "csv", t_ns, {c: y[:, j] for j, c in enumerate(CHANNELS)})
    (tmp_path / "g.toml").write_text(
        '[[group]]\nname = "bldg"\nchannels = ["s0","s1","s2","s3","s4","s5"]\n'
        'reference = ["s0","s1","s4","s5"]\nuncertain = ["s2","s3"]\n'
    )
    out = tmp_path / "o"
    code = main(
        [
            "run",
            str(tmp_path / "d.csv"),
            "--config",
            str(tmp_path / "g.toml"),
            "--corrected",
            "--out",
            str(out),
            "--no-progress",
        ]
    )
    assert code == 1
    found = json.loads((out / "findings.json").read_text())
    assert [(f["channel"], f["type"]) for f in found["faults"]] == [("s4", "drift")]
    # the error functions of both uncertain sensors rose at once: a reference's fault
    # (or a change of the whole), attributed to neither uncertain sensor by the detector
    ef = next(d for d in found["detectors"] if d["name"] == "error_function")
    assert any("on every uncertain sensor of group 'bldg' (s2, s3)" in n for n in ef["notes"])
    corrected = pd.read_csv(out / "corrected.csv")
    for c in ("s2", "s3"):
        np.testing.assert_allclose(corrected[c], y[:, CHANNELS.index(c)], rtol=1e-12)


# ------------------------------------------------------- sizes and times of faults


@pytest.mark.parametrize("p", [50, None], ids=["p50", "default-p"])
def test_an_offset_reads_in_the_sensors_units_and_from_its_onset(p: int | None) -> None:
    """An offset of one standard deviation on uncertain s3 from 80 s: the residual reads
    it times the taps' sum (1.30 at p = 50: 3.136 for 2.427 before), and the change point
    took the first samples the window smeared it into (99.82 s for 100 s before). Now the
    size within 1.5 % and the onset within 2 samples; the first alarm no earlier than the
    onset."""
    y = _building()
    size = float(np.std(y[:, 3]))
    y[:, 3] = inject_fault(y[:, 3], RATE, "additive", 80.0, size)
    _, model, res = _fit_run(y, p=p)
    evs = [e for e in res.events if e.channel == "s3"]
    assert [e.type for e in evs] == [FaultType.ADDITIVE]
    ev = evs[0]
    dc = next(float(np.sum(f.taps[0])) for f in model.functions if f.channel == "s3")
    assert ev.magnitude["offset"] == pytest.approx(size, rel=0.015)
    assert ev.evidence["residual_magnitude"]["offset"] == pytest.approx(size * dc, rel=0.015)
    assert ev.onset_s == pytest.approx(80.0, abs=0.02)
    assert ev.evidence["first_alarm_s"] >= ev.onset_s
    assert not [e for e in res.events if e.channel == "s2"]


def test_an_offset_that_ends_is_timed_at_both_edges() -> None:
    y = _building()
    size = float(np.std(y[:, 3]))
    y[:, 3] = inject_fault(y[:, 3], RATE, "additive", 60.0, size, end_s=90.0)
    _, _, res = _fit_run(y)
    (ev,) = [e for e in res.events if e.channel == "s3"]
    assert ev.magnitude["offset"] == pytest.approx(size, rel=0.015)
    assert ev.onset_s == pytest.approx(60.0, abs=0.02)
    assert ev.end_s == pytest.approx(90.0, abs=0.02)


def test_a_gain_keeps_its_size_and_is_timed_from_its_onset() -> None:
    """The gain was right before (1.2996 for 1.3 in the probe) and stays so. Its onset
    is as fuzzy as the reading is small around it, but no longer smeared early by the
    window: at four onsets, 0.12 s off on average before (the change point: 0.32 s early
    at worst), within 0.03 s on average now."""
    y0 = _building(seed=0)
    errors = []
    for onset in (60.0, 70.3, 80.0, 91.17):
        y = y0.copy()
        y[:, 2] = inject_fault(y[:, 2], RATE, "multiplicative", onset, 1.3)
        _, _, res = _fit_run(y)
        (ev,) = [e for e in res.events if e.channel == "s2"]
        assert ev.type is FaultType.MULTIPLICATIVE
        assert ev.magnitude["gain"] == pytest.approx(1.3, abs=0.01)
        assert "residual_magnitude" not in ev.evidence
        errors.append(ev.onset_s - onset)
    assert np.mean(np.abs(errors)) < 0.03, errors
    assert np.max(np.abs(errors)) < 0.06, errors


def test_a_drift_rate_reads_in_the_sensors_units() -> None:
    """A drift's slope reads times the taps' sum too (0.109 for 0.0837 per s before)."""
    y = _building()
    rate = 2.0 * float(np.std(y[:, 3])) / 60.0
    y[:, 3] = inject_fault(y[:, 3], RATE, "drift", 60.0, rate)
    _, _, res = _fit_run(y)
    (ev,) = [e for e in res.events if e.channel == "s3"]
    assert ev.type is FaultType.DRIFT
    assert ev.magnitude["rate_per_s"] == pytest.approx(rate, rel=0.03)


@pytest.mark.parametrize("rising", [True, False], ids=["onset", "end"])
def test_edge_fit_finds_the_step_through_any_taps(rising: bool) -> None:
    """Closed form: a noise-free residual that is random taps applied to a step (or to
    a signal times a step) has its edge found exactly, whatever sample the taps treat
    as the current one."""
    rng = np.random.default_rng(3)
    n, p, s_cur, edge = 2000, 30, 11, 1000
    taps = rng.standard_normal(p + 1)
    for x in (None, rng.standard_normal(n)):
        on = np.arange(n) >= edge if rising else np.arange(n) < edge
        signal = on * (1.0 if x is None else x)
        r = apply_taps(signal[:, None], taps[None, :], np.zeros(1), s_cur)
        span = (edge - 2 * p, edge + 2 * p)
        got = _edge_fit(r, x, taps, s_cur, 0.0, range(edge - p, edge + p), span, rising=rising)
        assert got == edge


def test_in_sensor_units_leaves_a_function_blind_to_offsets_alone() -> None:
    """Taps that sum to zero (a difference in time) pass no offset: its reading is not
    divided by that zero."""
    f = SensorFunction(
        "s",
        "g",
        ("s", "r"),
        np.array([[1.0, -1.0], [0.5, 0.5]]),
        np.zeros(2),
        0,
        None,
        1.0,  # type: ignore[arg-type]
    )
    ev = Event("s", 1.0, None, FaultType.ADDITIVE, {"offset": 0.2}, 1.0, "error_function")
    _in_sensor_units(ev, f)
    assert ev.magnitude == {"offset": 0.2}


# ----------------------------------------------- indirect with every input measured


def _chain_with_measured_forces() -> tuple[Dataset, dict[str, Any]]:
    rate = 250.0
    m = chain_model()
    _, y, u = simulate_chain(24.0, rate, model=m, noise=0.01, seed=3)
    A, B, C, D = m.discrete(rate)
    names = ("s1", "s2", "s3", "s4", "u1", "u2")
    config = {
        "group": [
            {
                "name": "chain",
                "channels": list(names),
                "reference": ["s3", "s4"],
                "uncertain": ["s1", "s2"],
                "inputs": ["u1", "u2"],
            }
        ],
        "model": {
            "A": A,
            "B": B,
            "C": C,
            "D": D,
            "outputs": ["s1", "s2", "s3", "s4"],
            "inputs": ["u1", "u2"],
        },
    }
    return Dataset(np.column_stack([y, u]), names, rate, (0, int(20 * rate))), config


def test_indirect_with_every_input_measured_is_refused_up_front() -> None:
    """Li et al. 2007, Eq. 3-8: the uncertain sensors enter the inverse model only as
    stand-ins for the inputs it eliminates; with every input measured, no error function
    responds to its sensor. Refused by ``applicable`` (the skip reason, or the run's
    error when named) with the option to change, not after the fit with "the error
    function does not respond to its own sensor"."""
    data, config = _chain_with_measured_forces()
    det = ErrorFunction(approach="indirect")
    want = (
        r'\[detectors.error_function\] approach = "indirect" needs at least one unmeasured '
        r"input in \[model\] \(group 'chain' measures every input: u1, u2\); use approach "
        r'= "direct"'
    )
    reason = det.applicable(data, RunContext(config=config, explicit=True))
    assert reason is not None
    assert re.fullmatch(want, reason), reason
    with pytest.raises(ConfigError, match=want):
        det.fit(data, RunContext(config=config))
    # the direct approach works on the same data
    assert ErrorFunction(approach="direct").applicable(data, RunContext(config=config)) is None


@pytest.mark.parametrize(("measured", "blind"), [("u2", "s2"), ("u1", "s1")])
def test_indirect_refuses_a_sensor_no_unmeasured_input_reaches(measured: str, blind: str) -> None:
    """One force of the chain measured: the other reaches only its own mass's sensor
    directly (D = [[1, 0], [0, 1], [0, 0], [0, 0]]), so the other uncertain sensor does
    not enter the inverse model (a zero column of D_d^+). Refused naming that sensor,
    not "does not respond to its own sensor" after the fit."""
    data, config = _chain_with_measured_forces()
    config["group"][0]["inputs"] = [measured]
    ctx = RunContext(config=config)
    det = ErrorFunction(approach="indirect")
    reason = det.applicable(data, ctx)
    assert reason is not None
    assert f"uncertain sensor {blind!r} of group 'chain' sees no unmeasured input" in reason
    assert reason.endswith('use approach = "direct"')
    with pytest.raises(DetectorError, match=f"uncertain sensor {blind!r}"):
        det.fit(data, ctx)


def test_inverse_model_refuses_when_nothing_is_left_to_eliminate() -> None:
    A, B, C, D = chain_model().discrete(250.0)
    with pytest.raises(DetectorError, match=r"needs at least one unmeasured input.*all 2"):
        inverse_model(A, B, C, D, [0, 1], [2, 3], [0, 1])


def test_a_named_indirect_error_function_with_measured_inputs_exits_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data, config = _chain_with_measured_forces()
    t_ns = np.round(np.arange(data.n) / data.rate_hz * 1e9).astype(np.int64)
    write_archive(
        tmp_path / "c.csv",
        "csv",
        t_ns,
        {c: np.asarray(data.values)[:, j] for j, c in enumerate(data.channels)},
    )
    model = config["model"]
    np.savez(tmp_path / "m.npz", **{k: model[k] for k in "ABCD"}, dt=1.0 / data.rate_hz)
    (tmp_path / "c.toml").write_text(
        "[train]\nstart = 0.0\nend = 20.0\n"
        '[[group]]\nname = "chain"\nchannels = ["s1","s2","s3","s4","u1","u2"]\n'
        'reference = ["s3","s4"]\nuncertain = ["s1","s2"]\ninputs = ["u1","u2"]\n'
        '[model]\nfile = "m.npz"\noutputs = ["s1","s2","s3","s4"]\ninputs = ["u1","u2"]\n'
        '[detectors.error_function]\napproach = "indirect"\n'
    )
    code = main(
        [
            "run",
            str(tmp_path / "c.csv"),
            "--config",
            str(tmp_path / "c.toml"),
            "--detectors",
            "error_function",
            "--out",
            str(tmp_path / "o"),
            "--no-progress",
        ]
    )
    err = capsys.readouterr().err
    assert code == 2
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err
    assert 'approach = "indirect" needs at least one unmeasured input' in lines[0]
    assert 'use approach = "direct"' in lines[0]
