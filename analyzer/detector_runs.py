"""Fitting and running the detectors over the aligned channels: each detector a task of
the executor (threads, a Dask cluster or serial: the same results), once per channel
group, a long archive's per-sample signals moved to files as each detector finishes,
and the groups' results joined back into one per detector."""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, wait
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.detectors import REGISTRY, Dataset, DetectorResult, RunContext, detector_class
from analyzer.detectors.base import SIGNAL_DTYPE
from analyzer.errors import AnalyzerError, ConfigError, DetectorError, TooLittleDataError
from analyzer.options import RunOptions
from analyzer.paging import is_mapped, mapped_file, release, spill, trim_heap
from analyzer.parallel import DaskExecutor, Executor, TaskHandle, ThreadExecutor
from analyzer.types import Note, Stage, stage_detail


class SkipReason(Note):
    """Why a detector did not run, as the findings write it (a text), and, when it had
    too little healthy data (:class:`~analyzer.errors.TooLittleDataError`), the training
    rows it would need (``rows``): the reasons travel as text through the channel groups
    and the screening to the one-line error, which says how long a window would do
    (:func:`analyzer.pipeline._no_detector_error`)."""

    rows: int | None

    def __new__(cls, text: str, rows: int | None = None) -> SkipReason:
        reason = super().__new__(cls, text)
        reason.rows = rows
        return reason


def skip_reason(err: DetectorError, data: Dataset) -> str:
    """``err``'s text, with the training rows the detector would need when it had too
    little healthy data. Of what it counts (finite residual samples, rows with every
    lag) it lost rows with a gap in some channel, a share of any window (scaled with
    it), and complete rows it left out while its filters settled, which the detectors
    cap at a quarter of the window: at a short window the cap cuts the settling short,
    and a longer one leaves more out (a SKAB valve's 241 rows left 60 of the residual,
    631 rows 157). So the need is counted with a quarter of the window left out, or
    what was left out when more, and never below the need scaled by the window's rows
    per counted sample (many gaps, each followed by a settling)."""
    if not isinstance(err, TooLittleDataError) or err.need <= err.have or err.have <= 0:
        return str(err)
    train = np.asarray(data.train_values())  # (short: the window was too short)
    complete = int(np.isfinite(train).all(axis=1).sum()) if train.ndim == 2 else 0
    if complete <= 0:
        return str(err)  # (no row holds every channel: no length can be told)
    settled = max(complete - err.have, -(-err.need // 3))
    rows = len(train)
    return SkipReason(
        str(err),
        max(
            math.ceil((err.need + settled) * rows / complete),
            math.ceil(err.need * rows / err.have),
        ),
    )


class TooShortForNamed(DetectorError):
    """A detector the user named (``--detectors``) had too little healthy data, and every
    other named one that could not run too: the run stops with the first one's error, as
    any named detector's, and ``reasons`` (each such detector's :class:`SkipReason`, by
    name) let the line say the window that lets all of them run
    (:func:`analyzer.pipeline._no_detector_error`). Before, such a line gave no length:
    ``ar_kalman_bank: too little healthy data to calibrate thresholds: 181 finite
    samples ..., need at least 512`` on a SKAB valve at 1 Hz."""

    def __init__(self, message: str, reasons: dict[str, str]) -> None:
        super().__init__(message)
        self.reasons = reasons


def detector_names(options: RunOptions) -> tuple[list[str], bool]:
    """The detectors a run fits (``--detectors``, else every registered one), and whether
    the user named them: a named detector that cannot run fails the run with its reason
    (``RunContext.explicit``), a default one is skipped with it."""
    if options.detectors:
        for d in options.detectors:
            if d not in REGISTRY:
                detector_class(d)  # raises the UsageError naming the known ones
        return list(options.detectors), True
    return list(REGISTRY), False


def _fit_and_run(
    det: Any,
    data: Dataset,
    ctx: RunContext,
    model: Any = None,
    keep: bool = False,
    run_ctx: RunContext | None = None,
) -> tuple[Any, DetectorResult]:
    """One detector's task: fit on the healthy window (unless ``model``, a fitted model
    of ``--model``, is given), run over the archive (with ``run_ctx`` when given: the run's
    own progress, :class:`_DetectShown`); its per-sample signals are kept as float32 (see
    :data:`SIGNAL_DTYPE`). Returns the fitted model when ``keep`` (``--save-model``), else
    None, with the result."""
    if model is None:
        model = det.fit(data, ctx)
    return (model if keep else None), _compact(det.run(model, data, run_ctx or ctx))


STEP_SHARE = 0.99
"""The most of its share a detector's fit or run advances ``detect`` by its own steps:
the rest when it has ended (a step's items done is not yet the fit or run done)."""


class _DetectShown:
    """``detect``'s progress: one stage over every detector, each detector's fit and
    run an equal share of it, advanced inside them by their own steps (time blocks,
    filters, observers: :class:`~analyzer.detectors.base.Steps`, one call per item) and
    named in the stage's detail (``detection_filter run: time blocks 3/8``), from any
    thread. Its share only rises: a step that starts again from nothing (the next step of
    the same run) leaves it where it was. Before, a detector's steps were stages of their
    own (``ar_kalman_bank 6%`` after ``detect 33%``), and the detection filter's and the
    equivalent model's none at all: a day's run was silent for 45-51 s (the ux55
    audit)."""

    def __init__(self, ctx: RunContext, stage: str, detectors: int) -> None:
        self.ctx, self.stage, self.total = ctx, stage, max(1, 2 * detectors)
        self.parts: dict[tuple[str, str], float] = {}
        self.said = 0.0
        self.lock = threading.Lock()

    def advance(self, name: str, phase: str, share: float, what: str = "") -> None:
        """``name``'s ``phase`` (fit, run) at ``share`` of its own (at most), ``what`` the
        step under way; said as ``detect`` with the detector in its detail."""
        if self.ctx.progress is None:
            return
        with self.lock:
            key = (name, phase)
            self.parts[key] = max(self.parts.get(key, 0.0), min(1.0, share))
            self.said = max(self.said, min(1.0, sum(self.parts.values()) / self.total))
            detail = f"{name} {phase}" + (f": {what}" if what else "")
            self.ctx.report(Stage(self.stage, detail), self.said)

    def ended(self, name: str, phase: str) -> None:
        """``name``'s ``phase`` done: its whole share."""
        self.advance(name, phase, 1.0, "done")

    def context(self, name: str, phase: str) -> RunContext:
        """The context ``name``'s ``phase`` runs with: its steps advance ``detect``."""
        if self.ctx.progress is None:
            return self.ctx

        def step(what: str, share: float) -> None:
            self.advance(name, phase, STEP_SHARE * share, what)

        return replace(self.ctx, progress=step)


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


def run_detectors(
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
    # progress: each detector's fit, then its run, advanced by their own steps
    # (a channel group's part of detect says its group: run_groups, _part_progress)
    shown = _DetectShown(ctx, "detect", len(names))
    for name in names:
        given = None if fits is None else fits.get(name)
        fit_ctx = shown.context(name, "fit")
        if given is not None:  # --model: fitted on another archive, nothing to check here
            det, model = given
            dets[name] = det
            extra: tuple[Any, ...] = (
                (model,) if staged else (model, keep, shown.context(name, "run"))
            )
            planned.append((name, executor.submit(task, det, data, fit_ctx, *extra)))
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
        extra = () if staged else (None, keep, shown.context(name, "run"))
        planned.append((name, executor.submit(task, det, data, fit_ctx, *extra)))
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

    total = sum(1 for _, p in planned if not isinstance(p, _NotApplicable | AnalyzerError))
    shown.total = max(1, 2 * total)  # (the detectors that are fitted and run)
    ended = 0

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
                    shown.ended(name, "fit")
                    if kept is not None:
                        kept[name] = (det, model)
                    t0 = time.perf_counter()
                    trim_heap()  # what the fits freed
                    ran = _compact(det.run(model, data, shown.context(name, "run")))
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
                shown.ended(name, "fit")
                shown.ended(name, "run")
                continue
            ended += 1
            if not staged:  # (on threads its fit's end was said when it was fitted)
                shown.ended(name, "fit")
            shown.ended(name, "run")
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
    if total and ended < total:  # detectors left out after an earlier one's error
        ctx.report("detect", 1.0)
    if ctx.explicit:
        _too_short_for_named(planned, settled, data)
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
            if ctx.explicit:  # the one-line error names the detector that could not run
                if str(outcome).startswith((f"{name}:", f"{name} ")):
                    raise outcome
                raise DetectorError(f"{name}: {outcome}") from outcome
            skipped[name] = skip_reason(outcome, data)
        elif isinstance(outcome, DetectorResult):
            results.append(outcome)
    return results, skipped


def _too_short_for_named(
    planned: list[tuple[str, Any]],
    settled: dict[int, DetectorResult | BaseException],
    data: Dataset,
) -> None:
    """Raise :class:`TooShortForNamed` when the first named detector (registry order)
    that cannot run had too little healthy data and so had every other one that cannot:
    a window long enough for the first alone stopped at the next one's need. Detectors
    after the first error were not waited for (its error is raised): their fits are
    waited for here (on a cluster, fit and run: one task). Returns when another reason
    stops a named detector (the plain error is raised, as before)."""
    first = next(
        (
            i
            for i, (_, plan) in enumerate(planned)
            if isinstance(plan, _NotApplicable | AnalyzerError)
            or isinstance(settled.get(i), BaseException)
        ),
        None,
    )
    if first is None or not isinstance(settled.get(first), TooLittleDataError):
        return
    reasons: dict[str, str] = {}
    for i, (name, plan) in enumerate(planned):
        outcome: Any = settled.get(i)
        if isinstance(plan, _NotApplicable | AnalyzerError):
            return
        if outcome is None and i > first:
            try:
                plan.result()
            except AnalyzerError as err:
                outcome = err
        if isinstance(outcome, TooLittleDataError):
            reasons[name] = skip_reason(outcome, data)
        elif isinstance(outcome, BaseException):
            return
    name = planned[first][0]
    outcome = settled[first]
    said = str(outcome)
    if not said.startswith((f"{name}:", f"{name} ")):
        said = f"{name}: {said}"
    raise TooShortForNamed(said, reasons) from outcome


def _part_progress(ctx: RunContext, at: int, parts: int, what: str) -> RunContext:
    """``ctx`` whose ``detect`` progress is part ``at`` of ``parts`` alike (a channel
    group's detectors, or the detectors of every channel), its share of the whole stage,
    with ``what`` (``group 3/32 (ch64..ch79)``) before the step under way: one ``detect``
    stage whose share only rises. Before, each group was a stage of its own, ``detect
    group 0`` ... ``detect group 31``, each first said at its own early share: a
    500-channel run showed ``17%`` for 55 s and never said how many groups there were
    (the ux56 audit)."""
    if ctx.progress is None:
        return ctx
    shown = ctx.progress

    def report(stage: str, done: float) -> None:
        detail = stage_detail(stage)
        said = f"{what}: {detail}" if detail else what
        shown(Stage(str(stage), said), (at + min(1.0, max(0.0, done))) / parts)

    return replace(ctx, progress=report)


def run_groups(
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
    """:func:`run_detectors` once per channel group (:mod:`analyzer.grouping`), one
    group after the other, each on a copy of its columns (memory-mapped for a long
    archive). The error functions, which pair sensors by the config's own groups, run
    once on every channel. Each group's detectors share the run's false-alarm rate in
    proportion to its channels, so the rate per sample of the archive stays the one
    asked for. Results in group order; skip reasons name the group. Named detectors
    with too little healthy data on a group (:class:`TooShortForNamed`) go on to the
    other groups, whose needs the window's hint counts too, then stop the run."""
    results: list[DetectorResult] = []
    skipped: dict[str, str] = {}
    short: list[TooShortForNamed] = []
    whole = [n for n in names if n == "error_function"]
    parts = len(groups) + (1 if whole else 0)  # (detect's share: each part alike)
    if whole:
        try:
            results, skipped = run_detectors(
                whole,
                options,
                data,
                _part_progress(ctx, 0, parts, "every channel"),
                executor,
                timings,
                spill_dir,
                finished,
                "",
                *fits_of("", fits, kept),
            )
        except TooShortForNamed as err:
            short.append(err)
    per_group = [n for n in names if n not in whole]
    total = sum(len(g) for g in groups)
    big = is_mapped(data.values)
    for k, group in enumerate(groups):
        columns = [data.channels.index(c) for c in group]
        path = ctx.workdir / f"group{k}.npy" if big and ctx.workdir is not None else None
        values = _columns(data.values, columns, path)
        # the group's columns, and everything else of the run's data (where the search
        # starts: a search again after a stretch of another load)
        part = replace(data, values=values, channels=group)
        share = replace(ctx, false_alarm_rate=ctx.false_alarm_rate * len(group) / total)
        share = _part_progress(
            share,
            parts - len(groups) + k,
            parts,
            f"group {k + 1}/{len(groups)} ({group[0]}..{group[-1]})",
        )
        tag = f"-g{k}"
        try:
            got, why = run_detectors(
                per_group,
                options,
                part,
                share,
                executor,
                timings,
                spill_dir,
                finished,
                tag,
                *fits_of(tag, fits, kept),
            )
        except TooShortForNamed as err:
            got, why = [], {}
            short.append(err)
            err.reasons = {f"{n} ({group[0]}..{group[-1]})": r for n, r in err.reasons.items()}
        results.extend(got)
        for name, reason in why.items():
            skipped[f"{name} ({group[0]}..{group[-1]})"] = reason
        del values, part
        trim_heap()
    if short:
        raise TooShortForNamed(str(short[0]), {k: r for e in short for k, r in e.reasons.items()})
    order = {n: i for i, n in enumerate(names)}
    results.sort(key=lambda r: order.get(r.detector, len(order)))  # stable: groups in order
    return results, skipped


def fits_of(
    tag: str,
    fits: dict[str, dict[str, tuple[Any, Any]]] | None,
    kept: dict[str, dict[str, tuple[Any, Any]]] | None,
) -> tuple[dict[str, tuple[Any, Any]] | None, dict[str, tuple[Any, Any]] | None]:
    """The ``fits`` and ``kept`` of :func:`run_detectors` for the channel group ``tag``:
    ``--model``'s fitted detectors of that group (none when the model has no such group),
    and a dict of ``kept`` to receive the group's fits (``--save-model``)."""
    return (
        None if fits is None else fits.get(tag, {}),
        None if kept is None else kept.setdefault(tag, {}),
    )


def fitted_estimates(
    collected: dict[str, dict[str, tuple[Any, Any]]],
    groups: Sequence[Sequence[str]],
    channels: Sequence[str],
) -> Callable[[str, str], tuple[int, Callable[[Any, int], npt.NDArray[np.float64]]] | None]:
    """``estimates(detector, channel)`` for :func:`analyzer.regenerate.corrected_values`:
    the fitted detector of the channel's group (``collected``, as :func:`fits_of` fills
    it: tag ``""`` for one group of every channel and for the error functions, ``-g{k}``
    for ``groups[k]``) computes its estimate of the channel again on rows of every
    analyzed channel (``channels``' order), with the model as fitted: ``(warmup,
    estimate(rows, start))`` from the detector's ``estimate_warmup(model, j)`` and
    ``estimate(model, rows, start, j)`` (``j``: the channel's column in its group), or
    None for a detector without them or without an estimate of that channel."""
    single = len(groups) == 1 and len(groups[0]) == len(channels)
    where: dict[str, tuple[str, tuple[str, ...]]] = {}
    if not single:
        for k, group in enumerate(groups):
            where.update({c: (f"-g{k}", tuple(group)) for c in group})

    def estimates(
        detector: str, channel: str
    ) -> tuple[int, Callable[[Any, int], npt.NDArray[np.float64]]] | None:
        tag, group = where.get(channel, ("", tuple(channels)))
        fitted = collected.get(tag, {}).get(detector)
        if fitted is None and tag:  # (the error functions: one run on every channel)
            tag, group = "", tuple(channels)
            fitted = collected.get(tag, {}).get(detector)
        if fitted is None or channel not in group:
            return None
        det, model = fitted
        if not hasattr(det, "estimate") or not hasattr(det, "estimate_warmup"):
            return None
        columns = [list(channels).index(c) for c in group]
        i = group.index(channel)
        warmup = det.estimate_warmup(model, i)
        if warmup is None:
            return None

        def estimate(rows: Any, start: int) -> npt.NDArray[np.float64]:
            part = np.ascontiguousarray(np.asarray(rows)[:, columns], dtype=np.float64)
            return np.asarray(det.estimate(model, part, start, i), dtype=np.float64)

        return int(warmup), estimate

    return estimates


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


def skip_reasons(skipped: dict[str, str]) -> list[str]:
    """Why each detector did not run, for the one-line error: a detector skipped on
    several channel groups (keys ``"name (first..last)"``, :func:`run_groups`) gives its
    first group's reason and how many more groups it failed on, so hundreds of channels
    still make a readable line."""
    by_name: dict[str, list[tuple[str, str]]] = {}
    for key, reason in skipped.items():
        by_name.setdefault(key.split(" (", 1)[0], []).append((key, reason))
    # detectors that fail for the same reason on the same group share one entry
    # ("ar_kalman_bank, detection_filter (a..b): singular AR regression ..."): the two AR
    # detectors fit the same model, and their reasons twice made the line 1.6 kB
    said: dict[tuple[str, str], list[str]] = {}
    for name, items in by_name.items():
        key, reason = items[0]
        if reason.startswith((f"{key}:", f"{key} ")):
            text = reason[len(key) :]
        elif reason.startswith((f"{name}:", f"{name} ")):  # "name (group)" for "name"
            text = reason[len(name) :]
        else:
            text = f": {reason}"
        if len(items) > 1:
            text += f" (and on {len(items) - 1} more channel groups)"
        said.setdefault((key[len(name) :], text), []).append(name)
    return [", ".join(names) + group + text for (group, text), names in said.items()]


def merge_groups(results: list[DetectorResult], order: Sequence[str]) -> list[DetectorResult]:
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
            unattributed=[u for p in parts for u in p.unattributed],
            # the ends only where every part gave them (they pair with the anomalies)
            unattributed_end_s=(
                [e for p in parts for e in p.unattributed_end_s]
                if all(len(p.unattributed_end_s) == len(p.unattributed) for p in parts)
                else []
            ),
            undecided=[u for p in parts for u in p.undecided],
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


def merge_tests(results: list[DetectorResult], parts: list[DetectorResult]) -> None:
    """The residual tests of each group's run (kept in the group's model by the
    pipeline) copied to the joined result of :func:`merge_groups`."""
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


def coupled(results: Sequence[DetectorResult]) -> Callable[[str, str, str], bool]:
    """``coupled(detector, a, b)``: whether a fault on channel ``b`` can show in what
    ``detector`` reports of channel ``a``: both in one of its results (one per channel
    group), and, where the result says which sensors' faults reach each residual, ``b``
    among those of ``a``. A result says so by the equivalent model's sensor network
    (``model["network"]``), or by ``model["reach"]``, the channels whose readings enter
    each residual, which may lie outside the result's ``channels``: the error functions
    report their uncertain sensors only, but each reads its references (and measured
    inputs) too, so a fault on a reference reaches the error function of every uncertain
    sensor it is a reference of, and of no other (Li et al. 2007: a reference that fails
    raises the error functions it feeds; the decoupling holds against the *uncertain*
    sensors only). A drift on reference s4 of a 3-floor building, named by the bank, the
    detection filter and the equivalent model, raised the error functions of the healthy
    uncertain s2 and s3 too; as these were not coupled to s4, their false drifts were
    kept, and ``--corrected`` then altered both healthy channels.

    The bank and the detection filter estimate every sensor from all the others, so a
    fault anywhere in a group spreads everywhere in it; the equivalent model's residual
    of a sensor sees only its own and its assistant sensors' readings (direct propagation,
    :mod:`~analyzer.detectors.network`). Two offsets from the same instant on s3 and s8
    of a 16-channel building, s3 no assistant of s8: the observers named both (s8
    unconfirmed: no sensor it assists alarmed), and s8 was taken for s3's fault spreading,
    which the network rules out (``sweep_isolation.py --onset 0.6 --second 0.6001``,
    seed 6)."""
    groups: dict[str, list[frozenset[str]]] = {}
    reach: dict[str, dict[str, set[str]]] = {}
    for r in results:
        model = r.model if isinstance(r.model, dict) else {}
        members = set(r.channels)
        network = model.get("network")
        feeds = model.get("reach")
        if isinstance(network, dict) and "assistants" in network:
            reach.setdefault(r.detector, {}).update(_network_reach(network))
        elif isinstance(feeds, dict):
            fed = {str(a): {str(b) for b in bs} for a, bs in feeds.items()}
            reach.setdefault(r.detector, {}).update(fed)
            members.update(b for bs in fed.values() for b in bs)
        groups.setdefault(r.detector, []).append(frozenset(members))

    def test(detector: str, a: str, b: str) -> bool:
        if not any(a in g and b in g for g in groups.get(detector, ())):
            return False
        reaches = reach.get(detector)
        return reaches is None or b in reaches.get(a, set())

    return test


def _network_reach(network: dict[str, Any]) -> dict[str, set[str]]:
    """For each sensor of a sensor network (as :meth:`SensorNetwork.as_dict` describes
    it), the other sensors whose faults reach its residual."""
    from analyzer.detectors.network import SensorNetwork

    net = SensorNetwork(
        tuple(network["sensors"]),
        {t: tuple(a) for t, a in network["assistants"].items()},
        tuple(network.get("quasi_heads", ())),
        network.get("propagation", "direct"),
    )
    return {s: net.dependencies(s) for s in net.sensors}


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
