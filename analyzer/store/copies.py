"""Channels that copy another channel over the whole record.

A channel recorded at the same times as another whose every sample equals that other
channel's (up to rounding), or an exact linear function of it (``b = alpha a + beta``:
another unit, a sign flip, a colour channel computed from another), carries nothing the
other does not: the two entries ``[1]`` and ``[6]`` of a symmetric ROS covariance
matrix, two components of a quaternion that stay equal, the joints of a fake joint-state
publisher that all move together. Modelled together they make every AR regression
singular (the least-squares estimate needs a non-singular Gram matrix of the lagged
channels), and the run was refused as a whole. :func:`find_copies` names them, so that
the default run leaves them out (:func:`analyzer.selection.select_channels`).

Only a copy over the *whole* record counts: two sensors that agree in the healthy window
and part later (one of them faulty) are both kept, as the fault is in what tells them
apart. The test runs on the raw samples, before alignment (no interpolation blurs a
copy), in two steps: a fingerprint of each channel (its samples at up to
:data:`FINGERPRINT_ROWS` evenly spaced rows, and its range) proposes candidate pairs,
which are then checked on every sample, a block of samples at a time (a mismatch
usually ends the check in its first block). A channel that holds one value at every
fingerprint row (rare events on a zero line, a flag) is a copy only of one equal to it
to the bit (their sums, one pass each, tell first): such channels may be many, and all
of one range.

A copy at a lag (``b[k] = alpha a[k - L] + beta``) is not looked for: none of the realdata
corpus's records holds one (ROS 1 and 2 bags, MCAP, CSV and SKAB files checked at lags 1
to 5 over channels recorded at the same times), and the one lagged echo in it, a
turtlesim pose velocity holding the last ``cmd_vel``, is sampled at other times (62.5 Hz
against 10 Hz or key repeats, as float32) and so copies nothing sample by sample. Where
such an echo makes an AR regression singular inside a training window, the fit names
it (:func:`analyzer.detectors.ar_model.fit_ar`: "follow the other channels' past
exactly").
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from analyzer.store.store import ChannelInfo, ChannelStore

FloatArray = npt.NDArray[np.float64]

FINGERPRINT_ROWS = 256
"""Evenly spaced samples of each channel whose cosine similarity proposes the pairs."""

CANDIDATE_COSINE = 1.0 - 1e-9
"""Smallest absolute cosine between two centred fingerprints for the pair to be checked
on every sample (an exact linear copy gives 1 up to rounding)."""

COPY_TOLERANCE = 1e-6
"""Largest difference between a channel and its linear image of the other, on any
sample, as a share of the channel's range (max - min over the record): a millionth of
the range passes the rounding of float32 sources and of a value written with fewer
digits, while two sensors' independent noise is orders of magnitude larger."""

ROUNDING = 1e-12
"""And as a share of the channel's largest magnitude (float64 rounding of ``alpha a +
beta`` on values far from zero)."""

BLOCK = 1 << 20
"""Samples of a pair compared at once."""

SAME_TIME_NS = 1_000
"""Largest difference, in nanoseconds, between the times of two channels' samples for
them to count as recorded at the same times: a microsecond, the resolution of ISO times
written with six decimals (the same recording written as MCAP, with nanosecond times,
and as CSV differs by under a microsecond on some samples; an audit's two copies of one
recording in one folder were analyzed as 10 sensors)."""

COSINE_BLOCK = 1024
"""Channels whose fingerprints are compared with every earlier one's at once (a
10 000-column CSV needs no 800-MB matrix)."""


@dataclass(frozen=True, slots=True)
class Copy:
    """``channel`` equals ``alpha * of + beta`` on every sample of the record."""

    channel: str
    of: str
    alpha: float
    beta: float

    @property
    def relation(self) -> str:
        """How ``channel`` follows ``of``, for a note: ``= of``, ``= -of``, ``= 0.891 of
        + 24.5``."""
        if self.alpha == 1.0 and self.beta == 0.0:
            return f"= {self.of}"
        gain = "-" if self.alpha == -1.0 else "" if self.alpha == 1.0 else f"{self.alpha:.6g} "
        shift = "" if self.beta == 0.0 else f" {'-' if self.beta < 0 else '+'} {abs(self.beta):.6g}"
        return f"= {gain}{self.of}{shift}"


def find_copies(store: ChannelStore, names: Sequence[str]) -> list[Copy]:
    """The channels of ``names`` (in their order) that copy an earlier one of ``names``
    over the whole record: recorded at the same times (within :data:`SAME_TIME_NS`),
    with gaps (NaN) at the same samples, and ``|b - (alpha a + beta)|`` within
    :data:`COPY_TOLERANCE` of ``b``'s range (plus :data:`ROUNDING` of its magnitude) on
    every sample. Each copy names the
    first channel it copies that is kept (a copy of a copy names the original).
    Constant channels are never copies (they are left out anyway)."""
    infos = {i.name: i for i in store.infos()}
    by_shape: dict[tuple[int, int], list[str]] = {}
    for name in names:
        i = infos[name]
        if i.constant:
            continue
        # (the spans are compared with the times, within SAME_TIME_NS)
        by_shape.setdefault((i.samples, i.finite), []).append(name)
    found: list[Copy] = []
    for group in by_shape.values():
        if len(group) > 1:
            found.extend(_copies_in(store, [infos[n] for n in group]))
    order = {n: k for k, n in enumerate(names)}
    return sorted(found, key=lambda c: order[c.channel])


def _copies_in(store: ChannelStore, group: list[ChannelInfo]) -> list[Copy]:
    """The copies among channels of one sample count, finite count and span."""
    n = group[0].samples
    rows = np.unique(np.linspace(0, n - 1, min(n, FINGERPRINT_ROWS)).astype(np.int64))
    prints = np.empty((rows.size, len(group)))
    for j, info in enumerate(group):
        prints[:, j] = store.raw(info.name)[1][rows]
    finite = np.isfinite(prints)
    held = np.where(finite, prints, 0.0)
    # (a column without a finite fingerprint sample is flat: its norm is 0)
    centred = np.where(finite, held - held.sum(axis=0) / np.maximum(finite.sum(axis=0), 1), 0.0)
    norm = np.linalg.norm(centred, axis=0)
    unit = np.divide(centred, norm, out=np.zeros_like(centred), where=norm > 0)
    flat = norm == 0
    is_kept = np.zeros(len(group), dtype=bool)
    # the kept channels flat in their fingerprints, by their sums: a flat channel is looked
    # up by its own, not compared with every earlier one (3000 such channels took 16 s
    # pair by pair); the first one's sums are computed when a second one comes
    flat_kept: dict[Sums, list[int]] = {}
    unsummed: list[int] = []

    copies: list[Copy] = []
    for j0 in range(0, len(group), COSINE_BLOCK):
        j1 = min(len(group), j0 + COSINE_BLOCK)
        cosine = np.abs(unit[:, :j1].T @ unit[:, j0:j1])  # (j1, j1 - j0): earlier x these
        for j in range(j0, j1):
            key: Sums | None = None
            candidates: list[int] = []
            if flat[j]:
                # flat in the fingerprint (rare events on one level): a copy only to the
                # bit, of a kept flat channel whose sums are the same to the bit
                if flat_kept or unsummed:
                    for i in unsummed:
                        flat_kept.setdefault(_sums(store, group[i]), []).append(i)
                    unsummed.clear()
                    key = _sums(store, group[j])
                    candidates = list(flat_kept.get(key, ()))
            else:
                near = (cosine[:j, j - j0] >= CANDIDATE_COSINE) & ~flat[:j]
                candidates = [int(i) for i in np.flatnonzero(near & is_kept[:j])]
            match = None
            for i in candidates:
                if flat[j]:
                    lines = [(1.0, 0.0)]
                else:
                    # equal (or of opposite sign) up to rounding before a fitted line, which
                    # would be 1 + 1e-15 with a shift of 1e-17
                    lines = [(1.0, 0.0), (-1.0, 0.0)]
                    fit = _line(prints[:, i], prints[:, j], finite[:, i] & finite[:, j])
                    if abs(fit[1]) <= _tolerance(group[j]):  # (no shift: not 3e-20 either)
                        lines.append((fit[0], 0.0))
                    lines.append(fit)
                line = next(
                    (
                        ab
                        for ab in lines
                        if _maps_range(group[i], group[j], *ab)
                        and _same_everywhere(store, group[i], group[j], *ab)
                    ),
                    None,
                )
                if line is not None:
                    match = Copy(group[j].name, group[i].name, *line)
                    break
            if match is not None:
                copies.append(match)
                continue
            is_kept[j] = True
            if flat[j]:
                if key is None:
                    unsummed.append(j)
                else:
                    flat_kept.setdefault(key, []).append(j)
    return copies


def _line(a: FloatArray, b: FloatArray, ok: npt.NDArray[np.bool_]) -> tuple[float, float]:
    """``alpha, beta`` of ``b = alpha a + beta`` through the fingerprints' finite rows
    (least squares)."""
    a, b = a[ok], b[ok]
    design = np.column_stack([a, np.ones_like(a)])
    (alpha, beta), *_ = np.linalg.lstsq(design, b, rcond=None)
    return float(alpha), float(beta)


def _tolerance(info: ChannelInfo) -> float:
    return COPY_TOLERANCE * (info.maximum - info.minimum) + ROUNDING * max(
        abs(info.maximum), abs(info.minimum)
    )


def _maps_range(a: ChannelInfo, b: ChannelInfo, alpha: float, beta: float) -> bool:
    """Whether the line takes ``a``'s range onto ``b``'s (a check of the record's extremes
    that costs nothing: most false candidates end here)."""
    if not (np.isfinite(alpha) and np.isfinite(beta)) or alpha == 0.0:
        return False
    ends = sorted((alpha * a.minimum + beta, alpha * a.maximum + beta))
    tol = _tolerance(b)
    return abs(ends[0] - b.minimum) <= tol and abs(ends[1] - b.maximum) <= tol


Sums = tuple[float, float, float]
"""Of a channel's finite samples: their count, sum, and sum weighted by position (sample
``k`` of ``n`` weighs ``k / n``)."""


def _sums(store: ChannelStore, info: ChannelInfo) -> Sums:
    """:data:`Sums` of ``info``'s channel, a block at a time: equal to the bit for two
    channels equal to the bit (the same operations on the same numbers), and almost
    never for two others. Channels flat in their fingerprints (rare events on a zero
    line) may all share one range, and checking every pair of them sample by sample
    grew with the square of their number (200 such channels of 2 million samples: 80 s;
    one pass each instead: a few)."""
    v = store.raw(info.name)[1]
    out = np.zeros(3)
    for s in range(0, info.samples, BLOCK):
        x = np.asarray(v[s : s + BLOCK], dtype=np.float64)
        ok = np.isfinite(x)
        xs = x[ok]
        out += (xs.size, xs.sum(), float(((s + np.flatnonzero(ok)) / info.samples) @ xs))
    return float(out[0]), float(out[1]), float(out[2])


def _same_everywhere(
    store: ChannelStore, a: ChannelInfo, b: ChannelInfo, alpha: float, beta: float
) -> bool:
    """Whether ``b`` is ``alpha a + beta`` on every sample (same times, same gaps)."""
    ta, va = store.raw(a.name)
    tb, vb = store.raw(b.name)
    tol = _tolerance(b)
    for s in range(0, a.samples, BLOCK):
        e = min(a.samples, s + BLOCK)
        if ta is not tb and not _same_times(ta[s:e], tb[s:e]):
            return False
        x = np.asarray(va[s:e], dtype=np.float64)
        y = np.asarray(vb[s:e], dtype=np.float64)
        fx, fy = np.isfinite(x), np.isfinite(y)
        if not np.array_equal(fx, fy):
            return False
        if alpha == 1.0 and beta == 0.0:
            diff = np.abs(y[fy] - x[fx])
        else:
            diff = np.abs(y[fy] - (alpha * x[fx] + beta))
        if diff.size and float(diff.max()) > tol:
            return False
    return True


def _same_times(ta: npt.NDArray[np.int64], tb: npt.NDArray[np.int64]) -> bool:
    """Whether two blocks of sample times agree within :data:`SAME_TIME_NS` each."""
    if np.array_equal(ta, tb):
        return True
    diff = np.asarray(ta, dtype=np.int64) - np.asarray(tb, dtype=np.int64)
    return bool(np.abs(diff).max() <= SAME_TIME_NS)
