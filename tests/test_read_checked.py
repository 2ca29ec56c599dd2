"""The reading stage's internal checks (analyzer.pipeline._read_checked): samples lost or
changed between the readers and the store, or inside a reader's reordering, are noticed,
the inputs are read again once with a note naming the channel, and the result is the
clean run's; a corruption that comes back stops the run with one line and exit 2.

Under heavy load an analysis of a 30 000-row CSV once in ~600 lost every channel's first
2 359 rows without a word (benchmarks/README.md, ``stress_repeat.py``): the injected
corruptions below are that one (rows lost at the start, in the store) and a value
overwritten while the reorderer held it."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.cli import main
from analyzer.pipeline import RunOptions, analyze
from analyzer.readers._common import Reorderer
from analyzer.readers.base import ChannelChunk
from analyzer.simulate import simulate_building
from analyzer.store import AlignedSeries, ChannelStore
from analyzer.writers import write_archive

RATE = 100.0
LOST = 2359
EPOCH_NS = 1_780_000_000 * 10**9


def _csv(tmp_path, name: str = "rec.csv", seconds: float = 60.0, start: float = 0.0) -> str:
    t, y, names = simulate_building(3, seconds, RATE, seed=3)
    t_ns = np.round(t * 1e9).astype(np.int64)
    # (dates: files with relative times, each from 0 s, are not stitched)
    start_iso = str(np.datetime64(EPOCH_NS + int(start * 1e9), "ns")) + "Z"
    path = tmp_path / name
    write_archive(path, "csv", t_ns, {n: y[:, i] for i, n in enumerate(names)}, start_iso=start_iso)
    return str(path)


def _dir(tmp_path, name: str):
    (tmp_path / name).mkdir()
    return tmp_path / name


def _losing_rows(monkeypatch, times: int) -> list[int]:
    """``ChannelStore.add`` drops the first :data:`LOST` samples of every channel's first
    chunk in the first ``times`` reads (a read starts with a new store)."""
    reads = [0]
    first_init = ChannelStore.__init__
    first_add = ChannelStore.add

    def init(self, *args, **kwargs):
        reads[0] += 1
        first_init(self, *args, **kwargs)

    def add(self, chunk):
        if reads[0] <= times and chunk.name not in self._raw:
            chunk = ChannelChunk(chunk.name, chunk.t_ns[LOST:], chunk.values[LOST:])
        first_add(self, chunk)

    monkeypatch.setattr(ChannelStore, "__init__", init)
    monkeypatch.setattr(ChannelStore, "add", add)
    return reads


def test_rows_lost_in_the_store_are_read_again_with_a_note(tmp_path, monkeypatch):
    csv = _csv(tmp_path)
    clean = analyze([csv], RunOptions(), _dir(tmp_path, "clean"))
    reads = _losing_rows(monkeypatch, 1)
    again = analyze([csv], RunOptions(), _dir(tmp_path, "again"))
    assert reads[0] >= 2  # (and a pass trained before a change may read it again)
    said = [n for n in again.notes if "internal check failed" in n]
    assert said == [
        "internal check failed in the store: 's0': 6000 samples read, 3641 stored; 's1': "
        "6000 samples read, 3641 stored and 1 more channels; the inputs were read again, "
        "and the second read passed the check"
    ]
    assert np.array_equal(np.asarray(clean.values), np.asarray(again.values), equal_nan=True)
    assert [c.samples for c in again.channels] == [6000] * 3
    assert again.start_ns == clean.start_ns
    assert [n for n in again.notes if n not in said] == clean.notes


def test_rows_lost_twice_stop_the_run_with_one_line(tmp_path, monkeypatch, capsys):
    csv = _csv(tmp_path)
    _losing_rows(monkeypatch, 2)
    code = main(["run", csv, "--out", str(_dir(tmp_path, "out")), "--no-progress"])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert "\n" not in err
    assert err.startswith(f"analyzer: error: {csv}: internal check failed in the store: 's0'"), err
    assert "; read again: internal check failed in the store: 's0'" in err
    assert err.endswith("the analysis stops rather than report a result of corrupted samples")
    assert not (tmp_path / "out" / "findings.json").exists()


def test_a_value_changed_in_the_reorderer_of_one_input_of_two_is_read_again(tmp_path, monkeypatch):
    """Of an archive of several inputs, a reader's failure is recorded as the input's
    error and the others are read ("reading stopped"); an internal check's failure is
    not the input's and goes up to the pipeline."""
    first = _csv(tmp_path, "a.csv")
    second = _csv(tmp_path, "b.csv", start=60.0)
    clean = analyze([first, second], RunOptions(), _dir(tmp_path, "clean"))
    changed = [0]
    push = Reorderer.push

    def corrupting(self, name, t, values):
        held = np.array(values)
        push(self, name, t, held)
        if name == "s2" and not changed[0]:
            changed[0] = 1
            held[7] += 1.0  # after the tally: changed while held

    monkeypatch.setattr(Reorderer, "push", corrupting)
    again = analyze([first, second], RunOptions(), _dir(tmp_path, "again"))
    assert changed == [1]
    said = [n for n in again.notes if "internal check failed" in n]
    assert said == [
        "internal check failed in the reader's reordering: 's2': 6000 samples pushed and "
        "released or dropped, but their values differ; the inputs were read again, and the "
        "second read passed the check"
    ]
    assert not [e for i in again.inputs for e in i.errors]
    assert np.array_equal(np.asarray(clean.values), np.asarray(again.values), equal_nan=True)


@pytest.mark.parametrize("inputs", [1, 2])
def test_a_clean_read_has_no_note(tmp_path, inputs):
    paths = [_csv(tmp_path, f"{i}.csv", start=60.0 * i) for i in range(inputs)]
    a = analyze(paths, RunOptions(), _dir(tmp_path, "out"))
    assert not [n for n in a.notes if "internal check" in n]


def test_a_stored_value_changed_while_aligning_is_read_again(tmp_path, monkeypatch):
    """The store is checked again once the aligned matrix is written: the raw samples
    were read for it, and a change after the first check would be in the matrix."""
    csv = _csv(tmp_path)
    clean = analyze([csv], RunOptions(), _dir(tmp_path, "clean"))
    materialize = AlignedSeries.materialize
    calls = [0]

    def changing(self, *args, **kwargs):
        calls[0] += 1
        if calls[0] == 1:
            _, v = self.store.raw("s1")
            v[100] = 7.0  # (v is the store's own array in memory)
        return materialize(self, *args, **kwargs)

    monkeypatch.setattr(AlignedSeries, "materialize", changing)
    again = analyze([csv], RunOptions(), _dir(tmp_path, "again"))
    assert again.notes[0] == (
        "internal check failed in the store after the alignment: 's1': 6000 samples read "
        "and stored, but their values differ; the inputs were read again, and the second "
        "read passed the check"
    )
    assert np.array_equal(np.asarray(clean.values), np.asarray(again.values), equal_nan=True)


def _dropping_arrow_rows(monkeypatch, times: int, at: int = 1000, count: int = LOST) -> list[int]:
    """Arrow's reader of the CSV passes on its first block without ``count`` rows from
    row ``at`` in the first ``times`` reads: what the stress runs saw (rows gone from
    the middle of the text before any sample reached the reordering)."""
    from analyzer.readers import csv_reader

    reads = [0]
    first = csv_reader.CsvReader._stream

    def stream(self):
        reads[0] += 1
        for k, (batch, invalid) in enumerate(first(self)):
            if reads[0] <= times and k == 0:
                import pyarrow as pa

                batch = (
                    pa.concat_tables(
                        [
                            pa.Table.from_batches([batch.slice(0, at)]),
                            pa.Table.from_batches([batch.slice(at + count)]),
                        ]
                    )
                    .combine_chunks()
                    .to_batches()[0]
                )
            yield batch, invalid

    monkeypatch.setattr(csv_reader.CsvReader, "_stream", stream)
    return reads


def test_rows_lost_inside_the_csv_parse_are_read_again_with_a_note(tmp_path, monkeypatch):
    csv = _csv(tmp_path)
    clean = analyze([csv], RunOptions(), _dir(tmp_path, "clean"))
    _dropping_arrow_rows(monkeypatch, 1)
    again = analyze([csv], RunOptions(), _dir(tmp_path, "again"))
    said = [n for n in again.notes if "internal check failed" in n]
    assert said == [
        f"internal check failed in the CSV reader: {csv}: 3641 rows read of the 6000 lines "
        "under its header; the inputs were read again, and the second read passed the check"
    ]
    assert np.array_equal(np.asarray(clean.values), np.asarray(again.values), equal_nan=True)
    assert again.start_ns == clean.start_ns


def test_the_same_short_count_twice_is_said_not_stopped_on(tmp_path, monkeypatch):
    """A shortfall that repeats exactly on the second read is a blind spot of the count,
    not a lost read: the analysis goes on with the rows read and says so."""
    csv = _csv(tmp_path)
    _dropping_arrow_rows(monkeypatch, 10)
    again = analyze([csv], RunOptions(), _dir(tmp_path, "again"))
    assert [c.samples for c in again.channels] == [6000 - LOST] * 3
    errors = [e for i in again.inputs for e in i.errors]
    assert (
        f"{csv}: 3641 rows read of the 6000 lines under its header (the same on a "
        "second read: lines this count cannot tell)" in errors
    )


@pytest.mark.parametrize("ending", ["\n", "\r\n"])
@pytest.mark.parametrize("block", [1, 2, 3, 5, 64])
def test_the_line_count_is_arrows_row_count(tmp_path, monkeypatch, ending, block):
    """The lines counted while hashing are the rows Arrow's reader passes on (header
    included), across block boundaries; None where that count would not be exact
    (blank lines, quotes, a lone carriage return)."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    from analyzer.readers import csv_reader

    monkeypatch.setattr(csv_reader, "HASH_BLOCK", block)
    rng = np.random.default_rng(block)
    for trial in range(40):
        rows = ["time,a,b"] + [
            f"{i / 100:.2f},{rng.random():.3f},{rng.random():.2f}" for i in range(trial % 9)
        ]
        text = ending.join(rows) + (ending if trial % 2 else "")
        path = tmp_path / f"t{trial}.csv"
        path.write_bytes(text.encode())
        _, _, lines = csv_reader._digest_and_lines(path, False)
        table = pacsv.read_csv(
            path,
            read_options=pacsv.ReadOptions(column_names=["t", "a", "b"]),
            convert_options=pacsv.ConvertOptions(column_types=dict.fromkeys("tab", pa.string())),
        )
        assert lines == table.num_rows, text
        blank = [text.replace(ending, ending * 2, 1)] if ending in text else []
        for inexact in (*blank, text + "\r", '"time",a,b' + text[8:]):
            path.write_bytes(inexact.encode())
            assert csv_reader._digest_and_lines(path, False)[2] is None, inexact
