"""Arrow's CSV reader losing rows when a file it still reads ahead is closed by hand: the
cause of the intermittent wrong analysis (a script, not a test).

A 5-minute record of the 6-floor building (30 000 rows, written by the project's own
``write_archive``) is read again and again with pyarrow alone, as ``CsvReader`` read it
before the forty-third session: a streaming reader takes the first block and is given
up (``CsvReader.__init__`` inspecting the first block), its file closed by hand
(``--close``) or left to Arrow's references (``--no-close``, what ``CsvReader`` does
now), and a second reader of the same file reads every row, which are counted. Arrow
reads ahead on its I/O threads; its read loop, after a short read at the end of the
file, asks the descriptor for the rest of its block once more, and a descriptor closed
meanwhile may already be the second reader's (the lowest free number): that reader then
loses ``BLOCK - size % BLOCK`` bytes of rows. Rare: run several at once on a loaded
machine::

    for i in 1 2 3; do python benchmarks/arrow_close_race.py --close & \\
        python benchmarks/arrow_close_race.py --no-close & done

Forty-third session, three of each at once beside other work: see benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from analyzer.simulate import simulate_building  # noqa: E402
from analyzer.writers import write_archive  # noqa: E402

BLOCK = 1 << 20


def _reader(raw: pa.NativeFile, names: list[str]) -> pacsv.CSVStreamingReader:
    return pacsv.open_csv(
        raw,
        read_options=pacsv.ReadOptions(
            column_names=names, skip_rows=1, block_size=BLOCK, use_threads=False
        ),
        convert_options=pacsv.ConvertOptions(column_types=dict.fromkeys(names, pa.string())),
    )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n", 1)[0])
    ap.add_argument("--close", action=argparse.BooleanOptionalAction, default=True)
    ap.add_argument("--seconds", type=float, default=240.0)
    args = ap.parse_args()
    t, y, names = simulate_building(6, 300.0, 100.0, seed=1)
    with tempfile.TemporaryDirectory(prefix="arrow-race-") as tmp:
        path = Path(tmp) / "rec.csv"
        write_archive(
            path, "csv", np.round(t * 1e9).astype(np.int64), dict(zip(names, y.T, strict=True))
        )
        columns = ["time", *names]
        rows = len(t)
        size = path.stat().st_size
        hole = BLOCK - size % BLOCK
        end = time.monotonic() + args.seconds
        runs = short = 0
        while time.monotonic() < end:
            first = pa.OSFile(str(path))
            given_up = _reader(first, columns)
            next(iter(given_up))
            given_up.close()
            if args.close:
                first.close()
            del first, given_up
            second = pa.OSFile(str(path))
            reader = _reader(second, columns)
            got = sum(b.num_rows for b in reader)
            reader.close()
            del second, reader
            runs += 1
            if got != rows:
                short += 1
                print(f"short: {got} rows of {rows} (a hole of {hole} bytes expected)", flush=True)
    mode = "--close" if args.close else "--no-close"
    print(f"{mode}: {runs} reads, {short} short", flush=True)
    return 1 if short else 0


if __name__ == "__main__":
    sys.exit(main())
