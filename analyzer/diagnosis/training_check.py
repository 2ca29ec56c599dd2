"""Is the healthy window healthy? A sensor that steps or changes its scale inside it.

Every model is fitted on the training window (``--train``) as healthy: a sensor fault
inside it is baked into the models, and the run then reports nothing, or something
misleading, with no word that the window was not healthy (an offset of 4 noise standard
deviations on one sensor of a simulated 6-sensor building, from the middle of its 12 s
window, gave no note and a false offset on another sensor at the record's end; a gain of
1.5 gave nothing at all). A drift is told already
(:func:`analyzer.diagnosis.merge.traced_into_training`: its line traced back inside the
window); this module tells a step and a gain change, from the window alone (no
detector's model: it runs in the driver, so the same serially, on threads or on a
cluster).

The test, per channel group (the channels modelled together,
:func:`analyzer.grouping.partition`):

1. Each channel ``j`` is predicted from the other channels of its group at lags
   ``-K .. K`` (:data:`LAGS`): a two-sided least-squares interpolator fitted on the
   whole window. Unlike a regression at lag 0, it follows channels related dynamically
   (the lag-0 relation of a lightly damped building's floors depends on which mode
   dominates: its slope moved between the halves of a healthy 12 s window by 10
   standard errors). The channel's own samples are no regressor, so a step or a change
   of scale of ``j`` is not predicted away: ``e_j = z_j - h_j`` (``z``: standardized).
2. The window is cut into :data:`BATCHES` consecutive batches. A **step** of ``j`` moves
   the mean of ``e_j``; a **gain change** moves the slope of ``z_j`` on its prediction
   ``h_j`` (``r = sum z~ h~ / sum h~^2``, centred within each batch so that a step does
   not leak into it). At every split between two batches the parts are compared by a
   two-sample t statistic whose variance is the scatter of the batches about their
   part's value (batch means: the residuals' autocorrelation within a batch is in that
   scatter; pooled over both parts, so that the change does not inflate it). The slope's
   batches are weighted by ``sum (z~ - r h~)^2 h~^2`` about their part's slope ``r``
   (its sandwich variance: the residual of a structure that rings grows with the
   excitation, so weights ``sum h~^2`` alone, which assume a constant residual
   variance, made healthy windows fail; about the whole window's slope, a gain of 2
   took its own change for noise and the other sensor of its floor was named). Where
   the batch deviations are correlated at lag 1 (``rho > 0``: batches shorter than the
   residual's memory) the variance is multiplied by ``(1 + rho) / (1 - rho)`` (AR(1)
   long-run variance). Under no change the t statistic follows Student's t with ``B - 2``
   degrees of freedom.
3. The largest ``|t|`` over the splits, channels, both statistics and the groups is
   compared with their Bonferroni bound at :data:`ALPHA`: a note on a healthy window
   has probability at most ``ALPHA`` (conservative: the splits are strongly correlated;
   on 300 healthy simulated windows, 4 to 16 channels, 12 s to 10 minutes, the largest
   ``|t|`` reached 0.84 of the bound). Where no split passes, the same two-sample
   statistics compare every stretch of batches that begins and ends inside the window
   with the rest of it (:func:`_parts`): a sensor that changes and comes back leaves
   part of its stretch on both sides of every split (an offset of 3 sd from 40 to 80 s
   of a 120-s window passed every split's bound). Their bound is Bonferroni at
   ``ALPHA`` over the stretches (253 for 24 batches): a note on a healthy window has
   probability at most ``2 ALPHA`` in all (on 90 healthy simulated windows, 4 to 16
   channels, 12 s to 10 minutes, the stretches' largest ``|t|`` reached 0.75 of their
   bound).
4. Which sensor: the structured-residual argument of the bank of estimators (Chang et
   al. 2017, Table 1). A fault on ``j`` leaves every relation without ``j`` unchanged,
   so the same statistic at the same splits, on the group without ``j``, passes (its
   bound: Bonferroni over those splits and channels), while without any other channel
   it still sees ``j``. The channels whose removal leaves the group consistent are the
   candidates, most consistent first. Two sensors that see the same motion (two on a
   floor) can often both be removed to the same effect: both are named. A change of the
   whole structure keeps every relation (a change of excitation scales ``z_j`` and
   ``h_j`` alike; a load that moves every channel along the structure's own relations)
   and is not seen, or breaks relations that no one channel is in (no candidate): no
   sensor is named. With two channels alone both are candidates.
5. What the relations cannot tell, the channels' own levels and shapes can: a step of
   the candidate is no sensor's when a channel outside the candidates changed its own
   level at the same splits (its batch means, bound at :data:`COMMON_ALPHA`: the
   monitored system moved); nor when the candidate's batch statistic is fitted better by
   a straight line over the window than by the step (a slow trend that any split cuts in
   two: warming, or a drift, which :func:`~analyzer.diagnosis.merge.traced_into_training`
   tells when it lasts past the window).

Cost: the lag covariances of the window (``2K + 1`` products of ``n x m`` by ``m x m``)
and the ``2K + 1`` products that predict every channel; the ``m`` systems without one
channel only when the window fails. 16 channels, 10 minutes at 100 Hz: see
:func:`check_training`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import special

from analyzer.diagnosis.merge import Finding
from analyzer.timeutil import short_seconds, spoken_duration, window_text
from analyzer.types import FaultType
from analyzer.window_note import WindowNote

FloatArray = npt.NDArray[np.float64]

ALPHA = 1e-4
"""Probability of a note on a healthy window, per run (Bonferroni over the splits,
channels, both statistics and the groups: an upper bound)."""

LAGS = 2
"""Lags ``K`` each side of the other channels' samples a channel is predicted from."""

BATCHES = 24
"""Batches the window is cut into (the split points, and the batch-means variance)."""

MIN_BATCHES = 8
"""Fewer batches than this (a short window) and the window is not checked."""

MIN_BATCH_ROWS = 16
"""Rows each batch needs at least: shorter windows have fewer batches."""

RIDGE = 1e-6
"""Ridge on the standardized lag covariance (channels that are near copies)."""

MAX_RHO = 0.8
"""Largest lag-1 correlation of the batch deviations the variance is corrected for (a
factor of 9): beyond it the AR(1) correction is no estimate any more."""

COMMON_ALPHA = 0.01
"""Level of the test that another channel's own level moved with the candidate's (step
5 of the module docstring): a sensor's step that coincides by chance with another
channel's apparent move is left unnoted with at most this probability."""


@dataclass(frozen=True, slots=True)
class WindowChange:
    """A sensor that changed inside the healthy window.

    ``channels``: the channel, or the channels the others cannot tell apart (two on one
    floor, or two channels alone), most likely first; ``kinds``: a step (``additive``)
    and/or a gain change (``multiplicative``); ``at_s``: the change's estimated time
    (seconds from the first sample), inside ``lo_s .. hi_s`` (the two batches around
    the split); ``offset``: the step in the channel's units; ``gain``: the channel's
    scale against the others after the change over before; ``statistic``: the
    ``|t|`` of the change, over ``critical``, its bound. A change that ends inside the
    window (the sensor comes back) has its return's time and batches in ``end_s``,
    ``end_lo_s`` and ``end_hi_s`` (None: it lasts to the window's end, or began before
    it)."""

    channels: tuple[str, ...]
    kinds: tuple[FaultType, ...]
    at_s: float
    lo_s: float
    hi_s: float
    offset: float | None
    gain: float | None
    statistic: float
    critical: float
    end_s: float | None = None
    end_lo_s: float | None = None
    end_hi_s: float | None = None


def check_training(
    window: npt.NDArray[np.floating],
    channels: Sequence[str],
    groups: Sequence[Sequence[str]],
    rate_hz: float,
    start_s: float = 0.0,
    *,
    alpha: float = ALPHA,
    lags: int = LAGS,
    batches: int = BATCHES,
) -> list[WindowChange]:
    """The sensors that changed inside the training window ``window`` (its rows, one
    column per channel of ``channels``, the first at ``start_s`` s), each group of
    ``groups`` (channel names) tested on its own (module docstring). A group of one
    channel, or a window of fewer than ``MIN_BATCHES * MIN_BATCH_ROWS`` rows finite in
    every channel of the group, is not tested.

    Measured (CPU time, one BLAS thread): 16 channels, 10 minutes at 100 Hz take 0.04-
    0.05 s when the window passes, 0.6 s when it fails (the 16 systems without one
    channel)."""
    index = {c: j for j, c in enumerate(channels)}
    tested = [[index[c] for c in g if c in index] for g in groups]
    tested = [g for g in tested if len(g) >= 2]
    changes = []
    for g in tested:
        block = np.asarray(window[:, g], dtype=np.float64)
        system = _System.build(block, lags, batches)
        if system is None:
            continue
        change = system.change(alpha / len(tested))
        if change is not None:
            j, kinds, row, lo, hi, offset, gain, t, crit, back = change
            end = (None,) * 3 if back is None else tuple(start_s + r / rate_hz for r in back)
            changes.append(
                WindowChange(
                    channels=tuple(channels[g[c]] for c in j),
                    kinds=kinds,
                    at_s=start_s + row / rate_hz,
                    lo_s=start_s + lo / rate_hz,
                    hi_s=start_s + hi / rate_hz,
                    offset=offset,
                    gain=gain,
                    statistic=t,
                    critical=crit,
                    end_s=end[0],
                    end_lo_s=end[1],
                    end_hi_s=end[2],
                )
            )
    return changes


def change_words(c: WindowChange) -> tuple[str, list[str]]:
    """Who changed (the channel, with those the others cannot tell from it) and what
    changed (its level's step, its scale's change), as the notes say them."""
    what = []
    if c.offset is not None:
        what.append(f"its level steps by {c.offset:+.4g}")
    if c.gain is not None:
        what.append(f"its scale against the others changes {c.gain:.3g}-fold")
    who = c.channels[0]
    if len(c.channels) > 1:
        who += f" (or {' or '.join(c.channels[1:])}: the others cannot tell them apart)"
    return who, what


def window_warnings(notes: Sequence[str]) -> list[str]:
    """The short forms of the run's :class:`WindowNote` notes, for stderr."""
    return [n.short for n in notes if isinstance(n, WindowNote)]


@dataclass(frozen=True, slots=True)
class WindowNeed:
    """What a window the notes suggest must hold for the detectors that ran: ``rows``
    rows with a sample of every channel (the run's own rule, from the detectors' fitted
    settings: :func:`analyzer.pipeline._window_need`), at ``rate_hz``; ``held``: how many
    of the archive's first ``i`` rows hold every channel (None: all of them). Without it
    the notes suggested windows the run then refused: a SKAB pump's ``--train 0:718`` was
    told ``--train 0:553`` (before a change), which stopped with "give --train 0:718"."""

    rows: int
    rate_hz: float
    held: npt.NDArray[np.int64] | None = None

    @property
    def seconds(self) -> float:
        return self.rows / self.rate_hz

    def _row(self, x: float) -> int:
        last = (len(self.held) - 1) if self.held is not None else np.iinfo(np.int64).max
        return int(min(last, max(0, round(x * self.rate_hz))))

    def holds(self, start: float, end: float) -> bool:
        """Whether ``start .. end`` (seconds) holds the rows the detectors need."""
        if self.held is None:
            return self._row(end) - self._row(start) >= self.rows
        return int(self.held[self._row(end)] - self.held[self._row(start)]) >= self.rows

    def end(self, start: float) -> float:
        """The earliest end (seconds) of a window from ``start`` that holds the rows
        (infinite past the archive's end)."""
        if self.held is None:
            return self._row(start) / self.rate_hz + self.seconds
        a = self._row(start)
        ahead = int(np.searchsorted(self.held, self.held[a] + self.rows))
        return ahead / self.rate_hz if ahead < len(self.held) else float("inf")


def window_notes(
    values: npt.NDArray[Any],
    channels: Sequence[str],
    groups: Sequence[Sequence[str]],
    train: tuple[int, int],
    train_s: tuple[float, float],
    duration_s: float,
    rate_hz: float,
    findings: Sequence[Finding] = (),
    need: Callable[[], WindowNeed | None] | None = None,
) -> list[str]:
    """The run's notes on its training window (rows ``train`` of the aligned matrix
    ``values``, ``train_s`` in seconds): :func:`check_training` on the channel
    ``groups``, told by :func:`training_notes` (a channel whose drift a finding traced
    into the window is told by that finding's note). ``need``: what the windows it
    suggests must hold (:class:`WindowNeed`), asked only when a change is found."""
    window = values[train[0] : train[1]]  # a view: each group reads its own columns
    changes = check_training(window, channels, groups, rate_hz, train[0] / rate_hz)
    if not changes:
        return []
    drifting = [
        f.channel for f in findings if any(e.evidence.get("starts_in_training") for e in f.events)
    ]
    return training_notes(
        changes, train_s, duration_s, drifting, need() if need is not None else None
    )


def training_notes(
    changes: Sequence[WindowChange],
    train_s: tuple[float, float],
    duration_s: float,
    drifting: Sequence[str] = (),
    need: WindowNeed | None = None,
) -> list[str]:
    """The run's note (a :class:`WindowNote`) for each change: which sensor, what, when,
    and the windows (``--train``) before and after it. ``train_s``: the window's start and end,
    ``duration_s``: the record's; ``drifting``: channels whose drift was already traced
    into the window (:func:`~analyzer.diagnosis.merge.traced_into_training`), not noted
    twice. A window suggested runs when given: it ends before the record does (the
    search runs from its end) and, with ``need``, holds what the detectors need (the
    window after the change is lengthened to it); a side too short is said with its
    length, and where neither side will do the note says so and how else to train."""
    notes: list[str] = []
    a, b = train_s
    for c in changes:
        if c.channels[0] in drifting:
            continue
        who, what = change_words(c)
        back = "" if c.end_s is None else f" and back at about {short_seconds(c.end_s)} s"
        last = c.hi_s if c.end_hi_s is None else c.end_hi_s  # (the change's, or its return's)
        before, after, short = _sides(a, c.lo_s, last, b - a, duration_s, need)
        advice = " or ".join(
            f"{w} ({s})"
            for w, s in ((before, "before it, if the sensor was right then"), (after, "after it"))
            if w is not None
        )
        if short:
            needs = (
                ""
                if need is None
                else f", shorter than the ~{spoken_duration(need.seconds)} the detectors need"
            )
            said = "; ".join(short) + needs
            advice = (
                f"{advice} ({said})"
                if advice
                else f"no window free of it is long enough ({said}): fit the models on a "
                "healthy recording of the same system with --save-model and analyze this one "
                "with --model"
            )
        tells = f"a window that does not cross it tells: {advice}" if before or after else advice
        head = (
            f"the healthy window ({short_seconds(a)}-{short_seconds(b)} s) is not steady: {who} "
            "changes "
            f"inside it at about {short_seconds(c.at_s)} s{back}"
        )
        between = f"between {short_seconds(c.lo_s)} and {short_seconds(c.hi_s)} s"
        if c.end_lo_s is not None and c.end_hi_s is not None:
            between += (
                f"; back between {short_seconds(c.end_lo_s)} and {short_seconds(c.end_hi_s)} s"
            )
        notes.append(
            WindowNote(
                f"{head} ({between}): {' and '.join(what)} "
                f"(|t| {c.statistic:.3g}, bound {c.critical:.3g}), while the channels modelled "
                "with it do not; a sensor fault there, or a change of the monitored system "
                "that they do not share, was fitted into the models as healthy, so faults may "
                f"be missed or misplaced; {tells}",
                f"{head} ({' and '.join(what)}): the models were fitted on it; {advice}",
                (a, c.lo_s) if c.lo_s - a > 0 else None,
            )
        )
    return notes


def _sides(
    a: float, lo: float, last: float, length: float, duration_s: float, need: WindowNeed | None
) -> tuple[str | None, str | None, list[str]]:
    """The ``--train`` windows before a change (``a .. lo``) and after it (from ``last``,
    as long as the window was, or as the detectors need), None where there is no such
    window or it would not run, and what is said of the sides too short."""
    short = []
    before = None
    if lo - a > 0:
        if need is None or need.holds(a, lo):
            before = f"--train {window_text(a, lo)}"
        else:
            short.append(f"before it: only {short_seconds(lo - a)} s")
    # the window must end before the record does: the search runs from its end
    room = duration_s - (1.0 / need.rate_hz if need is not None else 0.0)
    end = last + length
    if need is not None:
        least = need.end(last)
        end = max(end, least) if max(end, least) < room else least
    after = None
    if end < room:
        after = f"--train {window_text(last, end)}"
    elif duration_s > last:
        short.append(f"after it: only {short_seconds(duration_s - last)} s to the record's end")
    return before, after, short


_Change = tuple[
    tuple[int, ...],
    tuple[FaultType, ...],
    int,
    int,
    int,
    float | None,
    float | None,
    float,
    float,
    tuple[int, int, int] | None,
]


def _parts(b: int, returns: bool) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.intp]]:
    """The parts of ``b`` batches a change is tested on: ``inside`` (P, B), the batches
    after the change, and ``edges`` (P, 2), each part's first batch and the batch after
    its last (``b``: to the window's end). Without ``returns``: every split, the batches
    ``g .. b - 1`` against the rest, ``g = 1 .. b - 1``; with it: every stretch ``g0 ..
    g1 - 1`` that begins and ends inside the window (``1 <= g0 < g1 <= b - 1``), a
    sensor that changes and comes back."""
    if returns:
        g0, g1 = np.triu_indices(b - 1, k=1)
        edges = np.stack([g0 + 1, g1 + 1], axis=1)
    else:
        edges = np.stack([np.arange(1, b), np.full(b - 1, b)], axis=1)
    batch = np.arange(b)
    inside = (batch >= edges[:, :1]) & (batch < edges[:, 1:])
    return inside, edges.astype(np.intp)


@dataclass(frozen=True, slots=True)
class _Split:
    """The split statistics of one system: ``t_off``/``t_gain`` are ``(P, c)`` (row
    ``k``: part ``k`` of :func:`_parts` against the rest of the window); ``off``/
    ``ratio``: the rest's and the part's mean of ``e`` and slope, ``(P, c, 2)``."""

    t_off: FloatArray
    t_gain: FloatArray
    off: FloatArray
    ratio: FloatArray

    def peak(self) -> float:
        return float(max(np.max(np.abs(self.t_off)), np.max(np.abs(self.t_gain))))


@dataclass(slots=True)
class _System:
    """One group's window, standardized: ``z`` the rows whose lag neighbourhood is
    finite in every channel (``rows``: their numbers in the window; ``padded``: every
    row, non-finite values as 0, to take lags from), ``scale`` the channels' standard
    deviations, ``cov[d]`` the lag covariance ``E[z(t) z(t + d)^T]`` for ``d = 0 ..
    2K``, ``bounds`` the batches' first rows in ``z`` (and its length)."""

    z: FloatArray
    rows: npt.NDArray[np.intp]
    padded: FloatArray
    scale: FloatArray
    cov: FloatArray
    lags: int
    bounds: npt.NDArray[np.intp]
    _full: FloatArray | None = field(default=None)

    @classmethod
    def build(cls, block: FloatArray, lags: int, batches: int) -> _System | None:
        n_all, m = block.shape
        width = 2 * lags + 1
        if n_all < width:
            return None
        finite = np.isfinite(block).all(axis=1)
        if finite.all():
            rows = np.arange(lags, n_all - lags)
            mean, scale = block.mean(axis=0), block.std(axis=0)
        else:
            # a row is used when its whole lag neighbourhood is finite
            ok = np.convolve(finite.astype(np.int64), np.ones(width, dtype=np.int64), "valid")
            rows = np.flatnonzero(ok == width) + lags
            used = block[finite]
            mean, scale = used.mean(axis=0), used.std(axis=0)
        b = min(batches, rows.size // MIN_BATCH_ROWS)
        if b < MIN_BATCHES or not np.all(scale > 0):
            return None
        # equal batches: the last rows that do not fill one are left out (fewer than B)
        rows = rows[: b * (rows.size // b)]
        n = rows.size
        padded = (block - mean) / scale
        if not finite.all():
            padded[~finite] = 0.0
        # Toeplitz: the Gram matrix of the lagged samples from 2K + 1 lag covariances
        # (their edge rows aside, which change it by O(K / n))
        cov = np.empty((width, m, m))
        for d in range(width):
            cov[d] = padded[: n_all - d].T @ padded[d:] / n
        bounds = np.arange(b + 1) * (n // b)
        return cls(padded[rows], rows, padded, scale, cov, lags, bounds)

    def lagged(self, d: int) -> FloatArray:
        """The rows ``rows + d`` of ``padded`` (a view where the rows are contiguous)."""
        first = int(self.rows[0]) + d
        if int(self.rows[-1]) - int(self.rows[0]) == self.rows.size - 1:
            return self.padded[first : first + self.rows.size]
        return self.padded[self.rows + d]

    @property
    def n_batches(self) -> int:
        return int(self.bounds.size - 1)

    def critical(self, tests: int, alpha: float) -> float:
        """The two-sided Bonferroni bound of ``tests`` t statistics at ``alpha``."""
        # Student's t inverse survival function, as scipy.stats.t.isf computes it (without
        # importing scipy.stats: ~0.3 s a default run does not otherwise pay)
        return float(-special.stdtrit(self.n_batches - 2, alpha / tests / 2.0))

    def _gram(self) -> FloatArray:
        """The lagged samples' Gram matrix, lag-major: block ``(a, b)`` is
        ``E[z(t + a - K) z(t + b - K)^T] = cov[b - a]`` (or its transpose)."""
        m = self.z.shape[1]
        width = 2 * self.lags + 1
        gram = np.empty((m * width, m * width))
        for a in range(width):
            for b in range(width):
                block = self.cov[b - a] if b >= a else self.cov[a - b].T
                gram[a * m : (a + 1) * m, b * m : (b + 1) * m] = block
        return gram

    def predict(self, cols: list[int]) -> FloatArray:
        """``h``: each channel of ``cols`` predicted from the others of ``cols`` at lags
        ``-K .. K`` (least squares over the window, ridge :data:`RIDGE`), ``(n, len(cols))``."""
        if self._full is not None and len(cols) == self.z.shape[1]:
            return self._full
        m = self.z.shape[1]
        width = 2 * self.lags + 1
        gram = self._gram()
        lag_channel = np.tile(np.arange(m), width)
        coef = np.zeros((m * width, len(cols)))
        for c, j in enumerate(cols):
            keep = np.flatnonzero(np.isin(lag_channel, [i for i in cols if i != j]))
            g = gram[np.ix_(keep, keep)]
            g[np.diag_indices_from(g)] += RIDGE
            coef[keep, c] = np.linalg.solve(g, gram[keep, self.lags * m + j])
        h = self.lagged(-self.lags) @ coef[:m]
        for a in range(1, width):
            h += self.lagged(a - self.lags) @ coef[a * m : (a + 1) * m]
        if len(cols) == m:
            self._full = h
        return h

    def split(self, cols: list[int], inside: npt.NDArray[np.bool_] | None = None) -> _Split:
        """The split statistics of the channels ``cols``, each predicted from the others
        of ``cols``, on the parts ``inside`` (:func:`_parts`; None: every split)."""
        if inside is None:
            inside = _parts(self.n_batches, returns=False)[0]
        h = self.predict(cols)
        b = self.n_batches
        shape = (b, self.rows.size // b, len(cols))
        e = (self.z[:, cols] - h).reshape(shape)
        h3 = h.reshape(shape)
        mean_e = e.mean(axis=1)
        hc = h3 - h3.mean(axis=1)[:, None]
        # centred within each batch: z~ = h~ + e~, so sum z~ h~ = sum h~^2 + sum e~ h~
        # (and sum e~ h~ = sum e h~)
        ec = e - mean_e[:, None]
        eh = ec * hc
        hh = hc * hc
        q = hh.sum(axis=1)
        s = q + eh.sum(axis=1)
        # the sandwich's sums: sum (z~ - r h~)^2 h~^2 = sum (e~ + (1 - r) h~)^2 h~^2 for
        # each part's own slope r (_split_slopes)
        moments = np.stack(
            [
                np.einsum("blc,blc->bc", eh, eh),
                np.einsum("blc,blc->bc", eh, hh),
                (hh * hh).sum(axis=1),
            ]
        )
        t_off, off = _split_means(mean_e, inside)
        t_gain, ratio = _split_slopes(s, q, moments, inside)
        return _Split(t_off, t_gain, off, ratio)

    def change(self, alpha: float) -> _Change | None:
        """The group's change (module docstring, steps 3-5), or None. The splits are
        tested first; where none passes its bound, the stretches that begin and end
        inside the window, a sensor that changes and comes back (at the same ``alpha``:
        a note on a healthy window has probability at most ``2 alpha``)."""
        m = self.z.shape[1]
        for returns in (False, True):
            inside, edges = _parts(self.n_batches, returns)
            full = self.split(list(range(m)), inside)
            crit = self.critical(2 * m * len(edges), alpha)
            if full.peak() >= crit:
                break
        else:
            return None
        # the change: the statistic and part of the group's largest |t|
        t_off, t_gain = np.abs(full.t_off), np.abs(full.t_gain)
        lead = FaultType.ADDITIVE if t_off.max() >= t_gain.max() else FaultType.MULTIPLICATIVE
        t_lead = t_off if lead is FaultType.ADDITIVE else t_gain
        k = int(np.unravel_index(np.argmax(t_lead), t_lead.shape)[0])
        # the parts whose edges are within a batch of part k's
        near = np.flatnonzero(np.all(np.abs(edges - edges[k]) <= 1, axis=1))
        width = near.size
        if m == 2:
            candidates = sorted(range(m), key=lambda c: -float(t_lead[k, c]))
        else:
            # is the change still there without channel j? (same statistic, same splits;
            # every channel: the one that changed need not show it most itself, its twin
            # on a floor, whose estimate it is, may)
            bound = self.critical((m - 1) * width, alpha)
            without = {}
            for j in range(m):
                red = self.split([i for i in range(m) if i != j], inside)
                t_red = red.t_off if lead is FaultType.ADDITIVE else red.t_gain
                without[j] = float(np.max(np.abs(t_red[near])))
            candidates = sorted(
                (j for j in without if without[j] < bound), key=lambda c: without[c]
            )
        if not candidates:
            return None  # no one channel explains it: the structure's relations changed
        if lead is FaultType.ADDITIVE and self._others_moved(candidates, near, inside):
            return None  # the others' own levels moved with it: the system changed
        j = candidates[0]
        if not self._step_not_trend(j, inside[k], lead):
            return None  # a slow trend (the process's, or a drift)
        kinds = tuple(
            kind
            for kind, t in ((FaultType.ADDITIVE, t_off), (FaultType.MULTIPLICATIVE, t_gain))
            if t[near, j].max() >= crit
        ) or (lead,)
        g0, g1 = (int(g) for g in edges[k])
        row, lo, hi = self._locate(j, g0, lead)
        back = self._locate(j, g1, lead) if g1 < self.n_batches else None
        offset = float(full.off[k, j, 1] - full.off[k, j, 0]) * float(self.scale[j])
        r0, r1 = full.ratio[k, j]
        gain = float(r1 / r0) if r0 > 0 else None
        return (
            tuple(candidates),
            kinds,
            row,
            lo,
            hi,
            offset if FaultType.ADDITIVE in kinds else None,
            gain if FaultType.MULTIPLICATIVE in kinds else None,
            float(t_lead[k, j]),
            crit,
            back,
        )

    def _batch_series(self, j: int, kind: FaultType) -> tuple[FloatArray, FloatArray]:
        """Channel ``j``'s batch statistic and its weights: the batch means of ``e_j``
        (equal weights), or the batch slopes of ``z_j`` on ``h_j`` (weights ``sum h~^2``)."""
        h = self.predict(list(range(self.z.shape[1])))[:, j]
        z = self.z[:, j]
        starts = self.bounds[:-1]
        count = np.diff(self.bounds).astype(np.float64)
        if kind is FaultType.ADDITIVE:
            x = np.add.reduceat(z - h, starts) / count
            return x, np.ones_like(x)
        sum_z, sum_h = np.add.reduceat(z, starts), np.add.reduceat(h, starts)
        s = np.add.reduceat(z * h, starts) - sum_z * sum_h / count
        q = np.maximum(np.add.reduceat(h * h, starts) - sum_h**2 / count, np.finfo(float).tiny)
        return s / q, q

    def _step_not_trend(self, j: int, after: npt.NDArray[np.bool_], kind: FaultType) -> bool:
        """Whether channel ``j``'s batch statistic is fitted better (weighted least
        squares) by a step on the batches ``after`` (and back, where they end before the
        window does) than by a straight line over the window: a sensor that steps leaves
        both parts flat, a slow trend is a line that any split cuts in two."""
        x, w = self._batch_series(j, kind)
        step = 0.0
        for part in (after, ~after):
            mean = np.sum(w[part] * x[part]) / np.sum(w[part])
            step += float(np.sum(w[part] * (x[part] - mean) ** 2))
        centre = (self.bounds[:-1] + self.bounds[1:]) / 2.0
        root = np.sqrt(w)
        design = np.stack([root, root * centre], axis=1)
        coef, *_ = np.linalg.lstsq(design, root * x, rcond=None)
        line = float(np.sum((root * x - design @ coef) ** 2))
        return step < line

    def _others_moved(
        self, candidates: list[int], near: npt.NDArray[np.intp], inside: npt.NDArray[np.bool_]
    ) -> bool:
        """Whether a channel outside ``candidates`` changed its own level on the parts
        ``near`` of ``inside`` (its batch means' t statistic, Bonferroni bound of
        :data:`COMMON_ALPHA` over those channels and parts)."""
        others = [i for i in range(self.z.shape[1]) if i not in candidates]
        if not others:
            return False
        starts = self.bounds[:-1]
        means = np.add.reduceat(self.z[:, others], starts, axis=0) / np.diff(self.bounds)[:, None]
        t, _ = _split_means(means, inside)
        bound = self.critical(len(others) * near.size, COMMON_ALPHA)
        return bool(np.max(np.abs(t[near])) >= bound)

    def _locate(self, j: int, g: int, kind: FaultType) -> tuple[int, int, int]:
        """The change of channel ``j`` between batches ``g - 1`` and ``g``, in window
        rows: the least-squares change point of ``e_j`` (of ``e_j h_j`` for a gain)
        within those two batches, and their first and last rows."""
        lo, hi = int(self.bounds[g - 1]), int(self.bounds[g + 1])
        h = self.predict(list(range(self.z.shape[1])))[lo:hi, j]
        e = self.z[lo:hi, j] - h
        u = e if kind is FaultType.ADDITIVE else e * h
        cusum = np.cumsum(u - u.mean())
        at = lo + int(np.argmax(np.abs(cusum[:-1]))) + 1
        return int(self.rows[at]), int(self.rows[lo]), int(self.rows[hi - 1])


def _split_means(
    x: FloatArray, inside: npt.NDArray[np.bool_] | None = None
) -> tuple[FloatArray, FloatArray]:
    """For batch means ``x`` (B, c): on each part (``inside``, (P, B), of
    :func:`_parts`; None: every split, the first ``k`` batches against the rest, ``k =
    1 .. B - 1``) the means of the rest and of the part, and the two-sample t statistic
    of their difference, with the variance pooled over both (and corrected by
    :func:`_inflation`), ``(P, c)``."""
    b = x.shape[0]
    if inside is None:
        inside = _parts(b, returns=False)[0]
    n_in = inside.sum(axis=1, dtype=np.float64)[:, None]
    m_in = (inside @ x) / n_in
    m_out = ((~inside) @ x) / (b - n_in)
    part = inside[:, :, None]
    dev = x[None] - np.where(part, m_in[:, None], m_out[:, None])
    ss = np.sum(dev * dev, axis=1)
    var = ss / (b - 2) * (1.0 / n_in + 1.0 / (b - n_in)) * _inflation(dev, part)
    se = np.sqrt(var)
    t = np.divide(m_in - m_out, se, out=np.zeros_like(se), where=se > 0)
    return t, np.stack([m_out, m_in], axis=-1)


def _split_slopes(
    s: FloatArray, q: FloatArray, moments: FloatArray, inside: npt.NDArray[np.bool_]
) -> tuple[FloatArray, FloatArray]:
    """For batch sums ``s = sum z~ h~`` and ``q = sum h~^2`` (B, c): on each part
    (``inside``, (P, B)) the slopes ``r = sum s / sum q`` of the rest and of the part, and
    the t statistic of their difference. The batches' deviations ``s_b - r q_b`` have
    variance ``sigma^2 w_b``, with ``w_b = sum (z~ - r h~)^2 h~^2`` (the sandwich of a
    slope, about its own part's slope, so that the change itself is not taken for noise;
    from ``moments`` = the batch sums of ``(e~ h~)^2``, ``e~ h~^3``, ``h~^4``, (3, B, c))
    and one scale pooled over both: ``sigma^2 = sum (s_b - r q_b)^2 / w_b / (B - 2)``,
    ``Var(r) = sigma^2 sum w / (sum q)^2``, corrected by :func:`_inflation`."""
    b = s.shape[0]
    tiny = np.finfo(np.float64).tiny
    q = np.maximum(q, tiny)
    weight = inside.astype(np.float64)
    s2, q2 = weight @ s, weight @ q
    s1, q1 = s.sum(axis=0) - s2, np.maximum(q.sum(axis=0) - q2, tiny)
    r1, r2 = s1 / q1, s2 / q2
    part = inside[:, :, None]
    r = np.where(part, r2[:, None], r1[:, None])
    u = 1.0 - r
    w = np.maximum(moments[0] + 2.0 * u * moments[1] + u * u * moments[2], tiny)
    w2 = np.sum(w * part, axis=1)
    w1 = np.sum(w, axis=1) - w2
    dev = (s[None] - r * q[None]) / np.sqrt(w)
    sigma2 = np.sum(dev * dev, axis=1) / (b - 2)
    se = np.sqrt(sigma2 * (w1 / q1**2 + w2 / q2**2) * _inflation(dev, part))
    t = np.divide(r2 - r1, se, out=np.zeros_like(se), where=se > 0)
    return t, np.stack([r1, r2], axis=-1)


def _inflation(dev: FloatArray, part: npt.NDArray[np.bool_]) -> FloatArray:
    """The long-run variance factor ``(1 + rho) / (1 - rho)`` of batch statistics whose
    deviations from their part's value ``dev`` (splits, B, c) are correlated at lag 1
    (``rho`` over the pairs within a part, clipped to ``0 .. MAX_RHO``; an AR(1)
    approximation): batches shorter than the residual's memory are not independent."""
    same = part[:, 1:] == part[:, :-1]
    num = np.sum(dev[:, 1:] * dev[:, :-1] * same, axis=1)
    den = np.sum(dev * dev, axis=1)
    rho = np.clip(np.divide(num, den, out=np.zeros_like(num), where=den > 0), 0.0, MAX_RHO)
    return (1.0 + rho) / (1.0 - rho)
