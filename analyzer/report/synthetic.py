"""A synthetic :class:`~analyzer.findings.Analysis` of any size, for the report's
benchmark and tests: what the pipeline would hand the report for a long archive, built
in seconds instead of running the detectors.

The channels are a few lightly damped modes plus noise (a structure under ambient
excitation); each of two pseudo-detectors has a residual per channel (white noise of a
known deviation, plus the injected fault where there is one) and the fault-free
estimate ``measured - residual`` on faulty channels. Everything after that is the real
code: thresholds from :func:`analyzer.diagnosis.changes.calibrate` on the training
residual, events merged by :func:`analyzer.diagnosis.merge_events`, innovation tests by
:func:`analyzer.diagnosis.evidence.attach_evidence` and ``training_tests``. Long arrays
are written chunk by chunk into ``.npy`` memory maps when ``workdir`` is given, as the
pipeline does for long archives.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.detectors.base import DetectorResult, Event
from analyzer.diagnosis import merge_events
from analyzer.diagnosis.changes import calibrate, default_window
from analyzer.diagnosis.evidence import attach_evidence, training_tests
from analyzer.findings import Analysis
from analyzer.readers.base import InputInfo
from analyzer.store import ChannelInfo
from analyzer.types import NS_PER_S, FaultType, Format

FloatArray = npt.NDArray[np.float64]

START_NS = 1_767_225_600 * NS_PER_S
"""2026-01-01T00:00:00Z."""
CHUNK = 1 << 20
"""Rows generated at a time."""
DETECTORS = ("ar_kalman_bank", "detection_filter")
RESIDUAL_SD = 0.1


@dataclass(frozen=True, slots=True)
class SyntheticFault:
    """A fault of ``size`` on channel ``channel`` (index) from ``onset_s`` to ``end_s``:
    an offset, a gain (``size`` is the ratio) or a drift (``size`` per second)."""

    channel: int
    type: FaultType
    onset_s: float
    end_s: float | None
    size: float


def _alloc(workdir: Path | None, name: str, shape: tuple[int, ...]) -> FloatArray:
    if workdir is None:
        return np.zeros(shape, dtype=np.float64)
    return np.lib.format.open_memmap(
        workdir / f"{name}.npy", mode="w+", dtype=np.float64, shape=shape
    )


def _fault_signal(f: SyntheticFault, t: FloatArray, y: FloatArray) -> FloatArray:
    """What the fault adds to the healthy ``y`` at times ``t`` (zero outside its period)."""
    on = (t >= f.onset_s) & (t < (np.inf if f.end_s is None else f.end_s))
    if f.type is FaultType.ADDITIVE:
        return np.where(on, f.size, 0.0)
    if f.type is FaultType.MULTIPLICATIVE:
        return np.where(on, (f.size - 1.0) * y, 0.0)
    if f.type is FaultType.DRIFT:
        return np.where(on, f.size * (t - f.onset_s), 0.0)
    return np.where(on, -y, 0.0)  # other: a dead sensor reading zero


def synthetic_analysis(
    duration_s: float = 120.0,
    channels: int = 4,
    rate_hz: float = 50.0,
    faults: Sequence[SyntheticFault] = (),
    *,
    names: Sequence[str] | None = None,
    gap: tuple[int, float, float] | None = None,
    workdir: Path | None = None,
    seed: int = 0,
    false_alarm_rate: float = 1e-6,
) -> Analysis:
    """An Analysis of ``channels`` channels over ``duration_s`` seconds at ``rate_hz``
    with the given faults; ``gap = (channel, start_s, end_s)`` blanks a stretch (NaN).
    With ``workdir``, the aligned values, residuals and estimates are ``.npy`` memory
    maps there (the caller removes the folder)."""
    n = int(round(duration_s * rate_hz)) + 1
    m = int(channels)
    names = list(names) if names is not None else [f"/accel.data[{j}]" for j in range(m)]
    if len(names) != m:
        raise ValueError(f"expected {m} channel names, got {len(names)}")
    rng = np.random.default_rng(seed)
    freqs = np.array([1.1, 3.2, 5.3])
    amps = rng.uniform(0.5, 1.5, size=(3, m))
    phases = rng.uniform(0, 2 * np.pi, size=(3, m))
    values = _alloc(workdir, "aligned", (n, m))
    residual = {d: _alloc(workdir, f"residual_{d}", (m, n)) for d in DETECTORS}
    faulty = sorted({f.channel for f in faults})
    reference = {
        d: {j: _alloc(workdir, f"reference_{d}_{j}", (n,)) for j in faulty} for d in DETECTORS
    }
    for a in range(0, n, CHUNK):
        b = min(n, a + CHUNK)
        t = np.arange(a, b) / rate_hz
        # slowly modulated modes: the envelope changes over minutes, as ambient loads do
        mod = 1.0 + 0.5 * np.sin(2 * np.pi * t / 600.0)[:, None]
        healthy = mod * sum(
            amps[i] * np.sin(2 * np.pi * freqs[i] * t[:, None] + phases[i]) for i in range(3)
        ) + 0.05 * rng.standard_normal((b - a, m))
        block = healthy.copy()
        for f in faults:
            block[:, f.channel] += _fault_signal(f, t, healthy[:, f.channel])
        if gap is not None:
            block[(t >= gap[1]) & (t < gap[2]), gap[0]] = np.nan
        values[a:b] = block
        for d in DETECTORS:
            r = RESIDUAL_SD * rng.standard_normal((b - a, m)) + (block - healthy)
            r[np.isnan(block)] = np.nan
            residual[d][:, a:b] = r.T
            for j in faulty:
                reference[d][j][a:b] = block[:, j] - r[:, j]
    # a fifth of the record, at most ten minutes, or a thousand samples for a slow record
    # (the thresholds' calibration needs a few hundred)
    train_s = min(0.2 * duration_s, max(600.0, 1000.0 / rate_hz))
    train = (0, min(n, int(round(train_s * rate_hz)) + 1))
    window = default_window(rate_hz)
    results = []
    for k, d in enumerate(DETECTORS):
        thresholds = {
            names[j]: calibrate(
                residual[d][j, train[0] : train[1]], window, false_alarm_rate / m
            ).as_dict()
            for j in range(m)
        }
        events = [
            Event(
                names[f.channel],
                f.onset_s + 0.01 * k,
                f.end_s,
                f.type,
                _magnitude(f),
                0.97 - 0.02 * k,
                d,
                {"first_alarm_s": f.onset_s + 0.05, "p_value": 1e-30},
            )
            for f in faults
        ]
        results.append(
            DetectorResult(
                detector=d,
                channels=tuple(names),
                params={"order": 8, "window": window, "false_alarm_rate": false_alarm_rate},
                events=events,
                residuals={names[j]: residual[d][j] for j in range(m)},
                reference={names[j]: reference[d][j] for j in faulty},
                sigma={names[j]: _std(thresholds[names[j]]) for j in range(m)},
                thresholds=thresholds,
                model={
                    "type": "synthetic",
                    "order": 8,
                    "r_squared": {c: round(0.95 + 0.001 * i, 4) for i, c in enumerate(names)},
                },
            )
        )
    findings = merge_events(ev for r in results for ev in r.events)
    attach_evidence(findings, results, rate_hz, train)
    for r in results:
        r.model["training_tests"] = training_tests(r, train)
    end_ns = START_NS + int(round((n - 1) / rate_hz * NS_PER_S))
    infos = []
    for j, c in enumerate(names):
        col = values[:, j]
        finite = int(np.count_nonzero(np.isfinite(col)))
        infos.append(
            ChannelInfo(
                c,
                finite,
                START_NS,
                end_ns,
                rate_hz,
                1 if gap is not None and gap[0] == j else 0,
                finite,
                float(np.nanmin(col)),
                float(np.nanmax(col)),
            )
        )
    size = n * m * 8
    return Analysis(
        inputs=[InputInfo(Path("synthetic/archive.mcap"), Format.MCAP, size, "0" * 64)],
        channels=infos,
        analyzed=tuple(names),
        rate_hz=rate_hz,
        start_ns=START_NS,
        absolute_time=True,
        n=n,
        train=train,
        results=results,
        findings=findings,
        values=values,
        notes=["synthetic analysis (analyzer.report.synthetic)"],
        timings={},
    )


def _std(th: dict[str, object]) -> float:
    v = th["std"]
    return float(v) if isinstance(v, (int, float)) else 0.0


def _magnitude(f: SyntheticFault) -> dict[str, float]:
    key = {
        FaultType.ADDITIVE: "offset",
        FaultType.MULTIPLICATIVE: "gain",
        FaultType.DRIFT: "rate_per_s",
    }.get(f.type)
    return {} if key is None else {key: float(f.size)}


def describe(analysis: Analysis) -> dict[str, Any]:
    """A few numbers about a synthetic analysis (for the benchmark's printout)."""
    return {
        "samples": analysis.n,
        "channels": len(analysis.analyzed),
        "values": analysis.n * len(analysis.analyzed),
        "findings": len(analysis.findings),
    }


__all__ = ["SyntheticFault", "describe", "synthetic_analysis"]
