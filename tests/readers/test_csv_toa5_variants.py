"""Campbell Scientific TOA5 tables as they reach an analysis: straight from LoggerNet or
CardConvert, and opened in a spreadsheet and saved again (no quotes, rows padded with
separators to the widest line). The tables are written here by :func:`toa5`."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from readers_helpers import T0, collect

from analyzer.inspect import inspect_archive
from analyzer.readers import open_input

N = 400
TEN_MS = 10_000_000


def toa5(
    path: Path,
    data: np.ndarray,
    *,
    quoted: bool = True,
    record_unit: str = "RN",
    pad: int = 0,
    nan_every: int = 0,
) -> None:
    """A TOA5 table: station line, field names, units, processing, then rows of a
    ``TIMESTAMP`` at 100 Hz from :data:`T0`, a ``RECORD`` count and ``data``'s columns
    (``Acc1``...; ``"NAN"`` in every ``nan_every``-th row of the second). ``quoted``:
    as the logger writes it, else as a spreadsheet saves it again, every line padded
    with ``pad`` empty fields."""
    names = ["TIMESTAMP", "RECORD", *(f"Acc{k + 1}" for k in range(data.shape[1]))]
    station = [
        "TOA5",
        "Bridge_N",
        "CR1000X",
        "31337",
        "CR1000X.Std.05.02",
        "CPU:shm.CR1X",
        "7",
        "Acc",
    ]
    units = ["TS", record_unit, *("g" for _ in range(data.shape[1]))]
    process = ["", "", *("Smp" for _ in range(data.shape[1]))]
    stamps = np.datetime_as_string(np.datetime64(T0, "ns") + np.arange(len(data)) * TEN_MS, "ms")
    q = '"' if quoted else ""
    width = max(len(station), len(names)) + pad if not quoted else 0

    def line(cells: list[str], quote: bool = True) -> str:
        text = [f"{q}{c}{q}" if quote else c for c in cells]
        return ",".join(text + [""] * max(0, width - len(text))) + "\r\n"

    rows = []
    for i, row in enumerate(data):
        cells = [f"{v:.5f}" for v in row]
        if nan_every and i % nan_every == 3:
            cells[1] = f"{q}NAN{q}"
        # as the logger writes them: no trailing zeros (``00:00:01``, ``00:00:01.1``)
        stamp = f"{q}{str(stamps[i]).replace('T', ' ').rstrip('0').rstrip('.')}{q}"
        rows.append(line([stamp, str(i), *cells], quote=False))
    head = line(station) + line(names) + line(units) + line(process)
    path.write_bytes((head + "".join(rows)).encode())


def data(n: int = N) -> np.ndarray:
    return np.round(np.random.default_rng(3).normal(scale=0.01, size=(n, 3)), 5)


def test_a_toa5_table_saved_again_by_a_spreadsheet_is_read_as_the_logger_wrote_it(
    tmp_path: Path,
) -> None:
    """Without its quotes, the station line was a preamble and the processing line the
    header: channels ``Smp``, ``Smp_2``..., ``RECORD`` among them, without a word."""
    values = data()
    original = tmp_path / "CR1000X_Acc.csv"
    toa5(original, values)
    resaved = tmp_path / "CR1000X_Acc_excel.csv"
    toa5(resaved, values, quoted=False, pad=2)
    want = collect(open_input(original).chunks())
    reader = open_input(resaved)
    got = collect(reader.chunks())
    assert set(got) == set(want) == {"Acc1", "Acc2", "Acc3"}
    for name in want:
        np.testing.assert_array_equal(got[name][0], want[name][0])
        np.testing.assert_array_equal(got[name][1], want[name][1])
    np.testing.assert_array_equal(got["Acc1"][0], T0 + TEN_MS * np.arange(N))
    assert reader.info.absolute_time is True and reader.info.errors == []


def test_record_is_a_row_counter_without_its_unit_and_nan_cells_are_gaps(
    tmp_path: Path,
) -> None:
    """A table whose units line leaves ``RECORD`` blank made the row count a channel (a
    ramp, the "sensor" with the strongest drift). ``"NAN"`` (Campbell's missing value)
    is no sample, counted nowhere as a bad cell."""
    values = data()
    path = tmp_path / "CR1000X_Acc.dat"
    toa5(path, values, record_unit="", nan_every=10)
    doc = inspect_archive([path])
    channels = {c["name"]: c for c in doc["channels"]}
    assert set(channels) == {"Acc1", "Acc2", "Acc3"}
    assert channels["Acc1"]["samples"] == N and channels["Acc2"]["samples"] == N - N // 10
    assert doc["inputs"][0]["errors"] == []
    assert doc["inputs"][0]["time"] == "column 'TIMESTAMP': date-times (UTC where no zone is given)"
    assert doc["start"] == "2026-01-01T00:00:00.000Z"
    got = collect(open_input(path).chunks())
    keep = np.arange(N) % 10 != 3
    np.testing.assert_array_equal(got["Acc2"][0], (T0 + TEN_MS * np.arange(N))[keep])
    np.testing.assert_array_equal(got["Acc2"][1], values[keep, 1])
