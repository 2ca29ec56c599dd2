"""Decoupled sensor error functions (Li, Koh & Nagarajaiah 2007), checked against the
paper's four-degree-of-freedom example, its truss experiment's amplitude reductions,
closed-form identities of the method, and every refusal."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from scipy import signal

from analyzer.detectors import error_function
from analyzer.detectors.base import Dataset, DetectorResult, RunContext
from analyzer.detectors.decoupling import (
    decoupling_basis,
    decoupling_system,
    inverse_model,
    model_matrices,
    paper_coefficients,
)
from analyzer.detectors.error_function import (
    WEAK_SENSITIVITY,
    ErrorFunction,
    ErrorFunctionModel,
    Group,
    _select,
    _unit_fit,
    apply_taps,
    check_conditions,
    minimal_p,
    resolve_groups,
)
from analyzer.diagnosis.changes import detect
from analyzer.errors import ConfigError, DetectorError
from analyzer.simulate_mdof import (
    PAPER_FAILURES,
    ChainArchive,
    Failure,
    FailureSpec,
    chain_archive,
    chain_model,
    simulate_chain,
    simulate_discrete,
)
from analyzer.types import FaultType

TOL_S = 0.1
"""Onset and end must be within this of the injected failure (the brief's requirement)."""

# The paper's failures are 2 s apart on each sensor; the shared detector merges alarms
# closer than 8 windows, so the paper example is run with a 0.1 s window (0.8 s long
# window). The half-gain failures, 4 s long, use the default window.
PAPER_WINDOW_S = 0.1

HALF_GAIN_ABS_TOL = 0.02
"""The gain cuts' sizes (0.5 and 0.6) must be within this: measured on the test's seed 0,
0.0156 (indirect, s2) and 0.0132 (direct, s2) at most; over seeds 0-4, 0.0175 (the
estimates run 0.00-0.018 high). A 10 % error in the fitted gain change (0.5 read as 0.45)
must fail."""


def _run(
    arch: ChainArchive, config: dict[str, Any] | None = None, **kw: Any
) -> tuple[ErrorFunctionModel, DetectorResult]:
    data = Dataset(arch.values, arch.channels, arch.rate_hz, arch.train)
    # explicit: as with --detectors error_function (without groups it runs only on request)
    ctx = RunContext(config=arch.config if config is None else config, explicit=True)
    det = ErrorFunction(**kw)
    assert det.applicable(data, ctx) is None
    model = det.fit(data, ctx)
    return model, det.run(model, data, ctx)


def _truth(arch: ChainArchive) -> dict[str, list[tuple[float, float]]]:
    out: dict[str, list[tuple[float, float]]] = {}
    for f in arch.failures:
        out.setdefault(arch.channels[f.channel], []).append((f.start_s, f.end_s))
    return out


def _intervals(
    arch: ChainArchive, model: ErrorFunctionModel, res: DetectorResult, channel: str
) -> list[tuple[float, float | None]]:
    """The faulty intervals of ``channel``'s residual, as the shared detector finds them
    (the first step of ``events_from_residual``), in seconds."""
    f = next(f for f in model.functions if f.channel == channel)
    rate = arch.rate_hz
    return [
        (iv.onset / rate, None if iv.end is None else iv.end / rate)
        for iv in detect(res.residuals[channel], f.calibration, search_start=arch.train[1])
    ]


def _assert_matches(
    found: Sequence[tuple[float, float | None]], want: Sequence[tuple[float, float]], what: str
) -> None:
    assert len(found) == len(want), f"{what}: found {found}, want {want}"
    for (a, b), (a0, b0) in zip(found, want, strict=True):
        assert abs(a - a0) <= TOL_S, f"{what}: onset {a:.3f} s vs {a0} s ({found})"
        assert b is not None and abs(b - b0) <= TOL_S, f"{what}: end {b} s vs {b0} s ({found})"


def _assert_isolated(arch: ChainArchive, res: DetectorResult) -> None:
    """Every event lies on a failure of its own channel (onset inside it, within the
    tolerance) and never on a stretch where only another sensor failed."""
    truth = _truth(arch)
    for ev in res.events:
        own = truth.get(ev.channel, [])
        assert any(a - TOL_S <= ev.onset_s <= b for a, b in own), (
            f"event on {ev.channel} at {ev.onset_s:.3f} s matches none of its failures {own}"
        )


# ------------------------------------------------------------------ simulator


def test_chain_matches_the_paper_structure() -> None:
    m = chain_model()
    np.testing.assert_allclose(m.frequencies_hz, [17.479, 50.329, 77.109, 94.588], atol=1e-3)
    # c_i = 0.05 m_i + 0.001 k_i (Rayleigh): the damping matrix is 0.05 M + 0.001 K
    np.testing.assert_allclose(m.Cdamp, 0.05 * m.M + 0.001 * m.K)
    # accelerations of masses 1 and 2 see their forces directly; masses 3 and 4 do not
    np.testing.assert_allclose(m.D, [[1, 0], [0, 1], [0, 0], [0, 0]])


def test_modal_simulation_equals_state_recursion() -> None:
    m = chain_model()
    A, B, C, D = m.discrete(250.0)
    u = np.random.default_rng(3).standard_normal((400, 2))
    _, y_ref, _ = signal.dlsim((A, B, C, D, 1 / 250.0), u)
    np.testing.assert_allclose(simulate_discrete(A, B, C, D, u), y_ref, atol=1e-12)


def test_failure_injection() -> None:
    arch = chain_archive(failures=PAPER_FAILURES, train_s=1.0, test_s=11.0)
    _, clean, _ = simulate_chain(12.0, seed=0)
    k = lambda t: int(round(t * arch.rate_hz))  # noqa: E731
    assert np.all(arch.values[k(5.0) : k(7.0), 1] == 0.0)  # sensor 2 reads zero in 4-6 s
    assert not np.allclose(arch.values[k(3.0) : k(5.0), 0], clean[k(3.0) : k(5.0), 0])
    np.testing.assert_array_equal(arch.values[: k(3.0)], clean[: k(3.0)])
    np.testing.assert_array_equal(arch.values[:, 2:], clean[:, 2:])


def test_paper_failures_are_the_papers() -> None:
    """Li, Koh & Nagarajaiah (2007), "Numerical Simulation" (seed 000, the paragraph at
    line 201 of /work/shared/seeds/000_*.txt): sensor 1 gives "arbitrary random data
    ... during 2-4 and 6-8 s" and sensor 2 "reads uniform zero measurements during 4-6
    and 8-10 s". Written out here, not taken from the simulator, so that a changed
    constant fails (the example's tests take their truth from ``PAPER_FAILURES``)."""
    got = {(f.channel, f.kind, f.start_s, f.end_s) for f in PAPER_FAILURES}
    assert len(PAPER_FAILURES) == 4
    assert got == {
        (0, Failure.RANDOM, 2.0, 4.0),
        (0, Failure.RANDOM, 6.0, 8.0),
        (1, Failure.ZERO, 4.0, 6.0),
        (1, Failure.ZERO, 8.0, 10.0),
    }


# ------------------------------------------------------------- method identities


def test_conditions_of_the_paper() -> None:
    assert minimal_p(8, 2, 2) == 7  # p (2 - 2 + 1) >= 8 - 2 + 1
    check_conditions(n=8, n_s=2, n_d=2, r=2, p=7, approach="indirect")
    with pytest.raises(DetectorError, match=r"Eq. 19 fails: p \(n_s - n_d \+ 1\) = 6 \* 1"):
        check_conditions(n=8, n_s=2, n_d=2, r=2, p=6, approach="indirect")
    with pytest.raises(DetectorError, match=r"needs n_d >= r: 1 uncertain sensor\(s\) < 2"):
        check_conditions(n=8, n_s=3, n_d=1, r=2, p=20, approach="indirect")
    with pytest.raises(DetectorError, match=r"needs n_s >= n_d: 1 reference sensor\(s\) < 3"):
        check_conditions(n=8, n_s=1, n_d=3, r=2, p=20, approach="direct")
    with pytest.raises(DetectorError, match="p must be >= 1"):
        check_conditions(n=None, n_s=2, n_d=2, r=None, p=0, approach="direct")


@pytest.mark.parametrize("direction", ["sensitive", "paper"])
def test_indirect_error_function_vanishes_for_any_input(direction: str) -> None:
    """Eq. 25: with the exact model the error function is zero on healthy data whatever
    the (unmeasured) forces are: fitted on band-limited forcing, checked on white forcing
    with a different seed (the inputs are eliminated, not learned)."""
    arch = chain_archive(failures=(), train_s=10.0, test_s=0.0, seed=0)
    model, _ = _run(arch, approach="indirect", direction=direction)
    m = chain_model()
    A, B, C, D = m.discrete(arch.rate_hz)
    u = np.random.default_rng(9).standard_normal((3000, 2))
    y = simulate_discrete(A, B, C, D, u)
    for f in model.functions:
        idx = [arch.channels.index(c) for c in f.channels]
        r = f.residual(y[:, idx])
        assert np.nanstd(r) < 1e-9 * np.std(y[:, idx[0]]), (f.channel, np.nanstd(r))
        # and a failure of the examined sensor does show
        y_bad = y[:, idx].copy()
        y_bad[1000:1500, 0] = 0.0
        assert np.nanmax(np.abs(f.residual(y_bad))) > 1e-3 * np.std(y[:, idx[0]])


def test_decoupling_basis_solves_eq_17_and_21() -> None:
    """Every basis vector annihilates the state and the other uncertain sensor (the
    decoupling matrix Z of Eq. 17/21), to rounding."""
    m = chain_model()
    A, B, C, D = m.discrete(250.0)
    inv = inverse_model(A, B, C, D, [0, 1], [2, 3])
    for i in (0, 1):
        basis, F, info = decoupling_basis(inv, 28, i, np.ones(2))
        Z, _, _ = decoupling_system(inv, 28, i)
        norms = np.linalg.norm(Z, axis=0)
        zn = Z[:, norms > 0] / norms[norms > 0]
        assert info["null_dim"] == basis.shape[1] > 0
        assert np.max(np.abs(basis.T @ zn)) < 1e-10
        # the paper's own construction (Eq. 18 then Eq. 21) lies in the same space
        w, pinfo = paper_coefficients(inv, 28, i)
        assert pinfo["leakage"] < 1e-8
        resid = w - basis @ np.linalg.lstsq(basis, w, rcond=None)[0]
        assert np.linalg.norm(resid) < 1e-6 * np.linalg.norm(w)


def test_general_model_with_direct_term_and_measured_input() -> None:
    """Beyond the paper's Eq. 9: references that see an input directly (Db != 0) and a
    measured input kept in the error function. A random stable model; the healthy error
    functions vanish and each ignores a failure of the other uncertain sensor."""
    rng = np.random.default_rng(4)
    n, rate = 6, 100.0
    A = rng.standard_normal((n, n))
    A *= 0.9 / np.max(np.abs(np.linalg.eigvals(A)))
    B = rng.standard_normal((n, 3))
    C = rng.standard_normal((5, n))
    D = rng.standard_normal((5, 3))
    u = rng.standard_normal((3000, 3))
    y = simulate_discrete(A, B, C, D, u)
    values = np.column_stack([y, u[:, 2]])
    names = ("a", "b", "c", "d", "e", "force")
    config = {
        "group": [
            {
                "name": "g",
                "channels": list(names),
                "uncertain": ["a", "b"],
                "reference": ["c", "d", "e"],
                "inputs": ["force"],
            }
        ],
        "model": {
            "A": A,
            "B": B,
            "C": C,
            "D": D,
            "outputs": list(names[:5]),
            "inputs": ["", "", "force"],
        },
    }
    data = Dataset(values, names, rate, (0, 2000))
    ctx = RunContext(config=config)
    det = ErrorFunction(approach="indirect", p=12)
    model = det.fit(data, ctx)
    bad = values.copy()
    bad[2200:2600, 1] = rng.standard_normal(400)  # sensor b fails
    res = det.run(model, Dataset(bad, names, rate, (0, 2000)), ctx)
    ra, rb = res.residuals["a"], res.residuals["b"]
    scale = np.std(values[:, 0])
    assert np.nanmax(np.abs(ra)) < 1e-8 * scale  # decoupled: a's function ignores b
    assert np.nanmax(np.abs(rb[2000:2190])) < 1e-8 * scale
    assert np.nanstd(rb[2200:2600]) > 1e-2 * scale
    assert [e.channel for e in res.events] == ["b"]


def test_fir_application_matches_the_sliding_dot_product() -> None:
    rng = np.random.default_rng(1)
    vals = rng.standard_normal((200, 3))
    vals[50, 1] = np.nan
    taps = rng.standard_normal((3, 6))
    means = rng.standard_normal(3)
    s_cur = 2
    out = apply_taps(vals, taps, means, s_cur)
    p = taps.shape[1] - 1
    for t in range(200):
        lo = t - s_cur
        if lo < 0 or lo + p >= 200 or np.isnan(vals[lo : lo + p + 1]).any():
            assert np.isnan(out[t])
        else:
            want = np.sum(taps.T * (vals[lo : lo + p + 1] - means))
            assert out[t] == pytest.approx(want, rel=1e-10, abs=1e-12)


def test_run_is_chunked_and_can_write_to_a_work_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    arch = chain_archive(noise=0.01, seed=0, test_s=4.0)
    data = Dataset(arch.values, arch.channels, arch.rate_hz, arch.train)
    det = ErrorFunction(approach="direct")
    model = det.fit(data, RunContext(config=arch.config))
    whole = det.run(model, data, RunContext(config=arch.config))
    monkeypatch.setattr(error_function, "_RUN_CHUNK", 37)
    chunked = det.run(model, data, RunContext(config=arch.config, workdir=tmp_path))
    for ch in ("s1", "s2"):
        assert isinstance(chunked.residuals[ch], np.memmap)
        np.testing.assert_allclose(
            chunked.residuals[ch], whole.residuals[ch], rtol=1e-10, atol=1e-14, equal_nan=True
        )
        np.testing.assert_allclose(
            chunked.reference[ch], whole.reference[ch], rtol=1e-10, atol=1e-14, equal_nan=True
        )
    assert [(e.channel, e.onset_s) for e in chunked.events] == [
        (e.channel, e.onset_s) for e in whole.events
    ]


def test_unit_fit_recovers_a_pure_delay() -> None:
    """An error function that is the sensor delayed by 3 samples reads, after the unit
    fit, as the sensor itself: the "current sample" is found and the scale is exact."""
    r = 0.8 ** np.abs(np.arange(-6, 7))
    R = np.array([[r[6 + b - a] for b in range(7)] for a in range(7)])
    w = np.zeros(7)
    w[3] = -2.5
    s_cur, scale, r2 = _unit_fit(w, R)
    assert (s_cur, r2) == (3, pytest.approx(1.0))
    assert scale * w[3] == pytest.approx(1.0)


# ----------------------------------------------------------- the paper's example


@pytest.mark.parametrize("noise", [0.0, 0.01], ids=["noise-free", "1%-noise"])
@pytest.mark.parametrize("approach", ["indirect", "direct"])
def test_paper_example(approach: str, noise: float) -> None:
    """Li et al. 2007, Fig. 2-4: sensor 1 gives random data in 2-4 s and 6-8 s, sensor 2
    reads zero in 4-6 s and 8-10 s; each error function finds its own sensor's failures
    (onset and end within 0.1 s) and nothing of the other's."""
    arch = chain_archive(noise=noise, seed=0)
    model, res = _run(arch, approach=approach, window=int(PAPER_WINDOW_S * arch.rate_hz))
    truth = _truth(arch)
    for ch in ("s1", "s2"):
        _assert_matches(_intervals(arch, model, res, ch), truth[ch], f"{approach} {ch}")
        first = min(e.onset_s for e in res.events if e.channel == ch)
        assert abs(first - truth[ch][0][0]) <= TOL_S
    _assert_isolated(arch, res)
    assert set(res.residuals) == {"s1", "s2"}
    if noise > 0.0:
        # the zero reading of sensor 2 is a dead sensor: multiplicative, gain near 0
        dead = [e for e in res.events if e.channel == "s2"][0]
        assert dead.type is FaultType.MULTIPLICATIVE
        # measured on seed 0: 0.036 (indirect), 0.046 (direct); 0.003-0.046 over seeds
        # 0-2 and both spells. A gain near zero read 10 % too far from 1 comes out < 0.
        assert 0.0 <= dead.magnitude["gain"] <= 0.05


def test_paper_example_event_ends() -> None:
    arch = chain_archive(noise=0.01, seed=0)
    _, res = _run(arch, approach="direct", window=int(PAPER_WINDOW_S * arch.rate_hz))
    truth = _truth(arch)
    for ch in ("s1", "s2"):
        found = sorted((e.onset_s, e.end_s) for e in res.events if e.channel == ch)
        _assert_matches(found, truth[ch], ch)


@pytest.mark.parametrize("approach", ["indirect", "direct"])
def test_half_gain_failures_with_noise_on_all_sensors(approach: str) -> None:
    """The truss experiment's amplitude reductions (Sensor 2 halved, Sensor 1 reduced by
    40 %, overlapping), 1 % noise on every sensor: found on the right sensor, timed within
    0.1 s, and classified as gain changes of the right size."""
    failures = (
        FailureSpec(1, Failure.GAIN, 2.0, 6.0, 0.5),
        FailureSpec(0, Failure.GAIN, 4.0, 8.0, 0.6),
    )
    arch = chain_archive(failures=failures, noise=0.01, seed=0)
    model, res = _run(arch, approach=approach)
    truth = _truth(arch)
    for ch, gain in (("s1", 0.6), ("s2", 0.5)):
        _assert_matches(_intervals(arch, model, res, ch), truth[ch], f"{approach} {ch}")
        evs = [e for e in res.events if e.channel == ch]
        assert len(evs) == 1 and evs[0].type is FaultType.MULTIPLICATIVE
        assert evs[0].magnitude["gain"] == pytest.approx(gain, abs=HALF_GAIN_ABS_TOL)
        assert abs(evs[0].onset_s - truth[ch][0][0]) <= TOL_S
        assert evs[0].end_s is not None and abs(evs[0].end_s - truth[ch][0][1]) <= TOL_S
    _assert_isolated(arch, res)


@pytest.mark.parametrize("approach", ["indirect", "direct"])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_no_events_on_healthy_runs(approach: str, seed: int) -> None:
    arch = chain_archive(failures=(), noise=0.01, seed=seed)
    _, res = _run(arch, approach=approach)
    assert res.events == []


def test_no_events_on_a_noise_free_healthy_run() -> None:
    arch = chain_archive(failures=(), noise=0.0, seed=4)
    model, res = _run(arch, approach="direct")
    assert res.events == []
    assert all(f.summary["floor_used"] for f in model.functions)


# ------------------------------------------------- choice of the null-space vector


def test_sensitive_choice_beats_the_smallest_singular_vector() -> None:
    """At 1 kHz with 1 % noise on every sensor the band-limited data leave many nearly
    null directions; the smallest singular vector (Eq. 29 literally) is one that barely
    responds to sensor 2, and misses its halved amplitude. The sensitive choice sees it
    clearly."""
    failures = (FailureSpec(1, Failure.GAIN, 2.0, 6.0, 0.5),)
    arch = chain_archive(1000.0, failures=failures, noise=0.01, seed=0)
    ((a, b),) = _truth(arch)["s2"]
    fault = slice(int(a * arch.rate_hz) + 50, int(b * arch.rate_hz) - 50)
    healthy = slice(arch.train[1], int(a * arch.rate_hz) - 50)
    ratio = {}
    for direction in ("paper", "sensitive"):
        model, res = _run(arch, approach="direct", direction=direction)
        f = next(f for f in model.functions if f.channel == "s2")
        r = res.residuals["s2"]
        ratio[direction] = float(np.nanstd(r[fault]) / np.nanstd(r[healthy]))
        found = _intervals(arch, model, res, "s2")
        if direction == "paper":
            assert f.summary["sensitivity"] < 1.0
            assert found == [] and not any(e.channel == "s2" for e in res.events)
        else:
            assert f.summary["sensitivity"] > 10.0
            assert len(found) == 1, found
            onset, end = found[0]
            # the end is timed; the onset may be pulled early by a marginal alarm of the
            # shared detector just before the failure (seed 0: 0.85 s), so only "covers"
            assert onset <= a + TOL_S and end is not None and abs(end - b) <= TOL_S
            assert [e.channel for e in res.events] == ["s2"]
    assert ratio["paper"] < 1.5 < 5.0 < ratio["sensitive"]


def test_weak_error_function_is_reported() -> None:
    """At 1 kHz the exact (indirect) error function of sensor 1 barely sees it (see
    :data:`analyzer.simulate_mdof.DEFAULT_RATE_HZ`), at 250 Hz it does; the detector
    says which."""
    sens = {}
    for rate in (250.0, 1000.0):
        arch = chain_archive(rate, failures=(), noise=0.01, seed=0, train_s=12.0, test_s=0.0)
        model, res = _run(arch, approach="indirect")
        sens[rate] = next(f.summary["sensitivity"] for f in model.functions if f.channel == "s1")
        weak = any(n.startswith("s1: weak error function") for n in res.notes)
        assert weak == (sens[rate] < WEAK_SENSITIVITY)
    assert sens[1000.0] < 0.5 < 5.0 < sens[250.0]


# ----------------------------------------------------------------- configuration


def test_without_groups_every_sensor_is_examined_against_the_others() -> None:
    failures = (FailureSpec(1, Failure.ZERO, 2.0, 6.0),)
    arch = chain_archive(failures=failures, noise=0.01, seed=0)
    model, res = _run(arch, config={}, approach="direct")
    assert [f.channel for f in model.functions] == ["s1", "s2", "s3", "s4"]
    assert [f.channels[1:] for f in model.functions][1] == ("s1", "s3", "s4")
    assert any("no isolation" in n for n in res.notes)
    s2 = [e for e in res.events if e.channel == "s2"]
    assert len(s2) == 1 and abs(s2[0].onset_s - _truth(arch)["s2"][0][0]) <= TOL_S


def test_without_groups_it_does_not_run_unless_asked() -> None:
    arch = chain_archive(noise=0.01, seed=0, test_s=4.0)
    data = Dataset(arch.values, arch.channels, arch.rate_hz, arch.train)
    reason = ErrorFunction().applicable(data, RunContext(config={}))
    assert reason is not None and "[[group]]" in reason


def test_result_is_json_friendly() -> None:
    arch = chain_archive(noise=0.01, seed=0, test_s=4.0)
    _, res = _run(arch, approach="indirect", window=25)
    json.dumps(
        {
            "params": res.params,
            "model": res.model,
            "thresholds": res.thresholds,
            "sigma": res.sigma,
            "notes": res.notes,
        },
        allow_nan=False,
    )
    s1 = res.model["sensors"]["s1"]
    assert s1["approach"] == "indirect" and s1["p"] == 14 and s1["null_dim"] > 0
    assert res.reference["s1"].shape == res.residuals["s1"].shape == (arch.values.shape[0],)


def test_groups_from_config() -> None:
    chans = ["a", "b", "c", "d"]
    g = resolve_groups(
        chans, {"group": [{"name": "x", "channels": chans, "reference": ["c", "d"]}]}
    )
    assert g == [Group("x", ("a", "b"), ("c", "d"), (), True)]
    g = resolve_groups(chans, {"group": [{"channels": chans, "uncertain": ["a"]}]})
    assert g[0].reference == ("b", "c", "d")


@pytest.mark.parametrize(
    ("group", "match"),
    [
        ({"channels": ["a", "b"]}, "needs 'reference' or 'uncertain'"),
        ({"channels": ["a", "b"], "reference": ["a"], "uncertain": ["a"]}, "both reference"),
        ({"channels": ["a", "z"], "reference": ["z"]}, "channel 'z' is not in the data"),
        ({"channels": ["a", "b"], "reference": ["a", "b"]}, "at least one uncertain"),
        ({"channels": ["a", "b"], "reference": "a"}, "expected a list of channel names"),
    ],
)
def test_bad_groups(group: dict[str, Any], match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        resolve_groups(["a", "b", "c"], {"group": [group]})


def test_a_single_group_table_is_accepted() -> None:
    g = resolve_groups(["a", "b"], {"group": {"name": "x", "uncertain": ["a"], "reference": ["b"]}})
    assert g == [Group("x", ("a",), ("b",), (), True)]


def test_sensor_examined_in_two_groups() -> None:
    groups = [
        {"name": "g1", "uncertain": ["a"], "reference": ["b"]},
        {"name": "g2", "uncertain": ["a"], "reference": ["c"]},
    ]
    with pytest.raises(ConfigError, match="'a' is uncertain in groups 'g1' and 'g2'"):
        resolve_groups(["a", "b", "c"], {"group": groups})


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"approach": "both"}, "approach: expected one of"),
        ({"direction": "largest"}, "direction: expected one of"),
        ({"p": 0}, "p: expected a positive integer, got 0"),
        ({"l": 2.5}, "l: expected a positive integer"),
        ({"window": True}, "window: expected a positive integer"),
    ],
)
def test_bad_settings(kw: dict[str, Any], match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        ErrorFunction(**kw)


def _model_cfg(**over: Any) -> dict[str, Any]:
    A, B, C, D = chain_model().discrete(250.0)
    cfg: dict[str, Any] = {
        "A": A,
        "B": B,
        "C": C,
        "D": D,
        "dt": 1 / 250.0,
        "outputs": ["s1", "s2", "s3", "s4"],
        "inputs": [],
    }
    cfg.update(over)
    return cfg


@pytest.mark.parametrize(
    ("over", "match"),
    [
        ({"A": np.zeros((8, 7))}, r"expected a square matrix for A, got \(8, 7\)"),
        ({"B": np.zeros((7, 2))}, r"expected B with 8 rows, got \(7, 2\)"),
        ({"C": np.zeros((4, 7))}, r"expected C with 8 columns"),
        ({"D": np.zeros((4, 3))}, r"expected a \(4, 2\) matrix for D, got \(4, 3\)"),
        ({"outputs": ["s1"]}, "'outputs' names 1 channel"),
        ({"inputs": ["f"]}, "'inputs' names 1 channel"),
    ],
)
def test_bad_model(over: dict[str, Any], match: str) -> None:
    arch = chain_archive(failures=(), test_s=0.0, train_s=2.0)
    data = Dataset(arch.values, arch.channels, arch.rate_hz, arch.train)
    config = {"group": arch.config["group"], "model": _model_cfg(**over)}
    det = ErrorFunction(approach="indirect")
    assert det.applicable(data, RunContext(config=config)) is not None
    with pytest.raises(ConfigError, match=match):
        det.fit(data, RunContext(config=config))


def test_model_matrices_must_be_there_and_numeric() -> None:
    cfg = _model_cfg()
    del cfg["D"]
    with pytest.raises(ConfigError, match=r"\[model\]: missing matrix D"):
        model_matrices(cfg)
    with pytest.raises(ConfigError, match=r"\[model\]: C is not a numeric matrix"):
        model_matrices(_model_cfg(C=[["x"]]))
    with pytest.raises(ConfigError, match=r"\[model\]: A must be a finite 2-D matrix"):
        model_matrices(_model_cfg(A=np.full((8, 8), np.nan)))


# ----------------------------------------------------------------- refusals


def _data(values: np.ndarray | None = None, train: tuple[int, int] = (0, 2500)) -> Dataset:
    arch = chain_archive(failures=(), train_s=10.0, test_s=2.0, noise=0.01)
    vals = arch.values if values is None else values
    return Dataset(vals, arch.channels, arch.rate_hz, train)


def _cfg(**group: Any) -> dict[str, Any]:
    g = {
        "name": "chain",
        "channels": ["s1", "s2", "s3", "s4"],
        "reference": ["s3", "s4"],
        "uncertain": ["s1", "s2"],
    }
    g.update(group)
    return {"group": [g], "model": _model_cfg()}


@pytest.mark.parametrize(
    ("kw", "config", "match"),
    [
        ({"approach": "indirect"}, {}, r"needs a \[model\]"),
        (
            {"approach": "indirect"},
            _cfg(uncertain=["s1"], reference=["s2", "s3", "s4"]),
            r"n_d >= r: 1 uncertain sensor\(s\) < 2 unmeasured input\(s\)",
        ),
        (
            {"approach": "direct"},
            _cfg(uncertain=["s1", "s2", "s3"], reference=["s4"]),
            r"n_s >= n_d: 1 reference sensor\(s\) < 3 uncertain",
        ),
        ({"approach": "indirect", "p": 6}, _cfg(), r"Eq. 19 fails: .* = 6 < n - n_d \+ 1 = 7"),
        (
            {"approach": "indirect"},
            {**_cfg(), "model": _model_cfg(dt=0.001)},
            r"dt = 0.001 s does not match the data's sample time 0.004 s",
        ),
        (
            {"approach": "indirect"},
            {**_cfg(), "model": _model_cfg(outputs=["s1", "s2", "s3", "x"])},
            "channel 's4' is not an output of",
        ),
        (
            {"approach": "indirect"},
            _cfg(inputs=["s4"], reference=["s3"]),
            "input 's4' is not an input of",
        ),
    ],
)
def test_refusals(kw: dict[str, Any], config: dict[str, Any], match: str) -> None:
    data = _data()
    det = ErrorFunction(**kw)
    with pytest.raises(DetectorError, match=match):
        det.fit(data, RunContext(config=config))


def test_refuses_when_no_error_function_decouples() -> None:
    """Eq. 19 holds with equality for a generic observable model (n = 4, p = 3), yet the
    decoupling matrix is square and regular: no error function exists."""
    rng = np.random.default_rng(2)
    A = rng.standard_normal((4, 4))
    A *= 0.8 / np.max(np.abs(np.linalg.eigvals(A)))
    B, C, D = rng.standard_normal((4, 2)), rng.standard_normal((4, 4)), rng.standard_normal((4, 2))
    y = simulate_discrete(A, B, C, D, rng.standard_normal((1000, 2)))
    names = ("s1", "s2", "s3", "s4")
    config = {**_cfg(), "model": {"A": A, "B": B, "C": C, "D": D, "outputs": list(names)}}
    det = ErrorFunction(approach="indirect", p=3)
    with pytest.raises(
        DetectorError, match="no error function decouples uncertain sensor 0 with p=3"
    ):
        det.fit(Dataset(y, names, 100.0, (0, 1000)), RunContext(config=config))


def test_refuses_a_singular_inverse_model() -> None:
    """Displacement sensors do not see the forces directly (D_d = 0): Eq. 3 has no
    pseudoinverse."""
    m = chain_model(output="displacement")
    A, B, C, D = m.discrete(250.0)
    _, y, _ = simulate_chain(10.0, model=m, seed=0)
    data = Dataset(y, ("s1", "s2", "s3", "s4"), 250.0, (0, 2500))
    config = {
        **_cfg(),
        "model": {"A": A, "B": B, "C": C, "D": D, "outputs": ["s1", "s2", "s3", "s4"]},
    }
    with pytest.raises(DetectorError, match=r"D_d .* is singular or ill-conditioned"):
        ErrorFunction(approach="indirect").fit(data, RunContext(config=config))


def test_refuses_too_little_training_data_for_the_svd() -> None:
    with pytest.raises(DetectorError, match=r"too little training data for the SVD of W_NY"):
        ErrorFunction(approach="direct").fit(_data(train=(0, 50)), RunContext(config=_cfg()))
    with pytest.raises(DetectorError, match=r"s1: .*45 coefficients"):
        ErrorFunction(approach="direct", l=55).fit(_data(), RunContext(config=_cfg()))


def test_refuses_a_training_window_shorter_than_one_error_function_window() -> None:
    with pytest.raises(DetectorError, match=r"shorter than one error-function window"):
        ErrorFunction(approach="indirect").fit(_data(train=(0, 10)), RunContext(config=_cfg()))


def test_refuses_too_little_data_to_calibrate() -> None:
    with pytest.raises(DetectorError, match="s1: too little healthy data to calibrate"):
        ErrorFunction(approach="indirect").fit(_data(train=(0, 600)), RunContext(config=_cfg()))


@pytest.mark.parametrize(
    ("fill", "match"),
    [(np.nan, "channel 's3' has no finite sample"), (1.5, "channel 's3' is constant")],
)
def test_refuses_nan_only_and_constant_channels(fill: float, match: str) -> None:
    vals = _data().values.copy()
    vals[:, 2] = fill
    with pytest.raises(DetectorError, match=match):
        ErrorFunction().fit(_data(vals), RunContext(config=_cfg()))


def test_refuses_fewer_than_two_channels() -> None:
    data = Dataset(np.zeros((100, 1)), ("s1",), 250.0, (0, 50))
    det = ErrorFunction()
    assert "at least 2 channels" in str(det.applicable(data, RunContext()))
    with pytest.raises(DetectorError, match="at least 2 channels"):
        det.fit(data, RunContext())


def test_refuses_to_run_without_its_channels() -> None:
    data = _data()
    det = ErrorFunction(approach="direct")
    model = det.fit(data, RunContext(config=_cfg()))
    short = Dataset(data.values[:, :3], data.channels[:3], data.rate_hz, data.train)
    with pytest.raises(DetectorError, match=r"needs channel\(s\) \['s4'\]"):
        det.run(model, short, RunContext(config=_cfg()))


def test_numerical_refusals() -> None:
    with pytest.raises(DetectorError, match="does not respond to its own sensor"):
        _unit_fit(np.zeros(3), np.eye(3))
    with pytest.raises(DetectorError, match="covariance of the error-function candidates"):
        _select(np.eye(2), np.zeros((2, 2)), np.eye(2))
    A, B, C, D = chain_model().discrete(250.0)
    C = C.copy()
    C[2:] = 0.0  # the references see nothing: Eq. 18 has no matrix to invert
    inv = inverse_model(A, B, C, D, [0, 1], [2, 3])
    with pytest.raises(DetectorError, match=r"Eq. 18: the matrix \[O T_j\] is zero"):
        paper_coefficients(inv, 10, 0)


@pytest.mark.parametrize("train", [None, "0:10"])
def test_thresholds_calibrated_out_of_sample_leave_the_healthy_sensor_alone(
    tmp_path, capsys, train
):
    """The contract's example config on the bundled gain sample: the direct approach
    picks the direction of least variance of the training windows themselves, so
    calibrated in sample its thresholds gave false `other` findings on the healthy s3
    right after the window (1 with the default window, 4 with 10 s). Calibrated on each
    half's function applied to the other half, none; the gain on s4 is still found."""
    import json
    from pathlib import Path

    from analyzer.cli import main

    sample = Path(__file__).resolve().parents[2] / "samples" / "building_multiplicative.csv.gz"
    cfg = tmp_path / "c.toml"
    cfg.write_text(
        '[[group]]\nname = "building"\nchannels = ["s0", "s1", "s2", "s3", "s4"]\n'
        'reference = ["s0", "s1", "s2"]\nuncertain = ["s3", "s4"]\ninputs = []\n'
        '[detectors.error_function]\napproach = "direct"\np = 150\n'
    )
    argv = ["run", str(sample), "--out", str(tmp_path / "o"), "--config", str(cfg), "--no-progress"]
    if train:
        argv += ["--train", train]
    assert main(argv) == 1
    capsys.readouterr()
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    assert [(f["channel"], f["type"]) for f in doc["faults"]] == [("s4", "multiplicative")]
    assert "error_function" in doc["faults"][0]["evidence"]["detectors"]
    ef = next(d for d in doc["detectors"] if d["name"] == "error_function")
    assert json.dumps(ef["model"]).count('"out-of-sample"') == 2


LEAKY_P = 8
"""Eq. 19's default ``p`` for the sweep's group (2 x 4 samples): the window the direct
approach used before it doubled it to 16 there (``ErrorFunction._direct_p``). At 8 the
functions leave part of the building's response in their residuals, which then alarm on
the healthy record when the response swings; the tests of the rules for such alarms pin
it, to keep alarms to apply them to."""


def _sweep_record(
    seed: int, tmp_path, kind: str | None = None, onset: float = 72.0, p: int | None = None
):
    """``benchmarks/sweep_error_function.py``'s record: 3 floors x 2 sensors, 120 s, the
    last two uncertain; ``kind`` on s4 from ``onset`` (1 sd, 1.3, 1 sd per 20 s); ``p``
    set in the config when given."""
    from pathlib import Path

    from analyzer.config import load_config
    from analyzer.simulate import inject_fault, simulate_building
    from analyzer.writers import write_archive

    names = [f"s{i}" for i in range(6)]

    def listed(xs: list[str]) -> str:
        return ", ".join(f'"{x}"' for x in xs)

    cfg = Path(tmp_path) / "g.toml"
    cfg.write_text(
        f'[[group]]\nname = "building"\nchannels = [{listed(names)}]\n'
        f"reference = [{listed(names[:-2])}]\nuncertain = [{listed(names[-2:])}]\n"
        "inputs = []\n" + ("" if p is None else f"[detectors.error_function]\np = {p}\n")
    )
    t, Y, cols = simulate_building(
        n_floors=3, duration_s=120.0, rate_hz=100.0, seed=seed, sensors_per_floor=2
    )
    if kind is not None:
        sd = float(Y[:2400, 4].std())
        size = {"additive": sd, "multiplicative": 1.3, "drift": sd / 20.0}[kind]
        Y[:, 4] = inject_fault(Y[:, 4], 100.0, kind, onset, size)
    path = Path(tmp_path) / "record.csv"
    write_archive(
        path, "csv", np.round(t * 1e9).astype(np.int64), {c: Y[:, k] for k, c in enumerate(cols)}
    )
    return path, load_config(str(cfg))


def test_every_uncertain_sensor_at_once_is_attributed_to_none(tmp_path):
    """Seed 2 of the sweep, healthy: both uncertain sensors' functions alarmed together
    three times (within 0.7 s), each reported as an `other` on its sensor (six false
    findings). A failure of one uncertain sensor raises its own function only
    (decoupling), so all of them at once is no uncertain sensor's fault: none now, each
    anomaly unattributed, with a note. (At the window the run now chooses, 16, the
    functions no longer alarm on this record at all; p = 8 keeps the three anomalies.)"""
    from analyzer.pipeline import RunOptions, analyze

    path, config = _sweep_record(2, tmp_path, p=LEAKY_P)
    a = analyze([str(path)], RunOptions(config=config, detectors=["error_function"], jobs=1))
    assert a.findings == [], [(f.channel, f.onset_s) for f in a.findings]
    ef = next(r for r in a.results if r.detector == "error_function")
    assert len(ef.unattributed) == 3
    assert all(chs == ("s4", "s5") and not beside for _, chs, beside in ef.unattributed)
    said = [n for n in ef.notes if "on every uncertain sensor of group 'building'" in n]
    assert len(said) == 3


@pytest.mark.parametrize("kind", ["additive", "multiplicative", "drift"])
def test_one_uncertain_sensor_failing_is_still_found(tmp_path, kind):
    """The same record with a fault on s4 from 72 s: found on s4 (its function alone
    rises), and the healthy anomalies before it are no findings."""
    from analyzer.pipeline import RunOptions, analyze

    path, config = _sweep_record(2, tmp_path, kind)
    a = analyze([str(path)], RunOptions(config=config, detectors=["error_function"], jobs=1))
    on_s4 = [f for f in a.findings if f.channel == "s4" and f.onset_s > 70.0]
    assert on_s4 and on_s4[0].type.value == kind
    assert not [f for f in a.findings if f.onset_s < 70.0]


@pytest.mark.parametrize("onset", [97.5, 98.5])
def test_a_lasting_fault_beside_the_other_functions_transient_is_kept(tmp_path, onset):
    """The review's case: seed 2's s5 function alarms from 96.7 to 99.2 s on the healthy
    record; an offset on s4 from ``onset`` begins within the long window of it. The two
    do not end together (s4's lasts), so it is no change of the whole: s4 is found (and
    s5's transient stays an `other`, as before the rule). At p = 8 (the transient is
    gone at the window the run now chooses)."""
    from analyzer.pipeline import RunOptions, analyze

    path, config = _sweep_record(2, tmp_path, "additive", onset, p=LEAKY_P)
    a = analyze([str(path)], RunOptions(config=config, detectors=["error_function"], jobs=1))
    found = [(f.channel, f.type.value) for f in a.findings if f.onset_s > 90.0]
    assert ("s4", "additive") in found, found
    ef = next(r for r in a.results if r.detector == "error_function")
    assert all(t0 < 90.0 for t0, _, _ in ef.unattributed)


def test_all_at_once_keeps_groups_of_one_name_apart_and_dates_the_onset():
    """Two [[group]] tables of one name (the config allows it) are two groups; an
    anomaly is dated at its earliest onset, not its first alarm."""
    from analyzer.detectors.base import Event
    from analyzer.detectors.error_function import _all_at_once

    def fn(channel, refs):
        return SimpleNamespace(channel=channel, group="a", channels=(channel, *refs))

    functions = [fn("s2", ["s0", "s1"]), fn("s3", ["s0", "s1"]), fn("s6", ["s4", "s5"])]
    functions.append(fn("s7", ["s4", "s5"]))

    def ev(channel, onset, first, end):
        return Event(
            channel=channel,
            type=FaultType.ADDITIVE,
            onset_s=onset,
            end_s=end,
            magnitude={},
            confidence=1.0,
            detector="error_function",
            evidence={"first_alarm_s": first},
        )

    notes: list[str] = []
    out: list = []
    # one sensor of each group: no group's every sensor
    lone = [ev("s2", 70.0, 70.5, None), ev("s6", 70.1, 70.6, None)]
    assert _all_at_once(lone, functions, 2.0, notes, out) == lone and out == []
    # the first group's both, lasting; the second's both, ending together; and a lasting
    # fault on s2 beside s3's transient, which outlasts it: kept
    kept = [ev("s2", 90.0, 90.1, None), ev("s3", 90.5, 91.0, 92.0)]
    both = [ev("s2", 70.0, 70.5, None), ev("s3", 70.1, 70.6, None), *kept]
    both += [ev("s6", 30.0, 30.2, 31.0), ev("s7", 29.9, 30.4, 31.1)]
    assert _all_at_once(both, functions, 2.0, notes, out) == kept
    assert sorted(out) == [(29.9, ("s6", "s7"), ()), (70.0, ("s2", "s3"), ())]
    assert len(notes) == 2
