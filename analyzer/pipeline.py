"""The one pipeline every entry point calls (``analyzer run``, the watcher, the Dask
backend): readers -> store -> detectors -> diagnosis -> report."""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import inspect
import json
import os
import shutil
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, wait
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer import __version__
from analyzer.config import Config, load_config
from analyzer.detectors import REGISTRY, Dataset, DetectorResult, RunContext, detector_class
from analyzer.detectors.ar_model import flat_channels
from analyzer.detectors.base import SIGNAL_DTYPE
from analyzer.diagnosis import Finding, merge_events, one_fault_at_a_time
from analyzer.diagnosis.changes import Calibration
from analyzer.diagnosis.evidence import attach_evidence, training_tests, windowed_summary
from analyzer.diagnosis.merge import present_at_search_start, traced_into_training
from analyzer.diagnosis.stuck import healthy_stats, relabel_frozen
from analyzer.errors import (
    AnalyzerError,
    ConfigError,
    DetectorError,
    ReaderError,
    UsageError,
    one_line,
)
from analyzer.grouping import partition
from analyzer.modelfile import SavedModel, check_model_path, load_model, save_model
from analyzer.outdir import prepare_dir, remove_if_empty
from analyzer.paging import is_mapped, mapped_file, release, spill, trim_heap
from analyzer.parallel import (
    DaskExecutor,
    Executor,
    SerialExecutor,
    TaskHandle,
    ThreadExecutor,
    locked,
    make_executor,
)
from analyzer.readers import open_archive
from analyzer.readers.base import InputInfo, TimeSource
from analyzer.regenerate import corrected_values, result_signals, write_corrected_csv
from analyzer.scratch import make_scratch, remove_scratch, scratch
from analyzer.store import AlignedSeries, ChannelInfo, ChannelStore
from analyzer.timeutil import iso_utc, parse_time, plausible_epoch
from analyzer.types import NS_PER_S

SCHEMA = "analyzer.findings/1"
DEFAULT_TRAIN_FRACTION = 0.2
DEFAULT_TRAIN_MAX_S = 600.0
MATERIALIZE_IN_MEMORY = 1 << 24
"""Aligned matrices up to this many values stay in memory; larger ones are memory-mapped."""

Progress = Callable[[str, float], None]


@dataclass(slots=True)
class RunOptions:
    """Options of ``analyzer run`` (and ``watch``); None means the contract's default."""

    channels: list[str] | None = None
    train: str | None = None
    config: Config = field(default_factory=Config)
    detectors: list[str] | None = None
    rate: float | None = None
    jobs: int | None = None
    scheduler: str | None = None
    time_source: TimeSource = "log"
    corrected: bool = False
    progress: Progress | None = None
    model: SavedModel | None = None
    """``--model``: fitted models to run instead of fitting on this archive."""
    model_path: str | None = None
    model_sha256: str | None = None
    """The SHA-256 of the model file as it was read (``findings.json``'s ``model``): taken
    when the file is loaded, so a watcher that runs for weeks names the model it uses,
    not a file replaced since, and a cluster worker need not see the file."""
    save_model: Path | None = None
    """``--save-model``: where to write this run's fitted models."""
    screen: list[str] | None = None
    """``--screen``: these detectors first, the others only when they find a fault
    (:func:`analyze_screened`)."""


@dataclass(slots=True)
class Analysis:
    """Everything one run found; ``findings.json`` and the report are views of it."""

    inputs: list[InputInfo]
    channels: list[ChannelInfo]
    analyzed: tuple[str, ...]
    rate_hz: float
    start_ns: int
    absolute_time: bool
    n: int
    train: tuple[int, int]
    results: list[DetectorResult]
    findings: list[Finding]
    values: np.ndarray
    notes: list[str] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    skipped: dict[str, str] = field(default_factory=dict)
    corrected: np.ndarray | None = None
    """With ``--corrected``: the analyzed channels with every fault removed (Wang & Song
    2014, Section 6.3), same shape as ``values``."""
    corrections: list[dict[str, Any]] = field(default_factory=list)
    saved: SavedModel | None = None
    """The fitted models of this run (with ``--save-model``), or those it ran (``--model``)."""
    model_info: dict[str, Any] | None = None
    """With ``--model``: the model file and what it was trained on (``findings.json``)."""
    screen: dict[str, Any] | None = None
    """With ``--screen``: the screening's detectors and whether they found a fault
    (``findings.json``), from :func:`analyze_screened`."""

    @property
    def duration_s(self) -> float:
        """``n / rate``: the time ``n`` samples cover (one sample period each)."""
        return self.n / self.rate_hz

    @property
    def faulty(self) -> bool:
        return bool(self.findings)

    def times_s(self) -> np.ndarray:
        return np.arange(self.n) / self.rate_hz

    def times_between(self, a: int, b: int) -> np.ndarray:
        """Rows ``a .. b - 1`` of :meth:`times_s`."""
        return np.arange(a, b) / self.rate_hz

    def onset_iso(self, seconds: float | None) -> str | None:
        if seconds is None or not self.absolute_time:
            return None
        return iso_utc(self.start_ns + int(round(seconds * NS_PER_S)))


MIN_TRAIN_ROWS = 16
"""Fewer training samples than this cannot calibrate anything: a usage error naming
``--train`` (the detectors ask for more, each with its own reason)."""


def parse_train(text: str, start_ns: int, duration_s: float, absolute: bool) -> tuple[float, float]:
    """``--train START:END`` in seconds from the first sample or ISO-8601 times."""
    parts = _train_parts(text)
    secs = []
    for kind, val in parts:
        if kind == "ns":
            if not absolute:
                raise UsageError(
                    f"--train: {text!r} uses absolute times but the input has relative timestamps"
                )
            secs.append((int(val) - start_ns) / NS_PER_S)
        else:
            secs.append(float(val))
    lo, hi = secs
    if not (0.0 <= lo < hi):
        raise UsageError(f"--train: the window {text!r} must satisfy 0 <= START < END")
    if lo >= duration_s:
        raise UsageError(
            f"--train: the window {text!r} starts after the data ends ({duration_s:.3f} s)"
        )
    return lo, min(hi, duration_s)


def _train_parts(text: str) -> tuple[tuple[str, Any], tuple[str, Any]]:
    """The two halves of ``--train START:END`` as :func:`parse_time` reads them."""
    if text.count(":") < 1:
        raise UsageError(f"--train: expected START:END, got {text!r}")
    # ISO times contain colons: split on the separating colon between two parseable halves
    for i, ch in enumerate(text):
        if ch != ":":
            continue
        try:
            return parse_time(text[:i]), parse_time(text[i + 1 :])
        except ValueError:
            continue
    raise UsageError(f"--train: cannot read {text!r} as START:END (seconds or ISO-8601 times)")


def check_train(text: str) -> None:
    """What can be checked of ``--train`` before the data is read (its syntax and order),
    so a bad window is a usage error up front (the watcher checks it once, not per
    archive)."""
    (ka, a), (kb, b) = _train_parts(text)
    if ka == kb and not (float(a) < float(b) and (ka == "ns" or float(a) >= 0.0)):
        raise UsageError(f"--train: the window {text!r} must satisfy 0 <= START < END")


def default_train(duration_s: float) -> tuple[float, float]:
    """The first 20 % of the data, at most 10 minutes (CONTRACT.md)."""
    return 0.0, min(DEFAULT_TRAIN_FRACTION * duration_s, DEFAULT_TRAIN_MAX_S)


def _select(store: ChannelStore, patterns: list[str] | None, notes: list[str]) -> list[str]:
    infos = {i.name: i for i in store.infos()}
    if not infos:
        raise ReaderError("no numeric channel found in the input")
    if patterns:
        unmatched = store.unmatched(patterns)
        if unmatched:
            raise UsageError(f"--channels: pattern {unmatched[0]!r} matches no channel")
        chosen = store.select(patterns)
        constant = [c for c in chosen if infos[c].constant]
        if constant:
            notes.append(f"constant or empty channels not analyzed: {', '.join(constant)}")
        chosen = [c for c in chosen if not infos[c].constant]
    else:
        chosen = store.select(None)
        constant = [c for c in infos if infos[c].constant]
        if constant:
            notes.append(f"constant or empty channels not analyzed: {', '.join(constant)}")
    if not chosen:
        raise UsageError("no channel left to analyze (all selected channels are constant or empty)")
    return chosen


CROWDED = 1.5
"""A channel with this many times more samples than its own rate gives over its span has
samples that share log times: said in a note."""


def _crowded_channels(
    infos: Sequence[ChannelInfo], chosen: Sequence[str], rate: float
) -> list[str]:
    """Notes on the analyzed channels whose samples crowd onto fewer distinct times (log
    times written in batches): the alignment keeps one value per tick of the ``rate`` Hz
    clock, so the rest are not analyzed. (A channel merely faster than the clock is
    low-passed and decimated: nothing to note.)"""
    notes = []
    wanted = set(chosen)
    for i in infos:
        if i.name not in wanted or not i.rate_hz > 0:
            continue
        times = (i.end_ns - i.start_ns) / NS_PER_S * i.rate_hz + 1
        if i.samples > CROWDED * times:
            notes.append(
                f"{i.name}: {i.samples:,} samples on only about {int(times):,} distinct log "
                f"times at {i.rate_hz:.6g} Hz (written in batches): one value per tick of "
                f"the {rate:.6g} Hz clock is analyzed; --time header (where messages carry "
                "stamps) may keep more"
            )
    return notes


WARMUP_S = 1.0
"""With ``--model``: the least time at a record's start in which no fault is searched."""


def _model_channels(
    store: ChannelStore, model: SavedModel, options: RunOptions, notes: list[str]
) -> list[str]:
    """``--model``'s channels, all of which this archive must have (:class:`UsageError`
    naming the option and the missing ones), in the model's order; a note names the
    archive's other channels (not analyzed) and a time source other than the model's."""
    infos = store.infos()
    have = {i.name for i in infos}
    missing = [c for c in model.channels if c not in have]
    where = options.model_path or "the model"
    if missing:
        more = f" and {len(missing) - 3} more" if len(missing) > 3 else ""
        raise UsageError(
            f"--model {where}: this archive has no channel {', '.join(missing[:3])}{more} "
            f"(the model was fitted on {len(model.channels)} channels)"
        )
    if options.rate is not None and abs(options.rate - model.rate_hz) > 1e-9 * model.rate_hz:
        raise UsageError(
            f"--rate {options.rate:g}: the model {where} was fitted at {model.rate_hz:.6g} Hz; "
            "leave --rate out or fit a model at that rate"
        )
    fitted = set(model.channels)
    others = [i.name for i in infos if i.name not in fitted and not i.constant]
    if others:
        more = f" and {len(others) - 5} more" if len(others) > 5 else ""
        notes.append(
            f"{len(others)} channel(s) of this archive are not in the model and were not "
            f"analyzed: {', '.join(others[:5])}{more} (a model fitted with them includes them)"
        )
    if options.time_source != model.time_source:
        notes.append(
            f"timestamps: --time {options.time_source} here, the model was fitted on "
            f"--time {model.time_source} ones"
        )
    return list(model.channels)


def _warmup(model: SavedModel) -> int:
    """Samples at the start of a record analyzed with ``--model`` in which no fault is
    searched: the filters start from a zero state there, so each fitted model's settling
    time (:func:`_settling`) plus its longest alarm window (the windowed
    statistics at the first searched sample must not reach back into the settling); at
    least :data:`WARMUP_S`. (The caller keeps it to at most half the record.)"""
    warm = int(np.ceil(WARMUP_S * model.rate_hz))
    for fits in model.fits.values():
        for _, fitted in fits.values():
            warm = max(warm, _settling(fitted) + _longest_window(fitted))
    return warm


def _settling(fitted: Any) -> int:
    """Samples a fitted model's filters take to forget their start state to 1e-6 (its
    ``settle``; a bank's slowest estimator's, not the bank's 1e-12 block warm-up)."""
    own = getattr(fitted, "settle", 0) or 0
    bank = getattr(fitted, "bank", None)
    per_estimator = getattr(bank, "settle", ()) or ()
    return int(max([int(own), *(int(x) for x in per_estimator)]))


def _longest_window(obj: Any, depth: int = 0) -> int:
    """The longest window of the alarm calibrations (:class:`Calibration`) held in a
    fitted model's fields (their tuples and nested dataclasses, a few levels deep)."""
    if isinstance(obj, Calibration):
        return max(obj.windows, default=obj.window)
    if depth > 3:
        return 0
    if isinstance(obj, tuple | list):
        return max((_longest_window(x, depth + 1) for x in obj), default=0)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return max(
            (_longest_window(getattr(obj, f.name), depth + 1) for f in dataclasses.fields(obj)),
            default=0,
        )
    return 0


def _in_registry_order(
    kept: dict[str, dict[str, tuple[Any, Any]]],
) -> dict[str, dict[str, tuple[Any, Any]]]:
    """Each channel group's fits in registry order (threads keep them as they finish)."""
    rank = {n: i for i, n in enumerate(REGISTRY)}
    return {
        tag: {n: fits[n] for n in sorted(fits, key=lambda n: rank.get(n, len(rank)))}
        for tag, fits in kept.items()
    }


def _model_detectors(model: SavedModel, options: RunOptions) -> list[str]:
    """The detectors ``--model`` runs: all it holds, or those of ``--detectors`` (each
    of which it must hold)."""
    # registry order, as a run that fits them (the fits themselves may have been kept in
    # the order they finished): the results, and so the findings' merge, follow it
    rank = {n: i for i, n in enumerate(REGISTRY)}
    held = sorted(model.detectors(), key=lambda n: rank.get(n, len(rank)))
    if not options.detectors:
        return held
    absent = [d for d in options.detectors if d not in held]
    if absent:
        raise UsageError(
            f"--detectors {absent[0]}: not in the model {options.model_path or ''} "
            f"(it holds {', '.join(held)})"
        )
    return [d for d in held if d in options.detectors]


def _reuse_note(model: SavedModel, options: RunOptions, warm_s: float) -> str:
    trained = ", ".join(Path(p).name for p, _ in model.inputs[:3])
    if len(model.inputs) > 3:
        trained += f" and {len(model.inputs) - 3} more files"
    return (
        f"fitted models from {options.model_path or 'a model file'} (trained on {trained}, "
        f"healthy window {model.train_s[0]:.3f}-{model.train_s[1]:.3f} s); nothing was "
        f"fitted on this archive, and no fault is searched in its first {warm_s:.3f} s "
        "while the filters settle"
    )


def _model_info(model: SavedModel, options: RunOptions) -> dict[str, Any]:
    path = Path(options.model_path) if options.model_path else None
    digest = options.model_sha256
    if digest is None and path is not None and path.is_file():
        digest = sha256_of(path)
    return {
        "path": str(path) if path else None,
        "sha256": digest,
        **model.describe(),
    }


def _digest(path: Path) -> str:
    """An input's SHA-256, or "" when it is gone."""
    return sha256_of(path) if path.exists() else ""


def _detector_names(options: RunOptions) -> tuple[list[str], bool]:
    if options.detectors:
        for d in options.detectors:
            if d not in REGISTRY:
                detector_class(d)  # raises the UsageError naming the known ones
        return list(options.detectors), True
    return list(REGISTRY), False


def _fit_and_run(
    det: Any, data: Dataset, ctx: RunContext, model: Any = None, keep: bool = False
) -> tuple[Any, DetectorResult]:
    """One detector's task: fit on the healthy window (unless ``model``, a fitted model
    of ``--model``, is given), run over the archive; its per-sample signals are kept as
    float32 (see :data:`SIGNAL_DTYPE`). Returns the fitted model when ``keep``
    (``--save-model``), else None, with the result."""
    if model is None:
        model = det.fit(data, ctx)
    return (model if keep else None), _compact(det.run(model, data, ctx))


def _compact(result: DetectorResult) -> DetectorResult:
    """``result`` with its per-sample signals in :data:`SIGNAL_DTYPE` (the float64 arrays
    of the detector are released as soon as its task ends)."""
    result.residuals = {c: _compacted(a) for c, a in result.residuals.items()}
    result.reference = {c: _compacted(a) for c, a in result.reference.items()}
    return result


def _compacted(a: Any) -> Any:
    """One signal in :data:`SIGNAL_DTYPE`; a memory-mapped one (a long archive's, see
    :meth:`RunContext.buffer`) is left for :func:`_spill` to convert, one channel at a
    time, rather than copied into memory here."""
    return a if is_mapped(a) else np.asarray(a, dtype=SIGNAL_DTYPE)


def _spill(result: DetectorResult, spill_dir: Path | None, tag: str = "") -> DetectorResult:
    """``result`` with its per-sample signals moved to memory-mapped files in
    ``spill_dir`` (a long archive; :func:`analyzer.paging.spill`), so the signals of the
    detectors that have finished stop counting against memory; unchanged without it.
    ``tag`` tells apart the files of one detector's runs on several channel groups."""
    if spill_dir is None:
        return result
    spill_dir.mkdir(exist_ok=True)
    base = spill_dir / f"{result.detector}{tag}"
    result.residuals = spill(
        result.residuals, base.with_name(base.name + "-residuals.npy"), SIGNAL_DTYPE
    )
    result.reference = spill(
        result.reference, base.with_name(base.name + "-reference.npy"), SIGNAL_DTYPE
    )
    return result


def _fit(det: Any, data: Dataset, ctx: RunContext, model: Any = None) -> tuple[Any, Any, float]:
    """A detector's fit on the healthy window, as a task: ``(detector, fitted model,
    seconds)``; ``model`` (``--model``) is returned as it is."""
    t0 = time.perf_counter()
    if model is None:
        model = det.fit(data, ctx)
    return det, model, time.perf_counter() - t0


def _run_detectors(
    names: list[str],
    options: RunOptions,
    data: Dataset,
    ctx: RunContext,
    executor: Executor,
    *rest: Any,
) -> tuple[list[DetectorResult], dict[str, str]]:
    """:func:`_run_planned` with ``executor``; on a Dask cluster the detectors' own steps
    run in this process (threads for the fits, as with ``--jobs``; ``ctx.map_shared`` on
    ``ctx.local``), over its memory-mapped archive and scratch space, and only the pieces
    they split off (time blocks, folds, estimators: ``ctx.map``/``ctx.imap``) go to the
    workers, a few at a time. Neither side then holds the archive: each task carries its
    block's rows, each result is written here as it comes back."""
    if not isinstance(executor, DaskExecutor):
        return _run_planned(names, options, data, ctx, executor, *rest)
    local = ThreadExecutor(max(1, len(names)))
    done = False
    try:
        outcome = _run_planned(names, options, data, ctx, local, *rest)
        done = True
        return outcome
    finally:
        local.close(wait=done)


def _run_planned(
    names: list[str],
    options: RunOptions,
    data: Dataset,
    ctx: RunContext,
    executor: Executor,
    timings: dict[str, float] | None = None,
    spill_dir: Path | None = None,
    finished: Callable[[DetectorResult], None] | None = None,
    tag: str = "",
    fits: dict[str, tuple[Any, Any]] | None = None,
    kept: dict[str, tuple[Any, Any]] | None = None,
) -> tuple[list[DetectorResult], dict[str, str]]:
    """Fit and run the detectors ``names``, each as a task of ``executor``; results and
    skip reasons in registry order, so any executor gives the serial run's output.
    ``finished`` is called with each result as soon as it is final (in that order);
    ``tag`` names the channel group in spilled files' names (:func:`_spill`).
    ``fits`` (``--model``) gives ``(detector, fitted model)`` by name: those run without
    a fit; ``kept`` (``--save-model``) receives each detector's ``(detector, fitted
    model)``.

    A detector whose needs are not met, or that raises :class:`DetectorError`, is skipped
    with its reason; when the user named the detectors (``ctx.explicit``) the first such
    error in registry order is raised instead, as the plain loop would."""
    if fits is not None:  # --model: only what it fitted (on this channel group) runs
        names = [n for n in names if n in fits]
    # Local threads: the fits (training window only, memory independent of the archive's
    # length) run concurrently; the runs over the archive then follow one at a time in
    # this thread, each splitting its own work over the pool (time blocks, chunks,
    # sensors), or over the cluster's workers (ctx.executor). Running two detectors over
    # the archive at once would hold both their per-sample arrays: peak memory would
    # grow twice as fast with the archive.
    staged = isinstance(executor, ThreadExecutor)
    task = _fit if staged else _fit_and_run
    # (name, handle) for a submitted task, (name, error) for one settled up front
    planned: list[tuple[str, Any]] = []
    keep = kept is not None
    dets: dict[str, Any] = {}  # the detector object of each task (saved with its model)
    for name in names:
        given = None if fits is None else fits.get(name)
        if given is not None:  # --model: fitted on another archive, nothing to check here
            det, model = given
            dets[name] = det
            extra: tuple[Any, ...] = (model,) if staged else (model, keep)
            planned.append((name, executor.submit(task, det, data, ctx, *extra)))
            continue
        cls = detector_class(name)
        try:
            det = cls(**options.config.detectors.get(name, {}))
        except TypeError as err:
            bad = ConfigError(f"[detectors.{name}]: {err}")
            bad.__cause__ = err
            planned.append((name, bad))
            break  # the plain loop stops here at the latest: start nothing after it
        reason = det.applicable(data, ctx)
        if reason is not None:
            planned.append((name, _NotApplicable(reason)))
            if ctx.explicit:
                break
            continue
        dets[name] = det
        extra = () if staged else (None, keep)
        planned.append((name, executor.submit(task, det, data, ctx, *extra)))
    # settled[i]: the result of planned[i], or the error its fit or run raised. On threads
    # each run starts as soon as its fit is done (whichever detector that is: a fast fit
    # need not wait for a slow one), one run at a time; results are then taken in
    # registry order, the first error raised as the plain loop would
    settled: dict[int, DetectorResult | BaseException] = {}
    # on threads, a long archive's signals go to files (_spill, then ``finished``) on the
    # pool while the next detector runs, not in between (where one core waited)
    spilling: dict[int, TaskHandle] = {}

    def spill_and_finish(result: DetectorResult) -> DetectorResult:
        out = _spill(result, spill_dir, tag)
        if finished is not None:
            finished(out)
        return out

    # progress: on threads each detector's fit, then its run; else each fit-and-run
    stage = "detect" + (f" group {tag[2:]}" if tag.startswith("-g") else "")
    per = 2 if staged else 1
    total = per * sum(1 for _, p in planned if not isinstance(p, _NotApplicable | AnalyzerError))
    ended = 0

    def show(extra: int = 0) -> None:
        if total:
            ctx.report(stage, min(1.0, (per * ended + extra) / total))

    try:
        for i in _fit_order(planned, staged):
            name, plan = planned[i]
            if isinstance(plan, _NotApplicable | AnalyzerError):
                continue
            if ctx.explicit and any(
                k < i and isinstance(v, BaseException) for k, v in settled.items()
            ):
                continue  # an earlier detector's error will be raised: no need to run this
            try:
                if staged:
                    det, model, fit_s = plan.result()
                    show(1)  # fitted
                    if kept is not None:
                        kept[name] = (det, model)
                    t0 = time.perf_counter()
                    trim_heap()  # what the fits freed
                    ran = _compact(det.run(model, data, ctx))
                    if spill_dir is None:
                        settled[i] = ran
                    else:
                        spilling[i] = executor.submit(spill_and_finish, ran)
                    del ran
                    release(data.values)  # what the run read of a memory-mapped archive
                    trim_heap()  # the run's per-sample arrays
                    if timings is not None:  # the fits overlap: their sum exceeds the wall time
                        # (summed over channel groups)
                        run_s = time.perf_counter() - t0
                        timings[f"fit {name}"] = timings.get(f"fit {name}", 0.0) + fit_s
                        timings[f"run {name}"] = timings.get(f"run {name}", 0.0) + run_s
                else:
                    model, result = plan.result()
                    if kept is not None:
                        kept[name] = (dets[name], model)
                    settled[i] = _spill(result, spill_dir, tag)
                    del result
                    trim_heap()
            except DetectorError as err:
                settled[i] = err
                ended += 1
                show()
                continue
            ended += 1
            show()
            if i in spilling:
                continue  # finished once its signals are in their files
            result = settled[i]
            if finished is not None and isinstance(result, DetectorResult):
                finished(result)
        for i, handle in spilling.items():
            settled[i] = handle.result()
    except BaseException:
        for plan in [p for _, p in planned] + list(spilling.values()):
            if hasattr(plan, "cancel"):
                plan.cancel()
        raise
    if total and per * ended < total:  # detectors left out after an earlier one's error
        ctx.report(stage, 1.0)
    results: list[DetectorResult] = []
    skipped: dict[str, str] = {}
    for i, (name, plan) in enumerate(planned):
        if isinstance(plan, _NotApplicable):
            if ctx.explicit:
                raise DetectorError(f"{name}: {plan.reason}")
            skipped[name] = plan.reason
            continue
        if isinstance(plan, AnalyzerError):
            raise plan
        outcome = settled.get(i)
        if isinstance(outcome, DetectorError):
            if ctx.explicit:
                raise outcome
            skipped[name] = str(outcome)
        elif isinstance(outcome, DetectorResult):
            results.append(outcome)
    return results, skipped


def _run_groups(
    groups: list[tuple[str, ...]],
    names: list[str],
    options: RunOptions,
    data: Dataset,
    ctx: RunContext,
    executor: Executor,
    timings: dict[str, float],
    spill_dir: Path | None,
    finished: Callable[[DetectorResult], None],
    fits: dict[str, dict[str, tuple[Any, Any]]] | None = None,
    kept: dict[str, dict[str, tuple[Any, Any]]] | None = None,
) -> tuple[list[DetectorResult], dict[str, str]]:
    """:func:`_run_detectors` once per channel group (:mod:`analyzer.grouping`), one
    group after the other, each on a copy of its columns (memory-mapped for a long
    archive). The error functions, which pair sensors by the config's own groups, run
    once on every channel. Each group's detectors share the run's false-alarm rate in
    proportion to its channels, so the rate per sample of the archive stays the one
    asked for. Results in group order; skip reasons name the group."""
    results: list[DetectorResult] = []
    skipped: dict[str, str] = {}
    whole = [n for n in names if n == "error_function"]
    if whole:
        results, skipped = _run_detectors(
            whole,
            options,
            data,
            ctx,
            executor,
            timings,
            spill_dir,
            finished,
            "",
            *_fits_of("", fits, kept),
        )
    per_group = [n for n in names if n not in whole]
    total = sum(len(g) for g in groups)
    big = is_mapped(data.values)
    for k, group in enumerate(groups):
        columns = [data.channels.index(c) for c in group]
        path = ctx.workdir / f"group{k}.npy" if big and ctx.workdir is not None else None
        values = _columns(data.values, columns, path)
        part = Dataset(values, group, data.rate_hz, data.train)
        share = replace(ctx, false_alarm_rate=ctx.false_alarm_rate * len(group) / total)
        tag = f"-g{k}"
        got, why = _run_detectors(
            per_group,
            options,
            part,
            share,
            executor,
            timings,
            spill_dir,
            finished,
            tag,
            *_fits_of(tag, fits, kept),
        )
        results.extend(got)
        for name, reason in why.items():
            skipped[f"{name} ({group[0]}..{group[-1]})"] = reason
        del values, part
        trim_heap()
    order = {n: i for i, n in enumerate(names)}
    results.sort(key=lambda r: order.get(r.detector, len(order)))  # stable: groups in order
    return results, skipped


def _fits_of(
    tag: str,
    fits: dict[str, dict[str, tuple[Any, Any]]] | None,
    kept: dict[str, dict[str, tuple[Any, Any]]] | None,
) -> tuple[dict[str, tuple[Any, Any]] | None, dict[str, tuple[Any, Any]] | None]:
    """The ``fits`` and ``kept`` of :func:`_run_detectors` for the channel group ``tag``:
    ``--model``'s fitted detectors of that group (none when the model has no such group),
    and a dict of ``kept`` to receive the group's fits (``--save-model``)."""
    return (
        None if fits is None else fits.get(tag, {}),
        None if kept is None else kept.setdefault(tag, {}),
    )


def _columns(values: Any, columns: list[int], path: Path | None) -> npt.NDArray[np.float64]:
    """``values[:, columns]`` as a contiguous array: in memory, or written block by block
    to a memory-mapped ``path``, unlinked at once (a long archive's matrix is not read
    whole, and the copy's space goes with its mapping)."""
    if path is None:
        return np.ascontiguousarray(np.asarray(values)[:, columns], dtype=np.float64)
    n = values.shape[0]
    out = mapped_file(path, (n, len(columns)), np.float64)
    with contextlib.suppress(OSError):
        path.unlink()
    step = 1 << 16
    for a in range(0, n, step):
        out[a : a + step] = values[a : a + step][:, columns]
        release(values[a : a + step])
        release(out[a : a + step])
    return out


def _skip_reasons(skipped: dict[str, str]) -> list[str]:
    """Why each detector did not run, for the one-line error: a detector skipped on
    several channel groups (keys ``"name (first..last)"``, :func:`_run_groups`) gives its
    first group's reason and how many more groups it failed on, so hundreds of channels
    still make a readable line."""
    by_name: dict[str, list[tuple[str, str]]] = {}
    for key, reason in skipped.items():
        by_name.setdefault(key.split(" (", 1)[0], []).append((key, reason))
    out = []
    for name, items in by_name.items():
        key, reason = items[0]
        if reason.startswith((f"{key}:", f"{key} ")):
            text = reason
        elif reason.startswith((f"{name}:", f"{name} ")):  # "name (group)" for "name"
            text = key + reason[len(name) :]
        else:
            text = f"{key}: {reason}"
        if len(items) > 1:
            text += f" (and on {len(items) - 1} more channel groups)"
        out.append(text)
    return out


def _merge_groups(results: list[DetectorResult], order: Sequence[str]) -> list[DetectorResult]:
    """One result per detector: the runs of a detector on several channel groups joined
    (channels in the archive's ``order``, events and per-channel signals; the model of
    each group under ``model["group_models"]``). Results of a detector that ran once are
    returned as they are."""
    rank = {c: i for i, c in enumerate(order)}
    by_name: dict[str, list[DetectorResult]] = {}
    for r in results:
        by_name.setdefault(r.detector, []).append(r)
    out = []
    for name, parts in by_name.items():
        if len(parts) == 1:
            out.append(parts[0])
            continue
        merged = DetectorResult(
            name,
            tuple(sorted({c for p in parts for c in p.channels}, key=lambda c: rank.get(c, -1))),
            _joined_params([p.params for p in parts]),
            [ev for p in parts for ev in p.events],
            {},
            notes=[n for p in parts for n in p.notes],
        )
        for p in parts:  # a channel in two configured groups: its first group's signals
            for c, v in p.residuals.items():
                merged.residuals.setdefault(c, v)
            for c, v in p.reference.items():
                merged.reference.setdefault(c, v)
            for c, x in p.sigma.items():
                merged.sigma.setdefault(c, x)
            for c, t in p.thresholds.items():
                merged.thresholds.setdefault(c, t)
        merged.model = {
            "groups": len(parts),
            "group_models": [{"channels": list(p.channels), **p.model} for p in parts],
        }
        out.append(merged)
    return out


def _joined_params(params: list[dict[str, Any]]) -> dict[str, Any]:
    """A detector's settings over its channel groups: a setting the groups share as it is,
    one that differs (an order chosen by BIC per group) as the list of the groups'
    values, and the false-alarm rate as the run's (the sum of the groups' shares)."""
    out: dict[str, Any] = {}
    for key in dict.fromkeys(k for p in params for k in p):
        values = [p.get(key) for p in params]
        out[key] = values[0] if all(repr(v) == repr(values[0]) for v in values) else values
    rates = [p.get("false_alarm_rate") for p in params]
    if all(isinstance(r, int | float) for r in rates):
        out["false_alarm_rate"] = float(sum(rates))  # type: ignore[arg-type]
    return out


def _merge_tests(results: list[DetectorResult], parts: list[DetectorResult]) -> None:
    """The residual tests of each group's run (:func:`_residual_tests`, kept in the
    group's model) copied to the joined result of :func:`_merge_groups`."""
    for r in results:
        if "group_models" not in r.model:
            continue
        r.model["training_tests"], r.model["windowed_tests"] = {}, {}
        for p in parts:
            if p.detector != r.detector:
                continue
            for key in ("training_tests", "windowed_tests"):
                for c, v in p.model.get(key, {}).items():
                    r.model[key].setdefault(c, v)
        for g in r.model["group_models"]:
            g.pop("training_tests", None)
            g.pop("windowed_tests", None)


def _residual_tests(
    task: tuple[DetectorResult, tuple[str, ...], tuple[int, int], float],
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The residual tests of some of a detector's channels: over the training window, and
    windowed over the whole archive."""
    result, channels, train, rate_hz = task
    return (
        training_tests(result, train, channels),
        windowed_summary(result, rate_hz, channels=channels),
    )


def _coupled(results: Sequence[DetectorResult]) -> Callable[[str, str, str], bool]:
    """Whether a detector modelled two channels together: both in one of its results
    (one per channel group)."""
    groups: dict[str, list[frozenset[str]]] = {}
    for r in results:
        groups.setdefault(r.detector, []).append(frozenset(r.channels))
    return lambda detector, a, b: any(a in g and b in g for g in groups.get(detector, ()))


def _fit_order(planned: list[tuple[str, Any]], staged: bool) -> Iterator[int]:
    """Indices of ``planned`` in the order their runs start: registry order, or on threads
    (``staged``) as their fits finish (the earliest-registered of those done first)."""
    if not staged:
        yield from range(len(planned))
        return
    waiting = {i: plan for i, (_, plan) in enumerate(planned) if isinstance(plan, Future)}
    yield from (i for i in range(len(planned)) if i not in waiting)
    while waiting:
        wait(list(waiting.values()), return_when=FIRST_COMPLETED)
        first = min(i for i, plan in waiting.items() if plan.done())
        del waiting[first]
        yield first


@dataclass(frozen=True, slots=True)
class _NotApplicable:
    reason: str


def analyze(
    inputs: Sequence[str | Path], options: RunOptions, workdir: Path | None = None
) -> Analysis:
    """Read, align, fit on the healthy window, run the detectors and merge their events.

    With ``workdir`` the raw store and, for long archives, the aligned matrix and long
    results are memory-mapped there (the caller removes it after use); without it
    everything is kept in memory and the scratch space is removed on return.

    The detectors run on the executor ``--jobs``/``--scheduler`` ask for
    (:func:`analyzer.parallel.make_executor`: one thread per core by default, ``--jobs 1``
    serially; on a Dask cluster the detectors' steps stay here and the pieces they split
    off go to the workers, see :func:`_run_detectors`); the results are the serial run's
    whatever the executor. The scheduler is contacted first, so an unreachable one fails
    before any reading."""
    jobs = options.jobs if options.jobs is not None else (os.cpu_count() or 1)
    executor = make_executor(jobs, options.scheduler)
    # on a cluster, this process's own share of the work (alarm searches, observers,
    # residual tests) runs on --jobs threads (default: one per core) of its own
    local = ThreadExecutor(jobs) if isinstance(executor, DaskExecutor) and jobs > 1 else None
    done = False
    try:
        if workdir is None:
            with scratch() as tmp:
                analysis = _analyze(inputs, options, tmp, True, executor, local)
        else:
            analysis = _analyze(inputs, options, workdir, False, executor, local)
        done = True
        return analysis
    finally:
        if local is not None:
            local.close(wait=done)
        executor.close(wait=done)


def analyze_screened(inputs: Sequence[str | Path], options: RunOptions, workdir: Path) -> Analysis:
    """:func:`analyze` with ``--screen``: the archive analyzed with the screening's
    detectors alone first; when they find no fault that is the analysis (a note and
    ``findings.json``'s ``screen`` say the others did not run), else the archive is
    analyzed again with every detector of the run (``--detectors``, or the defaults)
    and that is the analysis, the same as without ``--screen``. A faster pass over a
    long run of mostly healthy archives (one detector alone analyzes 4 hours of MCAP
    1.2-2.6x as fast as all three, the equivalent model fastest), at the price of what
    the screening's detectors miss and the others would have found; a faulty archive
    costs the screening more than a plain run. Screening detectors that cannot run on
    the archive (a :class:`DetectorError`, such as too little healthy data for them)
    leave it to every detector, with their error in ``screen``. Without ``--screen``:
    :func:`analyze`.

    The screening works in a directory of its own in ``workdir``, removed before the
    second analysis (a long archive's aligned matrix and signals are files there)."""
    if not options.screen:
        return analyze(inputs, options, workdir)
    names = ", ".join(options.screen)
    screen_dir = workdir / "screen"
    screen_dir.mkdir()
    shown = options.progress
    screening = replace(
        options,
        detectors=list(options.screen),
        screen=None,
        # its stages shown as the screening's ("screen read", ...): a fault's full
        # analysis shows the plain ones after them
        progress=None if shown is None else lambda stage, done: shown(f"screen {stage}", done),
    )
    try:
        first: Analysis | None = analyze(inputs, screening, screen_dir)
    except DetectorError as err:  # say, too little healthy data for them: the others decide
        first, failed = None, one_line(err)
    if first is not None and not first.faulty:
        first.screen = {"detectors": list(options.screen), "fault": False}
        first.notes.append(
            f"screened with {names} alone (--screen): no fault, so the other detectors did not run"
        )
        return first
    screen: dict[str, Any] = {"detectors": list(options.screen), "fault": True}
    if first is None:  # no verdict of theirs: what stopped them instead
        screen["fault"], screen["error"] = None, failed
        why = f"they could not run ({failed}), so analyzed with every detector"
    else:
        why = "a fault, so analyzed again with every detector; these findings are that analysis's"
    del first
    shutil.rmtree(screen_dir, ignore_errors=True)
    analysis = analyze(inputs, replace(options, screen=None), workdir)
    analysis.screen = screen
    analysis.notes.append(f"screened with {names} alone (--screen): {why}")
    return analysis


def _analyze(
    inputs: Sequence[str | Path],
    options: RunOptions,
    work: Path,
    in_memory: bool,
    executor: Executor,
    local: ThreadExecutor | None = None,
) -> Analysis:
    timings: dict[str, float] = {}
    notes: list[str] = []
    progress = options.progress
    t_start = time.perf_counter()
    archive = open_archive(inputs)
    reading = None if progress is None else partial(progress, "read")
    chunks = archive.chunks(options.time_source, reading)
    with ChannelStore.from_chunks(chunks, work / "store") as store:
        timings["read"] = time.perf_counter() - t_start
        if progress:
            progress("read", 1.0)
        if not store.infos():
            bad = "; ".join(e for i in archive.inputs for e in i.errors)
            raise ReaderError(
                f"{', '.join(str(i.path) for i in archive.inputs)}: no numeric channel found"
                + (f" ({bad})" if bad else "")
            )
        reused = options.model
        if reused is None:
            chosen = _select(store, options.channels, notes)
        else:
            chosen = _model_channels(store, reused, options, notes)
        t0 = time.perf_counter()
        aligned: AlignedSeries = store.align(
            chosen, options.rate if reused is None else reused.rate_hz
        )
        n_values = aligned.n * len(chosen)
        big = n_values > MATERIALIZE_IN_MEMORY and not in_memory
        path = work / "aligned.npy" if big else None
        values = aligned.materialize(path)
        release(values)  # written: its pages go back to the page cache (see analyzer.paging)
        timings["align"] = time.perf_counter() - t0
        if progress:
            progress("align", 1.0)
        # the raw samples are no longer needed: unmap them now, or their pages stay in the
        # resident set for the rest of the run (memory that grows with the archive)
        infos = store.infos()
        store.close()
        # and their files: for a long archive the largest scratch files after the matrix
        # (16 bytes per value: a time and a value), kept to the end of the run until now
        shutil.rmtree(work / "store", ignore_errors=True)
        trim_heap()  # and what reading freed (the CSV reader's Arrow buffers, say)
        notes.extend(_crowded_channels(infos, chosen, aligned.rate_hz))
        absolute = all(i.absolute_time for i in archive.inputs) and plausible_epoch(
            aligned.start_ns
        )
        duration = aligned.duration_s
        if reused is not None:
            # no fit here: the first samples only let the filters settle (no fault is
            # searched there), the rest is tested whole
            wanted = _warmup(reused)
            warm = max(1, min(wanted, aligned.n // 2))
            tr = (0.0, (warm - 1) / aligned.rate_hz)
            if warm < wanted:
                notes.append(
                    f"the model's filters need {wanted / aligned.rate_hz:.6g} s to settle from "
                    f"their zero start state, longer than half this record: the fault search "
                    f"starts at {warm / aligned.rate_hz:.6g} s, and a finding there may be "
                    "the filters still settling (a longer file, or one that follows on, "
                    "tells)"
                )
        elif options.train is not None:
            tr = parse_train(options.train, aligned.start_ns, duration, absolute)
        elif options.config.train is not None:
            tr = options.config.train
            if tr[0] >= duration:
                raise ConfigError(
                    f"{options.config.path}: [train] the window {tr[0]:g}-{tr[1]:g} s starts "
                    f"after the data ends ({duration:.3f} s)"
                )
            tr = (tr[0], min(tr[1], duration))
        else:
            tr = default_train(duration)
        train = (int(round(tr[0] * aligned.rate_hz)), int(round(tr[1] * aligned.rate_hz)) + 1)
        train = (train[0], min(train[1], aligned.n))
        # a channel that does not vary in the healthy window cannot be modelled from it
        tv = np.asarray(values[train[0] : train[1]])
        if reused is not None:
            pass  # the model's channels were modelled on its own training window
        elif tv.shape[0] < MIN_TRAIN_ROWS:
            raise UsageError(
                f"the training window {tr[0]:.3f}-{tr[1]:.3f} s holds {tv.shape[0]} sample(s) "
                f"at {aligned.rate_hz:.6g} Hz, need at least {MIN_TRAIN_ROWS}: give a longer "
                "one with --train (the default is the first 20 % of the data, at most 10 min)"
            )
        flat = flat_channels(tv) if tv.shape[0] else np.ones(len(chosen), bool)
        if reused is None and flat.any():
            dropped = [c for c, f in zip(chosen, flat, strict=True) if f]
            notes.append(
                "constant or empty in the training window, not analyzed: " + ", ".join(dropped)
            )
            keep = np.flatnonzero(~flat)
            if keep.size == 0:
                how = (
                    "--train"
                    if options.train is not None
                    else "[train] in the config"
                    if options.config.train is not None
                    else "--train (default: the first 20 % of the data)"
                )
                raise UsageError(
                    "every selected channel is constant or empty in the training window "
                    f"({tr[0]:.3f}-{tr[1]:.3f} s): choose another window with {how}"
                )
            chosen = [chosen[k] for k in keep]
            values = np.asarray(values)[:, keep]
        data = Dataset(values, tuple(chosen), aligned.rate_hz, train)
        names, explicit = _detector_names(options)
        if reused is not None:
            names = _model_detectors(reused, options)
            notes.append(_reuse_note(reused, options, tr[1] + 1 / aligned.rate_hz))
        healthy = healthy_stats(values, chosen, train) if reused is None else dict(reused.healthy)
        if isinstance(executor, DaskExecutor):
            notes.append(executor.describe())
        parallel = not isinstance(executor, SerialExecutor)
        ctx = RunContext(
            false_alarm_rate=options.config.false_alarm_rate
            if reused is None
            else reused.false_alarm_rate,
            workdir=None if in_memory else work,
            map_outputs=big,
            jobs=executor.workers,
            progress=locked(progress) if parallel else progress,
            config=options.config.as_context() if reused is None else reused.config,
            explicit=explicit,
            executor=executor if parallel else None,
            local=local,
        )
        t0 = time.perf_counter()
        # a long archive's kept signals go to files as each detector finishes
        spill_dir = work / "signals" if big else None
        # the tests of each residual are independent: local threads share the residuals
        # without copies (a cluster would need them shipped: there they run on this
        # process's own threads), one task per detector and channel so the threads stay
        # evenly loaded. A detector's tests start as soon as its run ends, and fill the
        # pool while the next one runs.
        pool = executor if isinstance(executor, ThreadExecutor) else local
        tests: list[tuple[tuple[DetectorResult, tuple[str, ...], tuple[int, int], float], Any]]
        tests = []

        # with --model the training window's tests are the model's (this record has none)
        tested_train = train if reused is None else (0, 0)

        def start_tests(r: DetectorResult) -> None:
            for ch in r.residuals:
                task = (r, (ch,), tested_train, aligned.rate_hz)
                tests.append((task, pool.submit(_residual_tests, task) if pool else None))

        if reused is None:
            groups, group_notes = partition(
                chosen, np.asarray(values[train[0] : train[1]]), options.config.groups
            )
            notes.extend(group_notes)
        else:
            groups = [tuple(g) for g in reused.groups]
        fits = None if reused is None else reused.fits
        kept: dict[str, dict[str, tuple[Any, Any]]] | None = (
            {} if options.save_model is not None else None
        )
        shared = (options, data, ctx, executor, timings, spill_dir, start_tests)
        try:
            if len(groups) == 1 and len(groups[0]) == len(chosen):
                results, skipped = _run_detectors(names, *shared, "", *_fits_of("", fits, kept))
            else:
                results, skipped = _run_groups(groups, names, *shared, fits, kept)
        except BaseException:
            for _, handle in tests:
                if handle is not None:
                    handle.cancel()
            raise
        timings["detect"] = time.perf_counter() - t0
        if not results:
            why = "; ".join(_skip_reasons(skipped))
            hint = ""
            if "too little healthy data" in why:
                hint = (
                    f"; the training window {tr[0]:.3f}-{tr[1]:.3f} s is too short for these "
                    "detectors: give a longer healthy stretch with --train START:END"
                    + (
                        " (the default is the first 20 % of the data, at most 10 min)"
                        if options.train is None and options.config.train is None
                        else ""
                    )
                )
            raise DetectorError(f"no detector could run ({why}){hint}")
        findings = merge_events(ev for r in results for ev in r.events)
        # the seed methods isolate one fault at a time among the sensors modelled together
        findings, conflicts = one_fault_at_a_time(findings, _coupled(results))
        notes.extend(conflicts)
        # a frozen sensor is told by its readings, not by the residual's shape
        notes.extend(relabel_frozen(findings, values, chosen, aligned.rate_hz, healthy))
        notes.extend(traced_into_training(findings, reused is not None))
        if reused is not None:
            search_s = train[1] / aligned.rate_hz
            notes.extend(present_at_search_start(findings, search_s, aligned.rate_hz))
        t0 = time.perf_counter()
        parts = results
        results = _merge_groups(parts, chosen)  # one result per detector (channel groups)
        attach_evidence(findings, results, aligned.rate_hz, train)
        for r in parts:
            r.model["training_tests"], r.model["windowed_tests"] = {}, {}
        for k, (task, handle) in enumerate(tests):
            trained, windowed = _residual_tests(task) if handle is None else handle.result()
            task[0].model["training_tests"].update(trained)
            task[0].model["windowed_tests"].update(windowed)
            ctx.report("tests", (k + 1) / len(tests))
        _merge_tests(results, parts)
        if reused is not None:
            for r in results:
                r.model["training_tests"] = dict(reused.training_tests.get(r.detector, {}))
        # on threads: what was left of the tests when the detection ended
        timings["test"] = time.perf_counter() - t0
        corrected = None
        corrections: list[dict[str, Any]] = []
        if options.corrected:
            res_map, ref_map = result_signals(results)
            corrected, corrections = corrected_values(
                values, chosen, aligned.rate_hz, findings, res_map, ref_map, ctx.buffer
            )
        timings["total"] = time.perf_counter() - t_start
        return Analysis(
            inputs=archive.inputs,
            channels=infos,
            analyzed=tuple(chosen),
            rate_hz=aligned.rate_hz,
            start_ns=aligned.start_ns,
            absolute_time=absolute,
            n=aligned.n,
            train=train,
            results=results,
            findings=findings,
            values=values,
            notes=notes,
            timings=timings,
            skipped=skipped,
            corrected=corrected,
            corrections=corrections,
            saved=reused
            if kept is None
            else SavedModel(
                channels=tuple(chosen),
                rate_hz=aligned.rate_hz,
                train_s=(tr[0], tr[1]),
                inputs=tuple(
                    (str(i.path), i.sha256 or _digest(Path(i.path))) for i in archive.inputs
                ),
                groups=tuple(tuple(g) for g in groups),
                fits=_in_registry_order(kept),
                healthy=healthy,
                training_tests={r.detector: dict(r.model["training_tests"]) for r in results},
                false_alarm_rate=ctx.false_alarm_rate,
                config=dict(ctx.config),
                time_source=options.time_source,
                created=iso_utc(time.time_ns()) or "",
            ),
            model_info=None if reused is None else _model_info(reused, options),
        )


def sha256_of(path: Path) -> str:
    h = hashlib.sha256()
    if path.is_dir():
        for p in sorted(path.rglob("*")):
            if p.is_file():
                h.update(p.relative_to(path).as_posix().encode())
                _hash_file(h, p)
        return h.hexdigest()
    _hash_file(h, path)
    return h.hexdigest()


def _hash_file(h: Any, path: Path) -> None:
    with path.open("rb") as f:
        while blk := f.read(1 << 20):
            h.update(blk)


def findings_document(analysis: Analysis) -> dict[str, Any]:
    """``findings.json`` exactly as in CONTRACT.md (plus extension fields)."""
    a = analysis
    train0, train1 = a.train
    return {
        "schema": SCHEMA,
        "analyzer_version": __version__,
        "inputs": [
            {
                "path": str(i.path),
                "format": str(i.format),
                "sha256": i.sha256 or _digest(Path(i.path)),
                "errors": list(i.errors),
            }
            for i in a.inputs
        ],
        "start": iso_utc(a.start_ns) if a.absolute_time else None,
        "duration_s": round(a.duration_s, 6),
        "rate_hz": a.rate_hz,
        "train": {"start_s": train0 / a.rate_hz, "end_s": (train1 - 1) / a.rate_hz},
        "channels": [
            {
                "name": c.name,
                "samples": c.samples,
                "rate_hz": round(c.rate_hz, 6),
                "gaps": c.gaps,
                "analyzed": c.name in a.analyzed,
            }
            for c in a.channels
        ],
        "faults": [
            {
                "channel": f.channel,
                "type": str(f.type),
                "onset_s": round(f.onset_s, 4),
                "end_s": None if f.end_s is None else round(f.end_s, 4),
                "onset": a.onset_iso(f.onset_s),
                "end": a.onset_iso(f.end_s),
                "magnitude": {k: float(v) for k, v in f.magnitude.items()},
                "confidence": round(float(f.confidence), 4),
                "detector": f.detector,
                "evidence": _jsonable(f.evidence),
            }
            for f in a.findings
        ],
        "detectors": [
            {
                "name": r.detector,
                "channels": list(r.channels),
                "params": _jsonable(r.params),
                "model": _jsonable(r.model),
                "notes": list(r.notes),
            }
            for r in a.results
        ],
        "model": a.model_info,
        "screen": a.screen,
        "skipped_detectors": a.skipped,
        "notes": a.notes,
        "corrections": _jsonable(a.corrections),
    }


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.floating, float)):
        v = float(x)
        return v if np.isfinite(v) else None
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.bool_,)):
        return bool(x)
    if isinstance(x, (str, int, bool)) or x is None:
        return x
    return str(x)


def write_atomic(path: Path, data: bytes | str) -> None:
    """Write ``path`` via a temporary file and rename, so readers never see half a file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data.encode("utf-8") if isinstance(data, str) else data)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the usual file mode
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_outputs(analysis: Analysis, out_dir: Path) -> dict[str, Any]:
    """``out_dir/findings.json`` and ``out_dir/report.html`` (atomically). The report's
    figures are drawn by the worker processes of an enclosing
    :func:`analyzer.report.workers.figure_workers` context (``analyzer run`` enters one),
    else in this process; the page is the same either way."""
    from analyzer.report import render_report

    doc = findings_document(analysis)
    write_atomic(out_dir / "findings.json", json.dumps(doc, indent=2, allow_nan=False) + "\n")
    write_atomic(out_dir / "report.html", render_report(analysis, doc))
    if analysis.corrected is not None:
        write_corrected_csv(
            out_dir / "corrected.csv", analysis.times_between, analysis.analyzed, analysis.corrected
        )
    return doc


def run(inputs: Sequence[str | Path], out_dir: str | Path, options: RunOptions) -> int:
    """``analyzer run``: analyze, write the outputs, return the exit code (0 or 1)."""
    out = Path(out_dir)
    if options.save_model is not None:
        check_model_path(options.save_model)
        _not_into_inputs(options.save_model, inputs)
    created = prepare_dir(out, "--out")  # before the work: it must not fail at the end
    work = make_scratch()
    try:
        analysis = analyze_screened(inputs, options, work)
        if options.progress:
            options.progress("report", 0.0)
        write_outputs(analysis, out)
        if options.progress:
            options.progress("report", 1.0)
        if options.save_model is not None and analysis.saved is not None:
            save_model(options.save_model, analysis.saved)
        return 1 if analysis.faulty else 0
    except BaseException:
        if created:
            remove_if_empty(out)
        raise
    finally:
        remove_scratch(work)


def _not_into_inputs(path: Path, inputs: Sequence[str | Path]) -> None:
    """``--save-model`` must not overwrite an input file nor add a file to an input
    directory (an archive of several files): inputs are never modified."""
    target = path.resolve()
    for i in inputs:
        src = Path(i).resolve()
        if target == src or (src.is_dir() and src in target.parents):
            raise UsageError(
                f"--save-model: {path} is {'an input' if target == src else 'inside the input'}"
                f" {i}: inputs are never modified; write the model elsewhere"
            )


def load_options(config_path: str | None, **kw: Any) -> RunOptions:
    """RunOptions with the config file loaded and validated (every detector section,
    whether or not that detector runs: a typo never passes silently)."""
    model_path = kw.pop("model", None)
    save = kw.pop("save_model", None)
    if model_path is not None:
        for option, key in (("--train", "train"), ("--channels", "channels")):
            if kw.get(key) is not None:
                raise UsageError(
                    f"{option}: not used with --model (the model was fitted on its own "
                    "channels and healthy window)"
                )
        if config_path is not None:
            raise UsageError(
                f"--config {config_path}: not used with --model (the model holds the "
                "configuration it was fitted with)"
            )
        if save is not None:
            raise UsageError("--save-model: not used with --model (nothing is fitted)")
        kw["model"] = load_model(model_path)
        kw["model_path"] = str(model_path)
        with contextlib.suppress(OSError):  # (read a moment ago: gone only in a race)
            kw["model_sha256"] = sha256_of(Path(model_path))
    if save is not None:
        kw["save_model"] = Path(save)
        check_model_path(kw["save_model"])
    cfg = load_config(config_path, set(REGISTRY))
    _check_detector_options(cfg)
    if kw.get("train") is not None:
        check_train(kw["train"])
    if kw.get("detectors"):
        kw["detectors"] = list(dict.fromkeys(kw["detectors"]))  # each detector runs once
        for name in kw["detectors"]:
            detector_class(name)  # an unknown name is a usage error before any reading
    if kw.get("screen"):
        kw["screen"] = _check_screen(list(dict.fromkeys(kw["screen"])), kw)
    return RunOptions(config=cfg, **kw)


def _check_screen(screen: list[str], kw: dict[str, Any]) -> list[str]:
    """``--screen``'s detectors, checked before any reading: known, among those the run
    would run (``--detectors``, a ``--model``'s), not all of them, and not with
    ``--save-model`` (a screened run may fit only some of the detectors)."""
    for name in screen:
        if name not in REGISTRY:
            known = ", ".join(REGISTRY)
            raise UsageError(f"--screen {name}: no such detector (known: {known})")
    if kw.get("save_model") is not None:
        raise UsageError(
            "--screen: not used with --save-model (a screened run fits only the screening's "
            "detectors when they find nothing)"
        )
    model = kw.get("model")
    held = list(model.detectors()) if model is not None else None
    full = kw.get("detectors") or held or list(REGISTRY)
    absent = [d for d in screen if d not in full]
    if absent:
        where = "--detectors" if kw.get("detectors") else "the model" if held else "the run"
        raise UsageError(f"--screen {absent[0]}: not among the detectors of {where}")
    if set(screen) >= set(full):
        raise UsageError(
            f"--screen {','.join(screen)}: every detector of the run; screen with fewer"
        )
    return screen


def _check_detector_options(cfg: Config) -> None:
    """Each ``[detectors.NAME]`` section's settings: known to the detector and accepted by
    it (:class:`ConfigError` naming the file, the section and the setting)."""
    for name, opts in cfg.detectors.items():
        cls = detector_class(name)
        params = inspect.signature(cls.__init__).parameters
        known = [k for k, p in params.items() if k != "self" and p.kind is p.POSITIONAL_OR_KEYWORD]
        if not any(p.kind is p.VAR_KEYWORD for p in params.values()):
            for key in opts:
                if key not in known:
                    raise ConfigError(
                        f"{cfg.path}: [detectors.{name}] unknown setting {key!r} "
                        f"(known: {', '.join(known)})"
                    )
        try:
            cls(**opts)
        except (AnalyzerError, TypeError, ValueError) as err:
            msg = str(err)
            where = "" if msg.startswith(f"[detectors.{name}]") else f"[detectors.{name}] "
            raise ConfigError(f"{cfg.path}: {where}{msg}") from err


__all__ = [
    "Analysis",
    "AnalyzerError",
    "RunOptions",
    "analyze",
    "findings_document",
    "load_options",
    "run",
    "write_outputs",
]
