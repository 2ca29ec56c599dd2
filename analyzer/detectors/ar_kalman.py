"""AR model -> bank of steady-state Kalman estimators (Chang et al. 2017).

1. An AR model is fitted on the healthy window (Eq. 1-5) and put in companion form
   (Eq. 7-8).
2. Estimator ``j`` of the bank measures every sensor but ``j`` (Eq. 10, Table 1): its
   steady-state gain comes from the discrete algebraic Riccati equation with the AR
   residual covariance as process and measurement noise (which also stabilizes unstable
   AR poles, Section 2.3). It yields the innovations of the sensors it measures and the
   filtered estimate of sensor ``j`` from the others.
3. A fault on sensor ``j`` leaves estimator ``j`` consistent (it never sees ``j``) while
   every other estimator, fed the faulty signal, degrades; the residual of ``j`` against
   its estimate from the others carries the fault's shape (pulse then offset, oscillation,
   slope: Section 2.3), which the shared classifier reads.
4. Faults that follow one another (the paper's re-occurring faults, Section 4) are found
   one at a time: once a fault is isolated, its channel is replaced by its estimate from
   the other sensors over the fault period and the bank is run again.

Residual convention: ``measured - estimated`` (the paper plots ``estimated - measured``).
"""

from __future__ import annotations

import numbers
import re
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from analyzer.detectors.ar_model import ARModel, error_ratio, fit_ar, select_order
from analyzer.detectors.base import (
    SIGNAL_DTYPE,
    Advance,
    Dataset,
    DetectorResult,
    Event,
    RunContext,
    map_in,
)
from analyzer.detectors.kalman_bank import (
    NIS_DTYPE,
    BankBlock,
    BankFilter,
    BankOutputs,
    InnovationMoments,
    LeaveOneOut,
    bank_block,
    estimator_consistency,
    leave_one_out,
    solved_leave_one_out_task,
)
from analyzer.detectors.lti import (
    ImpulseResponseBank,
    time_blocks,
    warm_spans,
)
from analyzer.diagnosis.changes import (
    Calibration,
    Interval,
    alarm_statistic,
    calibrate,
    default_window,
    detect,
    detection_confidence,
    needing_calibration,
)
from analyzer.diagnosis.classify import (
    MIN_GAIN,
    Classification,
    ReferenceSlope,
    correlation_time,
    reference_slope,
)
from analyzer.diagnosis.events import bounded_onset, diagnose_interval, slope_before
from analyzer.diagnosis.load import LoadGuard
from analyzer.diagnosis.spread import event_intervals
from analyzer.errors import DetectorError, TooLittleDataError
from analyzer.paging import (
    RELEASE_ROWS,
    read_column,
    release,
    write_rows,
)
from analyzer.timeutil import seconds_text
from analyzer.types import FaultType

FloatArray = npt.NDArray[np.float64]

RELATIVE_CONSISTENCY = 0.25
"""A leave-out estimator over its threshold still isolates its sensor when it is at most
this fraction as inconsistent as the typical other estimator: a change that inflates
every estimator alike (a burst of excitation) must not mask a sensor fault."""

MAX_CHANNELS = 64
"""A bank of m estimators with p m states each costs O(m^3 p^2) per sample: beyond this,
the user should choose the sensors to analyze."""
MAX_STATES = 640
"""Most states (AR order times channels) an estimator of the bank may have: the largest
the defaults give (64 channels at the criteria's highest order, 10). Each estimator's
Riccati solution costs the cube of it: 4 channels of 10 minutes fitted and ran in 7 s at
order 10 (40 states), 11 s at 80, 69 s at 160 (640 states); an order of 500 (2000
states) ran for 13 minutes without a word before this limit. A set ``order`` beyond it
makes the bank not applicable; ``"aic"``/``"bic"`` search up to the order it allows
(``max_order`` or less)."""


AUTO_BLOCK = {2: 64, 6: 32}
"""Lifted block length by channel count (largest key not above m; smaller blocks
for larger states: measured by benchmarks/bench_bank.py --sweep)."""


CV_FOLDS = 5
"""Folds of the cross-validation that gives out-of-sample training residuals."""

KEPT_INNOVATIONS_BYTES = 160 << 20
"""Memory the cross-validation may hold in its folds' innovations between its two
passes (115 MB for 16 channels and a 10-minute window at 100 Hz); beyond it, pass 2
filters each fold again (~0.1 s of CPU per fold at 16 channels)."""

CONSISTENCY_PIECE = 1 << 17
"""Rows of consistency recomputed at once around a fault (each piece after its own
warm-up): bounds the memory of a window that spans a long fault."""

SPREAD_SIGMAS = 3.0
"""A gain that no estimator confirmed is refused when the other sensors' residuals move
against its spread (:meth:`ARKalmanBank._spread`: ratio below zero) by more than this
many standard errors: a sensor's fault shows there with ratio 1. Gains only: a gain's
correction follows the sensor's own reading, so the ratio's error is what the residuals'
correlation time says; an offset's or a drift's is a slow step or ramp, against which a
real record's residuals wander in ways that time does not capture (an injected drift on
SKAB's pump, taken for an offset, came out at -24.6 +- 1.3)."""

UNCONFIRMED_FACTOR = 0.75
"""Confidence factor for a fault seen on its sensor's residual while no estimator that
uses the sensor became inconsistent (a small fault: located, but not confirmed)."""


def _is_integer(value: Any) -> bool:
    """An integer setting (a boolean is not one, nor is a float with no fraction)."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool | np.bool_)


ESTIMATOR_INDEX = re.compile(r"without channel (\d+)")
"""How the bank's leave-one-out estimators name their left-out channel where the
channels' names are not known (:mod:`analyzer.detectors.kalman_bank`)."""


def _named(err: DetectorError, channels: Sequence[str]) -> DetectorError:
    """``err`` with each ``without channel j`` its channel's name: the skip reason read
    ``the Kalman estimator without channel 0 is unstable``, an index where the user
    knows names. Other errors (too little data, say) are returned as they are."""
    text = str(err)
    if type(err) is not DetectorError or not ESTIMATOR_INDEX.search(text):
        return err
    return DetectorError(
        ESTIMATOR_INDEX.sub(
            lambda m: (
                f"without {channels[int(m.group(1))]}"
                if int(m.group(1)) < len(channels)
                else m.group(0)
            ),
            text,
        )
    )


@dataclass(frozen=True, slots=True)
class FittedBank:
    ar: ARModel
    estimators: tuple[LeaveOneOut, ...]
    window: int
    residual_cal: tuple[Calibration, ...]
    consistency_cal: tuple[Calibration, ...]
    innovation_inv_cov: tuple[FloatArray, ...]
    tau: tuple[float, ...]
    calibration: str = "in-sample"
    bank: BankFilter | None = None


ORDER_NOTE = (
    "the AR order {order} set in the config is below the {best} BIC selects on the training "
    "window, where its one-step prediction error is {ratio:.2g}x as large: the estimators "
    "leave dynamics in their residuals, which can hide a fault (leave the order out, or set "
    'order = "bic")'
)
"""The bank's note on a fixed order well below BIC's (:meth:`ARKalmanBank._order_note`);
the run repeats it on stderr (:func:`analyzer.pipeline.config_warnings`)."""
ORDER_ERROR_RATIO = 1.25
"""A fixed order's one-step prediction error variance over that of BIC's order (the
geometric mean over the channels) from which the note is given: on the bundled gain
sample order 3 gives 1.62 and missed a gain of 1.5 that BIC's 10 finds; the contract's
example order 7 gives 1.13 and finds it."""


class ARKalmanBank:
    """``ar_kalman_bank``: the detector of Chang et al. (2017).

    Settings: ``order`` (int, or ``"aic"`` / ``"bic"``), ``max_order`` for the criteria."""

    name: ClassVar[str] = "ar_kalman_bank"

    def __init__(
        self, order: int | str = "bic", max_order: int = 10, block: int | None = None
    ) -> None:
        where = "[detectors.ar_kalman_bank]"
        if isinstance(order, str):
            if order not in ("aic", "bic"):
                raise DetectorError(
                    f"{where} order: expected an integer, 'aic' or 'bic', got {order!r}"
                )
        elif not _is_integer(order):  # 7.5 was truncated by the fit, true read as 1
            raise DetectorError(
                f"{where} order: expected an integer, 'aic' or 'bic', got {order!r}"
            )
        elif order < 1:
            raise DetectorError(f"{where} order must be >= 1, got {order}")
        if not _is_integer(max_order) or max_order < 1:
            # (0 gave "too little healthy data for any AR model")
            raise DetectorError(f"{where} max_order: expected an integer >= 1, got {max_order!r}")
        if block is not None and (not _is_integer(block) or block < 1):
            raise DetectorError(f"{where} block: expected an integer >= 1, got {block!r}")
        self.order: int | str = order if isinstance(order, str) else int(order)
        self.max_order = int(max_order)
        self.block = None if block is None else int(block)

    def applicable(self, data: Dataset, context: RunContext) -> str | None:
        if len(data.channels) < 2:
            return "needs at least 2 channels (each estimator of the bank leaves one out)"
        if len(data.channels) > MAX_CHANNELS:
            return (
                f"{len(data.channels)} channels are too many for one bank (at most "
                f"{MAX_CHANNELS}): select the sensors with --channels"
            )
        # (a criterion searches orders up to what the limit allows: fit())
        if isinstance(self.order, int) and self.order * len(data.channels) > MAX_STATES:
            return (
                f"order {self.order} with {len(data.channels)} channels makes estimators of "
                f"{self.order * len(data.channels)} states (at most {MAX_STATES}: the fit's "
                f"cost grows with their cube); set a lower [detectors.{self.name}] order"
            )
        return None

    # -- fitting ---------------------------------------------------------------------------
    def fit(self, data: Dataset, context: RunContext) -> FittedBank:
        reason = self.applicable(data, context)
        if reason:
            raise DetectorError(f"ar_kalman_bank {reason}")
        train = np.asarray(data.train_values(), dtype=np.float64)
        # a criterion's search stops at the order the state limit allows
        highest = self._highest_order(len(data.channels))
        window = default_window(data.rate_hz)
        try:
            order = (
                select_order(train, self.order, highest)
                if isinstance(self.order, str)
                else self.order
            )
            ar = fit_ar(train, order, data.channels)
        except TooLittleDataError as err:  # (the thresholds' calibration needs more)
            raise needing_calibration(err, window) from None
        block = self._block(ar.m)
        try:
            solved = context.map(
                solved_leave_one_out_task,
                [(ar, j, block) for j in range(ar.m)],
                "estimators solved",
            )
            estimators = tuple(e for e, _ in solved)
            resid, cons, skip, how, inv_covs = self._calibration_outputs(
                ar, estimators, train, context, tuple(P for _, P in solved)
            )
        except DetectorError as err:
            named = _named(err, data.channels)
            if named is err:
                raise
            raise named from err
        res_cal, con_cal, taus = [], [], []
        # the false-alarm rate is per sample of the archive: shared among its channels
        alpha = context.false_alarm_rate / ar.m
        for j in range(ar.m):
            r = resid[skip:, j]
            res_cal.append(calibrate(r, window, alpha))
            con_cal.append(calibrate(cons[skip:, j], window, alpha))
            taus.append(correlation_time(r))
        return FittedBank(
            ar,
            estimators,
            window,
            tuple(res_cal),
            tuple(con_cal),
            tuple(inv_covs),
            tuple(taus),
            how,
            BankFilter.build(estimators, block, inv_covs),
        )

    def _block(self, m: int) -> int:
        if self.block is not None:
            return self.block
        return next((AUTO_BLOCK[k] for k in sorted(AUTO_BLOCK, reverse=True) if m >= k), 64)

    def _calibration_outputs(
        self,
        ar: ARModel,
        estimators: tuple[LeaveOneOut, ...],
        train: FloatArray,
        context: RunContext | None = None,
        solutions: tuple[FloatArray, ...] | None = None,
    ) -> tuple[FloatArray, FloatArray, int, str, list[FloatArray]]:
        """Residuals and consistency of the training window *out of sample*, the skipped
        cold start, how they were obtained, and each estimator's inverse innovation
        covariance.

        A model judged on the data it was fitted to looks better than it is: in-sample
        residuals of an AR model with ``p m`` coefficients per channel understate its
        residuals on new data, and thresholds set from them raise false alarms. So the
        training window is cut into ``CV_FOLDS`` blocks; each block's residuals come from a
        model fitted without it (K-fold cross-validation), filtered from a warm-up before
        the block. Where the window is too short for that, in-sample residuals are used and
        the model summary says so. ``solutions``: the estimators' DARE solutions, where
        the folds' Riccati equations start from (:func:`solved_leave_one_out`)."""
        n = train.shape[0]
        skip = min(max(e.settle for e in estimators), n // 4)
        block = estimators[0].block
        k = CV_FOLDS
        edges = np.linspace(0, n, k + 1).astype(int)
        # the calibration series over the window (memory-mapped for a long archive: a
        # long training window's are not held, calibrate reads them a block at a time);
        # in this process each fold writes its rows in place (no second copy of them)
        # (the folds cover the window: every row of resid and cons is written)
        shared = context is None or context.shares_memory

        def series(name: str) -> npt.NDArray[Any]:
            if context is None:
                return np.empty((n, ar.m))
            return context.buffer(f"{self.name}-{name}", (n, ar.m))

        resid = series("cal-resid")
        into = resid if shared else None
        # on a cluster the window is sent to each worker once, not with every fold's task
        held = train if context is None else context.scatter(train)
        try:
            # the folds are independent: each is fitted and filtered (pass 1) as one task
            spans = [(int(edges[f]), int(edges[f + 1])) for f in range(k)]
            # each fold's estimators take the whole model's settle and warm-up times
            times = tuple((e.settle, e.warmup) for e in estimators)
            tasks = [(held, a, b, ar.order, block, skip, times, solutions, into) for a, b in spans]
            folds = map_in(context, _cv_fold_task, tasks, "calibration folds")
            how = f"{k}-fold out-of-sample"
        except DetectorError:
            item = (train, 0, n, None, block, skip, None, None, into)
            folds = [_cv_fold_task(item, ar, estimators)]
            how = "in-sample (training window too short for cross-validation)"
        # pass 1 (in the fold tasks): residuals and the innovation moments of every
        # estimator after the cold start; pass 2: the consistency, normalized by the
        # covariance from all folds' moments
        moments = InnovationMoments(ar.m)
        for f, fold in enumerate(folds):
            if fold.resid is not None:  # from another process
                write_rows(resid, fold.a, fold.resid)
                # pass 2 needs the folds' models, not their residuals: not held twice
                folds[f] = replace(fold, resid=None)
            moments.merge(fold.moments)
            del fold
        inv_covs = moments.inverse_covariances()
        cons = series("cal-cons")
        into = cons if shared else None
        items = [(held, fold, inv_covs, into) for fold in folds]
        checked = map_in(context, _cv_consistency_task, items, "consistency folds")
        for fold, nis in zip(folds, checked, strict=True):
            if nis is not None:
                write_rows(cons, fold.a, nis)
        return resid, cons, skip, how, inv_covs

    def _bank_outputs(
        self,
        model: FittedBank,
        Y: FloatArray,
        context: RunContext | None = None,
        start: int = 0,
        stop: int | None = None,
        into: BankOutputs | None = None,
        consistency: bool = True,
        shown: str | None = None,
    ) -> BankOutputs:
        """Run the bank over ``Y[start:stop]`` (raw units), into ``into`` when given;
        without ``consistency`` only the residuals and estimates (``nis`` None: the
        estimate outputs alone, a fraction ``1/m`` of the bank's work).

        Serially the span is one pass with the state carried from chunk to chunk (from a
        zero state at the record's start, or after a warm-up when ``start > 0``). With a
        parallel executor in ``context`` the span is cut into time blocks, each filtered
        from a warm-up of ``BankFilter.warmup`` samples before it, so the blocks are
        independent and equal the serial run to rounding. ``shown``: the progress stage
        each finished block advances (the whole record's pass: on a day's archive the
        longest step of a run, which left its progress silent for most of a minute).
        Short of 100 %: the pass's end is the detector's, which ``detect`` says (a
        terminal's bar ends a line at 100 %, one per stage of the run)."""
        bank = model.bank
        if bank is None:  # pragma: no cover - fitted by fit()
            raise DetectorError("ar_kalman_bank: the model has no estimator bank")
        ar = model.ar
        N, m = Y.shape
        stop = N if stop is None else stop
        if into is None:  # the consistency only feeds alarm statistics: single precision
            nis = np.empty((N, m), NIS_DTYPE) if consistency else None
            if context is None:
                into = BankOutputs(np.empty((N, m)), np.empty((N, m)), nis)
            else:  # memory-mapped for a long archive (RunContext.buffer)
                resid = context.buffer(f"{self.name}-resid", (N, m))
                into = BankOutputs(resid, context.buffer(f"{self.name}-est", (N, m)), nis)
        spans = time_blocks(start, stop, bank.warmup, context, m)
        # a cluster: each task gets its block's rows (and the warm-up before them) and the
        # bank, sent to each worker once (RunContext.scatter); a few blocks in flight at a
        # time, each result written here as it comes back. Else the blocks write their
        # rows in place (serially, or on threads): no block copies
        cluster = context is not None and len(spans) > 1 and not context.shares_memory
        held = context.scatter(bank) if cluster and context is not None else bank
        wanted = into.nis is not None
        inv = model.innovation_inv_cov
        items = [(ar.mean, ar.scale, held, Y[a - w : b], w, inv, wanted) for a, b, w in spans]
        if cluster:
            assert context is not None
            pieces = zip(spans, context.imap(_bank_block_task, items), strict=True)
            for k, ((a, _, _), out) in enumerate(pieces):
                if shown is not None and k + 1 < len(spans):
                    done = f"{shown}: time blocks {k + 1}/{len(spans)}"
                    context.report(done, (k + 1) / len(spans))
                write_rows(into.resid, a, out.resid)
                write_rows(into.est, a, out.est)
                if into.nis is not None:
                    assert out.nis is not None
                    write_rows(into.nis, a, out.nis)
                del out
            return into
        advanced = (
            None if shown is None or context is None else Advance(context, shown, stop - start)
        )
        tasks = [(item, into, a, advanced) for (a, _, _), item in zip(spans, items, strict=True)]
        if len(tasks) == 1 or context is None:
            for task in tasks:
                _bank_block_into(task)
        else:
            context.map(_bank_block_into, tasks)
        return into

    def estimate_warmup(self, model: FittedBank, j: int) -> int | None:
        """Rows :meth:`estimate` filters before the rows it estimates (sensor ``j``):
        the bank forgets its state within them, so the estimates equal the run's to
        rounding."""
        if model.bank is None:  # pragma: no cover - fitted by fit()
            raise DetectorError("ar_kalman_bank: the model has no estimator bank")
        return model.bank.warmup

    def estimate(self, model: FittedBank, rows: FloatArray, start: int, j: int) -> FloatArray:
        """Sensor ``j``'s estimate from the others (raw units) over ``rows[start:]``,
        filtered from ``rows[:start]`` (a warm-up of up to :meth:`estimate_warmup` rows;
        from a zero state when ``start`` is 0, as the run does at the record's start):
        the run's ``reference``, computed again on other rows, such as the record with
        other sensors' faults corrected (:func:`analyzer.regenerate.corrected_values`).
        The bank's estimate outputs alone, without the consistency, with the model as
        fitted."""
        Y = np.asarray(rows, dtype=np.float64)
        out = self._bank_outputs(model, Y, None, start=start, consistency=False)
        return np.array(out.est[start:, j])

    # -- running ---------------------------------------------------------------------------
    def run(self, model: FittedBank, data: Dataset, context: RunContext) -> DetectorResult:
        ar = model.ar
        rate = data.rate_hz
        Y = np.asarray(data.values, dtype=np.float64)
        N, m = Y.shape
        train_stop = data.search_start  # (the healthy window's end, unless searched again)
        events: list[Event] = []
        notes: list[str] = self._order_note(ar.order, data)
        unattributed: list[tuple[float, tuple[str, ...], tuple[str, ...]]] = []
        unattributed_end: list[float] = []  # when each one's alarms ended
        explained: list[tuple[int, int, int]] = []  # (channel, start, stop) already isolated
        # the residuals and estimates over the whole record; the estimators' consistency
        # only where a fault is isolated (recomputed there with the corrections so far)
        out = self._bank_outputs(model, Y, context, consistency=False, shown="whole record")
        # the residual the report shows: as measured, before any correction
        resid0: npt.NDArray[Any] = out.resid
        est0: npt.NDArray[Any] = out.est
        fixes: list[tuple[int, int, int, FloatArray]] = []  # (channel, a, b, corrected)
        # each residual's healthy share of its estimate, left out of fault shapes
        # (over the healthy window's second half, as events_from_residual measures it)
        healthy = slice((data.train[0] + data.train[1]) // 2, data.train[1])
        # (without one in the record, --model: each fault's before its onset)
        slopes = (
            [reference_slope(resid0[healthy, j], est0[healthy, j]) for j in range(m)]
            if data.healthy
            else None
        )

        loud = LoadGuard(data.values, data.train, rate, data.healthy)

        def consistency(lo: int, hi: int) -> FloatArray:
            return self._consistency(model, Y, fixes, lo, hi, context)

        def explains(
            c: int, a: int, b: int, cls: Classification, est: FloatArray, lo: int, hi: int
        ) -> float:
            """The largest whole-period value (rows ``lo .. hi - 1``) of the estimators
            that use sensor ``c``, with ``c``'s fitted fault ``cls`` over rows
            ``a .. b - 1`` (``est``: its estimate there) taken out as a confirmed fault's
            correction takes it out."""
            column = _corrected_rows(Y, fixes, a, b, channel=c)[:, 0]
            trial = [*fixes, (c, a, b, _undo_fault(column, est, cls, rate))]
            return max(
                (self._longest_violation(model, Y, trial, i, lo, hi) for i in range(m) if i != c),
                default=0.0,
            )

        corrected = False
        guessed = False  # some correction so far is an unconfirmed finding's
        alarms = None  # per channel, valid until the outputs are refiltered
        for _ in range(4 * m):
            if alarms is None:
                alarms = _alarm_intervals(model, out, train_stop, context)
            found = self._next_fault(
                model,
                out,
                consistency,
                rate,
                train_stop,
                explained,
                alarms,
                lambda j, windows: self._window_consistency(model, Y, fixes, j, windows),
                lambda j, lo, hi: self._longest_violation(model, Y, fixes, j, lo, hi),
                context.workdir if context.map_outputs else None,
                # no move once an unconfirmed finding was corrected: that correction is a
                # guess, and a guess on a healthy sensor is itself a change the other
                # estimators see (drifts on s3 and s2 at once, the first taken as s4's:
                # then healthy s1's estimator stayed the quietest, and s1's fitted drift
                # took enough out of the others to pass for the cause, 0.81)
                None if guessed else explains,
                names=data.channels,
                slopes=slopes,
            )
            release(out.resid)  # what the search read of memory-mapped outputs
            release(out.est)
            if found is None:
                break
            ev, spans, cls = found
            if ev is None or cls is None:
                # nothing is corrected, so the bank's outputs stay as they are
                explained.extend(spans)
                t = min(a for _, a, _ in spans) / rate
                unattributed.append((t, tuple(data.channels[c] for c, _, _ in spans), ()))
                unattributed_end.append(max(b for _, _, b in spans) / rate)
                notes.append(
                    f"residual anomaly at {seconds_text(t)} s on "
                    f"{', '.join(data.channels[c] for c, _, _ in spans)} not attributed to a "
                    "sensor (no estimator isolates it: several sensors at once, or a change "
                    "of the structure or excitation; or no fault shape and no confirmation)"
                )
                continue
            ((j, a, b),) = spans
            # a gain says how far the other residuals carry its spread, and one that no
            # estimator confirmed is refused when they move against it
            ratio, se = (
                self._spread(model, Y, fixes, out, j, a, b, cls, rate)
                if cls.type is FaultType.MULTIPLICATIVE
                else (float("nan"), float("inf"))
            )
            if np.isfinite(ratio):
                ev.evidence["spread"] = {"ratio": ratio, "se": se}
            if ev.evidence.get("isolated") is False and ratio + SPREAD_SIGMAS * se < 0.0:
                explained.append((j, a, b))
                t = a / rate
                unattributed.append((t, (data.channels[j],), ()))
                unattributed_end.append(b / rate)
                notes.append(
                    f"gain-like change of residual at {seconds_text(t)} s on {data.channels[j]} "
                    "not attributed to the sensor: no estimator confirmed it, and the "
                    f"estimators that take {data.channels[j]} in move against the change "
                    f"its correction would take out of them ({ratio:+.2f} times it, "
                    f"+- {se:.2f}; a sensor's fault shows there 1 time): the structure's "
                    "response changed (a load of another colour, say), not the sensor"
                )
                continue
            # where the other sensors' response was louder than anywhere in the healthy
            # window, the finding says how much (analyzer.diagnosis.load). Not refused
            # there unconfirmed, as the equivalent model's are: a 1.5 gain on the top
            # floor (tests/detectors/test_ar_kalman.py, its alarm at a level of 1.06) is
            # unconfirmed too, and the bank's one healthy finding on the simulated 5-floor
            # building (100 Hz, seed 5) sat at a level of 0.56, in no loud stretch.
            k0 = int(round(float(ev.evidence["first_alarm_s"]) * rate))
            load = loud.at_alarm(range(m), j, k0)
            if load > 1.0:
                ev.evidence["load_ratio"] = load
            ev.channel = data.channels[j]
            events.append(ev)
            guessed = guessed or ev.evidence.get("isolated") is False
            explained.append((j, a, b))
            if not corrected:
                # what the report shows is kept as measured (in the precision the pipeline
                # keeps signals in); the bank's own outputs are then refiltered in place
                resid0 = _kept(context, f"{self.name}-resid0", out.resid)
                est0 = _kept(context, f"{self.name}-est0", out.est)
                corrected = True
            # Correct the isolated channel so the bank can isolate the next fault (Section 4:
            # "corrected by a curve-fitting algorithm"): remove the fitted fault shape, or
            # where there is none (type other) use the estimate from the other sensors.
            # The estimators forget the change within their warm-up, so only the fault
            # period and the warm-up after it are filtered again, from copies of those rows
            # with every correction so far (the input itself is never written), a piece
            # of CONSISTENCY_PIECE rows at a time after its own warm-up: a fault that
            # lasts for hours is not copied whole.
            assert model.bank is not None
            warm = model.bank.warmup
            column = _corrected_rows(Y, fixes, a, b, channel=j)[:, 0]
            fixes.append((j, a, b, _undo_fault(column, out.est[a:b, j], cls, rate)))
            del column
            pieces = range(a, min(N, b + warm), CONSISTENCY_PIECE)
            for k, p in enumerate(pieces):
                q = min(N, b + warm, p + CONSISTENCY_PIECE)
                s = max(0, p - warm)
                seg = _corrected_rows(Y, fixes, s, q)
                rows = BankOutputs(out.resid[s:q], out.est[s:q], None)
                self._bank_outputs(model, seg, context, start=p - s, stop=q - s, into=rows)
                # (a fault that lasts for hours: a day's run was silent for a minute here)
                done = f"fault {len(events)} corrected and filtered again: {k + 1}/{len(pieces)}"
                context.report(done, (k + 1) / len(pieces))
            alarms = None
            isolated = f"{len(events)} fault{'' if len(events) == 1 else 's'} isolated"
            context.report(isolated, min(1.0, len(events) / m))
        # the residual the report shows: as measured, before any correction, kept in the
        # pipeline's signal precision (each float64 array let go before the next is copied;
        # memory-mapped ones are converted channel by channel as the pipeline spills them)
        del out
        if not context.map_outputs:
            resid0 = resid0.astype(SIGNAL_DTYPE, copy=False)
            est0 = est0.astype(SIGNAL_DTYPE, copy=False)
        residuals = {c: resid0[:, j] for j, c in enumerate(data.channels)}
        reference = {c: est0[:, j] for j, c in enumerate(data.channels)}
        return DetectorResult(
            detector=self.name,
            channels=data.channels,
            params={
                "order": ar.order,
                "order_rule": self.order,
                "filter": _describe(model.bank),
                "window": model.window,
                "false_alarm_rate": context.false_alarm_rate,
            },
            events=events,
            residuals=residuals,
            reference=reference,
            sigma={c: model.residual_cal[j].std for j, c in enumerate(data.channels)},
            thresholds={c: model.residual_cal[j].as_dict() for j, c in enumerate(data.channels)},
            model={
                "type": "AR",
                "order": ar.order,
                "channels": list(data.channels),
                "n_train": ar.n_train,
                "aic": ar.aic,
                "bic": ar.bic,
                "r_squared": {
                    c: float(v) for c, v in zip(data.channels, ar.r_squared(), strict=True)
                },
                "estimator_states": ar.order * ar.m,
                "threshold_calibration": model.calibration,
            },
            notes=notes,
            unattributed=unattributed,
            unattributed_end_s=unattributed_end,
        )

    def _highest_order(self, m: int) -> int:
        """The highest order a criterion searches for ``m`` channels: ``max_order``, or
        less where the state limit allows less."""
        return min(self.max_order, max(1, MAX_STATES // m))

    def _order_note(self, order: int, data: Dataset) -> list[str]:
        """A note when the config fixed an AR order below the one BIC selects on the
        healthy window: the model then leaves dynamics in its residuals, and faults with
        them (a gain of 1.5 on a 5-channel building was missed at order 3, BIC's 10,
        with nothing said)."""
        if isinstance(self.order, str) or not data.healthy or data.search_from is not None:
            return []
        train = np.asarray(data.train_values(), dtype=np.float64)
        highest = self._highest_order(len(data.channels))
        try:
            best = select_order(train, "bic", max(highest, order))
        except DetectorError:
            return []
        if best <= order:
            return []
        ratio = error_ratio(train, order, best)
        if not ratio > ORDER_ERROR_RATIO:
            return []
        return [ORDER_NOTE.format(order=order, best=best, ratio=ratio)]

    def _spread(
        self,
        model: FittedBank,
        Y: FloatArray,
        fixes: list[tuple[int, int, int, FloatArray]],
        out: BankOutputs,
        j: int,
        a: int,
        b: int,
        cls: Classification,
        rate: float,
    ) -> tuple[float, float]:
        """How much of its own spread a fault on sensor ``j`` over rows ``a .. b - 1``
        leaves in the other sensors' residuals: the least-squares ratio of those
        residuals (with ``fixes``) to the change the fault's correction makes to them,
        and its standard error, over the fault's first :data:`CONSISTENCY_PIECE` rows.

        Every estimator but ``j``'s takes sensor ``j``'s reading in, so a fault on it
        reaches their residuals through their gains on it; correcting the reading
        (:func:`_undo_fault`) changes them by ``d_i``. Where the fault is real they
        carry ``d_i`` (ratio 1); where sensor ``j``'s residual changed for another
        reason (the model's error under a load of another colour) they do not, and
        correcting it adds ``-d_i`` to them. Residuals and changes are scaled by each
        residual's healthy deviation; the error takes the residuals' median correlation
        time as the samples per independent one. ``(nan, inf)`` when the correction
        changes nothing (no estimator takes the sensor in)."""
        assert model.bank is not None
        N, m = Y.shape
        q = min(b, a + CONSISTENCY_PIECE, N)
        s = max(0, a - model.bank.warmup)
        seg = _corrected_rows(Y, fixes, s, q)
        seg[a - s :, j] = _undo_fault(
            seg[a - s :, j].copy(), np.asarray(out.est[a:q, j]), cls, rate
        )
        rows = BankOutputs(np.empty((q - s, m)), np.empty((q - s, m)), None)
        self._bank_outputs(model, seg, None, start=a - s, stop=q - s, into=rows, consistency=False)
        del seg
        others = [i for i in range(m) if i != j]
        sig = np.array([model.residual_cal[i].std for i in others])
        r = np.asarray(out.resid[a:q][:, others], dtype=np.float64)
        release(out.resid)
        z = r / sig
        d = (r - rows.resid[a - s :, others]) / sig
        ok = np.isfinite(z) & np.isfinite(d)
        z, d = np.where(ok, z, 0.0), np.where(ok, d, 0.0)
        dd = float(np.sum(d * d))
        if not dd > 0.0:
            return float("nan"), float("inf")
        tau = float(np.median([model.tau[i] for i in others]))
        return float(np.sum(z * d) / dd), float(np.sqrt(tau / dd))

    def _consistency(
        self,
        model: FittedBank,
        Y: FloatArray,
        fixes: list[tuple[int, int, int, FloatArray]],
        lo: int,
        hi: int,
        context: RunContext | None = None,
    ) -> npt.NDArray[Any]:
        """Every estimator's consistency ``(hi - lo, m)`` over rows ``lo .. hi - 1`` of the
        record with the corrections ``fixes`` applied: recomputed from a warm-up before
        each piece of at most :data:`CONSISTENCY_PIECE` rows, so it equals a run over the
        whole (corrected) record to rounding and its memory is set by the piece."""
        N, m = Y.shape
        lo, hi = max(0, lo), min(N, hi)
        assert model.bank is not None
        warm = model.bank.warmup
        nis = np.empty((max(0, hi - lo), m), NIS_DTYPE)
        for a in range(lo, hi, CONSISTENCY_PIECE):
            b = min(hi, a + CONSISTENCY_PIECE)
            s = max(0, a - warm)
            seg = _corrected_rows(Y, fixes, s, b)
            rows = BankOutputs(
                np.empty(seg.shape), np.empty(seg.shape), np.empty(seg.shape, NIS_DTYPE)
            )
            self._bank_outputs(model, seg, context, start=a - s, stop=b - s, into=rows)
            assert rows.nis is not None
            nis[a - lo : b - lo] = rows.nis[a - s :]
        return nis

    def _estimator_consistency(
        self,
        model: FittedBank,
        Y: FloatArray,
        fixes: list[tuple[int, int, int, FloatArray]],
        j: int,
        lo: int,
        hi: int,
    ) -> npt.NDArray[Any]:
        """Estimator ``j``'s consistency over rows ``lo .. hi - 1`` of the corrected
        record (:meth:`_consistency`'s column ``j`` to rounding): its own impulse
        responses only, about ``1 / m`` of the whole bank's work."""
        N, m = Y.shape
        lo, hi = max(0, lo), min(N, hi)
        bank = model.bank
        assert bank is not None
        if not (isinstance(bank.system, ImpulseResponseBank) and bank.whitened):
            return self._consistency(model, Y, fixes, lo, hi)[:, j]
        system = bank.system.subset([j])
        warm = bank.warmup
        nis = np.empty(max(0, hi - lo), NIS_DTYPE)
        for a in range(lo, hi, CONSISTENCY_PIECE):
            b = min(hi, a + CONSISTENCY_PIECE)
            s = max(0, a - warm)
            seg = _corrected_rows(Y, fixes, s, b)
            nis[a - lo : b - lo] = estimator_consistency(
                model.ar.mean, model.ar.scale, bank, system, j, seg, a - s
            )
        return nis

    def _window_consistency(
        self,
        model: FittedBank,
        Y: FloatArray,
        fixes: list[tuple[int, int, int, FloatArray]],
        j: int,
        windows: list[tuple[int, int]],
    ) -> Iterator[npt.NDArray[Any]]:
        """Estimator ``j``'s consistency over each of ``windows`` (in order of their
        starts), computed for a batch of nearby windows at once: windows closer than the
        warm-up share one pass, and the batches grow (4x, up to
        :data:`CONSISTENCY_PIECE` rows) as the caller asks for more, so the first
        windows cost little and a long run of them about one pass over their span."""
        assert model.bank is not None
        join = model.bank.warmup  # filtering a gap costs no more than a new warm-up
        budget = 1 << 12
        i = 0
        while i < len(windows):
            lo, hi = windows[i]
            k = i + 1
            while (
                k < len(windows)
                and windows[k][0] - hi <= join
                and max(hi, windows[k][1]) - lo <= budget
            ):
                hi = max(hi, windows[k][1])
                k += 1
            block = self._estimator_consistency(model, Y, fixes, j, lo, hi)
            for a, b in windows[i:k]:
                yield block[a - lo : b - lo]
            i = k
            budget = min(CONSISTENCY_PIECE, 4 * budget)

    def _longest_violation(
        self,
        model: FittedBank,
        Y: FloatArray,
        fixes: list[tuple[int, int, int, FloatArray]],
        j: int,
        lo: int,
        hi: int,
    ) -> float:
        """:meth:`_violation` of estimator ``j``'s consistency over rows ``lo .. hi - 1``
        (a whole fault period), computed a piece at a time: its memory does not grow with
        the period."""
        cal = model.consistency_cal[j]
        history = max(cal.windows) - 1
        tail = np.zeros(0)
        best = 0.0
        for a in range(max(0, lo), min(Y.shape[0], hi), CONSISTENCY_PIECE):
            b = min(hi, a + CONSISTENCY_PIECE)
            part = np.nan_to_num(self._estimator_consistency(model, Y, fixes, j, a, b))
            # the windows that end in this piece reach back into the one before
            x = np.concatenate((tail, part))
            stat = alarm_statistic(x, cal, raw=True, start=tail.shape[0], base=tail.shape[0])
            best = max(best, float(np.max(stat, initial=0.0)))
            tail = x[x.shape[0] - min(history, x.shape[0]) :]
        return best

    def _next_fault(
        self,
        model: FittedBank,
        out: BankOutputs,
        consistency: Callable[[int, int], FloatArray],
        rate: float,
        train_stop: int,
        explained: list[tuple[int, int, int]],
        alarms: list[list[Interval]] | None = None,
        estimator: Callable[[int, list[tuple[int, int]]], Iterator[npt.NDArray[Any]]] | None = None,
        longest: Callable[[int, int, int], float] | None = None,
        scratch: Path | None = None,
        explains: Callable[[int, int, int, Classification, FloatArray, int, int], float]
        | None = None,
        *,
        names: Sequence[str],
        slopes: Sequence[ReferenceSlope | None] | None = None,
    ) -> tuple[Event | None, list[tuple[int, int, int]], Classification | None] | None:
        """The earliest not-yet-explained fault, isolated to one sensor, or None
        (``names``: the channels, which the evidence names the candidates and estimators by).
        ``alarms``: each channel's alarm intervals in ``out`` when already known (they only
        change when the outputs do). ``estimator(j, windows)``: estimator ``j``'s
        consistency over each window in turn; ``longest(j, lo, hi)``: the largest alarm
        statistic of estimator ``j``'s consistency over ``lo .. hi - 1`` (both from
        ``consistency`` when not given). ``scratch``: where a long fault's corrected
        residual is mapped (:func:`~analyzer.diagnosis.events.diagnose_interval`).
        ``explains(c, a, b, cls, est, lo, hi)``: the largest value over ``lo .. hi - 1``
        of the estimators that use sensor ``c`` with its fault ``cls`` over ``a .. b - 1``
        corrected; without it, no fault moves to another candidate.
        ``slopes``: each channel's :class:`~analyzer.diagnosis.classify.ReferenceSlope`
        over the healthy window; without them each fault's is measured before its onset
        (:func:`~analyzer.diagnosis.events.slope_before`)."""
        if estimator is None:

            def estimator(j: int, windows: list[tuple[int, int]]) -> Iterator[npt.NDArray[Any]]:
                return (consistency(a, b)[:, j] for a, b in windows)

        if longest is None:

            def longest(j: int, lo: int, hi: int) -> float:
                return self._violation(model, consistency(lo, hi)[:, j], j)

        resid, est = out.resid, out.est
        N, m = resid.shape
        cands = []
        margin = model.residual_cal[0].long_window
        if alarms is None:
            alarms = _alarm_intervals(model, out, train_stop)
        for j in range(m):
            for iv in alarms[j]:
                stop = N if iv.end is None else iv.end
                if any(_overlaps(iv.onset, stop, a, b, margin) for c, a, b in explained if c == j):
                    continue  # the same fault (or its onset's edge), seen again after correction
                if any(
                    _overlaps(iv.onset, iv.onset + 1, a, a, margin)
                    or _overlaps(iv.onset, iv.onset + 1, b, b, margin)
                    for c, a, b in explained
                    if c != j
                ):
                    # a transient where another sensor's fault begins or ends: the
                    # correction's residual timing error, not a new fault
                    continue
                cands.append((iv.onset, j, iv, stop))
        if not cands:
            return None
        cands.sort(key=lambda c: (c[0], c[1]))
        t0 = cands[0][0]
        # every channel alarming within the long window of the earliest onset competes
        span = model.residual_cal[0].long_window
        group = [c for c in cands if c[0] <= t0 + span]
        # consistency of each estimator over the start of the fault
        lo = max(train_stop, t0 - model.window)
        hi = min(N, t0 + 2 * span)
        violation = self._violations(model, consistency(lo, hi))
        cand_ch = sorted({c[1] for c in group})
        # the faulty sensor: the candidate whose leave-out estimator stays most consistent
        # Among the candidates whose leave-out estimator is consistent, the one whose own
        # residual carries the strongest change (the others see an attenuated copy
        # through the estimators); if none is consistent, the least inconsistent.
        consistent = [c for c in cand_ch if violation[c] < 1.0]
        if consistent:
            j = max(
                consistent, key=lambda c: self._strength(resid[:, c], model.residual_cal[c], t0, hi)
            )
        else:
            j = min(cand_ch, key=lambda c: violation[c])
        others = [violation[i] for i in range(m) if i != j]
        typical = float(np.median(others)) if others else 0.0
        if violation[j] >= 1.0 and violation[j] > RELATIVE_CONSISTENCY * typical:
            # every estimator, even the one that never sees the alarming sensor, is about
            # as inconsistent: the data changed as a whole (excitation or structure),
            # which no single sensor fault explains (Section 2.3)
            return None, [(c[1], c[0], c[3]) for c in group], None
        # confirmed: some estimator that sees sensor j degrades (Section 2.3)
        isolated = _confirmed(violation[j], max(others, default=0.0))

        def diagnosed(j: int) -> tuple[Interval, int | None, Classification, int | None]:
            """Candidate ``j``'s alarm interval, the row its shape is fitted up to (None:
            its end), its classification and its end."""
            _, _, iv, _ = next(c for c in group if c[1] == j)
            # A later alarm on another channel is either this fault spreading through the
            # estimators that use sensor j, or the next fault. Only the next fault makes
            # estimator j (which never sees sensor j) inconsistent; fit this fault's shape
            # before it, so the two do not blur (re-occurring faults, Section 4).
            limit = None
            later = sorted({c[0] for c in cands if c[1] != j and c[0] > t0 + span})
            windows = [(max(train_stop, t2 - model.window), min(N, t2 + 2 * span)) for t2 in later]
            # estimator j's consistency only, over the windows batched (a fault that lasts
            # spreads through the other estimators: thousands of alarms over a long archive)
            for t2, nis_j in zip(later, estimator(j, windows), strict=False):
                if self._violation(model, nis_j, j) >= 1.0:
                    # a slowly growing fault alarms late: keep a long window off its alarm,
                    # or off where estimator j first lost consistency before it, if earlier
                    # (the next fault's start, which the other channels' alarms, still on
                    # with this fault's spread, do not show)
                    lost = self._first_violation(
                        model, j, (lo, min(N, t2 + 2 * span)), estimator, consistency
                    )
                    limit = max(iv.onset + span, min(t2, N if lost is None else lost) - span)
                    break
            cls, end = diagnose_interval(
                resid[:, j],
                est[:, j],
                model.residual_cal[j],
                iv,
                rate,
                model.tau[j],
                limit,
                scratch=scratch,
                slope=(
                    slopes[j]
                    if slopes is not None
                    else slope_before(
                        resid[:, j], est[:, j], train_stop, iv.onset, model.residual_cal[j], rate
                    )
                ),
            )
            return iv, limit, cls, end

        iv, limit, cls, end = diagnosed(j)
        stop = N if end is None else end
        moved_evidence: dict[str, Any] = {}
        if not isolated:
            # a slowly growing fault disturbs the estimators that use the sensor only
            # later: look for the confirmation over the whole fault period, estimator by
            # estimator (the ones most inconsistent at the onset first) until one confirms
            until = stop if limit is None else min(stop, limit)
            whole = {j: longest(j, lo, until)}
            for i in sorted((i for i in range(m) if i != j), key=lambda i: -violation[i]):
                whole[i] = longest(i, lo, until)
                if _confirmed(whole[j], whole[i]):
                    isolated = True
                    break
            if not isolated:
                # Over the whole period, another candidate's leave-out estimator stayed
                # consistent while one that uses it did not: the fault is that sensor's.
                # At the onset every estimator was still consistent, and the strongest
                # residual was a neighbour's, which the estimators that use the faulty
                # sensor carry amplified: a drift of 0.0185/s on s3 of a 5-floor building
                # (estimator s3 0.56, the others 3.7-13.5 times their threshold) showed
                # as -0.021/s on s4. Its correction on s4 then took part of the drift
                # out of s3's residual (0.0074/s reported, and false drifts on s2, s1).
                # The move stands only when correcting that sensor (its fitted fault
                # taken out) leaves every estimator consistent over the period, and only
                # while every correction so far is a confirmed finding's (the caller
                # gives no ``explains`` otherwise).
                moved = [
                    c
                    for c in cand_ch
                    if c != j and _confirmed(whole[c], max(v for i, v in whole.items() if i != c))
                ]
                if moved and explains is not None:
                    c = min(moved, key=lambda c: whole[c])
                    trial = diagnosed(c)
                    t_stop = N if trial[3] is None else trial[3]
                    a = trial[0].onset
                    after = explains(c, a, t_stop, trial[2], est[a:t_stop, c], lo, until)
                    if after < 1.0:
                        moved_evidence = {
                            "moved_from": names[j],
                            "whole_period_consistency": {
                                names[i]: float(v) for i, v in sorted(whole.items())
                            },
                            "corrected_consistency": after,
                        }
                        j = c
                        isolated = True
                        iv, limit, cls, end = trial
                        stop = t_stop
        if not cls.weighed or (
            not isolated and (cls.type is FaultType.OTHER or stop - iv.onset < span)
        ):
            # A change of residual that no estimator using the sensor confirms and that
            # either no fault shape explains or that is gone within a long window is
            # within the model's own error (it follows the response level): noted, not
            # reported as a faulty sensor. Nor is one whose residual had too few finite
            # samples to weigh any shape (a model's archive after a gap: confidence 0, an
            # offset of 0, and exit 1 for it; the realdata audit).
            return None, [(j, iv.onset, stop)], None
        onset_s, factor, early = bounded_onset(iv.onset, cls, rate, train_stop)
        conf = detection_confidence(iv) * cls.confidence * factor
        if not isolated:
            conf *= UNCONFIRMED_FACTOR
        ev = Event(
            channel="",
            onset_s=onset_s,
            end_s=None if end is None else end / rate,
            type=cls.type,
            magnitude=cls.magnitude,
            confidence=float(conf),
            detector=self.name,
            evidence={
                "isolated": isolated,
                "estimator_consistency": {names[i]: float(v) for i, v in enumerate(violation)},
                "candidates": [names[c] for c in cand_ch],
                "first_alarm_s": iv.first_alarm / rate,
                "peak_over_threshold": iv.peak,
                "p_value": iv.p_value,
                "type_weights": cls.weights,
                "explained": cls.explained,
                "noise_scale": cls.noise_scale,
                **early,
                **moved_evidence,
            },
            intervals=event_intervals(
                cls, iv.onset_range, onset_s, early, rate, model.residual_cal[j].mean_variance()
            ),
        )
        return ev, [(j, iv.onset, stop)], cls

    def _violations(
        self, model: FittedBank, nis: FloatArray, channels: Sequence[int] | None = None
    ) -> FloatArray:
        """Largest alarm statistic of each estimator's normalized innovations ``nis``
        (rows of a window, one column per estimator; of ``channels`` only, when given):
        below 1 while the estimator is consistent (masked samples count as consistent)."""
        cols = range(nis.shape[1]) if channels is None else channels
        return np.array([self._violation(model, nis[:, j], j) for j in cols])

    def _violation(self, model: FittedBank, nis: FloatArray, j: int) -> float:
        """Largest alarm statistic of estimator ``j``'s normalized innovations ``nis`` (a
        window's column): below 1 while the estimator is consistent (masked samples count
        as consistent)."""
        cons = np.nan_to_num(nis)
        cal = model.consistency_cal[j]
        return float(np.max(alarm_statistic(cons, cal, raw=True), initial=0.0))

    def _first_violation(
        self,
        model: FittedBank,
        j: int,
        window: tuple[int, int],
        estimator: Callable[[int, list[tuple[int, int]]], Iterator[npt.NDArray[Any]]],
        consistency: Callable[[int, int], FloatArray],
    ) -> int | None:
        """The first row of ``window`` (``a .. b - 1``) where estimator ``j``'s alarm
        statistic reaches 1 (:meth:`_violation`'s), or None; None too where that loss is
        common to the estimators (below). Estimator ``j`` never sees sensor ``j``: while
        ``j``'s fault goes on, it loses consistency at the next fault of another sensor
        (:meth:`_next_fault`), which a slowly growing one (a drift) shows there before any
        channel's alarm interval begins: the channels that estimate ``j``'s neighbours
        still alarm with ``j``'s fault, and a new interval of theirs begins only after
        theirs ended. An offset of 2 sd on s4 of the 3x2 building from 16 s and a drift of
        0.5 sd/s on s5 from 32 s (Chang et al.'s Fig. 15, seed 4): the first new interval
        began at 37.03 s, the offset was fitted to 35.03 s (5.055 for 5.358), and the
        leftover kept s5's residual alarmed from 16 s, so its drift was taken for the
        offset's echo and lost.

        A change of the environment or the structure (a temperature swing) makes every
        estimator lose consistency alike, estimator ``j`` with them, and is not another
        sensor's fault. So the loss stands only where estimator ``j`` stands out from the
        others by the test :meth:`_next_fault` puts the onset to
        (:data:`RELATIVE_CONSISTENCY`): over the long window that ends at the loss, the
        others, which see sensor ``j``'s fault as well as the new one, are at least
        ``1 / RELATIVE_CONSISTENCY`` times as inconsistent as estimator ``j``. In Fig. 15
        (seeds 0-9) estimator ``j`` was 0.019-0.13 times the others' median there; in
        sweep_eov's thermal records before their fault (no fault of another sensor)
        1.07-1.25 times."""
        a, b = window
        if b <= a:
            return None
        nis = next(iter(estimator(j, [(a, b)])), None)
        if nis is None:
            return None
        stat = alarm_statistic(np.nan_to_num(nis), model.consistency_cal[j], raw=True)
        over = np.flatnonzero(stat >= 1.0)
        if not over.size:
            return None
        lost = a + int(over[0])
        span = model.residual_cal[0].long_window
        violation = self._violations(model, consistency(max(a, lost - span), lost + 1))
        others = np.delete(violation, j)
        typical = float(np.median(others)) if others.size else 0.0
        if violation[j] > RELATIVE_CONSISTENCY * typical:
            return None  # every estimator lost it alike: a common change
        return lost

    @staticmethod
    def _strength(r: FloatArray, cal: Calibration, a: int, b: int) -> float:
        z = cal.standardize(r[a:b])
        return float(np.nanmean(np.abs(z))) if b > a else 0.0


def _alarm_intervals(
    model: FittedBank, out: BankOutputs, train_stop: int, context: RunContext | None = None
) -> list[list[Interval]]:
    """Every channel's alarm intervals in the bank's residuals after the training window;
    the channels in parallel on threads (the alarm statistic runs without the GIL)."""
    tasks = [
        (out.resid[:, j], model.residual_cal[j], train_stop) for j in range(out.resid.shape[1])
    ]
    if context is None:
        return [_detect_task(t) for t in tasks]
    return context.map_shared(_detect_task, tasks, "channels searched for alarms")


def _detect_task(task: tuple[FloatArray, Calibration, int]) -> list[Interval]:
    residual, cal, start = task
    found = detect(residual, cal, search_start=start)
    release(residual)  # a memory-mapped channel: read again only where a fault is
    return found


@dataclass(frozen=True, slots=True)
class _Fold:
    """One cross-validation fold: the training rows ``a .. b - 1`` held out, the model
    fitted without them, its estimators (a bank is built from them again where pass 2
    filters the rows again: a bank's spectra, ~40 MB at 16 channels, are not held per
    fold between the passes), and their out-of-sample residuals and innovation moments
    (after the cold start)."""

    a: int
    b: int
    ar: ARModel
    estimators: tuple[LeaveOneOut, ...]
    resid: FloatArray | None
    """None once written into the caller's residuals."""
    moments: InnovationMoments
    innov: npt.NDArray[np.float64] | None = None
    """The held-out rows' innovations (N, m, m - 1), kept for pass 2 when they fit in
    :data:`KEPT_INNOVATIONS_BYTES` (else pass 2 filters the rows again)."""


def _cv_fold_task(
    item: tuple[
        FloatArray,
        int,
        int,
        int | None,
        int,
        int,
        tuple[tuple[int, int], ...] | None,
        tuple[FloatArray, ...] | None,
        npt.NDArray[Any] | None,
    ],
    ar: ARModel | None = None,
    estimators: tuple[LeaveOneOut, ...] | None = None,
) -> _Fold:
    """Fit without rows ``a .. b - 1`` of ``train`` (order ``order``; or use ``ar`` and
    ``estimators`` as they are: the in-sample fallback) and filter the held-out rows from
    a warm-up before them; ``times`` are the whole model's estimators' settle and warm-up
    times and ``solutions`` their DARE solutions (:func:`leave_one_out`). The residuals
    are written into rows ``a .. b - 1`` of ``into`` when given (the fold's ``resid`` is
    then None), else kept in the fold."""
    train, a, b, order, block, skip, times, solutions, into = item
    if ar is None or estimators is None:
        assert order is not None
        # the block's rows, and the rows whose lags touch it, drop out of the fit
        ar = fit_ar(train, order, exclude=(a, b))
        estimators = tuple(
            leave_one_out(
                ar,
                j,
                block,
                None if times is None else times[j],
                None if solutions is None else solutions[j],
            )
            for j in range(ar.m)
        )
    bank = BankFilter.build(estimators, block)
    moments = InnovationMoments(ar.m)
    # the innovations are kept for pass 2 when they fit in KEPT_INNOVATIONS_BYTES; else
    # (a long window) only their moments are taken, chunk by chunk, and pass 2 filters
    # the fold again
    keep = (b - a) * ar.m * (ar.m - 1) * 8 * CV_FOLDS <= KEPT_INNOVATIONS_BYTES
    pieces = []
    innov = None
    for lo, hi, w in _fold_pieces(a, b, bank.warmup):
        first = max(0, skip - lo)  # the cold start's rows are not in the moments
        out = bank_block(
            ar.mean,
            ar.scale,
            bank,
            train[lo - w : hi],
            w,
            None,
            innov_moments=None if keep else moments,
            moments_from=first,
        )
        if keep:  # one piece: a short fold
            assert out.innov is not None
            moments.add(out.innov[first:])
            innov = out.innov
        if into is not None:
            write_rows(into, lo, out.resid)
        else:
            pieces.append(out.resid)
        del out
    kept = None if into is not None else np.concatenate(pieces)
    return _Fold(a, b, ar, estimators, kept, moments, innov)


FOLD_PIECE = 1 << 17
"""Rows of a long cross-validation fold filtered at once (each piece after its own
warm-up): the bank's per-row outputs of a piece (residuals, estimates, consistency:
about 50 MB at 16 channels), not of the fold, are held at once."""


def _fold_pieces(a: int, b: int, warmup: int) -> list[tuple[int, int, int]]:
    """The rows ``a .. b - 1`` of a fold in pieces of :data:`FOLD_PIECE` rows, each
    with its warm-up (``lo, hi, w``: filtered from row ``lo - w``). The bank's filters
    forget their state within ``warmup`` rows, so the pieces equal one pass over the
    fold to rounding (as the run's time blocks do); a fold of at most ``FOLD_PIECE``
    rows is one piece, as before."""
    return warm_spans(a, b, FOLD_PIECE, warmup)


def _cv_consistency_task(
    item: tuple[FloatArray, _Fold, list[FloatArray], FloatArray | None],
) -> FloatArray | None:
    """Pass 2 of the calibration on one fold: the consistency of its held-out rows, from
    the innovations pass 1 kept (the same products :func:`bank_block` takes of them),
    or by filtering the rows again with the fold's bank, built again from its
    estimators (the same bank: the build is deterministic). Written into the rows
    ``a .. b - 1`` of ``into`` when given (None returned), else returned."""
    train, fold, inv_covs, into = item
    if fold.innov is not None:
        m = fold.innov.shape[1]
        nt = fold.innov.transpose(1, 0, 2)  # (m, N, m - 1)
        inv_stack = np.stack([np.asarray(c) for c in inv_covs])
        nis = np.asarray((np.matmul(nt, inv_stack) * nt).sum(axis=2).T / (m - 1))
    else:  # a piece at a time, as pass 1 (written into ``into`` as they come)
        bank = BankFilter.build(fold.estimators, fold.estimators[0].block)
        pieces = []
        for lo, hi, w in _fold_pieces(fold.a, fold.b, bank.warmup):
            out = bank_block(fold.ar.mean, fold.ar.scale, bank, train[lo - w : hi], w, inv_covs)
            assert out.nis is not None
            if into is not None:
                write_rows(into, lo, out.nis)
            else:
                pieces.append(out.nis)
            del out
        if into is not None:
            return None
        nis = np.concatenate(pieces)
    if into is None:
        return nis
    write_rows(into, fold.a, nis)
    return None


def _bank_block_task(item: tuple[Any, ...]) -> BankBlock:
    """:func:`bank_block` on one tuple of arguments ``(mean, scale, bank, Y, warm,
    inv_covs, consistency)`` (what an executor maps)."""
    mean, scale, bank, Y, warm, inv_covs, consistency = item
    return bank_block(mean, scale, bank, Y, warm, inv_covs, consistency=consistency)


def _bank_block_into(task: tuple[tuple[Any, ...], BankOutputs, int, Advance | None]) -> None:
    """:func:`bank_block` writing its rows into shared outputs (serially or on threads),
    advancing the run's progress (``Advance``) chunk by chunk where given."""
    (mean, scale, bank, Y, warm, inv_covs, consistency), into, at, advanced = task
    bank_block(
        mean,
        scale,
        bank,
        Y,
        warm,
        inv_covs,
        into=into,
        at=at,
        consistency=consistency,
        advanced=advanced,
    )


def _kept(context: RunContext, name: str, a: FloatArray) -> npt.NDArray[Any]:
    """``a`` (samples, channels) in :data:`SIGNAL_DTYPE`: in memory, or for a long
    archive a memory-mapped copy written one channel at a time (RunContext.buffer), by
    ``pwrite`` (:func:`~analyzer.paging.write_rows`: a store through the new file's
    mapping would fault in, and have the kernel zero, every page first)."""
    if not context.map_outputs:
        return a.astype(SIGNAL_DTYPE)
    out = context.buffer(name, a.shape, SIGNAL_DTYPE)
    for j in range(a.shape[1]):
        for p in range(0, a.shape[0], RELEASE_ROWS):
            q = min(a.shape[0], p + RELEASE_ROWS)
            write_rows(out[:, j], p, a[p:q, j].astype(SIGNAL_DTYPE))
            release(a[p:q, j])
    return out


def _describe(bank: BankFilter | None) -> str:
    if bank is None:  # pragma: no cover - fitted by fit()
        return "none"
    if isinstance(bank.system, ImpulseResponseBank):
        return f"impulse responses of {bank.system.taps} taps (FFT)"
    return f"lifted state space, block {bank.block}"


def _corrected_rows(
    Y: FloatArray,
    fixes: list[tuple[int, int, int, FloatArray]],
    lo: int,
    hi: int,
    channel: int | None = None,
) -> FloatArray:
    """A copy of rows ``lo .. hi - 1`` of ``Y`` (of its column ``channel`` only, as a
    one-column array, when given) with the corrections ``fixes`` applied (in order) where
    they overlap; a memory-mapped ``Y``'s rows are given back once copied."""
    if channel is None:
        rows = Y[lo:hi]
        seg = np.array(rows, dtype=np.float64)
        release(rows)
    else:  # a piece of rows at a time: a long fault's column would map the whole matrix
        seg = read_column(Y, channel, lo, hi)[:, None]
    for j, a, b, fixed in fixes:
        x0, x1 = max(a, lo), min(b, hi)
        if x0 < x1 and (channel is None or j == channel):
            seg[x0 - lo : x1 - lo, 0 if channel is not None else j] = fixed[x0 - a : x1 - a]
    return seg


def _undo_fault(y: FloatArray, est: FloatArray, cls: Classification, rate: float) -> FloatArray:
    """The sensor's reading with the fitted fault removed: ``y - D`` (additive), ``y / a``
    (multiplicative, a not near 0), ``y - b t`` (drift); the estimate from the other
    sensors where the fault cannot be inverted (dead sensor, ``other``)."""
    if cls.type is FaultType.MULTIPLICATIVE and abs(cls.params.get("gain", 1.0)) >= MIN_GAIN:
        return y / cls.reading_gain
    shape = cls.fault_signal(np.arange(y.shape[0]) / rate, est)
    if shape is None or cls.type is FaultType.MULTIPLICATIVE:
        return est.copy()
    return y - shape


def _confirmed(own: float, others: float) -> bool:
    """A fault on sensor j is confirmed when some estimator that uses j is inconsistent
    (over its threshold) and clearly more so than estimator j itself."""
    return bool(others >= 1.0 and own <= RELATIVE_CONSISTENCY * others)


def _overlaps(a0: int, a1: int, b0: int, b1: int, slack: int) -> bool:
    return a0 < b1 + slack and b0 - slack < a1


__all__ = [
    "ARKalmanBank",
    "FittedBank",
    "BankFilter",  # (its home is kalman_bank; here too for models saved before the move)
    "LeaveOneOut",  # (likewise)
]
