"""A CSV with plain numbers and plain ISO 8601 times is read without pandas (its format
choice is made from the cells' form, Arrow's arrays are viewed without pyarrow's
``to_numpy``, which imports pandas), with the result of the pandas path."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pytest
from readers_helpers import collect, synthetic

from analyzer.readers import csv_reader, open_input
from analyzer.writers import write_archive

CELLS = [
    ["2026-01-01T01:00:00Z", "2026-01-01 01:00:00.5Z", "2026-01-01T01:00:00.123456789Z"],
    ["2026-01-01T01:00:00+02:00", "2026-01-01T01:00:00-05:30", "2026-01-01T01:00:00+0200"],
    ["2026-01-01T01:00:00", "2026-01-01 01:00:00.25"],
    ["2026-01-01T01:00:00", "2026-01-01T01:00", "2026-01-01"],  # not all plain
    ["2026-01-01T01:00:00Z", "2026-01-01T01:00:00"],  # with and without zone
    ["2026-01-01T01:00:00Z", ""],  # a blank
    ["2026-02-29T01:00:00Z", "2024-02-29T01:00:00Z"],  # no such day
    ["2026-01-01T23:59:60Z", "2026-01-01T24:00:00Z"],  # leap second, hour 24
    ["1600-01-01T00:00:00Z", "2262-04-11T23:47:16.854775807Z"],
    ["2026-01-01T01:00:00.1234567891Z", "20260101T010000Z", "2026-1-1T01:00:00Z"],
    ["2026-01-01T01:00:00+01", "2026-01-01T01:00:00+01:00"],
]


def _reader() -> csv_reader.CsvReader:
    reader = csv_reader.CsvReader.__new__(csv_reader.CsvReader)
    reader._time_format = None
    reader._day_first = None
    reader._iso_type = pa.timestamp("ns", "UTC")
    return reader


@pytest.mark.parametrize("cells", CELLS)
def test_first_block_format_and_times_equal_the_pandas_choice(
    cells: list[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    text = pa.array(cells)
    fast = _reader()
    t_fast, keep_fast = fast._datetimes(text)
    monkeypatch.setattr(csv_reader, "_plain_iso", lambda _text: False)
    slow = _reader()
    t_slow, keep_slow = slow._datetimes(text)
    assert fast._time_format == slow._time_format
    np.testing.assert_array_equal(keep_fast, keep_slow)
    np.testing.assert_array_equal(t_fast[keep_fast], t_slow[keep_slow])


PLAIN_AND_ARROW = [
    (True, True),
    (True, True),  # (an offset with or without its colon)
    (True, True),  # (no zone: plain too)
    (False, True),  # no seconds, a date alone: not plain, though Arrow reads them
    (True, False),  # each cell plain; Arrow refuses zoned and zone-less together
    (False, False),
    (True, False),  # the form is plain; the day is not there
    (False, False),
    (True, False),  # plain, out of the nanosecond range
    (False, False),
    (False, True),  # an offset of hours alone: not plain
]
"""Per case of :data:`CELLS`: whether the cells are plain ISO 8601 (``_plain_iso``), and
whether Arrow parses them (``_iso_datetimes``)."""


@pytest.mark.parametrize(
    ("cells", "plain", "arrow"),
    [(c, *e) for c, e in zip(CELLS, PLAIN_AND_ARROW, strict=True)],
)
def test_plain_iso_cells_are_what_pandas_iso8601_parses(
    cells: list[str], plain: bool, arrow: bool
) -> None:
    text = pa.array(cells)
    assert csv_reader._plain_iso(text) is plain
    assert (_reader()._iso_datetimes(text) is not None) is arrow
    if plain and arrow:
        series = pd.Series(cells, dtype=object)
        assert csv_reader._datetime_format(series) == ("ISO8601", None)


def test_numpy_view_equals_to_numpy() -> None:
    values = pa.array(np.linspace(-3, 3, 101))
    ints = pa.array(np.arange(-50, 51, dtype=np.int64) * 10**15)
    for array in (values, ints, values.slice(7, 40), ints.slice(13), values.slice(5, 0)):
        got = csv_reader._numpy(array)
        want = array.to_numpy(zero_copy_only=False)
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)
    with_null = pa.array([1.0, None, 3.0])
    np.testing.assert_array_equal(csv_reader._numpy(with_null), [1.0, np.nan, 3.0])
    text = pa.array(["a", "b"])
    assert list(csv_reader._numpy(text)) == ["a", "b"]


def test_plain_iso_csv_is_read_without_pandas_as_with_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    t, data = synthetic(5000, channels=3)
    path = tmp_path / "iso.csv"
    write_archive(path, "csv", t, data, start_iso="2026-01-01T00:00:00Z")
    monkeypatch.setattr(csv_reader, "BLOCK_BYTES", 8192)
    fast = open_input(path)
    fast_out = collect(fast.chunks())
    monkeypatch.setattr(csv_reader, "_plain_iso", lambda _text: False)
    slow = open_input(path)
    slow_out = collect(slow.chunks())
    assert fast.start_ns() == slow.start_ns()
    assert fast.info.errors == slow.info.errors
    assert fast_out.keys() == slow_out.keys()
    for name in slow_out:
        np.testing.assert_array_equal(fast_out[name][0], slow_out[name][0])
        assert fast_out[name][1].tobytes() == slow_out[name][1].tobytes()
    code = (
        "import sys\n"
        "from analyzer.readers import open_archive\n"
        f"archive = open_archive([{str(path)!r}, {str(path)!r}])\n"
        "n = sum(len(c) for c in archive.chunks())\n"
        "print(n > 0, 'pandas' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["True", "False"]
