"""``--model``: the fitted models of ``--save-model`` run on a new archive: its channels
checked against the model's, the warm-up in which no fault is searched while the filters
settle, and what the notes and ``findings.json`` say about the model."""

from __future__ import annotations

import dataclasses
from collections.abc import Collection, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from analyzer.config import measured_inputs
from analyzer.detectors import REGISTRY
from analyzer.diagnosis.changes import Calibration
from analyzer.errors import ArchiveUsageError, capped
from analyzer.findings import sha256_of
from analyzer.modelfile import SavedModel
from analyzer.options import RunOptions, check_model_options
from analyzer.selection import StuckNote, model_stuck
from analyzer.store import ChannelStore
from analyzer.timeutil import seconds_text

WARMUP_S = 1.0
"""With ``--model``: the least time at a record's start in which no fault is searched."""


def model_channels(
    store: ChannelStore,
    model: SavedModel,
    options: RunOptions,
    notes: list[str],
    blank: Collection[str] = (),
) -> list[str]:
    """``--model``'s channels, all of which this archive must have (:class:`UsageError`
    naming the option and the missing ones; a CSV column of ``blank``, there but blank in
    every row, is had: a dead sensor's finding, unless every channel is so), in the
    model's order; a note names the
    archive's other channels (not analyzed) and a time source other than the model's,
    and one (a :class:`~analyzer.selection.StuckNote`) those of its channels that read
    one value over this whole record: a sensor dead since the model was saved, reported
    as a fault (:func:`analyzer.pipeline.constant_findings`), not a note only."""
    infos = store.infos()
    have = {i.name for i in infos}
    missing = [c for c in model.channels if c not in have]
    where = options.model_path or "the model"
    dead = [c for c in missing if c in blank]
    if dead and len(dead) == len(model.channels):
        # (no channel of the model has a reading: nothing to audit by it)
        raise ArchiveUsageError(
            f"--model {where}: {', '.join(dead[:3])}"
            f"{f' and {len(dead) - 3} more' if len(dead) > 3 else ''} "
            f"{'is' if len(dead) == 1 else 'are'} in this archive but blank in every row "
            "(dead sensors, or ones not recorded): no reading to audit by the model"
        )
    # the column is there, blank in every row: a dead sensor, the finding of
    # :func:`blank_findings`; the others audited as far as the model allows ("this
    # archive has no channel s3" was false, and the healthy sensors went unaudited)
    missing = [c for c in missing if c not in blank]
    if missing:
        raise ArchiveUsageError(_missing_line(store, missing, where, len(model.channels)))
    check_model_options(model, options.rate, options.detectors, options.model_path)
    stuck = model_stuck(
        infos, model.channels, measured_inputs(model.config), model.zero_at_rest or ()
    )
    if stuck:
        notes.append(StuckNote.of(stuck, modelled=True))
    fitted = set(model.channels)
    others = [i.name for i in infos if i.name not in fitted and not i.constant and not i.flag]
    flags = [i.name for i in infos if i.name not in fitted and i.flag]
    if flags:
        notes.append(
            f"flags or labels of this archive (two whole numbers over the record), not in the "
            f"model, not analyzed: {capped(flags, 5)}"
        )
    if others:
        notes.append(
            f"{len(others)} channel(s) of this archive are not in the model and were not "
            f"analyzed: {capped(others, 5)} (a model fitted with them includes them)"
        )
    if options.time_source != model.time_source:
        notes.append(
            f"timestamps: --time {options.time_source} here, the model was fitted on "
            f"--time {model.time_source} ones"
        )
    return list(model.channels)


def _missing_line(store: ChannelStore, missing: Sequence[str], where: str, fitted: int) -> str:
    """``--model``'s error for the model's channels this archive lacks: the first three
    and how many more, the archive's own channels (the first four and how many more, as
    ``--channels``' error: a file of another system, or of renamed sensors, said only
    what it lacked), and, where an archive's channel holds a missing one's name
    (``/s4.data`` for ``s4``, ``S4``), did you mean it (:meth:`ChannelStore.did_you_mean`)."""
    near = next(((c, n) for c in missing if (n := store.did_you_mean(c, literal=True))), None)
    hint = f"; did you mean {near[1]} for {near[0]}?" if near else ""
    return (
        f"--model {where}: this archive has no channel {capped(missing, 3)}{hint} "
        f"(the model was fitted on {fitted} channels; the archive's channels: "
        f"{capped(store.names)})"
    )


def warmup(model: SavedModel) -> int:
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


def settling_rows(fits: Mapping[str, Mapping[str, tuple[Any, Any]]]) -> dict[str, int]:
    """Per detector of ``fits`` (by channel group, then detector: ``(detector, fitted
    model)``), the samples its filters take to forget their start state at the record's
    first sample (:func:`_settling`, the longest of its groups'): where its residuals
    still carry the start-up transient, which the report's whole-record residual leaves
    out of its scale."""
    rows: dict[str, int] = {}
    for group in fits.values():
        for name, (_, fitted) in group.items():
            rows[name] = max(rows.get(name, 0), _settling(fitted))
    return rows


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


def in_registry_order(
    kept: dict[str, dict[str, tuple[Any, Any]]],
) -> dict[str, dict[str, tuple[Any, Any]]]:
    """Each channel group's fits in registry order (threads keep them as they finish)."""
    rank = {n: i for i, n in enumerate(REGISTRY)}
    return {
        tag: {n: fits[n] for n in sorted(fits, key=lambda n: rank.get(n, len(rank)))}
        for tag, fits in kept.items()
    }


def model_detectors(model: SavedModel, options: RunOptions) -> list[str]:
    """The detectors ``--model`` runs: all it holds, or those of ``--detectors`` (each
    of which it must hold)."""
    # registry order, as a run that fits them (the fits themselves may have been kept in
    # the order they finished): the results, and so the findings' merge, follow it
    rank = {n: i for i, n in enumerate(REGISTRY)}
    held = sorted(model.detectors(), key=lambda n: rank.get(n, len(rank)))
    if not options.detectors:
        return held
    check_model_options(model, options.rate, options.detectors, options.model_path)
    return [d for d in held if d in options.detectors]


def reuse_note(model: SavedModel, options: RunOptions, warm_s: float) -> str:
    trained = ", ".join(Path(p).name for p, _ in model.inputs[:3])
    if len(model.inputs) > 3:
        trained += f" and {len(model.inputs) - 3} more files"
    start, end = model.train_window_s()
    return (
        f"fitted models from {options.model_path or 'a model file'} (trained on {trained}, "
        f"healthy window {seconds_text(start)}-{seconds_text(end)} s); nothing was "
        f"fitted on this archive, and no fault is searched in its first {seconds_text(warm_s)} s "
        "while the filters settle"
    )


def model_info(model: SavedModel, options: RunOptions) -> dict[str, Any]:
    path = Path(options.model_path) if options.model_path else None
    digest = options.model_sha256
    if digest is None and path is not None and path.is_file():
        digest = sha256_of(path)
    return {
        "path": str(path) if path else None,
        "sha256": digest,
        **model.describe(),
    }
