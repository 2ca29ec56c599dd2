"""CSV / TSV reader (optionally gzip-compressed).

Layout detection, from the first lines: the separator (``,`` ``;`` tab ``|``: the one that
splits every sample line into the same number of fields, tab and ``;`` preferred since
they rule out a decimal comma), the decimal mark (``1,5`` under a ``;`` or tab separator),
the header (first line) and the time column: the first column named ``time``,
``timestamp``, ``t``, ``__time``, ``%time`` or ``datetime`` (any case), else the first
column.

The body is read by Arrow's streaming CSV reader in blocks, every column as text; each
block is then converted column-wise (trim, numeric test by regular expression, cast): no
Python per row. A column is a channel when its non-blank cells are numbers (``true`` /
``false`` count as 1 / 0); blank cells are gaps, i.e. no sample of that channel on that
row, and so are the odd non-numeric cells of a column that is at least 90 % numbers
(counted in ``info.errors``). Fast path, same result: the columns whose first block holds
only plain finite numbers are parsed by Arrow straight to float64 (no text, no cast); from
the first block where one of them does not parse that way (a blank, ``ERR``, ``nan``), the
file is read again as text (see :meth:`CsvReader._stream`).

The time column holds seconds (decimal text is converted to integer nanoseconds exactly),
integer nanoseconds (integers above 1e15) or date-time strings (ISO 8601 or any format
pandas recognises; UTC where no zone is given). Seconds below 1e8 (before 1973) are taken
as relative time: ``InputInfo.absolute_time`` is False.
"""

from __future__ import annotations

import contextlib
import csv
import gzip
import re
import warnings
from collections.abc import Generator, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv

from analyzer.errors import ReaderError
from analyzer.readers._common import FloatArray, IntArray, Reorderer, file_digest, one_line
from analyzer.readers.base import ChannelChunk, InputInfo, TimeSource

if TYPE_CHECKING:  # pandas is imported where a time column needs it: MCAP and bag runs,
    import pandas as pd  # and CSVs with numeric or ISO times, never load it (~0.3 s)
from analyzer.types import Format

TIME_NAMES = ("time", "timestamp", "t", "__time", "%time", "datetime")
SEPARATORS = ("\t", ";", ",", "|")
SAMPLE_BYTES = 1 << 16
BLOCK_BYTES = 1 << 20
"""Bytes of text per block Arrow parses. Its streaming reader reads up to ~32 blocks ahead
of the one it parses (96 MB at 4 MiB blocks, and the next file is read on a thread at
the same time): reading the 4-hour, 16-channel CSV archive peaked at 548-572 MB with 4
MiB blocks and at 378-398 MB with 1 MiB, in 2.73-2.80 s of CPU instead of 3.14-3.83 (512
KiB: 354 MB but slower again, 256 KiB slower still)."""
NS_THRESHOLD = 1e15
"""Integer times above this are nanoseconds."""
EPOCH_THRESHOLD_S = 1e8
"""Times in seconds at or above this are Unix times; below, relative times."""

NUMERIC_SHARE = 0.9
"""A column is numeric when at least this share of its non-blank cells are numbers (a
logger writing the odd ``ERR`` does not turn a sensor channel into text)."""

NUMBER = r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^(?i:[-+]?(inf|infinity|nan))$"
INTEGER = r"^[-+]?\d+$"
BOOLEAN = r"^(?i:true|false)$"
FORMAT_SAMPLE = 200
"""Leading time cells from which the date-time format of a file is chosen."""
PLAIN_ISO = (
    r"^\d{4}-\d{2}-\d{2}[T ](?:[01]\d|2[0-3]):[0-5]\d:[0-5]\d(?:\.\d{1,9})?"
    r"(?:Z|[+-](?:[01]\d|2[0-3]):?[0-5]\d)?$"
)
_NS_MIN = -9223372036854775807
"""``pd.Timestamp.min`` in ns (pandas' NaT is one below)."""
_NS_MAX = 9223372036854775807
"""``pd.Timestamp.max`` in ns."""
"""Dates outside what int64 nanoseconds can hold (years 1677-2262) are not times."""
_DECIMAL_COMMA = re.compile(r"^\s*[-+]?\d+,\d+\s*$")


@dataclass(frozen=True, slots=True)
class _Layout:
    separator: str
    decimal_comma: bool
    names: tuple[str, ...]
    time_column: int
    compressed: bool
    encoding: str


class CsvReader:
    """One CSV/TSV file."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        try:
            size = self.path.stat().st_size
        except OSError as err:
            raise ReaderError(f"{self.path}: cannot read: {one_line(err.strerror or err)}") from err
        if size == 0:
            raise ReaderError(f"{self.path}: empty file (0 bytes)")
        self._size = size
        self.fraction_read = 0.0
        """The share of the file :meth:`chunks` has got through (see ``Reader``)."""
        self._layout = self._detect()
        self._numeric: dict[int, bool] = {}
        self._fast: tuple[int, ...] = ()
        self._time_kind = ""
        self._time_format: str | None = None
        self._iso_type: pa.DataType = pa.timestamp("ns", "UTC")
        first_time = self._inspect_first_block()
        total, sha = file_digest([self.path])
        self.info = InputInfo(self.path, Format.CSV, size_bytes=total, sha256=sha)
        self.info.absolute_time = self._time_kind != "seconds" or (
            first_time is not None and first_time >= EPOCH_THRESHOLD_S * 1e9
        )
        self._first_time = first_time

    # ------------------------------------------------------------------ protocol
    def start_ns(self) -> int | None:
        return self._first_time

    def chunks(self, time: TimeSource = "log") -> Iterator[ChannelChunk]:
        del time  # CSV rows have one time only
        self.fraction_read = 0.0
        reorder = Reorderer()
        skipped = 0
        bad_cells: dict[str, int] = {}
        try:
            for batch, invalid in self._stream():
                skipped += invalid
                t_ns, keep = self._times(batch.column(self._layout.time_column))
                dropped = int(np.count_nonzero(~keep))
                skipped += dropped
                # one time array for every float64 column (the reorderer works out the
                # order of shared times once); the values are Arrow's, viewed
                t_kept = t_ns[keep] if dropped else t_ns
                for index, name in enumerate(self._layout.names):
                    if index == self._layout.time_column:
                        continue
                    column = batch.column(index)
                    if column.type == pa.float64():  # parsed by Arrow: all finite numbers
                        values = _numpy(column)
                        reorder.push(name, t_kept, values[keep] if dropped else values)
                        continue
                    if index not in self._numeric:
                        decision = self._classify(column)
                        if decision is None:
                            continue
                        self._numeric[index] = decision
                    if not self._numeric[index]:
                        continue
                    present, values, bad = self._values(column)
                    if bad:
                        bad_cells[name] = bad_cells.get(name, 0) + bad
                    present &= keep
                    reorder.push(name, t_ns[present], values[present])
                yield from reorder.release(None)
        except (pa.ArrowException, OSError, EOFError, ValueError) as err:
            self._error(
                f"unreadable from some point on ({one_line(err)}); the rows before it were read"
            )
        yield from reorder.flush()
        if skipped:
            self._error(
                f"{skipped} rows without a readable time or with the wrong number of fields skipped"
            )
        for name, count in bad_cells.items():
            self._error(f"{name}: {count} non-numeric cells treated as gaps")
        for line in reorder.drop_report():
            self._error(line)

    # ------------------------------------------------------------------ layout
    def _detect(self) -> _Layout:
        try:
            with self.path.open("rb") as raw:
                compressed = raw.read(2) == b"\x1f\x8b"
                raw.seek(0)
                stream = gzip.GzipFile(fileobj=raw) if compressed else raw
                head = stream.read(SAMPLE_BYTES)
        except (OSError, EOFError) as err:
            raise ReaderError(f"{self.path}: cannot read as text ({one_line(err)})") from err
        try:
            sample = head.decode("utf-8-sig")
            encoding = "utf8"
        except UnicodeDecodeError as err:
            if err.start < len(head) - 4:  # not just a character cut by the sample's end
                encoding = "latin1"
                sample = head.decode("latin-1")
            else:
                encoding = "utf8"
                sample = head[: err.start].decode("utf-8-sig")
        lines = sample.splitlines()
        if len(sample) == SAMPLE_BYTES and len(lines) > 1:
            lines = lines[:-1]  # the last line may be cut
        lines = [line for line in lines if line.strip()][:50]
        if not lines:
            raise ReaderError(f"{self.path}: no header line")
        if "\x00" in sample:
            raise ReaderError(f"{self.path}: not a text file (binary data)")
        separator = self._separator(lines)
        header = next(csv.reader([lines[0]], delimiter=separator))
        names = _unique([h.strip() or f"column{i}" for i, h in enumerate(header)])
        if len(names) < 2:
            raise ReaderError(f"{self.path}: no numeric column (a single column {names[0]!r})")
        lowered = [n.lower() for n in names]
        time_column = next((lowered.index(n) for n in TIME_NAMES if n in lowered), 0)
        body = [row for row in csv.reader(lines[1:], delimiter=separator)]
        decimal_comma = separator != "," and any(
            _DECIMAL_COMMA.match(cell) for row in body for cell in row
        )
        return _Layout(separator, decimal_comma, tuple(names), time_column, compressed, encoding)

    def _separator(self, lines: list[str]) -> str:
        name = self.path.name.lower().removesuffix(".gz")
        if name.endswith(".tsv"):
            return "\t"
        best, best_fields = ",", 0.0
        for separator in SEPARATORS:
            counts = [len(row) for row in csv.reader(lines, delimiter=separator)]
            if counts[0] >= 2 and all(c == counts[0] for c in counts):
                return separator
            mean = sum(counts) / len(counts)
            if mean > best_fields:
                best, best_fields = separator, mean
        return best

    # ------------------------------------------------------------------ blocks
    def _stream(self) -> Iterator[tuple[pa.RecordBatch, int]]:
        """The blocks of the body with the count of rows skipped for a wrong number of
        fields since the previous block; the columns of :attr:`_fast` as float64 as long
        as every cell of theirs parses as a finite number, else (from the first block
        where one does not) every column as text.

        Arrow's parse of a float64 column accepts exactly the cells that
        :func:`_all_numbers` accepts after trimming blanks and tabs, with the same
        value, so a fast block equals the text block converted. A block that fails
        (or holds nan/inf, which the text path treats apart) is read again as text by a
        second reader, which parses the blocks before it again without yielding them:
        the blocks are cut at the same places (same block size, same parse options).
        Its row-skip count restarts from the file's beginning; the first block it
        yields carries the difference, so that the total is that of the text read.
        """
        done = 0
        counted = 0
        if self._fast:
            fast = self._batches({self._layout.names[i]: pa.float64() for i in self._fast})
            try:
                for batch, invalid in fast:
                    if not all(_finite(batch.column(i)) for i in self._fast):
                        break
                    yield batch, invalid
                    done += 1
                    counted += invalid
                else:
                    return
            except (pa.ArrowException, OSError, EOFError, ValueError):
                pass  # the text read below meets the same error at the same block
            finally:
                fast.close()
        invalid_total = 0
        for index, (batch, invalid) in enumerate(self._batches()):
            invalid_total += invalid
            if index < done:
                continue
            yield batch, invalid_total - counted
            counted = invalid_total

    def _batches(
        self, types: dict[str, pa.DataType] | None = None
    ) -> Generator[tuple[pa.RecordBatch, int], None, None]:
        """Blocks of the body, every column as text except those in ``types``.

        Arrow's threads are off: its streaming reader parses the blocks one after the
        other either way (same wall time, measured), but with threads it parses blocks
        ahead, which costs CPU for nothing when only the first block is wanted or when a
        float64 read is abandoned, and a reader abandoned with work in flight on Arrow's
        thread pool can hang the interpreter's exit (apache/arrow#43604, #43892)."""
        layout = self._layout
        column_types = {name: pa.string() for name in layout.names}
        column_types.update(types or {})
        invalid = [0]

        def skip_row(_row: object) -> str:
            invalid[0] += 1
            return "skip"

        # how far the reader has got: a block is BLOCK_BYTES of the text (Arrow reads
        # the file itself far ahead); of a .gz, the position in the compressed file
        raw = pa.OSFile(str(self.path))
        blocks = 0
        try:
            stream = pa.CompressedInputStream(raw, "gzip") if layout.compressed else raw
            reader = self._open(stream, column_types, skip_row)
        except BaseException:
            raw.close()
            raise
        try:
            for batch in reader:
                count, invalid[0] = invalid[0], 0
                blocks += 1
                with contextlib.suppress(OSError, pa.ArrowException):
                    at = raw.tell() if layout.compressed else blocks * BLOCK_BYTES
                    self.fraction_read = max(self.fraction_read, min(1.0, at / self._size))
                yield batch, count
        finally:
            reader.close()
            raw.close()

    def _open(
        self, stream: pa.NativeFile, column_types: dict[str, pa.DataType], skip_row: Any
    ) -> pacsv.CSVStreamingReader:
        """Arrow's streaming reader of the body of ``stream`` (see :meth:`_batches`)."""
        layout = self._layout
        return pacsv.open_csv(
            stream,
            read_options=pacsv.ReadOptions(
                column_names=list(layout.names),
                skip_rows=1,
                block_size=BLOCK_BYTES,
                encoding=layout.encoding,
                use_threads=False,
            ),
            parse_options=pacsv.ParseOptions(
                delimiter=layout.separator, invalid_row_handler=skip_row
            ),
            convert_options=pacsv.ConvertOptions(
                column_types=column_types,
                null_values=[],  # a blank or "NaN" cell fails a float64 column: text path
                strings_can_be_null=False,
                quoted_strings_can_be_null=False,
            ),
        )

    def _inspect_first_block(self) -> int | None:
        try:
            with contextlib.closing(self._batches()) as blocks:
                batch = next((b for b, _ in blocks if b.num_rows), None)
        except (pa.ArrowException, OSError, EOFError, ValueError) as err:
            raise ReaderError(f"{self.path}: cannot parse as CSV ({one_line(err)})") from err
        if batch is None:
            raise ReaderError(f"{self.path}: no data rows")
        numeric = []
        fast = []
        for index in range(len(self._layout.names)):
            if index == self._layout.time_column:
                continue
            column = batch.column(index)
            if not self._layout.decimal_comma and _all_numbers(_trimmed(column)) is not None:
                fast.append(index)  # plain numbers only: what _classify calls numeric
                decision: bool | None = True
            else:
                decision = self._classify(column)
            if decision is not None:
                self._numeric[index] = decision
                if decision:
                    numeric.append(index)
        self._fast = tuple(fast)
        if not numeric:
            raise ReaderError(
                f"{self.path}: no numeric column besides the time column "
                f"{self._layout.names[self._layout.time_column]!r}"
            )
        t_ns, keep = self._times(batch.column(self._layout.time_column), first=True)
        if not bool(keep.any()):
            raise ReaderError(
                f"{self.path}: time column {self._layout.names[self._layout.time_column]!r} "
                "holds neither numbers nor dates"
            )
        return int(t_ns[keep].min())

    # ------------------------------------------------------------------ conversion
    def _clean(self, column: pa.Array) -> pa.Array:
        text = pc.utf8_trim_whitespace(column)
        if self._layout.decimal_comma:
            text = pc.replace_substring(text, ",", ".")
        return text

    def _classify(self, column: pa.Array) -> bool | None:
        """True: numeric, False: text, None: only blanks so far."""
        text = self._clean(column)
        nonblank = int(pc.sum(pc.not_equal(text, "")).as_py() or 0)
        if nonblank == 0:
            return None
        ok = pc.or_(pc.match_substring_regex(text, NUMBER), pc.match_substring_regex(text, BOOLEAN))
        numeric = int(pc.sum(ok).as_py() or 0)
        return numeric >= NUMERIC_SHARE * nonblank

    def _values(self, column: pa.Array) -> tuple[np.ndarray, FloatArray, int]:
        """(present mask, values, count of non-numeric non-blank cells)."""
        fast = None if self._layout.decimal_comma else _all_numbers(column)
        if fast is not None:
            return np.ones(fast.shape[0], dtype=bool), fast, 0
        text = self._clean(column)
        number = pc.match_substring_regex(text, NUMBER)
        boolean = pc.match_substring_regex(text, BOOLEAN)
        values = pc.cast(pc.if_else(number, text, pa.scalar(None, pa.string())), pa.float64())
        values = pc.if_else(
            boolean, pc.cast(pc.equal(pc.utf8_lower(text), "true"), pa.float64()), values
        )
        present = np.asarray(pc.is_valid(values).to_numpy(zero_copy_only=False), dtype=bool)
        blank = np.asarray(pc.equal(text, "").to_numpy(zero_copy_only=False), dtype=bool)
        bad = int(np.count_nonzero(~present & ~blank))
        out = values.to_numpy(zero_copy_only=False).astype(np.float64)
        return present, out, bad

    def _times(self, column: pa.Array, *, first: bool = False) -> tuple[IntArray, np.ndarray]:
        """Integer nanoseconds of the time column and the mask of rows that have one."""
        text = pc.utf8_trim_whitespace(column)
        if self._layout.decimal_comma:
            text = pc.replace_substring(text, ",", ".")
        if first or not self._time_kind:
            self._time_kind = self._time_kind_of(text)
        n = len(text)
        if self._time_kind == "datetime":
            return self._datetimes(text)
        number = pc.match_substring_regex(text, NUMBER)
        keep = np.asarray(pc.fill_null(number, False).to_numpy(zero_copy_only=False), dtype=bool)
        out = np.zeros(n, dtype=np.int64)
        if not keep.any():
            return out, keep
        idx = np.nonzero(keep)[0]
        selected = text.take(pa.array(idx))
        if self._time_kind == "ns" and bool(
            pc.all(pc.match_substring_regex(selected, INTEGER)).as_py()
        ):
            out[idx] = _numpy(pc.cast(selected, pa.int64()))
            return out, keep
        try:
            exact = pc.cast(selected, pa.decimal128(38, 9))
            words = np.frombuffer(exact.buffers()[1], dtype="<i8")
            start = exact.offset * 2
            out[idx] = words[start : start + 2 * len(exact) : 2]
        except pa.ArrowException:
            seconds = _numpy(pc.cast(selected, pa.float64()))
            finite = np.isfinite(seconds)
            keep[idx[~finite]] = False
            out[idx[finite]] = np.round(seconds[finite] * 1e9).astype(np.int64)
        return out, keep

    @staticmethod
    def _time_kind_of(text: pa.Array) -> str:
        # a cell's length as a boolean: no Python value passes into Arrow, which would
        # import pandas (pyarrow checks every such value for a pandas type)
        nonblank = text.filter(pc.cast(pc.utf8_length(text), pa.bool_()))
        if len(nonblank) == 0:
            return "seconds"
        numbers = pc.match_substring_regex(nonblank, NUMBER)
        if not pc.all(numbers).as_py():
            return "datetime"
        integers = pc.match_substring_regex(nonblank, INTEGER)
        if pc.all(integers).as_py():
            largest = pc.max(pc.abs(pc.cast(nonblank, pa.float64()))).as_py()
            if largest is not None and largest > NS_THRESHOLD:
                return "ns"
        return "seconds"

    def _datetimes(self, text: pa.Array) -> tuple[IntArray, np.ndarray]:
        if self._time_format is None and _plain_iso(text):
            # the cells pandas samples to choose the format are plain ISO 8601, which
            # its ISO8601 format parses: that is its choice, made without importing
            # pandas (~0.3 s, and more when several files are opened on threads)
            fast = self._iso_datetimes(text)
            if fast is not None:
                self._time_format = "ISO8601"
                return fast, np.ones(fast.shape[0], dtype=bool)
        if self._time_format == "ISO8601":
            fast = self._iso_datetimes(text)
            if fast is not None:
                return fast, np.ones(fast.shape[0], dtype=bool)
        import pandas as pd

        series = pd.Series(text.to_numpy(zero_copy_only=False), dtype=object)
        series = series.where(series != "", None)
        if self._time_format is None:
            self._time_format = _datetime_format(series)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            parsed = pd.to_datetime(series, utc=True, format=self._time_format, errors="coerce")
        lo, hi = pd.Timestamp(_NS_MIN, tz="UTC"), pd.Timestamp(_NS_MAX, tz="UTC")
        in_range = parsed.notna() & (parsed >= lo) & (parsed <= hi)
        keep = np.asarray(in_range.to_numpy(), dtype=bool)
        out = np.zeros(len(series), dtype=np.int64)
        out[keep] = parsed[keep].dt.as_unit("ns").astype("int64").to_numpy()
        return out, keep

    def _iso_datetimes(self, text: pa.Array) -> IntArray | None:
        """Nanoseconds of a block of ISO 8601 times by Arrow's own parser (several times
        faster than pandas), or None when a cell does not parse that way (blank, out of
        range, mixed with and without zone, or any other form): then pandas decides, as
        for any other format. Where Arrow parses a time, it gives the instant pandas
        gives (checked on zones, offsets, fractions, no such day, leap second, the
        int64 range: tests/readers/test_readers_csv.py); the zoned and the zone-less
        form are tried in turn, the one that worked last first."""
        if len(text) == 0:
            return None
        other = pa.timestamp("ns") if self._iso_type.tz is not None else pa.timestamp("ns", "UTC")
        for kind in (self._iso_type, other):
            try:
                parsed = pc.cast(text, kind)
            except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
                continue
            if parsed.null_count:
                return None
            self._iso_type = kind
            out = np.asarray(_numpy(parsed.cast(pa.int64())), dtype=np.int64)
            if int(out.min()) < _NS_MIN:  # pandas' NaT: not a time
                return None
            return out
        return None

    def _error(self, line: str) -> None:
        if line not in self.info.errors:
            self.info.errors.append(line)


def _all_numbers(column: pa.Array) -> FloatArray | None:
    """The column as float64 when every cell is a plain finite number (Arrow's own
    string-to-float conversion, one pass), else None: blanks, text, booleans, spelled-out
    nan/inf and anything else unusual go the careful way (:meth:`CsvReader._values`)."""
    try:
        values = pc.cast(column, pa.float64())
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
        return None
    if values.null_count:
        return None
    out = np.asarray(_numpy(values), dtype=np.float64)
    return out if bool(np.isfinite(out).all()) else None


_NUMPY_TYPES = {pa.float64(): np.dtype(np.float64), pa.int64(): np.dtype(np.int64)}


def _numpy(array: pa.Array) -> np.ndarray:
    """A float64 or int64 Arrow array without nulls as a read-only numpy view of its
    buffer (what ``to_numpy()`` returns), any other as ``to_numpy(zero_copy_only=False)``.
    pyarrow's ``to_numpy`` imports pandas on its first call (~0.3 s, serialised while the
    files of an archive are opened on threads); a plain CSV needs it nowhere else."""
    dtype = _NUMPY_TYPES.get(array.type)
    if dtype is None or array.null_count:
        return array.to_numpy(zero_copy_only=False)
    data = array.buffers()[1]
    if data is None or len(array) == 0:
        return np.zeros(0, dtype=dtype)
    return np.frombuffer(data, dtype=dtype, count=len(array), offset=array.offset * dtype.itemsize)


def _finite(column: pa.Array) -> bool:
    """Whether every value of a float64 column is finite."""
    return bool(np.isfinite(_numpy(column)).all())


def _trimmed(column: pa.Array) -> pa.Array:
    """``column`` without leading and trailing blanks and tabs: what Arrow's float64
    parse of a CSV cell ignores."""
    return pc.utf8_trim(column, " \t")


def _plain_iso(text: pa.Array) -> bool:
    """Whether the first :data:`FORMAT_SAMPLE` cells of ``text`` (a time column's first
    block, trimmed) are all nonblank and in the plain ISO 8601 form (date, ``T`` or
    blank, hours:minutes:seconds, up to 9 decimals, ``Z`` or an offset): then pandas'
    ``ISO8601`` format parses any of them Arrow parses, which is what
    :func:`_datetime_format` would test."""
    sample = text.slice(0, FORMAT_SAMPLE)
    if len(sample) == 0:
        return False
    return bool(pc.all(pc.match_substring_regex(sample, PLAIN_ISO)).as_py())


def _datetime_format(series: pd.Series) -> str:
    """A format that parses ``series`` (ISO 8601 if it does, else pandas' inference)."""
    import pandas as pd

    sample = series.dropna().iloc[:FORMAT_SAMPLE]
    for fmt in ("ISO8601", None):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)  # "could not infer format"
                pd.to_datetime(sample, utc=True, format=fmt)
        except (ValueError, TypeError):
            continue
        if fmt is None:
            from pandas.tseries.api import guess_datetime_format

            guessed = guess_datetime_format(str(sample.iloc[0])) if len(sample) else None
            return guessed or "mixed"
        return fmt
    return "mixed"


def _unique(names: list[str]) -> list[str]:
    seen: dict[str, int] = {}
    out = []
    for name in names:
        if name in seen:
            seen[name] += 1
            out.append(f"{name}_{seen[name]}")
        else:
            seen[name] = 1
            out.append(name)
    return out
