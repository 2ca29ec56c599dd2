"""CSV/TSV reader: separators, decimal commas, gaps, time formats."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest
from readers_helpers import collect, synthetic

from analyzer.readers import open_input
from analyzer.writers import write_archive


def read(path: Path) -> tuple[dict[str, tuple[np.ndarray, np.ndarray]], object]:
    reader = open_input(path)
    return collect(reader.chunks()), reader.info


@pytest.mark.parametrize("name", ["data.csv", "data.tsv", "data.csv.gz"])
def test_round_trip_relative_seconds(tmp_path: Path, name: str) -> None:
    t, data = synthetic(2500, channels=3)
    path = tmp_path / name
    write_archive(path, "csv", t, data)
    got, info = read(path)
    assert info.absolute_time is False
    for key in data:
        np.testing.assert_array_equal(got[key][0], t - t[0])  # exact nanoseconds
        np.testing.assert_array_equal(got[key][1], data[key])  # exact float round trip


def test_round_trip_iso_times(tmp_path: Path) -> None:
    t, data = synthetic(500, channels=2)
    path = tmp_path / "iso.csv"
    write_archive(path, "csv", t, data, start_iso="2026-01-01T00:00:00Z")
    got, info = read(path)
    assert info.absolute_time is True
    np.testing.assert_array_equal(got["s0"][0], t)  # synthetic() starts 2026-01-01 UTC


def test_semicolon_and_decimal_comma(tmp_path: Path) -> None:
    path = tmp_path / "eu.csv"
    path.write_text("Zeit;Druck;Temp\n0,0;1,5;20\n0,5;2,25;21\n1,0;-3,125;22\n")
    got, _ = read(path)
    np.testing.assert_array_equal(got["Druck"][0], [0, 500_000_000, 1_000_000_000])
    np.testing.assert_array_equal(got["Druck"][1], [1.5, 2.25, -3.125])
    np.testing.assert_array_equal(got["Temp"][1], [20.0, 21.0, 22.0])


def test_blank_cells_are_gaps_and_text_columns_are_skipped(tmp_path: Path) -> None:
    path = tmp_path / "gaps.csv"
    path.write_text("timestamp,A,B,label,flag\n0.0, ,1,x,true\n0.1, 4,,y,false\n0.2, 5,3,z,TRUE\n")
    got, _ = read(path)
    assert set(got) == {"A", "B", "flag"}
    np.testing.assert_array_equal(got["A"][0], [100_000_000, 200_000_000])
    np.testing.assert_array_equal(got["A"][1], [4.0, 5.0])
    np.testing.assert_array_equal(got["B"][0], [0, 200_000_000])
    np.testing.assert_array_equal(got["flag"][1], [1.0, 0.0, 1.0])


def test_time_column_by_name_not_position(tmp_path: Path) -> None:
    path = tmp_path / "late.csv"
    path.write_text("x,y,Time\n1,2,10\n3,4,11\n")
    got, _ = read(path)
    assert set(got) == {"x", "y"}
    np.testing.assert_array_equal(got["x"][0], [10_000_000_000, 11_000_000_000])


def test_nanosecond_integers_and_zones(tmp_path: Path) -> None:
    path = tmp_path / "ns.csv"
    path.write_text("%time,v\n1486559106139796569,1\n1486559106140360682,2\n")
    got, info = read(path)
    np.testing.assert_array_equal(got["v"][0], [1486559106139796569, 1486559106140360682])
    assert info.absolute_time is True
    zoned = tmp_path / "zoned.csv"
    zoned.write_text("datetime,v\n2026-01-01T02:00:00+02:00,1\n2026-01-01T02:00:01+02:00,2\n")
    got, _ = read(zoned)
    np.testing.assert_array_equal(
        got["v"][0], [1_767_225_600_000_000_000, 1_767_225_601_000_000_000]
    )


def test_quoted_us_style_timestamps(tmp_path: Path) -> None:
    path = tmp_path / "quoted.csv"
    path.write_text('timestamp,A\n" 01/20/2021 10:11:32.332", 1\n" 01/20/2021 10:11:32.532",2\n')
    got, _ = read(path)
    np.testing.assert_array_equal(got["A"][0], [1611137492332000000, 1611137492532000000])


def test_non_numeric_cells_later_are_gaps_and_recorded(tmp_path: Path) -> None:
    path = tmp_path / "dirty.csv.gz"
    with gzip.open(path, "wt") as handle:
        handle.write("time,x,note\n")
        for i in range(20):
            handle.write(f"{i},{'ERR' if i == 7 else i},{'ok' if i % 2 else 12}\n")
    got, info = read(path)
    np.testing.assert_array_equal(got["x"][1], [i for i in range(20) if i != 7])
    assert "note" not in got  # half numbers: a text column
    assert info.errors == ["x: 1 non-numeric cells treated as gaps"]


def test_rows_without_time_are_skipped_and_recorded(tmp_path: Path) -> None:
    path = tmp_path / "holes.csv"
    path.write_text("time,x\n0,1\n,2\n2,3\n")
    got, info = read(path)
    np.testing.assert_array_equal(got["x"][1], [1.0, 3.0])
    assert any("rows without a readable time" in e for e in info.errors)


def test_unsorted_rows_come_out_sorted(tmp_path: Path) -> None:
    path = tmp_path / "unsorted.csv"
    path.write_text("time,x\n0.2,3\n0.0,1\n0.1,2\n")
    got, _ = read(path)
    np.testing.assert_array_equal(got["x"][1], [1.0, 2.0, 3.0])


def test_latin1_file(tmp_path: Path) -> None:
    path = tmp_path / "latin1.csv"
    path.write_bytes("time;Temperatur (°C);Ort\n0;21,5;Köln\n1;22,0;Köln\n".encode("latin-1"))
    got, _ = read(path)
    np.testing.assert_array_equal(got["Temperatur (°C)"][1], [21.5, 22.0])


def test_fast_numeric_path_equals_the_careful_path():
    """A column of plain numbers is converted by Arrow's cast in one pass; anything the
    careful path treats specially (blanks, text, booleans, nan/inf, padding) falls back,
    and both give the same values."""
    import pyarrow as pa

    from analyzer.readers.csv_reader import _all_numbers

    clean = pa.array(["1.5", "-2e-3", "+.5", "5.", "-0", "1E+05", "123456789.123456789"])
    fast = _all_numbers(clean)
    assert fast is not None
    np.testing.assert_array_equal(fast, [1.5, -2e-3, 0.5, 5.0, -0.0, 1e5, 123456789.123456789])
    for odd in ("", " 1.5", "true", "nan", "inf", "1,5", "abc"):
        assert _all_numbers(pa.array(["1.0", odd])) is None, odd
