"""Sensor fault diagnosis with equivalent models and an assistant state (Wang & Song 2014).

Equivalent model (Section 2, Eq. 7-13)
--------------------------------------
For one target sensor ``i`` the plant, whatever its nonlinear structure, is written as a
one-dimensional linear state equation with bounded uncertainty,
``x_i' = a x_i + b u + d``, ``y = x_i + f_s`` (Eq. 13), where the *equivalent disturbance*
``d`` collects the model uncertainty, the other states and the actuator faults.

The assistant-state observer (Section 4.2, Eq. 26-32), its exact discretization and the
relation that feeds it are in :mod:`analyzer.detectors.assistant_observer`.

Detector
--------
For every target sensor with assistant sensors in the sensor network
(:mod:`analyzer.detectors.network`), the rate ``z_i`` is a linear relation identified on
the healthy window (least-squares FIR of the assistant sensors' samples, the "analytical
relationship" of Section 4.3). The fault estimate ``-lambda1 r`` (sensor units,
``measured - estimated``, the fault regeneration of Section 6.3) is the channel's residual;
alarms are isolated by the network's laws (Section 6.2).
"""

from __future__ import annotations

import numbers
from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar, NamedTuple

import numpy as np
import numpy.typing as npt

from analyzer.config import measured_inputs
from analyzer.detectors.ar_kalman import RELATIVE_CONSISTENCY
from analyzer.detectors.assistant_observer import (
    AssistantObserver,
    Pretreatment,
    Relation,
    fit_relation,
    pretreat,
)
from analyzer.detectors.base import (
    SIGNAL_DTYPE,
    Dataset,
    DetectorResult,
    Event,
    RunContext,
    dilate_forward,
)
from analyzer.detectors.detection_filter import UNCONFIRMED_FACTOR, long_run_time
from analyzer.detectors.lowpass import LowpassPieces
from analyzer.detectors.network import NetworkDiagnosis, Propagation, SensorNetwork
from analyzer.diagnosis.changes import (
    LONG_FACTOR,
    Calibration,
    alarm_statistic,
    calibrate,
    default_window,
    needing_calibration,
)
from analyzer.diagnosis.events import events_from_residual
from analyzer.diagnosis.load import LOUD_BANK_MAX, LOUD_KINDS, LOUD_MARK, LoadGuard
from analyzer.diagnosis.streamed import row_moments
from analyzer.errors import DetectorError, TooLittleDataError
from analyzer.paging import (
    ScratchRows,
    release,
    write_rows,
)
from analyzer.timeutil import seconds_text, spoken_duration
from analyzer.types import FaultType

FloatArray = npt.NDArray[np.float64]


def _is_integer(value: Any) -> bool:
    """An integer setting (a boolean is not one, nor is a float with no fraction)."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_)


def _is_real(value: Any) -> bool:
    """A numeric setting (a boolean or a string is not one)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)


def _sequence(value: Any) -> bool:
    """A list-like setting (a string is not a list of its characters)."""
    return isinstance(value, Sequence | np.ndarray) and not isinstance(value, str)


def _names(value: Any) -> bool:
    """A list of channel names."""
    return _sequence(value) and all(isinstance(v, str) for v in value)


COPY_TOLERANCE = 1e-10
"""Two sensors whose healthy correlation is within this of +-1 are copies of each other
(the same signal, up to a scale and offset, and rounding): the network never makes one
the other's assistant."""


# -- the detector --------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class TargetObserver:
    target: int
    relation: Relation
    observer: AssistantObserver
    pretreatment: Pretreatment
    input: int | None
    cal: Calibration
    tau: float


@dataclass(frozen=True, slots=True)
class FittedEquivalentModel:
    network: SensorNetwork
    observers: tuple[TargetObserver, ...]
    window: int
    settle: int
    chained: Mapping[tuple[str, str], Calibration] = field(default_factory=dict)
    """``(t, s)``: the healthy calibration of target ``t``'s residual with assistant ``s``'s
    fault estimate taken out (:func:`chain`), for every edge ``s -> t`` of two sensors with
    an observer (an edge whose calibration failed, for too little data, has none)."""

    def __setstate__(self, state: tuple[Any, ...]) -> None:
        """Unpickled (a model file): one saved before the chained calibrations existed
        holds four fields; its edges then have none, and a target confirms an alarm by
        its own alarm, as before (its model file used to end ``--model`` with an internal
        error)."""
        names = [f.name for f in fields(self)]
        for name, value in zip(names, state, strict=False):
            object.__setattr__(self, name, value)
        if len(state) < len(names):
            object.__setattr__(self, "chained", {})


class EquivalentModel:
    """``equivalent_model``: Wang & Song (2014) observers with an assistant state, one per
    target sensor, and the sensor-network diagnosis logic.

    Settings: ``lambda1``, ``lambda2`` (rad/s, Theorem 6; default the sample rate, so the
    residual follows a fault within about a sample), ``assistants`` (``{target = [sensor,
    ...]}``; default a ring through the sensors in order of healthy correlation, each
    target assisted by ``n_assistants`` sensors), ``quasi_heads``, ``propagation``
    (``"direct"``/``"chained"``), ``lags`` (FIR length of the relations, or ``"bic"``),
    ``max_lags``, ``inputs`` (``{target = input_channel}``, the ``u`` of Eq. 8),
    ``table`` (candidate ``[a, b]`` pairs for Algorithm 1; default least squares).

    Measured inputs are not sensors under test: the channels of the ``inputs`` setting and
    those the config names as measured excitation (``[[group]] inputs``, ``[model] inputs``:
    :func:`measured_inputs`) are left out of the automatic network, so no observer targets
    them (the pipeline reports no fault on them either). The config's measured inputs are
    known excitation, as the ``u`` of Eq. 8 is (and as Park's ``B u`` and Li's measured
    inputs are to the other model-based detectors): each target's relation takes them as
    regressors beside its assistant sensors (the forces that drive a chain explain much of
    its accelerations: without them a gain of 0.5 on one sensor of Li et al.'s chain was
    missed). Like any known input, a fault on one is not isolated: it reaches every
    residual. A configured ``assistants`` table may name a measured input as an assistant
    sensor: it then enters the network as a head (no observer of its own), not as a
    target."""

    name: ClassVar[str] = "equivalent_model"

    def __init__(
        self,
        lambda1: float | None = None,
        lambda2: float | None = None,
        assistants: Mapping[str, Sequence[str]] | None = None,
        n_assistants: int = 2,
        quasi_heads: Sequence[str] = (),
        propagation: str = "direct",
        lags: int | str = "bic",
        max_lags: int = 64,
        inputs: Mapping[str, str] | None = None,
        table: Sequence[Sequence[float]] | None = None,
    ) -> None:
        where = "[detectors.equivalent_model]"
        for key, val in (("lambda1", lambda1), ("lambda2", lambda2)):
            if val is not None and (not _is_real(val) or not 0.0 < float(val) < np.inf):
                raise DetectorError(f"{where} {key} must be > 0 (Theorem 6), got {val!r}")
        if not _is_integer(n_assistants) or n_assistants < 1:
            raise DetectorError(
                f"{where} n_assistants: expected an integer >= 1, got {n_assistants!r}"
            )
        if propagation not in ("direct", "chained"):
            raise DetectorError(
                f"{where} propagation must be 'direct' or 'chained', got {propagation!r}"
            )
        if isinstance(lags, str):
            if lags != "bic":
                raise DetectorError(f"{where} lags: expected an integer or 'bic', got {lags!r}")
        elif not _is_integer(lags):  # 2.5 was accepted
            raise DetectorError(f"{where} lags: expected an integer or 'bic', got {lags!r}")
        elif lags < 0:
            raise DetectorError(f"{where} lags must be >= 0, got {lags}")
        if not _is_integer(max_lags) or max_lags < 0:
            # (-1 left the BIC no length to choose from: "max() arg is an empty sequence")
            raise DetectorError(f"{where} max_lags: expected an integer >= 0, got {max_lags!r}")
        if assistants is not None and not (
            isinstance(assistants, Mapping)
            and all(_names(v) for v in assistants.values())
            and all(isinstance(k, str) for k in assistants)
        ):
            raise DetectorError(
                f"{where} assistants: expected a table of sensor lists ({{target = "
                f"[sensor, ...]}}), got {assistants!r}"
            )
        if not _names(quasi_heads):
            raise DetectorError(
                f"{where} quasi_heads: expected a list of sensors, got {quasi_heads!r}"
            )
        if inputs is not None and not (
            isinstance(inputs, Mapping)
            and all(isinstance(k, str) and isinstance(v, str) for k, v in inputs.items())
        ):
            raise DetectorError(
                f"{where} inputs: expected a table {{target = input_channel}}, got {inputs!r}"
            )
        if table is not None and not (
            _sequence(table)
            and all(_sequence(r) and len(r) == 2 and all(map(_is_real, r)) for r in table)
        ):
            raise DetectorError(
                f"{where} table: expected a list of [a, b] number pairs, got {table!r}"
            )
        self.lambda1 = None if lambda1 is None else float(lambda1)
        self.lambda2 = None if lambda2 is None else float(lambda2)
        self.assistants = (
            None if assistants is None else {k: list(v) for k, v in assistants.items()}
        )
        self.n_assistants = int(n_assistants)
        self.quasi_heads = tuple(quasi_heads)
        self.propagation = Propagation(propagation)
        self.lags: int | str = lags if isinstance(lags, str) else int(lags)
        self.max_lags = int(max_lags)
        self.inputs = dict(inputs or {})
        self.table = None if table is None else [list(map(float, r)) for r in table]

    def applicable(self, data: Dataset, context: RunContext) -> str | None:
        names = set(data.channels)
        excitation = measured_inputs(context.config)
        if self.assistants is not None:
            used = set(self.assistants) | {a for v in self.assistants.values() for a in v}
            missing = sorted(used - names)
            if missing:
                return (
                    f"[detectors.equivalent_model] assistants names channel {missing[0]!r}, "
                    "which is not analyzed"
                )
            if not any(self.assistants.values()):
                return "the configured sensor network has no assistant sensors"
            tested = sorted(t for t, a in self.assistants.items() if a and t in excitation)
            if tested:
                return (
                    f"[detectors.equivalent_model] assistants makes {tested[0]!r} a target "
                    "sensor, but the config names it a measured input ([[group]] inputs or "
                    "[model] inputs), which is not a sensor under test"
                )
        elif len(self._sensors(data.channels, excitation)) < 3:
            return (
                "needs at least 3 channels for an automatic sensor network (two sensors that "
                "assist each other cannot be told apart); configure assistants otherwise"
            )
        bad = sorted((set(self.inputs) | set(self.inputs.values())) - names)
        if bad:
            return (
                f"[detectors.equivalent_model] inputs names channel {bad[0]!r}, "
                "which is not analyzed"
            )
        return None

    def _sensors(
        self,
        channels: Sequence[str],
        excitation: frozenset[str],
        keep: frozenset[str] = frozenset(),
    ) -> list[str]:
        """The channels that are sensors of the network: not an ``inputs`` channel and not
        a measured input of the config (``excitation``), unless in ``keep`` (measured inputs
        a configured ``assistants`` table names as assistant sensors)."""
        skip = (set(self.inputs.values()) | excitation) - keep
        return [c for c in channels if c not in skip]

    def _network(self, data: Dataset, context: RunContext | None = None) -> SensorNetwork:
        excitation = measured_inputs({} if context is None else context.config)
        keep: frozenset[str] = frozenset()
        if self.assistants is not None:
            keep = frozenset(a for v in self.assistants.values() for a in v) & excitation
        sensors = self._sensors(data.channels, excitation, keep)
        if self.assistants is not None:
            try:
                return SensorNetwork(
                    tuple(sensors),
                    {t: tuple(a) for t, a in self.assistants.items()},
                    self.quasi_heads,
                    self.propagation,
                )
            except ValueError as err:
                raise DetectorError(f"[detectors.equivalent_model] {err}") from err
        # the correlations of the rows without a gap, a block of rows at a time (a
        # long training window is not copied)
        corr = row_moments(data.train_values(), [data.index(c) for c in sensors]).correlation()
        corr = np.nan_to_num(corr)
        # a copy of a sensor (the same signal logged twice, or scaled) is no assistant: its
        # residual would be the difference of the two, zero but for rounding, and any
        # fault on either a change of a billion noise levels (a step on s2 at 40 s, with
        # s6 a copy of s2, was typed a drift from 15 s)
        corr[(1.0 - np.abs(corr) < COPY_TOLERANCE) & ~np.eye(len(sensors), dtype=bool)] = 0.0
        net = SensorNetwork.design(sensors, corr, self.n_assistants)
        if self.quasi_heads or self.propagation is not Propagation.DIRECT:
            net = SensorNetwork(net.sensors, net.assistants, self.quasi_heads, self.propagation)
        return net

    # -- fitting -----------------------------------------------------------------------------
    def fit(self, data: Dataset, context: RunContext) -> FittedEquivalentModel:
        reason = self.applicable(data, context)
        if reason:
            raise DetectorError(f"{self.name}: {reason}")
        dt = 1.0 / data.rate_hz
        l1 = self.lambda1 if self.lambda1 is not None else data.rate_hz
        l2 = self.lambda2 if self.lambda2 is not None else l1
        net = self._network(data, context)
        train = np.asarray(data.train_values(), dtype=np.float64)
        window = default_window(data.rate_hz)
        targets = [s for s in net.sensors if net.assistant_sensors(s)]
        # the config's measured inputs outside the network: regressors of every relation
        excitation = measured_inputs(context.config)
        known = [c for c in data.channels if c in excitation and c not in net.sensors]
        far = context.false_alarm_rate / len(data.channels)  # per channel
        tasks = []
        shared = context.scatter(train)  # on a cluster, sent to each worker once
        for s in targets:  # each target's observer is fitted on its own (executor tasks)
            uch = self.inputs.get(s)
            ui = None if uch is None else data.index(uch)
            ass = [data.index(a) for a in net.assistant_sensors(s)]
            ass += [data.index(c) for c in known if c != uch]
            tasks.append((self, shared, data.index(s), ass, ui, (dt, l1, l2), window, far))
        fitted = context.map(_fit_observer_task, tasks, "observers fitted")
        observers = tuple(ob for ob, _, _ in fitted)
        settle = max((lag for _, lag, _ in fitted), default=0)
        held = {data.channels[ob.target]: halves for ob, _, halves in fitted}
        del fitted
        chained = _chained_calibrations(net, observers, held, data.channels, window, far)
        return FittedEquivalentModel(net, observers, window, settle, chained)

    def _fit_observer(
        self,
        train: FloatArray,
        i: int,
        ass: list[int],
        ui: int | None,
        rates: tuple[float, float, float],
        window: int,
        far: float,
    ) -> tuple[TargetObserver, int, list[FloatArray]]:
        """The observer of sensor ``i`` from its assistants ``ass`` (input ``ui``), its
        healthy calibration, the samples it needs to settle, and its held-out healthy fault
        estimate (:meth:`_held_out_estimate`, whole halves: the chained residuals of its
        edges are calibrated on them)."""
        dt, l1, l2 = rates
        try:
            rel = fit_relation(train, i, ass, self.lags, self.max_lags)
            pre = pretreat(train[:, i], None if ui is None else train[:, ui], dt, l2, self.table)
        except TooLittleDataError as err:  # (the thresholds' calibration needs more)
            raise needing_calibration(err, window) from None
        obs = AssistantObserver(pre.a, pre.b, l1, l2, dt)
        phi = float(np.exp(-l1 * dt))
        lag = _settle_samples(rel, phi)
        halves = self._held_out_estimate(obs, rel, train, i)
        z = [h[_head(lag, h.shape[0]) :] for h in halves]
        cal = calibrate(z, window, far)
        return TargetObserver(i, rel, obs, pre, ui, cal, long_run_time(z, window)), lag, halves

    def _held_out_estimate(
        self, obs: AssistantObserver, rel: Relation, train: FloatArray, i: int
    ) -> list[FloatArray]:
        """The healthy fault estimate for calibration, out of sample: the relation is
        refitted on each half of the training window (same lags) and evaluated on the
        other half, so the thresholds reflect how well it predicts data it has not seen.
        The two halves in time order, to be read as one series (not concatenated), each
        from its first row (the observer settles over its head: :func:`_head`)."""
        n = train.shape[0]
        half = n // 2
        parts = []
        for fit_rows, eval_rows in (
            (slice(0, half), slice(half, n)),
            (slice(half, n), slice(0, half)),
        ):
            try:
                r_half = fit_relation(train[fit_rows], i, rel.assistants, rel.lags)
            except DetectorError:
                r_half = rel  # too little data for halves: fall back to in-sample
            zeta, _ = self._fault_estimate(obs, r_half, train, i)
            # a copy of the half it evaluates: the estimate over the whole window is freed
            parts.append(zeta[eval_rows].copy())
            del zeta
        return parts[::-1]

    @staticmethod
    def _fault_estimate(
        obs: AssistantObserver,
        rel: Relation,
        values: FloatArray,
        i: int,
        out: tuple[FloatArray, FloatArray] | None = None,
    ) -> tuple[FloatArray, FloatArray]:
        """``-lambda1 r`` after each sample (sensor units, measured - estimated; Eq. 32 and
        the fault regeneration of Section 6.3), NaN around gaps, and the estimate ``z`` of
        the sensor from its assistants that drives it.

        One compiled pass over the rows (:func:`_observer_loop`): the target's and the
        assistants' samples are read where they lie (no column copies of the record), the
        FIR, the observer's recursion and the gap mask run block by block. Without numba
        (or for a non-float record) :func:`_fault_estimate_numpy` computes the same.
        ``out``: two float64 arrays of the record's length to write ``zeta`` and ``z``
        into (memory-mapped ones get each piece from memory by ``pwrite``,
        :func:`~analyzer.paging.write_rows`: a store through their mapping faults every
        page in: with the low-pass and the gap mask written the same way, the run on 4
        hours of 16 channels went from 140 k minor faults to 13 k)."""
        n = np.asarray(values).shape[0]
        zeta, z = (np.empty(n), np.empty(n)) if out is None else out
        for a, zp, zz in EquivalentModel._fault_estimate_pieces(obs, rel, values, i):
            # into memory-mapped outputs by pwrite from the piece: a store through their
            # mapping faults every page in
            write_rows(zeta, a, zp)
            write_rows(z, a, zz)
        return zeta, z

    @staticmethod
    def _fault_estimate_pieces(
        obs: AssistantObserver, rel: Relation, values: FloatArray, i: int
    ) -> Iterator[tuple[int, FloatArray, FloatArray]]:
        """:meth:`_fault_estimate` a piece of rows at a time, ``(first row, zeta, z)``:
        the pieces are the pass's own buffers, valid until the next one is asked for (a
        caller that keeps only some of it, or keeps it low-passed, writes no more)."""
        arr = np.asarray(values)
        if _observer_kernel is None or arr.ndim != 2 or arr.dtype.kind != "f":
            zeta, z = _fault_estimate_numpy(obs, rel, values, i)
            yield 0, zeta, z
            return
        phi = float(np.exp(-obs.lambda1 * obs.dt))
        n = arr.shape[0]
        cols = np.asarray(rel.assistants, dtype=np.int64)
        coef = np.ascontiguousarray(rel.coef, dtype=np.float64).reshape(len(rel.assistants), -1)
        settle = _settle_samples(rel, phi)
        # the pass carries its state (FIR history, recursion, last gap) from piece to
        # piece, so a memory-mapped record is read and given back a piece at a time
        hist = np.zeros((len(cols), coef.shape[1] - 1))
        state = np.array([0.0, float(-settle - 2)])
        pieces = (np.empty(min(n, _PIECE)), np.empty(min(n, _PIECE)))
        for a in range(0, n, _PIECE):
            b = min(n, a + _PIECE)
            rows = arr[a:b]
            into = (pieces[0][: b - a], pieces[1][: b - a])
            _observer_kernel(
                rows,
                a,
                i,
                cols,
                coef,
                float(rel.intercept),
                phi,
                (1.0 - phi) / obs.lambda1,
                -obs.lambda1,
                settle,
                hist,
                state,
                into[0],
                into[1],
            )
            release(rows)
            yield a, into[0], into[1]

    def estimate_warmup(self, model: FittedEquivalentModel, j: int) -> int | None:
        """Rows :meth:`estimate` reads before the rows it estimates (sensor ``j``): the
        relation's FIR memory and the settling after a gap (:func:`_settle_samples`);
        None when no observer targets sensor ``j``."""
        ob = _observer_of(model, j)
        return None if ob is None else _settle_samples(ob.relation, _phi(ob.observer))

    def estimate(
        self, model: FittedEquivalentModel, rows: FloatArray, start: int, j: int
    ) -> FloatArray:
        """Sensor ``j``'s estimate from its assistants (:meth:`Relation.estimate`, NaN
        where a gap's settling hides it, as the run's ``reference``) over ``rows[start:]``,
        with ``rows[:start]`` as the history (up to :meth:`estimate_warmup` rows): the run's
        ``reference`` computed again on other rows, such as the record with other sensors'
        faults corrected (:func:`analyzer.regenerate.corrected_values`)."""
        ob = _observer_of(model, j)
        if ob is None:
            raise DetectorError(f"{self.name}: no observer estimates sensor {j}")
        arr = np.asarray(rows, dtype=np.float64)
        z = ob.relation.estimate(arr)
        gap = ~np.isfinite(arr[:, j])
        for c in ob.relation.assistants:
            gap |= ~np.isfinite(arr[:, c])
        if gap.any():
            z[dilate_forward(gap, _settle_samples(ob.relation, _phi(ob.observer)))] = np.nan
        return z[start:]

    # -- running -----------------------------------------------------------------------------
    def run(
        self, model: FittedEquivalentModel, data: Dataset, context: RunContext
    ) -> DetectorResult:
        values = np.asarray(data.values)
        rate = data.rate_hz
        net = model.network
        residuals: dict[str, FloatArray] = {}
        reference: dict[str, FloatArray] = {}
        cands: dict[str, list[Event]] = {}
        # the observers are independent: on threads they share the archive (on a cluster
        # each task would ship it, so there they run here one after the other). For a long
        # archive each writes its two signals into a row of a memory-mapped buffer.
        kept: tuple[Any, Any] | None = None
        if context.map_outputs and model.observers:
            shape = (values.shape[0], len(model.observers))
            kept = (
                context.buffer(f"{self.name}-resid", shape, SIGNAL_DTYPE),
                context.buffer(f"{self.name}-ref", shape, SIGNAL_DTYPE),
            )
        # a long archive: each observer's two float64 signals go to scratch rows, reused
        # by the next observer of the same thread
        scratch = ScratchRows(context.workdir if context.map_outputs else None)
        tasks = [
            (
                ob,
                values,
                data.channels[ob.target],
                rate,
                self.name,
                (data.healthy_start, data.train[1], data.search_start),
                None if kept is None else (kept[0][:, k], kept[1][:, k]),
                scratch,
            )
            for k, ob in enumerate(model.observers)
        ]
        unweighed: list[str] = []  # notes on alarms too thin to weigh (no candidates)
        for task, (zeta, z, found, thin) in zip(
            tasks, context.map_shared(_observer_task, tasks, "observers run"), strict=True
        ):
            residuals[task[2]] = zeta
            reference[task[2]] = z
            cands[task[2]] = found
            unweighed.extend(thin)
        slack_s = model.window * 8 / rate

        def blind(t0: float) -> set[str]:
            """Sensors that read over the long window from ``t0`` while their residual
            is mostly empty there (an assistant of theirs has no data)."""
            a = max(0, int(round(t0 * rate)))
            b = min(values.shape[0], a + max(1, int(round(slack_s * rate))))
            out = set()
            for name, zeta in residuals.items():
                k = data.channels.index(name)
                if (
                    np.isfinite(np.asarray(zeta[a:b])).mean() < 0.5
                    and np.isfinite(values[a:b, k]).mean() >= 0.5
                ):
                    out.add(name)
            return out

        chains = {
            (t, a): (ob.relation.coef[ob.relation.assistants.index(data.index(a))], cal)
            for ob in model.observers
            for (t, a), cal in model.chained.items()
            if data.channels[ob.target] == t
        }
        cals = {data.channels[ob.target]: ob.cal for ob in model.observers}
        long = LONG_FACTOR * model.window

        def grade(s: str, t0: float, also: Collection[str] = ()) -> Grade:
            """Every residual's violation over the bank's window at an alarm of ``s``
            from ``t0`` (from ``window`` before it to two long windows after), and those
            of the chained residuals of ``s``'s targets (:func:`chain`), with the fault
            estimates of the sensors ``also`` taken out too where ``s``'s relation or a
            target's uses them (calibrated as the edge ``s -> t`` alone: each estimate
            taken out adds its noise, which makes such a residual quiet less readily)."""
            k0 = int(round(t0 * rate))
            lo = max(data.search_start, k0 - model.window)
            hi = min(values.shape[0], k0 + 2 * long)
            a = max(0, lo - long)  # the samples that fill the windows at ``lo``
            own = {n: _violation(residuals[n][a:hi], cals[n], lo - a) for n in residuals}
            chained = {}
            for t in net.targets(s):
                if (t, s) not in chains:
                    continue
                h, cal = chains[t, s]
                # s's fault estimate, and t's residual, clear of those of ``also``
                into_s = [o for o in also if (s, o) in chains]
                into_t = [o for o in also if o not in (s, t) and (t, o) in chains]
                firs = [chains[s, o][0] for o in into_s] + [chains[t, o][0] for o in into_t]
                b = max(0, a - sum(f.shape[0] - 1 for f in [h, *firs]))  # the FIRs' memory
                zs = residuals[s][b:hi]
                for o in into_s:
                    zs = chain(zs, residuals[o][b:hi], chains[s, o][0])
                c = chain(residuals[t][b:hi], zs, h)
                for o in into_t:
                    c = chain(c, residuals[o][b:hi], chains[t, o][0])
                chained[t] = _violation(c, cal, lo - b)
            return Grade(own, chained)

        events, notes, decisions = self._isolate(net, cands, slack_s, blind, grade)
        notes = [*unweighed, *notes, *self._loud_unconfirmed(events, data)]
        # alarms the network's laws left ambiguous: no sensor named; and alarms of data
        # that changed as a whole (:func:`_judge`)
        unattributed = [
            (float(d["onset_s"]), tuple(d["ambiguous"]), tuple(d["faulty"]))
            for d in decisions
            if d["sensor"] in d["ambiguous"] and not d.get("blind")
        ] + [(float(d["onset_s"]), tuple(d["changed"]), ()) for d in decisions if "changed" in d]
        undecided: list[tuple[float, tuple[str, ...], tuple[str, ...]]] = [
            (float(d["onset_s"]), (str(d["sensor"]),), tuple(str(b) for b in d["blind"]))
            for d in decisions
            if d.get("blind")
        ]
        excitation = measured_inputs(context.config)
        for s, why in net.undiagnosable().items():
            if s not in excitation:  # a measured input in the network assists only
                notes.append(f"{s} cannot be diagnosed by the observers alone ({why})")
        l1 = model.observers[0].observer.lambda1 if model.observers else self.lambda1
        l2 = model.observers[0].observer.lambda2 if model.observers else self.lambda2
        return DetectorResult(
            detector=self.name,
            channels=tuple(residuals),
            params={
                "lambda1": l1,
                "lambda2": l2,
                "lags": self.lags,
                "window": model.window,
                "false_alarm_rate": context.false_alarm_rate,
            },
            events=events,
            residuals=residuals,
            reference=reference,
            sigma={data.channels[o.target]: o.cal.std for o in model.observers},
            thresholds={data.channels[o.target]: o.cal.as_dict() for o in model.observers},
            model={
                "type": "equivalent models with assistant states",
                "source": "relations identified on the healthy window",
                "network": net.as_dict(),
                "observers": {
                    data.channels[o.target]: {
                        "relation": o.relation.as_dict(data.channels),
                        "pretreatment": o.pretreatment.as_dict(),
                        "input": None if o.input is None else data.channels[o.input],
                        "lambda1": o.observer.lambda1,
                        "lambda2": o.observer.lambda2,
                    }
                    for o in model.observers
                },
                "decisions": decisions,
            },
            notes=notes,
            unattributed=unattributed,
            undecided=undecided,
        )

    @staticmethod
    def _loud_unconfirmed(events: list[Event], data: Dataset) -> list[str]:
        """Take out of ``events`` (in place) the gains and shapeless changes
        (:data:`~analyzer.diagnosis.load.LOUD_KINDS`) no target sensor's residual confirmed
        that were first raised where the other sensors' response was louder than anywhere
        in the healthy window (:mod:`analyzer.diagnosis.load`), and say why in a note each.
        Every relation's residual grows with the response there (fitted on a quieter
        stretch), most of all a weak one: with one floor's sensor left out of a simulated
        5-floor building, a target's relation lost its neighbour (R^2 0.96 down to 0.61)
        and healthy "gains" came out at 1.02-1.13 of the threshold, unconfirmed, where the
        response was 6.5 times the healthy window's (``benchmarks/sweep_missing_floor.py``).
        The level is the other channels': a sensor's own gain must not excuse itself. The
        events kept there have it in their evidence (``load_ratio``).

        Only in records of at most :data:`LOUD_BANK_MAX` channels, as the detection
        filter's stricter rule (banks of under 6, whose median of other residuals says
        little): in larger ones a lone gain still goes to the readings' judgement
        (:func:`~analyzer.diagnosis.readings.refuted_by_readings`), which refuted the
        healthy ones of load changes on 6- and 16-channel buildings
        (``tests/diagnosis/test_readings.py``), and a real lone gain there is not dropped
        unjudged. The price in small banks: a real gain that starts in a loud stretch and
        that no other residual confirms is a note too (one of 150 such gains lost, seed 3
        without s1, a 1.2 gain on s2 from 47.8 s; the run's note then says an alarm was
        left out in a loud stretch), against 11 -> 3 findings on other sensors."""
        if len(data.channels) > LOUD_BANK_MAX:
            return []
        loud = LoadGuard(data.values, data.train, data.rate_hz, data.healthy)
        columns = range(len(data.channels))
        notes = []
        for ev in list(events):
            first_s = float(ev.evidence.get("first_alarm_s", ev.onset_s))
            k0 = int(round(first_s * data.rate_hz))
            load = loud.at_alarm(columns, data.index(ev.channel), k0)
            if load <= 1.0:
                continue
            ev.evidence["load_ratio"] = load
            if not ev.evidence.get("confirmed_by", [None]) and ev.type in LOUD_KINDS:
                events.remove(ev)
                notes.append(
                    f"alarm on {ev.channel} at {seconds_text(first_s)} s not reported: no target "
                    "sensor's residual confirmed it, and the other sensors' signals there "
                    f"were {load:.1f} {LOUD_MARK}, which raises every residual (a "
                    "longer healthy window covers it)"
                )
        return notes

    @staticmethod
    def _isolate(
        net: SensorNetwork,
        cands: Mapping[str, list[Event]],
        slack_s: float,
        blind: Callable[[float], set[str]] | None = None,
        grade: Callable[..., Grade] | None = None,
    ) -> tuple[list[Event], list[str], list[dict[str, Any]]]:
        """Keep the events the network's laws attribute to their own sensor: for each
        event, the alarming set is every sensor whose residual alarms at (or first alarms
        within ``slack_s`` of) the event's first alarm; :meth:`SensorNetwork.diagnose`
        decides. First alarms are used, not fitted onsets, which a drift fit may move.
        An event that no target sensor's residual confirms is noted, not reported, when it
        has no fault shape or is over within ``slack_s`` (the long window).

        ``grade(s, t0)``: the residuals' violations at an alarm of ``s`` (:class:`Grade`).
        With it, law 0's verdict is weighed (:func:`_judge`): an alarming target confirms
        ``s`` only when ``s``'s fault estimate explains its alarm, and an alarm that the
        residuals blind to ``s`` share is attributed to no sensor (the data changed as a
        whole). Without it, every alarming target confirms (the alarms alone)."""

        def first(e: Event) -> float:
            return float(e.evidence.get("first_alarm_s", e.onset_s))

        allev = [(s, ev) for s, evs in cands.items() for ev in evs]
        events: list[Event] = []
        notes: list[str] = []
        decisions: list[dict[str, Any]] = []
        # events attributed to their own sensor: (sensor, event, first alarm, diagnosis,
        # index of the decision)
        accepted: list[tuple[str, Event, float, NetworkDiagnosis, int]] = []
        # what each event's alarm was put down to when it began (by id): its sensor's own
        # fault, confirmed or not, or the faults of the sensors its residual depends on
        put_down: dict[int, tuple[str, tuple[str, ...]]] = {}
        for s, ev in sorted(allev, key=lambda p: first(p[1])):
            t0 = first(ev)
            alarming = {
                o
                for o, e in allev
                if abs(first(e) - t0) <= slack_s
                or (first(e) <= t0 and (e.end_s is None or e.end_s >= t0))
            }
            dark = (blind(t0) if blind is not None else set()) - alarming
            diag: NetworkDiagnosis = net.diagnose(alarming, dark)
            decisions.append({"onset_s": t0, "sensor": s, **diag.as_dict()})

            # A target whose alarm has lasted since before s's and was put down to another
            # fault then (a confirmed fault of its own, or another assistant's) does not
            # confirm s: a gain on s10 from 480 s, and s14's alarms that it explained,
            # "confirmed" an alarm on s12 (which assists both) at 849 s (16 channels, seed
            # 16 of sweep_isolation.py --onset 0.4 --second 0.7). An earlier alarm of the
            # target's own, unconfirmed, may be s's fault seen first there, and does.
            def stale(target: str, s: str = s, t0: float = t0) -> bool:
                return any(
                    o == target
                    and first(e) < t0 - slack_s
                    and (e.end_s is None or e.end_s >= t0)
                    and (
                        put_down.get(id(e), ("", ()))[0] == "confirmed"
                        or (
                            put_down.get(id(e), ("", ()))[0] == "propagated"
                            and s not in put_down[id(e)][1]
                        )
                    )
                    for o, e in allev
                )

            # (nor one whose alarm another such sensor explains: s14, assisted by s10)
            confirmed = [
                t
                for t in net.targets(s)
                if t in diag.propagated
                and not stale(t)
                and not any(d != s and stale(d) for d in diag.propagated[t])
            ]
            if s in diag.faulty and grade is not None:
                lasting = {
                    r for r, e, _, _, _ in accepted if r != s and (e.end_s is None or e.end_s >= t0)
                }
                judged = _judge(
                    net,
                    s,
                    confirmed,
                    grade(s, t0),
                    lasting,
                    lambda other, out, t0=t0: grade(other, t0, out),  # type: ignore[misc]
                )
                if judged.second is not None:
                    notes.append(
                        f"alarm on {s} at {seconds_text(t0)} s: the residuals that cannot see it "
                        f"alarm with a second fault, on {judged.second}, which its own target "
                        "sensors' residuals confirm (two faults at once, not a change of the data "
                        "as a whole)"
                    )
                decisions[-1]["grade"] = judged.evidence
                confirmed = judged.confirmed
                if judged.changed is not None:
                    decisions[-1]["changed"] = sorted(alarming)
                    put_down[id(ev)] = ("changed", ())
                    notes.append(
                        f"alarm on {s} at {seconds_text(t0)} s not attributed: {judged.changed}"
                    )
                    continue
            if s in diag.faulty:
                put_down[id(ev)] = ("confirmed" if confirmed else "own", ())
            elif s in diag.propagated:
                put_down[id(ev)] = ("propagated", diag.propagated[s])
            unconfirmed = s in diag.faulty and not confirmed
            if unconfirmed and ev.type is FaultType.OTHER:
                notes.append(
                    f"anomaly on {s} at {seconds_text(t0)} s not reported: it has no fault shape "
                    "and no target sensor's residual saw it (model mismatch rather than a sensor "
                    "fault)"
                )
            elif unconfirmed and ev.end_s is not None and ev.end_s - ev.onset_s < slack_s:
                # as the bank does (ar_kalman_bank._next_fault): a change gone within the
                # long window that no other residual confirms is within the model's error
                notes.append(
                    f"anomaly on {s} at {seconds_text(t0)} s not reported: it was over within "
                    f"{spoken_duration(ev.end_s - ev.onset_s)} and no target sensor's residual saw "
                    "it (within the model's own error rather than a sensor fault)"
                )
            elif s in diag.faulty:
                ev.evidence.update(
                    {
                        "law": diag.laws[s],
                        "alarming": sorted(alarming),
                        "assistants": list(net.assistant_sensors(s)),
                        "confirmed_by": confirmed,
                    }
                )
                if "grade" in decisions[-1]:
                    ev.evidence["grade"] = decisions[-1]["grade"]
                if not confirmed:
                    ev.confidence *= UNCONFIRMED_FACTOR
                events.append(ev)
                accepted.append((s, ev, t0, diag, len(decisions) - 1))
            elif s in diag.propagated:
                notes.append(
                    f"alarm on {s} at {seconds_text(t0)} s explained by the alarm on its assistant "
                    f"sensor(s) {', '.join(diag.propagated[s])} (law 0)"
                )
            elif diag.laws.get(s, "").startswith("undecided"):
                decisions[-1]["blind"] = sorted(net.dependencies(s) & dark)
                notes.append(
                    f"alarm on {s} at {seconds_text(t0)} s not attributed: {diag.laws[s]} (missing "
                    "samples of its assistants), so a fault there explains it as well as one "
                    f"on {s} (law 0 cannot decide)"
                )
            elif diag.faulty:  # a second fault beside those, on one of the ambiguous
                notes.append(
                    f"alarm on {s} at {seconds_text(t0)} s not attributed: beside the fault on "
                    f"{', '.join(diag.faulty)}, a fault on any one of "
                    f"{', '.join(diag.ambiguous)} explains the alarms (law 0 for two faults)"
                )
            else:
                notes.append(
                    f"alarm on {s} at {seconds_text(t0)} s not attributed: no law isolates one "
                    f"sensor among {', '.join(sorted(alarming))}"
                )
        # A target's observer can see its assistant's fault before the assistant's own
        # residual does (a gain fault on s5 alarmed s4's residual, whose assistant it is,
        # 16 s before s5's own): at that first alarm law 0 can only name the target. When
        # the assistant's own alarm starts while the target's still lasts and its decision
        # explains the target's alarm by it, the single fault is the assistant's: the
        # target's earlier event is withdrawn (Section 6.2's laws applied to the alarms
        # over the event's span, not only at its first instant). Only an event no target
        # of its sensor confirmed: a fault of its own would reach the residuals it assists.
        withdrawn: set[int] = set()
        for s, ev, t0, _, k in accepted:
            if ev.evidence.get("confirmed_by"):
                continue
            end = np.inf if ev.end_s is None else ev.end_s
            root = next(
                (
                    (r, tr)
                    for r, _, tr, rdiag, _ in accepted
                    if r != s and t0 < tr <= end and r in rdiag.propagated.get(s, ())
                ),
                None,
            )
            if root is None:
                continue
            r, tr = root
            withdrawn.add(id(ev))
            decisions[k]["revised"] = (
                f"explained by the alarm on {r} at {seconds_text(tr)} s (law 0)"
            )
            notes.append(
                f"alarm on {s} at {seconds_text(t0)} s explained by the alarm on its assistant "
                f"sensor {r} that began at {seconds_text(tr)} s while it lasted (law 0)"
            )
        events = [ev for ev in events if id(ev) not in withdrawn]
        return events, notes, decisions


def _fit_observer_task(task: tuple[Any, ...]) -> tuple[TargetObserver, int, list[FloatArray]]:
    """:meth:`EquivalentModel._fit_observer` on one tuple (what an executor maps)."""
    det, *args = task
    out: tuple[TargetObserver, int, list[FloatArray]] = det._fit_observer(*args)
    return out


def _head(skip: int, n: int) -> int:
    """Samples left out at the head of a held-out half of ``n`` samples while the observer
    settles from its start: ``skip``, at most a quarter of the half."""
    return min(skip, n // 4)


def chain(zeta_t: FloatArray, zeta_s: FloatArray, h_ts: FloatArray) -> FloatArray:
    """Target ``t``'s residual with assistant ``s``'s fault estimate taken out,
    ``zeta_t + h_ts * zeta_s`` (``h_ts``: the FIR that ``t``'s relation applies to ``s``).

    The observers are linear and time-invariant: a fault ``f`` on ``s`` gives ``s``'s
    residual ``L f`` and ``t``'s ``-h_ts * L f`` (``L`` the observer's low-pass, Eq. 30),
    so the sum holds none of it, whatever its shape. It is ``t``'s relation with ``s``'s
    reading replaced by ``s``'s estimate from its own assistants: a residual that cannot
    see ``s``. NaN where either residual is NaN within the FIR's memory."""
    zt = np.asarray(zeta_t, dtype=np.float64)
    zs = np.asarray(zeta_s, dtype=np.float64)
    gap = ~np.isfinite(zs)
    out = zt + _fir(h_ts, np.where(gap, 0.0, zs))
    out[dilate_forward(gap, h_ts.shape[0] - 1)] = np.nan
    return out


def _fir(h: FloatArray, x: FloatArray) -> FloatArray:
    """``sum_l h[l] x[k - l]`` (zero before the first sample)."""
    return np.convolve(x, h)[: x.shape[0]]


def _chained_calibrations(
    net: SensorNetwork,
    observers: Sequence[TargetObserver],
    held: Mapping[str, list[FloatArray]],
    names: Sequence[str],
    window: int,
    far: float,
) -> dict[tuple[str, str], Calibration]:
    """The healthy calibration of :func:`chain` for every edge ``s -> t`` between two
    sensors with an observer, on their held-out fault estimates (``held``: each target's
    two halves, :meth:`EquivalentModel._held_out_estimate`), as each observer's own is
    calibrated: the chained residual predicts data its relations were not fitted on. An
    edge with too little data for it has none (its target confirms as before)."""
    by_name = {names[ob.target]: ob for ob in observers}
    out: dict[tuple[str, str], Calibration] = {}
    for t, ob in by_name.items():
        for s in net.assistant_sensors(t):
            if s not in by_name:
                continue
            h = ob.relation.coef[ob.relation.assistants.index(by_name[s].target)]
            skip = (
                max(
                    _settle_samples(ob.relation, _phi(ob.observer)),
                    _settle_samples(by_name[s].relation, _phi(by_name[s].observer)),
                )
                + h.shape[0]
            )
            parts = []
            for zt, zs in zip(held[t], held[s], strict=True):
                c = chain(zt, zs, h)
                parts.append(c[_head(skip, c.shape[0]) :])
            try:
                out[t, s] = calibrate(parts, window, far)
            except DetectorError:
                continue
    return out


MOSTLY = 0.5
"""A target's alarm confirms a fault on its assistant ``s`` when ``s``'s fault estimate
accounts for most of it: with the estimate taken out (:func:`chain`) the target's residual
is back under its threshold and at most this fraction of its violation."""


@dataclass(frozen=True, slots=True)
class Grade:
    """The residuals' violations at an alarm: each residual's largest alarm statistic in
    units of its threshold (below 1 while it is consistent) over a window at the alarm,
    ``own`` by sensor, ``chained`` by target of the alarming sensor (:func:`chain`)."""

    own: dict[str, float]
    chained: dict[str, float]


class Judgement(NamedTuple):
    """:func:`_judge`'s verdict: the targets that confirm, why no sensor is blamed
    (``changed``, None when law 0's verdict stands) and the numbers behind it."""

    confirmed: list[str]
    changed: str | None
    evidence: dict[str, Any]
    second: str | None = None
    """The sensor of a second fault from the same instant that explains the alarms of the
    residuals blind to ``s`` (:func:`_second_fault`), or None."""


def _judge(
    net: SensorNetwork,
    s: str,
    alarmed: Sequence[str],
    grade: Grade,
    lasting: Collection[str] = (),
    regrade: Callable[[str, Collection[str]], Grade] | None = None,
) -> Judgement:
    """Law 0 weighed by the residuals' violations, for an alarm of ``s`` that law 0 names
    (no assistant of ``s`` alarms) while its targets ``alarmed`` alarm with it.

    Law 0 reads "not over its threshold" as "no fault there": a change of the response's
    level or colour alarms the residuals with a large share of model error together, and
    law 0 then names a sensor whose assistants' residuals happen to be noise-dominated,
    while its targets' coincident alarms looked like its fault reaching them (Probe P1,
    burst3 on 4 channels: s1 named, "confirmed" by s2, both residuals mostly model error).
    As the bank decides between its leave-out estimators (``RELATIVE_CONSISTENCY``):

    * the residuals that cannot see ``s`` (those of the sensors whose relation does not
      use it, and its targets' chained residuals) are about as far over their thresholds
      as ``s``'s own: their median violation is over 1 and more than
      ``RELATIVE_CONSISTENCY`` times ``s``'s. The data changed as a whole (excitation or
      structure), which no single sensor fault explains;
    * a target confirms ``s`` when its residual alarms (over 1) and its chained residual,
      which holds no fault of ``s``'s, is quiet: under 1 and at most :data:`MOSTLY` of
      its own violation. A target whose chained residual alarms (over 1 and more than
      ``RELATIVE_CONSISTENCY`` times its own) contradicts ``s``'s fault, which would leave
      it healthy; when only such targets speak, the alarm is not ``s``'s doing either.

    The targets are weighed whether or not their alarm began with ``s``'s (a target
    whose alarm began with a burst and lasted into a fault of ``s``'s confirms it by its
    chained residual); ``alarmed`` (the alarming ones) confirm by their alarm alone when
    the edge has no chained calibration. Residuals that see a sensor with a fault found
    earlier and still under way (``lasting``) say nothing of this one and are left out.
    A real fault of ``s`` leaves the residuals that cannot see it healthy, so neither
    rule refuses it.

    Two faults from the same instant alarm the residuals blind to ``s`` too, those that
    see the other. Before refusing, the second fault is tried (``regrade(s2, out)``: the
    violations at an alarm of ``s2`` with the fault estimates of ``out`` taken out,
    :func:`_second_fault`): when one sensor explains every alarm of the residuals blind
    to ``s`` and its own target sensors confirm it, it is left out as a fault under way
    is, and ``s`` is judged by the rest."""
    own = grade.own.get(s, 0.0)

    def sees_lasting(n: str, without: str | None = None) -> bool:
        seen = {n} | net.dependencies(n)
        if without is not None:  # a chained residual: s's reading replaced by s's estimate
            seen = (seen - {without}) | net.dependencies(without)
        return bool(seen & set(lasting))

    blind = [
        v
        for n, v in grade.own.items()
        if n != s and s not in net.dependencies(n) and not sees_lasting(n)
    ] + [v for t, v in grade.chained.items() if not sees_lasting(t, s)]
    typical = float(np.median(blind)) if blind else 0.0
    evidence: dict[str, Any] = {
        "violation": own,
        "blind_median": typical,
        "targets": {t: [grade.own.get(t, 0.0), grade.chained[t]] for t in grade.chained},
    }
    if typical >= 1.0 and typical > RELATIVE_CONSISTENCY * own:
        second = None if regrade is None else _second_fault(net, s, grade, set(lasting), regrade)
        if second is not None:
            judged = _judge(net, s, alarmed, grade, {*lasting, second})
            if judged.changed is None:
                judged.evidence["second"] = second
                return judged._replace(second=second)
        return Judgement(
            [],
            f"the residuals that cannot see {s} are about as far over their thresholds "
            f"(median {typical:.2f} of threshold) as its own ({own:.2f}): the data changed "
            "as a whole (a change of the structure or excitation), which no single sensor "
            "fault explains",
            evidence,
        )
    confirmed, refuted = [], []
    for t in net.targets(s):
        if t not in grade.chained:
            if t in alarmed:  # no chained residual to weigh it by: its alarm alone
                confirmed.append(t)
            continue
        if sees_lasting(t, s):
            continue
        v, c = grade.own.get(t, 0.0), grade.chained[t]
        if v >= 1.0 and c < 1.0 and c <= MOSTLY * v:
            confirmed.append(t)
        elif c >= 1.0 and c > RELATIVE_CONSISTENCY * v:
            refuted.append(t)
    if refuted and not confirmed:
        worst = max(refuted, key=lambda t: grade.chained[t])
        return Judgement(
            [],
            f"its fault estimate explains none of its target sensors' residuals: without "
            f"it, the residual of {', '.join(refuted)} still alarms ({worst}'s at "
            f"{grade.chained[worst]:.2f} of its threshold), so the residuals changed beyond "
            "one sensor's fault (a change of the structure or excitation)",
            evidence,
        )
    return Judgement(confirmed, None, evidence)


def _second_fault(
    net: SensorNetwork,
    s: str,
    grade: Grade,
    lasting: set[str],
    regrade: Callable[[str, Collection[str]], Grade],
) -> str | None:
    """The one sensor ``s2`` whose fault, with ``s``'s, explains the alarms of the
    residuals blind to ``s`` (:func:`_judge`), and which passes the confirmation ``s``
    would: ``s2``'s residual alarms, and one of its target sensors ``t`` alarms, both with
    ``s``'s fault estimate taken out (where their relations use ``s``), and is quiet with
    ``s2``'s taken out too (under 1 and at most :data:`MOSTLY` of it; ``s2``'s estimate
    clear of ``s``'s). None when no sensor does.

    The network's law 0 for two faults at once (:meth:`SensorNetwork._smallest_explanations`)
    on the residuals that cannot see ``s``: each alarming one must depend on ``s2`` (be its
    residual, or use it). A change of the whole response alarms residuals that no one
    sensor links, and a sensor they happen to share is not confirmed: its targets'
    residuals, its fault estimate taken out, alarm on."""

    def seen(n: str, without: str | None = None) -> set[str]:
        out = {n} | net.dependencies(n)
        if without is not None:  # a chained residual: s's reading replaced by s's estimate
            out = (out - {without}) | net.dependencies(without)
        return out

    alarms = [
        seen(n)
        for n, v in grade.own.items()
        if v >= 1.0 and n != s and s not in net.dependencies(n) and not seen(n) & lasting
    ] + [seen(t, s) for t, v in grade.chained.items() if v >= 1.0 and not seen(t, s) & lasting]
    if not alarms:
        return None
    shared = set.intersection(*alarms) - {s} - lasting

    def alarm(n: str) -> float:  # n's violation with s's fault estimate taken out
        return grade.chained.get(n, grade.own.get(n, 0.0))

    for s2 in sorted(shared, key=lambda n: -alarm(n)):
        if alarm(s2) < 1.0:
            continue
        g2 = regrade(s2, {s, *lasting})
        for t in net.targets(s2):
            if t == s or t not in g2.chained or seen(t) & lasting:
                continue
            # t's alarm once s's fault estimate is taken out, then s2's too
            v, c = alarm(t), g2.chained[t]
            if v >= 1.0 and c < 1.0 and c <= MOSTLY * v:
                return s2
    return None


def _violation(x: npt.NDArray[Any], cal: Calibration, history: int) -> float:
    """Largest alarm statistic of the residual ``x`` (channel units) from sample
    ``history`` on, the samples before filling its windows: below 1 while the residual
    is consistent (NaNs count as gaps). 0 for no sample."""
    arr = np.asarray(x, dtype=np.float64)
    if arr.shape[0] <= history:
        return 0.0
    stat = alarm_statistic(arr, cal, raw=True, start=history, base=history)
    return float(np.max(stat, initial=0.0))


def _observer_of(model: FittedEquivalentModel, j: int) -> TargetObserver | None:
    """The fitted observer whose target is sensor ``j``, or None."""
    return next((o for o in model.observers if o.target == j), None)


def _phi(obs: AssistantObserver) -> float:
    """The observer's pole per sample, ``exp(-lambda1 dt)``."""
    return float(np.exp(-obs.lambda1 * obs.dt))


def _observer_task(
    task: tuple[
        TargetObserver,
        FloatArray,
        str,
        float,
        str,
        tuple[int | None, int, int],
        tuple[Any, Any] | None,
        ScratchRows,
    ],
) -> tuple[npt.NDArray[Any], npt.NDArray[Any], list[Event], list[str]]:
    """One observer over the archive: its fault estimate (residual), the estimate from
    the assistants (NaN where the residual is), its candidate events and the note on its
    alarms too thin to weigh (:func:`~analyzer.diagnosis.events.unweighed_note`). The two
    signals are returned in :data:`SIGNAL_DTYPE`, written into the two given arrays
    (rows of memory-mapped buffers) when there are. For a long archive the two float64
    signals the event search reads are scratch rows (memory-mapped, reused by the next
    observer), and every pass gives back what it is done with."""
    ob, values, name, rate, detector, (train_start, train_stop, search), into, scratch = task
    # without a healthy window in the record (--model): each fault's slope before its onset
    n = values.shape[0]
    notes: list[str] = []
    with scratch.row("observer-zeta", n) as zeta_row, scratch.row("observer-z", n) as z_row:
        # the fault estimate is searched whole, in float64 (the pass's own array without
        # scratch); of the estimate from the assistants the search reads only its
        # low-passed form: neither is written whole and read back to be kept or filtered
        zeta = np.empty(n) if zeta_row is None else zeta_row
        kept = (np.empty(n, SIGNAL_DTYPE), np.empty(n, SIGNAL_DTYPE)) if into is None else into
        phi = float(np.exp(-ob.observer.lambda1 * ob.observer.dt))
        smooth = LowpassPieces(phi, np.empty(n) if z_row is None else z_row)
        pieces = EquivalentModel._fault_estimate_pieces(ob.observer, ob.relation, values, ob.target)
        for a, zp, zz in pieces:
            bad = ~np.isfinite(zp)
            if bad.any():  # around gaps only (the piece is the pass's own buffer)
                zz[bad] = np.nan
            # a long archive's rows by pwrite; kept in the pipeline's signal precision
            write_rows(zeta, a, zp)
            write_rows(kept[0], a, zp)
            write_rows(kept[1], a, zz)
            smooth.push(a, zz)
            for part in (kept[0][a : a + zp.shape[0]], kept[1][a : a + zp.shape[0]]):
                release(part)  # no-ops in memory
        release(values)  # a memory-mapped archive: its columns were read whole, give them back
        found = events_from_residual(
            name,
            zeta,
            smooth.finish(),
            ob.cal,
            rate,
            detector,
            search_start=search,
            healthy_start=train_start,
            healthy_stop=train_stop,
            before_onset=train_start is None,
            tau_corr=ob.tau,
            scratch=scratch.workdir,
            split=True,
            notes=notes,
        )
    return kept[0], kept[1], found, notes


def _settle_samples(rel: Relation, phi: float) -> int:
    """Samples after a gap before the fault estimate is trusted again: the FIR's memory and
    the observer's decay to ``1e-6``."""
    return rel.lags + int(np.ceil(np.log(1e-6) / np.log(min(max(phi, 1e-3), 1 - 1e-9))))


def _fault_estimate_numpy(
    obs: AssistantObserver, rel: Relation, values: FloatArray, i: int
) -> tuple[FloatArray, FloatArray]:
    """:meth:`EquivalentModel._fault_estimate` from its parts, whole columns at a time:
    :meth:`Relation.estimate`, :meth:`AssistantObserver.rate_residual` and the gap mask
    (the reference form of the compiled :func:`_observer_loop`)."""
    y = np.asarray(values[:, i], dtype=np.float64)
    z = rel.estimate(values)
    gap = ~np.isfinite(y)
    for j in rel.assistants:
        gap |= ~np.isfinite(values[:, j])
    r = obs.rate_residual(z, np.where(np.isfinite(y), y, 0.0))
    zeta = -obs.lambda1 * r
    if gap.any():
        phi = float(np.exp(-obs.lambda1 * obs.dt))
        zeta[dilate_forward(gap, _settle_samples(rel, phi))] = np.nan
    return zeta, z


_BLOCK = 1024  # rows per block of the compiled pass (its buffers stay in cache)
_PIECE = 256 * _BLOCK
"""Rows per call of the compiled pass (a memory-mapped record's pages are released after
each: 32 MB of a 16-channel record)."""
_BIG = float(np.finfo(np.float64).max)


def _observer_loop(
    values: FloatArray,
    offset: int,
    target: int,
    cols: npt.NDArray[np.int64],
    coef: FloatArray,
    intercept: float,
    phi: float,
    gain: float,
    scale: float,
    settle: int,
    hist: FloatArray,
    state: FloatArray,
    zeta: FloatArray,
    z: FloatArray,
) -> None:  # pragma: no cover - compiled by numba
    """``z[k] = intercept + sum_j sum_l coef[j, l] x_j[k - l]`` (:meth:`Relation.estimate`:
    NaN inputs count as 0, +-inf as the largest float, as ``np.nan_to_num`` does),
    ``r[k] = phi r[k - 1] + gain (z[k] - y[k])`` (``y`` NaN -> 0; the recursion exactly as
    ``lfilter`` runs it) and ``zeta = scale r``, NaN within ``settle`` samples after a
    row where the target or an assistant is not finite. Block by block: the last ``L``
    inputs of a block are the next one's FIR history; the FIR runs lag by lag over a
    block (a vector loop) and sums the lags of each output in order.

    ``values`` are the record's rows from ``offset`` on; the pass resumes from and leaves
    its state in ``hist`` (the last ``L`` inputs, zeros at the record's start) and
    ``state`` (``r`` and the record's row of the last gap, ``-settle - 2`` at the start),
    so consecutive calls give the outputs of one call over their rows."""
    n = values.shape[0]
    p = cols.shape[0]
    width = coef.shape[1]
    lag = width - 1
    buf = np.zeros((p, lag + _BLOCK))
    for c in range(p):
        for m in range(lag):
            buf[c, m] = hist[c, m]
    ym = np.empty(_BLOCK)
    gaps = np.zeros(_BLOCK, dtype=np.bool_)
    acc = np.empty(_BLOCK)
    part = np.empty(_BLOCK)
    r = state[0]
    last_gap = int(state[1]) - offset  # as a row of ``values``
    for s in range(0, n, _BLOCK):
        nb = min(_BLOCK, n - s)
        for k in range(nb):
            yv = float(values[s + k, target])
            g = not np.isfinite(yv)
            ym[k] = 0.0 if g else yv
            for c in range(p):
                xv = float(values[s + k, cols[c]])
                if not np.isfinite(xv):
                    g = True
                    xv = 0.0 if np.isnan(xv) else (_BIG if xv > 0.0 else -_BIG)
                buf[c, lag + k] = xv
            gaps[k] = g
        for k in range(nb):
            acc[k] = intercept
        for c in range(p):
            xb = buf[c]
            for k in range(nb):
                part[k] = 0.0
            m = 0
            while m < width:  # four lags per sweep, added in lag order
                if m + 4 <= width:
                    h0, h1, h2, h3 = coef[c, m], coef[c, m + 1], coef[c, m + 2], coef[c, m + 3]
                    x0 = xb[lag - m : lag - m + nb]
                    x1 = xb[lag - m - 1 : lag - m - 1 + nb]
                    x2 = xb[lag - m - 2 : lag - m - 2 + nb]
                    x3 = xb[lag - m - 3 : lag - m - 3 + nb]
                    for k in range(nb):
                        part[k] = (((part[k] + h0 * x0[k]) + h1 * x1[k]) + h2 * x2[k]) + h3 * x3[k]
                    m += 4
                else:
                    h0 = coef[c, m]
                    x0 = xb[lag - m : lag - m + nb]
                    for k in range(nb):
                        part[k] += h0 * x0[k]
                    m += 1
            for k in range(nb):
                acc[k] += part[k]
        for k in range(nb):
            x = gain * (acc[k] - ym[k])
            # lfilter([1], [1, -phi]): y = x + zstate, zstate = 0 * x - (-phi) * y
            r = x + r
            z[s + k] = acc[k]
            zeta[s + k] = scale * r
            r = 0.0 * x + phi * r
            if gaps[k]:
                last_gap = s + k
            if s + k - last_gap <= settle:
                zeta[s + k] = np.nan
        for c in range(p):  # the last ``lag`` inputs: the next block's history
            for m in range(lag):
                buf[c, m] = buf[c, nb + m]
    for c in range(p):
        for m in range(lag):
            hist[c, m] = buf[c, m]
    state[0] = r
    state[1] = float(last_gap + offset)


_observer_kernel: Callable[..., None] | None
try:  # numba compiles the per-sample pass; nogil lets threads run observers at once
    from numba import njit
except ImportError:  # pragma: no cover - numba is a dependency; numpy without it
    _observer_kernel = None
else:
    _observer_kernel = njit(cache=True, nogil=True)(_observer_loop)


__all__ = [
    "EquivalentModel",
    "FittedEquivalentModel",
    "TargetObserver",
    # (their home is assistant_observer; here too for models saved before the move)
    "AssistantObserver",
    "Pretreatment",
    "Relation",
]
