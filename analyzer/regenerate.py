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

:func:`corrected_values` returns the corrected array and one JSON-friendly record per
correction; :func:`write_corrected_csv` writes the time column and every analyzed channel
(``analyzer run --corrected``).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from analyzer.types import FaultType

FloatArray = npt.NDArray[np.float64]

MIN_GAIN = 0.1
"""Below this |gain| a multiplicative fault is treated as a dead sensor: dividing by the gain
would amplify noise more than tenfold, so the fault-free estimate is used instead."""


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

    def as_dict(self) -> dict[str, Any]:
        return {
            "channel": self.channel,
            "detector": self.detector,
            "type": self.type,
            "start_s": self.start_s,
            "end_s": self.end_s,
            "method": self.method,
            "samples": self.samples,
            "mean_fault": self.mean_fault,
            "rms_fault": self.rms_fault,
            "note": self.note,
        }


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
    n = y.shape[0]
    start = int(np.clip(round(event.onset_s * rate_hz), 0, n))
    stop = n if event.end_s is None else int(np.clip(round(event.end_s * rate_hz), start, n))
    seg = slice(start, stop)
    mag = event.magnitude or {}
    kind = FaultType(event.type)
    if kind is FaultType.ADDITIVE and "offset" in mag:
        return start, stop, np.full(stop - start, float(mag["offset"])), "offset"
    if kind is FaultType.DRIFT and "rate_per_s" in mag:
        tau = (np.arange(start, stop) - event.onset_s * rate_hz) / rate_hz
        return start, stop, float(mag["rate_per_s"]) * np.maximum(tau, 0.0), "drift"
    if kind is FaultType.MULTIPLICATIVE and "gain" in mag and abs(float(mag["gain"])) >= MIN_GAIN:
        g = float(mag["gain"])
        return start, stop, y[seg] * (1.0 - 1.0 / g), "gain"
    if kind is FaultType.MULTIPLICATIVE and reference is not None:
        ref = np.asarray(reference, dtype=np.float64)[seg]
        return start, stop, y[seg] - ref, "reference"
    if residual is not None:
        return start, stop, np.asarray(residual, dtype=np.float64)[seg].copy(), "residual"
    if reference is not None:
        ref = np.asarray(reference, dtype=np.float64)[seg]
        return start, stop, y[seg] - ref, "reference"
    return start, stop, None, "skipped"


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


def _lookup(m: SignalMap | None, detector: str, channel: str) -> FloatArray | None:
    if m is None:
        return None
    got = m.get((detector, channel))  # type: ignore[call-overload]
    if got is None:
        got = m.get(channel)  # type: ignore[call-overload]
    return None if got is None else np.asarray(got, dtype=np.float64)


def corrected_values(
    values: FloatArray,
    channels: Sequence[str],
    rate_hz: float,
    events: Iterable[FaultLike],
    residuals: SignalMap | None = None,
    references: SignalMap | None = None,
) -> tuple[FloatArray, list[dict[str, Any]]]:
    """``values`` (N, m) with every event's fault removed over its period
    (``S_fault_free = S_fault - f_s``, Section 6.3), and one record per event.

    ``residuals`` / ``references`` give the residual (measured - estimated) and fault-free
    estimate of the detector whose event is corrected, keyed by channel or by
    ``(detector, channel)`` (:func:`result_signals`; for merged findings the finding's
    ``detector`` is its leading detector). When two events of a channel overlap, samples
    already corrected are not corrected again (the more confident event first)."""
    out = np.array(values, dtype=np.float64, copy=True)
    if out.ndim != 2 or out.shape[1] != len(channels):
        raise ValueError(
            f"expected a (N, {len(channels)}) array for {len(channels)} channels, got {out.shape}"
        )
    index = {c: j for j, c in enumerate(channels)}
    done = np.zeros(out.shape, dtype=bool)
    records: list[dict[str, Any]] = []
    evs = sorted(events, key=lambda e: -float(getattr(e, "confidence", 0.0)))
    for ev in evs:

        def record(
            method: str,
            samples: int = 0,
            mean: float | None = None,
            rms: float | None = None,
            note: str = "",
            ev: FaultLike = ev,
        ) -> dict[str, Any]:
            end = None if ev.end_s is None else float(ev.end_s)
            return Correction(
                ev.channel,
                ev.detector,
                FaultType(ev.type).value,
                float(ev.onset_s),
                end,
                method,
                samples,
                mean,
                rms,
                note,
            ).as_dict()

        j = index.get(ev.channel)
        if j is None:
            records.append(record("skipped", note="channel not analyzed"))
            continue
        res = _lookup(residuals, ev.detector, ev.channel)
        ref = _lookup(references, ev.detector, ev.channel)
        start, stop, fs, method = fault_signal(ev, values[:, j], rate_hz, res, ref)
        if fs is None:
            records.append(record(method, note="no fault model, residual or reference"))
            continue
        col = out[start:stop, j]
        ok = np.isfinite(fs) & np.isfinite(col) & ~done[start:stop, j]
        col[ok] = col[ok] - fs[ok]
        done[start:stop, j] |= ok
        used = fs[ok]
        note = ""
        if ok.sum() < stop - start:
            left = stop - start - int(ok.sum())
            note = f"{left} samples left as measured (gap or already corrected)"
        records.append(
            record(
                method,
                int(ok.sum()),
                float(np.mean(used)) if used.size else None,
                float(np.sqrt(np.mean(used * used))) if used.size else None,
                note,
            )
        )
    return out, records


def write_corrected_csv(
    path: str | Path, t_s: FloatArray, channels: Sequence[str], corrected: FloatArray
) -> Path:
    """Write ``time`` (seconds) and every channel of ``corrected`` as CSV: shortest
    round-trip floats, an empty cell for a gap (as ``analyzer export``); written to a
    temporary name and renamed, so a reader never sees half a file."""
    import pyarrow as pa
    import pyarrow.csv as pcsv

    p = Path(path)
    t = np.asarray(t_s, dtype=np.float64)
    data = np.asarray(corrected, dtype=np.float64)
    if data.ndim != 2 or data.shape != (t.shape[0], len(channels)):
        raise ValueError(
            f"expected a ({t.shape[0]}, {len(channels)}) array for the corrected channels, "
            f"got {data.shape}"
        )
    names = ["time", *channels]
    if len(set(names)) != len(names):
        raise ValueError(f"duplicate column names in {names}")
    cols = [pa.array(t)] + [pa.array(data[:, j], from_pandas=True) for j in range(data.shape[1])]
    table = pa.Table.from_arrays(cols, names=names)
    p.parent.mkdir(parents=True, exist_ok=True)
    tmp = p.with_name(f".{p.name}.part")
    try:
        pcsv.write_csv(table, str(tmp))
        os.replace(tmp, p)
    finally:
        tmp.unlink(missing_ok=True)
    return p


__all__ = [
    "MIN_GAIN",
    "Correction",
    "FaultLike",
    "corrected_values",
    "fault_signal",
    "result_signals",
    "write_corrected_csv",
]
