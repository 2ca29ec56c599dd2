"""Beard-Jones detection filter for sensor faults by state augmentation (Park, Rizzoni &
Ribbens 1994), designed in discrete time.

The filters' design (augmentation, gains, the conditions on the model: Eq. 10-20,
Theorem 4.1, Lemmas 3.1-3.2) is in :mod:`analyzer.detectors.beard_jones`, the models
they are designed on in :mod:`analyzer.detectors.state_space`.

Isolation
---------
One filter per sensor (a bank). The fault estimate ``zeta`` of filter ``i`` (sensor units,
``measured - estimated``) is the channel's residual and goes through
:func:`analyzer.diagnosis.events.events_from_residual`. A fault on sensor ``j`` also moves
``zeta`` of filters ``i != j`` (their state estimate uses sensor ``j``), but then the residual
of filter ``i`` leaves the direction ``e_i``: the innovations of its other sensors become
inconsistent (their normalized squared size, watched with the same windowed statistics as
the residuals). Alarms within a long window of each other compete for one fault: the
sensor is the one whose filter stays closest to its direction, clearly closer than the
typical other filter (:data:`DIRECTION_SEPARATION`, with 6 or more channels; if over
its threshold, :data:`DIRECTION_RELATIVE`); it is reported when other filters -- they
measure the sensor -- left their directions (confirmation: with 6 or more channels, most
of them, their median over its threshold; with fewer, one of them).
An alarm no filter confirms is model mismatch, noted but not reported.
Two faults at once leave every filter off its direction (no sensor named), and a
filter's residual changes where another sensor's fault begins or ends: a fault goes on
through a change of its filter where another reported fault ended (:func:`_another_ended`)
and where its filter alarms again inside it with no sensor named (:func:`_went_on`), and
one named only after the other ended begins at its filter's unnamed change before
(:func:`_began_unnamed`), unless that change was where the filter's own reported fault
was lost: then it is that fault going on (:func:`_resumes`).

Thresholds of the AR-based bank are calibrated out of sample (models refitted on each
half of the healthy window, run on the other half), since in-sample innovations are too
small. The
calibration streams the bank's outputs over the window (fault estimates kept, residual
vectors reduced to running moments, then filtered again for their normalized squares),
so fitting on an hour holds a few values per filter and sample, not every residual
vector.

Model: the ``[model]`` of the config when one is given, else a multichannel AR model
identified on the healthy window, in block observer-canonical form (:func:`ar_observer_form`).
"""

from __future__ import annotations

import numbers
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from analyzer.detectors.base import (
    SIGNAL_DTYPE,
    Advance,
    Dataset,
    DetectorResult,
    Event,
    RunContext,
    Steps,
    dilate_forward,
    map_in,
)
from analyzer.detectors.beard_jones import ParkFilter, check_observable, filter_bank, park_filter
from analyzer.detectors.lowpass import LowpassPieces
from analyzer.detectors.lti import ImpulseResponseBank, LiftedBank, run_chunked, time_blocks
from analyzer.detectors.state_space import StateSpaceModel, model_from_ar, model_from_config
from analyzer.diagnosis.changes import (
    Calibration,
    alarm_statistic,
    calibrate,
    default_window,
    needing_calibration,
)
from analyzer.diagnosis.classify import CORRELATION_LAGS, integrated_time
from analyzer.diagnosis.events import events_from_residual, first_bound
from analyzer.diagnosis.load import LOUD_KINDS, LOUD_MARK, LoadGuard
from analyzer.diagnosis.streamed import (
    BlockMeans,
    LaggedSums,
    RowMoments,
    Series,
    finite_blocks,
    series_moments,
)
from analyzer.errors import DetectorError, TooLittleDataError
from analyzer.paging import RELEASE_ROWS, Released, ScratchRows, finite_rows, release, write_rows
from analyzer.timeutil import seconds_text, spoken_duration
from analyzer.types import FaultType

FloatArray = npt.NDArray[np.float64]

UNCONFIRMED_FACTOR = 0.75
"""Confidence factor for a fault that no other residual confirms (used by the
equivalent-model detector for foot-sensors, whose fault reaches no other residual)."""

DIRECTION_RELATIVE = 0.25
"""A filter whose residual leaves its direction (off-direction statistic over 1) still
isolates its sensor when it is at most this fraction as far off as the typical other
filter: a burst of excitation that inflates every filter alike must not mask a sensor
fault (the same rule as the AR Kalman bank's relative consistency)."""

DIRECTION_SEPARATION = 0.6
"""A filter whose residual stays within its direction (off-direction statistic under 1)
isolates its sensor only when it is at most this fraction of the typical other filter's:
under a load the models were not fitted on (a machine's sine, a walking load at the
training level) every filter sits near its threshold, and the one a hair below the rest
(0.74-0.97 of the typical other's, in eight healthy simulated records) named no sensor;
a sensor's own offset or gain leaves its filter at 0.18-0.52 of the typical other's
(``sweep_isolation.py``, half- and 0.3x-size faults on 6 and 16 channels). With at least
:data:`SEPARATION_OTHERS` other filters."""

SEPARATION_OTHERS = 5
"""Other filters needed for :data:`DIRECTION_SEPARATION` and for a confirmation by most of
them (their median): with fewer (2 to 5 channels) a median says little, and a slow drift
of a sensor leaves its own filter at 0.72-0.94 of the typical other's (2- and 4-channel
buildings, one sensor per floor): there one other filter over its threshold confirms, and
the sensor's filter needs only to be the closest to its direction, as before."""

DIRECTION_BATCH = 1 << 16
"""Longest stretch of samples whose direction statistics are computed in one pass for the
alarm groups' windows (:meth:`DetectionFilter._window_violations`): a filter bank's
outputs over it are a few tens of MB."""

CALIBRATION_ROWS = 1 << 16
"""Rows of the training window a calibration pass reads at once to find its gaps."""

KEPT_RESIDUALS_BYTES = 160 << 20
"""Memory the calibration may hold in its filters' residual vectors (each without its own
direction) between its two passes (~115 MB for 16 channels and a 10-minute window at
100 Hz); beyond it, pass 2 runs the bank over the stretches again (~0.45 s of CPU at 16
channels)."""


def direction_angles(q: FloatArray, scale: FloatArray | None = None) -> FloatArray:
    """Angles (radians) between residual vectors ``q`` (N, m) and every output direction
    ``e_j``: ``(N, m)``, ``arccos(|q_j| / |q|)``; rows with ``q = 0`` give NaN. ``scale``
    divides each component first (whitening by the healthy residual spread)."""
    qq = np.asarray(q, dtype=np.float64)
    if scale is not None:
        qq = qq / np.asarray(scale, dtype=np.float64)
    norm = np.linalg.norm(qq, axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.abs(qq) / norm
    return np.arccos(np.clip(cos, 0.0, 1.0))


# -- the detector -----------------------------------------------------------------------------


def _is_integer(value: Any) -> bool:
    """An integer setting (a boolean is not one, nor is a float with no fraction)."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_)


def _span(channels: Sequence[str]) -> str:
    """Channels in a few words: all of a few, else the first and last."""
    return ", ".join(channels) if len(channels) <= 4 else f"{channels[0]}..{channels[-1]}"


def _is_real(value: Any) -> bool:
    """A numeric setting (a boolean or a string is not one)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)


@dataclass(frozen=True, slots=True)
class FittedDetectionFilter:
    model: StateSpaceModel
    filters: tuple[ParkFilter, ...]
    window: int
    zeta_cal: tuple[Calibration, ...]
    direction_cal: tuple[Calibration, ...]
    direction_inv_cov: tuple[FloatArray, ...]
    q_scale: tuple[FloatArray, ...]
    tau: tuple[float, ...]
    settle: int


class DetectionFilter:
    """``detection_filter``: a bank of Park et al. (1994) detection filters, one per sensor.

    Settings: ``order`` (AR order or ``"aic"``/``"bic"``, used without a ``[model]``),
    ``max_order``, ``fault_pole`` (``alpha`` of Eq. 12-14, 1 = constant faults),
    ``time_constant_s`` (of the fault estimate, ``sigma = exp(-1 / (T rate))``; default one
    sample period: the estimate follows a fault within a couple of samples, so a step stays
    a step for the classifier -- averaging is the detection windows' job),
    ``use_config_model`` (False ignores ``[model]``)."""

    name: ClassVar[str] = "detection_filter"

    def __init__(
        self,
        order: int | str = "bic",
        max_order: int = 10,
        fault_pole: float = 1.0,
        time_constant_s: float | None = None,
        use_config_model: bool = True,
        block: int = 64,
    ) -> None:
        where = "[detectors.detection_filter]"
        if isinstance(order, str):
            if order not in ("aic", "bic"):
                raise DetectorError(
                    f"{where} order: expected an integer, 'aic' or 'bic', got {order!r}"
                )
        elif not _is_integer(order):  # 2.5 ran as order 2
            raise DetectorError(
                f"{where} order: expected an integer, 'aic' or 'bic', got {order!r}"
            )
        elif order < 1:
            raise DetectorError(f"{where} order must be >= 1, got {order}")
        for key, count in (("max_order", max_order), ("block", block)):
            if not _is_integer(count) or count < 1:
                raise DetectorError(f"{where} {key}: expected an integer >= 1, got {count!r}")
        if not _is_real(fault_pole) or not 0.0 < float(fault_pole) <= 1.0:
            raise DetectorError(f"{where} fault_pole must be in (0, 1], got {fault_pole!r}")
        if time_constant_s is not None and (
            not _is_real(time_constant_s) or not 0.0 < float(time_constant_s) < np.inf
        ):
            raise DetectorError(f"{where} time_constant_s must be > 0, got {time_constant_s!r}")
        if not isinstance(use_config_model, bool | np.bool_):
            # bool("false") is True: the model was used
            raise DetectorError(
                f"{where} use_config_model: expected true or false, got {use_config_model!r}"
            )
        self.order: int | str = order if isinstance(order, str) else int(order)
        self.max_order = int(max_order)
        self.fault_pole = float(fault_pole)
        self.time_constant_s = None if time_constant_s is None else float(time_constant_s)
        self.use_config_model = bool(use_config_model)
        self.block = int(block)

    def _config_model(self, context: RunContext) -> Mapping[str, Any] | None:
        model = context.config.get("model") if self.use_config_model else None
        return model if model else None

    def applicable(self, data: Dataset, context: RunContext) -> str | None:
        model = self._config_model(context)
        if model is not None:
            outs = list(model.get("outputs") or [])
            absent = [c for c in outs + list(model.get("inputs") or []) if c not in data.channels]
            if outs and absent:
                return (
                    f"the [model] names channels not analyzed here: {', '.join(absent)} "
                    f"(analyzed: {_span(data.channels)})"
                )
            n_out = len(outs) or np.asarray(model["C"]).shape[0]
            if n_out < 2:
                return "needs a model with at least 2 outputs (one fault direction per sensor)"
            return None
        if len(data.channels) < 2:
            return "needs at least 2 channels (one fault direction per sensor)"
        return None

    def _sigma(self, rate_hz: float) -> float:
        tau_s = self.time_constant_s if self.time_constant_s is not None else 1.0 / rate_hz
        return float(min(np.exp(-1.0 / (tau_s * rate_hz)), self.fault_pole * (1.0 - 1e-6)))

    # -- fitting -----------------------------------------------------------------------------
    def fit(self, data: Dataset, context: RunContext) -> FittedDetectionFilter:
        reason = self.applicable(data, context)
        if reason:
            raise DetectorError(f"{self.name} {reason}")
        cfg = self._config_model(context)
        window = default_window(data.rate_hz)
        try:
            model = (
                model_from_config(cfg, data)
                if cfg is not None
                else model_from_ar(data, self.order, self.max_order)
            )
        except TooLittleDataError as err:  # (the thresholds' calibration needs more)
            raise needing_calibration(err, window) from None
        sigma = self._sigma(data.rate_hz)
        filters = self._bank(model, data, sigma, context)
        train = np.asarray(data.train_values(), dtype=np.float64)
        settle = max(f.settle() for f in filters)
        if cfg is not None:
            # a given model: only the noise ratio was fitted, calibrate in sample
            skip = min(settle, train.shape[0] // 4)
            segments = [_Segment(model, filters, train, skip)]
        else:
            segments = self._held_out(model, data, train, sigma, context)
        k = len(filters)

        def kept(name: str, seg: _Segment) -> npt.NDArray[Any] | None:
            """Where a task writes a stretch's series per filter: a buffer of the
            caller's (memory-mapped for a long archive) where tasks share its memory."""
            n = seg.values.shape[0] - seg.start
            return context.buffer(f"{self.name}-{name}", (n, k)) if context.shares_memory else None

        # pass 2 needs every filter's residual vectors off its own direction again: kept
        # from pass 1 when they fit in KEPT_RESIDUALS_BYTES, else the bank runs again
        m = filters[0].n_outputs
        rows = sum(seg.values.shape[0] - seg.start for seg in segments)
        keep = rows * k * (m - 1) * 8 <= KEPT_RESIDUALS_BYTES
        parts = map_in(
            context,
            _moments_task,
            [(seg, kept("zeta", seg), keep) for seg in segments],
            "calibration stretches",
        )
        alpha_far = context.false_alarm_rate / len(data.channels)  # per channel
        zcal, dcal, dinv, qscale, taus = [], [], [], [], []
        for i in range(k):
            # the stretches' series read one after the other (no concatenated copy)
            z = [zetas[:, i] for zetas, _, _ in parts]
            try:
                zcal.append(calibrate(z, window, alpha_far))
            except DetectorError as err:
                raise _settling_error(err, filters[i].settle(), data) from None
            taus.append(long_run_time(z, window))
            moments = RowMoments.merged([each[i] for _, each, _ in parts])
            # np.cov of the residual vectors without the filter's own direction
            cov = np.atleast_2d(np.delete(np.delete(moments.m2, i, 0), i, 1) / (moments.n - 1))
            dinv.append(np.asarray(np.linalg.pinv(cov), dtype=np.float64))
            qs = np.sqrt(np.diag(moments.m2) / moments.n)  # np.std of each component
            qscale.append(np.where(qs > 0, qs, 1.0))
        inv_covs = tuple(dinv)
        offs = [off for _, _, off in parts]
        del parts
        nis = map_in(
            context,
            _nis_task,
            [
                (seg, inv_covs, kept("nis", seg), off)
                for seg, off in zip(segments, offs, strict=True)
            ],
            "direction stretches",
        )
        del offs
        for i in range(k):
            dcal.append(calibrate([part[:, i] for part in nis], window, alpha_far))
        del nis
        return FittedDetectionFilter(
            model,
            filters,
            window,
            tuple(zcal),
            tuple(dcal),
            tuple(dinv),
            tuple(qscale),
            tuple(taus),
            settle,
        )

    def _bank(
        self,
        model: StateSpaceModel,
        data: Dataset,
        sigma: float,
        context: RunContext | None = None,
        check: bool = True,
    ) -> tuple[ParkFilter, ...]:
        """One Park filter per output sensor (independent designs: executor tasks);
        ``check=False`` skips the observability test (a model whose form guarantees it)."""
        names = [data.channels[j] for j in model.outputs]
        eig = np.linalg.eigvals(model.A)
        if check:
            check_observable(model.A, model.C, eig)  # once for the bank (Theorem 4.1)
        tasks = [(model, i, self.fault_pole, sigma, names, eig) for i in range(len(model.outputs))]
        return tuple(map_in(context, _park_task, tasks, "filters designed"))

    def _held_out_half(
        self,
        model: StateSpaceModel,
        data: Dataset,
        train: FloatArray,
        sigma: float,
        order: int,
        rows: tuple[slice, slice],
    ) -> _Segment:
        """The rows ``rows[1]`` of the training window under the bank fitted on
        ``rows[0]`` (the whole model where a half is too short), as a :class:`_Segment`
        whose outputs the calibration streams."""
        fit_rows, eval_rows = rows
        try:
            sub = model_from_ar(data, order, self.max_order, rows=train[fit_rows])
            # the observer-canonical form of an AR model is observable by construction
            # (ar_observer_form); the whole-window model passed the test already
            bank = self._bank(sub, data, sigma, check=False)
        except DetectorError:
            sub, bank = model, self._bank(model, data, sigma)  # halves too short
        skip = min(max(f.settle() for f in bank), (train.shape[0] // 2) // 4)
        # only the evaluated rows (and the history the filters remember before them)
        return _Segment(sub, bank, train[: eval_rows.stop], eval_rows.start + skip)

    def _held_out(
        self,
        model: StateSpaceModel,
        data: Dataset,
        train: FloatArray,
        sigma: float,
        context: RunContext | None = None,
    ) -> list[_Segment]:
        """Healthy stretches for calibration, out of sample: the AR model (same order) is
        refitted on each half of the training window, and each half's bank runs over the
        other half (first the first half's rows, then the second's). An AR model's
        in-sample innovations are smaller than on new data, and the thresholds must hold
        on new data."""
        n = train.shape[0]
        half = n // 2
        order = int(model.summary["order"])
        halves = ((slice(0, half), slice(half, n)), (slice(half, n), slice(0, half)))
        # the tasks need the channel names and the training rows, not the archive
        light = replace(data, values=train, train=(0, n))
        tasks = [(self, model, light, train, sigma, order, rows) for rows in halves]
        parts = map_in(context, _held_out_half_task, tasks, "held-out halves")
        return [parts[1], parts[0]]  # evaluated on the first half, then on the second

    @staticmethod
    def _inputs(
        model: StateSpaceModel, values: FloatArray
    ) -> tuple[FloatArray, npt.NDArray[np.bool_]]:
        """The bank's input ``v = [y; u]`` (centred, outputs scaled, missing values as 0)
        and the rows where a value is missing."""
        outputs, inputs = list(model.outputs), list(model.inputs)
        m = len(outputs)
        v = np.empty((values.shape[0], m + len(inputs)))
        # the AR model's outputs are the leading columns: a slice, not a gathered copy
        cols = values[:, :m] if outputs == list(range(m)) else values[:, outputs]
        np.subtract(cols, model.y_mean, out=v[:, :m])
        v[:, :m] /= model.y_scale
        if inputs:
            v[:, m:] = values[:, inputs]
            v[:, m:] -= model.u_mean
        finite = np.isfinite(v)
        if finite.all():  # the usual chunk: nothing to mask
            return v, np.zeros(v.shape[0], dtype=bool)
        gap = ~finite
        v[gap] = 0.0
        return v, np.asarray(gap.any(axis=1), dtype=bool)

    def _outputs(
        self,
        model: StateSpaceModel,
        filters: Sequence[ParkFilter],
        values: FloatArray,
        start: int = 0,
    ) -> list[tuple[FloatArray, FloatArray, FloatArray]]:
        """Per filter: residual vector ``q`` (N - start, m), fault estimate and
        fault-free estimate (sensor units) for the rows from ``start``; NaN where an input
        was missing and while the filter settles after it. Keeps every filter's ``q``
        (``k m`` values per row): the whole-array reference that the streamed outputs
        of the calibration (:func:`_moments_task`) and of a run (:meth:`_run_outputs`)
        are tested against. An impulse-response bank filters only the history it
        remembers before ``start`` (the outputs of a run from row 0, to rounding)."""
        bank = filter_bank(filters)
        if bank.history is not None:  # and a gap before it masks nothing from ``start`` on
            first = max(0, start - max(bank.history, *(f.settle() for f in filters)))
        else:  # a lifted bank remembers everything: run from the first row
            first = 0
        v, bad = self._inputs(model, np.asarray(values[first:]))
        m = filters[0].n_outputs
        out = np.empty((len(filters), m + 2, v.shape[0]))
        for at, y in bank.run(v):
            out[:, :, at : at + y.shape[2]] = y
        out = out[:, :, start - first :]
        res = []
        for f in filters:
            i = f.sensor
            q = out[i, :m].T * model.y_scale  # sensor units
            zeta = out[i, m] * model.y_scale[i]
            ref = out[i, m + 1] * model.y_scale[i] + model.y_mean[i]
            if bad.any():
                mask = dilate_forward(bad, f.settle())[start - first :]
                q[mask] = np.nan
                zeta[mask] = np.nan
                ref[mask] = np.nan
            res.append((q, zeta, ref))
        return res

    @classmethod
    def _run_outputs(
        cls,
        model: FittedDetectionFilter,
        values: FloatArray,
        context: RunContext | None = None,
        directions: bool = True,
        bank: ImpulseResponseBank | LiftedBank | None = None,
    ) -> tuple[
        FloatArray, npt.NDArray[np.float32], npt.NDArray[np.float32] | None, npt.NDArray[np.bool_]
    ]:
        """Per filter (rows): fault estimate (sensor units), fault-free estimate (float32, in
        the model's centred and scaled units: ``ref * y_scale + y_mean`` is in sensor units,
        :func:`_sensor_units`) and the normalized squared residual off the filter's
        direction (:func:`_nis`, float32; None without ``directions``: then an
        impulse-response bank runs its two estimate outputs per filter only, about
        ``2 / (m + 2)`` of its work), NaN where an
        input was missing and while the filter settles after it; and the rows where an
        input was missing. ``bank``: :func:`filter_bank` of the model's filters, when the
        caller has it. The bank's input is built chunk by chunk from ``values`` (with
        the history an impulse-response bank remembers) and the residual vectors are
        reduced per chunk and not kept, so memory grows with ``3 k N`` only. With a
        parallel executor in ``context`` an impulse-response bank runs in time blocks
        (each recomputed from the history it remembers: the serial outputs to rounding),
        written in place on threads."""
        k = len(model.filters)
        N = values.shape[0]
        bank = filter_bank(model.filters) if bank is None else bank
        if not directions and isinstance(bank, ImpulseResponseBank):
            m = model.filters[0].n_outputs
            bank = bank.select([m, m + 1])  # the fault estimate and the fault-free one
        # the fault-free estimate is kept centred and scaled (order 1, so single precision
        # loses nothing a sensor's offset would), the direction statistic only feeds
        # alarm statistics: both in float32
        mapped = context is not None and context.map_outputs

        def rows(name: str, dtype: npt.DTypeLike) -> npt.NDArray[Any]:
            """(k, N), a row per filter; memory-mapped for a long archive (its buffer is
            channel-major: the transpose is), else in memory."""
            if mapped:
                assert context is not None
                return context.buffer(name, (N, k), dtype).T
            return np.empty((k, N), dtype)

        outs: tuple[Any, ...] = (
            rows("zeta", np.float64),
            rows("ref", np.float32),
            np.empty((k, N), dtype=np.float32) if directions else None,
            np.zeros(N, dtype=bool),
        )
        hist = bank.history
        spans = [(0, N)]
        if context is not None and hist is not None:
            blocks = time_blocks(0, N, max(hist, 1), context, values.shape[1])
            spans = [(a, b) for a, b, _ in blocks]
        # its pass over the whole record (a run's, not the few stretches of an event)
        # advances the progress chunk by chunk: on a day's archive the detection filter's
        # run left --progress silent for most of a minute
        advanced = (
            Advance(context, "whole record", N) if context is not None and not directions else None
        )
        if len(spans) == 1 or context is None:
            for a, b in spans:
                _df_span((model, bank, values, 0, a, b, outs, directions, advanced))
        elif context.shares_memory:
            context.map(
                _df_span,
                [(model, bank, values, 0, a, b, outs, directions, advanced) for a, b in spans],
            )
        else:  # a cluster: each task gets its span and the history before it, nothing more
            # (the model and the bank are sent to each worker once); a few spans in flight
            # at a time, each written here as it comes back
            assert hist is not None
            shared_model, shared_bank = context.scatter(model), context.scatter(bank)
            starts = [max(0, a - hist) for a, _ in spans]
            tasks = (
                (shared_model, shared_bank, values[base:b], base, a, b, None, directions)
                for base, (a, b) in zip(starts, spans, strict=True)
            )
            shown = Steps(context, "time blocks", len(spans))
            for (a, b), piece in zip(spans, context.imap(_df_span, tasks), strict=True):
                shown.done()
                for whole, part in zip(outs, piece, strict=True):
                    if whole is not None and whole.ndim == 2:  # (filters, samples)
                        write_rows(whole.T, a, part.T)  # to a long archive's file directly
                    elif whole is not None:
                        whole[a:b] = part
                del piece
        zeta, ref, nis, bad = outs
        if bad.any():
            for i, f in enumerate(model.filters):
                mask = dilate_forward(bad, f.settle())
                zeta[i, mask] = np.nan
                ref[i, mask] = np.nan
                release(zeta[i])
                release(ref[i])
                if nis is not None:
                    nis[i, mask] = np.nan
        return zeta, ref, nis, bad

    @classmethod
    def _direction_statistics(
        cls,
        model: FittedDetectionFilter,
        bank: ImpulseResponseBank | LiftedBank,
        values: FloatArray,
        bad: npt.NDArray[np.bool_],
        lo: int,
        hi: int,
    ) -> list[FloatArray]:
        """Per filter, the alarm statistic of its direction statistic over samples
        ``lo .. hi - 1`` (> 1: its residual left its sensor's direction). Recomputed for
        the window from the data (with the history the bank remembers and a long window
        before ``lo`` for the statistic): what a run over the whole record gives there, to
        rounding. ``bad``: the record's rows with a missing input."""
        long = max(cal.long_window for cal in model.direction_cal)
        s = max(0, lo - (long - 1))
        _, _, nis, _ = _df_span((model, bank, values, 0, s, hi, None, True))
        assert nis is not None
        stats = []
        for i, f in enumerate(model.filters):
            settle = f.settle()
            first = max(0, s - settle)
            mask = dilate_forward(bad[first:hi], settle)[s - first :]
            row = nis[i]
            row[mask] = np.nan
            stats.append(alarm_statistic(row, model.direction_cal[i], raw=True)[lo - s :])
        return stats

    @classmethod
    def _window_violations(
        cls,
        model: FittedDetectionFilter,
        bank: ImpulseResponseBank | LiftedBank,
        values: FloatArray,
        bad: npt.NDArray[np.bool_],
        windows: list[tuple[int, int]],
        context: RunContext | None = None,
    ) -> list[list[float]]:
        """Per window ``(lo, hi)``, each filter's largest direction alarm statistic over
        it: ``max(_direction_statistics(..., lo, hi)[i], initial=0)``, to rounding.

        The windows' union (windows overlapping, or closer than the history a window's
        statistics start from, merged) is worked through in stretches of at most
        :data:`DIRECTION_BATCH` samples, each computed once with the history it needs,
        and every window takes the maxima over the stretches it overlaps: a sample's
        statistics are computed once however many windows hold it (a slow drift's
        alarm groups each reach back to its traced onset), and memory is set by the
        stretch, not by the windows. The stretches are independent: with a ``context``
        they run on its threads (each returns only its windows' maxima)."""
        k = len(model.filters)
        viol = [[0.0] * k for _ in windows]
        long = max(cal.long_window for cal in model.direction_cal)
        join = long + (bank.history or 0)
        order = sorted(range(len(windows)), key=lambda w: windows[w][0])
        spans: list[list[int]] = []
        for w in order:
            lo, hi = windows[w]
            if hi <= lo:
                continue
            if spans and lo <= spans[-1][1] + join:
                spans[-1][1] = max(spans[-1][1], hi)
            else:
                spans.append([lo, hi])
        tasks = []
        for lo_s, hi_s in spans:
            inside = [w for w in order if windows[w][0] < hi_s and windows[w][1] > lo_s]
            for p in range(lo_s, hi_s, DIRECTION_BATCH):
                q = min(hi_s, p + DIRECTION_BATCH)
                held = [w for w in inside if windows[w][0] < q and windows[w][1] > p]
                if not held:
                    continue  # a gap between windows, filtered only as the next's history
                cuts = [(max(windows[w][0], p) - p, min(windows[w][1], q) - p) for w in held]
                tasks.append(((model, bank, values, bad, p, q, cuts), held))
        found = (
            [_violations_task(t) for t, _ in tasks]
            if context is None
            else context.map_shared(_violations_task, [t for t, _ in tasks])
        )
        for (_, held), maxima in zip(tasks, found, strict=True):
            for w, top in zip(held, maxima, strict=True):
                viol[w] = [max(v, t) for v, t in zip(viol[w], top, strict=True)]
        return viol

    @classmethod
    def _residual_vectors(
        cls,
        model: FittedDetectionFilter,
        j: int,
        values: FloatArray,
        bad: npt.NDArray[np.bool_],
        lo: int,
        hi: int,
        bank: ImpulseResponseBank | LiftedBank | None = None,
    ) -> FloatArray:
        """Residual vectors ``q`` (sensor units) of filter ``j`` over samples ``lo .. hi - 1``
        of the run (clipped to the record), recomputed from the data for the few samples an
        event needs (only the input the filter remembers is rebuilt); NaN as in
        :meth:`_run_outputs`. ``bank``: the impulse responses of every filter (the run's
        :func:`filter_bank`), whose filter ``j`` is taken instead of building its own (a
        fault that lasts asks for this at hundreds of alarms)."""
        f = model.filters[j]
        hi = min(values.shape[0], hi)
        if hi <= lo:
            return np.empty((0, f.n_outputs))

        def inputs(a: int, b: int) -> FloatArray:
            rows = values[a:b]
            v = cls._inputs(model.model, np.asarray(rows))[0]
            release(rows)  # a memory-mapped archive: hundreds of events would map it all
            return v

        one = bank.subset([j]) if isinstance(bank, ImpulseResponseBank) else filter_bank([f])
        pieces = [y[0, : f.n_outputs] for _, y in run_chunked(one, inputs, hi, lo)]
        q = np.concatenate(pieces, axis=1).T * model.model.y_scale
        first = max(0, lo - f.settle())
        q[dilate_forward(bad[first:hi], f.settle())[lo - first :]] = np.nan
        return q

    def estimate_warmup(self, model: FittedDetectionFilter, j: int) -> int | None:
        """Rows :meth:`estimate` filters before the rows it estimates (sensor ``j``): the
        input history the filters' impulse responses remember, or the settling after a
        gap if longer; None for sensors without a filter and for filters with a long
        memory (a lifted bank: an output depends on the whole past)."""
        outputs = list(model.model.outputs)
        if j not in outputs:
            return None
        hist = filter_bank(model.filters).history
        if hist is None:
            return None
        return max(hist, model.filters[outputs.index(j)].settle())

    def estimate(
        self, model: FittedDetectionFilter, rows: FloatArray, start: int, j: int
    ) -> FloatArray:
        """Sensor ``j``'s fault-free estimate (sensor units; NaN where an input was missing
        and while the filter settles after it) over ``rows[start:]``, with ``rows[:start]``
        as the history (up to :meth:`estimate_warmup` rows): the run's ``reference``
        computed again on other rows, such as the record with other sensors' faults
        corrected (:func:`analyzer.regenerate.corrected_values`)."""
        outputs = list(model.model.outputs)
        if j not in outputs:
            raise DetectorError(f"{self.name}: no filter estimates sensor {j}")
        _, refs, _, _ = self._run_outputs(model, np.asarray(rows, dtype=np.float64), None, False)
        return _sensor_units(model, refs, outputs.index(j))[start:]

    # -- running -----------------------------------------------------------------------------
    @staticmethod
    def _refit_before_others(
        events: list[Event],
        owners: list[int],
        found: Sequence[tuple[Sequence[Event], Sequence[str]]],
        cals: Sequence[Calibration],
        tasks: list[tuple[Any, ...]],
        context: RunContext,
        n: int,
        rate: float,
    ) -> None:
        """Each reported fault whose stretch holds another filter's candidate onset (in
        ``found``, reported or not: an alarm taken for this fault's may be another
        sensor's fault) gets its shape fitted up to the first such onset a part's length
        or more after its own: the other fault's trace in its filter's residual would
        bend the shape (an offset of 2 sd on another floor from 150 s flattened a drift's
        line from 100 s, traced back to 89.4 s). The filter's events are searched again
        with those onsets (``until``: :func:`~analyzer.diagnosis.events.first_bound`) and
        each reported event takes the refitted one of its first alarm's shape, onset and
        magnitude (its end stays the whole stretch's). Only filters with such an event
        are searched again: two sensors' faults at once, but also one fault whose own
        trace alarmed another filter a part's length into it (a gain of 1.5 alone is
        then fitted on its first part: 1.4991 -> 1.4999; the second search cost 0.02 s
        against the first's 0.3 s in the review's runs)."""
        onsets = sorted(
            {(int(round(ev.onset_s * rate)), j) for j, (evs, _) in enumerate(found) for ev in evs}
        )
        redo: dict[int, list[int]] = {}
        for ev, j in zip(events, owners, strict=True):
            others = [k for k, o in onsets if o != j]
            b = n if ev.end_s is None else int(round(ev.end_s * rate))
            bound = first_bound(others, int(round(ev.onset_s * rate)), cals[j], rate)
            if ev.type is not FaultType.OTHER and bound is not None and bound < b:
                redo[j] = others
        if not redo:
            return
        again = context.map_shared(_filter_events_task, [(*tasks[j], redo[j]) for j in redo])
        for j, (refitted, _) in zip(redo, again, strict=True):
            by_alarm = {e.evidence.get("first_alarm_s"): e for e in refitted}
            for ev, owner in zip(events, owners, strict=True):
                new = by_alarm.get(ev.evidence.get("first_alarm_s")) if owner == j else None
                if new is None:
                    continue
                for name in REFITTED:
                    setattr(ev, name, getattr(new, name))
                kept = {k: ev.evidence[k] for k in DIRECTION_EVIDENCE if k in ev.evidence}
                ev.evidence.clear()
                ev.evidence.update({**new.evidence, **kept})

    def run(
        self, model: FittedDetectionFilter, data: Dataset, context: RunContext
    ) -> DetectorResult:
        ssm = model.model
        names = tuple(data.channels[j] for j in ssm.outputs)
        rate = data.rate_hz
        # the few stretches an event needs are rebuilt from data.values (_residual_vectors,
        # _direction_violations): over the record only the two estimates per filter
        bank = filter_bank(model.filters)
        zetas, refs, _, bad = self._run_outputs(
            model, data.values, context, directions=False, bank=bank
        )
        train_stop = data.search_start
        events: list[Event] = []
        notes: list[str] = []
        unattributed: list[tuple[float, tuple[str, ...], tuple[str, ...]]] = []
        residuals: dict[str, FloatArray] = {}
        reference: dict[str, FloatArray] = {}
        n = data.n
        m = len(model.filters)
        # per filter (independent: in parallel on threads, which share the arrays): the
        # candidate events of its fault estimate
        # a long archive: each task's reference in sensor units goes to a scratch row,
        # reused by the next task of the same thread
        scratch = ScratchRows(context.workdir if context.map_outputs else None)
        tasks = [
            (model, i, names[i], zetas, refs, rate, self.name, data, scratch) for i in range(m)
        ]
        found = context.map_shared(_filter_events_task, tasks, "filters searched")
        w = model.window
        cands: list[tuple[int, int, Event]] = []  # (first alarm, filter, event)
        for i in range(m):
            found_i, unweighed = found[i]
            notes.extend(unweighed)  # alarms too thin to weigh: no candidates
            for ev in found_i:
                k0 = int(round(float(ev.evidence.get("first_alarm_s", ev.onset_s)) * rate))
                cands.append((k0, i, ev))
        cands.sort(key=lambda c: (c[0], c[1]))
        span = model.zeta_cal[0].long_window
        # what the direction statistics still remember of the stretch before a change
        after = max(cal.long_window for cal in model.direction_cal) + model.settle
        groups: list[tuple[list[tuple[int, int, Event]], int, int]] = []
        over: list[tuple[int, int]] = []  # each group's window over its change (if any)
        while cands:
            # every alarm within a long window of the earliest competes for one fault
            t0 = cands[0][0]
            group = [c for c in cands if c[0] <= t0 + span]
            cands = [c for c in cands if c[0] > t0 + span]
            lo = max(train_stop, min(int(round(c[2].onset_s * rate)) for c in group) - w)
            over.append((lo, min(n, t0 + 2 * span)))
            groups.append((group, *_direction_window(group, *over[-1], after, n, rate)))
        # each filter's largest direction statistic over each group's window, every
        # sample computed once (a fault that lasts has hundreds of alarm groups)
        windows = [(lo, hi) for _, lo, hi in groups]
        moved = [k for k, (_, lo, hi) in enumerate(groups) if (lo, hi) != over[k]]
        violations = self._window_violations(
            model, bank, data.values, bad, windows + [over[k] for k in moved], context
        )
        changed_viol = dict(zip(moved, violations[len(groups) :], strict=True))
        loud = LoadGuard(data.values, data.train, rate, data.healthy)
        last: dict[int, Event] = {}  # each filter's latest reported event
        # each filter's latest alarm that no sensor was named for (several at once)
        unnamed: dict[int, Event] = {}
        began_at: list[tuple[Event, float]] = []  # reported parts that began unnamed
        owners: list[int] = []  # each reported event's filter
        for k, ((group, lo, hi), viol) in enumerate(
            zip(groups, violations[: len(groups)], strict=True)
        ):
            chans = sorted({c[1] for c in group})
            # the sensor whose filter's residual stays closest to its own direction
            j = min(chans, key=lambda c: (viol[c], -_strength(zetas[c], model.zeta_cal[c], lo, hi)))
            others = [viol[o] for o in range(m) if o != j]
            typical, many, confirmed, blurred = _separation(viol, j)
            k0, _, ev = next(c for c in group if c[1] == j)
            k_on = int(round(ev.onset_s * rate))
            f = model.filters[j]
            span_j = max(2, int(np.ceil(1.0 / (1.0 - f.sigma))))
            seg = self._residual_vectors(model, j, data.values, bad, k_on, k_on + span_j, bank)
            ev.evidence.update(
                {
                    "direction": names[j],
                    "off_direction_violation": viol[j],
                    "direction_angle_deg": _mean_angle_deg(seg, model.q_scale[j], j),
                    "other_filters_violation": {names[o]: viol[o] for o in range(m) if o != j},
                    "confirmed": confirmed,
                    "candidates": [names[c] for c in chans],
                }
            )
            when = f"{seconds_text(ev.onset_s)} s"
            if blurred:
                # several sensors at once: a filter's alarm that began inside its own
                # reported fault, of its type, is that fault going on beside another
                went_on = _went_on(group, last, w / rate)
                for c, cand in went_on:
                    ended = last[c].end_s
                    assert ended is not None  # (_went_on: only faults that ended)
                    notes.append(
                        f"the {cand.type.value} fault on {names[c]} from "
                        f"{seconds_text(last[c].onset_s)} s goes on past {seconds_text(ended)} s "
                        "to "
                        + (
                            "the record's end"
                            if cand.end_s is None
                            else f"{seconds_text(cand.end_s)} s"
                        )
                        + f": its filter alarmed again from {seconds_text(cand.onset_s)} s, inside "
                        "it, beside another sensor's fault"
                    )
                    last[c].end_s = cand.end_s
                chans = [c for c in chans if c not in {c for c, _ in went_on}]
                unnamed.update((c, cand) for k_c, c, cand in group if c in chans)
                if not chans:
                    continue
                unattributed.append((ev.onset_s, tuple(names[c] for c in chans), ()))
                how = (
                    "the residual of every filter left its sensor's direction"
                    if viol[j] >= 1.0
                    else f"{names[j]}'s filter stayed within its direction but no closer to "
                    f"it than the others to theirs ({viol[j]:.2f} of its threshold, their "
                    f"typical {typical:.2f}; at most {DIRECTION_SEPARATION:g}x isolates)"
                )
                notes.append(
                    f"anomaly at {when} on {', '.join(names[c] for c in chans)} not attributed: "
                    f"{how} (not one "
                    "sensor: several at once, or a change of the structure or excitation)"
                )
                continue
            if not confirmed:
                notes.append(
                    f"anomaly on {names[j]} at {when} not reported: "
                    + (
                        f"most filters that measure {names[j]} did not see its signal "
                        f"change (their median {typical:.2f} of the threshold"
                        if many
                        else f"no filter that measures {names[j]} saw its signal change "
                        f"(the largest {max(others):.2f} of the threshold"
                    )
                    + ": model mismatch rather than a sensor fault)"
                )
                continue
            before = last.get(j)
            if (
                before is not None
                and before.end_s == ev.onset_s
                and before.type is ev.type
                and (
                    (k in changed_viol and not _isolates(changed_viol[k], j, chans))
                    or _another_ended(events, owners, j, ev.onset_s, span / rate)
                )
            ):
                # the change was another sensor's (its fault's end, say): the fault of
                # this one goes on through it
                before.end_s = ev.end_s
                notes.append(
                    f"the fault on {names[j]} from {seconds_text(before.onset_s)} s goes on past "
                    f"{when}, where its filter's residual changed with another sensor's fault"
                )
                continue
            # In a stretch louder than anything in the healthy window (the other
            # filters' channels' level over 1: analyzer.diagnosis.load) a bank of under 6
            # channels uses DIRECTION_SEPARATION too, for a gain or a shapeless change
            # (LOUD_KINDS: what a louder response passes for). There every filter's
            # residual rises together (the AR model was fitted on a quieter stretch), and
            # one other filter over its threshold confirmed healthy alarms: the simulated
            # 5-floor building with one floor's sensor left out, 2-3 of 10 seeds, the named
            # filter at 0.71-1.02 of the others' median (benchmarks/sweep_missing_floor.py).
            # A sensor's fault leaves its own filter clearly closer to its direction.
            # Outside such stretches a small bank keeps its rule (a slow drift leaves its
            # filter at 0.72-0.94 of the others'). Measured on the other channels only: a
            # gain fault must not excuse itself.
            load = loud(ssm.outputs, ssm.outputs[j], lo, hi)
            if load > 1.0:
                ev.evidence["load_ratio"] = load
                apart = viol[j] <= DIRECTION_SEPARATION * typical
                if not many and ev.type in LOUD_KINDS and not apart:
                    notes.append(
                        f"anomaly on {names[j]} at {when} not reported: the other sensors' "
                        f"signals there were {load:.1f} {LOUD_MARK}, which raises every "
                        "filter's residual, and its filter was "
                        f"no closer to its direction than the others to theirs ({viol[j]:.2f} "
                        f"of its threshold, their typical {typical:.2f}; at most "
                        f"{DIRECTION_SEPARATION:g}x isolates in so loud a stretch)"
                    )
                    continue
            began = _began_unnamed(ev, unnamed.get(j), before)
            if began is not None and before is not None and _resumes(began, before):
                # the unnamed part began where the filter's own fault was lost (another
                # sensor's fault began): that fault went on beside it, not a second one
                before.end_s = ev.end_s
                notes.append(
                    f"the fault on {names[j]} from {seconds_text(before.onset_s)} s goes on past "
                    f"{seconds_text(began.onset_s)} s and {when}: its filter's residual changed "
                    "where another sensor's fault began and ended, no sensor named between"
                )
                continue
            if began is not None:
                notes.append(
                    f"the fault on {names[j]} from {when} began at {seconds_text(began.onset_s)} "
                    "s, where its filter's residual changed and no sensor was named (several "
                    "faults at once)"
                )
                began_at.append((ev, began.onset_s))
            events.append(ev)
            owners.append(j)
            last[j] = ev
            for c in chans:
                if c != j:
                    notes.append(
                        f"alarm on {names[c]} near {when} explained by the fault on {names[j]}: "
                        f"the residual of {names[c]}'s filter left its direction"
                    )
        self._refit_before_others(events, owners, found, model.zeta_cal, tasks, context, n, rate)
        for ev, onset_s in began_at:
            # after the refit, which searches from the part's first alarm (that stays the
            # one that named the sensor)
            ev.onset_s = onset_s
        # kept in the pipeline's signal precision, each float64 array let go before the
        # next is copied (memory-mapped ones are converted channel by channel as the
        # pipeline spills them)
        del tasks, found
        residuals.clear()
        if not context.map_outputs:
            zetas = zetas.astype(SIGNAL_DTYPE)
        residuals.update((names[i], zetas[i]) for i in range(len(names)))
        reference.clear()
        for i in range(len(names)):  # in sensor units, a stretch at a time, in place
            reference[names[i]] = _sensor_units(model, refs, i, out=refs[i])
        del refs
        return DetectorResult(
            detector=self.name,
            channels=names,
            params={
                "order": self.order,
                "fault_pole": self.fault_pole,
                "fault_estimate_pole": model.filters[0].sigma,
                "window": model.window,
                "false_alarm_rate": context.false_alarm_rate,
            },
            events=events,
            residuals=residuals,
            reference=reference,
            sigma={names[i]: model.zeta_cal[i].std for i in range(len(names))},
            thresholds={names[i]: model.zeta_cal[i].as_dict() for i in range(len(names))},
            model={
                **ssm.summary,
                "observable": True,
                "filters": {
                    names[i]: {
                        "spectral_radius": f.spectral_radius,
                        "fault_direction": names[i],
                    }
                    for i, f in enumerate(model.filters)
                },
            },
            notes=notes,
            unattributed=unattributed,
        )


REFITTED = ("onset_s", "type", "magnitude", "confidence")
"""The fields of an event that a shape refitted before another sensor's fault replaces
(with the evidence of the fit: :meth:`DetectionFilter._refit_before_others`)."""

DIRECTION_EVIDENCE = (
    "direction",
    "off_direction_violation",
    "direction_angle_deg",
    "other_filters_violation",
    "confirmed",
    "candidates",
)
"""The evidence a reported event has from the filters' directions (kept when its shape
is refitted)."""


def _direction_window(
    group: Sequence[tuple[int, int, Event]], lo: int, hi: int, after: int, n: int, rate: float
) -> tuple[int, int]:
    """The samples ``lo .. hi - 1`` whose direction statistics name the sensor of an alarm
    group (:meth:`DetectionFilter.run`), moved ``after`` samples past the group's earliest
    change when it holds a fault's part from a change (evidence ``changed_at_s``; the
    same length, within the record's ``n`` samples; ``rate``: samples per second), unless
    the part ends before that.

    Before a change the alarms were already on: the direction statistics over the change
    hold the part before it for a long window, and the filters' residuals settle after
    it. Two faults on s3 (100-200 s) and s0 (150-250 s): every filter but s0's stayed 20
    to 70 times off its direction from 202.5 s, s0's at 0.2-0.6; over 199.75-204 s s0's
    largest was 300 (both faults, before 200 s) and s3's 65 (s0's fault alone), so the
    part of s3's residual from 200 s (s0's fault leaking in, -0.19 for s3's 3.75) was
    reported as a fault of s3, and s0's was lost."""
    # (a part's first alarm is its change)
    parts = [(k0, ev) for k0, _, ev in group if ev.evidence.get("changed_at_s") is not None]
    if not parts:
        return lo, hi
    k0, ev = min(parts, key=lambda p: p[0])
    start = k0 + after
    stop = min(n, start + (hi - lo))
    # a part shorter than the statistics' memory is judged over the change, as before:
    # a window wholly after it would see every filter healthy and drop it (the review)
    ends = n if ev.end_s is None else int(round(ev.end_s * rate))
    return (start, stop) if start < min(stop, ends) else (lo, hi)


def _began_unnamed(ev: Event, part: Event | None, before: Event | None) -> Event | None:
    """``part``, the latest alarm of ``ev``'s filter that no sensor was named for, when
    ``ev``'s fault began with it: ``ev`` is a part from a change (evidence
    ``changed_at_s``) that ``part`` ends at, both of one type, ``part`` a part from a
    change as well, and no reported fault of the filter (``before``) ends there.

    Two faults at once leave every filter off its direction, so a fault that began
    beside another is named only once the other ends. An offset on s3 from 100 to
    200 s and one on s0 from 150 to 250 s (seed 3 of ``sweep_two_faults.py``): s0's
    filter changed at 150.0 s (no sensor named) and at 200.07 s, where s3's fault
    ended; s0's fault was reported from 200.07 s."""
    if (
        part is None
        or part.end_s is None
        or ev.evidence.get("changed_at_s") is None
        or part.evidence.get("changed_at_s") is None
        or part.type is not ev.type
        or part.end_s != ev.onset_s
        or (before is not None and before.end_s == ev.onset_s)
    ):
        return None
    return part


def _resumes(part: Event, before: Event) -> bool:
    """Whether ``part``, a filter's alarm that no sensor was named for and that a later
    part of its fault began with (:func:`_began_unnamed`), began where the filter's
    latest reported fault (``before``), of its type, was lost: that fault went on
    through it, beside another sensor's, and what follows is still that fault.

    An offset on s2 from 100 to 250 s and one on s5 from 150 to 200 s (seed 26 of
    ``sweep_two_faults.py``, ``nested``): s2's filter reported the offset to 150.04 s,
    where s5's began, alarmed on from there with no sensor named, and named s2 again
    from 200.05 s, where s5's ended; that part taken back to 150.04 s was a second
    finding on s2, 150.0-250.0 s, inside the first (100.0-250.0 s)."""
    return before.end_s is not None and before.type is part.type and before.end_s == part.onset_s


def _went_on(
    group: Sequence[tuple[int, int, Event]], last: Mapping[int, Event], margin_s: float
) -> list[tuple[int, Event]]:
    """The alarms of ``group`` (first alarm, filter, event) that continue their filter's
    latest reported fault (``last``, by filter): of its type, beginning more than
    ``margin_s`` (a short alarm window) before it ended and ending after it, each with
    its filter.

    Where the direction statistics name no one sensor (every filter off its direction:
    several faults at once), a filter that alarms again inside the fault it reported
    sees that fault go on beside the other. A drift on s0 from 100 to 200 s and an
    offset on s3 from 150 to 250 s (seed 6 of ``sweep_two_faults.py``): s0's filter
    ended the drift at 150.08 s, where s3's offset began, and alarmed again on a drift
    from 143.7 to 200.0 s that no sensor was named for; the drift was reported to
    150.1 s, and s3's fault split at 200.1 s, where s0's ended."""
    went_on: list[tuple[int, Event]] = []
    for _, c, cand in group:
        before = last.get(c)
        if (
            before is not None
            and before.end_s is not None
            and cand.type is before.type
            and cand.onset_s < before.end_s - margin_s
            and (cand.end_s is None or cand.end_s > before.end_s)
        ):
            went_on.append((c, cand))
    return went_on


def _another_ended(
    events: Sequence[Event], owners: Sequence[int], j: int, t: float, within_s: float
) -> bool:
    """Whether a reported event of a filter other than ``j`` (``owners``: each event's
    filter) ended within ``within_s`` (a long alarm window) of ``t``, where filter ``j``'s
    residual changed: that sensor's fault ended there, and the change in ``j``'s
    residual is its fault's trace leaving it, not a change of ``j``'s fault.

    After the other fault's end only ``j``'s fault is left, so the direction statistics
    from after the change name ``j`` (:func:`_isolates`) whether or not its fault changed.
    Two offsets, s0 from 100 to 200 s and s3 from 150 to 250 s: s3's filter changed at
    200.12 s, s0's fault ending at 200.0 s; s3's part after it isolated s3 (0.53 of its
    threshold, the others 286-349) and s3's fault was reported as two, 150-200.1 s and
    200.1-250 s (on the next floor, s1's second part was then taken for s0's fault, which
    the bank saw to 225.8 s)."""
    return any(
        o != j and e.end_s is not None and abs(e.end_s - t) <= within_s
        for e, o in zip(events, owners, strict=True)
    )


def _isolates(viol: Sequence[float], j: int, chans: Sequence[int]) -> bool:
    """Whether filter ``j`` is the one of the alarmed filters ``chans`` closest to its
    direction by the statistics ``viol`` (each filter's largest over a window) and
    clearly closer than the typical other (:data:`DIRECTION_RELATIVE`,
    :data:`DIRECTION_SEPARATION`), with other filters off theirs: the sensor
    :meth:`DetectionFilter.run` names for the alarms."""
    if min(chans, key=lambda c: viol[c]) != j:
        return False
    _, _, confirmed, blurred = _separation(viol, j)
    return confirmed and not blurred


def _separation(viol: Sequence[float], j: int) -> tuple[float, bool, bool, bool]:
    """``(typical, many, confirmed, blurred)`` of filter ``j`` among all, by their
    direction statistics ``viol``: the other filters' median; whether they are
    :data:`SEPARATION_OTHERS` or more; confirmed: some other filter left its direction,
    with that many of them most (a sensor's fault moves every other filter's residual off
    its direction; one of fifteen over its threshold is what chance and a model's
    mismatch give); blurred: ``j``'s own filter is not clearly closer to its direction
    than the typical other (:data:`DIRECTION_RELATIVE`, :data:`DIRECTION_SEPARATION`):
    no one sensor."""
    others = [viol[o] for o in range(len(viol)) if o != j]
    typical = float(np.median(others)) if others else 0.0
    many = len(others) >= SEPARATION_OTHERS
    confirmed = bool(others) and (typical if many else max(others)) >= 1.0
    blurred = (viol[j] >= 1.0 and viol[j] > DIRECTION_RELATIVE * typical) or (
        many and confirmed and viol[j] > DIRECTION_SEPARATION * typical
    )
    return typical, many, confirmed, blurred


def long_run_time(r: Series, window: int) -> float:
    """Effective correlation time (samples) of a healthy residual for the classifier's
    effective sample size: the larger of the integrated autocorrelation time
    (:func:`correlation_time`) and the long-run variance ratio ``B var(block mean) / var``
    at block lengths ``B = window, 2 window, ...`` up to an eighth of the record. A residual
    that wanders slowly (more power near zero frequency than its short-lag autocorrelation
    shows) would otherwise make a constant fault look like a slow drift.

    ``r``: one array, or arrays read one after the other as one series (NaNs ignored);
    two passes a block at a time (:mod:`analyzer.diagnosis.streamed`), the same numbers
    as the whole-series formulas to rounding."""
    first = series_moments(r)
    n = first.n
    sizes = []
    b = max(1, int(window))
    while 8 * b <= n:
        sizes.append(b)
        b *= 2
    lags = LaggedSums(CORRELATION_LAGS) if n >= 8 else None
    means = [BlockMeans(b) for b in sizes]
    if lags is not None or means:
        for x in finite_blocks(r):
            if lags is not None:
                lags.add(x - first.mean)
            for each in means:
                each.add(x)
    tau = 1.0 if lags is None else integrated_time(lags.values())
    v = first.var()
    if not v > 0.0:
        return tau
    for each in means:
        tau = max(tau, float(each.b * each.moments.var(ddof=1) / v))
    return tau


def _sensor_units(
    model: FittedDetectionFilter,
    refs: npt.NDArray[Any],
    i: int,
    out: npt.NDArray[Any] | None = None,
) -> npt.NDArray[Any]:
    """Filter ``i``'s fault-free estimate in sensor units (:func:`_sensor_unit_pieces`)
    into ``out`` (the row itself, say, or a memory-mapped float64 array: written by
    ``pwrite``, :func:`~analyzer.paging.write_rows`), else a new float64 array."""
    target = np.empty(refs[i].shape[0]) if out is None else out
    for a, part in _sensor_unit_pieces(model, refs, i):
        write_rows(target, a, part)  # a mapped row's file by pwrite, not its mapping
    return target


def _sensor_unit_pieces(
    model: FittedDetectionFilter, refs: npt.NDArray[Any], i: int
) -> Iterator[tuple[int, FloatArray]]:
    """Filter ``i``'s fault-free estimate in sensor units from its centred, scaled
    single-precision row, in float64 :data:`RELEASE_ROWS` samples at a time (``(first
    sample, piece)``; a memory-mapped source row is given back behind)."""
    ssm = model.model
    row = refs[i]
    n = row.shape[0]
    scale, mean = float(ssm.y_scale[i]), float(ssm.y_mean[i])
    for a in range(0, n, RELEASE_ROWS):
        b = min(n, a + RELEASE_ROWS)
        part = row[a:b].astype(np.float64)
        part *= scale
        part += mean
        yield a, part
        release(row[a:b])  # no-op in memory


def _filter_events_task(task: tuple[Any, ...]) -> tuple[list[Event], list[str]]:
    """Filter ``i``: the candidate events of its fault estimate ``zetas[i]`` (each shape
    fitted up to the first of ``until``, other sensors' onsets, where given:
    :func:`~analyzer.diagnosis.events.events_from_residual`), and the note on its alarms
    too thin to weigh (:func:`~analyzer.diagnosis.events.unweighed_note`)."""
    model, i, name, zetas, refs, rate, detector, data, scratch, *rest = task
    until: Sequence[int] = rest[0] if rest else ()
    n = refs[i].shape[0]
    notes: list[str] = []
    with scratch.row(f"units{i}", n) as into:
        # float64, low-passed as each piece comes: a long archive's row is written once
        smooth = LowpassPieces(model.filters[i].sigma, np.empty(n) if into is None else into)
        for a, part in _sensor_unit_pieces(model, refs, i):
            smooth.push(a, part)
        found = events_from_residual(
            name,
            zetas[i],
            smooth.finish(),
            model.zeta_cal[i],
            rate,
            detector,
            search_start=data.search_start,
            healthy_start=data.healthy_start,
            healthy_stop=data.train[1],
            before_onset=not data.healthy,
            tau_corr=model.tau[i],
            scratch=scratch.workdir,
            split=True,
            notes=notes,
            until=until,
        )
    release(zetas[i])  # memory-mapped rows: read again only where an event is
    release(refs[i])
    return found, notes


def _violations_task(task: tuple[Any, ...]) -> list[list[float]]:
    """Each filter's direction statistics over one stretch ``p .. q - 1``
    (:meth:`DetectionFilter._direction_statistics`), reduced to their maxima over each
    of ``cuts`` (offsets into the stretch)."""
    model, bank, values, bad, p, q, cuts = task
    stats = DetectionFilter._direction_statistics(model, bank, values, bad, p, q)
    return [[float(np.max(st[a:b], initial=0.0)) for st in stats] for a, b in cuts]


def _park_task(task: tuple[Any, ...]) -> ParkFilter:
    """The Park filter of output ``i`` of ``model`` (what an executor maps)."""
    model, i, alpha, sigma, names, eig = task
    return park_filter(
        model.A,
        model.B,
        model.C,
        model.D,
        i,
        model.Q,
        model.R,
        model.S,
        alpha=alpha,
        sigma=sigma,
        names=names,
        check_observability=False,
        eigenvalues=eig,
    )


def _held_out_half_task(task: tuple[Any, ...]) -> _Segment:
    """:meth:`DetectionFilter._held_out_half` on one tuple (what an executor maps)."""
    det, *args = task
    out: _Segment = det._held_out_half(*args)
    return out


@dataclass(frozen=True, slots=True)
class _Segment:
    """A healthy stretch the thresholds are calibrated on: the rows ``start ..`` of
    ``values`` under the bank ``filters`` of ``model`` (the rows before ``start`` are the
    history the filters remember)."""

    model: StateSpaceModel
    filters: tuple[ParkFilter, ...]
    values: FloatArray
    start: int


def _segment_chunks(seg: _Segment) -> Iterator[tuple[int, FloatArray, FloatArray]]:
    """The bank's residual vectors ``q`` (k, n, m) and fault estimates ``zeta`` (k, n),
    in sensor units, over the rows ``seg.start ..`` of ``seg.values``, chunk by chunk
    (``(first row - start, q, zeta)``): what :meth:`DetectionFilter._outputs` gives for
    those rows, NaN where an input was missing and while each filter settles after it,
    with only a chunk of outputs held at once. Filter ``i`` is the bank's row
    ``filters[i].sensor``, as in ``_outputs``."""
    model, filters, values, start = seg.model, seg.filters, seg.values, seg.start
    stop = values.shape[0]
    bank = filter_bank(filters)
    settles = [f.settle() for f in filters]
    # a gap before ``first`` masks nothing from ``start`` on; a lifted bank remembers
    # everything and runs from the first row
    first = 0 if bank.history is None else max(0, start - max(bank.history, *settles))
    cols = list(model.outputs) + list(model.inputs)
    bad = ~finite_rows(values[first:stop], cols, CALIBRATION_ROWS)  # no copy of the rows
    masks = [dilate_forward(bad, s)[start - first :] for s in settles] if bad.any() else None
    m = filters[0].n_outputs
    rows = np.array([f.sensor for f in filters])
    scale = model.y_scale

    def inputs(a: int, b: int) -> FloatArray:
        v, _ = DetectionFilter._inputs(model, np.asarray(values[a:b]))
        release(values[a:b])
        return v

    for lo, y in run_chunked(bank, inputs, stop, start):
        at = lo - start
        q = y[rows, :m].transpose(0, 2, 1) * scale
        zeta = y[rows, m] * scale[rows, None]
        if masks is not None:
            for i, mask in enumerate(masks):
                hit = mask[at : at + y.shape[2]]
                q[i, hit] = np.nan
                zeta[i, hit] = np.nan
        yield at, q, zeta


def _series_out(seg: _Segment, into: npt.NDArray[Any] | None) -> npt.NDArray[Any]:
    """``into``, or a new ``(n, k)`` array (column ``i`` contiguous: filter ``i``'s
    series) for a stretch's ``n`` rows and ``k`` filters."""
    if into is not None:
        return into
    return np.empty((len(seg.filters), seg.values.shape[0] - seg.start)).T


def _moments_task(
    task: tuple[_Segment, npt.NDArray[Any] | None, bool],
) -> tuple[npt.NDArray[Any], list[RowMoments], FloatArray | None]:
    """Per filter over a calibration stretch: its fault estimates (column ``i`` of the
    ``(n, k)`` array returned: ``into`` when given, a :func:`~analyzer.paging.buffer`
    written by :func:`~analyzer.paging.write_rows`, so a memory-mapped one's pages are
    not held), the moments of its residual vectors over the rows where none is missing,
    and, when ``keep``, its residual vectors without its own direction (``(k, n, m -
    1)``, NaN rows as they came: what :func:`_nis_task` would run the bank again for;
    else None). What an executor maps."""
    seg, into, keep = task
    zetas = _series_out(seg, into)
    k, m = len(seg.filters), seg.filters[0].n_outputs
    moments = [RowMoments(m) for _ in range(k)]
    offs = np.empty((k, seg.values.shape[0] - seg.start, m - 1)) if keep else None
    for at, q, zeta in _segment_chunks(seg):
        write_rows(zetas, at, zeta.T)
        for i in range(k):
            good = np.isfinite(q[i]).all(axis=1)
            moments[i].add(q[i] if good.all() else q[i][good])
            if offs is not None:  # np.delete(q[i], i, axis=1), without its copy
                offs[i, at : at + q.shape[1], :i] = q[i, :, :i]
                offs[i, at : at + q.shape[1], i:] = q[i, :, i + 1 :]
    return zetas, moments, offs


def _nis_task(
    task: tuple[_Segment, tuple[FloatArray, ...], npt.NDArray[Any] | None, FloatArray | None],
) -> npt.NDArray[Any]:
    """Per filter over a calibration stretch: the normalized squared residual vector
    off its own direction, under the inverse covariances ``inv_covs`` (the covariances
    needed the whole window first), as column ``i`` of the ``(n, k)`` array returned
    (``into`` when given, as in :func:`_moments_task`). From the vectors ``offs`` pass 1
    kept, or (None: too many to keep) a second run of the bank, chunk by chunk."""
    seg, inv_covs, into, offs = task
    out = _series_out(seg, into)
    if offs is not None:
        nis = np.empty((offs.shape[1], len(inv_covs)))
        for i, inv in enumerate(inv_covs):
            nis[:, i] = _nis(offs[i], inv)
        write_rows(out, 0, nis)
        return out
    for at, q, _ in _segment_chunks(seg):
        nis = np.empty((q.shape[1], len(inv_covs)))
        for i, inv in enumerate(inv_covs):
            nis[:, i] = _nis(np.delete(q[i], i, axis=1), inv)
        write_rows(out, at, nis)
    return out


def _df_span(task: tuple[Any, ...]) -> tuple[FloatArray, FloatArray, FloatArray | None, Any]:
    """Outputs of the detection-filter bank over samples ``a .. b - 1`` (see
    :meth:`DetectionFilter._run_outputs`): written into ``outs`` (columns
    ``a .. b - 1``) when given, else returned as arrays of ``b - a`` columns; the direction
    statistic only with ``directions`` (and a bank with every output). ``values`` holds
    the archive's rows from ``base`` on."""
    model, bank, values, base, a, b, outs, directions, *more = task
    advanced = more[0] if more else None  # (rows done: Advance)
    ssm = model.model
    k = len(model.filters)
    m = model.filters[0].n_outputs
    at = a if outs is None else 0  # column of sample lo is lo - at
    if outs is None:
        outs = (
            np.empty((k, b - a)),
            np.empty((k, b - a), np.float32),
            np.empty((k, b - a), np.float32) if directions else None,
            np.zeros(b - a, dtype=bool),
        )
    zeta, ref, nis, bad = outs
    scale = ssm.y_scale[:, None]

    def inputs(lo: int, hi: int) -> FloatArray:
        rows = values[lo - base : hi - base]
        v, bad_v = DetectionFilter._inputs(ssm, np.asarray(rows))
        release(rows)  # a memory-mapped archive: read once per chunk, not kept resident
        first = max(lo, a)  # the history before the span belongs to another span
        bad[first - at : hi - at] = bad_v[first - lo :]
        return v

    written = Released(zeta, ref, axis=1, start=a - at)  # memory-mapped: given back behind
    for lo, y in run_chunked(bank, inputs, b, a):
        cols = slice(lo - at, lo - at + y.shape[2])
        # the two estimates are each filter's last outputs (all it has in a selected bank)
        # a long archive's buffers are written by pwrite, not through their maps
        write_rows(zeta.T, cols.start, (y[:, -2] * scale).T)
        write_rows(ref.T, cols.start, y[:, -1].T)  # centred, scaled: see _run_outputs
        written.upto(cols.stop, final=lo + y.shape[2] == b)
        if advanced is not None:
            advanced(cols.stop - cols.start)
        if nis is None:
            continue
        for i in range(k):
            off = np.delete(y[i, :m] * scale, i, axis=0)
            nis[i, cols] = _nis(off.T, model.direction_inv_cov[i])
    return outs


def _strength(z: FloatArray, cal: Calibration, a: int, b: int) -> float:
    """Mean |standardized residual| over ``[a, b)``."""
    seg = cal.standardize(z[a:b])
    return float(np.nanmean(np.abs(seg))) if b > a and np.isfinite(seg).any() else 0.0


def _nis(r: FloatArray, inv_cov: FloatArray) -> FloatArray:
    """Normalized squared residual per sample, ``r' S^-1 r / dim``."""
    if r.shape[1] == 0:
        return np.zeros(r.shape[0])
    return np.einsum("ki,ki->k", r @ inv_cov, r) / r.shape[1]


def _mean_angle_deg(q: FloatArray, scale: FloatArray, i: int) -> float | None:
    """Angle (degrees) between the mean whitened residual over ``q`` and ``e_i``."""
    good = np.isfinite(q).all(axis=1)
    if not good.any():
        return None
    mean = np.mean(q[good] / scale, axis=0)
    ang = direction_angles(mean[None, :])[0, i]
    return None if not np.isfinite(ang) else float(np.degrees(ang))


__all__ = [
    "DetectionFilter",
    "FittedDetectionFilter",
    "ParkFilter",  # (its home is beard_jones; here too for models saved before the move)
    "StateSpaceModel",  # (state_space; likewise)
    "direction_angles",
    "long_run_time",
]


def _percent(share: float) -> str:
    """A share of samples, in percent, for a message: whole percents from 1 % up, one
    decimal below (a channel with a gap every 250 samples was "s4 0 %", named as the
    channel with most gaps beside "0"), and "under 0.1 %" below that, never "0 %" for a
    channel that has gaps."""
    if share >= 1:
        return f"{share:.0f} %"
    return f"{share:.1f} %" if share >= 0.05 else "under 0.1 %"


def _settling_error(err: DetectorError, settle: int, data: Dataset) -> DetectorError:
    """``err`` (too few healthy samples) saying why where gaps are the reason: a filter's
    output is left out while it settles after each gap of its inputs, so a training
    window cut by gaps into stretches shorter than that gives it nothing to calibrate
    on, however many complete rows it holds."""
    train = np.asarray(data.train_values(), dtype=np.float64)
    complete = np.isfinite(train).all(axis=1)
    if complete.all():
        return err
    # the longest stretch of complete rows
    edges = np.flatnonzero(np.diff(np.concatenate(([0], complete.astype(np.int8), [0]))))
    longest = int(np.max(edges[1::2] - edges[::2])) if edges.size else 0
    if longest > 2 * settle:
        return err
    missing = (~np.isfinite(train)).mean(axis=0)
    worst = [
        f"{data.channels[j]} {_percent(100 * float(missing[j]))}"
        for j in np.argsort(-missing, kind="stable")[:3]
        if missing[j] > 0
    ]
    return DetectorError(
        f"{err} (the training window's longest stretch without a gap is {longest} samples, "
        f"and a filter's output is left out for up to {settle} samples, "
        f"{spoken_duration(settle / data.rate_hz)}, while it settles after a gap: a --train with "
        f"fewer gaps, or leave out the channels with most gaps there: {', '.join(worst)})"
    )
