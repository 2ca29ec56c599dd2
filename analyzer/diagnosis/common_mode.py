"""Is a sensor's slow change every sensor's? Temperature, or a shared supply.

A slow change common to every channel of a group (the structure warming, and with it
every sensor's zero; a supply that every sensor shares) was blamed on one sensor: on a
simulated 6-sensor building whose every channel drifts by one standard deviation over
10 minutes, the equivalent model reported a drift of s2 from 149 s, and one fault at a
time took the bank's drifts of s4 and s5 and its offsets of s0 and s1 for it (16
channels: 1 to 7 such findings a run, most of two detectors). At the instant of the
onset no relation between the channels is broken (every leave-one-out estimator of the
bank is consistent: the relative test that tells a change of the whole structure does
not apply), so the detectors cannot tell; the channels' own slow levels can. Cross,
Worden & Chen (2011) remove such environmental trends as the direction common to the
channels (cointegration); here the common trend is only used to judge a finding.

The test, for each drift or offset finding on channel ``j`` (:func:`common_changes`):

1. Every channel's **slow level**: its means over blocks of ``L`` rows, the training
   window cut into :data:`~analyzer.diagnosis.training_check.BATCHES` blocks (the same
   batches :mod:`~analyzer.diagnosis.training_check` judges the window by; a block of
   several periods of the structure's first mode averages its vibration out). In units
   of the channel's **healthy slow scatter**: the training blocks' scatter about their
   own straight line (a trend inside the window is not scatter), with the AR(1)
   long-run factor ``(1 + rho) / (1 - rho)`` of their lag-1 correlation, as the
   window's check uses; ``y_c = (x_c - mean_c) / scale_c`` with the training mean.
2. The finding's **shape** ``h``: a step over the finding's span (an offset), or a line
   from its onset (a drift), in blocks. On every channel ``c`` of ``j``'s group the
   matched statistic ``T_c = sum h y_c / se`` (``se`` with the training mean's own
   error: ``sqrt(infl (sum h^2 + (sum h)^2 / B))``, ``B`` training blocks) follows
   Student's t with ``B - 2`` degrees of freedom on a healthy channel. The channels
   where ``|T_c|`` passes the two-sided bound at
   :data:`~analyzer.diagnosis.training_check.COMMON_ALPHA` with the sign of ``T_j`` share
   the change. It is **common** to the group when they are at least :data:`MIN_SHARED`
   and more than half of the group's channels (``j`` among them).
3. But a sensor's own fault on top of a common change must stay (an offset of 2 sd on
   one sensor of a drifting building). Each other sharing channel ``c`` is asked
   whether it **explains** ``j``: ``y_j`` is regressed on a constant, a line and ``y_c``,
   and then on each of the shapes ``j`` may have of its own (Frisch-Waugh-Lovell): the
   finding's ``h`` (one-sided, in ``j``'s direction, at the same level) and a step and a
   kink from every block inside the finding's span (two-sided, Bonferroni over them;
   a lasting offset from 365 s on a drifting channel was reported as a drift from
   208 s, a shape the common trend explains). The t statistics are about the
   regression's residual scatter, corrected by its AR(1) factor. ``c`` explains ``j``
   when none passes. The finding is a common change, not reported (a note says so),
   when more than half of the others explain it; a single trace (their median) stepped
   with another sensor's real fault and kept every false finding beside it. The line is
   there because ``y_c`` carries two common parts in other proportions: the structure's
   slow vibration, the same on every floor, and the trend, in each sensor's own units
   (read with the vibration's proportion, a common drift of one standard deviation
   left a line of ``j``'s own that a drift from 120 s took up at ``t`` 7.4). A drift of
   ``j`` from its own onset is no line from the record's start: half the common rate,
   from the window's end, stayed on every simulated record tried.

The findings are judged as the detectors report them, before one fault at a time
(:func:`~analyzer.diagnosis.merge.one_fault_at_a_time`) takes the faults of the sensors
modelled together for one: each is judged on its own channel's reading, and a real
fault that a common change's finding would have taken stays.

Two genuine faults at once on two sensors of six (or of four) are not most of a group:
they stay. A group of fewer than :data:`MIN_SHARED` channels is not judged (a change of
two sensors at once is as likely two faults as one cause).

Cost: one pass over the record's rows of the groups that have such a finding (block sums
in chunks): 16 channels, one hour at 100 Hz: see :func:`common_changes`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import special

from analyzer.diagnosis.merge import Finding
from analyzer.diagnosis.training_check import (
    BATCHES,
    COMMON_ALPHA,
    MAX_RHO,
    MIN_BATCH_ROWS,
    MIN_BATCHES,
    WindowNote,
)
from analyzer.errors import capped
from analyzer.timeutil import short_seconds, spoken_duration
from analyzer.types import FaultType

FloatArray = npt.NDArray[np.float64]

MIN_SHARED = 3
"""Fewest channels (the finding's among them) that must share a change for it to be
common: two sensors that change together may be two faults."""

CHUNK_ROWS = 1 << 18
"""Rows read at once to sum the blocks (a long record is a memory-mapped matrix)."""


@dataclass(frozen=True, slots=True)
class SlowLevels:
    """The channels' block means in units of their healthy slow scatter.

    ``y``: ``(blocks, channels)``, NaN where a block has no finite value; ``centre_s``:
    each block's middle (seconds from the first row); ``rows``: the block length;
    ``first``: the first block's first row; ``inflation``: each channel's AR(1) factor;
    ``trained``: the number of training blocks (their mean is 0)."""

    y: FloatArray
    centre_s: FloatArray
    rows: int
    first: int
    rate_hz: float
    inflation: FloatArray
    trained: int

    @classmethod
    def build(
        cls,
        values: npt.NDArray[Any],
        cols: Sequence[int],
        train: tuple[int, int],
        rate_hz: float,
        batches: int = BATCHES,
    ) -> SlowLevels | None:
        """The slow levels of the columns ``cols`` of ``values`` (rows x channels), the
        blocks aligned on the training window ``train`` (rows), or None when the window
        holds fewer than ``MIN_BATCHES`` blocks of ``MIN_BATCH_ROWS`` rows, or a
        channel is flat or missing in it."""
        a, b = train
        length = max(MIN_BATCH_ROWS, (b - a) // batches)
        trained = (b - a) // length
        if trained < MIN_BATCHES:
            return None
        n = values.shape[0]
        first = a % length
        count = (n - first) // length
        cols = list(cols)
        sums = np.zeros((count, len(cols)))
        finite = np.zeros((count, len(cols)))
        step = max(1, CHUNK_ROWS // length)
        every = cols == list(range(values.shape[1]))  # (no copy of a column subset)
        for k in range(0, count, step):
            k1 = min(count, k + step)
            rows = values[first + k * length : first + k1 * length]
            block = np.asarray(rows if every else rows[:, cols], dtype=np.float64)
            block = block.reshape(k1 - k, length, len(cols))
            total = block.sum(axis=1)
            if np.isfinite(total).all():  # no gap: the plain sums
                sums[k:k1], finite[k:k1] = total, length
                continue
            ok = np.isfinite(block)
            sums[k:k1] = np.where(ok, block, 0.0).sum(axis=1)
            finite[k:k1] = ok.sum(axis=1)
        # a block with fewer than half its rows is no level (a gap's edge)
        x = np.where(finite >= length / 2, sums / np.maximum(finite, 1.0), np.nan)
        lo = (a - first) // length
        window = x[lo : lo + trained]
        if not np.isfinite(window).all():
            return None
        centre = np.arange(trained) - (trained - 1) / 2.0
        slope = centre @ (window - window.mean(axis=0)) / (centre @ centre)
        dev = window - window.mean(axis=0) - np.outer(centre, slope)
        scale = np.sqrt((dev * dev).sum(axis=0) / (trained - 2))
        if not np.all(scale > 0):
            return None
        lag = (dev[1:] * dev[:-1]).sum(axis=0) / (dev * dev).sum(axis=0)
        rho = np.clip(lag, 0.0, MAX_RHO)
        y = (x - window.mean(axis=0)) / scale
        centre_s = (first + (np.arange(count) + 0.5) * length) / rate_hz
        return cls(y, centre_s, length, first, rate_hz, (1.0 + rho) / (1.0 - rho), trained)

    def shape(self, f: Finding) -> FloatArray:
        """The finding's shape over the blocks: 1 over its span (an offset; a block the
        span covers in part, in part), or its line from the onset (a drift, in seconds)."""
        t0 = f.onset_s
        t1 = np.inf if f.end_s is None else f.end_s
        half = 0.5 * self.rows / self.rate_hz
        lo, hi = self.centre_s - half, self.centre_s + half
        if f.type is FaultType.DRIFT:
            return np.clip(np.minimum(self.centre_s, t1) - t0, 0.0, None)
        covered = np.clip(np.minimum(hi, t1) - np.maximum(lo, t0), 0.0, None)
        return covered / (hi - lo)

    def scan(self, f: Finding) -> FloatArray:
        """A step and a line (a kink) from each block that begins inside the finding's
        span, the last two blocks apart: the changes of its own that ``j`` may have
        there, whatever the detectors' onset and shape (a lasting offset from 365 s on
        a channel that drifts with the others was reported as a drift from 208 s)."""
        t1 = np.inf if f.end_s is None else f.end_s
        start = self.centre_s - 0.5 * self.rows / self.rate_hz
        at = np.flatnonzero((start >= f.onset_s) & (start < t1))
        at = at[at < start.size - 2]
        step = (np.arange(start.size)[:, None] >= at[None, :]).astype(np.float64)
        kink = np.clip(self.centre_s[:, None] - start[None, at], 0.0, None)
        return np.concatenate([step, kink], axis=1)

    def critical(self, alpha: float = COMMON_ALPHA) -> float:
        """The two-sided bound at ``alpha`` of a t statistic with the training blocks'
        degrees of freedom."""
        return _t_bound(self.trained - 2, alpha)

    def matched(self, h: FloatArray) -> FloatArray:
        """Each channel's statistic ``T_c`` of the shape ``h`` (module docstring, step 2)."""
        ok = np.isfinite(self.y)
        hy = np.where(ok, self.y, 0.0).T @ h
        hh = (ok * (h * h)[:, None]).sum(axis=0)
        sh = (ok * h[:, None]).sum(axis=0)
        se = np.sqrt(self.inflation * (hh + sh * sh / self.trained))
        return np.divide(hy, se, out=np.zeros_like(hy), where=se > 0)

    def beyond(self, j: int, shared: Sequence[int], shapes: FloatArray) -> tuple[FloatArray, int]:
        """The t statistics of each column of ``shapes`` (blocks x K), added alone to the
        regression of ``y_j`` on a constant, a line and the median ``y`` of the channels
        ``shared`` (step 3; Frisch-Waugh-Lovell: each shape and ``y_j`` made orthogonal
        to those three once), and their degrees of freedom."""
        g = np.nanmedian(self.y[:, list(shared)], axis=1)
        y = self.y[:, j]
        ok = np.isfinite(y) & np.isfinite(g)
        t = self.centre_s[ok] - self.centre_s[ok].mean()
        base = np.stack([np.ones(t.size), t, g[ok]], axis=1)
        q, _ = np.linalg.qr(base)
        ry = y[ok] - q @ (q.T @ y[ok])
        rh = shapes[ok] - q @ (q.T @ shapes[ok])
        hh = np.einsum("bk,bk->k", rh, rh)
        dof = t.size - base.shape[1] - 1
        if dof < 2:
            return np.full(shapes.shape[1], np.inf), 1
        hh = np.maximum(hh, np.finfo(np.float64).tiny)
        coef = rh.T @ ry / hh
        s2 = np.maximum(float(ry @ ry) - coef * coef * hh, 0.0) / dof
        # the residuals' lag-1 correlation (without any shape: the common trend's misfit)
        rho = float(np.clip(ry[1:] @ ry[:-1] / max(float(ry @ ry), 1e-300), 0.0, MAX_RHO))
        se = np.sqrt(s2 / hh * (1.0 + rho) / (1.0 - rho))
        return np.divide(coef, se, out=np.full_like(coef, np.inf), where=se > 0), dof

    def explains(
        self, c: int, j: int, h: FloatArray, sign: float, alpha: float, scan: FloatArray
    ) -> bool:
        """Whether channel ``c``'s slow level explains ``j``'s (a constant, a line and
        ``c``'s level times a factor) with no change of ``j``'s own: neither along the
        shape ``h`` in the direction ``sign`` (bound at ``alpha``) nor a step or kink of
        ``scan`` (Bonferroni over them)."""
        stats, dof = self.beyond(j, [c], np.column_stack([h, scan]))
        own = float(np.max(np.abs(stats[1:]), initial=0.0))
        return bool(
            sign * stats[0] < _t_bound(dof, alpha)
            and own < _t_bound(dof, alpha / max(scan.shape[1], 1))
        )


@dataclass(frozen=True, slots=True)
class CommonChange:
    """A finding judged a common change: ``shared`` the channels whose slow level follows
    its shape (``j``'s among them) out of ``group``; ``spread`` the smallest and largest
    ``|T_c|`` of those, over ``critical``; ``explained``: how many of the other sharing
    channels explain ``j``'s slow level with no change of ``j``'s own."""

    finding: Finding
    shared: tuple[str, ...]
    group: tuple[str, ...]
    spread: tuple[float, float]
    critical: float
    explained: int
    block_s: float


def judge(
    f: Finding, j: int, levels: SlowLevels, names: Sequence[str], alpha: float = COMMON_ALPHA
) -> CommonChange | None:
    """Whether finding ``f`` on column ``j`` of ``levels`` is a change common to the
    channels ``names`` (the columns of ``levels``) that ``j``'s own reading does not
    exceed (module docstring, steps 2-3), or None."""
    h = levels.shape(f)
    if not np.any(h > 0):
        return None
    t = levels.matched(h)
    crit = levels.critical(alpha)
    if abs(t[j]) < crit:
        return None  # the reading's slow level does not show the shape: not judged here
    sign = np.sign(t[j])
    shared = [c for c in range(t.size) if sign * t[c] >= crit]
    if len(shared) < MIN_SHARED or 2 * len(shared) <= t.size:
        return None
    others = [c for c in shared if c != j]
    explained = sum(levels.explains(c, j, h, sign, alpha, levels.scan(f)) for c in others)
    if 2 * explained <= len(others):
        return None  # j changed beyond the others': one sensor's fault stays
    return CommonChange(
        finding=f,
        shared=tuple(names[c] for c in shared),
        group=tuple(names),
        spread=(float(np.min(np.abs(t[shared]))), float(np.max(np.abs(t[shared])))),
        critical=crit,
        explained=explained,
        block_s=levels.rows / levels.rate_hz,
    )


def _t_bound(dof: int, alpha: float) -> float:
    """The two-sided bound at ``alpha`` of a t statistic with ``dof`` degrees of freedom."""
    return float(-special.stdtrit(dof, alpha / 2.0))


JUDGED = (FaultType.ADDITIVE, FaultType.DRIFT)
"""The finding types judged: the shapes of a slow common change (a gain change or an
``other`` fault is the sensor's own)."""


def common_changes(
    findings: Sequence[Finding],
    values: npt.NDArray[Any],
    channels: Sequence[str],
    groups: Sequence[Sequence[str]],
    train: tuple[int, int],
    rate_hz: float,
) -> tuple[list[Finding], list[str]]:
    """``findings`` less those that are a slow change common to most channels of their
    group (module docstring), and a note (a :class:`CommonNote`) per group that had such
    findings. ``values``: the aligned matrix (rows x ``channels``); ``groups``: the
    channels modelled together (a finding is judged in the largest that holds its
    channel: the detectors' results, one per group and detector, some of a group's
    channels only); ``train``: the healthy window's rows. The slow levels are computed
    only for groups with a drift or offset finding.

    Measured (CPU time, one BLAS thread): 16 channels, one hour at 100 Hz: 17 ms with
    one finding judged, 30 ms with two."""
    index = {c: k for k, c in enumerate(channels)}
    judged: dict[tuple[str, ...], list[CommonChange]] = {}
    levels: dict[tuple[str, ...], SlowLevels | None] = {}
    out: list[Finding] = []
    for f in findings:
        holding = [tuple(c for c in g if c in index) for g in groups if f.channel in g]
        names = max(holding, key=len, default=())
        if f.type not in JUDGED or len(names) < MIN_SHARED:
            out.append(f)
            continue
        if names not in levels:
            levels[names] = SlowLevels.build(values, [index[c] for c in names], train, rate_hz)
        lv = levels[names]
        verdict = None if lv is None else judge(f, names.index(f.channel), lv, names)
        if verdict is None:
            out.append(f)
        else:
            judged.setdefault(names, []).append(verdict)
    return out, [common_note(v) for v in judged.values()]


LISTED = 4
"""Findings a note names one by one; the rest are counted."""


class CommonNote(WindowNote):
    """A note of this check: like the training window's notes, its ``short`` form is
    repeated on stderr by ``analyzer run`` (a finding it removed changes the exit code:
    a user who reads only that and stderr must hear why)."""


def common_note(changes: Sequence[CommonChange]) -> CommonNote:
    """The note on the findings of one group judged a common change."""
    ordered = sorted(changes, key=lambda c: (c.finding.onset_s, c.finding.channel))
    first = ordered[0]
    widest = max(changes, key=lambda c: len(c.shared))
    n, m = len(widest.shared), len(widest.group)
    what = capped(
        [
            f"the {c.finding.type.value} fault on {c.finding.channel} from "
            f"{short_seconds(c.finding.onset_s)} s ({'+'.join(_detectors(c.finding))})"
            for c in ordered
        ],
        LISTED,
    )
    lo = min(c.spread[0] for c in changes)
    hi = max(c.spread[1] for c in changes)
    head = (
        f"a slow change common to {n} of {m} sensors ({', '.join(widest.shared)}) from "
        f"{short_seconds(first.finding.onset_s)} s: temperature or a shared supply, not one "
        "sensor's fault"
    )
    return CommonNote(
        f"{head}; not reported: {what}. Each such sensor's slow level "
        f"({spoken_duration(first.block_s)} means, in units of its scatter in the healthy "
        "window) follows the fault's shape "
        f"(|t| {lo:.3g} to {hi:.3g}, bound {first.critical:.3g}), and the faulty sensor's "
        "is explained by most of the others' (a factor and a line) with no step, kink or "
        "shape of its own beyond chance",
        f"{head} ({len(ordered)} drift or offset finding(s) not reported)",
    )


def _detectors(f: Finding) -> list[str]:
    return list(f.evidence.get("detectors") or [f.detector])
