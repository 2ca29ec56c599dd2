"""The channel store: raw samples of every channel, kept out of core, served as
time-aligned blocks on a common clock.

Raw samples are appended per channel to in-memory buffers that spill to flat binary
files (int64 nanoseconds, float64 values) in a work directory once they pass a size
limit, so ingesting a long archive needs memory for the buffers only; after
:meth:`ChannelStore.finalize` each channel is a pair of (memory-mapped) arrays. The fields
of one message (a ``Float64MultiArray``'s elements, a CSV's columns), which the readers
hand over with one time array, keep it once (:meth:`ChannelStore._sharing`).

:meth:`ChannelStore.align` returns an :class:`AlignedSeries`: a common clock
``t_k = t0 + k / rate`` and, block by block, every channel on it:

* a channel near the clock's rate is linearly interpolated (this absorbs jitter);
* a faster channel is first low-passed with a windowed-sinc FIR (anti-aliasing: cutoff
  0.45 x the clock rate), then interpolated: the polyphase-resampling result, without
  assuming an exact integer rate ratio;
* where two consecutive raw samples are more than ``GAP_FACTOR`` nominal periods apart,
  the clock ticks between them are NaN: gaps are kept, never interpolated across.
  A channel sampled at irregular times (event-driven, Poisson-like: see
  :func:`_irregular`) has the mean of its steps as its period, and its gaps are the
  steps more than ``GAP_FACTOR`` times its longest ordinary step (the 99th percentile
  of its steps): the regular rule, with the one period replaced by the spread of periods
  the channel really has.
"""

from __future__ import annotations

import fnmatch
import glob
import os
import re
import sys
from collections.abc import Collection, Iterable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from analyzer.errors import IntegrityError, StoreError, capped
from analyzer.paging import is_mapped, mapped_file, pwrite_all, release
from analyzer.readers.base import ChannelChunk
from analyzer.readers.tally import Tally
from analyzer.scratch import make_scratch, remove_scratch, scratch_full
from analyzer.store.patterns import matching
from analyzer.timeutil import plain_number, short_seconds, spoken_duration
from analyzer.types import NS_PER_S

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

UNREADABLE = 1e30
"""Magnitude beyond which an aligned value is no sensor's reading in any unit (an
infinity, an overrange code, a corrupt cell) and is taken as a gap: its square, and a
sum of a few of those, would overflow, and with them every variance and test statistic
of its stretch; and the detectors keep their residuals and estimates in float32, whose
range ends at 3.4e38 (readings of 1e90, accepted when the bound was 1e100, left every
residual figure blank and the innovation tests empty, without a word)."""

GAP_FACTOR = 2.5
"""A step between raw samples longer than this many nominal periods is a gap (so one
dropped sample is bridged, two or more are not); of an irregularly sampled channel, a
step longer than this many times its longest ordinary step (:func:`_irregular`)."""

RARE_STEPS = 0.01
"""Share of a channel's steps that outages may take: while no more than this share of
its steps are gaps by the regular rule, they are taken as outages (and losses) of a
regular clock; beyond it, the channel is tested for irregular sampling
(:func:`_irregular`), whose longest ordinary step is the ``1 - RARE_STEPS`` quantile of
its steps (which outages, as rare, do not reach)."""

OFF_CLOCK_SHARE = 0.25
"""Share of a channel's steps off every whole number of nominal periods (by more than a
quarter period) above which it is irregularly sampled: a regular clock, however many
samples it loses, steps by whole periods (0 % off, but for jitter); steps spread
continuously over the periods are off half the time (50 %, more for exponential steps,
whose many short steps are off too). The threshold lies halfway."""

SPILL_SAMPLES = 1 << 22
"""Buffered samples (all channels) before the buffers are written to the work dir."""


FINALIZE_THREADS = 2
"""Channels finalized at once (threads: numpy's passes release the GIL)."""

ALIGN_THREADS = 2
"""Blocks of the aligned matrix filled at once (threads: numpy copies release the GIL)."""

MAX_ROWS_PER_SAMPLE = 100
"""The common clock may have at most this many rows per sample of the densest channel
(plus :data:`MIN_ROWS_ALLOWED`): more means a timestamp far from the rest (one glitched
row of an epoch-time log spans decades) or an absurd ``--rate``, which would otherwise
fill the disk with an aligned matrix of gaps."""

MIN_ROWS_ALLOWED = 1_000_000

FLAG_SAMPLES = 100
"""Fewest finite samples of a channel of two whole-number values for it to be a flag
(:attr:`ChannelInfo.flag`): a handful of samples shows few values whatever the channel
(an AIS topic's two messages gave two timestamps), as the training window's few-values
note also asks 100 samples before it speaks (:func:`analyzer.pipeline._few_values`)."""


@dataclass(slots=True)
class ChannelInfo:
    """What ``inspect`` reports about one channel (raw samples, before alignment)."""

    name: str
    samples: int
    start_ns: int
    end_ns: int
    rate_hz: float
    gaps: int
    finite: int
    minimum: float
    maximum: float
    irregular: bool = False
    """Sampled at irregular times (:func:`_irregular`): ``rate_hz`` is its mean rate."""
    bridge: float = GAP_FACTOR
    """The longest step between two samples that the alignment interpolates across, in
    nominal periods (``1 / rate_hz``): a longer one is a gap. :data:`GAP_FACTOR` for a
    regular channel."""
    levels: tuple[float, ...] | None = None
    """Its distinct finite values, in increasing order, when it has at most two over the
    whole record (``()`` for an empty channel); None when it has more."""

    @property
    def constant(self) -> bool:
        return not (self.finite > 1 and self.maximum > self.minimum)

    @property
    def flag(self) -> bool:
        """Whether it holds exactly two values over the whole record, both whole numbers
        (0 and 1, 1 and 2...): a status flag, a mode or a label column (SKAB's
        ``anomaly`` and ``changepoint``, written by the benchmark's authors), not a
        measurement. (One value is :attr:`constant`; fewer than :data:`FLAG_SAMPLES`
        samples tell nothing.)"""
        return (
            self.finite >= FLAG_SAMPLES
            and self.levels is not None
            and len(self.levels) == 2
            and all(float(x).is_integer() for x in self.levels)
        )


@dataclass(slots=True)
class _Raw:
    t_parts: list[IntArray] = field(default_factory=list)
    v_parts: list[FloatArray] = field(default_factory=list)
    buffered: int = 0
    spilled: int = 0
    t: IntArray | None = None
    v: FloatArray | None = None
    total: int = 0
    """Samples added so far."""
    leader: str | None = None
    """The channel whose times are this one's (:meth:`ChannelStore._sharing`); None: it
    keeps its own (``t_parts`` and its ``.t`` file)."""
    last_t: IntArray | None = None
    """The times of the last chunk it kept its own times for (held, so that their memory
    is not another array's while a later channel's chunk is compared with them)."""
    order: IntArray | None = None
    """The order that sorted its times (finalize), for the channels that share them."""


class ChannelStore:
    """Raw channels of one archive. Use as a context manager (or call :meth:`close`) to
    remove the spill files."""

    def __init__(self, workdir: str | Path | None = None, spill_samples: int = SPILL_SAMPLES):
        self._own_dir = workdir is None
        self._workdir = Path(workdir) if workdir is not None else None
        self._spill = spill_samples
        self._raw: dict[str, _Raw] = {}
        self._buffered = 0
        self._info: dict[str, ChannelInfo] = {}
        self._final = False
        self._recent: str | None = None
        """The last channel that kept its own times for a chunk."""

    # -- building --------------------------------------------------------------------------
    @classmethod
    def from_chunks(
        cls,
        chunks: Iterable[ChannelChunk],
        workdir: str | Path | None = None,
        spill_samples: int = SPILL_SAMPLES,
    ) -> ChannelStore:
        store = cls(workdir, spill_samples)
        for chunk in chunks:
            store.add(chunk)
        store.finalize()
        return store

    def _dir(self) -> Path:
        if self._workdir is None:
            self._workdir = make_scratch("analyzer-store-")
        self._workdir.mkdir(parents=True, exist_ok=True)
        return self._workdir

    def add(self, chunk: ChannelChunk) -> None:
        if self._final:
            raise StoreError("the store is finalized: no more samples can be added")
        if len(chunk) == 0:
            return
        raw = self._raw.setdefault(chunk.name, _Raw())
        t = np.asarray(chunk.t_ns, dtype=np.int64)
        leader = self._sharing(raw, t)
        if leader is None:
            if raw.leader is not None:
                self._unshare(chunk.name, raw)
            raw.t_parts.append(t)
            raw.last_t = t
            self._recent = chunk.name
        else:
            raw.leader = leader
        raw.v_parts.append(np.asarray(chunk.values, dtype=np.float64))
        raw.total += len(chunk)
        raw.buffered += len(chunk)
        self._buffered += len(chunk)
        if self._buffered >= self._spill:
            self._spill_all()

    def _sharing(self, raw: _Raw, t: IntArray) -> str | None:
        """The channel whose times ``raw``'s new chunk (times ``t``) shares, or None.

        The fields of one message (a ``Float64MultiArray``'s elements, a CSV's columns)
        come from the readers with one time array (:meth:`~analyzer.readers._common.
        Reorderer.release`): kept once, not once per field, the store writes and maps a
        16-field topic's times once instead of 16 times (184 MB less of a 4-hour,
        16-channel archive). A channel shares the times of the channel before it that
        kept its own (or of the one it shares already) while every chunk of it is that
        channel's latest chunk, the very same memory (held in ``last_t``, so no other
        array can be there), with all of that channel's samples before it: then its times
        are that channel's, sample for sample."""
        name = raw.leader if raw.leader is not None else self._recent if not raw.total else None
        if name is None:
            return None
        lead = self._raw[name]
        last = lead.last_t
        if (
            last is None
            or lead.leader is not None
            or last.shape != t.shape
            or last.strides != t.strides
            or last.__array_interface__["data"][0] != t.__array_interface__["data"][0]
            or raw.total != lead.total - t.shape[0]
        ):
            return None
        return name

    def _unshare(self, name: str, raw: _Raw) -> None:
        """Give ``raw`` its own copy of the times it shared so far (its new chunk's times
        are not its leader's): the spilled part to its own ``.t`` file, the rest in
        memory."""
        assert raw.leader is not None
        lead = self._raw[raw.leader]
        lead_t = self._paths(raw.leader)[0]
        if raw.spilled:
            own_t = self._paths(name)[0]
            block = 1 << 22
            with own_t.open("wb") as out:
                for a in range(0, raw.spilled, block):
                    b = min(raw.spilled, a + block)
                    part = np.fromfile(lead_t, dtype=np.int64, count=b - a, offset=8 * a)
                    out.write(part.data)
        # the buffered samples' times: the leader's from raw.spilled to raw.total, which
        # are in its file (when it spilled more) and in its buffered parts
        a, b = raw.spilled, raw.total
        pieces = []
        if a < lead.spilled:
            upto = min(b, lead.spilled)
            pieces.append(np.fromfile(lead_t, dtype=np.int64, count=upto - a, offset=8 * a))
            a = upto
        if a < b:
            pieces.append(np.concatenate(lead.t_parts)[a - lead.spilled : b - lead.spilled])
        raw.t_parts = [np.concatenate(pieces)] if pieces else []
        raw.leader = None

    def _paths(self, name: str) -> tuple[Path, Path]:
        idx = list(self._raw).index(name)
        d = self._dir()
        return d / f"ch{idx:05d}.t", d / f"ch{idx:05d}.v"

    def _spill_all(self) -> None:
        """Every channel's buffered samples appended to its files in the scratch folder;
        a full scratch disk said as such (:func:`~analyzer.scratch.scratch_full`)."""
        try:
            self._spill_each()
        except OSError as err:
            full = scratch_full(err, self._workdir)
            if full is err:
                raise
            raise full from err

    def _spill_each(self) -> None:
        for name, raw in self._raw.items():
            if not raw.buffered:
                continue
            tp, vp = self._paths(name)
            if raw.leader is None:
                with tp.open("ab") as ft:
                    for t in raw.t_parts:
                        ft.write(np.ascontiguousarray(t).data)
            with vp.open("ab") as fv:
                for v in raw.v_parts:
                    fv.write(np.ascontiguousarray(v).data)
            raw.spilled += raw.buffered
            raw.t_parts.clear()
            raw.v_parts.clear()
            raw.buffered = 0
        self._buffered = 0

    def finalize(self) -> None:
        """Make every channel one time-sorted pair of arrays and compute its summary."""
        if self._final:
            return
        if any(r.spilled for r in self._raw.values()):
            self._spill_all()
        for name, raw in self._raw.items():
            if raw.leader is not None and raw.total != self._raw[raw.leader].total:
                self._unshare(name, raw)  # it missed the leader's last chunks
        paths = {name: self._paths(name) for name, raw in self._raw.items() if raw.spilled}
        own = [(name, raw) for name, raw in self._raw.items() if raw.leader is None]
        shared = [(name, raw) for name, raw in self._raw.items() if raw.leader is not None]
        # the channels are independent and numpy's passes over them (the sort test, the
        # summary's median, min/max, diff) release the GIL: on threads they overlap; the
        # channels that share another's times take them once that one's are sorted
        with ThreadPoolExecutor(min(FINALIZE_THREADS, max(1, len(own)))) as pool:
            infos = dict(pool.map(lambda item: _finish(item[0], item[1], paths), own))
            infos.update(
                pool.map(
                    lambda item: _finish(item[0], item[1], paths, self._raw[item[1].leader or ""]),
                    shared,
                )
            )
        for name, raw in self._raw.items():
            self._info[name] = infos[name]
            raw.order = raw.last_t = None  # (for the sharing channels, done with)
        self._recent = None
        self._final = True

    def tally(self, block: int = 1 << 22) -> Tally:
        """What the finalized store holds (:class:`~analyzer.readers.tally.Tally`), for
        the comparison with what the readers handed over: a block at a time, each block's
        pages of a spilled channel given back after it (:func:`~analyzer.paging.release`).
        Each channel's summary is checked against its arrays too (sample count, first and
        last time), so that the aligned clock, which starts at the earliest of them, starts
        at a sample the store holds. The channels that share one time array (the fields
        of one message, :meth:`_sharing`: the very same array object after
        :meth:`finalize`) are tallied together, a block of the times at a time: its sum
        is taken once for all of them (:meth:`~analyzer.readers.tally.Tally.add` sees the
        same block again) and its pages read once, not once per channel; the sums are the
        same integers."""
        self._need_final()
        out = Tally()
        groups: dict[int, list[tuple[str, IntArray, FloatArray]]] = {}
        for name, raw in self._raw.items():
            t, v = raw.t, raw.v
            info = self._info[name]
            assert t is not None and v is not None
            n = int(t.shape[0])
            if v.shape[0] != n or info.samples != n or n == 0:
                raise IntegrityError(
                    f"internal check failed in the store: {name!r} holds {n} times and "
                    f"{v.shape[0]} values, its summary {info.samples} samples"
                )
            if info.start_ns != int(t[0]) or info.end_ns != int(t[-1]):
                raise IntegrityError(
                    f"internal check failed in the store: {name!r} spans {int(t[0])}-"
                    f"{int(t[-1])} ns, its summary {info.start_ns}-{info.end_ns} ns"
                )
            out.sums[name] = [0, 0, 0]  # (the store's order of channels)
            groups.setdefault(id(t), []).append((name, t, v))  # (t is held: ids are unique)
        for members in groups.values():
            t = members[0][1]
            n = int(t.shape[0])
            for s in range(0, n, block):
                e = min(n, s + block)
                times = np.asarray(t[s:e])
                for name, _, v in members:
                    out.add(name, times, np.asarray(v[s:e]))
                    release(v[s:e])
                release(t[s:e])
        return out

    # -- reading ---------------------------------------------------------------------------
    @property
    def names(self) -> list[str]:
        return list(self._info)

    def info(self, name: str | None = None) -> ChannelInfo | list[ChannelInfo]:
        self._need_final()
        if name is None:
            return list(self._info.values())
        try:
            return self._info[name]
        except KeyError:
            raise StoreError(f"unknown channel {name!r}") from None

    def infos(self) -> list[ChannelInfo]:
        self._need_final()
        return list(self._info.values())

    def raw(self, name: str) -> tuple[IntArray, FloatArray]:
        self._need_final()
        r = self._raw.get(name)
        if r is None or r.t is None or r.v is None:
            raise StoreError(f"unknown channel {name!r}")
        return r.t, r.v

    def select(self, patterns: Sequence[str] | None = None, numeric_only: bool = True) -> list[str]:
        """Channels matching any shell-style pattern (all when None), without the constant
        or empty ones when ``patterns`` is None (the contract's default). A pattern that
        is a channel's exact name selects that channel, so ``/accel.data[3]`` means the
        array element, not a character class (as a pattern it also matches on). A pattern
        ``!GLOB`` leaves out the channels ``GLOB`` matches: from those the other patterns
        select, or from the default selection when all patterns are exclusions."""
        self._need_final()
        if not patterns:
            return [i.name for i in self._info.values() if not (numeric_only and i.constant)]
        include, exclude = self._split(patterns)
        chosen = self.select(None, numeric_only) if not include else self._matching(include)
        if not exclude:
            return chosen
        dropped = set(self._matching(exclude))
        return [c for c in chosen if c not in dropped]

    def unmatched(self, patterns: Sequence[str]) -> list[str]:
        """The patterns of ``patterns`` (as :meth:`select` reads them) that match no
        channel: an exclusion ``!GLOB`` whose ``GLOB`` matches none is one too."""
        self._need_final()
        include, exclude = self._split(patterns)
        bad = [p for p in include if not self._matching([p])]
        return bad + [f"!{p}" for p in exclude if not self._matching([p])]

    def unmatched_line(self, patterns: Sequence[str], option: str = "--channels") -> str:
        """The usage error of ``option`` for its first pattern that matches no channel
        (:meth:`unmatched`), or "" when each matches one: it names the archive's
        channels (:func:`~analyzer.errors.capped`: the first four and ``and N more``)
        and, when channels hold the pattern inside their names (``s4`` in
        ``/s4.data``), the one or the ``*s4*`` that matches them (the pattern is matched
        against the whole name, and ``s4`` said only that it matches nothing)."""
        unmatched = self.unmatched(patterns)
        if not unmatched:
            return ""
        pattern = unmatched[0]
        near = self.did_you_mean(pattern)
        hint = f"; did you mean {near}?" if near else ""
        whole = " (a pattern matches the whole name; " if hint else " ("
        if "[" in pattern:
            whole += (
                "brackets holding digits, * or ? match an array's index as written, "
                "'/scan.ranges[1*]'; any other '[' starts a set of characters, '[[]' "
                "matches a '['; "
            )
        return (
            f"{option}: pattern {pattern!r} matches no channel{hint}{whole}the channels: "
            f"{capped(list(self._info))})"
        )

    def did_you_mean(self, pattern: str, literal: bool = False) -> str:
        """What ``"did you mean ...?"`` names for ``pattern`` (its ``GLOB`` for ``!GLOB``):
        the pattern written as a channel's name (:meth:`_rewritten`: ``odom.*`` for
        ``/odom.*``, ``/odom/pose/*`` for ``/odom.pose.*``), or the channels that hold
        it inside their names, case aside (``s4`` in ``/s4.data``): the one, the
        ``*s4*`` that matches them, or a few of them; "" when none does. ``literal``:
        ``pattern`` is a channel's name, not a pattern (its brackets are characters; a
        model's channel the archive lacks, :func:`analyzer.reuse.model_channels`). For
        :meth:`unmatched_line` too."""
        bang, core = (
            ("!", pattern[1:]) if pattern.startswith("!") and not literal else ("", pattern)
        )
        if not literal:
            rewritten = self._rewritten(core)
            if rewritten:
                found = self._matching([rewritten])
                if len(found) == 1 and found[0] == rewritten:
                    return f"{bang}{rewritten}"
                return f"'{bang}{rewritten}', which matches {capped(found)}"
        glob_core = glob.escape(core) if literal else core
        wrapped = f"{'' if glob_core.startswith('*') else '*'}{glob_core}"
        wrapped += "" if glob_core.endswith("*") else "*"
        inside = self._matching([wrapped]) or [
            n for n in self._info if fnmatch.fnmatchcase(n.lower(), wrapped.lower())
        ]
        if len(inside) == 1:
            return f"{bang}{inside[0]}"
        if inside and self._matching([wrapped]) and not literal:
            return f"'{bang}{wrapped}', which matches {capped(inside)}"
        if inside:
            return f"one of {capped(inside)}"
        return ""

    def _rewritten(self, pattern: str) -> str:
        """``pattern`` as the channels are named, where a common slip makes it match none
        and the mended one matches some: a ROS topic without its leading ``/``
        (``odom.*``), or a field path written with ``/`` as PlotJuggler and rqt write it
        (``/odom/pose/*``: the fields follow the topic after a ``.``; the last ``/``s
        are tried first, as a topic's name holds ``/`` too: ``/turtle1/pose/x`` is
        ``/turtle1/pose.x``); "" when none matches."""
        tries = [] if pattern.startswith(("/", "*")) else [f"/{pattern}"]
        for head in tries[:] or [pattern]:
            slashes = [i for i, ch in enumerate(head) if ch == "/" and i > 0]
            for k in range(1, len(slashes) + 1):
                cut = slashes[-k]
                tries.append(head[:cut] + "." + head[cut + 1 :].replace("/", "."))
        return next((p for p in tries if self._matching([p])), "")

    def _split(self, patterns: Sequence[str]) -> tuple[list[str], list[str]]:
        """Patterns that select, and those that leave out (``!GLOB``; a channel whose name
        starts with ``!`` is still selected by its exact name)."""
        include = [p for p in patterns if not p.startswith("!") or p in self._info]
        exclude = [p[1:] for p in patterns if p.startswith("!") and p not in self._info]
        return include, exclude

    def _matching(self, patterns: Sequence[str]) -> list[str]:
        """The channels any of ``patterns`` matches (:func:`~analyzer.store.patterns.
        matching`: an array's index ``[10*]`` as written), in the store's order."""
        hit = {n for p in patterns for n in matching(self._info, p)}
        return [name for name in self._info if name in hit]

    def align(
        self,
        channels: Sequence[str],
        rate_hz: float | None = None,
        start_ns: int | None = None,
        end_ns: int | None = None,
        blank: Collection[str] = (),
    ) -> AlignedSeries:
        """The channels on a common clock (default rate: :func:`clock_rate`, the dominant
        rate of the measuring channels). ``blank``: channels of ``channels`` that have no
        sample at all (a CSV column blank in every row that a saved model needs), their
        columns all NaN, the clock set by the others."""
        self._need_final()
        empty = tuple(c for c in channels if c in blank)
        if len(empty) == len(channels):
            raise StoreError("no channel to align")
        infos = [self.info(c) for c in channels if c not in empty]
        assert all(isinstance(i, ChannelInfo) for i in infos)
        rate = clock_rate(infos) if rate_hz is None else float(rate_hz)  # type: ignore[arg-type]
        if not rate > 0:
            raise StoreError(f"cannot align on a clock rate of {rate!r} Hz")
        t0 = min(i.start_ns for i in infos) if start_ns is None else int(start_ns)  # type: ignore[union-attr]
        t1 = max(i.end_ns for i in infos) if end_ns is None else int(end_ns)  # type: ignore[union-attr]
        if t1 < t0:
            raise StoreError("empty time range")
        rows = np.floor((t1 - t0) * rate / NS_PER_S + 1e-9) + 1
        # (a rate near the float's limit gives no finite count: as many as it can hold,
        # for the check below to refuse by name)
        n = int(rows) if np.isfinite(rows) else sys.maxsize
        span = (t1 - t0) / NS_PER_S
        if n < 2 and rate_hz is not None and span > 0:
            raise StoreError(
                f"--rate {plain_number(rate)} Hz is too low: the data span "
                f"{spoken_duration(span)}, which "
                f"gives "
                f"{n} row(s) on that clock (need at least 2, so at least "
                f"{plain_number(1 / span)} Hz)"
            )
        most = max(i.samples for i in infos)  # type: ignore[union-attr]
        if n > MAX_ROWS_PER_SAMPLE * most + MIN_ROWS_ALLOWED:
            raise StoreError(
                f"the common clock at {plain_number(rate)} Hz would need "
                f"{_count(n if np.isfinite(rows) else span * rate)} rows over "
                f"{spoken_duration(span)} for "
                f"at most {most:,} samples per channel: a timestamp lies far from the others "
                "(an outlier, or a wrong unit), or --rate is far above the data's rate"
                + self._largest_gap(channels, span)
            )
        return AlignedSeries(self, tuple(channels), rate, t0, n, empty)

    def _largest_gap(self, channels: Sequence[str], span_s: float) -> str:
        """For the error above: the largest stretch that no channel covers
        (:meth:`_apart`), or the largest gap between two samples of a channel, when it
        holds most of the span, said as what it likely is: a lone sample far from the
        rest (an outlier timestamp), or two stretches far apart (files of an archive
        recorded apart in time, which one clock cannot hold)."""
        apart = self._apart(channels, span_s)
        if apart:
            return apart
        widest: tuple[float, int, str] | None = None
        seen: set[int] = set()
        for c in channels:  # (the error's path: each time array's steps once)
            tc, _ = self.raw(c)
            if id(tc) in seen:
                continue  # (a channel that shares another's times)
            seen.add(id(tc))
            if tc.shape[0] >= 3:
                steps = np.diff(np.asarray(tc))
                k = int(np.argmax(steps))
                if widest is None or steps[k] > widest[0]:
                    widest = (float(steps[k]), k, c)
        if widest is None:
            return ""
        _, k, name = widest
        t, _ = self.raw(name)
        gap = widest[0] / NS_PER_S
        if gap < 0.5 * span_s:
            return ""
        start = float(self.info(name).start_ns)  # type: ignore[union-attr]
        where = (float(t[k]) - start) / NS_PER_S
        if k == 0 or k == t.shape[0] - 2:
            which = "first" if k == 0 else "last"
            return (
                f"; the {which} sample of {name} lies {spoken_duration(gap)} from the others: "
                "an outlier timestamp"
            )
        return (
            f"; {name} has no sample for {spoken_duration(gap)} after {short_seconds(where)} s: "
            "records that far apart in time are analyzed one at a time (one clock cannot hold "
            "them)"
        )

    def _apart(self, channels: Sequence[str], span_s: float) -> str:
        """For :meth:`_largest_gap`: the largest stretch of time that no channel covers
        (from its first sample to its last), when it holds most of the span: the files of
        an archive that share no channel, recorded far apart (two ROS 1 bags of 2017 and
        2024 were said to have "a timestamp far from the others" or too high a --rate)."""
        spans = sorted(
            (i.start_ns, i.end_ns, i.name)
            for i in (self.info(c) for c in channels)
            if isinstance(i, ChannelInfo)
        )
        best, before, after, reach, last = 0, "", "", spans[0][1], spans[0][2]
        for start, end, name in spans[1:]:
            if start - reach > best:
                best, before, after = start - reach, last, name
            if end > reach:
                reach, last = end, name
        gap = best / NS_PER_S
        if gap < 0.5 * span_s:
            return ""
        return (
            f"; no channel has a sample for {spoken_duration(gap)} between {before}'s last and "
            f"{after}'s first: records that far apart in time are analyzed one at a time "
            "(one clock cannot hold them)"
        )

    def _need_final(self) -> None:
        if not self._final:
            raise StoreError("the store is not finalized")

    def close(self) -> None:
        for r in self._raw.values():
            r.t = r.v = None
        if self._own_dir and self._workdir is not None:
            remove_scratch(self._workdir)

    def __enter__(self) -> ChannelStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _finish(
    name: str, raw: _Raw, paths: dict[str, tuple[Path, Path]], lead: _Raw | None = None
) -> tuple[str, ChannelInfo]:
    """One channel's time-sorted arrays (set on ``raw``) and its summary; ``lead``: the
    finished channel whose times it shares."""
    spilled = paths.get(name)
    v: FloatArray
    if spilled is not None:
        v = np.memmap(spilled[1], dtype=np.float64, mode="r")
    else:
        v = np.concatenate(raw.v_parts)
        raw.v_parts.clear()
    if lead is not None:
        assert lead.t is not None
        t = lead.t
        if lead.order is not None:
            v = np.asarray(v)[lead.order]
    else:
        if spilled is not None:
            t = np.memmap(spilled[0], dtype=np.int64, mode="r")
        else:
            t = np.concatenate(raw.t_parts)
        raw.t_parts.clear()
        if not _is_sorted(t):
            raw.order = np.argsort(t, kind="stable")
            t = np.asarray(t)[raw.order]
            v = np.asarray(v)[raw.order]
    raw.t, raw.v = t, v
    return name, _summarize(name, t, v)


def _is_sorted(t: IntArray, block: int = 1 << 22) -> bool:
    """Whether ``t`` never decreases; a spilled channel's pages read here go back to the
    page cache block by block (:func:`~analyzer.paging.release`), so checking a long
    channel does not hold it in the resident set."""
    n = t.shape[0]
    for s in range(0, n - 1, block):
        e = min(n, s + block + 1)
        falls = bool(np.any(np.diff(t[s:e]) < 0))
        release(t[s:e])
        if falls:
            return False
    return True


def _summarize(name: str, t: IntArray, v: FloatArray, block: int = 1 << 22) -> ChannelInfo:
    n = int(t.shape[0])
    # median period from up to ~1M evenly spread steps (exact for short channels)
    if n > 1:
        stride = max(1, (n - 1) // (1 << 20))
        # t[::stride], taken a block at a time with each block's pages given back: the
        # spread steps touch every page of a spilled channel, whose mapped pages would
        # otherwise all be resident at once (a day of 100 Hz: 69 MB per channel)
        if is_mapped(t):
            parts = []
            for s in range(0, n, block):
                e = min(n, s + block)
                parts.append(np.array(t[-(-s // stride) * stride : e : stride]))
                release(t[s:e])
            spread = np.concatenate(parts)
        else:
            spread = np.asarray(t[::stride] if stride > 1 else t)
        dt = np.diff(spread)
        dt = dt[dt > 0]
        if stride > 1:
            dt = dt / stride  # spread steps estimate the period on average
        period = float(np.median(dt)) if dt.size else 0.0
        # the mean of the steps near the median (gaps and doubled stamps left out): the
        # median alone of jittered steps is off by its sampling noise (+-2 ms of uniform
        # jitter at 100 Hz gave 99.86 Hz, and a common clock 0.14 % slow); of regular
        # steps it is the median itself
        core = dt[(dt > 0.5 * period) & (dt < 1.5 * period)]
        if core.size:
            period = float(np.mean(core))
    else:
        period = 0.0
    gaps = 0
    finite = 0
    lo, hi = np.inf, -np.inf
    levels: set[float] | None = set()
    for s in range(0, n, block):
        e = min(n, s + block)
        vv = np.asarray(v[s:e])
        fin = np.isfinite(vv)
        finite += int(fin.sum())
        if fin.any():
            ff = vv[fin]
            b_lo, b_hi = float(ff.min()), float(ff.max())
            lo, hi = min(lo, b_lo), max(hi, b_hi)
            if levels is not None:
                levels = _two_levels(levels, ff, b_lo, b_hi)
        release(v[s:e])
        if period > 0:
            tt = np.asarray(t[max(0, s - 1) : e])
            gaps += int(np.count_nonzero(np.diff(tt) > GAP_FACTOR * period))
            release(t[max(0, s - 1) : e])
    rate = NS_PER_S / period if period > 0 else 0.0
    kept = None if levels is None else tuple(sorted(levels))
    if period > 0 and n - 1 >= 1 / RARE_STEPS and gaps > RARE_STEPS * (n - 1):
        # more gaps than a regular clock's outages: the steps may vary by nature
        irregular = _irregular(t, period)
        if irregular is not None:
            mean, longest = irregular
            return ChannelInfo(
                name,
                n,
                int(t[0]),
                int(t[-1]),
                NS_PER_S / mean,
                _steps_over(t, longest, block),
                finite,
                lo,
                hi,
                irregular=True,
                bridge=longest / mean,
                levels=kept,
            )
    return ChannelInfo(name, n, int(t[0]), int(t[-1]), rate, gaps, finite, lo, hi, levels=kept)


def _two_levels(seen: set[float], block: FloatArray, lo: float, hi: float) -> set[float] | None:
    """The distinct values of a channel so far, ``seen`` (at most two), with those of its
    next ``block`` of finite values (its least ``lo`` and greatest ``hi``); None once
    there are more than two. Vectorized over the block: each value is compared with
    the block's two extremes, so a channel of more values is known at its first block
    and its later blocks are not compared at all."""
    if lo != hi and not bool(np.all((block == lo) | (block == hi))):
        return None
    out = seen | {lo, hi}
    return out if len(out) <= 2 else None


def _irregular(t: IntArray, period: float) -> tuple[float, float] | None:
    """Of a channel whose steps between samples often exceed :data:`GAP_FACTOR` times
    its (median-based) ``period``: its mean step and its longest bridged step (ns) when
    it is sampled at irregular times, else None (a regular clock that loses samples:
    left as it is).

    Irregular: more than :data:`OFF_CLOCK_SHARE` of its steps are off every whole
    number (at least one) of periods by more than a quarter period, which no regular
    clock does, whatever it loses (a lost sample is a step of two periods), but steps
    spread over a range do: of exponential intervals (Poisson sampling) 64 % are off,
    of gamma-distributed ones of shape 4 53 %, of uniform ones 50 %. A regular clock
    whose stamps jitter by more than about +-25 % of a period (uniformly: its steps then
    vary by +-50 %) is off as often; if it also loses runs of samples (more than
    :data:`RARE_STEPS` of its steps are gaps by the regular rule), it is taken as
    irregular too, and its rate is the mean rate of the samples it delivers.

    Such a channel's steps below the median are as ordinary as those above it: its
    period is the mean step (one raw sample per tick of a clock at its rate, on average;
    the median of exponential steps is ln 2 = 0.69 of their mean, and a clock at its
    rate ticked 1.44 times per sample) and, as the regular rule bridges steps of up to
    :data:`GAP_FACTOR` periods, it bridges steps of up to :data:`GAP_FACTOR` times the
    longest ordinary step, its ``1 - RARE_STEPS`` quantile (a regular clock's is its
    period). Exponential steps: 2.5 x 4.6 = 11.5 mean steps, which one step in 1e5
    exceeds by chance; a stretch without samples longer than that is a gap. Outages
    take under :data:`RARE_STEPS` of the steps, or they would move that quantile."""
    steps = _step_sample(t)
    if steps.shape[0] < 1 / RARE_STEPS:
        return None
    r = steps / period
    off = np.abs(r - np.maximum(1.0, np.rint(r))) > 0.25
    if np.count_nonzero(off) <= OFF_CLOCK_SHARE * steps.shape[0]:
        return None
    longest = GAP_FACTOR * float(np.quantile(steps, 1 - RARE_STEPS))
    mean = float(np.mean(steps[steps <= longest]))
    return mean, longest


def _step_sample(t: IntArray, most: int = 1 << 20, runs: int = 64) -> FloatArray:
    """The positive steps between consecutive samples of ``t``: all of them for up to
    ``most`` steps, else those of ``runs`` contiguous stretches spread evenly over it
    (steps of samples ``k`` apart, as :func:`_summarize` takes for the median, are sums
    of ``k`` steps: their spread is not the steps')."""
    n = t.shape[0]
    if n - 1 <= most:
        steps = np.diff(np.asarray(t))
        release(t)
    else:
        size = most // runs
        parts = []
        for s in np.linspace(0, n - size - 1, runs).astype(np.int64):
            parts.append(np.diff(np.asarray(t[s : s + size + 1])))
            release(t[s : s + size + 1])
        steps = np.concatenate(parts)
    steps = steps[steps > 0]
    return steps.astype(np.float64)


def _steps_over(t: IntArray, limit: float, block: int = 1 << 22) -> int:
    """How many steps between consecutive samples of ``t`` are longer than ``limit``
    (ns), read a block at a time (each block's pages given back)."""
    n = t.shape[0]
    whole = int(limit)  # an integer step exceeds limit when it exceeds its floor
    count = 0
    for s in range(0, n, block):
        tt = t[max(0, s - 1) : min(n, s + block)]
        count += int(np.count_nonzero(np.diff(np.asarray(tt)) > whole))
        release(tt)
    return count


def dominant_rate(rates: Sequence[float]) -> float:
    """The rate most channels share (within 2 %); ties go to the faster. Rounded to an
    integer when within 0.1 % of one (nominal rates such as 200 Hz)."""
    rs = sorted((r for r in rates if r > 0), reverse=True)
    if not rs:
        raise StoreError("no channel has at least two samples: cannot infer a clock rate")
    best: list[float] = []
    for r in rs:
        group = [x for x in rs if abs(x - r) <= 0.02 * r]
        if len(group) > len(best):
            best = group
    rate = float(np.median(best))
    if abs(rate - round(rate)) <= 1e-3 * rate and round(rate) > 0:
        rate = float(round(rate))
    return rate


UNCERTAINTY_FIELD = re.compile(r"(?:^|[./])[A-Za-z0-9_]*covariance(?:\[\d+\])*$", re.IGNORECASE)
"""Names of the entries of a ROS covariance array (``/amcl_pose.pose.covariance[7]``,
``/imu.orientation_covariance[0]``): an estimate's uncertainty, published with it."""


LONG_ARRAY = 64
"""An array field of a message with more elements than this (channels ``topic.field[i]``
of one field, :func:`long_arrays`) holds one sensor's many readings of one kind: a laser
scan's beams (a few hundred to a few thousand), a point cloud's or a depth image's
numbers. The numbered sensors a message carries side by side stay below it: a robot's
joints (a humanoid's ``JointState`` has a few dozen), a 6x6 covariance (36), an array
of a few thermocouples or strain gauges. A 360-beam ``/scan`` at 10 Hz, counted as 360
channels, outvoted a 200-Hz IMU, odometry and joints for the common clock (15 channels),
and the run was refused (the training window too short at 10 Hz), while each beam was
analyzed as a sensor of its own (ux58)."""

_INDEX = re.compile(r"\[\d+\]")


def array_field(name: str) -> str | None:
    """The array field a channel is an element of, its indices as ``[*]``
    (``/scan.ranges[148]`` -> ``/scan.ranges[*]``, ``/tf.transforms[3].transform.x`` ->
    ``/tf.transforms[*].transform.x``: the pattern ``--channels`` takes for all its
    elements); None for a channel that is no array's element."""
    field, count = _INDEX.subn("[*]", name)
    return field if count else None


def long_arrays(names: Iterable[str]) -> dict[str, list[str]]:
    """The array fields of more than :data:`LONG_ARRAY` elements among the channels
    ``names`` (:func:`array_field`), each with its elements, in ``names``' order."""
    fields: dict[str, list[str]] = {}
    for name in names:
        field = array_field(name)
        if field is not None:
            fields.setdefault(field, []).append(name)
    return {f: elements for f, elements in fields.items() if len(elements) > LONG_ARRAY}


def _votes(infos: Sequence[ChannelInfo]) -> list[float]:
    """The rates that vote for the common clock: one per channel, but one per long array
    (:func:`long_arrays`: the rate most of its elements share)."""
    arrays = long_arrays(i.name for i in infos)
    members = {name for elements in arrays.values() for name in elements}
    votes = [i.rate_hz for i in infos if i.name not in members]
    rates = {i.name: i.rate_hz for i in infos}
    for elements in arrays.values():
        own = [rates[name] for name in elements if rates[name] > 0]
        if own:
            votes.append(dominant_rate(own))
    return votes


def clock_rate(infos: Sequence[ChannelInfo]) -> float:
    """The default rate of the common clock for the channels ``infos``: the
    :func:`dominant_rate` of those that measure something, the entries of covariance
    arrays (:data:`UNCERTAINTY_FIELD`) not voting unless every channel is one, and the
    elements of a long array (:data:`LONG_ARRAY`: a laser scan's beams) voting as one
    channel. A 6x6
    covariance matrix is up to 21 distinct numbers per message of the estimate it
    qualifies: counted as channels, a 1.4 Hz pose estimate's 8 varying entries (its pose
    and 4 of its covariance) outvoted a 27 Hz odometry's 6 (the realdata audit's
    ``nav2_turtlebot.mcap``), and the 20-s default training window held 29 rows, too few
    for any detector. Among the channels that vote it is still the rate most share: a
    16-channel 100-Hz archive runs at 100 Hz beside any number of slower ones fewer than
    16."""
    measured = [i for i in infos if not UNCERTAINTY_FIELD.search(i.name)]
    return dominant_rate(_votes(measured if any(i.rate_hz > 0 for i in measured) else infos))


@dataclass(frozen=True, slots=True)
class AlignedSeries:
    """Channels of a store on the clock ``start_ns + k / rate_hz``, ``k < n``."""

    store: ChannelStore
    channels: tuple[str, ...]
    rate_hz: float
    start_ns: int
    n: int
    blank: tuple[str, ...] = ()
    """Channels without a sample (:meth:`ChannelStore.align`'s ``blank``): all NaN."""

    @property
    def duration_s(self) -> float:
        """``n / rate``: the time ``n`` samples cover (one sample period each)."""
        return self.n / self.rate_hz

    def times_ns(self, a: int = 0, b: int | None = None) -> IntArray:
        b = self.n if b is None else b
        k = np.arange(a, b, dtype=np.int64)
        return self.start_ns + np.round(k * (NS_PER_S / self.rate_hz)).astype(np.int64)

    def block(self, a: int, b: int) -> FloatArray:
        """Rows ``a:b`` of the aligned matrix, (b - a, m) float64, NaN in gaps."""
        a = max(0, a)
        b = min(self.n, b)
        out = np.full((max(0, b - a), len(self.channels)), np.nan)
        if b <= a:
            return out
        grid = self.times_ns(a, b)
        for j, name in enumerate(self.channels):
            if name in self.blank:
                continue  # (no sample: NaN, as the gaps)
            t, v = self.store.raw(name)
            info = self.store.info(name)
            assert isinstance(info, ChannelInfo)
            out[:, j] = _resample(t, v, grid, info.rate_hz, self.rate_hz, bridge=info.bridge)
        return out

    def blocks(self, size: int = 1 << 16) -> Iterator[tuple[int, FloatArray]]:
        for a in range(0, self.n, size):
            yield a, self.block(a, a + size)

    def materialize(
        self,
        path: Path | None = None,
        block: int = 1 << 16,
        unreadable: IntArray | None = None,
    ) -> FloatArray:
        """The whole aligned matrix, in memory or memory-mapped at ``path`` (.npy).

        ``unreadable``: an int64 array with an entry per channel, to which the count of
        each channel's aligned values beyond :data:`UNREADABLE` in magnitude (infinities
        included) is added, and they are then NaN (gaps): what an analysis takes, since
        such a value is an overrange or error code, or a corrupt cell, not a reading, and
        one of them would otherwise swamp every estimate it enters.

        A file-backed matrix is filled a block of rows at a time in memory and each block
        written to the file by ``pwrite``: stored through the mapping (a channel's column
        at a time), every page of the new file was faulted in and zeroed by the kernel
        before being overwritten (2 % of a 4-hour run's CPU)."""
        shape = (self.n, len(self.channels))
        if path is None:
            out: FloatArray = np.empty(shape)
        else:
            out = mapped_file(path, shape, np.float64)
        read = [j for j, name in enumerate(self.channels) if name not in self.blank]
        infos = [self.store.info(self.channels[j]) for j in read]
        raws = [self.store.raw(self.channels[j]) for j in read]
        finders = [_Finder(t) for t, _ in raws]
        fd = None if path is None else os.open(path, os.O_WRONLY)
        found: list[IntArray] = []  # per block with unreadable values: counts per channel

        def fill(a: int) -> None:
            b = min(self.n, a + block)
            grid = self.times_ns(a, b)
            rows = out[a:b] if fd is None else np.empty((b - a, shape[1]))
            if len(read) < shape[1]:
                rows[:] = np.nan  # (the blank channels' columns)
            for j, (t, v), info, find in zip(read, raws, infos, finders, strict=True):
                assert isinstance(info, ChannelInfo)
                # straight into the rows, without the block's intermediate copies:
                # a channel sampled on this very clock (what _resample returns for it)
                s = _on_clock(t, grid, info.rate_hz, self.rate_hz, find)
                if s is not None:
                    rows[:, j] = v[s : s + grid.shape[0]]
                    # a spilled channel's pages back to the page cache once copied
                    release(t[s : s + grid.shape[0]])
                    release(v[s : s + grid.shape[0]])
                else:
                    rows[:, j] = _resample(
                        t, v, grid, info.rate_hz, self.rate_hz, find, info.bridge
                    )
            if unreadable is not None:
                bad = np.abs(rows) > UNREADABLE  # NaN is not: a gap already
                if bad.any():
                    rows[bad] = np.nan
                    found.append(np.count_nonzero(bad, axis=0))
            if fd is not None:
                assert isinstance(out, np.memmap)
                at = int(out.offset) + a * shape[1] * rows.itemsize
                pwrite_all(fd, rows.data, at)

        # the blocks are independent and their copies (and page faults) run without the
        # GIL: on threads they overlap
        starts = range(0, self.n, block)
        try:
            if len(starts) < 2 or ALIGN_THREADS < 2:
                for a in starts:
                    fill(a)
            else:
                with ThreadPoolExecutor(ALIGN_THREADS) as pool:
                    for _ in pool.map(fill, starts):
                        pass
        finally:
            if fd is not None:
                os.close(fd)
        if unreadable is not None:
            for counts in found:
                unreadable += counts
        return out


class _Finder:
    """``searchsorted`` on a long sorted time array that reads only near the answer.

    A binary search over a spilled channel touches a page at every halving, and the
    kernel maps the whole large folio (up to 2 MB) around each: block after block of the
    alignment that left about 70 % of each channel's time file resident on a day-long
    archive, pages no block's own release covered. A coarse index (every :attr:`STEP`-th time,
    kept in memory) narrows each search to one stretch of ``STEP`` samples, read and
    given back at once."""

    STEP = 4096

    def __init__(self, t: IntArray) -> None:
        self.t = t
        self.coarse = np.array(t[:: self.STEP]) if t.shape[0] > self.STEP else None
        release(t)  # the index's reads: one time per stretch of the file

    def __call__(self, x: Any, side: Literal["left", "right"] = "left") -> int:
        t = self.t
        if self.coarse is None:
            return int(np.searchsorted(t, x, side))
        # t[k * STEP] for k < i compare before x (as searchsorted on t would), so the
        # answer lies in t[(i - 1) * STEP + 1 .. i * STEP] (or at its end)
        i = int(np.searchsorted(self.coarse, x, side))
        lo = max(0, (i - 1) * self.STEP + 1)
        hi = min(t.shape[0], i * self.STEP)
        if hi <= lo:
            return lo
        window = t[lo:hi]
        k = lo + int(np.searchsorted(window, x, side))
        release(window)
        return k


def _on_clock(
    t: IntArray, grid: IntArray, rate: float, target: float, find: _Finder | None = None
) -> int | None:
    """Where ``grid`` starts in ``t`` when the channel's samples there are exactly the
    ticks of ``grid`` (a channel sampled on the clock itself), else None: then
    ``v[s : s + len(grid)]`` is what :func:`_resample` returns (its first shortcut, for a
    channel it does not decimate)."""
    n = grid.shape[0]
    if t.shape[0] == 0 or n == 0 or not rate > 0 or rate > 1.5 * target:
        return None
    s = int(np.searchsorted(t, grid[0], "left")) if find is None else find(grid[0], "left")
    if s + n <= t.shape[0] and np.array_equal(t[s : s + n], grid):
        return s
    return None


def _resample(
    t: IntArray,
    v: FloatArray,
    grid: IntArray,
    rate: float,
    target: float,
    find: _Finder | None = None,
    bridge: float = GAP_FACTOR,
) -> FloatArray:
    """One channel's raw samples onto ``grid`` (see the module docstring); ``find``
    searches ``t`` (:class:`_Finder`); the pages it reads of ``t`` and ``v`` are
    released (a spilled channel's); steps of more than ``bridge`` periods (``1 /
    rate``) are gaps (:attr:`ChannelInfo.bridge`)."""
    out = np.full(grid.shape[0], np.nan)
    if t.shape[0] == 0 or rate <= 0:
        if t.shape[0] == 1:
            out[grid == t[0]] = v[0]
        return out
    period = NS_PER_S / rate
    decimate = rate > 1.5 * target
    taps = None
    margin = 2
    if decimate:
        ntaps = int(8 * np.ceil(rate / target)) | 1
        from scipy import signal  # only a decimated channel needs it (import: ~1 s)

        taps = signal.firwin(ntaps, 0.45 * target, fs=rate)
        margin = ntaps
    if find is None:
        i0 = int(np.searchsorted(t, grid[0], "left"))
        i1 = int(np.searchsorted(t, grid[-1], "right"))
    else:
        i0, i1 = find(grid[0], "left"), find(grid[-1], "right")
    i0, i1 = max(0, i0 - margin), min(t.shape[0], i1 + margin)
    out = _resampled(t, v, grid, period, taps, i0, i1, out, bridge)
    release(t[i0:i1])
    release(v[i0:i1])
    return out


def _resampled(
    t: IntArray,
    v: FloatArray,
    grid: IntArray,
    period: float,
    taps: FloatArray | None,
    i0: int,
    i1: int,
    out: FloatArray,
    bridge: float = GAP_FACTOR,
) -> FloatArray:
    """:func:`_resample` from the samples ``i0 .. i1 - 1`` of the channel on."""
    if i1 - i0 < 1:
        return out
    tt = np.asarray(t[i0:i1])
    if taps is None:
        # the channel was sampled on this very clock (the usual case for a logger's own
        # channels): its samples are the aligned values, no interpolation needed
        k = int(np.searchsorted(tt, grid[0], "left"))
        if k + grid.shape[0] <= tt.shape[0] and np.array_equal(tt[k : k + grid.shape[0]], grid):
            out[:] = v[i0 + k : i0 + k + grid.shape[0]]
            return out
    vv = np.asarray(v[i0:i1], dtype=np.float64)
    if taps is not None and vv.shape[0] > taps.shape[0]:
        vv = _low_passed(tt, vv, taps, period, bridge)
    base = tt[0]
    x = (tt - base).astype(np.float64)
    g = (grid - base).astype(np.float64)
    if x.shape[0] == 1:
        hit = np.abs(g - x[0]) <= 0.5 * period
        out[hit] = vv[0]
        return out
    y = np.interp(g, x, vv)
    # bracketing raw samples of each tick; a tick is valid when they are close enough
    right = np.searchsorted(x, g, "left")
    exact = (right < x.shape[0]) & (x[np.minimum(right, x.shape[0] - 1)] == g)
    right = np.clip(right, 1, x.shape[0] - 1)
    step = x[right] - x[right - 1]
    inside = (g >= x[0] - 0.5 * period) & (g <= x[-1] + 0.5 * period)
    ok = inside & ((step <= bridge * period) | exact)
    # outside the channel's first/last sample by up to half a period: hold the edge value
    out[ok] = y[ok]
    return out


def _low_passed(
    tt: IntArray, vv: FloatArray, taps: FloatArray, period: float, bridge: float = GAP_FACTOR
) -> FloatArray:
    """``vv`` (raw samples at times ``tt``) through the anti-aliasing FIR ``taps``, from
    the samples that exist only: a normalized convolution on the channel's own clock.

    Each missing sample (a NaN, a step of several periods: a dropped message) is a slot
    with no value, and the taps that fall on such slots or past the channel's first or
    last sample are left out, the others scaled up to the filter's DC gain. A plain
    convolution took them for zeros: a 100 Hz IMU's 9.81 m/s^2 of gravity, decimated to
    20 Hz, began at 5.79 and swung to 10.54 at the record's ends and beside each NaN.
    A step of ``k`` periods has ``k - 1`` empty slots, at most half a filter's length
    (:func:`_slots`): a long outage keeps the two sides apart, and a channel that loses
    a few samples now and then is filtered through its losses (3 of every 53 samples of
    a 1 kHz channel lost: every value is there, not NaN). A value is NaN where less than
    half the filter's weight has its sample. Away from missing samples every tap has its
    sample and the result is the plain convolution's, unchanged.

    Steps of up to ``bridge`` periods are one slot: :data:`GAP_FACTOR` of a regular
    channel; of an irregularly sampled one (:func:`_irregular`), every step short of
    a gap, so its samples are filtered in their order as if evenly spaced at its mean
    step (in time, the cutoff rises in dense stretches and falls in sparse ones)."""
    from scipy import signal

    fin = np.isfinite(vv)
    at = _slots(tt, period, taps.shape[0] // 2 + 1, bridge)
    full = float(np.sum(taps))
    if at is None and bool(fin.all()):
        # every sample there: only the taps past the ends are missing (no second pass)
        num = signal.oaconvolve(vv, taps, mode="same")
        return _edges_scaled(num, taps, full)
    if at is None:
        spread, present = np.where(fin, vv, 0.0), fin.astype(np.float64)
    else:
        spread = np.zeros(int(at[-1]) + 1)
        present = np.zeros(spread.shape[0])
        spread[at] = np.where(fin, vv, 0.0)
        present[at] = fin
    num = signal.oaconvolve(spread, taps, mode="same")
    den = signal.oaconvolve(present, taps, mode="same")
    weight = signal.oaconvolve(present, np.abs(taps), mode="same")
    if at is not None:
        num, den, weight = num[at], den[at], weight[at]
    # where every tap has its sample, den is the DC gain but for rounding: left as is
    partial = np.abs(den - full) > 1e-9 * abs(full)
    with np.errstate(divide="ignore", invalid="ignore"):
        num[partial] = num[partial] * (full / den[partial])
    # the samples present cancel more than half their weight (mostly the filter's
    # negative side lobes): no low-passed value to stand for the tick
    num[partial & ~(den > 0.5 * weight)] = np.nan
    num[~fin] = np.nan
    return num


def _edges_scaled(num: FloatArray, taps: FloatArray, full: float) -> FloatArray:
    """``num`` (``oaconvolve(v, taps, "same")`` of a channel with every sample) with the
    outputs near its ends scaled to the DC gain ``full`` by the taps that had a sample
    (their sums from the taps' running sum, no second convolution)."""
    n, size = num.shape[0], taps.shape[0]
    h = (size - 1) // 2  # "same" output j is the full convolution's j + h
    c = np.concatenate(([0.0], np.cumsum(taps)))
    j = np.unique(np.r_[np.arange(min(h, n)), np.arange(max(0, n - (size - h)), n)])
    den = c[np.minimum(size - 1, j + h) + 1] - c[np.maximum(0, j + h - n + 1)]
    fix = (np.abs(den - full) > 1e-9 * abs(full)) & (den > 0.0)
    num[j[fix]] *= full / den[fix]
    return num


def _slots(tt: IntArray, period: float, most: int, bridge: float = GAP_FACTOR) -> IntArray | None:
    """The slot of each sample on the channel's own clock (None: one each, in a row):
    a step of ``k`` nominal periods (rounded) moves the next sample ``k`` slots on, at
    most ``most + 1`` (past the filter's reach, a longer outage is all the same). Steps
    of up to ``bridge`` periods (:data:`GAP_FACTOR` of a regular channel) are one slot
    (jitter, one bridged sample)."""
    steps = np.diff(tt) / period
    jump = steps > bridge
    if not jump.any():
        return None
    advance = np.ones(tt.shape[0], dtype=np.int64)
    advance[0] = 0
    advance[1:][jump] = np.minimum(np.rint(steps[jump]).astype(np.int64), most + 1)
    return np.cumsum(advance)


def _count(rows: float) -> str:
    """A row count for a message: exact while an integer holds it, else its magnitude."""
    if not np.isfinite(rows):
        return "countless"
    return f"{int(rows):,}" if rows < 1e15 else f"{rows:.3g}"
