"""``analyzer export``: the time-aligned channels as .csv or .parquet, block by block
(memory does not grow with the archive's length)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from analyzer.errors import UsageError, capped
from analyzer.outdir import not_into_inputs, prepare_dir, remove_if_empty
from analyzer.readers import open_archive
from analyzer.readers.base import TimeSource, one_clock
from analyzer.scratch import scratch
from analyzer.store import AlignedSeries, ChannelStore, clock_rate

BLOCK = 1 << 16

WARNED_LINES = 5
"""Lines of input errors an export repeats through ``warn`` (as ``run`` does)."""


def export_archive(
    inputs: Sequence[str | Path],
    out: Path,
    channels: list[str] | None = None,
    rate: float | None = None,
    time: TimeSource = "log",
    warn: Callable[[str], None] | None = None,
) -> Path:
    """Write the aligned channels of ``inputs`` to ``out``; what went wrong with the
    inputs while they were read (a truncated file, samples dropped: ``inputs[].errors``
    of ``inspect``) is told to ``warn``, a line each, once the file is written."""
    suffix = "".join(out.suffixes[-1:]).lower()
    if suffix not in (".csv", ".parquet"):
        raise UsageError(f"--out: {out} must end in .csv or .parquet")
    if out.is_dir():
        raise UsageError(f"--out: {out} is a directory")
    # (the input was read, then replaced by its export, its absolute times lost)
    not_into_inputs(out, inputs, "--out", "export elsewhere")
    created = prepare_dir(out.parent, "--out")  # before reading: not at the end
    try:
        return _export(inputs, out, suffix, channels, rate, time, warn)
    except BaseException:
        if created:
            remove_if_empty(out.parent)
        raise


def _export(
    inputs: Sequence[str | Path],
    out: Path,
    suffix: str,
    channels: list[str] | None,
    rate: float | None,
    time: TimeSource,
    warn: Callable[[str], None] | None = None,
) -> Path:
    archive = open_archive(inputs)
    with (
        scratch("analyzer-export-") as tmp,
        ChannelStore.from_chunks(archive.chunks(time), tmp) as store,
    ):
        if channels:
            unmatched = store.unmatched_line(channels)
            if unmatched:
                raise UsageError(unmatched)
            names = store.select(channels, numeric_only=False)
        else:
            names = store.select(None, numeric_only=False)
        if not names:
            where = capped([str(i) for i in inputs], 3, what="inputs")
            why = [i.no_numeric for i in archive.inputs if i.no_numeric]
            why += [e for i in archive.inputs for e in i.errors]
            bad = capped(why, 3, "; ", "input errors")
            raise UsageError(
                f"{where}: no numeric channel to export" + (f" ({bad})" if bad else "")
            )
        one_clock(names, archive.inputs)
        aligned = store.align(names, _default_rate(store, names) if rate is None else rate)
        tmp_out = out.with_name(f".{out.name}.part")
        try:
            if suffix == ".csv":
                _write_csv(aligned, tmp_out)
            else:
                _write_parquet(aligned, tmp_out)
            tmp_out.replace(out)
        finally:
            tmp_out.unlink(missing_ok=True)
    if warn is not None:
        lines = [f"{i.path}: {e}" for i in archive.inputs for e in i.errors]
        for line in lines[:WARNED_LINES]:
            warn(line)
        if len(lines) > WARNED_LINES:
            warn(f"{len(lines) - WARNED_LINES} more input errors (`analyzer inspect` lists them)")
    return out


def _default_rate(store: ChannelStore, names: Sequence[str]) -> float:
    """The dominant rate of the channels that vary (of all when none does).

    An export keeps the constant channels (``run`` leaves them out), but they do not
    set its clock: a ROS ``Odometry`` at 20 Hz brings 72 constant covariance fields,
    which outnumbered an IMU's varying channels at 100 Hz and made the clock 20 Hz. Nor
    do the entries of covariance arrays (:func:`analyzer.store.clock_rate`)."""
    infos = {i.name: i for i in store.infos()}
    varying = [n for n in names if not infos[n].constant]
    return clock_rate([infos[n] for n in varying or names])


def _table(aligned: AlignedSeries, a: int, blk: np.ndarray, schema: object) -> object:
    import pyarrow as pa

    t = np.arange(a, a + blk.shape[0]) / aligned.rate_hz
    cols = [pa.array(t)] + [pa.array(blk[:, j], from_pandas=True) for j in range(blk.shape[1])]
    return pa.Table.from_arrays(cols, schema=schema)


def _schema(aligned: AlignedSeries) -> object:
    import pyarrow as pa

    return pa.schema([("time", pa.float64())] + [(c, pa.float64()) for c in aligned.channels])


def _write_csv(aligned: AlignedSeries, path: Path) -> None:
    """CSV via pyarrow's writer: shortest round-trip floats, an empty cell for a gap."""
    import pyarrow.csv as pcsv

    schema = _schema(aligned)
    with pcsv.CSVWriter(str(path), schema) as w:
        for a, blk in aligned.blocks(BLOCK):
            w.write_table(_table(aligned, a, blk, schema))


def _write_parquet(aligned: AlignedSeries, path: Path) -> None:
    import pyarrow.parquet as pq

    schema = _schema(aligned)
    with pq.ParquetWriter(str(path), schema) as w:
        for a, blk in aligned.blocks(BLOCK):
            w.write_table(_table(aligned, a, blk, schema))
