"""Whether a damaged ``.gz`` read through :class:`~analyzer.readers.csv_reader._Gunzip`
(``CsvReader._inflated_blocks``) can lose rows to a read in flight when its files are
closed by hand, as ``arrow_close_race.py`` found for ``pa.OSFile`` (a script, not a test).

A 20-minute record of the 6-floor building (written by the project's own
``write_archive``) is gzipped and cut at 70 % (a power loss). Again and again, a
streaming reader over ``pa.PythonFile(_Gunzip(path))`` takes the first block and is
given up (as ``CsvReader`` gives up its first block's reader, or a float64 reader), its
``PythonFile`` and ``_Gunzip`` then closed by hand (``--close``, what
``_inflated_blocks`` does) or left to their references (``--no-close``). Next the plain
CSV is read in full through a ``pa.OSFile``, which gets the lowest free descriptor: the
number the given-up ``_Gunzip``'s file just gave back (in the analysis, the next reader
is ``_arrow_blocks``' ``OSFile`` of the ``.gz``), and the damaged ``.gz`` through a new
``_Gunzip``; both reads' rows are counted. The given-up ``_Gunzip`` counts the reads
that end after its close, and how: with text of its own stream (a read already in
progress; a buffered file's close waits for it) or ``ValueError: read of closed file``.
Arrow's ``PythonFile`` refuses later reads before they reach Python ("operation on
closed Python file"), and a closed Python file holds no descriptor number. Forty-fourth
session: no row lost in 1 110 reads closed by hand (benchmarks/README.md). Several at
once on a loaded machine::

    for i in 1 2; do python benchmarks/gunzip_close_race.py --close & \\
        python benchmarks/gunzip_close_race.py --no-close & done
"""

from __future__ import annotations

import argparse
import gzip
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from analyzer.readers.csv_reader import BLOCK_BYTES, _Gunzip  # noqa: E402
from analyzer.simulate import simulate_building  # noqa: E402
from analyzer.writers import write_archive  # noqa: E402


class _Counted(_Gunzip):
    """A ``_Gunzip`` that counts the reads that end after it was closed, and how."""

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        self.late = self.late_text = self.late_raised = 0

    def read(self, size: int = -1) -> bytes | memoryview:
        try:
            out = super().read(size)
        except ValueError:
            self.late += self.closed
            self.late_raised += self.closed
            raise
        self.late += self.closed
        self.late_text += self.closed and len(out) > 0
        return out


def _reader(raw: pa.NativeFile, names: list[str]) -> pacsv.CSVStreamingReader:
    return pacsv.open_csv(
        raw,
        read_options=pacsv.ReadOptions(
            column_names=names, skip_rows=1, block_size=BLOCK_BYTES, use_threads=False
        ),
        parse_options=pacsv.ParseOptions(invalid_row_handler=lambda row: "skip"),
        convert_options=pacsv.ConvertOptions(column_types=dict.fromkeys(names, pa.string())),
    )


def _rows(raw: Any, names: list[str]) -> int:
    reader = _reader(raw, names)
    rows = sum(b.num_rows for b in reader)
    reader.close()
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n", 1)[0])
    ap.add_argument("--close", action=argparse.BooleanOptionalAction, default=True)
    ap.add_argument("--seconds", type=float, default=120.0)
    ap.add_argument("--duration", type=float, default=1200.0, help="seconds of record")
    args = ap.parse_args()
    t, y, names = simulate_building(6, args.duration, 100.0, seed=1)
    with tempfile.TemporaryDirectory(prefix="gunzip-race-") as tmp:
        plain = Path(tmp) / "rec.csv"
        write_archive(
            plain, "csv", np.round(t * 1e9).astype(np.int64), dict(zip(names, y.T, strict=True))
        )
        packed = gzip.compress(plain.read_bytes())
        cut = Path(tmp) / "cut.csv.gz"
        cut.write_bytes(packed[: len(packed) * 7 // 10])
        columns = ["time", *names]
        rows = len(t)
        size = plain.stat().st_size
        end = time.monotonic() + args.seconds
        runs = short = reused = late = late_text = late_raised = 0
        damaged_rows: set[int] = set()
        while time.monotonic() < end:
            gunzip = _Counted(cut)
            source = pa.PythonFile(gunzip, mode="r")
            given_up = _reader(source, columns)
            next(iter(given_up))
            given_up.close()
            number = gunzip._raw.fileno()
            if args.close:
                source.close()
                gunzip.close()
            del source, given_up
            victim = pa.OSFile(str(plain))
            reused += victim.fileno() == number
            got = _rows(victim, columns)
            del victim
            again = _Gunzip(cut)
            damaged_rows.add(_rows(pa.PythonFile(again, mode="r"), columns))
            again.close()
            runs += 1
            late += gunzip.late
            late_text += gunzip.late_text
            late_raised += gunzip.late_raised
            if got != rows:
                short += 1
                print(f"short: {got} rows of {rows}", flush=True)
    mode = "--close" if args.close else "--no-close"
    print(
        f"{mode}: {runs} reads of {size} bytes, "
        f"{short} short ({reused} on the number the given-up .gz file had); reads of the "
        f".gz ending after its close: {late} ({late_text} with text of its own stream, "
        f"{late_raised} raised on the closed file); rows of the "
        f"damaged .gz read in full: {sorted(damaged_rows)}",
        flush=True,
    )
    return 1 if short or len(damaged_rows) > 1 else 0


if __name__ == "__main__":
    sys.exit(main())
