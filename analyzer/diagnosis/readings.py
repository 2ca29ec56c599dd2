"""Is a lone equivalent-model fault in the sensor's reading? The other detectors' residuals
of the same sensor say.

A sensor's fault is in its reading, and a fault in a reading reaches, in full, every
residual that compares that reading with an estimate made without it: the AR bank's
residual of sensor ``c`` is ``y_c`` minus the estimate of the Kalman estimator that leaves
``c`` out (Chang et al. 2017), and the detection filter's is its estimate of a fault in
``c``'s output direction (Park et al. 1994), both in ``c``'s units. The equivalent
model's residual of ``c`` is the error of ``c``'s relation to its assistant sensors
(Wang & Song 2014, Eq. 30), which grows with the structure's response wherever that
relation is not exact: when the excitation changes level or colour (a machine's sine at a
mode, narrowband load) it grows on one sensor more than on the others, and the network's
law 0 names that sensor. The fitted shape is then mostly a small gain (the relation's
error is proportional to the response), a fault the sensor's reading does not hold: on
``benchmarks/sweep_eov.py`` (healthy sensors, the load changing from 60 % of the record)
the five false findings, all the equivalent model's alone (gains of 0.87-0.98 and one
``other``), had the bank's residual of the same sensor over the same stretch carry
-0.92 to +0.01 of the fitted fault (standard errors 0.001-0.08), the detection filter's
-0.48 to +0.01, while the equivalent model's own lone findings of a real fault (a 2-sd
offset, a drift: ``--fault``) were carried at 0.95-1.07 and 0.92-1.06.

The test (:func:`refuted_by_readings`), for each finding that rests on the equivalent
model alone: its fault signal ``x`` over its stretch (the fitted shape, from the
equivalent model's magnitude: an offset ``D``, a drift ``r (t - t0)``, a gain ``a`` as
``(1 - 1/a) y`` of the reading ``y``, since ``y = a y_true``; for an ``other`` fault,
the equivalent model's residual itself less its healthy mean, whose healthy noise energy
is taken out of the fit's denominator: errors in the regressor would otherwise pull the
ratio towards zero), and each reading residual ``z`` less its healthy mean, regressed on
it through the origin: ``beta = sum x z / sum x^2``, with its standard error from the
stretch's scatter about the fit and the residual's healthy correlation time
(:func:`~analyzer.diagnosis.classify.correlation_time`). A sensor's fault gives
``beta`` near 1. The finding is refused (a note says why) when every reading residual
of the sensor that the run has (the bank's and the detection filter's, at least one)
carries less than :data:`CARRIED` of it at :data:`SIGMAS` standard errors: ``beta +
SIGMAS se < CARRIED``.

Another sensor's fault under way reaches the bank's and the filter's residuals of ``c``
through the estimates (they take that sensor in), in a share the regression cannot
know: a finding that begins while other findings last is judged with their fault
signals as further regressors (their fitted shapes), ``z = beta x + sum_g gamma_g
x_g``, ``beta`` and its standard error (the ``(1, 1)`` element of the inverse normal
matrix, the same scatter and correlation time) read as above, so that the other faults'
share is not taken for this one's. The stretch ends at the first of their reported ends
(past it their share is not known: :func:`_stretch`), and a finding whose signal is, to
rounding, a sum of theirs (an offset beside a lasting offset) is not judged
(:data:`COLLINEAR`). On ``sweep_eov.py --fault`` the two lone gains beside the control's
offset (harmonic_res 4 ch seed 4, narrowband 6 ch seed 3), not judged before, had the
bank's residual carry -0.92 +- 0.04 and -0.08 +- 0.04 of them. A finding beside one
whose shape has no magnitude to build its signal from (an ``other``, a frozen sensor) is
still not judged. One judged is judged up to the onset of the next other finding (or
the end of one beside it), when that leaves at least the long alarm window
(:func:`shortest`). A frozen or clipped sensor is told by its readings (``stuck.py``,
``clipping.py``): not judged here either.

A run with a saved model (``--model``, and so ``watch --model``) has no healthy window
of its own, only the filters' warm-up: the residuals' healthy means, standard
deviations and correlation times are those of the training run's window, saved with
the model (:func:`residual_health`, ``SavedModel.reading_health``). A model saved
before they were has none, and its runs' lone equivalent-model findings stand as the
detector reported them. Fitted on the first 40 % of ``sweep_eov.py``'s narrowband 6 ch
seed 3 and run on the rest, the false gain on s5 the model run reported is refused
(the bank's -0.09 +- 0.04).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.detectors.base import DetectorResult
from analyzer.diagnosis.changes import LONG_FACTOR, default_window
from analyzer.diagnosis.classify import correlation_time
from analyzer.diagnosis.evidence import settled
from analyzer.diagnosis.merge import Finding
from analyzer.diagnosis.streamed import series_moments
from analyzer.timeutil import seconds_text
from analyzer.types import FaultType

FloatArray = npt.NDArray[np.float64]

JUDGED_DETECTOR = "equivalent_model"
"""The detector whose lone findings are judged."""

READING_RESIDUALS = ("ar_kalman_bank", "detection_filter")
"""The detectors whose residual of a sensor carries a fault of its reading in full (module
docstring)."""

CARRIED = 0.5
"""A reading residual refutes a fault when it carries less than this share of it."""

SIGMAS = 3.0
"""Standard errors the share must lie below :data:`CARRIED` by."""

COLLINEAR = 1.0 / np.sqrt(np.finfo(np.float64).eps)
"""The variance inflation of the fault's share (``(X'X)^-1_00 (X'X)_00``, 1 when its
signal is orthogonal to the other faults') beyond which its signal is, to rounding, a
sum of theirs (an offset beside another sensor's lasting offset: two constants) and
there is no share to read: half the digits of the solve are lost there. Without it,
such a finding got ``beta`` from the rounding (+2.41, +1.13, +0.69) with a standard error
of about 20 000."""

PIECE = 1 << 20
"""Rows read at a time from the residuals (a lone fault may last for days)."""

READ_BY_READINGS = ("frozen", "clipped")
"""Evidence keys of findings told from the readings themselves (not judged here)."""


def shortest(rate_hz: float) -> int:
    """The fewest rows a finding is judged on: the long alarm window (2 s at 100 Hz). A
    lone fault's onset may be traced a few tenths of a second before the fault (an
    offset of 0.2 sd from 360.0 s was named from 359.6 s), and another sensor's finding
    from the fault's onset ends the stretch there: judged on a quarter of a second,
    mostly before the fault, a real offset that the bank's residual carried in full
    from its onset was refused (the bank's +0.20 +- 0.06)."""
    return LONG_FACTOR * default_window(rate_hz)


@dataclass(frozen=True, slots=True)
class Carried:
    """What one reading residual carries of a fault: ``beta`` (1 for the sensor's fault)
    and its standard error ``se``, over ``samples`` rows."""

    detector: str
    beta: float
    se: float
    samples: int

    @property
    def refutes(self) -> bool:
        return self.beta + SIGMAS * self.se < CARRIED

    def as_dict(self) -> dict[str, Any]:
        return {"beta": self.beta, "se": self.se, "samples": self.samples}


def _lone(f: Finding) -> bool:
    return list(f.evidence.get("detectors") or [f.detector]) == [JUDGED_DETECTOR]


def _read_by_readings(f: Finding) -> bool:
    return any(k in f.evidence for k in READ_BY_READINGS) or any(
        k.startswith("clipped") or k == "stuck_at" for k in f.magnitude
    )


def _stretch(
    f: Finding, others: Sequence[Finding], n: int, rate_hz: float
) -> tuple[tuple[int, int], list[Finding]]:
    """The rows ``f`` is judged on, up to the onset of the next other finding or the end
    of one under way at its onset, and the other findings under way at its onset (their
    faults are fitted with it). Past a reported end the other fault's share is not known:
    an end reported early while that fault lasts would leave its share, constant, to be
    taken for an offset's or a drift's (a real offset of 0.3 beside another sensor's
    offset of 1.0 reaching the residuals at -0.6, its end reported 180 s early, was
    refused at -1.0 +- 0.002)."""
    a = max(0, int(round(f.onset_s * rate_hz)))
    b = n if f.end_s is None else min(n, int(round(f.end_s * rate_hz)) + 1)
    under_way = []
    for g in others:
        if g.onset_s <= f.onset_s and (g.end_s is None or g.end_s > f.onset_s):
            under_way.append(g)
            if g.end_s is not None:
                b = min(b, int(round(g.end_s * rate_hz)) + 1)
        elif f.onset_s < g.onset_s:
            b = min(b, int(round(g.onset_s * rate_hz)))
    return (a, max(a, b)), under_way


Health = dict[str, dict[str, tuple[float, float, float]]]
"""``health[detector][channel]``: a residual's healthy mean, standard deviation and
correlation time (samples), as :func:`residual_health` measures them."""


def _healthy(z: npt.NDArray[Any], train: tuple[int, int]) -> tuple[float, float, float] | None:
    """Mean, standard deviation and correlation time of the healthy residual ``z``, read
    a block at a time (no float64 copy of a long, memory-mapped training window: a
    saved model measures every residual of every channel)."""
    h = z[settled(train) : train[1]]
    moments = series_moments(h)
    if moments.n < 8:
        return None
    return moments.mean, moments.std(), correlation_time(h)


def residual_health(results: Sequence[DetectorResult], train: tuple[int, int]) -> Health:
    """The healthy mean, standard deviation and correlation time of every residual the
    rule reads (the equivalent model's and the reading residuals), over the training
    window ``train`` after its first quarter: what a saved model keeps for ``--model``
    runs, whose records have no healthy window of their own."""
    out: Health = {}
    for r in results:
        if r.detector != JUDGED_DETECTOR and r.detector not in READING_RESIDUALS:
            continue
        mine = out.setdefault(r.detector, {})
        for channel, z in r.residuals.items():
            healthy = _healthy(z, train)
            if healthy is not None:
                mine[channel] = healthy
    return out


def _health_of(
    r: DetectorResult, channel: str, train: tuple[int, int], health: Health | None
) -> tuple[float, float, float] | None:
    """The healthy statistics of ``r``'s residual of ``channel``: measured on ``train``,
    or (``--model``) those saved with the model (None when it has none)."""
    if health is None:
        return _healthy(r.residuals[channel], train)
    return health.get(r.detector, {}).get(channel)


def _signal(
    f: Finding,
    a: int,
    b: int,
    reading: npt.NDArray[Any],
    own: npt.NDArray[Any] | None,
    own_mean: float,
    rate_hz: float,
) -> FloatArray | None:
    """The fault signal of ``f`` on rows ``a:b`` (module docstring), or None when its
    fitted shape lacks the magnitude it needs (an ``other`` fault: its equivalent
    model's residual ``own``, when given)."""
    m = f.magnitude
    if f.type is FaultType.ADDITIVE and "offset" in m:
        return np.full(b - a, float(m["offset"]))
    if f.type is FaultType.DRIFT and "rate_per_s" in m:
        return float(m["rate_per_s"]) * (np.arange(a, b) / rate_hz - f.onset_s)
    if f.type is FaultType.MULTIPLICATIVE and m.get("gain"):
        return (1.0 - 1.0 / float(m["gain"])) * np.asarray(reading[a:b], dtype=np.float64)
    if f.type is FaultType.OTHER and own is not None:
        return np.asarray(own[a:b], dtype=np.float64) - own_mean
    return None


def carried(
    f: Finding,
    results: Sequence[DetectorResult],
    values: npt.NDArray[Any],
    index: Mapping[str, int],
    rows: tuple[int, int],
    train: tuple[int, int],
    rate_hz: float,
    beside: Sequence[Finding] = (),
    health: Health | None = None,
) -> list[Carried]:
    """How much of ``f``'s fault signal each reading residual of its sensor carries over
    ``rows`` (module docstring), fitted jointly with the fault signals of the findings
    ``beside`` it (other sensors' faults under way, which reach the same residuals through
    the estimates); empty when no reading residual can say. ``index``: the columns of
    ``values`` by channel; ``health``: the residuals' healthy statistics saved with a
    model (:func:`residual_health`), else measured on ``train``."""
    a, b = rows
    by = {r.detector: r for r in results if f.channel in r.residuals}
    own = by.get(JUDGED_DETECTOR)
    if own is None or b - a < shortest(rate_hz):
        return []
    own_healthy = _health_of(own, f.channel, train, health)
    if own_healthy is None or any(g.channel not in index for g in beside):
        return []
    k = 1 + len(beside)
    out: list[Carried] = []
    for name in READING_RESIDUALS:
        r = by.get(name)
        if r is None:
            continue
        z = r.residuals[f.channel]
        healthy = _health_of(r, f.channel, train, health)
        if healthy is None:
            continue
        mean, _, tau = healthy
        xx = np.zeros((k, k))
        xz = np.zeros(k)
        szz = 0.0
        count = 0
        for p in range(a, b, PIECE):
            q = min(b, p + PIECE)
            signals = [
                _signal(
                    f, p, q, values[:, index[f.channel]], own.residuals[f.channel],
                    own_healthy[0], rate_hz,
                ),
                *(
                    _signal(g, p, q, values[:, index[g.channel]], None, 0.0, rate_hz)
                    for g in beside
                ),
            ]  # fmt: skip
            if any(x is None for x in signals):
                return []
            x = np.vstack([s for s in signals if s is not None])
            zz = np.asarray(z[p:q], dtype=np.float64) - mean
            ok = np.isfinite(x).all(axis=0) & np.isfinite(zz)
            x, zz = x[:, ok], zz[ok]
            xx += x @ x.T
            xz += x @ zz
            szz += float(zz @ zz)
            count += int(ok.sum())
        signal = xx.copy()
        if f.type is FaultType.OTHER:  # the regressor's own healthy noise (errors in x)
            signal[0, 0] -= count * own_healthy[1] ** 2
        if count < shortest(rate_hz) or not signal[0, 0] > 0.0:
            continue
        try:
            inverse = np.linalg.inv(signal)
        except np.linalg.LinAlgError:  # the faults' signals one and the same: no share
            continue
        if float(inverse[0, 0]) * float(signal[0, 0]) > COLLINEAR:
            continue  # this fault's signal is the others' (an offset beside an offset)
        beta = inverse @ xz
        # the stretch's scatter about the fit
        scatter = max(0.0, szz - 2.0 * float(beta @ xz) + float(beta @ xx @ beta)) / max(
            1, count - k
        )
        variance = scatter * tau * float(inverse[0, 0])
        if not variance >= 0.0:  # the other faults' signals explain this one's away
            continue
        out.append(Carried(name, float(beta[0]), float(np.sqrt(variance)), count))
    return out


def refuted_by_readings(
    findings: Sequence[Finding],
    results: Sequence[DetectorResult],
    values: npt.NDArray[Any],
    channels: Sequence[str],
    train: tuple[int, int],
    rate_hz: float,
    health: Health | None = None,
) -> tuple[list[Finding], list[str]]:
    """``findings`` less those that rest on the equivalent model alone and whose fault
    the reading residuals of their sensor do not carry (module docstring), and a note for
    each. Judged findings keep what each reading residual carried in their evidence
    (``readings``). ``values``: the aligned matrix (rows x ``channels``); ``train``: the
    healthy window's rows."""
    index = {c: k for k, c in enumerate(channels)}
    n = int(values.shape[0])
    kept: list[Finding] = []
    notes: list[str] = []
    others = [f for f in findings if not _lone(f)]
    for f in findings:
        if not _lone(f) or _read_by_readings(f) or f.channel not in index:
            kept.append(f)
            continue
        rows, beside = _stretch(f, [g for g in others if g.channel != f.channel], n, rate_hz)
        said = carried(f, results, values, index, rows, train, rate_hz, beside, health)
        if said:
            f.evidence["readings"] = {c.detector: c.as_dict() for c in said}
        if not said or not all(c.refutes for c in said):
            kept.append(f)
            continue
        shares = ", ".join(f"{c.detector}'s {c.beta:+.2f} +- {c.se:.2f}" for c in said)
        if beside:  # (their faults reach the same residuals through the estimates)
            shares += ", fitted with the fault of " + ", ".join(
                f"{g.channel} from {g.onset_s:.1f} s" for g in beside
            )
        notes.append(
            f"{JUDGED_DETECTOR}'s {f.type.value} fault on {f.channel} at "
            f"{seconds_text(f.onset_s)} s not "
            f"reported: the residuals of {f.channel} that take its reading in against an "
            f"estimate made without it carry too little of it ({shares} of the fault, "
            f"{rows[0] / rate_hz:.1f}-{rows[1] / rate_hz:.1f} s; a fault of the reading "
            "gives 1): its equivalent model's relation changed with the response (a change "
            "of the excitation or the structure), not the sensor"
        )
    return kept, notes
