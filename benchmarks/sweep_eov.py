"""Healthy sensors under environmental and operational variability (EOV): what the
analysis takes for a sensor fault when the structure, its load or its temperature
changes, and whether a real fault is still found there.

Each run simulates the shear building of ``sweep_isolation.py`` (``--floors`` floors x 2
accelerometers, f1 = 1.01 Hz, 2 % modal damping, band-limited ground acceleration at
100 Hz, ``--minutes`` long) with every sensor healthy, but with the conditions of one
**case** changing from 60 % of the record (50 % for ``quiet`` and the damage cases, inside
the training window for ``trainburst``). Sensor noise is white and fixed in absolute terms
at 20 dB below each channel's RMS in the training window (the first 20 %), so it does not
follow a later change in the excitation. Time-varying stiffness is held constant over each
second, discretized exactly (zero-order hold) and the state carried over from second to
second; constant stiffness is ``simulate_response``. The cases (:data:`CASES`):

* ``baseline``: nothing changes (the false-alarm floor);
* ``burst3``, ``burst10``: the excitation x3 / x10 for 45 s (traffic, a gust);
  ``burst5smooth``: x5 for 40 s with 5 s ramps (a passing truck);
* ``rise2``: the excitation rises linearly to 2x over the record; ``quiet``: x0.2 from
  50 % on (night);
* ``harmonic``: the broadband excitation drops to 0.3x and a machine's sine between modes
  1 and 2 is added; ``pedestrian``: the same with a 2 Hz walking load with harmonics, for
  120 s; ``narrowband``: the excitation becomes 0.5-1.5 Hz band noise of unit variance
  (level and colour change);
* ``harmonic_eq``, ``pedestrian_eq``, ``narrowband_eq``: those loads on 0.3x broadband,
  scaled so that the top floor's response RMS equals the training window's (colour without
  a level change); ``harmonic_res``: a sine at mode 2, the top floor at 2x;
* ``stiff3``, ``stiff5``: every storey's stiffness falls linearly by 3 % / 5 % over the
  record (temperature); ``stiffday``: +-2.5 %, one sine period over the record (a day);
* ``thermal``, ``thermal3``: an additive drift common to every channel, 1 / 3 standard
  deviations (each channel's, training window) over the record; ``thermalgain``: 2
  standard deviations times a per-channel coefficient U(0.5, 1.5) (strain gauges);
* ``damage``, ``damage_mid``: storey 1 / storey ``floors // 2`` (0-based) loses 10 % of
  its stiffness at 50 % (a structural change, not a sensor fault);
* ``trainburst``: a x5 burst of 30 s inside the training window.

Each record is written as a CSV in a temporary directory and analyzed with the defaults
(``pipeline.analyze``: the first 20 % as training window, every default detector). A
healthy run is counted **with a finding** when the analysis reports any fault (the CLI's
exit 1), **noted** when it reports none but its notes say something (an anomaly left
unattributed, for instance). The findings are counted by the detectors they rest on
(``evidence.detectors``).

With ``--fault`` (the control) each record also has a lasting offset of 2 standard
deviations (training window) on one sensor drawn from the seed, from 5 s after the change
(30 s for ``quiet`` and the damage cases, 60 % of the record for ``trainburst``) to the
end. A run is **right** with exactly one finding, on that sensor, of type additive;
**found** when that sensor has a finding of any type; **with extra** when another sensor
has one.

The cases come from a probe of commit ad51145 (2026-12-05): its tables are in
``benchmarks/README.md``. The whole grid (22 cases x 3 sizes x 5 seeds, 10-minute
records) should take 20 minutes at most (the probe's runs, through the CLI, took 2-6 s
each); a script, not a timed test::

    python benchmarks/sweep_eov.py [--cases burst3,thermal] [--floors 2,3,8]
                                   [--seeds 0:5] [--minutes 10] [--fault]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import numpy.typing as npt  # noqa: E402
from scipy import linalg, signal  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from analyzer.pipeline import RunOptions, analyze  # noqa: E402
from analyzer.simulate import (  # noqa: E402
    Building,
    band_limited_noise,
    shear_building,
    simulate_response,
)
from analyzer.writers import write_archive  # noqa: E402

FloatArray = npt.NDArray[np.float64]
Stiffness = Callable[[float], FloatArray]
"""Time (s) -> each storey's stiffness as a factor of the healthy one, shape (floors,)."""

RATE_HZ = 100.0
F1_HZ = 1.01
DAMPING = 0.02
SNR_DB = 20.0
TRAIN_FRACTION = 0.2
"""The analysis' default training window (records up to 50 minutes): the noise level and
every standard deviation the cases are scaled by are taken over it."""
CHANGE_FRACTION = 0.6
PIECE_S = 1.0
"""Time-varying stiffness is held constant over pieces this long."""
FAULT_SD = 2.0
SHORT = {
    "ar_kalman_bank": "bank",
    "detection_filter": "DF",
    "equivalent_model": "EM",
    "error_function": "EF",
}


@dataclass(frozen=True)
class Scene:
    """What a case builds its conditions from: the healthy building and its broadband
    ground acceleration (unit variance), and the seed's generator for the case's own
    draws."""

    floors: int
    duration_s: float
    t: FloatArray
    broadband: FloatArray
    frequencies_hz: FloatArray
    rng: np.random.Generator

    @property
    def change_s(self) -> float:
        return CHANGE_FRACTION * self.duration_s

    @property
    def train_rows(self) -> int:
        return int(TRAIN_FRACTION * self.duration_s * RATE_HZ)


class Load(NamedTuple):
    """A case's conditions: the ground acceleration, the storeys' stiffness over time
    (None: healthy throughout) and a drift added to every channel, in units of each
    channel's standard deviation (``spread``: times a coefficient U(0.5, 1.5) per
    channel)."""

    ground: FloatArray
    stiffness: Stiffness | None = None
    drift_sd: FloatArray | None = None
    spread: bool = False


class Case(NamedTuple):
    """A case's conditions and where its control fault starts: ``delay_s`` after
    ``change`` of the record."""

    build: Callable[[Scene], Load]
    change: float = CHANGE_FRACTION
    delay_s: float = 5.0


# --- the loads --------------------------------------------------------------------------


def _gated(s: Scene, envelope: FloatArray) -> Load:
    """The broadband excitation times ``envelope``: a change of level, not of colour."""
    return Load(envelope * s.broadband)


def _burst(factor: float, length_s: float = 45.0) -> Callable[[Scene], Load]:
    """Excitation x``factor`` for ``length_s`` from the change (traffic, a gust)."""

    def build(s: Scene) -> Load:
        on = (s.t >= s.change_s) & (s.t < s.change_s + length_s)
        return _gated(s, 1.0 + (factor - 1.0) * on)

    return build


def _smooth_burst(s: Scene) -> Load:
    """Excitation x5 for 40 s from the change, with 5 s ramps (a passing truck)."""
    t0 = s.change_s
    rise = np.clip(np.minimum((s.t - t0) / 5.0, (t0 + 40.0 - s.t) / 5.0), 0.0, 1.0)
    return _gated(s, 1.0 + 4.0 * rise)


def _rise(s: Scene) -> Load:
    """Excitation rising linearly to 2x over the record."""
    return _gated(s, 1.0 + s.t / s.duration_s)


def _quiet(s: Scene) -> Load:
    """Excitation x0.2 from 50 % on (a quiet night)."""
    return _gated(s, np.where(s.t >= 0.5 * s.duration_s, 0.2, 1.0))


def _train_burst(s: Scene) -> Load:
    """A x5 burst of 30 s inside the training window (at 40 % of it)."""
    t0 = 0.4 * TRAIN_FRACTION * s.duration_s
    return _gated(s, 1.0 + 4.0 * ((s.t >= t0) & (s.t < t0 + 30.0)))


def _sine(s: Scene, f_hz: float) -> FloatArray:
    """A machine at ``f_hz``, random phase, unit variance."""
    return np.sqrt(2.0) * np.sin(2.0 * np.pi * f_hz * s.t + s.rng.uniform(0.0, 2.0 * np.pi))


def _walking(s: Scene) -> FloatArray:
    """A walking load, unit variance: a step rate near 2 Hz (sd 0.05 Hz between seeds,
    wandering by 0.02 Hz within the record) with its 2nd and 3rd harmonics."""
    f0 = 2.0 + 0.05 * s.rng.standard_normal()
    wander = 0.02 * band_limited_noise(s.t.size, RATE_HZ, 0.1, s.rng)
    phase = np.cumsum(2.0 * np.pi * (f0 + wander) / RATE_HZ)
    load = np.sin(phase) + 0.4 * np.sin(2.0 * phase) + 0.1 * np.sin(3.0 * phase)
    return load / np.std(load)


def _narrowband(s: Scene) -> FloatArray:
    """0.5-1.5 Hz band noise (4th-order Butterworth band-pass), unit variance."""
    b, a = signal.butter(4, [0.5, 1.5], btype="band", fs=RATE_HZ)
    band = signal.lfilter(b, a, s.rng.standard_normal(s.t.size))
    return band / np.std(band)


def _mode_gap(s: Scene) -> float:
    return 0.5 * float(s.frequencies_hz[0] + s.frequencies_hz[1])


def _harmonic(s: Scene) -> Load:
    """From the change, the broadband excitation drops to 0.3x and a machine's sine
    (unit variance) between modes 1 and 2 is added: the level drops."""
    on = s.t >= s.change_s
    return Load(np.where(on, 0.3 * s.broadband + _sine(s, _mode_gap(s)), s.broadband))


def _pedestrian(s: Scene) -> Load:
    """For 120 s from the change, 0.3x broadband plus a walking load of unit variance."""
    on = (s.t >= s.change_s) & (s.t < s.change_s + 120.0)
    return Load(np.where(on, 0.3 * s.broadband + _walking(s), s.broadband))


def _narrowband_case(s: Scene) -> Load:
    """From the change, the excitation is 0.5-1.5 Hz band noise of unit variance: its
    level and colour change."""
    return Load(np.where(s.t >= s.change_s, _narrowband(s), s.broadband))


def _coloured(make: Callable[[Scene], FloatArray], target: float) -> Callable[[Scene], Load]:
    """From the change, 0.3x broadband plus the load ``make`` draws, scaled so that the top
    floor's response RMS is ``target`` x the training window's: a change of colour (and
    with ``target`` 1 none of level)."""

    def build(s: Scene) -> Load:
        on = s.t >= s.change_s
        background = np.where(on, 0.3, 1.0) * s.broadband
        load = np.where(on, make(s), 0.0)
        building = shear_building(s.floors, F1_HZ, DAMPING)
        top_b = simulate_response(building, background, RATE_HZ)[:, -1]
        top_l = simulate_response(building, load, RATE_HZ)[:, -1]
        wanted = target**2 * np.var(top_b[: s.train_rows]) - np.var(top_b[on])
        return Load(background + np.sqrt(max(wanted, 0.0) / np.var(top_l[on])) * load)

    return build


def _uniform_stiffness(
    shape: Callable[[float, float], float],
) -> Callable[[Scene], Load]:
    """Every storey's stiffness times ``shape(t, duration)`` (temperature)."""

    def build(s: Scene) -> Load:
        ones = np.ones(s.floors)
        return Load(s.broadband, stiffness=lambda t: ones * shape(t, s.duration_s))

    return build


def _damaged(storey: Callable[[int], int]) -> Callable[[Scene], Load]:
    """Storey ``storey(floors)`` (0: between the ground and floor 1) loses 10 % of its
    stiffness at 50 % of the record."""

    def build(s: Scene) -> Load:
        which = np.arange(s.floors) == storey(s.floors)

        def stiffness(t: float) -> FloatArray:
            return np.where(which & (t >= 0.5 * s.duration_s), 0.9, 1.0)

        return Load(s.broadband, stiffness=stiffness)

    return build


def _thermal(sd: float, spread: bool = False) -> Callable[[Scene], Load]:
    """A drift common to every channel growing linearly to ``sd`` standard deviations over
    the record (``spread``: times a coefficient U(0.5, 1.5) per channel)."""

    def build(s: Scene) -> Load:
        return Load(s.broadband, drift_sd=sd * s.t / s.duration_s, spread=spread)

    return build


CASES: dict[str, Case] = {
    "baseline": Case(lambda s: Load(s.broadband)),
    "burst3": Case(_burst(3.0)),
    "burst10": Case(_burst(10.0)),
    "burst5smooth": Case(_smooth_burst),
    "rise2": Case(_rise),
    "quiet": Case(_quiet, change=0.5, delay_s=30.0),
    "harmonic": Case(_harmonic),
    "pedestrian": Case(_pedestrian),
    "harmonic_eq": Case(_coloured(lambda s: _sine(s, _mode_gap(s)), 1.0)),
    "pedestrian_eq": Case(_coloured(_walking, 1.0)),
    "harmonic_res": Case(_coloured(lambda s: _sine(s, float(s.frequencies_hz[1])), 2.0)),
    "narrowband_eq": Case(_coloured(_narrowband, 1.0)),
    "narrowband": Case(_narrowband_case),
    "stiff3": Case(_uniform_stiffness(lambda t, d: 1.0 - 0.03 * t / d)),
    "stiffday": Case(_uniform_stiffness(lambda t, d: 1.0 + 0.025 * np.sin(2.0 * np.pi * t / d))),
    "stiff5": Case(_uniform_stiffness(lambda t, d: 1.0 - 0.05 * t / d)),
    "thermal": Case(_thermal(1.0)),
    "thermal3": Case(_thermal(3.0)),
    "thermalgain": Case(_thermal(2.0, spread=True)),
    "damage": Case(_damaged(lambda floors: 0), change=0.5, delay_s=30.0),
    "damage_mid": Case(_damaged(lambda floors: floors // 2), change=0.5, delay_s=30.0),
    "trainburst": Case(_train_burst, delay_s=0.0),
}
"""Case name -> its conditions (the module docstring says what each models)."""


# --- the structure ----------------------------------------------------------------------


def storey_building(floors: int, factors: FloatArray) -> Building:
    """:func:`analyzer.simulate.shear_building` with storey ``i`` (between floor ``i - 1``,
    the ground for ``i = 0``, and floor ``i``) ``factors[i]`` times as stiff; modal damping
    of the changed structure's own modes."""
    w1_unit = 2.0 * np.sin(np.pi / (2.0 * (2 * floors + 1)))
    k = (2.0 * np.pi * F1_HZ / w1_unit) ** 2 * np.asarray(factors, dtype=np.float64)
    above = k[1:]
    K = np.diag(k + np.append(above, 0.0)) - np.diag(above, 1) - np.diag(above, -1)
    w2, phi = linalg.eigh(K)
    w = np.sqrt(w2)
    Cd = phi @ np.diag(2.0 * DAMPING * w) @ phi.T
    A = np.block([[np.zeros((floors, floors)), np.eye(floors)], [-K, -Cd]])
    B = np.concatenate([np.zeros(floors), -np.ones(floors)])[:, None]
    C = np.hstack([-K, -Cd])
    return Building(floors, A, B, C, np.zeros((floors, 1)), w / (2.0 * np.pi), DAMPING)


def respond(floors: int, ground: FloatArray, stiffness: Stiffness | None) -> FloatArray:
    """Floor absolute accelerations (N, floors) under ``ground``. With ``stiffness`` the
    structure is held constant over each :data:`PIECE_S` piece (consecutive equal pieces
    joined), discretized exactly (ZOH) and run mode by mode as
    ``z[k + 1] = lambda z[k] + g u[k]`` by ``lfilter``, the state carried over."""
    if stiffness is None:
        return simulate_response(shear_building(floors, F1_HZ, DAMPING), ground, RATE_HZ)
    n = ground.shape[0]
    piece = int(PIECE_S * RATE_HZ)
    spans: list[tuple[int, int, tuple[float, ...]]] = []
    for k0 in range(0, n, piece):
        key = tuple(float(v) for v in np.round(stiffness(k0 / RATE_HZ), 6))
        k1 = min(n, k0 + piece)
        if spans and spans[-1][2] == key:
            spans[-1] = (spans[-1][0], k1, key)
        else:
            spans.append((k0, k1, key))
    out = np.empty((n, floors))
    x = np.zeros(2 * floors)
    models: dict[tuple[float, ...], tuple[FloatArray, ...]] = {}
    for k0, k1, key in spans:
        if key not in models:
            ad, bd, c, _ = storey_building(floors, np.array(key)).discrete(RATE_HZ)
            lam, V = np.linalg.eig(ad)
            Vinv = np.linalg.inv(V)
            models[key] = (c, lam, V, Vinv, Vinv @ bd[:, 0])
        c, lam, V, Vinv, g = models[key]
        z0 = Vinv @ x
        drive = np.outer(ground[k0:k1], g)
        Z = np.empty((k1 - k0, 2 * floors), dtype=np.complex128)
        z_end = np.empty(2 * floors, dtype=np.complex128)
        for i, li in enumerate(lam):
            Z[:, i], zf = signal.lfilter([0.0, 1.0], [1.0, -li], drive[:, i], zi=[z0[i]])
            z_end[i] = zf[0]
        out[k0:k1] = np.real(Z @ V.T) @ c.T
        x = np.real(V @ z_end)
    return out


def record(
    name: str, floors: int, seed: int, minutes: float, fault: bool
) -> tuple[FloatArray, FloatArray, str | None]:
    """``(t, Y, faulty)``: times (s), the (N, 2 floors) readings of case ``name`` and, with
    ``fault``, the channel with the control offset (else None)."""
    case = CASES[name]
    rng = np.random.default_rng(seed)
    duration = 60.0 * minutes
    n = int(duration * RATE_HZ)
    t = np.arange(n) / RATE_HZ
    freqs = shear_building(floors, F1_HZ, DAMPING).frequencies_hz
    cut = min(0.4 * RATE_HZ, 2.0 * float(freqs[-1]))
    scene = Scene(floors, duration, t, band_limited_noise(n, RATE_HZ, cut, rng), freqs, rng)
    load = case.build(scene)
    clean = np.repeat(respond(floors, load.ground, load.stiffness), 2, axis=1)
    train = scene.train_rows
    rms = np.sqrt(np.mean(clean[:train] ** 2, axis=0))
    Y = clean + rng.standard_normal(clean.shape) * rms / 10.0 ** (SNR_DB / 20.0)
    sd = np.std(Y[:train], axis=0)
    if load.drift_sd is not None:
        coef = rng.uniform(0.5, 1.5, Y.shape[1]) if load.spread else np.ones(Y.shape[1])
        Y += np.outer(load.drift_sd, coef * sd)
    if not fault:
        return t, Y, None
    k = int(np.random.default_rng(10_000 + seed).integers(Y.shape[1]))
    onset = case.change * duration + case.delay_s
    Y[int(onset * RATE_HZ) :, k] += FAULT_SD * sd[k]
    return t, Y, f"s{k}"


# --- the runs ---------------------------------------------------------------------------


class Found(NamedTuple):
    channel: str
    type: str
    onset_s: float
    end_s: float | None
    detectors: tuple[str, ...]


class Run(NamedTuple):
    case: str
    channels: int
    seed: int
    found: list[Found]
    noted: bool
    """No finding, but notes (an anomaly left unattributed, ...)."""
    seconds: float
    """The analysis alone (the record's simulation and writing apart)."""
    faulty: str | None
    skipped: tuple[str, ...]
    """Detectors the analysis did not run (too little training, ...)."""


def run(name: str, floors: int, seed: int, minutes: float, fault: bool, folder: Path) -> Run:
    """One record simulated, written as CSV in ``folder``, analyzed with the defaults."""
    t, Y, faulty = record(name, floors, seed, minutes, fault)
    path = folder / f"{name}_{floors}_{seed}.csv"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {f"s{i}": Y[:, i] for i in range(Y.shape[1])})
    try:
        start = time.perf_counter()
        analysis = analyze([str(path)], RunOptions())
        seconds = time.perf_counter() - start
    finally:
        path.unlink()
    found = [
        Found(
            f.channel,
            f.type.value,
            float(f.onset_s),
            f.end_s,
            tuple(f.evidence.get("detectors") or [f.detector]),
        )
        for f in analysis.findings
    ]
    noted = not found and bool(analysis.notes)
    skipped = tuple(SHORT.get(d, d) for d in sorted(analysis.skipped))
    return Run(name, Y.shape[1], seed, found, noted, seconds, faulty, skipped)


def verdict(r: Run) -> str:
    """Healthy: finding / noted / none. Control: right / extra (the fault's sensor found,
    others too) / found (only that sensor, not as one offset) / missed."""
    if r.faulty is None:
        return "finding" if r.found else "noted" if r.noted else "none"
    hit = any(f.channel == r.faulty for f in r.found)
    others = any(f.channel != r.faulty for f in r.found)
    if len(r.found) == 1 and hit and r.found[0].type == "additive":
        return "right"
    return "missed" if not hit else "extra" if others else "found"


def by_detectors(found: list[Found]) -> str:
    """Findings counted by the detectors they rest on: ``EM 12, bank+EM 3``."""
    c = Counter("+".join(SHORT.get(d, d) for d in f.detectors) for f in found)
    return ", ".join(f"{k} {v}" for k, v in c.most_common()) or "-"


def describe(found: list[Found]) -> str:
    return ", ".join(
        f"{f.channel} {f.type} {f.onset_s:.1f}-{'end' if f.end_s is None else f'{f.end_s:.1f}'}"
        f" ({'+'.join(SHORT.get(d, d) for d in f.detectors)})"
        for f in found
    )


def cell(runs: list[Run]) -> str:
    if not runs:
        return "-"
    if runs[0].faulty is None:
        alarmed = sum(bool(r.found) for r in runs)
        findings = sum(len(r.found) for r in runs)
        noted = sum(r.noted for r in runs)
        return f"{alarmed}/{len(runs)} ({findings} f; {noted} noted)"
    v = Counter(verdict(r) for r in runs)
    found = v["right"] + v["extra"] + v["found"]
    return f"{v['right']}/{len(runs)} right, {found} found, {v['extra']} w/ extra"


def table(runs: list[Run], cases: list[str], channels: list[int], fault: bool) -> None:
    """Per case and record size: the counts of :func:`cell`; then which detectors the
    findings rest on (with ``fault``: those on the faulty sensor and the others)."""
    grid = {
        (c, m): [r for r in runs if r.case == c and r.channels == m]
        for c in cases
        for m in channels
    }
    heads = ["case", *(f"{m} ch" for m in channels), "median s"]
    rows = []
    for c in cases:
        times = [r.seconds for m in channels for r in grid[c, m]]
        rows.append([c, *(cell(grid[c, m]) for m in channels), f"{statistics.median(times):.1f}"])
    widths = [max(len(x) for x in col) + 2 for col in zip(heads, *rows, strict=True)]
    print()
    for row in (heads, *rows):
        print(
            "".join(
                x.ljust(w) if j == 0 else x.rjust(w)
                for j, (x, w) in enumerate(zip(row, widths, strict=True))
            )
        )
    legend = ", ".join(f"{v} = {k}" for k, v in SHORT.items())
    print(f"\nfindings by the detectors they rest on ({legend}):")
    width = max(len(c) for c in cases) + 2
    for c in cases:
        mine = [r for r in runs if r.case == c]
        if not fault:
            print(f"  {c:<{width}}{by_detectors([f for r in mine for f in r.found])}")
            continue
        on = [f for r in mine for f in r.found if f.channel == r.faulty]
        off = [f for r in mine for f in r.found if f.channel != r.faulty]
        print(f"  {c:<{width}}faulty sensor: {by_detectors(on)}; others: {by_detectors(off)}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--cases",
        default=",".join(CASES),
        metavar="NAME[,NAME...]",
        help=f"cases to run (default: all: {', '.join(CASES)})",
    )
    ap.add_argument(
        "--floors",
        default="2,3,8",
        metavar="F[,F...]",
        help="floors, 2 sensors each (default 2,3,8: 4, 6 and 16 channels)",
    )
    ap.add_argument("--seeds", default="0:5", help="first:stop (default 0:5)")
    ap.add_argument("--minutes", type=float, default=10.0, help="record length (default 10)")
    ap.add_argument(
        "--fault",
        action="store_true",
        help=f"the control: a lasting {FAULT_SD:g}-sd offset on one sensor during the change",
    )
    args = ap.parse_args(argv)
    cases = args.cases.split(",")
    unknown = [c for c in cases if c not in CASES]
    if unknown:
        ap.error(f"--cases: unknown {', '.join(unknown)} (known: {', '.join(CASES)})")
    try:
        floors = [int(x) for x in args.floors.split(",")]
        first, stop = (int(x) for x in args.seeds.split(":"))
    except ValueError as err:
        ap.error(f"--floors {args.floors!r} / --seeds {args.seeds!r}: {err}")
    if min(floors) < 2:
        ap.error(f"--floors: {min(floors)} floors make {2 * min(floors)} channels, expected >= 2")
    if stop <= first:
        ap.error(f"--seeds: {args.seeds} holds no seed (expected first:stop, first < stop)")
    if args.minutes <= 0:
        ap.error(f"--minutes: {args.minutes:g} is not a positive length")
    channels = [2 * f for f in floors]
    print(
        f"sweep_eov: {len(cases)} cases, {', '.join(map(str, channels))} channels, "
        f"{args.minutes:g} min at {RATE_HZ:g} Hz, seeds {args.seeds}, "
        + (f"a {FAULT_SD:g}-sd offset on one sensor (control)" if args.fault else "healthy sensors")
        + f", OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}",
        flush=True,
    )
    runs = []
    with tempfile.TemporaryDirectory(prefix="sweep_eov_") as tmp:
        for c in cases:
            for f in floors:
                for seed in range(first, stop):
                    r = run(c, f, seed, args.minutes, args.fault, Path(tmp))
                    runs.append(r)
                    faulty = f" {r.faulty:<4}" if r.faulty else ""
                    skipped = f" [{'+'.join(r.skipped)} skipped]" if r.skipped else ""
                    print(
                        f"  {c:<14}{r.channels:>3} ch seed {seed:<3}{faulty} {verdict(r):<8}"
                        f"{r.seconds:5.1f} s{skipped}  {describe(r.found)}",
                        flush=True,
                    )
    table(runs, cases, channels, args.fault)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
