"""The one pipeline every entry point calls (``analyzer run``, the watcher, the Dask
backend): readers -> store -> detectors -> diagnosis -> report."""

from __future__ import annotations

import contextlib
import hashlib
import math
import re
import shutil
import time
import warnings
from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.config import Config, measured_inputs
from analyzer.config import members as group_members
from analyzer.coverage import outside_note, span_gaps, span_note
from analyzer.data_ends import ends_with_data
from analyzer.delay_note import cautions_line, jitter_note, jitters, onset_cautions
from analyzer.detector_runs import (
    SkipReason,
    TooShortForNamed,
    coupled,
    detector_names,
    fits_of,
    fitted_estimates,
    merge_groups,
    merge_tests,
    run_detectors,
    run_groups,
    skip_reasons,
)
from analyzer.detectors import Dataset, DetectorResult, RunContext, detector_class
from analyzer.detectors.ar_kalman import ORDER_NOTE
from analyzer.detectors.ar_model import flat_channels
from analyzer.detectors.base import Event
from analyzer.diagnosis import (
    Finding,
    ends_hidden_by_later,
    ends_of_later_faults,
    merge_events,
    one_fault_at_a_time,
    onsets_hidden_by_earlier,
)
from analyzer.diagnosis.changes import LONG_FACTOR, default_window, training_need
from analyzer.diagnosis.clipping import find_clipping, merge_clipped
from analyzer.diagnosis.common_mode import common_changes
from analyzer.diagnosis.evidence import (
    attach_evidence,
    training_tests,
    whitenings,
    windowed_summary,
)
from analyzer.diagnosis.levels import LEVEL_TRAIN_BINS, excursions, level_note, response_levels
from analyzer.diagnosis.load import load_range, loud_stretch_count, loudest
from analyzer.diagnosis.merge import present_at_search_start, traced_into_training
from analyzer.diagnosis.oversampled import (
    MEMORY_SAMPLES,
    MOST_SAMPLES,
    Oversampled,
    measured_channels,
    oversampled,
    oversampled_note,
    slowed_itself,
    slower_clock_note,
)
from analyzer.diagnosis.readings import refuted_by_readings, residual_health
from analyzer.diagnosis.stuck import (
    dead_again,
    dead_unattributed,
    frozen_notes,
    healthy_stats,
    relabel_frozen,
    revived_gains,
    zero_channels,
)
from analyzer.diagnosis.training_check import (
    ALPHA,
    WindowChange,
    WindowNeed,
    WindowNote,
    change_words,
    check_training,
    window_notes,
    window_warnings,
)
from analyzer.diagnosis.unexplained import (
    Unexplained,
    echoes,
    lasting,
    missed_clusters,
    unexplained_alarms,
    unplaced,
)
from analyzer.errors import (
    LISTED,
    WARNED_LINES,
    AnalyzerError,
    ArchiveUsageError,
    DetectorError,
    IntegrityError,
    ReaderError,
    ShortConfigError,
    ShortDetectorError,
    ShortUsageError,
    UsageError,
    capped,
    clipped_line,
    one_line,
)
from analyzer.findings import (
    Analysis,
    findings_document,
    input_digest,
    time_source,
    write_outputs,
)
from analyzer.grouping import partition
from analyzer.missing_codes import (
    CodeHint,
    Unread,
    UnreadNote,
    absurd_note,
    as_gaps,
    code_hints,
    gaps_note,
)
from analyzer.modelfile import (
    SavedModel,
    check_model_path,
    model_bytes,
    not_a_model,
)
from analyzer.options import (
    MIN_TRAIN_ROWS,
    RunOptions,
    check_utc,
    load_options,
    parse_train,
)
from analyzer.outage import treat_outages
from analyzer.outdir import (
    not_into_inputs,
    not_into_watch,
    not_over_inputs,
    only_run,
    prepare_dir,
    remove_if_empty,
)
from analyzer.paging import release, row_blocks, trim_heap
from analyzer.parallel import (
    ClusterTrouble,
    DaskExecutor,
    Executor,
    SerialExecutor,
    ThreadExecutor,
    locked,
    make_executor,
    usable_cpus,
)
from analyzer.readers import (
    Archive,
    ArchiveNote,
    applied_renames,
    check_renames,
    open_archive,
)
from analyzer.readers.base import (
    InputInfo,
    about_selection,
    absolute_times,
    known_topics,
    one_clock,
    topic_of,
)
from analyzer.readers.quaternions import flipped_note
from analyzer.readers.seams import Seam, near_seam
from analyzer.readers.tally import Tally
from analyzer.reconfigure import (
    SEARCH_AGAIN_MIN,
    beside_faults,
    columns,
    found_again,
    lost_stretches,
    seen_late,
)
from analyzer.reconfigure import note as reconfigure_note
from analyzer.regenerate import corrected_values, healthy_stretch, result_signals
from analyzer.reuse import (
    in_registry_order,
    model_channels,
    model_detectors,
    model_info,
    reuse_note,
    settling_rows,
    warmup,
)
from analyzer.scratch import make_scratch, remove_scratch, scratch
from analyzer.search_after import Stretch, found_after
from analyzer.search_after import note as after_note
from analyzer.search_after import stretches as after_stretches
from analyzer.selection import (
    SIBLINGS_LISTED,
    CounterNote,
    NoSamplesNote,
    StuckNote,
    WindowConstantNote,
    cut_short,
    default_train,
    left_out,
    lone_channel,
    no_numeric_channel,
    select_channels,
    stuck_words,
    typed_fields,
)
from analyzer.silence_note import StoppedNote, silence_note, stopped_words
from analyzer.silent import blank_findings, merged, silent_findings
from analyzer.store import AlignedSeries, ChannelInfo, ChannelStore, clock_rate
from analyzer.store.store import UNREADABLE
from analyzer.timeutil import (
    DURATION_DECIMALS,
    iso_utc,
    json_time,
    plain_number,
    rows_within,
    seconds_text,
    short_seconds,
    spoken_duration,
    window_text,
)
from analyzer.types import NS_PER_S, FaultType, Note, prefixed
from analyzer.window_note import AnomalyNote, info_lines

MATERIALIZE_IN_MEMORY = 1 << 24
"""Aligned matrices up to this many values stay in memory; larger ones are memory-mapped."""


def _config_sensors(options: RunOptions) -> set[str]:
    """The channels the config names as sensors under test: its ``[[group]]`` members
    and ``[model]`` outputs, without the measured inputs (``[[group]] inputs``, ``[model]
    inputs``: an excitation that reads one value may be none applied, not a dead sensor)."""
    config = options.config
    out = {c for g in config.groups for c in group_members(g)}
    if config.model is not None:
        out.update(config.model.get("outputs", []))
    return out - measured_inputs(config.as_context())


def _config_named(options: RunOptions) -> set[str]:
    """The channels the config names: its ``[[group]]`` members and ``[model]`` outputs
    and inputs (a step command of 0 and 1 may be the model's measured input)."""
    config = options.config
    out = {c for g in config.groups for c in group_members(g)}
    if config.model is not None:
        out.update(config.model.get("outputs", []), config.model.get("inputs", []))
    return out


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
                f"times at {plain_number(i.rate_hz)} Hz (written in batches): one value per tick "
                f"of the {plain_number(rate)} Hz clock is analyzed; --time header (where "
                "messages carry "
                "stamps) may keep more"
            )
    return notes


UPSAMPLED = 2.0
"""A ``--rate`` more than this many times the fastest analyzed channel's is noted
(:func:`_upsampled`)."""


def _upsampled(
    infos: Sequence[ChannelInfo], chosen: Sequence[str], rate: float, asked: float | None
) -> list[str]:
    """A note (repeated on stderr) when ``--rate`` (``asked``) puts the clock at more than
    :data:`UPSAMPLED` times the fastest analyzed channel's rate: the ticks between two
    readings are interpolated lines, which the models take for the sensors' signal (a
    16.7-Hz ROS 1 bag aligned at 1000 Hz took 15 times as long, 4 times the memory, and
    gave four findings the bag at its own rate did not; the realdata audit)."""
    wanted = set(chosen)
    fastest = max((i.rate_hz for i in infos if i.name in wanted), default=0.0)
    if asked is None or not fastest > 0 or rate <= UPSAMPLED * fastest:
        return []
    text = (
        f"--rate {plain_number(asked)} puts the clock at {plain_number(rate / fastest)} times "
        "the fastest "
        f"analyzed channel ({plain_number(fastest)} Hz): the ticks between its readings are "
        "interpolated, and the models take those lines for the sensors' signal (a rate at "
        "or below the channels' own fits them)"
    )
    return [WindowNote(text, text)]


def _interpolated(infos: Sequence[ChannelInfo], chosen: Sequence[str], rate: float) -> list[str]:
    """One note naming the analyzed channels on a clock more than twice their own rate
    and how many times (a 1 Hz temperature beside 50 Hz accelerometers: 50-fold), in
    export's words (:func:`analyzer.export.interpolated_words`): the values between their
    samples are interpolated lines, which the models see as the sensor's signal. Export
    said it and run did not (the ux55 audit, item 13)."""
    from analyzer.export import interpolated_words, slower_channels

    wanted = set(chosen)
    slow = slower_channels([i for i in infos if i.name in wanted], rate)
    return [interpolated_words(slow, rate, "analyzed", fold=True)] if slow else []


def _irregular_channels(infos: Sequence[ChannelInfo], chosen: Sequence[str]) -> list[str]:
    """A note on the analyzed channels sampled at irregular times (event-driven, Poisson
    timestamps: :func:`analyzer.store.store._irregular`), those of one rate and bridge
    together: they are aligned at their mean rate and interpolated across their ordinary
    silences, which a regular clock's rule took for gaps (half the ticks were NaN and the
    run refused the training window)."""
    by: dict[tuple[float, float, int], list[str]] = {}
    infos_by = {i.name: i for i in infos}
    for c in chosen:
        i = infos_by.get(c)
        if i is not None and i.irregular:
            by.setdefault((i.rate_hz, i.bridge, i.gaps), []).append(c)
    return [
        f"{', '.join(names)}: sampled at irregular times (the intervals vary widely): "
        f"aligned at their mean rate {plain_number(rate)} Hz and interpolated across silences "
        "of up "
        f"to {spoken_duration(bridge / rate)} ({bridge:.3g} mean intervals); longer ones are "
        f"gaps ({gaps or 'none'} in each)"
        for (rate, bridge, gaps), names in by.items()
    ]


def _partial_channels(
    stretches: Sequence[Sequence[tuple[int, int]]],
    chosen: Sequence[str],
    topics: Collection[str],
    rate_hz: float,
    searched: set[str],
    not_again: bool,
) -> list[str]:
    """Notes on the analyzed channels without a reading for long at the record's start or
    end (``stretches``: :func:`analyzer.reconfigure.lost_stretches`; a sensor that died,
    silent or publishing NaN, a file of another channel set): while one is missing, the
    detectors that model the channels together lose their view of the others (the bank
    keeps only its estimator that leaves it out), which a user would not guess from "no
    fault found". The channels ``searched`` are missing where faults are searched (after
    the healthy window): the others are searched again without them
    (:mod:`analyzer.reconfigure`), which a note of its own reports, unless ``not_again``
    (a fixed channel set, or too few channels left), when the note names the
    ``--channels`` that does it, if enough channels would be left. A channel's topic is
    of the record's ``topics`` (:func:`~analyzer.readers.base.topic_of`: a CSV column is
    its own)."""
    # the fields of one topic that stop together are one note (fourteen alike, one per
    # field of two topics, on ROS_example.bag)
    groups: dict[tuple[str, tuple[tuple[int, int], ...], bool], list[str]] = {}
    for name, rows in zip(chosen, stretches, strict=True):
        if rows:
            key = (topic_of(name, topics), tuple(rows), name in searched)
            groups.setdefault(key, []).append(name)
    notes: list[str] = []
    for (topic, rows, there), names in groups.items():
        one = len(names) == 1
        its = "its" if one else "their"
        what = " and ".join(
            f"{its} first {short_seconds(b / rate_hz)} s"
            if a == 0
            else f"{its} last {short_seconds((b - a) / rate_hz)} s (after "
            f"{short_seconds(a / rate_hz)} s)"
            for a, b in rows
        )
        who = (
            f"{names[0]} has" if one else f"{capped(names)} ({len(names)} channels of {topic}) have"
        )
        it, pattern = ("it", names[0]) if one else ("them", f"{topic}.*")
        # (the time from which a channel that stops has no reading, for the last line)
        stop = next((a / rate_hz for a, b in rows if a > 0), None)
        if not there:
            then = "inside the healthy window, before the faults are searched"
            notes.append(
                StoppedNote.of(
                    f"{who} no reading in {what} of the record ({then})", names, stop, topic
                )
            )
            continue
        if not not_again:
            advice = (
                f"the others are searched again without {it} there (the notes say what that found)"
            )
        elif len(chosen) - len(names) >= SEARCH_AGAIN_MIN:
            advice = f"--channels '!{pattern}' searches the others there"
        else:
            advice = (
                f"too few channels would be left to search the others without {it} (at "
                f"least {SEARCH_AGAIN_MIN}: with two, each is estimated from the other alone)"
            )
        text = (
            f"{who} no reading in {what} of the record: where "
            f"{'it is' if one else 'they are'} missing, the detectors that model {it} with the "
            "others (ar_kalman_bank, detection_filter) lose their view of "
            f"{'them' if one else 'the others'} too; {advice}"
        )
        notes.append(StoppedNote.of(text, names, stop, topic))
    return notes


BLANK_WORDS = "blank in every row"
"""What a CSV column with no cell filled was (:func:`_no_reading`)."""


class BlankModelNote(Note):
    """:func:`_blank_model_note`'s note, which ``run`` repeats on stderr as a warning and
    ``watch`` among the archive's warnings: stderr said only the reader's "blank in every
    row; not analyzed", not that the model's detectors lost the other channels too."""

    __slots__ = ()


def _blank_model_note(
    dead: Sequence[str],
    results: Sequence[DetectorResult],
    no_reading: Mapping[str, str] | None = None,
) -> str:
    """With ``--model``: what its detectors (``results``) could audit beside the channels
    ``dead``, blank in every row of this record (each one's finding): the residuals that
    have data. A detector that models the channels together (the AR bank, the detection
    filter) has none without one of them, the equivalent model keeps those of the
    channels not modelled from it; "1 sensor fault found" alone let a user think the
    others were audited as usual. Each dead channel is listed in findings.json's
    ``channels[]`` as one with no reading (:func:`analyzer.findings.unread_channels`);
    ``no_reading``: what each one's values were (:func:`_no_reading`): "blank in every
    row" was said of an MCAP field NaN in every message too."""
    if not dead:
        return ""
    one = len(dead) == 1
    blank = all((no_reading or {}).get(c, BLANK_WORDS) == BLANK_WORDS for c in dead)
    state = (
        f"{'is' if one else 'are'} {BLANK_WORDS}"
        if blank
        else f"{'has' if one else 'have'} no reading at all"
    )
    it = "it" if one else "them"
    blind, partial = [], []
    for r in results:
        seen = [c for c, z in r.residuals.items() if c not in dead and np.isfinite(z).any()]
        if not seen:
            blind.append(r.detector)
        elif len(seen) < len(r.residuals) - len(dead):
            partial.append(f"{r.detector} audits only {', '.join(seen)}")
    said = []
    if blind:
        said.append(f"{' and '.join(blind)} {'has' if len(blind) == 1 else 'have'} no residual")
    if partial:
        said.append(f"{'; '.join(partial)} (the others are modelled from {it})")
    what = " and ".join(said) if said else "its detectors audit the others"
    pattern = " ".join(f"'!{c}'" for c in dead)
    return BlankModelNote(
        f"{capped(dead)} {state} (a dead sensor"
        f"{'' if one else 's'}: {'its' if one else 'their'} finding; listed in channels "
        f'with why "no reading"); the model\'s detectors need {it} beside the others: '
        f"without {it}, {what}; a model saved without {it} (--save-model on a healthy "
        f"record with --channels {pattern}) audits the others in full"
    )


def _residual_tests(
    task: tuple[DetectorResult, tuple[str, ...], tuple[int, int], float],
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The residual tests of some of a detector's channels: over the training window, and
    windowed over the whole archive."""
    result, channels, train, rate_hz = task
    if train[1] <= train[0]:  # --model: no training window of the record's own
        return training_tests(result, train, channels), windowed_summary(
            result, rate_hz, channels=channels
        )
    # both whitened by each residual's model of the training window, fitted once
    fitted = whitenings(result, train, channels)
    return (
        training_tests(result, train, channels, fitted),
        windowed_summary(result, rate_hz, channels=channels, train=train, fitted=fitted),
    )


_Outcome = tuple[list[DetectorResult], dict[str, str]]
"""Detectors' results and why the others were skipped (:func:`run_detectors`)."""


def analyze(
    inputs: Sequence[str | Path], options: RunOptions, workdir: Path | None = None
) -> Analysis:
    """Read, align, fit on the healthy window, run the detectors and merge their events.

    With ``workdir`` the raw store and, for long archives, the aligned matrix and long
    results are memory-mapped there (the caller removes it after use); without it
    everything is kept in memory and the scratch space is removed on return.

    The detectors run on the executor ``--jobs``/``--scheduler`` ask for
    (:func:`analyzer.parallel.make_executor`: one thread per usable CPU by default
    (:func:`~analyzer.parallel.usable_cpus`), ``--jobs 1``
    serially; on a Dask cluster the detectors' steps stay here and the pieces they split
    off go to the workers, see :func:`~analyzer.detector_runs.run_detectors`); the
    results are the serial run's whatever the executor. The scheduler is contacted
    first, so an unreachable one fails before any reading."""
    jobs = options.jobs if options.jobs is not None else usable_cpus()
    executor = make_executor(jobs, options.scheduler)
    # on a cluster, this process's own share of the work (alarm searches, observers,
    # residual tests) runs on --jobs threads (default: one per usable CPU) of its own
    local = ThreadExecutor(jobs) if isinstance(executor, DaskExecutor) and jobs > 1 else None
    done = False
    try:
        if workdir is None:
            with scratch() as tmp:
                analysis = _checked(
                    lambda: _analyze(inputs, options, tmp, True, executor, local), tmp
                )
                analysis = _trained_before(analysis, inputs, options, tmp, True, executor, local)
        else:
            analysis = _checked(
                lambda: _analyze(inputs, options, workdir, False, executor, local), workdir
            )
            analysis = _trained_before(analysis, inputs, options, workdir, False, executor, local)
        done = True
        return analysis
    finally:
        if local is not None:
            local.close(wait=done)
        executor.close(wait=done)


MODEL_SPREAD = 8.0
"""A channel whose spread over the archive is this many times the model's healthy spread,
or this many times less, is named with ``--model`` (:func:`_spread_against_model`)."""


def _spread_against_model(
    values: Any,
    chosen: Sequence[str],
    healthy: dict[str, tuple[float, float]],
    skip: Collection[str] = (),
) -> list[str]:
    """With ``--model``: a note (repeated on stderr) naming the channels whose spread over
    the archive is :data:`MODEL_SPREAD` times the model's healthy spread or more, or that
    much less: another unit (mm/s^2 for m/s^2, g), a sensor's gain, or a load far from
    the model's window. An archive in other units gave exit 0 and only "an anomaly at 3 s
    on all 10 channels attributed to no sensor" (audit). Not the channels ``skip`` (one
    value over the record: a fault of their own, whose finding says it)."""
    here = healthy_stats(values, chosen, (0, len(values)))
    odd = []
    for c in chosen:
        if c in skip or c not in here or c not in healthy or not healthy[c][1] > 0:
            continue
        ratio = here[c][1] / healthy[c][1]
        if not 1 / MODEL_SPREAD < ratio < MODEL_SPREAD:
            odd.append(f"{c} {ratio:.3g}x")
    if not odd:
        return []
    shown = ", ".join(odd[:6]) + (f", ... ({len(odd)} channels)" if len(odd) > 6 else "")
    text = (
        f"the archive's spread against the model's healthy window: {shown} (another unit, "
        "a sensor's gain, or a load far from the model's window; the model's thresholds "
        "are in its own units)"
    )
    return [WindowNote(text, text)]


def _rate_against_model(
    infos: Sequence[ChannelInfo], chosen: Sequence[str], model_hz: float
) -> list[str]:
    """With ``--model``: a note (repeated on stderr, as :func:`_spread_against_model`'s)
    when the channels run at another rate than the model was fitted at: they are
    resampled to the model's rate, and at a lower one of theirs the samples between
    their readings are interpolated lines, which the models take for the sensors'
    signal (a healthy 50-Hz file with a 200-Hz model gave three anomalies attributed to
    no sensor, "a change of the structure or excitation", and said so only in
    ``findings.json``; the audit)."""
    own = clock_rate([i for i in infos if i.name in set(chosen)])
    if not own > 0 or abs(own - model_hz) <= 0.01 * model_hz:
        return []
    between = (
        f"; {model_hz / own:.3g} times as many samples, the ones between their readings "
        "interpolated, which the models take for the sensors' signal"
        if own < model_hz
        else ""
    )
    # (a model below their rate may be one a run saved after slowing such a record on
    # purpose, where fitting at the logged rate is the worse choice: the advice says so;
    # the model file does not record whether its run slowed the record)
    advice = (
        " (a model fitted at their own rate fits them best)"
        if own < model_hz
        else (
            " (a model fitted at their own rate fits them best, unless that rate runs far "
            "above what they carry: a run without --rate then analyzes them slower, and "
            "its model, saved at that slower rate, is the better one)"
        )
    )
    text = (
        f"the channels run at {plain_number(own, 4)} Hz and the model at "
        f"{plain_number(model_hz, 4)} Hz: they are resampled to the model's rate{between}"
        f"{advice}"
    )
    return [WindowNote(text, text)]


def _louder_than_window(
    values: Any,
    train: tuple[int, int],
    rate_hz: float,
    train_bins: npt.NDArray[np.bool_],
    judged: int,
) -> list[str]:
    """A note (repeated on stderr) when ``judged`` findings' events or alarms left
    unreported (:func:`~analyzer.diagnosis.load.loud_stretch_count`) lie where the signals
    after the healthy window ``train`` (rows) were louder than anywhere inside it (the
    median channel's variance over the detectors' long window:
    :mod:`analyzer.diagnosis.load`), for a window too short for the level map's note
    (``train_bins``, its bins inside the window: fewer than
    :data:`~analyzer.diagnosis.levels.LEVEL_TRAIN_BINS`; a longer one shows the signals'
    own spread, and :func:`~analyzer.diagnosis.levels.level_note` names the stretches
    beyond it).

    Only then: the thresholds were set on the window, and every model's error grows with
    its signals, so a finding or an unreported alarm there is one the user should read
    with that in mind; a record that is merely louder later, with nothing judged there,
    needs no word (on healthy 60-s records of the simulated 5-floor building a note on
    every level past 2 times the window's came on 5 of 10; this one on none of them). A
    healthy 60-s record of that building, its first 12 s as the window, went up to 11
    times its level after it, and with one floor's sensor left out 2-3 of 10 such records
    had false findings there (none with ``--train 0:30``)."""
    if judged == 0 or int(train_bins.sum()) >= LEVEL_TRAIN_BINS:
        return []
    rng = load_range(values, train, rate_hz)
    ratio, row = loudest(rng, values, range(values.shape[1]), train[1], values.shape[0])
    if ratio <= 1.0:
        return []
    span = rng.window / rate_hz
    text = (
        f"{judged} of the detectors' alarms (reported as findings or not) lie where the "
        "signals were louder than anywhere in the healthy window (their "
        f"{span:g}-s variance, the median channel's, up to {ratio:.1f} times the "
        f"window's largest, at {row / rate_hz:.1f} s): the "
        "thresholds were set on a quieter stretch, so the detectors asked more of an alarm "
        "there (a finding's evidence gives load_ratio; the notes name the alarms left out); "
        "if a stretch as loud is known to be healthy, a --train window that takes it in "
        "judges them on it"
    )
    return [WindowNote(text, text)]


RETRAIN_SHARE = 0.25
"""The default training window is cut before a sensor's change inside it when at least
this share of it is left (:func:`_trained_before`)."""


def _trained_before(
    analysis: Analysis,
    inputs: Sequence[str | Path],
    options: RunOptions,
    work: Path,
    in_memory: bool,
    executor: Executor,
    local: ThreadExecutor | None,
) -> Analysis:
    """``analysis`` again, trained on the default window's part before a sensor's step
    or gain change inside it (:class:`WindowNote`), when that part holds at least
    :data:`RETRAIN_SHARE` of it: a fault that began there was fitted into the models as
    healthy, and the run found nothing (a 3-sd offset from 90 s of a 120-s window, on
    to the end of a 10-minute record: exit 0), or named a healthy sensor. Only where
    the window is the default one (no ``--train``, ``[train]`` or ``--model``); a note
    (repeated on stderr) says so; when the shorter window cannot be analyzed, the first
    analysis stands, with a note why."""
    if options.train is not None or options.config.train is not None or options.model:
        return analysis
    changes = [n for n in analysis.notes if isinstance(n, WindowNote) and n.before is not None]
    if not changes:
        return analysis
    a, b = analysis.train[0] / analysis.rate_hz, analysis.train[1] / analysis.rate_hz
    lo, hi, first = min((*n.before, n) for n in changes if n.before is not None)
    if hi - lo < RETRAIN_SHARE * (b - a):
        return analysis
    again = work / "trained-before"
    window = f"{lo:.9g}:{hi:.9g}"
    try:
        again.mkdir(exist_ok=True)
        retrained = replace(options, train=window)
        slowed = analysis.slowed  # (the first pass's clock: the window was cut on it)
        second = _checked(
            lambda: _analyze(inputs, retrained, again, in_memory, executor, local, slowed),
            again,
        )
    except (AnalyzerError, OSError, MemoryError) as err:
        # (a long archive's second pass needs its scratch space again: a full disk too)
        analysis.notes.append(
            f"the default window cut before that change ({window} s) could not be analyzed "
            f"({one_line(err)}): the analysis on the whole default window stands"
        )
        return analysis
    what = first.split("; a sensor fault there", 1)[0]
    lost = sorted({r.detector for r in analysis.results} - {r.detector for r in second.results})
    fewer = f"; on it {', '.join(lost)} could not run (see skipped_detectors)" if lost else ""
    second.notes.insert(
        0,
        WindowNote(
            f"trained on {short_seconds(lo)}-{short_seconds(hi)} s instead of the default "
            "window, which a change "
            f"crosses: {what}{fewer}; --train chooses the window",
            f"trained on {short_seconds(lo)}-{short_seconds(hi)} s instead: "
            + first.short.split(": the models were fitted on it", 1)[0]
            + fewer,
        ),
    )
    return second


def analyze_screened(inputs: Sequence[str | Path], options: RunOptions, workdir: Path) -> Analysis:
    """:func:`analyze`, whose ``--screen`` (``options.screen``) runs the screening's
    detectors first: when they find no fault their analysis is the analysis (a note and
    ``findings.json``'s ``screen`` say the others did not run), else every other detector
    of the run (``--detectors``, or the defaults) runs too on the same aligned archive,
    and the analysis is the plain run's. A faster pass over a long run of mostly healthy
    archives (one detector alone analyzes 4 hours of MCAP 1.2-2.6x as fast as all three,
    the equivalent model fastest), at the price of what the screening's detectors miss
    and the others would have found; a faulty archive costs about what a plain run does
    (read, aligned and screened once: :func:`_screened`)."""
    return analyze(inputs, options, workdir)


def _read_checked(
    inputs: Sequence[str | Path], options: RunOptions, work: Path
) -> tuple[Archive, ChannelStore, Tally, Unread]:
    """The inputs read into a finalized store, checked: what the readers handed over
    (tallied chunk by chunk, :class:`~analyzer.readers.tally.Tally`) must be what the
    store holds, sample for sample (each reader's reordering checks itself the same way,
    :meth:`~analyzer.readers._common.Reorderer.flush`). Returns the tally too, for the
    store's check again once it is aligned (:func:`_store_unchanged`). Raises
    :class:`IntegrityError` naming the channels that differ (:func:`_checked` reads
    again).

    The samples that are no reading (NaN, infinite, beyond 1e30, a ``--missing-values``
    code) are dropped on the way into the store, as blank cells are
    (:func:`~analyzer.missing_codes.as_gaps`): returned counted by channel too."""
    progress = options.progress
    reading = None if progress is None else partial(progress, "read")
    archive = open_archive(inputs, options.inside)
    archive.renames = dict(options.rename)
    archive.rename_origin = config_renames(options)
    fed = Tally()
    codes = options.missing_values
    unread = Unread()
    chunks = as_gaps(archive.chunks(options.time_source, reading), codes, unread)
    store = ChannelStore.from_chunks(fed.counted(chunks), work / "store")
    archive.notes.extend(n for n in [gaps_note(unread.coded, codes)] if n)
    try:
        check_renames(archive)  # (a NEW name no input holds: the option's error)
        _store_unchanged(store, fed, "")
    except (IntegrityError, UsageError):
        store.close()
        raise
    return archive, store, fed, unread


def _store_unchanged(store: ChannelStore, fed: Tally, when: str) -> None:
    """Raise :class:`IntegrityError` where the store no longer holds what was fed into
    it (``when``: after which step, for the message)."""
    differ = fed.differences(store.tally(), "read", "stored")
    if differ:
        raise IntegrityError(
            f"internal check failed in the store{when}: " + capped(differ, 2, "; ", "channels")
        )


def _checked(run: Callable[[], Analysis], work: Path) -> Analysis:
    """``run()`` (an :func:`_analyze` on ``work``), once more where an internal check of
    its reading stage failed (:class:`IntegrityError`), with a note that names the
    channels and what differed; where the second run fails the check too, an
    :class:`IntegrityError` stops the run (exit 2) rather than report a result of
    corrupted samples.

    Under heavy load an analysis of a 30 000-row CSV once in about 600 lost about 2 350
    rows of every channel without a word, and a second read was right: a file closed by
    hand while Arrow's read-ahead still read it (fixed in
    :meth:`~analyzer.readers.csv_reader.CsvReader._arrow_blocks`; benchmarks/README.md,
    ``arrow_close_race.py``). The checks stay as guards of the stages. They run
    while reading and aligning, before any detector, so a second run costs a second
    read; the first one's scratch files (the store's spill files, which a new store
    would append to, and the aligned matrix) are removed first."""
    try:
        return run()
    except IntegrityError as err:
        first = one_line(err)
    shutil.rmtree(work / "store", ignore_errors=True)
    (work / "aligned.npy").unlink(missing_ok=True)
    try:
        analysis = run()
    except IntegrityError as err:
        raise IntegrityError(
            f"{first}; read again: {one_line(err)}: the analysis stops rather than report a "
            "result of corrupted samples"
        ) from err
    analysis.notes.insert(
        0, f"{first}; the inputs were read again, and the second read passed the check"
    )
    return analysis


@contextlib.contextmanager
def _cut_short_said(inputs: Sequence[InputInfo], store: ChannelStore) -> Iterator[None]:
    """An analysis of an archive an input of which was cut short
    (:data:`~analyzer.selection.CUT_SHORT`; the errors that say where it was cut first:
    :func:`~analyzer.selection.cut_short`) that stops with an error says so first:
    ``FILE: truncated or damaged at byte N (...): only S s of data were read; `` before
    the error, of the same class (the watcher files it by its class). Else a truncated
    MCAP too short to analyze said only that the training window was too short ("give
    --train 0:12"), and the damage, the cause, was told only by a run that got further
    (the audit). Not an internal check's error (:class:`IntegrityError`), nor one that
    names the damage already."""
    damage = cut_short(inputs)
    if not damage:
        yield
        return
    spans = [(i.start_ns, i.end_ns) for i in store.infos() if i.samples > 0]
    read_s = (max(b for _, b in spans) - min(a for a, _ in spans)) / NS_PER_S if spans else 0.0
    try:
        yield
    except IntegrityError:
        raise
    except AnalyzerError as err:
        path, error = damage[0]
        what = error.split("; ", 1)[0]
        if what in str(err):
            raise
        more = _also_cut(path, damage)
        told = type(err).__new__(type(err))
        told.__dict__.update(err.__dict__)
        told.args = (
            f"{path}: {what}{more}: only {plain_number(read_s)} s of data were read; {err}",
        )
        raise told from err


def _also_cut(path: str, damage: Sequence[tuple[str, str]]) -> str:
    """The other inputs that were cut short, named after the first one's damage: `` (also
    cut short: b.mcap, c.bag)``; empty where there are none. The first input's own other
    errors of the kind are not counted: a ROS 1 bag cut short also says its index lies
    past its end ("truncated?"), the same cut, and a run said "(and 1 more input errors
    of the kind)" of it without naming it (a QA audit)."""
    others = list(dict.fromkeys(p for p, _ in damage if p != path))
    if not others:
        return ""
    return f" (also cut short: {capped(others, 3, what='inputs')})"


def _analyze(
    inputs: Sequence[str | Path],
    options: RunOptions,
    work: Path,
    in_memory: bool,
    executor: Executor,
    local: ThreadExecutor | None = None,
    slowed: Oversampled | None = None,
) -> Analysis:
    """One analysis of ``inputs`` (:func:`analyze`'s, and :func:`_trained_before`'s
    second pass, which passes the slower clock its first pass chose: ``slowed``)."""
    timings: dict[str, float] = {}
    notes: list[str] = []
    progress = options.progress
    t_start = time.perf_counter()
    archive, store, fed, no_reading = _read_checked(inputs, options, work)
    notes.extend(archive.notes)
    # (channels none of whose samples is a reading: said for that, not analyzed)
    unreadable_only = {c: w for c, w in no_reading.lost().items() if c not in store.names}
    if unreadable_only:
        notes.append(UnreadNote(unreadable_only))
    with store, _cut_short_said(archive.inputs, store):
        timings["read"] = time.perf_counter() - t_start
        if progress:
            progress("read", 1.0)
        if not store.infos():
            raise ReaderError(
                no_numeric_channel(
                    archive.inputs,
                    f"no channel has a reading ({UnreadNote(unreadable_only)})"
                    if unreadable_only
                    else "no numeric channel found",
                )
            )
        reused = options.model
        # CSV columns blank in every row: no channel, but named as what they are
        blank = {c for i in archive.inputs for c in i.blank_until} - set(store.names)
        blank |= set(unreadable_only)  # (no reading in any sample: as blank, once dropped)
        unread_words = _no_reading(blank, unreadable_only)
        if reused is None:
            relabelled = [p for i in archive.inputs for p in i.relabelled]
            # (the config's groups and [model] name their channels: all are kept)
            named = bool(options.config.groups) or options.config.model is not None
            chosen = select_channels(
                store,
                options.channels,
                notes,
                relabelled,
                not named,
                _config_named(options),
                [t for i in archive.inputs for t in i.log_topics],
                _config_sensors(options),
                blank,
                typed_fields(archive.inputs),
                {c: str(p) for c, p in archive.sources.items()},
            )
        else:
            chosen = model_channels(store, reused, options, notes, blank)
        # (a saved model's channel blank in every row: a column of NaN, and its finding)
        unread = [c for c in chosen if c in blank] if reused is not None else []
        notes.extend(
            _blank_note([c for c in blank if c not in chosen and c not in unreadable_only])
        )
        one_clock(chosen, archive.inputs)  # (else: "a timestamp lies far from the others")
        notes.extend(n for n in [flipped_note(archive.inputs, chosen)] if n)
        t0 = time.perf_counter()
        aligned: AlignedSeries = store.align(
            chosen, options.rate if reused is None else reused.rate_hz, blank=unread
        )
        absolute = absolute_times(archive.inputs)
        # a clock far above what the sensors carry, without --rate: aligned slower, as
        # --rate would (a retrained pass keeps its first pass's clock: ``slowed``)
        clips: str | None = None  # (a sensor that clips keeps the logged clock: said why)
        if slowed is None:
            slowed, clips = _slower_clock(aligned, chosen, options, absolute)
        if slowed is not None:
            options = replace(options, rate=slowed.suggest)
            aligned = store.align(chosen, slowed.suggest, blank=unread)
            notes.append(slower_clock_note(slowed, options.corrected))
        n_values = aligned.n * len(chosen)
        big = n_values > MATERIALIZE_IN_MEMORY and not in_memory
        path = work / "aligned.npy" if big else None
        unreadable = np.zeros(len(chosen), dtype=np.int64)
        values = aligned.materialize(path, unreadable=unreadable)
        # (those the reading dropped, and any the alignment met: none from finite samples)
        beyond = dict(no_reading.absurd)
        for c, n in zip(chosen, unreadable.tolist(), strict=True):
            if n:
                beyond[c] = beyond.get(c, 0) + n
        notes.extend(n for n in [absurd_note(beyond)] if n)
        release(values)  # written: its pages go back to the page cache (see analyzer.paging)
        # the raw samples were read again to align them: unchanged since they were checked
        _store_unchanged(store, fed, " after the alignment")
        timings["align"] = time.perf_counter() - t0
        if progress:
            progress("align", 1.0)
        # the raw samples are no longer needed: unmap them now, or their pages stay in the
        # resident set for the rest of the run (memory that grows with the archive)
        infos = store.infos()
        read = [c for c in chosen if c not in unread]  # (the channels with samples)
        notes.extend(span_note(span_gaps(store, read)))  # (a gappy folder: how much)
        # (an analyzed sensor that stops for a while mid-record: which, and when)
        topics = known_topics(archive.inputs)
        notes.extend(
            silence_note(store, read, topics, aligned.start_ns, aligned.duration_s, archive.seams)
        )
        store.close()
        # and their files: for a long archive the largest scratch files after the matrix
        # (16 bytes per value: a time and a value), kept to the end of the run until now
        shutil.rmtree(work / "store", ignore_errors=True)
        trim_heap()  # and what reading freed (the CSV reader's Arrow buffers, say)
        notes.extend(_crowded_channels(infos, chosen, aligned.rate_hz))
        notes.extend(_irregular_channels(infos, chosen))
        # (log times that jitter against the header stamps by a sizeable share of a period)
        jittery = jitters(archive.inputs, infos, chosen)
        notes.extend(jitter_note(jittery))
        # (a --rate far above every channel says it already, of them all)
        upsampled = _upsampled(infos, chosen, aligned.rate_hz, options.rate)
        notes.extend(upsampled or _interpolated(infos, chosen, aligned.rate_hz))
        if reused is not None:
            notes.extend(_rate_against_model(infos, chosen, reused.rate_hz))
        # (a file recorded apart from the others, whose channels were left out)
        notes.extend(outside_note(infos, chosen, aligned.start_ns, aligned.duration_s, absolute))
        if options.utc:
            check_utc(absolute, chosen)
        tr, train = _training_window(options, aligned, absolute, notes)
        try:
            values, chosen = _varying_in_training(
                values, chosen, train, tr, aligned.rate_hz, options, notes
            )
        except UsageError as err:
            # (times cut to whole seconds under 100 rows a second: "1 Hz", and nothing
            # said why; the input's warning is not printed when the run stops). Only for
            # a window short of samples, and a clock that collapsed most rows
            coarse = [
                f"{i.path}: {e}"
                for i in archive.inputs
                for e in i.errors
                if (m := COARSE_CLOCK.match(e)) and 2 * int(m[1]) >= int(m[2])
            ]
            if coarse and str(err).startswith("the training window") and "sample(s) at" in str(err):
                raise ShortUsageError(f"{err}; {coarse[0]}") from None
            raise
        # logger outages (every analyzed channel at one value, or repeating its values,
        # at once): missing data, not a sensor's fault, and a note (analyzer.outage)
        treat_outages(values, chosen, aligned.rate_hz, notes)
        # channels missing for long: the others are searched again without them, unless
        # the channel set is fixed (a saved model, or one kept, or the config's groups)
        stretches = lost_stretches(values, aligned.rate_hz)
        # where the faults are searched: after the healthy window (a channel that starts
        # late has its data there, and no search to lose before)
        lost = {
            c: clipped
            for c, rows in zip(chosen, stretches, strict=True)
            if (clipped := [(max(a, train[1]), b) for a, b in rows if b > train[1]])
        }
        fixed = (
            reused is not None
            or options.save_model is not None
            or bool(options.config.groups)
            or bool(options.screen)
        )
        few = len(chosen) - len(lost) < SEARCH_AGAIN_MIN
        notes.extend(
            _partial_channels(stretches, chosen, topics, aligned.rate_hz, set(lost), fixed or few)
        )
        # a sensor whose readings give way to blank cells or NaN for the rest of the record
        # (the others going on): dead, a finding as one that reads 0 (analyzer.silent)
        silent = silent_findings(
            values,
            chosen,
            aligned.rate_hz,
            aligned.start_ns,
            infos,
            archive.inputs,
            no_reading.last,
        ) + blank_findings(unread, aligned.duration_s)
        if fixed or few:
            lost = {}
        data = Dataset(values, tuple(chosen), aligned.rate_hz, train, healthy=reused is None)
        names, explicit = detector_names(options)
        if reused is not None:
            names = model_detectors(reused, options)
            notes.append(reuse_note(reused, options, tr[1] + 1 / aligned.rate_hz))
        healthy = healthy_stats(values, chosen, train) if reused is None else dict(reused.healthy)
        if reused is not None:  # (a dead sensor's 0x is its finding's: said there)
            stuck = {c for n in notes if isinstance(n, StuckNote) for c in n.names}
            notes.extend(_spread_against_model(values, chosen, healthy, stuck))
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
                chosen,
                np.asarray(values[train[0] : train[1]]),
                options.config.groups,
                model=options.config.model,
            )
            notes.extend(group_notes)
        else:
            groups = [tuple(g) for g in reused.groups]
        fits = None if reused is None else reused.fits
        # every group's fitted detectors, for a search again with the same models
        # (analyzer.search_after), and saved with --save-model
        collected: dict[str, dict[str, tuple[Any, Any]]] = {}
        kept = collected if options.save_model is not None else None
        single = len(groups) == 1 and len(groups[0]) == len(chosen)

        def detect(which: list[str], label: str, signals: str) -> _Outcome:
            """Fit and run the detectors ``which`` (in ``names``' order) on every channel
            group; their progress shown as ``label + "detect"``, a long archive's signals
            kept in ``work / signals``."""
            run_ctx = ctx
            if label and ctx.progress is not None:
                shown = ctx.progress
                run_ctx = replace(
                    ctx, progress=lambda stage, done: shown(prefixed(label, stage), done)
                )
            into = work / signals if big else None
            shared = (options, data, run_ctx, executor, timings, into, start_tests)
            if single:
                return run_detectors(which, *shared, "", *fits_of("", fits, collected))
            return run_groups(groups, which, *shared, fits, collected)

        excitation = measured_inputs(ctx.config)

        def diagnose(found: list[DetectorResult]) -> tuple[list[Finding], list[str]]:
            return _diagnose(
                found, values, chosen, aligned.rate_hz, healthy, train, reused, excitation
            )

        screen, screen_note = None, ""
        unrun: DetectorError | None = None  # (why no detector ran, where the run goes on)
        try:
            if options.screen:
                results, skipped, screen, screen_note = _screened(
                    options.screen, names, groups, detect, diagnose, tests
                )
            else:
                results, skipped = detect(names, "", "signals")
        except TooShortForNamed as err:  # (the named detectors' window, as for any)
            _cancel(tests)
            named_error: DetectorError = err  # (gaps or channels apart: their own line)
            if not _apart_in_training(values, chosen, train, aligned.rate_hz):
                named_error = _no_detector_error(
                    err.reasons,
                    tr,
                    options,
                    "",
                    _slow_clock(infos, chosen, aligned.rate_hz, options.rate is not None),
                    (aligned.rate_hz, aligned.duration_s),
                    named=True,
                    held=_held_rows(values),
                    crosses=_change_inside(values, chosen, groups, aligned.rate_hz),
                )
            if not _constant_only_possible(notes, options, silent):
                if named_error is err:
                    raise
                raise named_error from err
            results, skipped, unrun = [], dict(err.reasons), named_error
        except BaseException:
            _cancel(tests)
            raise
        timings["detect"] = time.perf_counter() - t0
        if not results and unrun is None:
            error = _no_detector_error(
                skipped,
                tr,
                options,
                _apart_in_training(values, chosen, train, aligned.rate_hz),
                _slow_clock(infos, chosen, aligned.rate_hz, options.rate is not None),
                (aligned.rate_hz, aligned.duration_s),
                held=_held_rows(values),
                crosses=_change_inside(values, chosen, groups, aligned.rate_hz),
            )
            absurd = next((n for n in notes if n.startswith("infinite or absurd values")), None)
            if absurd is not None:  # (a channel whose every value is beyond 1e30, say)
                error = DetectorError(f"{error}; {absurd}")
            if not _constant_only_possible(notes, options, silent):
                raise error from None
            unrun = error
        if unrun is not None:
            # a sensor named that reads one value over the record is a fault the
            # detectors need not confirm: reported, with why they could not run
            notes.append(NoDetectorNote.of(unrun, notes, silent))
            timings["total"] = time.perf_counter() - t_start
            return Analysis(
                inputs=archive.inputs,
                channels=infos,
                analyzed=tuple(chosen),
                rate_hz=aligned.rate_hz,
                start_ns=aligned.start_ns,
                absolute_time=absolute,
                slowed=slowed,
                n=aligned.n,
                train=train,
                results=[],
                findings=merged(silent, constant_findings(notes, [])),
                values=values,
                notes=notes,
                timings=timings,
                skipped=skipped,
                healthy=healthy,
                model_info=None if reused is None else model_info(reused, options),
                config_info=options.config.info(),
                left_out=_left_out(notes, infos, chosen, options),
                no_reading=unread_words,
                renamed=applied_renames(archive),
                unrun=unrun,
                time_source=time_source(archive.inputs, options.time_source),
            )
        findings, found_notes = diagnose(results)
        notes.extend(found_notes)
        if reused is None:  # a step or a gain change inside the healthy window itself
            notes.extend(
                window_notes(
                    values,
                    chosen,
                    groups,
                    train,
                    tr,
                    aligned.duration_s,
                    aligned.rate_hz,
                    findings,
                    lambda: _window_need(results, aligned.rate_hz, values),
                )
            )
            # and a clock far above what the sensors carry (the models' memory too short),
            # where the user chose it (--rate): a clock the run chose is said already,
            # and the channels low-passed to it may measure a little slower than they did
            # at their own (the noise above its Nyquist gone: 4.7 Hz at 200 Hz against
            # 5.5 Hz at 2 kHz), which would name a slower rate again
            memory = _models_memory(options.config, {r.detector for r in results})
            fast = (
                oversampled_note(values, chosen, train, aligned.rate_hz, memory, clips)
                if slowed is None
                else None
            )
            if fast is not None:
                notes.append(fast)
        # and without the sensors found faulty while anomalies no sensor explained came
        # beside their faults (a second fault from the same instant: one at a time)
        slack = LONG_FACTOR * default_window(aligned.rate_hz) / aligned.rate_hz
        suspects = (
            beside_faults(findings, results, aligned.n, aligned.rate_hz, slack)
            if reused is None
            and options.save_model is None
            and not options.config.groups
            and not options.screen
            else {}
        )
        if len(chosen) - len({*lost, *suspects}) < SEARCH_AGAIN_MIN:
            suspects = {}
        again: list[Finding] = []
        if lost or suspects:
            t_again = time.perf_counter()
            again, again_notes = _searched_without(
                (lost, suspects),
                findings,
                [r.detector for r in results],
                options,
                (values, chosen, train, aligned.rate_hz),
                ctx,
                executor,
                work if big else None,
                excitation,
            )
            # (a fault the first search saw only from later: the second search's onset)
            late = {id(g) for f in again for g in seen_late(f, findings, slack)}
            findings = [f for f in findings if id(f) not in late]
            findings = sorted([*findings, *again], key=lambda f: (f.onset_s, f.channel))
            notes.extend(again_notes)
            timings["search again"] = time.perf_counter() - t_again
        # the load or the structure beyond anything the training window held
        levels = response_levels(values, aligned.rate_hz, train if reused is None else None)
        # and searched again after such a stretch, where an anomaly no sensor explained
        # began: a fault that began there and outlasted it was left in that anomaly
        todo, more = (
            after_stretches(excursions(levels)[0], results, aligned.n, aligned.rate_hz, slack)
            if reused is None and not options.screen
            else ([], 0)
        )
        if todo:
            t_after = time.perf_counter()
            searched: list[tuple[Stretch, list[Finding]]] = []
            for k, stretch in enumerate(todo):
                new = _searched_after(
                    stretch,
                    k,
                    findings,
                    [r.detector for r in results],
                    (options, data, groups, collected),
                    ctx,
                    executor,
                    work if big else None,
                    diagnose,
                )
                searched.append((stretch, new))
                again.extend(new)
                findings = sorted([*findings, *new], key=lambda f: (f.onset_s, f.channel))
            notes.append(after_note(searched, more))
            timings["search after"] = time.perf_counter() - t_after
        # (over every search's findings: a later fault may be one a search again found);
        # a finding given another end may now be frozen over its period
        periods = {id(f): (f.onset_s, f.end_s) for f in findings}
        notes.extend(ends_of_later_faults(findings, coupled(results)))
        hidden = ends_hidden_by_later(findings, coupled(results))
        early = onsets_hidden_by_earlier(findings, coupled(results))
        if (
            (hidden or early)
            and reused is None
            and not options.screen
            and not options.config.groups
            and len(chosen) - 1 >= SEARCH_AGAIN_MIN
        ):
            t_ends = time.perf_counter()
            notes.extend(
                _ends_without(
                    hidden,
                    [r.detector for r in results],
                    options,
                    (values, chosen, train, aligned.rate_hz),
                    ctx,
                    executor,
                    work if big else None,
                    excitation,
                    early,
                )
            )
            timings["ends without"] = time.perf_counter() - t_ends
        moved = [f for f in findings if periods[id(f)] != (f.onset_s, f.end_s)]
        rows, zeros = _at_rest(train, reused)
        notes.extend(
            relabel_frozen(moved, values, chosen, aligned.rate_hz, healthy, train[1], rows, zeros)
        )
        # and a dead sensor in an anomaly the detectors attributed to no sensor: its
        # readings tell what their residuals could not isolate
        dead, told = dead_unattributed(
            results,
            findings,
            values,
            chosen,
            aligned.rate_hz,
            healthy,
            rows,
            train[1],
            excitation,
            zeros,
        )
        findings = [*findings, *dead]
        notes.extend(told)
        findings.sort(key=lambda f: (f.onset_s, f.channel))
        # the detection filter's lone shapeless fault on a sensor whose alarm the bank
        # could not place: an alarm no sensor's fault explains, not that sensor's fault
        findings, unplaced_alarms, unplaced_notes = unplaced(findings, results, slack)
        notes.extend(unplaced_notes)
        notes.extend(_weak_findings_note(findings, ctx.false_alarm_rate))
        seam_at = partial(near_seam, archive.seams, aligned.start_ns)
        notes.extend(_unattributed_notes(results, findings, aligned.rate_hz, seam_at))
        # and those of them no finding explains: a second faulty sensor the verdict,
        # findings.json and the run's last line name (the notes alone were missed)
        unexplained = sorted(
            [
                *unexplained_alarms(results, findings, slack, excursions(levels)[0]),
                *unplaced_alarms,
            ],
            key=lambda u: (u.onset_s, u.channels),
        )
        unexplained = [_tied_to_seam(u, seam_at(u.onset_s)) for u in unexplained]
        notes.extend(_after_gap_notes(findings, values, chosen, aligned.rate_hz))
        notes.extend(n for n in [level_note(levels)] if n)
        if levels is not None and levels.train is not None:
            judged = loud_stretch_count(
                [ev for f in findings for ev in f.events],
                [n for r in results for n in r.notes],
                len(chosen),
            )
            notes.extend(_louder_than_window(values, train, aligned.rate_hz, levels.train, judged))
        if isinstance(executor, DaskExecutor):  # after the work: tasks sent again, say
            notes.append(executor.describe())
            trouble = executor.trouble()  # (the cluster lost: a warning on stderr too)
            if trouble is not None:
                notes.append(ClusterTrouble(trouble))
        if screen is not None:
            notes.append(screen_note)
        t0 = time.perf_counter()
        parts = results
        results = merge_groups(parts, chosen)  # one result per detector (channel groups)
        # (the second search's findings carry the evidence of its own residuals)
        added = {id(f) for f in again}
        attach_evidence(
            [f for f in findings if id(f) not in added],
            results,
            aligned.rate_hz,
            train,
            whiten=reused is None,
        )
        for r in parts:
            r.model["training_tests"], r.model["windowed_tests"] = {}, {}
        for k, (task, handle) in enumerate(tests):
            trained, windowed = _residual_tests(task) if handle is None else handle.result()
            task[0].model["training_tests"].update(trained)
            task[0].model["windowed_tests"].update(windowed)
            ctx.report("tests", (k + 1) / len(tests))
        merge_tests(results, parts)
        if reused is not None:
            for r in results:
                r.model["training_tests"] = dict(reused.training_tests.get(r.detector, {}))
        # on threads: what was left of the tests when the detection ended
        timings["test"] = time.perf_counter() - t0
        corrected = None
        corrections: list[dict[str, Any]] = []
        if options.corrected:
            res_map, ref_map = result_signals(results)
            # (--model: the window is the filters' warm-up, not a healthy stretch; one of
            # the record's own that the analysis found free of faults instead)
            healthy_rows, said = (
                (train, "")
                if reused is None
                else _model_stretch(findings, aligned.n, aligned.rate_hz, train, reused)
            )
            corrected, corrections = corrected_values(
                values,
                chosen,
                aligned.rate_hz,
                findings,
                res_map,
                ref_map,
                ctx.buffer,
                healthy_rows,
                fitted_estimates(collected, groups, chosen),
            )
            if said and any(
                c["method"] in ESTIMATED or c["note"].startswith("left as measured")
                for c in corrections
            ):
                notes.append(said)
        # a fault under way where its channel stopped publishing lasts, as far as is known,
        # to the end of its data: no end (evidence.data_ends_s), not a recovery there (the
        # findings' own ends served the alarms they explain and the corrections above)
        ends_with_data(findings, values, chosen, aligned.rate_hz)
        # the sensors named (--channels, the config, the model) that read one value over
        # the whole record: one finding each, with what the detectors found on it
        findings = merged(silent, constant_findings(notes, findings))
        notes.extend(n for n in [_blank_model_note(unread, results, unread_words)] if n)
        # a clipped or stuck value that may be a logger's "no reading" (-9999): said how
        # to declare it (:mod:`analyzer.missing_codes`)
        notes.extend(code_hints(findings, values, chosen))
        # a finding whose onset coincides with a message the recorder logged late
        cautions = onset_cautions(
            [
                (f.channel, f.onset_s, f"{f.channel} {f.type} from {seconds_text(f.onset_s)} s")
                for f in findings
            ],
            jittery,
            aligned.start_ns,
            topics,
        )
        notes.extend(cautions_line(cautions))
        timings["total"] = time.perf_counter() - t_start
        return Analysis(
            inputs=archive.inputs,
            channels=infos,
            analyzed=tuple(chosen),
            rate_hz=aligned.rate_hz,
            start_ns=aligned.start_ns,
            absolute_time=absolute,
            slowed=slowed,
            n=aligned.n,
            train=train,
            results=results,
            findings=findings,
            values=values,
            notes=notes,
            timings=timings,
            skipped=skipped,
            levels=levels,
            unexplained=unexplained,
            corrected=corrected,
            corrections=corrections,
            settling=settling_rows(collected),
            healthy=healthy,
            saved=reused
            if kept is None
            else SavedModel(
                channels=tuple(chosen),
                rate_hz=aligned.rate_hz,
                # (its first and last sample, as findings.json's saved_model says them)
                train_s=(train[0] / aligned.rate_hz, (train[1] - 1) / aligned.rate_hz),
                inputs=tuple(
                    (str(i.path), i.sha256 or input_digest(Path(i.path))) for i in archive.inputs
                ),
                groups=tuple(tuple(g) for g in groups),
                fits=in_registry_order(kept),
                healthy=healthy,
                training_tests={r.detector: dict(r.model["training_tests"]) for r in results},
                false_alarm_rate=ctx.false_alarm_rate,
                config=dict(ctx.config),
                time_source=options.time_source,
                created=iso_utc(time.time_ns()) or "",
                reading_health=residual_health(results, train),
                zero_at_rest=zero_channels(values, chosen, train, healthy, aligned.rate_hz),
            ),
            model_info=None if reused is None else model_info(reused, options),
            config_info=options.config.info(),
            screen=screen,
            left_out=_left_out(notes, infos, chosen, options),
            no_reading=unread_words,
            renamed=applied_renames(archive),
            time_source=time_source(archive.inputs, options.time_source),
            cautions=cautions,
        )


def _constant_only_possible(
    notes: Sequence[str], options: RunOptions, silent: Sequence[Finding] = ()
) -> bool:
    """Whether a run whose detectors could not run reports the constant check's findings
    (a :class:`~analyzer.selection.StuckNote` among the ``notes``) or the ``silent``
    sensors' (:mod:`analyzer.silent`) rather than stop: a
    dead sensor the user named needs no model to be seen (a 12-s cart-pole record whose
    ``cart_position`` reads 0.0 on all 244 samples stopped with "no detector could run",
    naming it nowhere: the audit). Not with ``--save-model``, which has nothing to save."""
    return options.save_model is None and (
        bool(silent) or any(isinstance(n, StuckNote) for n in notes)
    )


class NoDetectorNote(WindowNote):
    """The note (repeated on stderr) of a run whose detectors could not run, that reports
    the constant check's findings alone (:func:`_constant_only_possible`): why they could
    not run (the error the run stopped with before), and that no other fault was searched
    for, so the exit code 1 is the dead sensors' only."""

    @classmethod
    def of(
        cls, error: Exception, notes: Sequence[str], silent: Sequence[Finding] = ()
    ) -> NoDetectorNote:
        """The note on ``error`` (the detectors' error), naming the channels the
        ``notes``' :class:`~analyzer.selection.StuckNote` reports and the ``silent``
        findings' (:mod:`analyzer.silent`)."""
        names = [c for n in notes if isinstance(n, StuckNote) for c in n.names]
        names += [f.channel for f in silent]
        which = [w for w, on in (("constant", len(names) > len(silent)), ("silent", silent)) if on]
        checks = f"{' and '.join(which)} check{'s' if len(which) > 1 else ''} ran"
        text = (
            f"no fault but a dead or stuck sensor ({', '.join(names)}) was searched for: "
            f"only the {checks} (it needs no healthy window); {one_line(error)}"
        )
        return cls(text, text)


CONSTANT_CHECK = "constant_check"
"""The name findings.json gives the check of :func:`constant_findings` (its findings'
``detector``, its entry in ``detectors``)."""


def constant_findings(notes: Sequence[str], findings: Sequence[Finding]) -> list[Finding]:
    """``findings`` with a finding for each channel named (``--channels``, the config's
    sensors, a saved model's channels) that reads one value on every sample of the
    record beside varying channels (the selection's :class:`~analyzer.selection.
    StuckNote`), sorted by onset: a note alone let a dead sensor pass as "no sensor fault
    found", exit 0 (a new user's audit). At 0 the contract's dead sensor
    (``multiplicative``, gain 0), else ``other`` stuck at its value; from the record's
    start (at or before: it may have been so before the record began) to its end,
    confidence 1 (every sample read). The detectors' own findings on such a channel
    (``--model`` runs them on it: the model needs it; they search only after their
    warm-up) are the same fault: one finding, their names in ``evidence.detectors``
    (CONTRACT.md: one physical fault is one entry)."""
    stuck = [i for n in notes if isinstance(n, StuckNote) for i in n.infos]
    names = {i.name for i in stuck}
    seen = {i.name: [f for f in findings if f.channel == i.name] for i in stuck}
    out = [f for f in findings if f.channel not in names]
    out += [_constant_finding(i, seen[i.name]) for i in stuck]
    return sorted(out, key=lambda f: (f.onset_s, f.channel))


def _constant_finding(info: ChannelInfo, also: Sequence[Finding]) -> Finding:
    """The finding on ``info``, a channel that reads one value over the whole record,
    with the detectors of the findings ``also`` on it (and their earliest onset,
    ``evidence.constant.seen_from_s``) as its evidence."""
    value = float(info.minimum)
    dead = value == 0.0
    detectors = [d for f in also for d in f.evidence.get("detectors", [f.detector])]
    constant: dict[str, Any] = {
        "value": value,
        "samples": info.finite,
        "said": stuck_words(info),
    }
    if also:
        constant["seen_from_s"] = min(f.onset_s for f in also)
    return Finding(
        info.name,
        FaultType.MULTIPLICATIVE if dead else FaultType.OTHER,
        0.0,
        None,
        {"gain": 0.0} if dead else {"stuck_at": value},
        1.0,
        CONSTANT_CHECK,
        evidence={
            "detectors": list(dict.fromkeys([CONSTANT_CHECK, *detectors])),
            "tests": {},
            "onset_at_or_before": True,
            "constant": constant,
        },
    )


def config_renames(options: RunOptions) -> dict[str, str]:
    """The renames of ``options`` that its config's ``[rename]`` gave (the option did not
    override them), each as its errors name it: ``F: [rename] s9 = "s2"``
    (:attr:`~analyzer.readers.Archive.rename_origin`)."""
    cfg = options.config
    given = dict(options.rename)
    return {
        new: f'{cfg.path}: [rename] {new} = "{old}"'
        for new, old in cfg.rename.items()
        if given.get(new) == old
    }


def _no_reading(blank: set[str], unread: Mapping[str, tuple[str, int]]) -> dict[str, str]:
    """The channels with no reading at all, each with what its values were: a CSV column
    ``blank`` in every row, or one of ``unread`` (:meth:`~analyzer.missing_codes.Unread.
    lost`: every value NaN, a ``--missing-values`` code or beyond 1e30), in name order
    (findings.json's ``channels[]`` and the report's channel table list them)."""
    return {
        c: (
            f"every one of its {unread[c][1]} values is {unread[c][0]}"
            if c in unread
            else BLANK_WORDS
        )
        for c in sorted(blank)
    }


def _blank_note(blank: Sequence[str]) -> list[str]:
    """The note on the CSV columns ``blank`` in every row that were not analyzed: the
    reader says it on stderr as an input's error, and findings.json's ``notes`` said
    nothing of them (a channel with no reading, said as :class:`~analyzer.missing_codes.
    UnreadNote` says the others)."""
    if not blank:
        return []
    one = len(blank) == 1
    return [
        f"{capped(sorted(blank))}: blank in every row (no reading at all: "
        f"{'a dead sensor, or one' if one else 'dead sensors, or ones'} not recorded), so "
        f'not analyzed; listed in channels with why "no reading"'
    ]


def _left_out(
    notes: Sequence[str], infos: Sequence[ChannelInfo], chosen: Sequence[str], options: RunOptions
) -> dict[str, dict[str, str]]:
    """Why each channel of ``infos`` not in ``chosen`` was not analyzed, as ``inspect
    --json`` says it (:func:`~analyzer.selection.left_out`), the training window's
    choices included; one the selection's notes do not name was ``not selected``
    (``--channels`` or the saved model did not name it)."""
    why = left_out(notes, {i.name: i for i in infos})
    analyzed = set(chosen)
    return {
        i.name: why.get(i.name, {"why": "not selected"}) for i in infos if i.name not in analyzed
    }


ESTIMATED = ("reference", "residual")
"""The corrections that replace a reading by an estimate, those that read the healthy
window (as does a reading left as measured for its estimate's error: ``skipped``, its
note ``left as measured...``)."""


def _model_stretch(
    findings: Sequence[Finding], n: int, rate_hz: float, train: tuple[int, int], model: SavedModel
) -> tuple[tuple[int, int] | None, str]:
    """``--model --corrected``: the rows of the record that the regeneration takes as its
    healthy window (:func:`~analyzer.regenerate.corrected_values`' ``healthy``), and a
    note that says which. The run's window is the filters' warm-up (their zero start
    state), so the stretch is the record's longest with no finding of any channel active
    (:func:`~analyzer.regenerate.healthy_stretch`), from the end of the warm-up the
    model asks for (:func:`~analyzer.reuse.warmup`: its filters' settling and its
    longest alarm window; a record shorter than twice that starts its search earlier)
    and that far from every finding's onset and end: the filters carry a fault for
    as long after it ends, and the detectors place an onset or an end within an alarm
    window. It must be at least as long as that warm-up, the span a ``--model`` run
    itself sets aside before it trusts a residual (its filters' settling, then one
    alarm window: what the detectors' own tests judge a residual's spread by), and
    at least :data:`MIN_TRAIN_ROWS` (what any training window needs). None without
    such a stretch: a reading replaced by an estimate is then replaced to its finding's
    end, whatever its estimate's error (the note says so)."""
    wanted = warmup(model)
    least = max(MIN_TRAIN_ROWS, wanted)
    got = healthy_stretch(findings, n, rate_hz, max(train[1], wanted), wanted, least)
    if got is None:
        return None, (
            "--corrected with --model: no stretch of at least "
            f"{spoken_duration(least / rate_hz)} of this "
            f"record is free of findings ({spoken_duration(wanted / rate_hz)} from each, after the "
            "filters' warm-up), so no healthy stretch calibrates the regeneration: a reading "
            "replaced by an estimate is replaced to its finding's end, even where the sensor "
            "is alive again or the estimate is no better than the reading"
        )
    return got, (
        f"--corrected with --model: the regeneration's healthy stretch is "
        f"{short_seconds(got[0] / rate_hz)}-{short_seconds(got[1] / rate_hz)} s of this record "
        "(the longest with no "
        f"finding active, after the filters' warm-up and {spoken_duration(wanted / rate_hz)} from "
        "each "
        "finding): a reading replaced by an estimate ends where the readings are alive "
        "again, and is left as measured where the estimate's error there is as large as "
        "the fault's"
    )


def _cancel(tests: list[Any]) -> None:
    """Cancel the residual tests not yet started (``(task, handle)`` pairs; a test already
    running finishes, its result unread)."""
    for _, handle in tests:
        if handle is not None:
            handle.cancel()


def _searched_without(
    left_out: tuple[dict[str, list[tuple[int, int]]], dict[str, list[tuple[int, int]]]],
    findings: list[Finding],
    ran: list[str],
    options: RunOptions,
    matrix: tuple[Any, list[str], tuple[int, int], float],
    ctx: RunContext,
    executor: Executor,
    work: Path | None,
    excitation: frozenset[str],
) -> tuple[list[Finding], list[str]]:
    """The detectors that ran (``ran``, one name per result) fitted again on the healthy
    window without the channels ``left_out`` names (:mod:`analyzer.reconfigure`: those
    missing for long, and the sensors found faulty with anomalies beside their faults,
    each with its rows), over the whole record, and the findings of theirs that begin in
    those rows and that ``findings`` lack, with their evidence (the tests of the second
    search's residuals); and the run's note on it. ``matrix``: the aligned values, their
    channels, the healthy window's rows and the rate."""
    values, chosen, train, rate_hz = matrix
    lost, suspects = left_out
    rows = {c: [*lost.get(c, []), *suspects.get(c, [])] for c in {*lost, *suspects}}
    keep = [c for c in chosen if c not in rows]
    names = list(dict.fromkeys(ran))
    sub = columns(values, chosen, keep, None if work is None else work / "aligned-without.npy")
    data = Dataset(sub, tuple(keep), rate_hz, train, healthy=True)
    groups, _ = partition(keep, np.asarray(sub[train[0] : train[1]]), model=options.config.model)
    into = None if work is None else work / "signals-again"
    # its own scratch (the detectors' long results have fixed names: the first search's
    # are still read) and the detectors that cannot run on fewer channels skipped, not
    # an error (--detectors, a config [model] naming a left-out channel)
    run_ctx = _search_context(ctx, "again")
    results = _run_again(names, options, data, groups, run_ctx, executor, into, None)
    if not results:
        return [], []
    healthy = healthy_stats(sub, keep, train)
    found, said = _diagnose(results, sub, keep, rate_hz, healthy, train, None, excitation)
    slack = LONG_FACTOR * default_window(rate_hz) / rate_hz
    added = found_again(found, findings, lost, rate_hz, slack, suspects, len(names))
    attach_evidence(added, merge_groups(results, keep), rate_hz, train)
    # what the second search says of its own findings' clipping goes with them (its other
    # notes are about the second search's view, not the record's)
    clipped = {f.channel for f in added if "clipped" in f.evidence}
    own = [n for n in said if any(n.startswith(f"{c} clips at ") for c in clipped)]
    return added, [reconfigure_note(lost, suspects, added, rate_hz, slack), *own]


def _ends_without(
    hidden: list[tuple[Finding, Finding]],
    ran: list[str],
    options: RunOptions,
    matrix: tuple[Any, list[str], tuple[int, int], float],
    ctx: RunContext,
    executor: Executor,
    work: Path | None,
    excitation: frozenset[str],
    early: Sequence[tuple[Finding, Finding]] = (),
) -> list[str]:
    """The ends of the ``hidden`` findings, each with the later fault on another sensor
    that hid its end (:func:`~analyzer.diagnosis.merge.ends_hidden_by_later`), from the
    detectors that ran (``ran``) fitted again without that fault's sensor, over the whole
    record: a finding of theirs on the same sensor that begins within a long alarm
    window of its onset and ends after the later fault began and before the hidden end
    gives its end (and its size, when of its type), or the latest end of its events
    that saw the sensor faulty again after it, or of the search's later findings on the
    sensor that began before the latest end of the finding's own events (none: the fault
    went on to the hidden end or the record's, and the finding stays). A hidden end
    where the later fault began (within a long alarm window: the first fault ended
    there, or was lost there) takes an end of theirs more than that window after it, or
    the record's end, but none more than that window after the latest end of its
    events (with the later fault's trace in
    their residuals they saw it no longer: an end past that is something else, and the
    finding stays). Its type, where that search reads another over the same period,
    comes from it too (:func:`_shape_without`). Then, every end done, the onsets of
    the ``early`` findings, each with the earlier fault under way where its lead began
    (:func:`_onset_without`),
    from the same search without that fault's sensor (a finding with an earlier and a
    later fault keeps the end found without the later one's, whichever sensor's name
    comes first). Changes the findings in place (their evidence ``end_without``: the sensor
    left out, the detector and the end before) and returns a note for each. One search
    per sensor left out. ``matrix``: the aligned values, their channels, the healthy
    window's rows and the rate.

    A detector that estimates a sensor from another sees that one's fault in its
    residual of the sensor: from where it began the two faults are one alarm to it,
    which ends where the later fault does, and the detection filter, which tells the
    sensors' directions apart, loses the first where both are on (every filter off its
    direction). Without the later fault's sensor the first fault is alone: a gain on s1
    from 100 to 200 s with an offset on s4 from 150 to 250 s (seed 1 of
    ``sweep_two_faults.py``) was reported to 250.1 s, the bank's and the observers'
    end, the filter's lost at 150.1 s; an offset on s0 from 100 to 200 s with one on s1
    from 150 to 250 s (seed 6) to 225.8 s, the bank's end, the filter's at 200.0 s."""
    values, chosen, train, rate_hz = matrix
    slack = LONG_FACTOR * default_window(rate_hz) / rate_hz
    names = list(dict.fromkeys(ran))
    notes: list[str] = []
    founds: dict[str, list[Finding]] = {}
    for left in sorted({g.channel for _, g in [*hidden, *early]}):
        keep = [c for c in chosen if c != left]
        path = None if work is None else work / f"aligned-ends-{chosen.index(left)}.npy"
        sub = columns(values, chosen, keep, path)
        data = Dataset(sub, tuple(keep), rate_hz, train, healthy=True)
        groups, _ = partition(
            keep, np.asarray(sub[train[0] : train[1]]), model=options.config.model
        )
        run_ctx = _search_context(ctx, f"ends{chosen.index(left)}", "ends")
        into = None if work is None else work / f"signals-ends{chosen.index(left)}"
        results = _run_again(names, options, data, groups, run_ctx, executor, into, None)
        if not results:
            continue
        found, _ = _diagnose(
            results, sub, keep, rate_hz, healthy_stats(sub, keep, train), train, None, excitation
        )
        founds[left] = found
        for f, g in hidden:
            if g.channel != left:
                continue
            # its shape as the residuals without the later fault's trace read it, where
            # that search saw the fault over the same period
            notes.extend(n for n in [_shape_without(f, g, found, slack)] if n)
            # ended where the later fault began (lost there, or ended): an end after it;
            # or within a long window after one of its detectors saw it begin (its
            # finding's onset may be another's early one, which the onset search moves
            # only after the ends)
            lost = f.end_s is not None and (
                f.end_s <= g.onset_s + slack
                or any(e.onset_s <= f.end_s <= e.onset_s + slack for e in g.events)
            )
            until = float("inf") if f.end_s is None or lost else f.end_s - slack
            # (lost there: no later than its events saw it, the later fault's trace in)
            ends = [e.end_s for e in f.events]
            past = float("inf") if None in ends else max(e for e in ends if e is not None)
            alone = [
                h
                for h in found
                if h.channel == f.channel
                and abs(h.onset_s - f.onset_s) <= slack
                and (
                    (h.end_s is None or h.end_s > f.end_s + slack)
                    if lost and f.end_s is not None
                    else h.end_s is not None and g.onset_s - slack <= h.end_s < until
                )
            ]
            if not alone:
                continue
            h = alone[0]
            # events of its own that saw the sensor faulty again after its end (a fault
            # that stopped and began again, its parts one finding): the fault went on
            again = [e.end_s for e in h.events if h.end_s is not None and e.onset_s > h.end_s]
            # or a later finding of the search on the sensor, of the same type, that began
            # where the first search's events still saw it faulty (its parts two findings
            # there: a gain whose end the search sees, :func:`~analyzer.diagnosis.events.
            # _gain_ended`)
            again += [
                k.end_s
                for k in found
                if k is not h
                and k.channel == f.channel
                and k.type is h.type
                and h.end_s is not None
                and h.end_s < k.onset_s < past
            ]
            end = h.end_s
            if again:
                end = None if None in again else max(e for e in again if e is not None)
                if not lost and (end is None or end >= until):
                    continue
            source: Finding | Event = h
            if lost and (float("inf") if end is None else end) > past + slack:
                # its lead saw it end past what the first search saw (not seen faulty
                # again after its end: then it went on): the latest end of its other
                # events that both searches allow, if any
                within = None if again else _within_both(h, f.end_s, past, slack)
                if within is None:
                    continue
                source, end = within, within.end_s
            was, f.end_s = f.end_s, end
            # (findings.json: where the end came from, beside the detectors' own events)
            f.evidence["end_without"] = {
                "left_out": left,
                "detector": source.detector,
                "was_s": was,
            }
            size = ""
            if source.type is f.type:
                f.magnitude = dict(source.magnitude)
                size = (
                    ", with its size then ("
                    + ", ".join(f"{k} {v:.4g}" for k, v in f.magnitude.items())
                    + ")"
                )
            notes.append(
                f"{f.type.value} fault on {f.channel}: ended at "
                + ("the record's end" if end is None else f"{seconds_text(end)} s")
                + f" as {source.detector} saw it with {left} left out{size}; with {left} it was "
                "reported to "
                + ("the record's end" if was is None else f"{seconds_text(was)} s")
                + f", the {g.type.value} fault on {left} (from {seconds_text(g.onset_s)} s) in the "
                "residuals of the detectors that model the two sensors together"
            )
    # the onsets after every end: a finding with an earlier fault under way where it began
    # and a later one that hid its end keeps the end found without the later one's sensor
    # (without the earlier one's, the later fault is still in its residuals), whichever
    # sensor's name comes first
    notes.extend(
        _onset_without(f, g, founds[g.channel], slack) for f, g in early if g.channel in founds
    )
    return [n for n in notes if n]


def _within_both(h: Finding, lost_at: float | None, past: float, slack: float) -> Event | None:
    """The event of ``h`` (a finding of the search without a later fault's sensor, whose
    lead ended past what the first search saw) of ``h``'s type with the latest end that
    both searches allow: more than ``slack`` after ``lost_at``, where the first search
    lost the fault (where the later fault began), and no more than ``slack`` after
    ``past``, the latest end of the first search's events; None when no event of ``h``
    has one.

    The detectors of ``h`` saw the fault alone and may disagree on its end: the lead,
    the event that alarmed first, is one of them (their confidences saturate at 1), and
    its end past ``past`` is no end the first search confirms, while another's within
    it is. A gain of 1.5 on s1 from 100 to 200 s beside an offset on s4 from 150 to
    250 s (seeds 7 and 13 of ``sweep_two_faults.py``, ``gain-offset``): with s4 the
    detection filter and the observers lost it at 150.1 s, the bank saw it to 250.0 s;
    without s4 the bank and the filter saw it to 200.0 s, the observers, whose gain led,
    to 272.7 s and 279.5 s."""
    lo = float("-inf") if lost_at is None else lost_at + slack
    ends = [
        e
        for e in h.events
        if e.type is h.type and e.end_s is not None and lo < e.end_s <= past + slack
    ]
    return max(ends, key=lambda e: float(e.end_s or 0.0)) if ends else None


def _shape_without(f: Finding, g: Finding, found: Sequence[Finding], slack: float) -> str:
    """The type and size of ``f``, a finding whose end a later fault of another sensor
    hid (:func:`~analyzer.diagnosis.merge.ends_hidden_by_later`; ``g``, that fault), from
    ``found``, the findings of the detectors fitted again without ``g``'s sensor: one on
    ``f``'s sensor over the same period (its onset and its end within ``slack``, a long
    alarm window, of ``f``'s; both open, or both closed) of another type gives its type,
    size, detector and confidence; ``f`` changes in place (evidence ``shape_without``: the
    sensor left out, the detector, the type and size before). ``f``'s evidence
    ``detectors``, ``tests`` and ``by_detector`` stay its first search's, as with
    :func:`_onset_without`: ``shape_without`` says that the type and size are not
    theirs. Returns a note, or ``""`` when there is no such finding or it agrees on
    the type.

    One of the same type leaves ``f`` as it is, size and all: the search has one sensor
    fewer, and where that sensor was ``f``'s best neighbour (the same floor's pair) its
    estimate of ``f``'s sensor is worse, so a gain (the reading against its estimate)
    came out 3-13 % off where the type agreed (a gain of 1.8 on the 3x2 and 5x1
    buildings, seeds 0-2), and the first search's vote, made with every sensor, stands.

    A detector that estimates a sensor from another sees that one's fault in its
    residual of the sensor: from where the later fault began, its trace is in the
    stretch the first fault's shape is fitted on, over the first fault's own to its end.
    Without the later fault's sensor the residuals carry the first fault alone. An
    offset of 2 sd on s4 of the 3x2 building from 16 s, with a drift of 0.5 sd/s on s5
    from 32 s (Chang et al.'s Fig. 15, seed 4): the detection filter and the observers,
    whose estimates of s4 take s5's drift in, read the stretch 16-50 s as a gain of 0.41
    (explained 0.63) and outvoted the bank's offset (5.06 for 5.36); without s5 all three
    read an offset (5.29-5.35). The search is the one the end is looked for in
    (:func:`_ends_without`): a search without the later sensor is run only for such a
    pair."""
    if "frozen" in f.evidence:
        return ""  # its readings decided its type (analyzer.diagnosis.stuck)

    def near(a: float | None, b: float | None) -> bool:
        if a is None or b is None:
            return a is None and b is None  # (both open)
        return abs(a - b) <= slack

    same = [
        h
        for h in found
        if h.channel == f.channel and near(h.onset_s, f.onset_s) and near(h.end_s, f.end_s)
    ]
    if not same:
        return ""
    h = min(same, key=lambda x: abs(x.onset_s - f.onset_s))
    if h.type is f.type:
        return ""  # the type agrees: its own size, from every sensor, stands
    kind_was, size_was, detector_was = f.type.value, dict(f.magnitude), f.detector
    was = {"type": kind_was, "magnitude": size_was, "detector": detector_was}
    f.type, f.magnitude = h.type, dict(h.magnitude)
    f.detector, f.confidence = h.detector, h.confidence
    f.evidence["shape_without"] = {"left_out": g.channel, "detector": h.detector, "was": was}
    size = ", ".join(f"{k} {v:.4g}" for k, v in f.magnitude.items())
    before = ", ".join(f"{k} {v:.4g}" for k, v in size_was.items())
    return (
        f"{f.type.value} fault on {f.channel} ({size}) as {h.detector} saw it with "
        f"{g.channel} left out; with {g.channel} {detector_was} read a {kind_was} fault, "
        f"{before}: "
        f"the {g.type.value} fault on {g.channel} (from {seconds_text(g.onset_s)} s) was in the "
        "stretch its shape was fitted on, in the residuals of the detectors that model "
        "the two sensors together"
    )


def _onset_without(f: Finding, g: Finding, found: Sequence[Finding], slack: float) -> str:
    """The period and shape of ``f``, a finding whose lead began while ``g``, an earlier
    fault of another sensor, was under way (:func:`~analyzer.diagnosis.merge.
    onsets_hidden_by_earlier`), from ``found``, the findings of the detectors fitted
    again without ``g``'s sensor: one on ``f``'s sensor that begins more than ``slack``
    (a long alarm window) after ``f`` did and within ``slack`` of one of ``f``'s events
    (another detector saw it begin there), before ``f`` ended, gives its onset, end,
    type and size; ``f`` changes in place (evidence ``onset_without``: the sensor left
    out, the detector, the period before). Returns a note, or ``""`` when no such
    finding, or when one of ``found`` on ``f``'s sensor begins within ``slack`` of
    ``f``'s onset: without ``g``'s sensor the sensor was seen faulty from there, so the
    onset is its own, not ``g``'s trace (a fault on s2 from 150 to 170 s and again from
    180 s, inside one on s5, that the bank saw as one from 150 s and the observers only
    from 180 s, keeps its 150 s). An end found without a later fault's sensor
    (evidence ``end_without``, :func:`_ends_without`) stays: this search still has that
    fault in its residuals.

    The type too: the lead's shape was fitted from its early onset, over the earlier
    fault's trace. An offset on s2 from 150 to 250 s beside a drift on s5 from 100 s
    (seed 17 of ``sweep_two_faults.py``, ``drift-offset``) was the bank's drift from
    142.15 s to 294.52 s (the observers' offset from 150.0 s outvoted one to one), and
    the bank's offset from 150.0 s to 250.0 s without s5 (3.43 for 3.43 injected)."""
    own = [h for h in found if h.channel == f.channel]
    if any(abs(h.onset_s - f.onset_s) <= slack for h in own):
        return ""
    alone = [
        h
        for h in own
        if h.onset_s > f.onset_s + slack
        and (f.end_s is None or h.onset_s < f.end_s)
        and any(abs(h.onset_s - e.onset_s) <= slack for e in f.events)
    ]
    if not alone:
        return ""
    h = min(alone, key=lambda x: x.onset_s)
    was = (f.onset_s, f.end_s)
    f.onset_s = h.onset_s
    ended = f.evidence.get("end_without")
    if ended is None:
        f.end_s = h.end_s
    f.evidence["onset_without"] = {
        "left_out": g.channel,
        "detector": h.detector,
        "was_s": list(was),
    }
    # its shape too: the lead's was fitted from its early onset, over the other's trace
    kind = "" if h.type is f.type else f" (with {g.channel}: a {f.type.value} fault)"
    f.type, f.magnitude = h.type, dict(h.magnitude)
    size = ", ".join(f"{k} {v:.4g}" for k, v in f.magnitude.items())
    span = "the record's end" if was[1] is None else f"{seconds_text(was[1])} s"
    return (
        f"{f.type.value} fault on {f.channel}: from {seconds_text(h.onset_s)} s to "
        + ("the record's end" if f.end_s is None else f"{seconds_text(f.end_s)} s")
        + ("" if ended is None else f" (its end as seen with {ended['left_out']} left out)")
        + f" ({size}) as {h.detector} saw it with {g.channel} left out{kind}; with "
        f"{g.channel} {f.detector} saw it from {seconds_text(was[0])} s to {span}, while the "
        f"{g.type.value} fault "
        f"on {g.channel} (from {seconds_text(g.onset_s)} s) was under way, in the residuals of the "
        "detectors that model the two sensors together"
    )


def _run_again(
    names: list[str],
    options: RunOptions,
    data: Dataset,
    groups: list[tuple[str, ...]],
    run_ctx: RunContext,
    executor: Executor,
    into: Path | None,
    fits: dict[str, dict[str, tuple[Any, Any]]] | None,
) -> list[DetectorResult]:
    """A second search's run of the detectors ``names`` on every channel group of
    ``data`` (one run when a single group holds every channel), fitted again, or with
    ``fits`` by group when given; its long signals in ``into``, its results only."""
    if len(groups) == 1 and len(groups[0]) == len(data.channels):
        given = None if fits is None else fits.get("", {})
        return run_detectors(
            names, options, data, run_ctx, executor, {}, into, lambda _: None, "", given, None
        )[0]
    return run_groups(
        groups, names, options, data, run_ctx, executor, {}, into, lambda _: None, fits
    )[0]


def _search_context(ctx: RunContext, scratch: str, label: str | None = None) -> RunContext:
    """``ctx`` for a second search: its own scratch directory ``scratch`` under the run's
    (the first search's long results, of fixed names, are still read), the detectors that
    cannot run skipped rather than an error, and its progress shown as ``label`` (default
    ``scratch``) before each stage."""
    own = None if ctx.workdir is None else ctx.workdir / scratch
    if own is not None:
        own.mkdir(exist_ok=True)
    run_ctx = replace(ctx, workdir=own, explicit=False)
    if ctx.progress is not None:
        shown, prefix = ctx.progress, f"{label or scratch} "
        run_ctx = replace(
            run_ctx, progress=lambda stage, done: shown(prefixed(prefix, stage), done)
        )
    return run_ctx


def _searched_after(
    stretch: Stretch,
    k: int,
    findings: list[Finding],
    ran: list[str],
    setup: tuple[RunOptions, Dataset, list[tuple[str, ...]], dict[str, Any]],
    ctx: RunContext,
    executor: Executor,
    work: Path | None,
    diagnose: Callable[[list[DetectorResult]], tuple[list[Finding], list[str]]],
) -> list[Finding]:
    """The detectors that ran (``ran``, one name per result) run again over the record
    with the models they fitted (``setup``: the options, the data, the channel groups and
    the fits by group), searching from ``stretch.search_row`` (the healthy window the
    same), and the findings of theirs that ``findings`` lack there
    (:func:`analyzer.search_after.found_after`), with their evidence (the tests of this
    search's residuals). ``k`` numbers the search (its scratch space)."""
    options, data, groups, fits = setup
    names = list(dict.fromkeys(ran))
    after = replace(data, search_from=stretch.search_row)
    # its own scratch: the first search's long results (fixed names) are still read
    run_ctx = _search_context(ctx, f"after{k}", "after")
    into = None if work is None else work / f"signals-after{k}"
    results = _run_again(names, options, after, groups, run_ctx, executor, into, fits)
    if not results:
        return []
    found, _ = diagnose(results)
    slack = LONG_FACTOR * default_window(data.rate_hz) / data.rate_hz
    added = found_after(found, findings, stretch, data.rate_hz, slack)
    attach_evidence(added, merge_groups(results, list(data.channels)), data.rate_hz, data.train)
    return added


GAP_SEARCH_ROWS = 1 << 16
"""Rows read at a time when a gap before a fault's onset is traced back to its start."""


def _after_gap_notes(
    findings: Sequence[Finding], values: Any, chosen: Sequence[str], rate_hz: float
) -> list[str]:
    """A note for each fault whose onset follows a gap in its channel's data within two
    long alarm windows: it may have begun in the gap, and its onset is where the data
    resumed (an offset from 205 s on a record missing 200-260 s was reported from
    260.78 s without a word; a folder of hourly files with one hour missing alike). A
    sensor that comes back from an outage with an offset is a common fault."""
    near = 2 * LONG_FACTOR * default_window(rate_hz)
    index = {c: j for j, c in enumerate(chosen)}
    out: list[str] = []
    for f in findings:
        j = index.get(f.channel)
        k = int(round(f.onset_s * rate_hz))
        if j is None or k <= 0:
            continue
        lo = max(0, k - near)
        missing = np.flatnonzero(~np.isfinite(np.asarray(values[lo:k, j], dtype=np.float64)))
        if not missing.size:
            continue
        end = lo + int(missing[-1]) + 1  # the first sample after the gap
        start = end - 1
        while start > 0:  # back to the gap's first sample, a block at a time
            a = max(0, start - GAP_SEARCH_ROWS)
            seen = np.flatnonzero(np.isfinite(np.asarray(values[a:start, j], dtype=np.float64)))
            if seen.size:
                start = a + int(seen[-1]) + 1
                break
            start = a
        late = f.onset_s - end / rate_hz
        f.evidence["after_gap_s"] = [json_time(start / rate_hz), json_time(end / rate_hz)]
        where = (
            "its onset is where the data resumed"
            if late <= 1.5 / rate_hz
            else f"found {late:.2f} s after the data resumed, while the detectors settle "
            "again after a gap: it may have been there from the resumption"
        )
        out.append(
            f"the {f.type.value} fault on {f.channel} found from {f.onset_s:.1f} s follows a "
            f"gap in its data ({start / rate_hz:.1f}-{end / rate_hz:.1f} s): it may have "
            f"begun during the gap ({where})"
        )
    return out


AR_DETECTORS = ("ar_kalman_bank", "detection_filter")
"""The detectors whose models remember an AR order's samples (:func:`_models_memory`)."""


def _slower_clock(
    aligned: AlignedSeries, chosen: Sequence[str], options: RunOptions, absolute: bool
) -> tuple[Oversampled | None, str | None]:
    """The slower clock a run aligns the channels at when their own (``aligned``'s) runs
    far above what they carry (:func:`~analyzer.diagnosis.oversampled.oversampled`, the
    note's measurement, over the first rows of the healthy window the run would take):
    only without ``--rate`` (any value, the logged rate too, keeps its clock) and
    ``--model`` (whose rate is the model's). None where the clock stays, or the window
    cannot be taken (the run then says why, at its own rate); beside it, the channel
    that clips where that alone kept the clock (:func:`_clips_as_logged`: the end-of-run
    note says so).

    The detectors' models remember a number of samples: at 2 kHz their 10 samples are
    5 ms of a building's 170-1000-ms periods, and a gain of 0.5 on a simulated 4-floor
    building was missed there (exit 0, an anomaly attributed to no sensor), found at
    200 Hz; of the 20 records ``benchmarks/sweep_oversampled.py`` noted, 19 were right
    at the rate the note named. Measured before the whole matrix is aligned, on the
    window's rows alone, so the record is aligned once, at the rate it is analyzed at."""
    if options.rate is not None or options.model is not None:
        return None, None
    try:
        _, (a, b) = _training_window(options, aligned, absolute, [])
    except AnalyzerError:
        return None, None
    if b - a < 2:
        return None, None
    # (the channels measured only: of many, a few dozen)
    picked = tuple(chosen[j] for j in measured_channels(len(chosen)))
    rows = replace(aligned, channels=picked).block(a, min(b, a + MOST_SAMPLES))
    rows[np.abs(rows) > UNREADABLE] = np.nan  # (as the matrix takes them: gaps)
    memory = _models_memory(options.config, detector_names(options)[0])
    found = oversampled(rows, picked, (0, b - a), aligned.rate_hz, memory)
    if found is None or not slowed_itself(found):
        return None, None
    clips = _clips_as_logged(aligned, chosen, (a, b))
    return (None, clips) if clips is not None else (found, None)


def _clips_as_logged(
    aligned: AlignedSeries, chosen: Sequence[str], train: tuple[int, int]
) -> str | None:
    """The first channel whose readings after the healthy window (rows ``train`` of
    ``aligned``) pile up at a limit as logged (a sensor that clips:
    :func:`~analyzer.diagnosis.clipping.find_clipping` on its raw samples): such a record
    keeps its clock. Clipping is read from exact repeats of the limit, which the low-pass
    before a slower clock smears: a 6-channel building at 200 Hz whose s2 clipped at
    half its peak from 72 s was one clipping finding at 200 Hz, a gain of 0.80 from
    105.7 s at the 100 Hz its content asked for. The raw samples of each channel once
    (only for a record that would be slowed)."""
    t0 = aligned.start_ns + int(round(train[0] / aligned.rate_hz * NS_PER_S))
    t1 = aligned.start_ns + int(round(train[1] / aligned.rate_hz * NS_PER_S))
    for name in chosen:
        if name in aligned.blank:
            continue
        t, v = aligned.store.raw(name)
        a, b = int(np.searchsorted(t, t0)), int(np.searchsorted(t, t1))
        if b < len(t) and find_clipping(v[:, None], 0, b, (a, b)) is not None:
            return name
    return None


def _models_memory(config: Config, ran: Collection[str]) -> int:
    """The most samples the run's AR models remember, for the note on a clock far above
    the sensors' content (:func:`~analyzer.diagnosis.oversampled.oversampled_note`): of
    the AR bank and the detection filter among those that ran (``ran``), the order its
    ``[detectors.NAME]`` section sets, or the highest its criterion searches
    (``max_order``, 10 unless set); the largest of them. The detection filter on the
    config's ``[model]`` has no AR order and does not count; without either detector,
    :data:`~analyzer.diagnosis.oversampled.MEMORY_SAMPLES` (the equivalent model's lags
    are a relation's FIR, chosen per sensor, not a memory the run sets as a whole)."""
    sizes = []
    for name in AR_DETECTORS:
        if name not in ran:
            continue
        det = detector_class(name)(**config.detectors.get(name, {}))
        if name == "detection_filter" and config.model is not None and det.use_config_model:
            continue  # a state-space model from the config, not an AR order
        sizes.append(det.order if isinstance(det.order, int) else det.max_order)
    return int(max(sizes, default=MEMORY_SAMPLES))


UNATTRIBUTED_LISTED = 3
"""Unattributed anomalies named one by one in the run's notes; the rest are counted."""


def _tied_to_seam(alarm: Unexplained, seam: Seam | None) -> Unexplained:
    """``alarm`` with the words of the seam between two files it begins at (where the
    tool dropped samples or left a file out, or a gap begins: :class:`~analyzer.readers.
    seams.Seam`), which explains the jump the detectors saw better than a second fault
    (ux62 MEDIUM 5: the seam's alarm was blamed on "a change of the structure or
    excitation"). It stays listed: a fault may begin there too."""
    return alarm if seam is None else replace(alarm, seam=seam.words)


def _unattributed_notes(
    results: Sequence[DetectorResult],
    findings: Sequence[Finding],
    rate_hz: float,
    seam_at: Callable[[float], Seam | None] = lambda _t: None,
) -> list[AnomalyNote]:
    """The run's notes on anomalies the detectors saw and attributed to no sensor
    (``DetectorResult.unattributed``), which only their own notes told before: two
    sensors faulty from the same instant on a 6-channel building gave no finding and
    exit 0, while all three detectors noted an anomaly they could not attribute.

    * a second fault beside a found one (the equivalent model's network: a fault on one
      of some sensors, with the one it named, explains the alarms);
    * an anomaly that two or more detectors left unattributed within one long alarm
      window of each other, with no finding under way then: several sensors at once,
      or a change of the structure or excitation; or, where it begins at a seam between
      two files that ``seam_at`` finds (samples dropped, a file left out, a gap), that
      seam's jump in the signal."""
    slack = LONG_FACTOR * default_window(rate_hz) / rate_hz
    out: list[AnomalyNote] = []
    reported = {f.channel for f in findings}
    seen: set[tuple[tuple[str, ...], tuple[str, ...]]] = set()
    for r in results:
        for onset, channels, beside in r.unattributed:
            if beside and (beside, channels) not in seen:
                seen.add((beside, channels))
                out.append(
                    AnomalyNote(_beside_words(r.detector, onset, beside, channels, reported))
                )

    def echo(t0: float, t1: float) -> bool:
        """A finding begins or ends with the anomaly: the anomaly is its doing."""
        return echoes(findings, t0, t1, slack)

    missed = missed_clusters(results, findings, slack)
    for c in missed[:UNATTRIBUTED_LISTED]:
        names = sorted({ch for _, _, chs in c for ch in chs})
        detectors = sorted({d for _, d, _ in c})
        during = lasting(findings, c[0][0], c[-1][0], slack)
        lasted = (
            " (while the "
            + ", ".join(
                f"{f.type.value} fault on {f.channel} from {f.onset_s:.1f} s" for f in during
            )
            + " lasted: it may be a second fault, or that one's doing)"
            if during
            else ""
        )
        seam = seam_at(c[0][0])
        cause = (
            "several sensors at once, or a change of the structure or excitation"
            if seam is None
            else f"at {seam.words}: the jump where the files were joined, more likely than "
            "the sensors (the input errors say more)"
        )
        out.append(
            AnomalyNote.at(
                f"anomaly at {c[0][0]:.1f} s on {', '.join(names)} attributed to no sensor by "
                f"{', '.join(detectors)}: {cause}{lasted} (the detectors' notes say more)",
                c[0][0],
                tuple(names),
            )
        )
    if len(missed) > UNATTRIBUTED_LISTED:
        more = len(missed) - UNATTRIBUTED_LISTED
        out.append(AnomalyNote.counting(f"{more} more such anomalies (detectors' notes)", more))
    # alarms a blind residual leaves undecided: one detector's, but its peers had lost
    # their view too (a channel gone missing): said at the run's level, once per sensors
    # (a 5 sd offset on s0 beside a channel missing from 200 s: exit 0, nothing said)
    said: list[tuple[float, tuple[str, ...], tuple[str, ...]]] = []
    for r in results:
        for onset, alarming, blind in r.undecided:
            if echo(onset, onset) or any(
                a == alarming and b == blind and abs(onset - t) <= slack for t, a, b in said
            ):
                continue
            said.append((onset, alarming, blind))
            if len(said) <= UNATTRIBUTED_LISTED:
                out.append(
                    AnomalyNote.at(
                        f"anomaly at {onset:.1f} s on {', '.join(alarming)} attributed to no "
                        f"sensor by {r.detector}: a fault on {', '.join(alarming)} or on "
                        f"{' or '.join(blind)} explains it, and the residuals of "
                        f"{', '.join(blind)} have no data there (a channel they are modelled from "
                        "is missing)",
                        onset,
                        tuple(alarming),
                    )
                )
    if len(said) > UNATTRIBUTED_LISTED:
        more = len(said) - UNATTRIBUTED_LISTED
        out.append(AnomalyNote.counting(f"{more} more such anomalies (detectors' notes)", more))
    return out


def _beside_words(
    detector: str,
    onset: float,
    beside: Sequence[str],
    channels: Sequence[str],
    reported: Collection[str],
) -> str:
    """The note on a second fault a detector's sensor network places beside another:
    "beside the fault on X" where X is a finding; where X is none (the run did not report
    it: the note named a fault the user could not find in findings.json, the ux55
    audit), the two are said as one anomaly neither of whose faults is reported."""
    if all(b in reported for b in beside):
        return (
            f"{detector}: beside the fault on {', '.join(beside)} at {onset:.1f} s, "
            f"a fault on one of {', '.join(channels)} explains its alarms (not "
            "reported: its sensor network cannot tell which)"
        )
    return (
        f"{detector}: anomaly at {onset:.1f} s that a fault on {', '.join(beside)} together "
        f"with one on one of {', '.join(channels)} would explain; neither is a finding of "
        "this run (the first was not confirmed, and its sensor network cannot tell which "
        "of the others)"
    )


WEAK_CONFIDENCE = 0.05
"""A finding below this confidence is named in a note: its alarm is about as likely a
chance peak of healthy data as a fault."""
LENIENT_RATE = 1e-4
"""A false-alarm rate above this (per sample) is named as the likely cause of weak findings."""


def _weak_findings_note(findings: Sequence[Finding], false_alarm_rate: float) -> list[str]:
    """A note naming the findings of confidence below :data:`WEAK_CONFIDENCE`: a fault
    shape that explains little, or an alarm no larger than healthy data of the record's
    length shows by chance (at a ``false_alarm_rate`` of 1e-2 per sample: findings of
    confidence 0.0, reported without a word before this note)."""
    weak = [f for f in findings if f.confidence < WEAK_CONFIDENCE]
    if not weak:
        return []
    named = ", ".join(f"{f.channel} at {f.onset_s:.1f} s" for f in weak[:5])
    more = f" and {len(weak) - 5} more" if len(weak) > 5 else ""
    why = (
        f"; a false-alarm rate of {false_alarm_rate:g} per sample reports healthy data's "
        "chance peaks too"
        if false_alarm_rate > LENIENT_RATE
        else ""
    )
    return [
        f"{len(weak)} of {len(findings)} findings {'has' if len(weak) == 1 else 'have'} a "
        f"confidence below {WEAK_CONFIDENCE} "
        f"({named}{more}): weak evidence, each about as likely no fault{why}"
    ]


def _at_rest(
    train: tuple[int, int], reused: SavedModel | None
) -> tuple[tuple[int, int] | None, tuple[str, ...] | None]:
    """What the frozen checks know of the channels that read zero when healthy: the
    training rows of a plain run, or, with ``--model`` (no training rows of its own), the
    channels its model saved as reading zero at rest (None: a model saved before)."""
    if reused is None:
        return train, None
    return None, reused.zero_at_rest


def _diagnose(
    results: list[DetectorResult],
    values: Any,
    chosen: list[str],
    rate_hz: float,
    healthy: dict[str, Any],
    train: tuple[int, int],
    reused: SavedModel | None,
    excitation: frozenset[str] = frozenset(),
) -> tuple[list[Finding], list[str]]:
    """The findings of the detectors' results and the notes that go with them: one finding
    per fault, one fault at a time among the sensors a detector models together (as the
    seed methods isolate them), a frozen sensor told by its readings rather than by the
    residual's shape, a lone equivalent-model fault that the sensor's reading residuals
    do not carry refused (:mod:`analyzer.diagnosis.readings`; with ``--model``, by the
    residuals' healthy statistics saved with the model), and
    (``--model``) the faults already there when the search began.
    The channels the config names as measured inputs (``excitation``: a force, a ground
    acceleration) are not sensors under test: what a detector that models them as
    channels (the bank, an AR detection filter) saw on them is a note, not a finding.
    Reads the results' events without changing them."""
    notes: list[str] = []
    findings = merge_events(ev for r in results for ev in r.events)
    # the measured inputs' findings are notes; what they explain is their echo in the
    # sensors (below), not the sensors' faults for as long as they last
    on_inputs = [f for f in findings if f.channel in excitation]
    for f in on_inputs:
        more = len({e.detector for e in f.events}) - 1
        notes.append(
            f"{f.channel} is a measured input (excitation) in the config, not a sensor under "
            f"test: the {f.type.value} anomaly {f.detector} saw on it from {f.onset_s:.1f} s"
            + (f" (with {more} more detector(s))" if more > 0 else "")
            + " is not reported as a sensor fault"
        )
    findings, echoes = _input_echoes(
        [f for f in findings if f.channel not in excitation], on_inputs, rate_hz
    )
    notes.extend(echoes)
    # a sensor that clips: its swarm of short faults is one, before one fault at a time
    groups = [r.channels for r in results]
    findings, clipped = merge_clipped(findings, values, chosen, rate_hz, train, groups)
    notes.extend(clipped)
    if reused is None:  # a slow change of most sensors at once: no one sensor's fault
        findings, common = common_changes(findings, values, chosen, groups, train, rate_hz)
        notes.extend(common)
    # a frozen sensor's fault from where it froze, before one fault at a time weighs
    # which fault was under way when (a dead sensor's first alarms can come seconds late)
    # (the notes of those it keeps: a finding taken for another's fault has none)
    own, zeros = _at_rest(train, reused)
    frozen = frozen_notes(findings, values, chosen, rate_hz, healthy, train[1], own, zeros)
    # a lone equivalent-model fault that the residuals taking its sensor's reading in do
    # not carry: the relation's error under a change of the response, not the reading's
    # (--model: with the residuals' healthy statistics saved with the model; none in a
    # model saved before they were, and then not judged)
    health = None if reused is None else reused.reading_health
    if health is None or health:
        findings, refuted = refuted_by_readings(
            findings, results, values, chosen, train, rate_hz, health
        )
        notes.extend(refuted)
    findings.sort(key=lambda f: (f.onset_s, f.channel))
    findings, conflicts = one_fault_at_a_time(findings, coupled(results))
    notes.extend(conflicts)
    notes.extend(frozen[id(f)] for f in findings if id(f) in frozen)
    # a dead spell again after a revival, inside the anomaly the detectors saw as one
    again, told = dead_again(findings, results, values, chosen, rate_hz, healthy, own, zeros)
    findings = sorted([*findings, *again], key=lambda f: (f.onset_s, f.channel))
    notes.extend(told)
    # a gain after a dead spell: the finding the dead sensor's cut short goes on
    revived, said = revived_gains(findings, results, rate_hz, np.shape(values)[0])
    findings = sorted([*findings, *revived], key=lambda f: (f.onset_s, f.channel))
    notes.extend(said)
    notes.extend(traced_into_training(findings, reused is not None))
    if reused is not None:
        notes.extend(present_at_search_start(findings, train[1] / rate_hz, rate_hz))
    else:
        at_search_start(findings, train[1] / rate_hz, rate_hz)
    return findings, notes


def at_search_start(findings: list[Finding], start_s: float, rate_hz: float) -> None:
    """Mark the findings whose onset is the first sample searched (``start_s``, the
    training window's end; to within 1.5 samples) with ``evidence.onset_at_search_start``:
    the fault was there when the search began, so it began at or before then, perhaps
    inside the training window (SKAB's pump: an onset at 719.000 s, the first sample
    after ``--train 0:718``, of a change the run's own note put at 581 s). Stated as the
    onset it read as a fact ("since 17:39:18"). With ``--model`` the search starts after
    the filters' warm-up instead, and ``onset_at_or_before`` says it
    (:func:`~analyzer.diagnosis.merge.present_at_search_start`)."""
    for f in findings:  # (an onset traced back into the window is where it was traced)
        if start_s - 0.5 / rate_hz <= f.onset_s <= start_s + 1.5 / rate_hz:
            f.evidence["onset_at_search_start"] = True


ECHO_WINDOWS = 4
"""How soon after a measured input's anomaly (in long alarm windows: 8 s at 100 Hz) a
sensor's finding begins for :func:`_input_echoes` to take it for its echo."""


def _input_echoes(
    findings: list[Finding], on_inputs: list[Finding], rate_hz: float
) -> tuple[list[Finding], list[str]]:
    """``findings`` less those that begin with an anomaly of a measured input (within
    :data:`ECHO_WINDOWS` long alarm windows of its onset), and a note for each.

    A measured input is a regressor of every model that has it (the bank's AR, the
    detection filter's ``B u``, the equivalent model's relations, the error functions):
    an offset on it moves every residual that takes it in, from its own onset (an offset
    on a measured ground acceleration was reported as an offset on a healthy sensor 3.4 s
    later). A sensor's fault that begins later, while the input's anomaly lasts, is its
    own: taking every such fault for the input's hid a drift and a gain that began 30 s
    into an input's offset (exit 0)."""
    if not on_inputs:
        return findings, []
    near = ECHO_WINDOWS * LONG_FACTOR * default_window(rate_hz) / rate_hz
    kept: list[Finding] = []
    notes: list[str] = []
    for f in findings:
        # (either side: a drift's onset is traced back from its line, an echo's a little
        # further or less far than the input's own: 0.6 s before it at 0.05 per s)
        cause = next((g for g in on_inputs if abs(f.onset_s - g.onset_s) <= near), None)
        if cause is None:
            kept.append(f)
            continue
        notes.append(
            f"{f.detector}'s {f.type.value} fault on {f.channel} at {seconds_text(f.onset_s)} s "
            f"not reported: it began {f.onset_s - cause.onset_s:+.1f} s from the "
            f"{cause.type.value} anomaly on the measured input {cause.channel} "
            f"({seconds_text(cause.onset_s)} s), which reaches every residual that takes the input "
            "in: taken for its echo"
        )
    return kept, notes


def _screened(
    screen: list[str],
    names: list[str],
    groups: Sequence[tuple[str, ...]],
    detect: Callable[[list[str], str, str], _Outcome],
    diagnose: Callable[[list[DetectorResult]], tuple[list[Finding], list[str]]],
    tests: list[Any],
) -> tuple[list[DetectorResult], dict[str, str], dict[str, Any], str]:
    """``--screen``: the screening's detectors run first on the archive; when their
    results hold no finding they are the analysis, else the other detectors run too and
    the analysis is every detector's, the plain run's (each detector's fit and run do not
    depend on which others run: the screening's results are kept, not computed again).
    Screening detectors that cannot run (skipped, or a :class:`DetectorError` when the
    user named the detectors) leave the archive to every detector, with their reason.
    Returns the results and skip reasons in the plain run's order, ``findings.json``'s
    ``screen``, and the note that says what happened."""

    def note(why: str) -> str:
        return f"screened with {', '.join(screen)} alone (--screen): {why}"

    first = [n for n in names if n in screen]
    verdict: dict[str, Any] = {"detectors": list(screen), "fault": True}
    try:
        results, skipped = detect(first, "screen ", "signals")
    except DetectorError as err:  # a named detector's error: the plain run's decides
        verdict.update(fault=None, error=one_line(err))
        # the screening's tests and signals go with its results (its files are left to
        # any test still reading them: the full run's go elsewhere)
        _cancel(tests)
        tests.clear()
        results, skipped = detect(names, "", "signals-all")
        why = f"they could not run ({verdict['error']}), so analyzed with every detector"
        return results, skipped, verdict, note(why)
    failed = {k: v for k, v in skipped.items() if k.split(" (", 1)[0] in first}
    if failed:
        verdict.update(fault=None, error="; ".join(skip_reasons(failed)))
        why = f"they could not run ({verdict['error']}), so analyzed with every detector"
    elif not diagnose(results)[0]:
        verdict["fault"] = False
        return results, skipped, verdict, note("no fault, so the other detectors did not run")
    else:
        why = "a fault, so every other detector ran too; these findings are every detector's"
    more, more_skipped = detect([n for n in names if n not in screen], "", "signals")
    rank = {n: i for i, n in enumerate(names)}
    results = sorted(results + more, key=lambda r: rank[r.detector])
    # skip reasons as the plain run lists them: the whole-archive ones, then group by group
    where = {f"{g[0]}..{g[-1]}": k for k, g in enumerate(groups)}

    def order(key: str) -> tuple[int, int]:
        name, _, group = key.partition(" (")
        return where.get(group.rstrip(")"), -1), rank.get(name, len(rank))

    skipped = dict(sorted({**skipped, **more_skipped}.items(), key=lambda kv: order(kv[0])))
    return results, skipped, verdict, note(why)


def _training_window(
    options: RunOptions, aligned: AlignedSeries, absolute: bool, notes: list[str]
) -> tuple[tuple[float, float], tuple[int, int]]:
    """The healthy window, in seconds and as rows ``[a, b)`` of the aligned matrix: with
    ``--model`` the warm-up in which the filters settle (no fault is searched there, the
    rest is tested whole; nothing is fitted), else ``--train``, the config's ``[train]``,
    or the default (the first 20 % of the data, at most 10 minutes)."""
    reused = options.model
    duration = aligned.duration_s
    if reused is not None:
        # no fit here: the first samples only let the filters settle (no fault is
        # searched there), the rest is tested whole
        wanted = warmup(reused)
        warm = max(1, min(wanted, aligned.n // 2))
        tr = (0.0, (warm - 1) / aligned.rate_hz)
        if warm < wanted:
            notes.append(
                f"the model's filters need {spoken_duration(wanted / aligned.rate_hz)} to "
                "settle from "
                f"their zero start state, longer than half this record: the fault search "
                f"starts at {short_seconds(warm / aligned.rate_hz)} s, and a finding there may be "
                "the filters still settling (a longer file, or one that follows on, "
                "tells)"
            )
    elif options.train is not None:
        tr = parse_train(options.train, aligned.start_ns, duration, absolute, notes)
    elif options.config.train is not None:
        tr = options.config.train
        if tr[0] >= duration:
            raise ShortConfigError(
                f"{options.config.path}: [train] the window {tr[0]:g}-{tr[1]:g} s starts "
                f"after the data ends ({seconds_text(duration)} s)"
            )
        tr = (tr[0], min(tr[1], duration))
    else:
        tr = default_train(duration)
    # (the rows inside the window asked for: the nearest row could lie before its start)
    train = rows_within(tr[0], tr[1], aligned.rate_hz)
    if reused is None and train[0] > 0:
        notes.append(
            f"the {short_seconds(tr[0])} s before the training window are not searched for "
            "faults (the "
            "search runs from the window's end): a window at the start covers them"
        )
    if reused is None and train[1] >= aligned.n and options.save_model is not None:
        # fitting a model on a healthy record, whole, for later archives (--model)
        notes.append(
            "the training window reaches the end of the data: nothing is left to search "
            "for faults (the models fitted on it are saved with --save-model)"
        )
    elif reused is None and train[1] >= aligned.n:
        # the search runs from the window's end: a window over all the data leaves
        # nothing to search, and "no fault found" (exit 0) would be a claim not made
        # (unless the run is there to save the models fitted on it, above)
        # a window that starts later covers the end only: it is what comes after it
        # that is missing ('800:900' of an 889-s bag "covered all the data")
        covers = (
            f"covers all the data (which ends at {seconds_text(duration)} s): nothing is left to "
            "search"
            if train[0] <= 0
            else f"reaches the end of the data (which ends at {seconds_text(duration)} s): it "
            "leaves nothing after it to search"
        )
        if options.train is not None:
            raise ShortUsageError(
                f"--train: the window {options.train!r} {covers} for faults; end it earlier"
            )
        raise ShortConfigError(
            f"{options.config.path}: [train] the window {tr[0]:g}-"
            f"{(options.config.train or tr)[1]:g} s {covers} for faults; end it earlier"
        )
    return tr, (train[0], min(train[1], aligned.n))


MOSTLY_ONE_VALUE = 0.99
"""Share of a channel's finite training samples at one value (its median) from which it
is taken as constant there: a sensor stuck, or at rest, through the healthy window but
for a few samples carries nothing to model, and those few make the detectors' regressions
singular (the whole detector was then skipped, and a fault on another sensor missed)."""


MEDIAN_ROWS = 1 << 16
"""Rows, evenly spaced, whose median stands for a long training window's (a value held in
99 % of the window is the median of any such sample of it)."""


def _mostly_one_value(tv: Any) -> npt.NDArray[np.bool_]:
    """Columns of the training rows ``tv`` whose finite samples sit at one value (their
    median) in at least :data:`MOSTLY_ONE_VALUE` of the rows; counted a block of rows at
    a time (a day-long window is not copied)."""
    n = tv.shape[0]
    sample = np.asarray(tv[:: max(1, n // MEDIAN_ROWS)], dtype=np.float64)
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an empty column's median: NaN
        median = np.nanmedian(sample, axis=0)
    count = np.zeros(tv.shape[1], dtype=np.int64)
    at = np.zeros(tv.shape[1], dtype=np.int64)
    for _, block in row_blocks(tv):
        rows = np.asarray(block)
        count += np.isfinite(rows).sum(axis=0)
        at += (rows == median).sum(axis=0)
    return np.asarray((count > 0) & (at >= MOSTLY_ONE_VALUE * count), dtype=bool)


FEW_VALUES = 4
"""A varying channel with at most this many distinct values among its training samples
is named in a note (a healthy sensor quantized to 3 levels got findings)."""


def _few_values(tv: Any) -> npt.NDArray[np.bool_]:
    """Columns of the training rows ``tv`` with at most :data:`FEW_VALUES` distinct
    finite values, from at most :data:`MEDIAN_ROWS` rows spread over the window (a
    sample: a value the sample misses does not change a coarse channel's verdict)."""
    n = tv.shape[0]
    sample = np.asarray(tv[:: max(1, n // MEDIAN_ROWS)], dtype=np.float64)
    out = np.zeros(sample.shape[1], dtype=bool)
    for j in range(sample.shape[1]):  # per channel, on a bounded sample
        col = sample[:, j]
        col = col[np.isfinite(col)]
        out[j] = col.size >= 100 and np.unique(col).size <= FEW_VALUES
    return out


COUNTER_SPREAD = 0.05
"""A channel whose every step between consecutive training samples lies within this share
of its mean step (non-zero) is a counter or a clock, not a sensor: a sensor's noise makes
its steps differ by far more."""


def _counters(tv: Any) -> npt.NDArray[np.bool_]:
    """Columns of the training rows ``tv`` that step by the same non-zero amount from
    each sample to the next (within :data:`COUNTER_SPREAD`; steps across a gap are not
    counted): a row counter, a second clock (``Elapsed Time`` beside ``time``), a pandas
    index written as a column. Taken a block of rows at a time."""
    m = tv.shape[1]
    lo = np.full(m, np.inf)
    hi = np.full(m, -np.inf)
    last: npt.NDArray[np.float64] | None = None
    with np.errstate(all="ignore"):
        for _, block in row_blocks(tv):
            rows = np.asarray(block, dtype=np.float64)
            if last is not None:
                rows = np.vstack([last, rows])
            steps = np.diff(rows, axis=0)
            if steps.shape[0]:
                lo = np.fmin(lo, np.nanmin(np.where(np.isfinite(steps), steps, np.inf), axis=0))
                hi = np.fmax(hi, np.nanmax(np.where(np.isfinite(steps), steps, -np.inf), axis=0))
            last = rows[-1:]
        mean = 0.5 * (lo + hi)
        counter = (
            np.isfinite(lo)
            & np.isfinite(hi)
            & (np.sign(lo) == np.sign(hi))
            & (lo != 0.0)
            & (hi - lo <= COUNTER_SPREAD * np.abs(mean))
        )
    return np.asarray(counter, dtype=bool)


def _varying_in_training(
    values: Any,
    chosen: list[str],
    train: tuple[int, int],
    tr: tuple[float, float],
    rate_hz: float,
    options: RunOptions,
    notes: list[str],
) -> tuple[Any, list[str]]:
    """``values`` and ``chosen`` without the channels that do not vary in the healthy
    window (they cannot be modelled from it; a note names them). A usage error when the
    window is too short to calibrate anything or no channel is left. With ``--model``
    every channel stays: the model's channels were modelled on its own window."""
    if options.model is not None:
        return values, chosen
    if not options.detectors:  # (detectors named with --detectors say it themselves)
        lone_channel(chosen, notes)
    tv = np.asarray(values[train[0] : train[1]])
    if tv.shape[0] < MIN_TRAIN_ROWS:
        raise ShortUsageError(
            f"the training window {seconds_text(tr[0])}-{seconds_text(tr[1])} s holds "
            f"{tv.shape[0]} sample(s) "
            f"at {plain_number(rate_hz)} Hz, need at least {MIN_TRAIN_ROWS}: give a longer "
            "one with --train (the default is the first 20 % of the data, at most 10 min)"
        )
    flat = flat_channels(tv) | _mostly_one_value(tv)
    counters = _counters(tv) & ~flat
    coarse = _few_values(tv) & ~flat & ~counters
    if coarse.any():
        notes.append(
            f"at most {FEW_VALUES} distinct values in the training window (a coarse "
            "quantization step, larger than the noise): the models see mostly its "
            "rounding, and a finding on it may be rounding: "
            + ", ".join(c for c, f in zip(chosen, coarse, strict=True) if f)
        )
    if not flat.any() and not counters.any():
        return values, chosen
    # (a channel with no sample there is not dead: its data lie elsewhere)
    empty = ~np.isfinite(tv).any(axis=0) if tv.size else np.ones(len(chosen), dtype=bool)
    missing = [c for c, f in zip(chosen, flat & empty, strict=True) if f]
    if missing:
        notes.append(NoSamplesNote.of(missing, tr))
    dropped = [c for c, f, e in zip(chosen, flat, empty, strict=True) if f and not e]
    if dropped:
        notes.append(_window_constant_note(dropped, tr))
    if counters.any():
        # a ramp made the bank's and the detection filter's regressions singular (both
        # skipped) and the equivalent model reported it as a drift
        ramps = [c for c, f in zip(chosen, counters, strict=True) if f]
        notes.append(
            CounterNote(
                "a counter or clock in the training window (the same step from each sample "
                "to the next), not analyzed: " + ", ".join(ramps),
                ramps,
            )
        )
    flat = flat | counters
    keep = np.flatnonzero(~flat)
    if keep.size == 0:
        how = (
            "--train"
            if options.train is not None
            else "[train] in the config"
            if options.config.train is not None
            else "--train (default: the first 20 % of the data)"
        )
        raise ArchiveUsageError(
            "every selected channel is constant or empty in the training window "
            f"({seconds_text(tr[0])}-{seconds_text(tr[1])} s): choose another window with {how}"
        )
    return np.asarray(values)[:, keep], [chosen[k] for k in keep]


def _window_constant_note(dropped: Sequence[str], tr: tuple[float, float]) -> WindowConstantNote:
    """The note on the channels ``dropped`` as not varying in the training window ``tr``
    (seconds) although they vary over the record (a channel constant over the whole
    record was left out before): repeated on stderr, for it was a note only (a sensor
    dead at the start, then alive, and exit 0 "no sensor fault found": a new user's
    audit), saying the window and that a ``--train`` where they vary analyzes them."""
    names = capped(list(dropped), SIBLINGS_LISTED, what="channels")
    one = len(dropped) == 1
    note = WindowConstantNote(
        "constant (or one value in 99 % of the samples) in the training window, not "
        "analyzed: " + ", ".join(dropped),
        f"{names} {'reads' if one else 'read'} one value in the training window "
        f"{seconds_text(tr[0])}-{seconds_text(tr[1])} s but {'varies' if one else 'vary'} later: "
        "not analyzed; a --train where "
        f"{'it varies analyzes it' if one else 'they vary analyzes them'}",
    )
    note.names = tuple(dropped)
    return note


COARSE_CLOCK = re.compile(r"(\d+) of (\d+) rows? gives? a channel a second value at the same time")
"""The CSV reader's line on rows collapsed onto one time (how many, of how many)."""

GAPPY_SHARE = 0.05
"""A channel missing more than this share of the training window's samples, beside
channels missing hardly any, is named when no detector could run."""


def _apart_in_training(
    values: Any, chosen: Sequence[str], train: tuple[int, int], rate_hz: float
) -> str:
    """A hint when the channels are each present in the training window but hardly ever
    together (fewer than :data:`MIN_TRAIN_ROWS` rows hold them all): a channel that
    stops before the others start; or when some channels miss samples there (more than
    :data:`GAPPY_SHARE`) and others hardly any: scattered losses (a wireless sensor's
    dropped packets, 20 % of s2's) left too few complete stretches, and the run said the
    window was too short (a longer one left fewer). Empty otherwise."""
    m = len(chosen)
    present = np.zeros(m, dtype=np.int64)
    first = np.full(m, -1, dtype=np.int64)
    last = np.full(m, -1, dtype=np.int64)
    together = 0
    for a, block in row_blocks(values[train[0] : train[1]]):
        ok = np.isfinite(np.asarray(block, dtype=np.float64))
        present += ok.sum(axis=0)
        together += int(ok.all(axis=1).sum())
        for j in np.flatnonzero(ok.any(axis=0)):
            rows = np.flatnonzero(ok[:, j])
            if first[j] < 0:
                first[j] = a + rows[0]
            last[j] = a + rows[-1]
    missing = 1.0 - present / max(1, train[1] - train[0])
    gappy = [c for j, c in enumerate(chosen) if missing[j] > GAPPY_SHARE]
    if gappy and missing.min() <= GAPPY_SHARE / 5 and len(gappy) < m:
        # scattered losses: rows hold the channel, but few stretches hold its lags
        shares = capped(
            [f"{c} {100 * missing[j]:.0f} %" for j, c in enumerate(chosen) if c in gappy]
        )
        leave = "'" + ",".join(f"!{c}" for c in gappy[:LISTED]) + "'"
        if len(gappy) > LISTED:
            leave = f"({leave} and {len(gappy) - LISTED} more)"
        return (
            f"; channels with samples missing in the training window ({shares}) leave the "
            f"models too few complete stretches: leave them out with --channels {leave} "
            "or choose a --train where they are complete"
        )
    if together >= MIN_TRAIN_ROWS or (present < MIN_TRAIN_ROWS).any():
        return ""
    t0 = train[0]
    spans = capped(
        [
            f"{c} {(t0 + first[j]) / rate_hz:.1f}-{(t0 + last[j] + 1) / rate_hz:.1f} s"
            for j, c in enumerate(chosen)
        ]
    )
    return (
        f"; in the training window only {together} row(s) hold every channel ({spans}): "
        "choose channels recorded at the same time (--channels) or a --train where they are"
    )


CONFIG_NEED = "in the config"
"""Words of a detector's reason for not running that a config file answers (the error
function's ``needs [[group]] reference/uncertain sensors in the config``), not the data:
such reasons come last in :func:`_no_detector_error`'s line."""


def _no_detector_error(
    skipped: dict[str, str],
    tr: tuple[float, float],
    options: RunOptions,
    apart: str = "",
    slow: str = "",
    clock: tuple[float, float] | None = None,
    named: bool = False,
    held: npt.NDArray[np.int64] | None = None,
    crosses: ChangeInside | None = None,
) -> DetectorError:
    """The error when no detector could run: each one's reason, after a hint when the
    healthy window is too short for them (``slow``: the common clock is slower than some
    channels, :func:`_slow_clock`), or when its channels are hardly ever present together
    (``apart``: :func:`_apart_in_training`; after the reasons when one of them is a
    singular regression, whose dependence says more). The hint comes first, and reasons
    a config answers (:data:`CONFIG_NEED`) last: the CLI cuts a long line
    (:func:`analyzer.errors.clipped_line`), and ``tilt_laser.bag``'s 1.1-kB line put the
    error function's wish for a ``[[group]]`` first and the hint that fixes the run
    (``--rate 43.2``) last. With ``clock`` (the rate and the archive's duration) a
    window too short says how long one would do (:func:`_longer_window`). ``named``:
    the detectors of ``skipped`` were named with ``--detectors`` and each must run, so
    the window is the one for all of them, and the line begins with their names.
    ``held``: the rows holding every channel (:func:`_held_rows`), for the window's end;
    ``crosses``: the change a suggested window would hold (:func:`_change_inside`)."""
    # the reasons the data can change first, those that need a config last (the line
    # is cut at errors.LINE_MOST: the cut takes the least useful)
    why = "; ".join(sorted(skip_reasons(skipped), key=lambda r: CONFIG_NEED in r))
    if apart and "singular" in why:  # (the dependence it names says more)
        return DetectorError(f"no detector could run ({why}){apart}")
    if apart:
        return DetectorError(f"no detector could run: {apart.removeprefix('; ')} ({why})")
    failed = "no detector could run"
    if named:
        names = list(dict.fromkeys(k.split(" (", 1)[0] for k in skipped))
        failed = f"{', '.join(names)} could not run"
    if "too little healthy data" in why:
        longer = (
            ""
            if clock is None
            else _longer_window(skipped, tr, *clock, every=named, held=held, crosses=crosses)
        )
        hint = (
            f"the training window {seconds_text(tr[0])}-{seconds_text(tr[1])} s is too short for "
            "these detectors: "
            + (longer or "give a longer healthy stretch with --train START:END")
            + (
                " (the default is the first 20 % of the data, at most 10 min)"
                if options.train is None and options.config.train is None
                else ""
            )
            + slow
        )
        if longer.startswith("the archive"):  # (no window of it is long enough)
            hint = longer + slow
        return ShortDetectorError(f"{failed}: {hint} ({why})")
    return DetectorError(f"{failed} ({why})")


def _held_rows(values: Any) -> npt.NDArray[np.int64]:
    """``held[i]``: how many of the archive's first ``i`` rows hold a sample of every
    analyzed channel (``len(values) + 1`` counts, block by block)."""
    counts = [np.zeros(1, dtype=np.int64)]
    total = 0
    for _, block in row_blocks(values):
        ok = np.isfinite(np.asarray(block, dtype=np.float64)).all(axis=1)
        counts.append(total + np.cumsum(ok, dtype=np.int64))
        total = int(counts[-1][-1]) if counts[-1].size else total
    return np.concatenate(counts)


WINDOW_MARGIN = 1.05
"""How much longer than the least a detector's "too little healthy data" asks for the
training window :func:`_longer_window` suggests: a longer window can let an order or lag
criterion choose a larger model, which needs a little more (the filters' settling is in
the need already: :func:`analyzer.detector_runs.skip_reason`)."""


def _window_need(
    results: Sequence[DetectorResult], rate_hz: float, values: Any
) -> WindowNeed | None:
    """What a training window must hold for each detector of ``results`` to run again
    (:class:`~analyzer.diagnosis.training_check.WindowNeed`), from their fits, not
    another fit: the rows that leave their thresholds' calibration enough of the
    residual at their ``window`` (:func:`~analyzer.diagnosis.changes.training_need`, the
    need that stopped the SKAB pumps' and the cart-pole's default windows, and always
    the model fits' at 1 Hz), :data:`WINDOW_MARGIN` more, as :func:`_longer_window`
    asks of a window too short. None when no detector says its window."""
    windows = [r.params.get("window") for r in results]
    known = [int(w) for w in windows if isinstance(w, (int, np.integer)) and w > 0]
    if not known:
        return None
    rows = math.ceil(max(training_need(w) for w in known) * WINDOW_MARGIN)
    return WindowNeed(rows, rate_hz, _held_rows(values))


ChangeInside = Callable[[float, float], WindowChange | None]
"""The first change of a sensor inside a window (its start and end in seconds) that
the healthy window's own check sees (:func:`_change_inside`), None when it sees none."""


def _change_inside(
    values: Any, channels: Sequence[str], groups: Sequence[Sequence[str]], rate_hz: float
) -> ChangeInside:
    """The check of the healthy window (:func:`~analyzer.diagnosis.training_check.
    check_training`) for a window the run would suggest: a SKAB pump's labelled record
    was told ``give --train 0:718`` while its anomaly began at 600 s, and the run with
    that window fitted the anomaly as healthy (no fault found). The window is checked,
    and so is the stretch from its start twice as long (the record's end at most): a
    change near the window's end has too little after it inside the window for the
    test to see it, and the longer stretch gives it as much after it as before. The
    earliest change before the window's end is returned. The two checks are each at half
    the healthy window's level (:data:`~analyzer.diagnosis.training_check.ALPHA`,
    Bonferroni): a healthy record is refused with at most the probability that its
    window is said not steady (a simulated 3-floor building at 1 Hz, healthy, had a
    change "seen" at |t| 7.97 against the bound 7.95 of one check at the full level, and
    its run was refused). Run only where the run stops
    for a window too short: its cost is the check's on twice the window, less than
    the detectors' fits on the window itself."""

    def inside(start: float, end: float) -> WindowChange | None:
        a = max(0, round(start * rate_hz))
        b = min(len(values), round(end * rate_hz) + 1)
        longer = b < len(values)  # (the window and as much again after it)
        alpha = ALPHA / 2 if longer else ALPHA  # (two checks: each at half the level)
        seen = check_training(values[a:b], channels, groups, rate_hz, a / rate_hz, alpha=alpha)
        if longer:
            stretch = values[a : min(len(values), 2 * b - a)]
            seen += check_training(stretch, channels, groups, rate_hz, a / rate_hz, alpha=alpha)
        before = [c for c in seen if c.at_s < end]
        return min(before, key=lambda c: c.at_s, default=None)

    return inside


def _too_short_before(change: WindowChange, start: float, end: float, need: str) -> str:
    """The line for a record whose suggested window (``start .. end`` s, holding
    ``need``) crosses ``change``: the run would fit it as healthy. It starts with "the
    archive" (:func:`_no_detector_error` puts it first, in place of the hint)."""
    who, what = change_words(change)
    said = f" ({' and '.join(what)})" if what else ""
    return (
        "the archive is too short before its first change to train on (fit the models on a "
        "healthy recording of the same system with --save-model and analyze this one with "
        f"--model): {who} changes at about {short_seconds(change.at_s)} s{said}, inside "
        f"--train {window_text(start, end)}, the window these detectors need ({need})"
    )


def _longer_window(
    skipped: Mapping[str, str],
    tr: tuple[float, float],
    rate_hz: float,
    duration_s: float,
    every: bool = False,
    held: npt.NDArray[np.int64] | None = None,
    crosses: ChangeInside | None = None,
) -> str:
    """The ``--train`` that lets at least one detector run (``every``: each of them, the
    detectors the user named), from the window's start ``tr[0]``: the fewest (most)
    training rows a detector that had too little healthy data would need
    (:class:`analyzer.detector_runs.SkipReason`), :data:`WINDOW_MARGIN` more, to the
    next whole second. With ``held`` (:func:`_held_rows`) the window is longer where
    the rows ahead hold fewer samples of every channel than the window did: a gap in the
    recording past the window (a SKAB valve's 76 s: its suggested 0:718 held 615 rows,
    too few). When the rest of the archive is shorter, a window
    from its start; when the whole archive is, a line that says so (starting ``the
    archive``: a window of all of it leaves nothing to search).
    With ``crosses`` (:func:`_change_inside`), a window that holds a change the run
    sees says so instead (:func:`_too_short_before`): the record before the change is
    too short to train on, and a window across it would fit the change as healthy.
    Empty when no detector said what it needs. The option comes first: a cut line
    (:func:`analyzer.errors.clipped_line`) keeps it."""
    needs = [r.rows if isinstance(r, SkipReason) else None for r in skipped.values()]
    known = [n for n in needs if n]
    if not known or (every and len(known) < len(needs)):  # (one need untold: no length)
        return ""
    rows = math.ceil((max(known) if every else min(known)) * WINDOW_MARGIN)
    need = (
        f"about {math.ceil(rows / rate_hz)} s of healthy data ({rows} samples at "
        f"{plain_number(rate_hz)} Hz)"
    )
    if rows / rate_hz >= duration_s:  # (a window of every row leaves nothing to search)
        return (
            f"the archive's {short_seconds(duration_s)} s at {plain_number(rate_hz)} Hz are "
            "too short for "
            f"these detectors, which need {need}"
        )

    def span(start: float) -> float:
        """The window's seconds from ``start``: ``rows``, or more where the rows ahead
        hold fewer samples of every channel than the window did (:func:`_held_rows`)."""
        if held is None:
            return rows / rate_hz
        w0, w1 = (min(len(held) - 1, round(x * rate_hz)) for x in tr)
        share = (held[w1 + 1 if w1 < len(held) - 1 else w1] - held[w0]) / max(1, w1 + 1 - w0)
        a = min(len(held) - 1, round(start * rate_hz))
        ahead = int(np.searchsorted(held, held[a] + math.ceil(rows * share)))
        return max(rows, ahead - a) / rate_hz  # (past the end: longer than the archive)

    start = tr[0] if tr[0] + span(tr[0]) < duration_s else 0.0
    length = span(start)
    if length >= duration_s:  # (its gaps leave too few rows in any window)
        return (
            f"the archive's {short_seconds(duration_s)} s at {plain_number(rate_hz)} Hz hold "
            "too few samples "
            f"of every channel for these detectors, which need {need}"
        )
    end: float = math.ceil(start + length)
    if end >= duration_s:
        end = start + length
    gaps = math.ceil(length - rows / rate_hz)
    if gaps > 0:
        need += f" and {gaps} s more for the gaps in it"
    change = None if crosses is None else crosses(start, end)
    if change is not None:
        return _too_short_before(change, start, end, need)

    moved = (
        f", from the archive's start: after {short_seconds(tr[0])} s it holds less"
        if start != tr[0]
        else ""
    )
    return f"give --train {short_seconds(start)}:{short_seconds(end)}, {need}{moved}"


def _slow_clock(
    infos: Sequence[ChannelInfo], chosen: Sequence[str], rate_hz: float, given: bool = False
) -> str:
    """A hint when some analyzed channels run at twice the common clock or faster (the
    clock is the rate most channels share, and 36 entries of a 1.4 Hz covariance matrix
    outvoted a 27 Hz odometry, before they lost their vote: :func:`analyzer.store.
    clock_rate`): analyzing the fast ones alone, or at their rate, gives a
    window more samples. ``given``: the clock is ``--rate``'s. Empty otherwise. The fix
    (``--rate R``) comes before the list of channels: a cut line keeps it."""
    wanted = set(chosen)
    rates = {i.name: i.rate_hz for i in infos if i.name in wanted}
    fast = sorted((c for c, r in rates.items() if r >= 2 * rate_hz), key=lambda c: -rates[c])
    if not fast:
        return ""
    top = rates[fast[0]]
    if given or len(fast) == len(rates):
        return (
            f", or a faster clock: --rate is {plain_number(rate_hz)} Hz, and {len(fast)} of the "
            f"{len(rates)} channels run at up to {plain_number(top)} Hz"
        )
    at = sum(1 for r in rates.values() if abs(r - rate_hz) <= 0.1 * rate_hz)
    return (
        f", or analyze faster channels: the common clock runs at {plain_number(rate_hz)} Hz, "
        f"the rate of {at} of the {len(rates)} channels, while {len(fast)} "
        f"{'runs' if len(fast) == 1 else 'run'} at up to "
        f"{plain_number(top)} Hz: --rate {plain_number(top)}, or --channels naming them "
        f"({', '.join(fast[:3])}"
        f"{', ...' if len(fast) > 3 else ''})"
    )


def run(inputs: Sequence[str | Path], out_dir: str | Path, options: RunOptions) -> int:
    """``analyzer run``: analyze, write the outputs, return the exit code (0 or 1)."""
    out = Path(out_dir)
    if options.save_model is not None:
        _check_save_model(options.save_model, out, inputs, options)
    written = OUTPUT_FILES if options.corrected else OUTPUT_FILES[:2]
    not_over_inputs(out, written, inputs, "findings.json")
    not_into_watch(out)  # (a watcher's reports are its own: ux66 item M4)
    created = prepare_dir(out, "--out")  # before the work: it must not fail at the end
    try:
        with only_run(out):
            return _run_into(inputs, out, options, created)
    except BaseException:
        if created:
            remove_if_empty(out)
        raise


def _run_into(inputs: Sequence[str | Path], out: Path, options: RunOptions, created: bool) -> int:
    """:func:`run`'s work, once ``out`` is checked, made and held (:func:`only_run`)."""
    work = make_scratch()
    try:
        analysis = analyze_screened(inputs, options, work)
        model = None
        if options.save_model is not None and analysis.saved is not None:
            model = model_bytes(analysis.saved)  # (its SHA-256 in findings.json)
            analysis.saved_model = saved_model_info(analysis, options.save_model, model)
        if options.progress:
            options.progress("report", 0.0)
        earlier = None
        also: list[tuple[Path, bytes]] = []
        if options.save_model is not None and model is not None:
            earlier = _file_sha256(options.save_model)
            also.append((options.save_model, model))  # (put in place with the outputs)
        write_outputs(analysis, out, options.warn, options.utc, also)
        if options.progress:
            options.progress("report", 1.0)
        if options.warn is not None:
            _warn_inputs(analysis, out, options.warn)
            configured = config_warnings(options.config, analysis)
            for line in configured:
                options.warn(line)
            for line in window_warnings(analysis.notes):  # a training window not healthy
                options.warn(line)
            warned = (CodeHint, UnreadNote, BlankModelNote)
            for line in (n for n in analysis.notes if isinstance(n, warned)):
                options.warn(line)
            for line in (n for n in analysis.notes if isinstance(n, ClusterTrouble)):
                options.warn(line)  # (the cluster failed the run: it went on here)
            skipped = skipped_warning(analysis, options, " ".join(configured))
            if skipped:  # (default detectors that did not run: findings.json alone said it)
                options.warn(skipped)
        if options.note is not None:  # (what the run did of its own accord: information)
            for line in info_lines(analysis.notes):
                options.note(line)
        if earlier is not None and options.warn is not None:
            options.warn(
                f"--save-model {options.save_model}: replaced the file that was there "
                f"(its SHA-256 was {earlier}; it is not kept)"
            )
        if options.say is not None:
            options.say(summary_line(analysis, out))
        return 1 if analysis.faulty else 0
    finally:
        remove_scratch(work)


def _file_sha256(path: Path) -> str | None:
    """The SHA-256 of the file at ``path``, or None where there is none (or it cannot be
    read): ``--save-model`` onto an existing model replaced it without a word, and a
    production model was lost to one mistyped command (a new user's audit, ux53 item 12)."""
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else None
    except OSError:
        return None


def _skipped_words(whole: list[str], some: list[str], ran: list[str]) -> str:
    """The head of :func:`skipped_warning`: the detectors that did not run at all
    (``whole``), or not on some channel groups (``some``), and what searched instead.
    A detector of ``some`` ran on the other groups: the line said it "did not run" and
    that the search "ran with" it "alone" (a new user's audit, ux53 item 7)."""
    rest = [r for r in ran if r not in some]
    others = " and ".join([", ".join(rest[:-1]), rest[-1]] if len(rest) > 1 else rest)
    if not some:
        return f"{', '.join(whole)} did not run: the search ran with {', '.join(ran)} alone"
    them = ", ".join(some)
    searched = (
        f"which {others} searched without {'it' if len(some) == 1 else 'them'}"
        if others
        else "which no other detector searched"
    )
    if not whole:
        return f"{them} did not run on some channel groups, {searched}"
    return f"{', '.join(whole)} did not run, nor {them} on some channel groups, {searched}"


def skipped_warning(analysis: Analysis, options: RunOptions, said: str = "") -> str:
    """A line for stderr naming the default detectors that did not run while others did,
    each with its reason (findings.json's ``skipped_detectors``), and what lets them run
    (a ``--train`` long enough, :func:`_longer_window`, where the data were too few):
    nav2's ``--train 0:27``, the window the README suggests, ran the equivalent model
    alone, and the run said "no sensor fault found" with nothing of the other two. The
    error functions' wish for a config's reference sensors (:data:`CONFIG_NEED`) is left
    out: they run only so; so are detectors named in ``said`` (the config's warnings,
    :func:`config_warnings`, which name a detector whose section was not used). Empty
    when every detector ran, or none did (an error)."""
    # (the error functions run only on a config's groups: their reasons are the config's,
    # which config_warnings says; so is a detector whose config section was not used)
    data = {
        k: v
        for k, v in analysis.skipped.items()
        if CONFIG_NEED not in v
        and k.split(" (", 1)[0] != "error_function"
        and k.split(" (", 1)[0] not in said
    }
    if not analysis.results or not data:
        return ""
    ran = list(dict.fromkeys(r.detector for r in analysis.results))
    names = list(dict.fromkeys(k.split(" (", 1)[0] for k in data))
    some = [n for n in names if n in ran]  # (skipped on some channel groups only)
    whole = [n for n in names if n not in ran]
    line = _skipped_words(whole, some, ran)
    told = {k: v for k, v in data.items() if isinstance(v, SkipReason) and v.rows}
    if told and not options.model:  # (their window: the rows each said it needs)
        rate = analysis.rate_hz
        tr = (analysis.train[0] / rate, (analysis.train[1] - 1) / rate)
        longer = _longer_window(
            told, tr, rate, analysis.duration_s, every=True, held=_held_rows(analysis.values)
        )
        them = (
            "them"
            if len(told) == len(data)
            else ", ".join(dict.fromkeys(k.split(" (", 1)[0] for k in told))
        )
        if longer.startswith("give "):
            line += f"; to let {them} run, {longer}"
        elif longer:
            line += f"; {longer}"
    elif "too little healthy data" in " ".join(data.values()) and not options.model:
        line += "; a longer healthy stretch (--train START:END) lets them run"
    # each reason to its first parenthesis (the same words for both AR detectors then
    # share one entry): the whole of them is in findings.json
    why = "; ".join(skip_reasons({k: v.split(" (", 1)[0] for k, v in data.items()}))
    return clipped_line(
        f"{line} ({why}; findings.json's skipped_detectors has the whole reasons)",
        keep=len(line),
    )


SUMMARY_LISTED = 3
"""Findings :func:`summary_line` names; it counts the rest."""


def summary_line(analysis: Analysis, out: Path) -> str:
    """The line ``analyzer run`` ends with, terminal or not: :func:`faults_words`, what a
    ``--save-model`` run saved, the report's path, and the alarms the findings do not
    explain. A run said nothing when stderr was no terminal (CI, ``| tee``, cron) and
    ended with exit code 1, which reads as a failure to anyone who has not read the
    contract: the line says it is a finding. Alarms the findings do not explain
    (:mod:`analyzer.diagnosis.unexplained`) end it: "1 sensor fault found on 1 sensor"
    read as the answer where a second sensor's alarms were left in the notes."""
    report = out / "report.html"
    saved = getattr(analysis, "saved_model", None)  # (an analysis of before it was kept)
    model = f"; {_saved_words(saved)}" if saved else ""
    if saved and saved["searched"] is None:
        return f"nothing after the training window to analyze{model}; report: {report}"
    after = " after the training window" if saved else ""
    # (an Analysis of a caller that predates the field has none)
    tail = _unexplained_words(analysis)
    return (
        f"{faults_words(analysis.findings, after, getattr(analysis, 'labels', None))}"
        f"{_unsearched(analysis)}{model}; "
        f"report: {report}{tail}"
    )


SENSORS_NAMED = 3
"""Sensors the last line names by name among its unexplained alarms; more are counted
(a day's 16 channels made a line of 536 characters: the ux55 audit)."""


def _unexplained_words(analysis: Analysis) -> str:
    """The last line's tail on the alarms no finding explains, short: how many times,
    the first (seconds, and UTC where the times are absolute), on which sensors (named
    up to :data:`SENSORS_NAMED`, else counted); the report has each one. With findings:
    :attr:`Analysis.unexplained`; without: the anomalies the detectors attributed to no
    sensor (:class:`~analyzer.window_note.AnomalyNote`), which left a run's stderr silent
    with exit 0 (ux55). Empty where there are none."""
    alarms = [(u.onset_s, u.channels) for u in getattr(analysis, "unexplained", [])]
    more = 0
    if not analysis.findings and not alarms:  # (else the bank's unplaced ones: det53a)
        quiet = [n for n in getattr(analysis, "notes", ()) if isinstance(n, AnomalyNote)]
        alarms = [(n.onset_s, n.channels) for n in quiet if n.onset_s is not None]
        more = sum(n.more for n in quiet)
    if not alarms:
        return ""
    count = len(alarms) + more
    first = min(t for t, _ in alarms)
    sensors = sorted({c for _, chs in alarms for c in chs})
    named = (
        " and ".join([", ".join(sensors[:-1]), sensors[-1]] if len(sensors) > 1 else sensors)
        if len(sensors) <= SENSORS_NAMED
        else f"{len(sensors)}{' or more' if more else ''} sensors"
    )
    when = f"at {first:.1f} s" if count == 1 else f"at {count} times from {first:.1f} s"
    if analysis.absolute_time:
        when += f" ({iso_utc(analysis.start_ns + round(first * NS_PER_S))})"
    seams = [u.seam for u in getattr(analysis, "unexplained", []) if getattr(u, "seam", "")]
    at_seam = f", {'one ' if count > 1 else ''}at {seams[0]}" if seams else ""
    return f"; alarms not explained {when}, on {named}{at_seam}: see the report"


def _unsearched(analysis: Analysis) -> str:
    """The summary line's words on the channels no fault was searched for because they
    have no sample in the training window (:class:`~analyzer.selection.NoSamplesNote`,
    said on stderr before): "no sensor fault found" alone read as every sensor checked
    where a renamed column's fault was never looked for (ux55); and on those that stop
    before the record's end (:func:`~analyzer.silence_note.stopped_words`: a topic that
    stopped for good, searched only where it has data). Empty where there are none."""
    notes = getattr(analysis, "notes", ())  # (an Analysis-like caller's may have none)
    names = sorted({c for n in notes if isinstance(n, NoSamplesNote) for c in n.names})
    said = []
    if names:
        said.append(
            f"{len(names)} channel{'s' if len(names) > 1 else ''} not searched, with no data "
            "in the training window"
        )
    # (a sensor that stopped for good: "no sensor fault found" alone read as the whole
    # record audited)
    if stopped := stopped_words(notes):
        said.append(stopped)
    return f" ({'; '.join(said)}: see above)" if said else ""


def faults_words(
    found: Sequence[Finding], after: str = "", labels: Mapping[str, str] | None = None
) -> str:
    """How many faults on how many sensors (found ``after``: " after the training
    window" of a ``--save-model`` run), the first :data:`SUMMARY_LISTED` by onset
    (sensor, with its label in parentheses where its message names it: ``labels``, a
    ``JointState``'s joint; type, onset); or that none was found: :func:`summary_line`'s,
    and the watcher's line for an archive with a fault (``analyzer.watch``), which said
    only "fault (s2)"."""
    if not found:
        return f"no sensor fault found{after}"
    labels = labels or {}
    sensors = len({f.channel for f in found})
    items = [
        f"{f.channel}{f' ({labels[f.channel]})' if f.channel in labels else ''} "
        f"{f.type}{_size_words(f)} from {_onset_words(f)}"
        for f in found
    ]
    return (
        f"{len(found)} sensor fault{'s' if len(found) > 1 else ''} found on {sensors} "
        f"sensor{'s' if sensors > 1 else ''}{after}: {capped(items, SUMMARY_LISTED)}"
    )


def saved_model_info(analysis: Analysis, path: Path, data: bytes) -> dict[str, Any]:
    """``findings.json``'s ``saved_model`` of a ``--save-model`` run (:attr:`Analysis.
    saved_model`): the file (``path``), the SHA-256 of its bytes ``data``, the window the
    models were fitted on, what was searched for faults after it (None: nothing, the
    window reaching the record's end) and the warnings the checks of that window gave
    (their stderr lines: a step or gain change inside it...). A fit-only run said "no
    sensor fault found", and nothing of the model, though nothing had been searched
    (the audit)."""
    start, end = analysis.train
    searched = (
        {
            "start_s": json_time(end / analysis.rate_hz),
            "end_s": round(analysis.duration_s, DURATION_DECIMALS),  # (as ``duration_s``)
        }
        if end < analysis.n
        else None
    )
    return {
        "path": str(path),
        "sha256": hashlib.sha256(data).hexdigest(),
        "train": {  # (as findings.json's train)
            "start_s": json_time(start / analysis.rate_hz),
            "end_s": json_time((end - 1) / analysis.rate_hz),
        },
        "searched": searched,
        "warnings": window_warnings(analysis.notes),
    }


def _saved_words(saved: Mapping[str, Any]) -> str:
    """The summary line's words on the saved model: its file, the window it was fitted
    on, and, where that window's checks warned, that it was (not a clean bill)."""
    tr = saved["train"]
    window = f"{short_seconds(tr['start_s'])}-{short_seconds(tr['end_s'])} s"
    warned = len(saved["warnings"])
    if not warned:
        return f"model saved to {saved['path']} (fitted on {window})"
    return (
        f"model saved to {saved['path']}, fitted on a window with "
        f"{'a warning' if warned == 1 else f'{warned} warnings'} ({window}: see above)"
    )


def _size_words(f: Finding) -> str:
    """The size a finding's type word alone does not say, for the summary line: a gain
    (`` (gain ×1.5)``; at 0 `` (gain ×0: dead sensor)``, the index's and the report's
    words after a colon), a stuck value (`` (stuck at 0.37)``), a silence (`` (no reading: dead
    sensor, silent)``); "" for an offset or a drift, whose type word says what the sensor
    does (the bundled sample's line stays ``/s4.data additive from 16.000 s``). The
    line said ``s3 multiplicative`` for a dead sensor, "dead" only in the index and the
    report, and a watcher's user reads the line (ux53 item 8)."""
    from analyzer.report.format import gain_words, num

    mag = f.magnitude or {}
    gain, stuck = _finite(mag.get("gain")), _finite(mag.get("stuck_at"))
    if f.type is FaultType.MULTIPLICATIVE and gain is not None:
        return f" ({gain_words(gain, inside=True)})"
    if f.type is FaultType.OTHER and mag.get("no_data_s") is not None:
        return " (no reading: dead sensor, silent)"
    if f.type is FaultType.OTHER and stuck is not None:
        return f" (stuck at {num(stuck)})"
    return ""  # (a size not measured, NaN, is not said: it read "gain ×n/a")


def _finite(v: Any) -> float | None:
    """``v`` as a float where it is a finite number, else None."""
    try:
        x = float(v)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def _onset_words(f: Finding) -> str:
    """A finding's onset as the summary line says it: seconds from the start, or, for a
    fault already there when the detectors could first judge the record (evidence
    ``onset_at_or_before``: a constant channel's from its first sample, ``--model``'s
    from the filters' warm-up), "the start", with the time before which nothing was
    judged where that is not the first sample: one fault present from the first sample
    read "from 0.000 s or earlier" by one detector and "from 3.600 s or earlier" by
    another (ux53 item 8). ``onset_s`` is unchanged. A fault there when the search began
    right after the training window (``onset_at_search_start``) keeps "T s or earlier":
    the window before it was taken as healthy, not left unjudged."""
    onset = _finite(f.onset_s)
    if f.evidence.get("onset_at_or_before"):
        if onset is None:  # (not known when it was first judged: "before nan s")
            return "the start"
        at = seconds_text(onset)
        return "the start" if float(at) == 0 else f"the start (not judged before {at} s)"
    if onset is None:
        return "an unknown time"
    at = seconds_text(onset)
    return f"{at} s{' or earlier' if f.evidence.get('onset_at_search_start') else ''}"


OUTPUT_FILES = ("findings.json", "report.html", "corrected.csv")
"""What :func:`run` writes into ``--out``."""


def _check_save_model(
    path: Path, out: Path, inputs: Sequence[str | Path], options: RunOptions
) -> None:
    """``--save-model``'s file, before any work: a file name in an existing directory or
    in ``--out`` (created next), not one of the run's outputs, and none of its inputs:
    the archive, the ``--config`` file or the config's ``[model] file``."""
    check_model_path(path, out)
    target = path.resolve()
    if target == out.resolve():
        raise UsageError(f"--save-model: {path} is the --out directory, expected a file name")
    if target.parent == out.resolve() and target.name in OUTPUT_FILES:
        raise UsageError(
            f"--save-model: {path} is the run's own {target.name} in --out; name the model "
            "otherwise"
        )
    config = options.config
    not_into_inputs(
        path,
        inputs,
        "--save-model",
        "write the model elsewhere",
        {"the --config file": config.path, "the config's [model] file": config.model_file},
    )
    not_a_model(path)  # (after: a file the run reads is named as such first)


def config_warnings(config: Config, analysis: Analysis) -> list[str]:
    """Lines for stderr on what the user wrote in the config and the run could not use
    (a ``[model]`` naming a channel the archive does not have, a ``dt`` that does not
    match its rate, a ``[[group]]`` input that is not there...): known only once the
    data is read, so the run goes on with the other detectors, but a detector the config
    configures (its ``[detectors.NAME]`` section; ``[model]`` for the detection filter,
    ``[[group]]`` for the error functions) that ran on no channel says why."""
    if config.path is None:
        return []
    configured = {name: f"[detectors.{name}]" for name in config.detectors}
    uses_model = config.detectors.get("detection_filter", {}).get("use_config_model", True)
    if config.model is not None and uses_model is not False:
        configured["detection_filter"] = "[model]"
    if any(g.get("reference") or g.get("uncertain") for g in config.groups):
        # (groups without reference or uncertain sensors only group the channels)
        configured["error_function"] = "[[group]]"
    ran = {r.detector for r in analysis.results}
    lines = []
    for name, what in configured.items():
        why = {k: v for k, v in analysis.skipped.items() if k.split(" (", 1)[0] == name}
        if name in ran or not why:
            continue
        lines.append(
            f"{config.path}: the config's {what} is not used, {'; '.join(skip_reasons(why))}"
        )
    # a [[group]] naming a channel the archive does not have: a typo, or a pattern
    # (names are exact); the group is analyzed without it, as a note says
    known = {c.name for c in analysis.channels}
    said = " ".join(analysis.skipped.values())  # (the error functions' line names them)
    for g in config.groups:
        absent = [c for c in group_members(g) if c not in known and repr(c) not in said]
        if absent and known:
            patterns = any(ch in c for c in absent for ch in "*?[")
            lines.append(
                f"{config.path}: [[group]] {g.get('name', '?')!r}: "
                f"{', '.join(repr(c) for c in absent)} not in the archive"
                + (" (channel names, not patterns)" if patterns else "")
            )
    # a fixed AR order below what the training window supports (the bank's own note)
    stem = ORDER_NOTE.split("{order}")[0]
    for r in analysis.results:
        lines.extend(
            f"{config.path}: [detectors.{r.detector}] {n}" for n in r.notes if n.startswith(stem)
        )
    return lines


def _warn_inputs(analysis: Analysis, out: Path, warn: Callable[[str], None]) -> None:
    """The inputs' errors (a truncated or unreadable file, samples dropped) and the
    archive's assembly notes (:func:`_archive_notes`), which a run that still exits 0 or 1
    would otherwise keep to findings.json and the report."""
    lines = input_warnings(analysis, selected_only=True)
    notes = _archive_notes(analysis)
    for line in lines[:WARNED_LINES]:
        warn(line)
    if len(lines) > WARNED_LINES:
        what = "input errors and notes" if notes else "input errors"
        warn(f"{len(lines) - WARNED_LINES} more {what} in {out / 'findings.json'}")


def input_warnings(analysis: Analysis, selected_only: bool = False) -> list[str]:
    """The lines ``analyzer run`` warns of about the inputs of a run that went on: each
    input error (``FILE: error``), then the archive's assembly notes
    (:func:`_archive_notes`). ``selected_only``: without the errors about topics that
    ``--channels`` (or a saved model) left out (:func:`~analyzer.readers.base.
    about_selection`: findings.json keeps them)."""
    names = [c.name for c in analysis.channels]
    unselected = {c for c, why in analysis.left_out.items() if why.get("why") == "not selected"}
    selected = [c for c in names if c not in unselected]
    lines = [
        f"{i.path}: {e}"
        for i in analysis.inputs
        for e in i.errors
        if not (selected_only and unselected) or about_selection(e, i, names, selected)
    ]
    return lines + _archive_notes(analysis)


def _archive_notes(analysis: Analysis) -> list[str]:
    """The notes on how the archive was put together (a file in its folders not read, an
    input given twice: :class:`~analyzer.readers.ArchiveNote`): each names its file, and
    what was left out of the archive is said where the inputs' errors are."""
    return [str(n) for n in analysis.notes if isinstance(n, ArchiveNote)]


__all__ = [
    "Analysis",
    "AnalyzerError",
    "BlankModelNote",
    "RunOptions",
    "analyze",
    "findings_document",
    "input_warnings",
    "load_options",
    "run",
    "summary_line",
    "write_outputs",
]
