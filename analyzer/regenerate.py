"""Fault regeneration and corrected signals (Wang & Song 2014, Section 6.3).

The fault monitoring system of Wang & Song regenerates the fault signal ``f_s`` of a
diagnosed sensor from its residual (Eq. 31-33: the residual settles at ``-f_s / lambda1``)
and replaces the faulty signal by ``S_fault_free = S_fault - f_s`` over the fault period.
Here this works for the event of any detector, given the event and the channel's residual
(``measured - estimated``) or fault-free estimate:

* additive (``magnitude.offset``): ``f_s = offset``;
* drift (``magnitude.rate_per_s``): ``f_s = rate (t - onset)``, the onset being where the
  fitted slope starts;
* multiplicative (``magnitude.gain`` = a): ``S_fault = a S``, so ``f_s = S_fault (1 - 1/a)``
  and the corrected signal is ``S_fault / a``; a dead or nearly dead sensor
  (``|a| < MIN_GAIN``) cannot be inverted and is replaced by the fault-free estimate;
* anything else (``other``, or no magnitude): ``f_s`` is the residual itself
  (the regenerated fault of Section 6.3), i.e. the signal becomes the detector's estimate.

The paper's regeneration assumes the assistant sensors healthy (law 0, one fault at a
time); here an estimate that replaces a reading is computed again, where the detector can,
with the other channels' fitted faults taken out first and the other regenerated channels'
estimates in place of their readings; an offset's correction ends where its residual does,
and a regenerated reading where the readings are alive again, when the finding says later
(:func:`corrected_values`).

:func:`corrected_values` returns the corrected array and one JSON-friendly record per
correction; :func:`write_corrected_csv` writes the time column and every analyzed channel
(``analyzer run --corrected``).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from analyzer.diagnosis.classify import MIN_GAIN
from analyzer.errors import counted
from analyzer.outdir import named_error, spreadsheet_safe
from analyzer.paging import RELEASE_ROWS, release
from analyzer.timeutil import exact_unit, iso_times, json_time
from analyzer.types import NS_PER_S, FaultType

FloatArray = npt.NDArray[np.float64]


class FaultLike(Protocol):
    """What a correction needs from an event or a merged finding."""

    channel: str
    type: FaultType
    onset_s: float
    end_s: float | None
    magnitude: dict[str, float]
    detector: str


@dataclass(frozen=True, slots=True)
class Correction:
    """One corrected fault period of one channel."""

    channel: str
    detector: str
    type: str
    start_s: float
    end_s: float | None
    method: str
    """``offset``, ``drift``, ``gain``, ``residual``, ``reference`` or ``skipped``."""
    samples: int
    """Samples actually changed."""
    mean_fault: float | None
    """Mean regenerated fault signal ``f_s`` over the period (channel units)."""
    rms_fault: float | None
    note: str = ""
    onset_s: float | None = None
    """The onset of the fault corrected (its finding's ``onset_s``): ``start_s`` is
    earlier where the correction reaches back before it (an offset or gain present when
    a ``--model`` search began is corrected from the record's start)."""

    def as_dict(self) -> dict[str, Any]:
        return {
            "channel": self.channel,
            "detector": self.detector,
            "type": self.type,
            # (to findings.json's four decimals, as a fault's onset_s and end_s)
            "start_s": _time(self.start_s),
            "onset_s": _time(self.start_s if self.onset_s is None else self.onset_s),
            "end_s": _time(self.end_s),
            "method": self.method,
            "samples": self.samples,
            "mean_fault": self.mean_fault,
            "rms_fault": self.rms_fault,
            "note": self.note,
        }


def _time(x: float | None) -> float | None:
    """A time in seconds as findings.json writes a fault's ``onset_s``
    (:func:`~analyzer.timeutil.json_time`; ``corrections[]`` wrote ``300.002537658976``)."""
    return None if x is None else json_time(float(x))


def fault_signal(
    event: FaultLike,
    measured: FloatArray,
    rate_hz: float,
    residual: FloatArray | None = None,
    reference: FloatArray | None = None,
) -> tuple[int, int, FloatArray | None, str]:
    """The regenerated fault ``f_s`` of ``event`` over its period ``[start, stop)`` (sample
    indices into ``measured``), and the method used; ``f_s`` is None when nothing usable
    is known (no magnitude, no residual, no reference)."""
    y = np.asarray(measured, dtype=np.float64)
    start, stop = _period(event, y.shape[0], rate_hz)
    method = _method(event, residual, reference)
    if method == "skipped":
        return start, stop, None, method
    fs = _fault_piece(method, event, rate_hz, y[start:stop], residual, reference, start, stop)
    return start, stop, fs, method


def _period(event: FaultLike, n: int, rate_hz: float) -> tuple[int, int]:
    """The sample indices ``[start, stop)`` of ``event``'s period in a record of ``n``."""
    start = int(np.clip(round(event.onset_s * rate_hz), 0, n))
    stop = n if event.end_s is None else int(np.clip(round(event.end_s * rate_hz), start, n))
    return start, stop


def _method(event: FaultLike, residual: Any, reference: Any) -> str:
    """How ``event``'s fault is regenerated (the order of the module's list)."""
    mag = event.magnitude or {}
    kind = FaultType(event.type)
    if kind is FaultType.ADDITIVE and "offset" in mag:
        return "offset"
    if kind is FaultType.DRIFT and "rate_per_s" in mag:
        return "drift"
    if kind is FaultType.MULTIPLICATIVE and "gain" in mag and abs(float(mag["gain"])) >= MIN_GAIN:
        return "gain"
    if kind is FaultType.MULTIPLICATIVE and reference is not None:
        return "reference"
    if residual is not None:
        return "residual"
    if reference is not None:
        return "reference"
    return "skipped"


def _fault_piece(
    method: str,
    event: FaultLike,
    rate_hz: float,
    y: npt.NDArray[Any],
    residual: npt.NDArray[Any] | None,
    reference: npt.NDArray[Any] | None,
    a: int,
    b: int,
) -> FloatArray:
    """``f_s`` of ``method`` on samples ``a .. b - 1`` (a new float64 array): ``y`` holds
    those samples of the measured channel, ``residual`` and ``reference`` the whole record."""
    mag = event.magnitude or {}
    if method == "offset":
        return np.full(b - a, float(mag["offset"]))
    if method == "drift":
        tau = (np.arange(a, b) - event.onset_s * rate_hz) / rate_hz
        return float(mag["rate_per_s"]) * np.maximum(tau, 0.0)
    measured = np.asarray(y, dtype=np.float64)
    if method == "gain":
        return measured * (1.0 - 1.0 / float(mag["gain"]))
    if method == "reference":
        assert reference is not None
        return measured - np.asarray(reference[a:b], dtype=np.float64)
    assert residual is not None
    return np.array(residual[a:b], dtype=np.float64, copy=True)


SignalMap = Mapping[str, FloatArray | None] | Mapping[tuple[str, str], FloatArray | None]


def result_signals(
    results: Iterable[Any],
) -> tuple[dict[tuple[str, str], FloatArray], dict[tuple[str, str], FloatArray]]:
    """Residuals and fault-free estimates of detector results (``DetectorResult``), keyed by
    ``(detector, channel)`` for :func:`corrected_values`."""
    res: dict[tuple[str, str], FloatArray] = {}
    ref: dict[tuple[str, str], FloatArray] = {}
    for r in results:
        for c, v in r.residuals.items():
            res[(r.detector, c)] = v
        for c, v in r.reference.items():
            ref[(r.detector, c)] = v
    return res, ref


def _lookup(m: SignalMap | None, detector: str, channel: str) -> npt.NDArray[Any] | None:
    if m is None:
        return None
    got = m.get((detector, channel))  # type: ignore[call-overload]
    if got is None:
        got = m.get(channel)  # type: ignore[call-overload]
    return None if got is None else np.asarray(got)


def corrected_values(
    values: FloatArray,
    channels: Sequence[str],
    rate_hz: float,
    events: Iterable[FaultLike],
    residuals: SignalMap | None = None,
    references: SignalMap | None = None,
    buffer: Callable[[str, tuple[int, int], npt.DTypeLike], npt.NDArray[Any]] | None = None,
    healthy: tuple[int, int] | None = None,
    estimates: Estimates | None = None,
) -> tuple[FloatArray, list[dict[str, Any]]]:
    """``values`` (N, m) with every event's fault removed over its period
    (``S_fault_free = S_fault - f_s``, Section 6.3), and one record per event.

    ``healthy``: the rows of the healthy window (``--model``, whose window is the
    filters' warm-up: a stretch of the record clear of every finding,
    :func:`healthy_stretch`). Given, a fault whose reading would be
    replaced by the detector's estimate (``residual``, or ``reference`` for anything but
    a multiplicative fault: a dead or nearly dead sensor, whose reading says nothing) is
    left as measured when the estimate's own error is as large as the
    fault's (:func:`_worth_replacing`): a gain of 1.25 on a building's ground-floor sensor,
    read as ``other``, left 0.24 sd of error; its estimate's was 0.43 sd, and the
    correction nearly doubled the error (``benchmarks/sweep_corrected.py``).

    ``residuals`` / ``references`` give the residual (measured - estimated) and fault-free
    estimate of the detector whose event is corrected, keyed by channel or by
    ``(detector, channel)`` (:func:`result_signals`; for merged findings the finding's
    ``detector`` is its leading detector). When two events of a channel overlap, samples
    already corrected are not corrected again (the more confident event first).

    ``estimates(detector, channel)``: the detector's estimate of the channel computed
    again (:data:`Estimates`). Given, a reading replaced by the estimate (``reference``,
    ``residual``) is replaced by the estimate computed on the readings with the other
    channels' fitted faults (offset, gain, drift) taken out over their periods, the
    models as the run fitted them: the estimate of a sensor from the others carries
    their faults (Wang & Song's regeneration assumes the assistant sensors healthy,
    law 0), and a dead sensor beside a neighbour's offset of 2 sd was regenerated with
    up to 4.9 times its estimator's own error (``benchmarks/sweep_corrected.py``,
    ``two-dead-neighbour``). Without other faults there, or for a detector that cannot
    estimate again, the run's estimate is used.

    An offset's correction ends where the residual it comes with says the offset ended
    (:func:`_trimmed_stop`), when that is before the finding's end: an offset whose
    end the detectors saw 3-8 s late while another sensor's gain was under way was
    subtracted from that many seconds of healthy readings.

    A reading replaced by an estimate ends, given ``healthy``, where the readings are
    alive again, when that is before the finding's end: a dead sensor that came back at
    220 s while its finding ran to the record's end had its healthy readings replaced
    by the estimate (0.27 sd of error; ``sweep_corrected.py`` ``two-dead-neighbour``,
    seed 6). Where the readings' own spread goes from dead to alive and stays alive
    (:func:`_revived_stop`), that is the end whatever the estimate carries: an estimate
    with another sensor's undetected drift in it kept the regeneration running over
    healthy readings (``two-dead-drift``: 0.13 sd of error there). Otherwise (readings
    that cannot tell: an ``other`` fault that moves as much as live readings) the
    residual decides (:func:`_alive_stop`: from where it reads as the healthy window's,
    not as the fault period's). Two channels replaced by estimates at once each
    take the other's estimate in place of its dead reading as an input
    (:func:`_regenerated_inputs`): the estimate of a dead sensor from one that is dead
    too was up to 1.9 times its estimator's own error (``two-dead``).

    ``buffer(name, shape, dtype)`` allocates the result and the mask of corrected samples
    (such as :meth:`~analyzer.detectors.base.RunContext.buffer`: memory-mapped for a long
    archive); default new arrays in memory. Everything is done :data:`RELEASE_ROWS` rows
    at a time with the pages of mapped arrays given back, so a long archive is corrected
    in memory set by that piece, not by its length."""
    n, m = np.shape(values) if np.ndim(values) == 2 else (-1, -1)
    if m != len(channels):
        raise ValueError(
            f"expected a (N, {len(channels)}) array for {len(channels)} channels, "
            f"got {np.shape(values)}"
        )

    def make(name: str, dtype: npt.DTypeLike) -> npt.NDArray[Any]:
        return np.empty((n, m), dtype) if buffer is None else buffer(name, (n, m), dtype)

    out = make("corrected", np.float64)
    done = make("corrected-done", np.bool_)
    for a in range(0, n, RELEASE_ROWS):
        b = min(n, a + RELEASE_ROWS)
        out[a:b] = values[a:b]
        done[a:b] = False
        for arr in (values[a:b], out[a:b], done[a:b]):
            release(arr)
    index = {c: j for j, c in enumerate(channels)}
    records: list[dict[str, Any]] = []
    evs = sorted(events, key=lambda e: -float(getattr(e, "confidence", 0.0)))
    # every fitted fault's span (offset, drift, gain), in the order they are corrected:
    # what the estimates computed again take out of the other channels
    shaped: list[_Shaped] = []
    spans: dict[int, _Shaped] = {}
    for ev in evs:
        j = index.get(ev.channel)
        if j is None:
            continue
        res = _lookup(residuals, ev.detector, ev.channel)
        method = _method(ev, res, _lookup(references, ev.detector, ev.channel))
        if method in MODEL_METHODS:
            spans[id(ev)] = _shaped_span(ev, j, method, n, rate_hz, res)
            shaped.append(spans[id(ev)])
    # the readings replaced by an estimate (a dead sensor, ``other``): their periods and
    # how each estimate is computed again, planned first so that each can take the
    # others' regenerated readings in place of theirs (:func:`_regenerated_inputs`)
    plans: dict[int, _Regen] = {}
    for ev in evs:
        j = index.get(ev.channel)
        if j is None or id(ev) in spans:
            continue
        res = _lookup(residuals, ev.detector, ev.channel)
        ref = _lookup(references, ev.detector, ev.channel)
        method = _method(ev, res, ref)
        if method == "skipped":
            continue
        start, stop = _period(ev, n, rate_hz)
        worth = None
        if healthy is not None and (
            method == "residual"
            or (method == "reference" and FaultType(ev.type) is not FaultType.MULTIPLICATIVE)
        ):
            worth = _worth_replacing(values, j, res, ref, healthy, (start, stop))
        given = None
        if estimates is not None and (
            method == "reference" or method == "residual" and ev.detector in RESIDUAL_IS_ERROR
        ):
            given = estimates(ev.detector, ev.channel)
        plans[id(ev)] = _Regen(ev, j, method, start, stop, res, ref, given, worth)
    regen = [p for p in plans.values() if p.skip is None]

    def column(name: str, rows: int) -> FloatArray:
        return np.empty(rows) if buffer is None else buffer(name, (rows, 1), np.float64)[:, 0]

    subs = _regenerated_inputs(regen, values, rate_hz, shaped, column)
    for p in regen:  # each regenerated reading ends where the readings are alive again
        again = _estimate_again(p.given, p.j, shaped, p.start, p.stop, subs)
        p.again = again
        if healthy is not None:
            residual = _residual_rows(p, values, rate_hz)
            revived = _revived_stop(values, p, healthy, rate_hz, residual)
            p.stop_trimmed = (
                _alive_stop(residual, values, p, healthy, rate_hz) if revived is None else revived
            )
    for sub in subs:  # a revived reading is its fellows' input again (its own period's)
        for a in range(max(sub.plan.stop_trimmed, sub.lo), sub.hi, RELEASE_ROWS):
            piece = sub.values[a - sub.lo : min(sub.hi, a + RELEASE_ROWS) - sub.lo]
            piece[...] = np.nan
            release(piece)
    for ev in evs:
        plan = plans.get(id(ev))
        stop_s = spans[id(ev)].end_s if id(ev) in spans else ev.end_s
        if plan is not None and plan.stop_trimmed < plan.stop:
            stop_s = plan.stop_trimmed / rate_hz

        def record(
            method: str,
            samples: int = 0,
            mean: float | None = None,
            rms: float | None = None,
            note: str = "",
            ev: FaultLike = ev,
            end: float | None = None if stop_s is None else float(stop_s),
            begin: float | None = None,
        ) -> dict[str, Any]:
            return Correction(
                ev.channel,
                ev.detector,
                FaultType(ev.type).value,
                float(ev.onset_s) if begin is None else begin,
                end,
                method,
                samples,
                mean,
                rms,
                note,
                float(ev.onset_s),
            ).as_dict()

        j = index.get(ev.channel)
        if j is None:
            records.append(record("skipped", note="channel not analyzed"))
            continue
        res = _lookup(residuals, ev.detector, ev.channel)
        ref = _lookup(references, ev.detector, ev.channel)
        start, stop = _period(ev, n, rate_hz)
        method = _method(ev, res, ref)
        if method == "skipped":
            records.append(record(method, note="no fault model, residual or reference"))
            continue
        if plan is not None and plan.skip is not None:
            records.append(record("skipped", note=plan.skip))
            continue
        notes = []
        again = None
        begin = None  # (the onset's own time, unless the span starts elsewhere)
        if id(ev) in spans:
            if spans[id(ev)].start != start:  # (from the record's start: its true start)
                begin = spans[id(ev)].start / rate_hz
            start, stop = spans[id(ev)].start, spans[id(ev)].stop
            notes.append(spans[id(ev)].note)
        elif plan is not None:
            again = plan.again
            if again is not None:
                notes.append("estimated again with the other channels' faults taken out")
            if plan.stop_trimmed < stop:
                ended = "the record's end" if ev.end_s is None else f"{float(ev.end_s):.4f} s"
                notes.append(
                    f"ended at {plan.stop_trimmed / rate_hz:.4f} s, where the readings are "
                    f"alive again (the finding ends at {ended})"
                )
                stop = plan.stop_trimmed
        count, total, squares = 0, 0.0, 0.0
        for a in range(start, stop, RELEASE_ROWS):
            b = min(stop, a + RELEASE_ROWS)
            rows = values[a:b]
            if again is None:
                fs = _fault_piece(method, ev, rate_hz, rows[:, j], res, ref, a, b)
            else:
                fs = np.asarray(rows[:, j], dtype=np.float64) - again(values, rate_hz, a, b)
            col = out[a:b, j]
            ok = np.isfinite(fs) & np.isfinite(col) & np.logical_not(done[a:b, j])
            col[ok] = col[ok] - fs[ok]
            done[a:b, j] |= ok
            used = fs[ok]
            count += int(used.size)
            total += float(np.sum(used))
            squares += float(np.sum(used * used))
            release(rows)
            for whole in (out, done, res, ref):
                release(None if whole is None else whole[a:b])
        note = "; ".join(x for x in notes if x)
        if count < stop - start:
            left = (
                f"{counted(stop - start - count, 'sample')} left as measured (gap or "
                "already corrected)"
            )
            note = f"{note}; {left}" if note else left
        records.append(
            record(
                method,
                count,
                total / count if count else None,
                float(np.sqrt(squares / count)) if count else None,
                note,
                begin=begin,
            )
        )
    return out, records


RESIDUAL_IS_ERROR = ("ar_kalman_bank",)
"""The detectors whose residual is the reading less their estimate (``y - reference``):
a correction by the residual (``residual``: the reading becomes the estimate) is then a
correction by the estimate, which may be computed again without the other channels'
faults. The detection filter's and the observers' residuals are fault estimates of
their own (filtered: 0.35 sd from ``y - reference``), so an ``other`` fault of theirs
stays corrected by its residual whatever the other channels do (the review: a
neighbour's offset of size 0 nearby changed the correction by up to 0.17 sd)."""

MODEL_METHODS = ("offset", "drift", "gain")
"""The methods that subtract a fitted fault shape (no estimate involved)."""

Estimates = Callable[[str, str], "tuple[int, Callable[[FloatArray, int], FloatArray]] | None"]
"""``estimates(detector, channel)``: ``(warmup, estimate)``, where ``estimate(rows,
start)`` is the detector's fault-free estimate of ``channel`` over ``rows[start:]``
(``rows``: readings of every analyzed channel, in :func:`corrected_values`'s column
order), filtered from ``rows[:start]``, at most ``warmup`` rows before (the run's own
estimate there, to rounding, given the run's readings); None when the detector cannot
compute it again."""

TRIM_WINDOW_S = 60.0
"""How far before a finding's end an offset's correction may end instead
(:func:`_trimmed_stop`)."""

TRIM_MIN_S = 0.5
"""The shortest tail an offset's correction is cut by: the residual's mean over it is
then known to a fraction of the offset, for a noisy estimate too."""

TRIM_SHARE = 0.25
"""A tail is cut only when the residual's mean square over it is under this share of the
offset's square (its RMS under half the offset): the detector sees no offset there."""


@dataclass(frozen=True, slots=True)
class _Shaped:
    """A fitted fault's correction: ``event`` on column ``j`` by ``method`` over rows
    ``[start, stop)``, the end its record gives (seconds, None: the record's end) and
    what it notes about that period."""

    event: FaultLike
    j: int
    method: str
    start: int
    stop: int
    end_s: float | None
    note: str


def _shaped_span(
    ev: FaultLike,
    j: int,
    method: str,
    n: int,
    rate_hz: float,
    res: npt.NDArray[Any] | None,
) -> _Shaped:
    """The rows a fitted fault's correction spans: the finding's period, from the
    record's start for an offset or gain present when a ``--model`` search began, and
    an offset's ending where its residual does (:func:`_trimmed_stop`)."""
    start, stop = _period(ev, n, rate_hz)
    end_s = ev.end_s
    notes = []
    evidence = getattr(ev, "evidence", None) or {}
    if method in ("offset", "gain") and evidence.get("onset_at_or_before") and start > 0:
        # --model: the fault was there when the search began, after the filters'
        # warm-up; a constant offset or gain holds over that warm-up as well
        notes.append(f"corrected from the record's start (the fault was there at {ev.onset_s:g} s)")
        start = 0
    if method == "offset" and ev.end_s is not None and res is not None:
        cut = _trimmed_stop(_residual_offset(ev), res, start, stop, rate_hz)
        if cut < stop:
            notes.append(
                f"ended at {cut / rate_hz:.4f} s, where the residual shows no offset (the "
                f"finding ends at {float(ev.end_s):.4f} s)"
            )
            stop, end_s = cut, cut / rate_hz
    return _Shaped(ev, j, method, start, stop, end_s, "; ".join(notes))


def _residual_offset(ev: FaultLike) -> float:
    """``ev``'s offset as its detector's residual reads it: the error functions' residual
    reads an offset ``D`` of the sensor as ``D * dc_gain`` (the taps' sum, 0.0146 on an
    accelerometer of Li et al.'s chain), while their event's offset is in the sensor's
    units (:func:`analyzer.detectors.error_function._in_sensor_units`, which keeps
    ``dc_gain`` in the event's evidence; a finding's leading event among its
    ``events``); the other detectors' residuals read ``D``."""
    offset = float(ev.magnitude["offset"])
    for e in (ev, *getattr(ev, "events", ())):
        evidence = getattr(e, "evidence", None) or {}
        if (
            "dc_gain" in evidence
            and getattr(e, "detector", None) == ev.detector
            and (getattr(e, "magnitude", None) or {}).get("offset") == offset
        ):
            return offset * float(evidence["dc_gain"])
    return offset


def _trimmed_stop(
    offset: float, res: npt.NDArray[Any], start: int, stop: int, rate_hz: float
) -> int:
    """Where an offset's correction over ``[start, stop)`` ends: ``stop``, or an earlier
    ``k`` (at most :data:`TRIM_WINDOW_S` before it, at least :data:`TRIM_MIN_S`) after
    which the residual ``res`` fits "no offset" better than the offset ``o`` (as ``res``
    reads it: :func:`_residual_offset`): the least of the
    tail sums ``sum_{t >= k} r_t^2 - (r_t - o)^2 = sum (2 o r_t - o^2)`` (what the offset
    saves of the residual's sum of squares there), negative, and the residual's mean
    square over the tail under :data:`TRIM_SHARE` of ``o^2``. Missing residuals count for
    neither."""
    least = max(1, int(round(TRIM_MIN_S * rate_hz)))
    lo = max(start, stop - int(round(TRIM_WINDOW_S * rate_hz)))
    if stop - lo < least or not np.isfinite(offset) or offset == 0.0:
        return stop
    r = np.asarray(res[lo:stop], dtype=np.float64)
    release(res[lo:stop])
    ok = np.isfinite(r)
    d = np.where(ok, 2.0 * offset * np.where(ok, r, 0.0) - offset * offset, 0.0)
    tails = np.cumsum(d[::-1])[::-1][: stop - lo - least + 1]
    k = int(np.argmin(tails))
    if not tails[k] < 0.0:
        return stop
    tail = r[k:][ok[k:]]
    if tail.size < least or float(np.mean(tail * tail)) > TRIM_SHARE * offset * offset:
        return stop
    return lo + k


def _estimate_again(
    given: tuple[int, Callable[[FloatArray, int], FloatArray]] | None,
    j: int,
    shaped: Sequence[_Shaped],
    start: int,
    stop: int,
    subs: Sequence[_Sub] = (),
) -> Callable[[npt.NDArray[Any], float, int, int], FloatArray] | None:
    """The estimate of column ``j`` over rows ``a .. b - 1`` computed again on the
    readings with the other columns' fitted faults (``shaped``) taken out and the other
    columns' regenerated readings (``subs``, where finite) in place of theirs, as a
    function of ``(values, rate_hz, a, b)``; None when the detector cannot (``given``
    None) or no other column's fault touches ``[start, stop)`` or the warm-up before it
    (the run's own estimate is then that one). ``subs`` are read when the function is
    called: :func:`_regenerated_inputs` refines them in place."""
    if given is None:
        return None
    warm, estimate = given
    near = [s for s in shaped if s.j != j and s.start < stop and s.stop > start - warm]
    nearby = [s for s in subs if s.j != j and s.lo < stop and s.hi > start - warm]
    if not near and not nearby:
        return None

    def again(values: npt.NDArray[Any], rate_hz: float, a: int, b: int) -> FloatArray:
        lo = max(0, a - warm)
        rows = np.array(values[lo:b], dtype=np.float64)
        release(values[lo:b])
        done = np.zeros(rows.shape, dtype=np.bool_)
        for s in near:  # (the more confident first; a sample is corrected once)
            p, q = max(s.start, lo), min(s.stop, b)
            if p >= q:
                continue
            col = rows[p - lo : q - lo, s.j]
            fs = _fault_piece(s.method, s.event, rate_hz, col, None, None, p, q)
            ok = np.isfinite(fs) & np.isfinite(col) & np.logical_not(done[p - lo : q - lo, s.j])
            col[ok] -= fs[ok]
            done[p - lo : q - lo, s.j] |= ok
        for r in nearby:
            p, q = max(r.lo, lo), min(r.hi, b)
            if p < q:
                col = rows[p - lo : q - lo, r.j]
                put = r.values[p - r.lo : q - r.lo]
                np.copyto(col, put, where=np.isfinite(put))
        return np.asarray(estimate(rows, a - lo), dtype=np.float64)

    return again


REGEN_PASSES = 3
"""Rounds of :func:`_regenerated_inputs`: two sensors replaced by estimates at once each
feed the other's; each round the error one passes to the other is multiplied by the
product of their estimators' weights on each other, small for estimators that draw on
several sensors (two sensors each estimated as the mean of the two others: 1/4 a
round, 0.4 % of the dead reading's error left after three rounds). In the 6-floor
building of ``sweep_corrected.py`` (``two-dead``) three rounds regenerate both at their
estimators' own error (regen/floor at most 1.07)."""


class _Regen:
    """A reading replaced by an estimate (method ``reference`` or ``residual``): ``event``
    on column ``j`` over rows ``[start, stop)``, its detector's signals and estimate
    computed again (``given``: :data:`Estimates`), why it is left as measured (``skip``,
    :func:`_worth_replacing`), and, once planned, the estimate with the other faults
    taken out (``again``) and where the readings are alive again (``stop_trimmed``)."""

    __slots__ = (
        "again",
        "event",
        "given",
        "j",
        "method",
        "ref",
        "res",
        "skip",
        "start",
        "stop",
        "stop_trimmed",
    )

    def __init__(
        self,
        event: FaultLike,
        j: int,
        method: str,
        start: int,
        stop: int,
        res: npt.NDArray[Any] | None,
        ref: npt.NDArray[Any] | None,
        given: tuple[int, Callable[[FloatArray, int], FloatArray]] | None,
        skip: str | None,
    ) -> None:
        self.event, self.j, self.method, self.start, self.stop = event, j, method, start, stop
        self.res, self.ref, self.given, self.skip = res, ref, given, skip
        self.again: Callable[[npt.NDArray[Any], float, int, int], FloatArray] | None = None
        self.stop_trimmed = stop


@dataclass(frozen=True, slots=True)
class _Sub:
    """Column ``j``'s regenerated readings over rows ``[lo, hi)`` (``values``; NaN: the
    reading itself), the input the other regenerated columns' estimates take instead of
    its readings."""

    j: int
    lo: int
    hi: int
    values: FloatArray
    plan: _Regen


def _regenerated_inputs(
    regen: Sequence[_Regen],
    values: npt.NDArray[Any],
    rate_hz: float,
    shaped: Sequence[_Shaped],
    column: Callable[[str, int], FloatArray],
) -> list[_Sub]:
    """What each regenerated column is to its fellows' estimates, over the rows where one
    of them is estimated (its period and warm-up) while it is replaced too: two dead
    sensors each feed the other's estimate a dead reading (the estimators assume their
    inputs healthy, Wang & Song's law 0). None of the detectors' estimators can leave out
    a second input with the model as fitted (the AR-Kalman bank's estimator of a sensor
    measures every other one; the detection filter and the equivalent model weigh fixed
    inputs), so the dead input is replaced by its own estimate instead: first the run's,
    then :data:`REGEN_PASSES` rounds of each computed again with the others' latest in
    place of their readings (Gauss-Seidel), the fitted faults taken out as well. The
    rows kept are those of the overlaps (and warm-ups) only, in ``column(name, rows)``
    (memory-mapped for a long archive), :data:`RELEASE_ROWS` at a time.

    The rounds converge only when the estimators' weights on each other multiply to less
    than one (:data:`REGEN_PASSES`); a round that changes the substitutes as much as the
    one before or more (two estimators weighing each other by 1.5, a linear
    extrapolation from the neighbours: 26 sd of error after three rounds, 1.5 from the
    dead readings) ends them, and none is used: each estimate takes the other's reading,
    as without this step."""
    subs: list[_Sub] = []
    for k in regen:
        spans = [
            (max(k.start, p.start - p.given[0]), min(k.stop, p.stop))
            for p in regen
            if p.j != k.j and p.given is not None
        ]
        spans = [(a, b) for a, b in spans if a < b]
        if not spans:
            continue
        lo, hi = min(a for a, _ in spans), max(b for _, b in spans)
        first = column(f"regenerated-input-{len(subs)}", hi - lo)
        for a in range(lo, hi, RELEASE_ROWS):
            b = min(hi, a + RELEASE_ROWS)
            rows = values[a:b]
            y = np.asarray(rows[:, k.j], dtype=np.float64)
            fs = _fault_piece(k.method, k.event, rate_hz, y, k.res, k.ref, a, b)
            first[a - lo : b - lo] = y - fs
            release(rows)
            release(first[a - lo : b - lo])
            for whole in (k.res, k.ref):
                release(None if whole is None else whole[a:b])
        subs.append(_Sub(k.j, lo, hi, first, k))
    change = float("inf")
    for _ in range(REGEN_PASSES if len(subs) > 1 else 0):
        moved = 0.0  # the round's sum of squared changes of the substitutes
        for sub in subs:
            again = _estimate_again(sub.plan.given, sub.j, shaped, sub.lo, sub.hi, subs)
            if again is None:
                continue
            for a in range(sub.lo, sub.hi, RELEASE_ROWS):
                b = min(sub.hi, a + RELEASE_ROWS)
                piece = sub.values[a - sub.lo : b - sub.lo]
                new = again(values, rate_hz, a, b)
                step = new - piece
                moved += float(np.sum(np.square(step[np.isfinite(step)])))
                piece[...] = new
                release(piece)
        if not moved < change:  # not contracting: the errors grow round by round
            return []
        change = moved
        if moved == 0.0:
            break
    return subs


def _residual_rows(
    plan: _Regen, values: npt.NDArray[Any], rate_hz: float
) -> Callable[[int, int], FloatArray]:
    """Rows ``a .. b - 1`` of the fault ``f_s`` that the regeneration of ``plan`` removes:
    the reading less the estimate that replaces it (computed again when it is), or the
    detector's residual for a ``residual`` correction of a detector whose residual is its
    own fault estimate."""

    def rows(a: int, b: int) -> FloatArray:
        y = values[a:b]
        if plan.again is None:
            out = _fault_piece(
                plan.method, plan.event, rate_hz, y[:, plan.j], plan.res, plan.ref, a, b
            )
        else:
            out = np.asarray(y[:, plan.j], dtype=np.float64) - plan.again(values, rate_hz, a, b)
        release(y)
        return out

    return rows


def _alive_stop(
    residual: Callable[[int, int], FloatArray],
    values: npt.NDArray[Any],
    plan: _Regen,
    healthy: tuple[int, int],
    rate_hz: float,
) -> int:
    """Where the regeneration of ``plan`` over ``[start, stop)`` ends: ``stop``, or an
    earlier ``k`` (a tail of at least :data:`TRIM_MIN_S`) from which the residual it
    removes (``residual(a, b)``) reads as the healthy window's and not as the fault's:
    the readings are alive again. The analogue of :func:`_trimmed_stop` for a reading
    whose fault has no shape: the two hypotheses are zero-mean Gaussian residuals with
    the healthy window's mean square ``s0`` (alive: the estimate's own error) and the
    period's ``s1`` (dead, stuck: the reading carries nothing); ``k`` minimizes the tail
    sum of the log-likelihood ratio ``d_t = (r_t^2 (1/s0 - 1/s1) - ln(s1/s0)) / 2``
    (negative where "alive" explains ``r_t`` better), which must be negative, and the
    tail's mean square must be at most :data:`REPLACE_FACTOR` ``s0``: by
    :func:`_worth_replacing`'s rule, the tail is not worth replacing. Only when
    ``s1 > REPLACE_FACTOR s0``. Read :data:`RELEASE_ROWS` rows at a time from the end;
    missing residuals count for neither.

    ``s1`` is the whole period's: where the signal is gone (a structure at rest) a dead
    or stuck reading's residual is the estimate's own error too, and "alive" wins without
    the readings saying anything. So the tail's readings (column ``plan.j`` of
    ``values``) must also vary about their mean by more than :data:`REPLACE_FACTOR`
    times the tail's mean square residual, as live readings that the estimate follows
    do; a dead sensor's finding that ran on into a quiet end was cut there, its zeros
    called alive."""
    start, stop = plan.start, plan.stop
    least = max(1, int(round(TRIM_MIN_S * rate_hz)))
    if stop - start < least:
        return stop

    def mean_square(a: int, b: int) -> float:
        total, count = 0.0, 0
        for p in range(a, b, RELEASE_ROWS):
            r = residual(p, min(b, p + RELEASE_ROWS))
            r = r[np.isfinite(r)]
            total, count = total + float(np.sum(r * r)), count + int(r.size)
        return total / count if count else float("nan")

    s0, s1 = mean_square(*healthy), mean_square(start, stop)
    if not (s0 > 0.0 and s1 > REPLACE_FACTOR * s0):
        return stop
    weight, bias = 0.5 * (1.0 / s0 - 1.0 / s1), 0.5 * float(np.log(s1 / s0))
    best, best_k, best_ms = 0.0, stop, float("nan")
    carry, squares, count = 0.0, 0.0, 0  # over the rows after the piece
    last = stop - least  # the latest tail's first row
    for b in range(stop, start, -RELEASE_ROWS):
        a = max(start, b - RELEASE_ROWS)
        r = np.asarray(residual(a, b), dtype=np.float64)
        ok = np.isfinite(r)
        r2 = np.where(ok, r, 0.0) ** 2
        d = np.where(ok, weight * r2 - bias, 0.0)
        tails = np.cumsum(d[::-1])[::-1] + carry
        sq = np.cumsum(r2[::-1])[::-1] + squares
        cnt = np.cumsum(ok[::-1])[::-1] + count
        if a <= last:
            valid = tails[: last - a + 1]
            i = int(np.argmin(valid))
            if valid[i] < best:
                best, best_k = float(valid[i]), a + i
                best_ms = float(sq[i] / cnt[i]) if cnt[i] else float("nan")
        carry, squares, count = float(tails[0]), float(sq[0]), int(cnt[0])
    if best_k == stop or not best_ms <= REPLACE_FACTOR * s0:
        return stop
    if not _spread(values, plan.j, best_k, stop) > REPLACE_FACTOR * best_ms:
        return stop  # (readings that do not move: dead or alive, they cannot tell)
    return best_k


def _spread(values: npt.NDArray[Any], j: int, a: int, b: int) -> float:
    """The variance of column ``j``'s finite readings over rows ``[a, b)`` (NaN when none),
    :data:`RELEASE_ROWS` rows at a time (two passes: the mean, then the squares about it)."""

    def pieces() -> Iterable[FloatArray]:
        for p in range(a, b, RELEASE_ROWS):
            rows = values[p : min(b, p + RELEASE_ROWS)]
            y = np.asarray(rows[:, j], dtype=np.float64)
            release(rows)
            yield y[np.isfinite(y)]

    total, count = 0.0, 0
    for y in pieces():
        total, count = total + float(np.sum(y)), count + int(y.size)
    if not count:
        return float("nan")
    mean = total / count
    return sum(float(np.sum(np.square(y - mean))) for y in pieces()) / count


def _revived_stop(
    values: npt.NDArray[Any],
    plan: _Regen,
    healthy: tuple[int, int],
    rate_hz: float,
    residual: Callable[[int, int], FloatArray],
) -> int | None:
    """Where the regeneration of ``plan`` over ``[start, stop)`` ends by the readings
    alone: the row ``k`` where column ``plan.j``'s readings go from dead to alive and
    stay alive to ``stop``, or None when they do not say so. :func:`_alive_stop` reads
    the reading less the estimate, and an estimate that carries another sensor's fault
    which no finding took out (a drift missed, or found 79 s late) leaves that residual
    above the healthy window's after the sensor came back, so the regeneration ran on
    over healthy readings (``sweep_corrected.py`` ``two-dead-drift`` seeds 3 and 7:
    0.124 and 0.133 sd of error there). The readings' own spread does not depend on the
    estimate: a dead reading varies by its gain (below ``MIN_GAIN``) times the live one,
    a stuck one not at all, and alive again the readings vary as in the healthy window.

    The period is split where its readings' spread changes most (:func:`_spread_split`);
    the split is a revival when the tail's readings vary by at least ``1 /``
    :data:`REPLACE_FACTOR` of the healthy window's variance ``v0`` (alive: a gain of
    0.71 or more) and the head's by at most ``MIN_GAIN`` times the tail's (dead: a gain
    under 0.32 of the tail's, or a dead reading whose finding began up to a tenth of its
    samples early). One split sees one change: a sensor dead at 10-20 s and 30-40 s
    and alive after was split at 20 s, and its second dead stretch kept as measured. So
    the tail is searched for a dead stretch, in blocks of :data:`TRIM_MIN_S` whose
    readings vary about their own mean by at most ``MIN_GAIN ** 2`` times the healthy
    window's blocks on average (a gain under ``MIN_GAIN``; a block's, as a block's
    variance depends on the signal's band, not only on its level), and the search
    starts again at the last one found. Of the 28 800 half-second blocks of the sweep's
    healthy records (8 seeds, 6 sensors) none was that quiet, the quietest at 0.021
    (``MIN_GAIN`` instead: 240 were, and a revived sensor's regeneration of
    ``two-dead-drift`` seed 3 went on to the finding's end). Readings
    that never vary by half the healthy spread again (a structure at rest) or die
    again to the period's end are not called alive here (:func:`_alive_stop` decides).
    A split at the latest row allowed (a tail of :data:`TRIM_MIN_S`) places a change
    that may lie later, with dead readings in the tail: a dead sensor whose finding
    ended 0.05-0.49 s after it came back kept up to 0.3 s of its dead readings as
    measured (54 of 222 such periods of the 3-sensor record of ``test_regenerate.py``;
    12 at 32233bd, where :func:`_alive_stop` alone decided, 6 now, all where it still
    does), so the period is then regenerated to its end (the estimate in place of at
    most that many live readings).
    A tail alive by the healthy window may be a weak reading of a structure that moves
    more than it did then: a gain of 0.2 (read as ``other``) whose structure's motion
    grew 3.5 times at the split was called alive and kept as measured (2.8 sd of error
    after it, 0.05 by the estimate), so the tail's readings must also vary, in blocks
    of :data:`TRIM_MIN_S` (a drift the estimate carries adds little to a half-second
    block), by at least ``1 /`` :data:`REPLACE_FACTOR` of the estimate's (the reading
    less ``residual(a, b)``: :func:`_residual_rows`) there, as the healthy window's.
    At most :data:`REVIVAL_SPLITS` splits, each four passes over what is left of the
    period, and one over the tail's estimate."""
    start, stop = plan.start, plan.stop
    least = max(1, int(round(TRIM_MIN_S * rate_hz)))
    v0 = _spread(values, plan.j, *healthy)
    if not v0 > 0.0:
        return None
    quiet = MIN_GAIN**2 * _block_variance(values, plan.j, *healthy, least)[1]
    a = start
    for _ in range(REVIVAL_SPLITS):
        split = _spread_split(values, plan.j, a, stop, v0, least)
        if split is None:
            return None
        k, head, tail = split
        if not (tail >= v0 / REPLACE_FACTOR and head <= MIN_GAIN * tail):
            return None
        if k == stop - least:  # (the change may lie in the last block: dead rows in it)
            return stop
        last, live = _block_variance(values, plan.j, k, stop, least, quiet)
        if last is None:  # alive from k to the period's end, if it moves as the estimate
            moves = _block_variance(values, plan.j, k, stop, least, less=residual)[1]
            return k if live >= moves / REPLACE_FACTOR else None
        a = last  # dead again there: alive (if ever) only after it
    return None


REVIVAL_SPLITS = 8
"""The most splits :func:`_revived_stop` makes of one period (a sensor that dies and
comes back eight times within one finding); past that the period is left to
:func:`_alive_stop` (a bound on the passes over a long archive, not a tuned number)."""


def _block_variance(
    values: npt.NDArray[Any],
    j: int,
    a: int,
    b: int,
    size: int,
    quiet: float = -1.0,
    less: Callable[[int, int], FloatArray] | None = None,
) -> tuple[int | None, float]:
    """Column ``j``'s readings (less ``less(p, q)``, rows ``p .. q - 1`` of what is
    taken out, when given) over rows ``[a, b)`` in blocks of ``size`` rows from
    ``a``, each block's variance about its own mean: the first row of the last block
    whose variance is at most ``quiet`` (None: none is), and the blocks' mean
    variance (NaN: no whole block). Only blocks of ``size`` finite readings count: the
    variance of a few consecutive readings of a live signal is that of a higher band
    (two readings 0.01 s apart of the 3-sensor record of ``test_regenerate.py``: 0.0027
    and 0.0038, under ``quiet``, 0.0052), so a period that ended 2 or 3 rows past a
    block, or a gap that left 2 or 3 readings in one, read as a dead stretch at its
    end and the revival was lost. :data:`RELEASE_ROWS` rows at a time (whole blocks)."""
    step = max(size, RELEASE_ROWS // size * size)
    last, total, blocks = None, 0.0, 0
    for p in range(a, b, step):
        q = min(b, p + step)
        rows = values[p:q]
        y = np.asarray(rows[:, j], dtype=np.float64)
        release(rows)
        if less is not None:
            y = y - less(p, q)
        pad = -y.size % size
        y = np.concatenate((y, np.full(pad, np.nan))).reshape(-1, size)
        ok = np.isfinite(y)
        count = ok.sum(axis=1)
        z = np.where(ok, y, 0.0)
        mean = z.sum(axis=1) / np.maximum(count, 1)
        var = np.where(ok, z - mean[:, None], 0.0) ** 2
        var = var.sum(axis=1) / np.maximum(count, 1)
        full = count == size  # (a short block of a live signal varies by its band)
        total, blocks = total + float(np.sum(var[full])), blocks + int(np.sum(full))
        hits = np.flatnonzero(full & (var <= quiet))
        if hits.size:
            last = p + int(hits[-1]) * size
    return last, (total / blocks if blocks else float("nan"))


def _spread_split(
    values: npt.NDArray[Any], j: int, start: int, stop: int, scale: float, least: int
) -> tuple[int, float, float] | None:
    """The maximum-likelihood split of column ``j``'s readings over ``[start, stop)``
    into two Gaussian segments, each with its own mean and variance (a change of the
    variance with the mean free, so that a reading stuck at any value reads as quiet):
    the row ``k`` (a head and a tail of at least ``least`` rows) that minimizes
    ``n1 ln v1 + n2 ln v2`` over the head's and the tail's ``n`` finite readings and
    variances, with the two variances (at least ``1e-12 * scale``: a reading stuck
    exactly has none); None when the period is too short.

    The head's sums are taken about the period's first finite reading and the tail's
    about its last, each added up from its own end of the period, never one total less
    the other: with a single shift (the healthy mean), a head stuck at 1e6 beside live
    readings of sd 1 near 0 left the tail's variance as the difference of sums of
    1e15, and the floor that kept ``ln 0`` out (relative to the period's mean square,
    2e11) read the stuck head as varying by 0.2: the revival was lost and the
    regeneration ran to the finding's end. :data:`RELEASE_ROWS` rows at a time: the
    two shifts (a piece at each end, unless all missing), each piece's tail sums, then
    the running sums from both ends."""
    if stop - start < 2 * least:
        return None
    pieces = range(start, stop, RELEASE_ROWS)

    def column(p: int) -> FloatArray:
        rows = values[p : min(stop, p + RELEASE_ROWS)]
        y = np.asarray(rows[:, j], dtype=np.float64)
        release(rows)
        return y

    ends = []  # the first finite reading from the period's start, the last before its end
    for order, end in ((pieces, 0), (reversed(pieces), -1)):
        for p in order:
            y = column(p)
            y = y[np.isfinite(y)]
            if y.size:
                ends.append(float(y[end]))
                break
    if len(ends) < 2:
        return None
    head_shift, tail_shift = ends
    sums = []  # per piece: count, sum and squares of its finite readings less tail_shift
    for p in pieces:
        y = column(p)
        t = y[np.isfinite(y)] - tail_shift
        sums.append((int(t.size), float(np.sum(t)), float(np.sum(t * t))))
    if sum(s[0] for s in sums) < 4:
        return None
    after = [(0, 0.0, 0.0)]  # per piece: the same over the rows after it
    for piece in sums[:0:-1]:
        after.append((after[-1][0] + piece[0], after[-1][1] + piece[1], after[-1][2] + piece[2]))
    after.reverse()
    floor = 1e-12 * scale
    best, got = float("inf"), None
    count, head, head_sq = 0, 0.0, 0.0  # over the rows before the piece
    for p, rest in zip(pieces, after, strict=True):
        y = column(p)
        ok = np.isfinite(y)
        h = np.where(ok, y - head_shift, 0.0)
        t = np.where(ok, y - tail_shift, 0.0)
        # the head before row p + i: the rows before the piece and the piece's first i;
        # the tail from row p + i: the piece's rows from i and the rows after the piece
        c1 = count + np.concatenate(([0], np.cumsum(ok)[:-1]))
        s1 = head + np.concatenate(([0.0], np.cumsum(h)[:-1]))
        q1 = head_sq + np.concatenate(([0.0], np.cumsum(h * h)[:-1]))
        c2 = rest[0] + np.cumsum(ok[::-1])[::-1]
        s2 = rest[1] + np.cumsum(t[::-1])[::-1]
        q2 = rest[2] + np.cumsum((t * t)[::-1])[::-1]
        at = np.arange(p, p + y.size)
        valid = (at >= start + least) & (at <= stop - least) & (c1 >= 2) & (c2 >= 2)
        if np.any(valid):
            c1, s1, q1, c2, s2, q2 = (x[valid] for x in (c1, s1, q1, c2, s2, q2))
            v1 = np.maximum(q1 / c1 - (s1 / c1) ** 2, floor)
            v2 = np.maximum(q2 / c2 - (s2 / c2) ** 2, floor)
            cost = c1 * np.log(v1) + c2 * np.log(v2)
            k = int(np.argmin(cost))
            if cost[k] < best:
                best, got = float(cost[k]), (int(at[valid][k]), float(v1[k]), float(v2[k]))
        count, head = count + int(np.sum(ok)), head + float(np.sum(h))
        head_sq += float(np.sum(h * h))
    return got


REPLACE_FACTOR = 2.0
"""A reading is replaced by a detector's estimate only when its residual's mean square
over the fault is more than this many times the healthy window's: the residual there is
the estimate's own error (and the noise); over the fault it adds the fault's, and the
estimate is the better reading only when the fault's share is the larger."""


def _worth_replacing(
    values: npt.NDArray[Any],
    j: int,
    res: npt.NDArray[Any] | None,
    ref: npt.NDArray[Any] | None,
    healthy: tuple[int, int],
    period: tuple[int, int],
) -> str | None:
    """None when replacing column ``j``'s readings over ``period`` by the estimate
    (``ref``, or the reading less ``res``) makes them better (:data:`REPLACE_FACTOR`),
    else why they are left as measured."""

    def mean_square(a: int, b: int) -> tuple[float, int]:
        total, count = 0.0, 0
        for p in range(a, b, RELEASE_ROWS):
            q = min(b, p + RELEASE_ROWS)
            if res is not None:
                r = np.asarray(res[p:q], dtype=np.float64)
            else:
                assert ref is not None
                rows = values[p:q]
                r = np.asarray(rows[:, j], dtype=np.float64) - np.asarray(
                    ref[p:q], dtype=np.float64
                )
                release(rows)
            r = r[np.isfinite(r)]
            total += float(np.sum(r * r))
            count += int(r.size)
            for whole in (res, ref):
                release(None if whole is None else whole[p:q])
        return (total / count if count else float("nan")), count

    base, n_base = mean_square(*healthy)
    fault, n_fault = mean_square(*period)
    if n_base < 2 or n_fault < 1 or not base > 0 or fault > REPLACE_FACTOR * base:
        return None
    return (
        f"left as measured: the estimate's own error (RMS {np.sqrt(base):.4g} over the healthy "
        f"window) is as large as the fault's (the residual's RMS {np.sqrt(fault):.4g} over it)"
    )


def healthy_stretch(
    events: Iterable[FaultLike],
    n: int,
    rate_hz: float,
    start: int,
    margin: int,
    least: int,
) -> tuple[int, int] | None:
    """The rows ``[a, b)`` of a record of ``n`` that :func:`corrected_values` may take as
    its ``healthy`` window where the run has none (``--model``: its window is the
    filters' warm-up): the longest stretch from row ``start`` on where no event is
    active, each event's period (:func:`_period`; to the record's end when it has no
    end) widened by ``margin`` rows either side (of equally long ones the earliest),
    when it holds at least ``least`` rows; None otherwise.

    What :func:`corrected_values` reads there is the estimate's own error (the residual's
    mean square) and the readings' spread, each a sensor's under the record's own
    excitation; a fault, or the filters carrying one after its end (or an onset found a
    little late), would pass for healthy spread there, hence the margin."""
    busy = sorted(
        (max(0, a - margin), min(n, b + margin))
        for a, b in (_period(ev, n, rate_hz) for ev in events)
    )
    best: tuple[int, int] | None = None
    at = max(0, start)
    for a, b in [*busy, (n, n)]:
        if a > at and (best is None or a - at > best[1] - best[0]):
            best = (at, a)
        at = max(at, b)
    return best if best is not None and best[1] - best[0] >= max(1, least) else None


def write_corrected_csv(
    path: str | Path,
    t_s: FloatArray | Callable[[int, int], FloatArray],
    channels: Sequence[str],
    corrected: FloatArray,
    utc: tuple[int, float] | None = None,
) -> Path:
    """Write ``time`` (seconds) and every channel of ``corrected`` as CSV: shortest
    round-trip floats, an empty cell for a gap (as ``analyzer export``); written to a
    temporary name and renamed, so a reader never sees half a file. ``t_s``: the time
    column, or a function of ``(a, b)`` that gives rows ``a .. b - 1`` of it. The rows are
    written :data:`RELEASE_ROWS` at a time with the pages of a mapped ``corrected`` given
    back, so a long archive takes memory set by that piece. ``utc``: ``(start_ns,
    rate_hz)`` of the record's clock, for a last column ``utc`` holding row ``k``'s time
    ``start_ns + k / rate_hz`` as ISO-8601 UTC (``run --corrected --utc``: ``time``
    counts from the first sample, a date appears nowhere else in the file). A channel
    name a spreadsheet would take for a formula is written with a ``'`` in front
    (:func:`~analyzer.outdir.spreadsheet_safe`). An error writing it names ``path``
    (:func:`analyzer.outdir.named_error`)."""
    import pyarrow as pa
    import pyarrow.csv as pcsv

    p = Path(path)
    n = int(np.shape(corrected)[0]) if np.ndim(corrected) == 2 else -1
    column = None if callable(t_s) else np.asarray(t_s, dtype=np.float64)

    def times(a: int, b: int) -> FloatArray:
        return column[a:b] if column is not None else np.asarray(t_s(a, b))  # type: ignore[operator]

    length = n if column is None else int(column.shape[0])
    if np.ndim(corrected) != 2 or n != length or np.shape(corrected)[1] != len(channels):
        raise ValueError(
            f"expected a ({length}, {len(channels)}) array for the corrected channels, "
            f"got {np.shape(corrected)}"
        )
    names = ["time", *channels]
    if len(set(names + (["utc"] if utc else []))) != len(names) + bool(utc):
        raise ValueError(f"duplicate column names in {names}{' and utc' if utc else ''}")
    # the header's names as text a spreadsheet does not evaluate (the cells below are numbers)
    schema = pa.schema([(spreadsheet_safe(name), pa.float64()) for name in names])
    if utc is not None:
        schema = schema.append(pa.field("utc", pa.string()))
        unit = exact_unit(*utc)
    p.parent.mkdir(parents=True, exist_ok=True)
    tmp = p.with_name(f".{p.name}.part")
    try:
        with pcsv.CSVWriter(str(tmp), schema) as writer:
            for a in range(0, max(n, 1), RELEASE_ROWS):
                b = min(n, a + RELEASE_ROWS)
                rows = np.asarray(corrected[a:b], dtype=np.float64)
                cols = [pa.array(np.asarray(times(a, b), dtype=np.float64))] + [
                    pa.array(rows[:, j], from_pandas=True) for j in range(rows.shape[1])
                ]
                if utc is not None:
                    k = np.arange(a, b, dtype=np.int64)
                    ns = utc[0] + np.round(k * (NS_PER_S / utc[1])).astype(np.int64)
                    cols.append(pa.array(iso_times(ns, unit)))
                writer.write_table(pa.Table.from_arrays(cols, schema=schema))
                release(corrected[a:b])
        os.replace(tmp, p)
    except OSError as err:  # (pyarrow's words name no file: the line names ``path``)
        raise named_error(err, p) from err
    finally:
        tmp.unlink(missing_ok=True)
    return p


__all__ = [
    "MIN_GAIN",
    "Correction",
    "Estimates",
    "FaultLike",
    "corrected_values",
    "fault_signal",
    "healthy_stretch",
    "result_signals",
    "write_corrected_csv",
]
