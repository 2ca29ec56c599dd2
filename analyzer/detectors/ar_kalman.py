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

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import numpy.typing as npt
from scipy import linalg

from analyzer.detectors.ar_model import ARModel, fit_ar, select_order
from analyzer.detectors.base import Dataset, DetectorResult, Event, RunContext
from analyzer.detectors.lti import LiftedSystem
from analyzer.diagnosis.changes import (
    Calibration,
    alarm_statistic,
    calibrate,
    default_window,
    detect,
    detection_confidence,
)
from analyzer.diagnosis.classify import Classification, correlation_time
from analyzer.diagnosis.events import diagnose_interval
from analyzer.errors import DetectorError
from analyzer.types import FaultType

FloatArray = npt.NDArray[np.float64]

RELATIVE_CONSISTENCY = 0.25
"""A leave-out estimator over its threshold still isolates its sensor when it is at most
this fraction as inconsistent as the typical other estimator: a change that inflates
every estimator alike (a burst of excitation) must not mask a sensor fault."""

MAX_CHANNELS = 64
"""A bank of m estimators with p m states each costs O(m^3 p^2) per sample: beyond this,
the user should choose the sensors to analyze."""

CV_FOLDS = 5
"""Folds of the cross-validation that gives out-of-sample training residuals."""

UNCONFIRMED_FACTOR = 0.75
"""Confidence factor for a fault seen on its sensor's residual while no estimator that
uses the sensor became inconsistent (a small fault: located, but not confirmed)."""


@dataclass(frozen=True, slots=True)
class LeaveOneOut:
    """Steady-state estimator that measures every channel but ``left_out``.

    State recursion ``x[k+1] = F x[k] + G ybar[k]`` (one-step predictions), outputs
    ``[nu; yhat_j] = H x[k] + J ybar[k]``: the innovations of the measured channels and the
    filtered estimate of the left-out channel (scaled units)."""

    left_out: int
    measured: tuple[int, ...]
    system: LiftedSystem
    settle: int
    """Samples for the filter to forget its state (used after gaps)."""


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


def leave_one_out(ar: ARModel, j: int, block: int = 64) -> LeaveOneOut:
    """Estimator ``j`` of the bank (Eq. 10) with the gain from the DARE."""
    A, C = ar.companion()
    m = ar.m
    measured = tuple(i for i in range(m) if i != j)
    Cb = C[list(measured)]
    K = C.T  # noise enters the newest block row (Eq. 8)
    Q = K @ ar.sigma @ K.T
    R = ar.sigma[np.ix_(measured, measured)]
    try:
        P = linalg.solve_discrete_are(A.T, Cb.T, Q, R)
    except (linalg.LinAlgError, ValueError) as err:
        raise DetectorError(
            f"the Kalman estimator without channel {j} has no stabilizing solution "
            f"(singular model: {err})"
        ) from err
    S = Cb @ P @ Cb.T + R
    M = np.linalg.solve(S, Cb @ P).T  # filter gain P Cb' S^-1
    n = A.shape[0]
    I_MC = np.eye(n) - M @ Cb
    F = A @ I_MC
    G = A @ M
    cj = C[j : j + 1]
    H = np.vstack([-Cb, cj @ I_MC])
    J = np.vstack([np.eye(len(measured)), cj @ M])
    rho = float(np.max(np.abs(np.linalg.eigvals(F))))
    if not rho < 1.0:
        raise DetectorError(
            f"the Kalman estimator without channel {j} is unstable (spectral radius {rho:.4f})"
        )
    settle = int(np.ceil(np.log(1e-6) / np.log(max(rho, 1e-3))))
    return LeaveOneOut(j, measured, LiftedSystem.build(F, G, H, J, block), settle)


class ARKalmanBank:
    """``ar_kalman_bank``: the detector of Chang et al. (2017).

    Settings: ``order`` (int, or ``"aic"`` / ``"bic"``), ``max_order`` for the criteria."""

    name: ClassVar[str] = "ar_kalman_bank"

    def __init__(self, order: int | str = "bic", max_order: int = 10, block: int = 64) -> None:
        if isinstance(order, str) and order not in ("aic", "bic"):
            raise DetectorError(
                "[detectors.ar_kalman_bank] order: expected an integer, 'aic' or 'bic', "
                f"got {order!r}"
            )
        if isinstance(order, int) and order < 1:
            raise DetectorError(f"[detectors.ar_kalman_bank] order must be >= 1, got {order}")
        self.order = order
        self.max_order = int(max_order)
        self.block = int(block)

    def applicable(self, data: Dataset, context: RunContext) -> str | None:
        if len(data.channels) < 2:
            return "needs at least 2 channels (each estimator of the bank leaves one out)"
        if len(data.channels) > MAX_CHANNELS:
            return (
                f"{len(data.channels)} channels are too many for one bank (at most "
                f"{MAX_CHANNELS}): select the sensors with --channels"
            )
        return None

    # -- fitting ---------------------------------------------------------------------------
    def fit(self, data: Dataset, context: RunContext) -> FittedBank:
        reason = self.applicable(data, context)
        if reason:
            raise DetectorError(f"ar_kalman_bank {reason}")
        train = np.asarray(data.train_values(), dtype=np.float64)
        order = (
            select_order(train, self.order, self.max_order)
            if isinstance(self.order, str)
            else self.order
        )
        ar = fit_ar(train, order)
        estimators = tuple(leave_one_out(ar, j, self.block) for j in range(ar.m))
        window = default_window(data.rate_hz)
        resid, innov, skip, how = self._calibration_outputs(ar, estimators, train)
        inv_covs = []
        for j in range(ar.m):
            nu = innov[j][skip:]
            cov = np.atleast_2d(np.cov(nu[np.isfinite(nu).all(axis=1)].T))
            inv_covs.append(np.asarray(np.linalg.pinv(cov), dtype=np.float64))
        cons = [self._consistency(innov[j], inv_covs[j]) for j in range(ar.m)]
        res_cal, con_cal, taus = [], [], []
        # the false-alarm rate is per sample of the archive: shared among its channels
        alpha = context.false_alarm_rate / ar.m
        for j in range(ar.m):
            r = resid[skip:, j]
            res_cal.append(calibrate(r, window, alpha))
            con_cal.append(calibrate(cons[j][skip:], window, alpha))
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
        )

    def _calibration_outputs(
        self, ar: ARModel, estimators: tuple[LeaveOneOut, ...], train: FloatArray
    ) -> tuple[FloatArray, list[FloatArray], int, str]:
        """Residuals and innovations of the training window *out of sample*.

        A model judged on the data it was fitted to looks better than it is: in-sample
        residuals of an AR model with ``p m`` coefficients per channel understate its
        residuals on new data, and thresholds set from them raise false alarms. So the
        training window is cut into ``CV_FOLDS`` blocks; each block's residuals come from a
        model fitted without it (K-fold cross-validation). Where the window is too short
        for that, in-sample residuals are used and the model summary says so."""
        n = train.shape[0]
        k = CV_FOLDS
        edges = np.linspace(0, n, k + 1).astype(int)
        resid = np.full((n, ar.m), np.nan)
        innov = [np.full((n, ar.m - 1), np.nan) for _ in range(ar.m)]
        try:
            for f in range(k):
                a, b = edges[f], edges[f + 1]
                held = train.copy()
                held[a:b] = np.nan  # rows whose lags touch the block drop out of the fit
                ar_f = fit_ar(held, ar.order)
                ests = tuple(leave_one_out(ar_f, j, self.block) for j in range(ar.m))
                r, _, nu = self._bank_outputs(ar_f, ests, train)
                resid[a:b] = r[a:b]
                for j in range(ar.m):
                    innov[j][a:b] = nu[j][a:b]
            # the first block is filtered from a cold start: skip the transient
            skip = min(max(e.settle for e in estimators), n // 4)
            return resid, innov, skip, f"{k}-fold out-of-sample"
        except DetectorError:
            r, _, nu = self._bank_outputs(ar, estimators, train)
            skip = min(max(e.settle for e in estimators), n // 4)
            return r, nu, skip, "in-sample (training window too short for cross-validation)"

    @staticmethod
    def _consistency(nu: FloatArray, inv_cov: FloatArray) -> FloatArray:
        """Normalized innovation squared per sample, ``nu' S^-1 nu / dim`` (chi-square
        over its degrees of freedom: 1 on average while the estimator is consistent)."""
        return np.einsum("ki,ij,kj->k", nu, inv_cov, nu) / nu.shape[1]

    def _bank_outputs(
        self, ar: ARModel, estimators: tuple[LeaveOneOut, ...], Y: FloatArray
    ) -> tuple[FloatArray, FloatArray, list[FloatArray]]:
        """Run every estimator over ``Y`` (raw units). Returns the left-out residuals
        (N, m) and estimates (N, m) in raw units, and each estimator's innovations."""
        Z = (np.asarray(Y, dtype=np.float64) - ar.mean) / ar.scale
        gap = ~np.isfinite(Z)
        Zf = np.where(gap, 0.0, Z)
        N, m = Z.shape
        resid = np.empty((N, m))
        est = np.empty((N, m))
        innov: list[FloatArray] = []
        any_gap = gap.any()
        for j, e in enumerate(estimators):
            u = Zf[:, list(e.measured)]
            out, _ = e.system.run(u)
            nu = out[:, :-1]
            yhat = out[:, -1]
            if any_gap:
                # mask samples whose inputs were missing, and the settling after them
                bad = _dilate_forward(np.asarray(gap[:, list(e.measured)].any(axis=1)), e.settle)
                nu[bad] = np.nan
                yhat[bad] = np.nan
            est[:, j] = yhat * ar.scale[j] + ar.mean[j]
            resid[:, j] = np.where(gap[:, j], np.nan, Y[:, j] - est[:, j])
            innov.append(nu)
        return resid, est, innov

    # -- running ---------------------------------------------------------------------------
    def run(self, model: FittedBank, data: Dataset, context: RunContext) -> DetectorResult:
        ar = model.ar
        rate = data.rate_hz
        Y = np.array(data.values, dtype=np.float64, copy=True)
        N, m = Y.shape
        train_stop = data.train[1]
        events: list[Event] = []
        notes: list[str] = []
        explained: list[tuple[int, int, int]] = []  # (channel, start, stop) already isolated
        first = None
        for _ in range(4 * m):
            resid, est, innov = self._bank_outputs(ar, model.estimators, Y)
            if first is None:
                first = (resid.copy(), est.copy())
            found = self._next_fault(model, resid, est, innov, rate, train_stop, explained)
            if found is None:
                break
            ev, spans, cls = found
            if ev is None or cls is None:
                explained.extend(spans)
                t = min(a for _, a, _ in spans) / rate
                notes.append(
                    f"residual anomaly at {t:.3f} s on "
                    f"{', '.join(data.channels[c] for c, _, _ in spans)} not attributed to a "
                    "sensor (no estimator isolates it, or no fault shape and no confirmation)"
                )
                continue
            ((j, a, b),) = spans
            ev.channel = data.channels[j]
            events.append(ev)
            explained.append((j, a, b))
            # Correct the isolated channel so the bank can isolate the next fault (Section 4:
            # "corrected by a curve-fitting algorithm"): remove the fitted fault shape, or
            # where there is none (type other) use the estimate from the other sensors.
            Y[a:b, j] = _undo_fault(Y[a:b, j], est[a:b, j], cls, rate)
            context.report("ar_kalman_bank", min(1.0, len(events) / m))
        if first is None:  # pragma: no cover - the loop runs at least once
            raise DetectorError("ar_kalman_bank produced no output")
        resid0, est0 = first
        # the residual the report shows: as measured, before any correction
        residuals = {c: resid0[:, j] for j, c in enumerate(data.channels)}
        reference = {c: est0[:, j] for j, c in enumerate(data.channels)}
        return DetectorResult(
            detector=self.name,
            channels=data.channels,
            params={
                "order": ar.order,
                "order_rule": self.order,
                "block": self.block,
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
        )

    def _next_fault(
        self,
        model: FittedBank,
        resid: FloatArray,
        est: FloatArray,
        innov: list[FloatArray],
        rate: float,
        train_stop: int,
        explained: list[tuple[int, int, int]],
    ) -> tuple[Event | None, list[tuple[int, int, int]], Classification | None] | None:
        """The earliest not-yet-explained fault, isolated to one sensor, or None."""
        N, m = resid.shape
        cands = []
        margin = model.residual_cal[0].long_window
        for j in range(m):
            for iv in detect(resid[:, j], model.residual_cal[j], search_start=train_stop):
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
        violation = np.array([self._violation(model, innov, j, lo, hi) for j in range(m)])
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
        _, _, iv, _ = next(c for c in group if c[1] == j)
        cal = model.residual_cal[j]
        # A later alarm on another channel is either this fault spreading through the
        # estimators that use sensor j, or the next fault. Only the next fault makes
        # estimator j (which never sees sensor j) inconsistent; fit this fault's shape
        # before it, so the two do not blur (re-occurring faults, Section 4).
        limit = None
        for t2 in sorted({c[0] for c in cands if c[1] != j and c[0] > t0 + span}):
            lo2, hi2 = max(train_stop, t2 - model.window), min(N, t2 + 2 * span)
            if self._violation(model, innov, j, lo2, hi2) >= 1.0:
                # a slowly growing fault alarms late: keep a long window off its alarm
                limit = max(iv.onset + span, t2 - span)
                break
        cls, end = diagnose_interval(resid[:, j], est[:, j], cal, iv, rate, model.tau[j], limit)
        stop = N if end is None else end
        if not isolated:
            # a slowly growing fault disturbs the estimators that use the sensor only
            # later: look for the confirmation over the whole fault period
            until = stop if limit is None else min(stop, limit)
            isolated = _confirmed(
                self._violation(model, innov, j, lo, until),
                max(self._violation(model, innov, i, lo, until) for i in range(m) if i != j),
            )
        if not isolated and (cls.type is FaultType.OTHER or stop - iv.onset < span):
            # A change of residual that no estimator using the sensor confirms and that
            # either no fault shape explains or that is gone within a long window is
            # within the model's own error (it follows the response level): noted, not
            # reported as a faulty sensor.
            return None, [(j, iv.onset, stop)], None
        conf = detection_confidence(iv) * cls.confidence
        if not isolated:
            conf *= UNCONFIRMED_FACTOR
        ev = Event(
            channel="",
            onset_s=float(max(0.0, iv.onset / rate + cls.onset_shift_s)),
            end_s=None if end is None else end / rate,
            type=cls.type,
            magnitude=cls.magnitude,
            confidence=float(conf),
            detector=self.name,
            evidence={
                "isolated": isolated,
                "estimator_consistency": {str(i): float(v) for i, v in enumerate(violation)},
                "candidates": [int(c) for c in cand_ch],
                "first_alarm_s": iv.first_alarm / rate,
                "peak_over_threshold": iv.peak,
                "p_value": iv.p_value,
                "type_weights": cls.weights,
                "explained": cls.explained,
            },
        )
        return ev, [(j, iv.onset, stop)], cls

    def _violation(
        self, model: FittedBank, innov: list[FloatArray], j: int, lo: int, hi: int
    ) -> float:
        """Largest alarm statistic of estimator ``j``'s normalized innovations over
        ``[lo, hi)``: below 1 while the estimator is consistent."""
        cons = self._consistency(np.nan_to_num(innov[j][lo:hi]), model.innovation_inv_cov[j])
        cal = model.consistency_cal[j]
        return float(np.max(alarm_statistic(cal.standardize(cons), cal), initial=0.0))

    @staticmethod
    def _strength(r: FloatArray, cal: Calibration, a: int, b: int) -> float:
        z = cal.standardize(r[a:b])
        return float(np.nanmean(np.abs(z))) if b > a else 0.0


def _undo_fault(y: FloatArray, est: FloatArray, cls: Classification, rate: float) -> FloatArray:
    """The sensor's reading with the fitted fault removed: ``y - D`` (additive), ``y / a``
    (multiplicative, a not near 0), ``y - b t`` (drift); the estimate from the other
    sensors where the fault cannot be inverted (dead sensor, ``other``)."""
    gain = cls.params.get("gain", 1.0)
    if cls.type is FaultType.MULTIPLICATIVE and abs(gain) > 0.1:
        return y / gain
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


def _dilate_forward(mask: npt.NDArray[np.bool_], n: int) -> npt.NDArray[np.bool_]:
    """True wherever ``mask`` was True within the previous ``n`` samples."""
    if not mask.any():
        return mask
    c = np.cumsum(np.concatenate(([0], mask.astype(np.int64))))
    k = np.arange(mask.shape[0])
    lo = np.maximum(0, k - n)
    return (c[k + 1] - c[lo]) > 0


__all__ = ["ARKalmanBank", "FittedBank", "LeaveOneOut", "leave_one_out"]
