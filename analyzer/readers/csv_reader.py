"""CSV / TSV reader (optionally gzip-compressed).

Layout detection, from the first 64 KiB: the separator (``,`` ``;`` tab ``|``: the one that
splits every one of the first 200 non-blank lines into the same number of fields, tab and
``;`` preferred since they rule out a decimal comma; failing that, the one that splits
the longest run of lines at their end alike), the decimal mark (``1,5`` anywhere in the
64 KiB under a ``;``, tab or ``|`` separator; a number with a decimal comma later in such
a file is read as one all the same), the header and the time column.

The header is the line just above the rows (the first lines with the rows' field count
that are as numeric as rows are), when it is less numeric than they are; lines above it
(a logger's metadata such as ``Sample rate: 100 Hz`` or ``station,ABC``, Excel's
``sep=;``, ``#`` comments, blank lines) are skipped without a note (see
:func:`_header_line`). Else the first line is the header, and a header with a field count
no row has is refused by name. A Campbell Scientific TOA5 file (first line ``"TOA5",...``, the
station) has its header on line 2, then a units line and a processing line, which are
skipped; its ``RECORD`` column (units ``RN``) is a row counter, not a channel. A repeated
name gets ``_2``, ``_3``, ... so that two columns never share a channel.

The time column is the first column named ``time``, ``timestamp``, ``__time``, ``%time``
or ``datetime`` (any case); else the first whose name, lowercased and less a
unit, zone or format in brackets (``Time (s)``, ``time [ms]``, ``Timestamp (UTC)``) or a
unit or zone word at its end (``time_s``, ``elapsed_ms``, ``time_utc``), is one of
:data:`TIME_PHRASES` (``time``, ``t [s]``, ``Date/Time``, ``Elapsed Time``, ``Zeit``,
``tiempo``...), or that is ``seconds``; else a column named ``t`` (in ``Time (s),T,RH``
it is a temperature); else the first column. ``timer_count``, ``time_offset_sensor`` or
``temps`` (temperatures, in English) is a channel. A unit in the name scales numeric times:
``ms``, ``us``, ``ns`` and, in brackets only, ``min`` and ``h``.

The body is read by Arrow's streaming CSV reader in blocks, every column as text; each
block is then converted column-wise (trim, numeric test by regular expression, cast): no
Python per row. A column is a channel when its non-blank cells are numbers (``true`` /
``false`` count as 1 / 0); blank cells are gaps, i.e. no sample of that channel on that
row, and so are the odd non-numeric cells of a column that is at least 90 % numbers
(counted in ``info.errors``). The first block where a column has non-blank cells decides;
a column skipped as text although more than half of its cells are numbers is named in
``info.errors`` (a sensor writing many error codes, or one whose first cells were all
text). Fast path, same result: the columns whose first block holds only plain finite
numbers are parsed by Arrow straight to float64 (no text, no cast); from the first block
where one of them does not parse that way (a blank, ``ERR``, ``nan``), the file is read
again as text (see :meth:`CsvReader._stream`).

The time column holds seconds or the unit its name gives (decimal text is converted to
integer nanoseconds exactly), integer nanoseconds (integers above 1e15, unless its name
gives a unit other than seconds), times of day or elapsed times without a date
(``hh:mm:ss[.f]``: relative times, a step back of more than half a day being the next
day) or date-time strings (ISO 8601 or any format pandas recognises; UTC where no zone is
given). Its kind is that of at least 90 % of the first block's non-blank cells, so that a
units line, a repeated header or a run of zero bytes under the header costs its rows
(counted in ``info.errors``), not the file. Times below 1e8 s (before 1973) are taken as
relative time: ``InputInfo.absolute_time`` is False. Times after the year 2262 (epoch
milliseconds in a column whose name does not say ``ms``, say) are not times: int64
nanoseconds cannot hold them.
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
"""Names of a time column (any case), preferred to the names :func:`_time_unit` accepts."""
TIME_PHRASES = frozenset(
    {
        *("time", "timestamp", "time stamp", "t", "datetime", "date time"),
        *("elapsed", "elapsed time", "time elapsed"),
        *("zeit", "zeitstempel", "datum zeit", "uhrzeit"),  # German
        *("horodatage", "date heure"),  # French ("temps" is English temperatures too)
        *("tiempo", "tempo"),  # Spanish, Italian, Portuguese
    }
)
"""Words of a time column's name once its unit and case are gone (see :func:`_time_unit`)."""
TIME_UNITS = {"s": (9, 1), "ms": (6, 1), "us": (3, 1), "ns": (0, 1), "min": (9, 60), "h": (9, 3600)}
"""Of a time column's unit: (decimal digits, integer factor), a value in that unit being
``value * 10**digits * factor`` nanoseconds (exact decimal scaling, see :func:`_exact_ns`)."""
_UNIT_NAMES = {"s": "seconds", "ms": "milliseconds", "us": "microseconds", "ns": "nanoseconds"}
_UNIT_NAMES |= {"min": "minutes", "h": "hours"}
_SUFFIX_UNITS = {
    **dict.fromkeys(("s", "sec", "secs", "second", "seconds"), "s"),
    **dict.fromkeys(("ms", "msec", "msecs", "millisecond", "milliseconds"), "ms"),
    **dict.fromkeys(("us", "µs", "μs", "usec", "usecs", "microsecond", "microseconds"), "us"),
    **dict.fromkeys(("ns", "nsec", "nsecs", "nanosecond", "nanoseconds"), "ns"),
}
"""Units a time column's name may end with (``time_ms``, ``Time [ms]``)."""
_BRACKET_UNITS = {
    **_SUFFIX_UNITS,
    **dict.fromkeys(("min", "mins", "minute", "minutes"), "min"),
    **dict.fromkeys(("h", "hr", "hrs", "hour", "hours"), "h"),
}
"""Units in brackets only: ``time_min`` might be the least time, ``time (min)`` is not."""
_BARE_UNITS = {"seconds": "s", "secs": "s", "sec": "s", "milliseconds": "ms"}
"""Units that name a time column by themselves (``h`` or ``min`` alone would not)."""
_ZONE_WORDS = frozenset({"utc", "gmt", "local", "lt"})
_BRACKETED = re.compile(r"(.*?)[\s_]*[(\[{]\s*(.*?)\s*[)\]}]")
"""A name ending in brackets (its unit, zone or format)."""
_TIME_NOTE = re.compile(
    r"utc|gmt|local|lt|z|(?:utc|gmt)?\s*[-+]\d{1,2}(?::?\d{2})?"
    r"|[ymdhsfzt]+(?:[-:./ ]+[ymdhsfzt]+)+"
)
"""Bracketed words of a time column that are no unit: a zone (``UTC``, ``+01:00``) or a
format (``hh:mm:ss``, ``yyyy-mm-dd hh:mm:ss``)."""
_WORD_BREAK = re.compile(r"[\W_]+")
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

FINITE = r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$"
NUMBER = FINITE + r"|^(?i:[-+]?(inf|infinity|nan))$"
INTEGER = r"^[-+]?\d+$"
BOOLEAN = r"^(?i:true|false)$"
NUMBER_OR_BOOLEAN = f"(?:{NUMBER})|(?:{BOOLEAN})"
"""Both in one pass: text columns are counted in every block (see :meth:`CsvReader._counts`)."""
TIME_OF_DAY = r"^\d+:\d{2}:\d{2}(?:\.\d{1,9})?$"
"""A time of day or an elapsed time without a date (``hh:mm:ss[.f]``)."""
DAY_NS = 86_400_000_000_000
"""Nanoseconds in a day: a time of day that steps back by more than half of it is the
next day's."""
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
DECIMAL_COMMA_CELL = r"^([-+]?\d*),(\d+(?:[eE][-+]?\d+)?)$"
"""A trimmed cell that is a number with a decimal comma (the digits before the comma in
group 1, those after it in group 2): in a ``;``, tab or ``|`` file whose 64 KiB sample
shows none, a later one is still a number (see :meth:`CsvReader._clean`)."""
_DIGIT_COMMA = re.compile(r",\d")
_FINITE = re.compile(FINITE)
LAYOUT_LINES = 200
"""Non-blank lines (of the 64 KiB sample) from which the separator and the header are
found: a logger's preamble may be tens of lines long."""
TOA5 = '"TOA5",'
"""How a Campbell Scientific TOA5 file starts: its station line, then the header, a
units line and a processing line (``Smp``, ``Avg``...) above the rows."""
_LINE_BREAK = re.compile(r"\r\n|\r|\n")


@dataclass(frozen=True, slots=True)
class _Layout:
    separator: str
    decimal_comma: bool
    names: tuple[str, ...]
    time_column: int
    compressed: bool
    encoding: str
    skip_rows: int = 1
    """Lines above the first row (header, preamble, units lines, blank lines)."""
    time_unit: str = "s"
    """The time column's unit when its values are numbers (a key of :data:`TIME_UNITS`)."""
    ignored: tuple[int, ...] = ()
    """Columns that are no channel (a TOA5 file's ``RECORD`` row counter)."""


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
        self._notes: list[str] = []
        """What the row handler of :meth:`_batches` found, for ``info.errors``."""
        self._layout = self._detect()
        self._numeric: dict[int, bool] = {}
        self._fast: tuple[int, ...] = ()
        self._time_kind = ""
        self._time_format: str | None = None
        self._iso_type: pa.DataType = pa.timestamp("ns", "UTC")
        self._clock = (0, 0)
        """Of a time-of-day column: (days passed, last time of day read), for midnight."""
        first_time = self._inspect_first_block()
        total, sha = file_digest([self.path])
        self.info = InputInfo(self.path, Format.CSV, size_bytes=total, sha256=sha)
        self.info.absolute_time = self._time_kind in ("ns", "datetime") or (
            self._time_kind == "seconds"
            and first_time is not None
            and first_time >= EPOCH_THRESHOLD_S * 1e9
        )
        self._first_time = first_time
        self.info.time = self._time_text()

    def _time_text(self) -> str:
        """Which column holds the time and how its cells are read (``InputInfo.time``)."""
        name = self._layout.names[self._layout.time_column]
        kind = self._time_kind
        if kind == "ns":
            how = "integer nanoseconds since 1970 (UTC)"
        elif kind == "datetime":
            how = "date-times (UTC where no zone is given)"
        elif kind == "timeofday":
            how = "times of day, relative"
        else:
            how = _UNIT_NAMES[self._layout.time_unit] + (
                " since 1970 (UTC)" if self.info.absolute_time else ", relative"
            )
        return f"column {name!r}: {how}"

    # ------------------------------------------------------------------ protocol
    def start_ns(self) -> int | None:
        return self._first_time

    def chunks(self, time: TimeSource = "log") -> Iterator[ChannelChunk]:
        del time  # CSV rows have one time only
        self.fraction_read = 0.0
        reorder = Reorderer()
        skipped = 0
        bad_cells: dict[str, int] = {}
        text_cells: dict[str, tuple[int, int]] = {}  # skipped columns: (non-blank, numbers)
        filled: set[int] = set()  # columns Arrow parsed as numbers in some block
        rows = 0
        self._clock = (0, 0)
        try:
            for batch, invalid in self._stream():
                skipped += invalid
                t_ns, keep = self._times(batch.column(self._layout.time_column))
                rows += batch.num_rows
                dropped = int(np.count_nonzero(~keep))
                skipped += dropped
                # one time array for every float64 column (the reorderer works out the
                # order of shared times once); the values are Arrow's, viewed
                t_kept = t_ns[keep] if dropped else t_ns
                for index, name in enumerate(self._layout.names):
                    if index == self._layout.time_column or index in self._layout.ignored:
                        continue
                    column = batch.column(index)
                    if column.type == pa.float64():  # parsed by Arrow: all finite numbers
                        filled.add(index)
                        values = _numpy(column)
                        reorder.push(name, t_kept, values[keep] if dropped else values)
                        continue
                    if index not in self._numeric:
                        decision = self._classify(column)
                        if decision is None:
                            continue
                        self._numeric[index] = decision
                    if not self._numeric[index]:
                        nonblank, numbers = self._counts(column)
                        seen = text_cells.get(name, (0, 0))
                        text_cells[name] = (seen[0] + nonblank, seen[1] + numbers)
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
        for note in self._notes:
            self._error(note)
        if skipped:
            self._error(
                f"{skipped} rows without a readable time or with the wrong number of fields skipped"
            )
        for name, count in bad_cells.items():
            self._error(f"{name}: {count} non-numeric cells treated as gaps")
        for name, (nonblank, numbers) in text_cells.items():
            if 2 * numbers > nonblank:  # at most half numbers: a text column by any reading
                self._error(
                    f"{name}: skipped as a text column, though {numbers} of its {nonblank} "
                    "non-blank cells are numbers"
                )
        blank = [
            name
            for index, name in enumerate(self._layout.names)
            if index != self._layout.time_column
            and index not in self._layout.ignored
            and index not in self._numeric
            and index not in filled
            and name != f"column{index}"  # no header either: a trailing separator
        ]
        if rows and blank:
            # (a column blank in every row had no note: it vanished from inspect)
            self._error(f"{', '.join(blank)}: blank in every row; no channel")
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
        if head.startswith((b"\xff\xfe", b"\xfe\xff")):  # its zero bytes are not binary data
            raise ReaderError(
                f'{self.path}: UTF-16 text (a spreadsheet\'s "Unicode text" export?), which '
                "is not read: save it as UTF-8 CSV"
            )
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
        # the lines as Arrow counts them (blank ones too: see _Layout.skip_rows)
        physical = sample.replace("\r\n", "\n").replace("\r", "\n").split("\n")
        cut = len(head) == SAMPLE_BYTES
        if cut and len(physical) > 1:
            physical = physical[:-1]  # the last line may be cut
        numbered = [(index, line) for index, line in enumerate(physical) if line.strip()]
        if not numbered:
            raise ReaderError(f"{self.path}: no header line")
        if "\x00" in sample:
            raise ReaderError(f"{self.path}: not a text file (binary data)")
        lines = [line for _, line in numbered]
        toa5 = lines[0].startswith(TOA5)
        if toa5:
            separator, header, first_row = ",", 1, 4
        else:
            separator = self._separator(lines[:LAYOUT_LINES])
            open_end = not cut and len(lines) <= LAYOUT_LINES and bool(physical[-1].strip())
            header = _header_line(lines[:LAYOUT_LINES], separator, open_end)
            first_row = header + 1
        if first_row >= len(lines) and (toa5 or not cut):  # a header alone
            raise ReaderError(f"{self.path}: no data rows (a header line only)")
        names = _unique(
            [h.strip() or f"column{i}" for i, h in enumerate(_fields(lines[header], separator))]
        )
        if len(names) < 2:
            raise ReaderError(f"{self.path}: no numeric column (a single column {names[0]!r})")
        time_column, time_unit = _time_column(names)
        ignored: tuple[int, ...] = ()
        if toa5:  # the units line names the row counter RN
            units = _fields(lines[2], separator)
            ignored = tuple(i for i, u in enumerate(units[: len(names)]) if u.strip() == "RN")
        # the whole sample decides: a logger's first rows may all be integers
        body = lines[first_row:]
        decimal_comma = (
            separator != ","
            and _DIGIT_COMMA.search("\n".join(body)) is not None
            and any(
                _DECIMAL_COMMA.match(cell)
                for row in csv.reader(body, delimiter=separator)
                for cell in row
            )
        )
        return _Layout(
            separator,
            decimal_comma,
            tuple(names),
            time_column,
            compressed,
            encoding,
            skip_rows=numbered[min(first_row, len(numbered)) - 1][0] + 1,
            time_unit=time_unit,
            ignored=ignored,
        )

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
        # lines above the header (a logger's metadata, Excel's "sep=;"): the separator
        # that splits the longest run of lines at the end alike, in two fields or more
        longest = 1
        for separator in SEPARATORS:
            counts = [len(_fields(line, separator)) for line in lines]
            run = next((i for i, c in enumerate(reversed(counts)) if c != counts[-1]), len(counts))
            if counts[-1] >= 2 and run > longest:
                best, longest = separator, run
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

        def skip_row(row: Any) -> str:
            # a cell opening a quote that is never closed joins the lines up to the next
            # quote (or the end of the file) into this one bad row: count them all
            lines = len(_LINE_BREAK.split(str(getattr(row, "text", "") or "").rstrip("\r\n")))
            invalid[0] += lines
            if lines > 1:
                number = getattr(row, "number", None)
                at = f" at line {number}" if isinstance(number, int) and number > 0 else ""
                note = f"a quote opened{at} is never closed: {lines} lines read as one row, skipped"
                if note not in self._notes:
                    self._notes.append(note)
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
                skip_rows=layout.skip_rows,
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
            # the rows are there (a header alone is found by _detect) but Arrow skipped
            # them all for their number of fields: a damaged header, or lines above it
            # that _header_line did not tell from the header
            raise ReaderError(
                f"{self.path}: no data rows: no line under the first has its "
                f"{len(self._layout.names)} fields (is the first line the header?)"
            )
        numeric = []
        fast = []
        for index in range(len(self._layout.names)):
            if index == self._layout.time_column or index in self._layout.ignored:
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
        time_column = batch.column(self._layout.time_column)
        t_ns, keep = self._times(time_column, first=True)
        if not bool(keep.any()):
            name = self._layout.names[self._layout.time_column]
            text = self._clean(time_column)
            numbers = text.filter(pc.match_substring_regex(text, FINITE))
            if self._time_kind in ("seconds", "ns") and len(numbers):
                # numbers that int64 nanoseconds cannot hold, such as epoch milliseconds
                # read as seconds: say so, not that there are no numbers
                unit = "ns" if self._time_kind == "ns" else self._layout.time_unit
                raise ReaderError(
                    f"{self.path}: time column {name!r}: {numbers[0].as_py()!r} is no time: "
                    f"as {_UNIT_NAMES[unit]} it lies outside the years 1677-2262"
                    + (
                        " (epoch milliseconds? a name such as 'time [ms]' says so)"
                        if unit == "s"
                        else ""
                    )
                )
            raise ReaderError(f"{self.path}: time column {name!r} holds neither numbers nor dates")
        return int(t_ns[keep].min())

    # ------------------------------------------------------------------ conversion
    def _clean(self, column: pa.Array) -> pa.Array:
        """The cells trimmed, with a decimal point for a decimal comma: every comma in a
        file whose sample shows decimal commas; else, under a ``;``, tab or ``|``
        separator, that of a cell that is a number but for it (a logger whose first
        64 KiB of values happened to be integers, ``12;0;3``, then ``12,5;0,25``)."""
        text = pc.utf8_trim_whitespace(column)
        if self._layout.decimal_comma:
            return pc.replace_substring(text, ",", ".")
        if self._layout.separator != "," and pc.any(pc.match_substring(text, ",")).as_py():
            return pc.replace_substring_regex(text, DECIMAL_COMMA_CELL, r"\1.\2")
        return text

    def _classify(self, column: pa.Array) -> bool | None:
        """True: numeric, False: text, None: only blanks so far."""
        nonblank, numeric = self._counts(column)
        if nonblank == 0:
            return None
        return numeric >= NUMERIC_SHARE * nonblank

    def _counts(self, column: pa.Array) -> tuple[int, int]:
        """(non-blank cells, cells that are numbers or booleans) of a text column."""
        text = self._clean(column)
        nonblank = int(pc.sum(pc.not_equal(text, "")).as_py() or 0)
        if nonblank == 0:
            return 0, 0
        ok = pc.match_substring_regex(text, NUMBER_OR_BOOLEAN)
        return nonblank, int(pc.sum(ok).as_py() or 0)

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
        """Integer nanoseconds of the time column and the mask of rows that have one.
        Numbers are in the column's unit (:attr:`_Layout.time_unit`); in seconds,
        integers above :data:`NS_THRESHOLD` are nanoseconds, in a unit its name gives
        they are not."""
        text = self._clean(column)
        if first or not self._time_kind:
            self._time_kind = self._time_kind_of(text)
            if self._time_kind == "ns" and self._layout.time_unit != "s":
                self._time_kind = "seconds"  # numbers in the named unit
            self._clock = (0, 0)
        n = len(text)
        if self._time_kind == "datetime":
            return self._datetimes(text)
        if self._time_kind == "timeofday":
            return self._times_of_day(text)
        number = pc.match_substring_regex(text, NUMBER)
        keep = np.asarray(pc.fill_null(number, False).to_numpy(zero_copy_only=False), dtype=bool)
        out = np.zeros(n, dtype=np.int64)
        if not keep.any():
            return out, keep
        idx = np.nonzero(keep)[0]
        selected = text.take(pa.array(idx))
        nanoseconds = self._time_kind == "ns" and bool(
            pc.all(pc.match_substring_regex(selected, INTEGER)).as_py()
        )
        if nanoseconds:
            with contextlib.suppress(pa.ArrowInvalid):  # beyond int64: the exact path's
                out[idx] = _numpy(pc.cast(selected, pa.int64()))
                return out, keep
        digits, factor = (0, 1) if nanoseconds else TIME_UNITS[self._layout.time_unit]
        exact = _exact_ns(selected, digits)
        if exact is not None:
            ns, fits = exact
            if factor != 1:  # minutes, hours: whole multiples of 1e9 ns
                fits &= np.abs(ns) <= _NS_MAX // factor
                ns = np.where(fits, ns, 0) * factor
        else:  # exponent notation, more decimals than digits or 38 digits: via float64
            with np.errstate(invalid="ignore", over="ignore"):
                scaled = np.round(_numpy(pc.cast(selected, pa.float64())) * (10.0**digits * factor))
            fits = np.abs(scaled) < 2.0**63  # False for nan and inf too
            ns = np.where(fits, scaled, 0).astype(np.int64)
        keep[idx[~fits]] = False
        out[idx[fits]] = ns[fits]
        return out, keep

    @staticmethod
    def _time_kind_of(text: pa.Array) -> str:
        """The kind of at least :data:`NUMERIC_SHARE` of the non-blank cells: one units
        line, repeated header or run of zero bytes from a power loss in the first block
        is a row without a time (skipped and counted), not a file of date-time text."""
        # a cell's length as a boolean: no Python value passes into Arrow, which would
        # import pandas (pyarrow checks every such value for a pandas type)
        nonblank = text.filter(pc.cast(pc.utf8_length(text), pa.bool_()))
        if len(nonblank) == 0:
            return "seconds"
        least = NUMERIC_SHARE * len(nonblank)
        numbers = pc.match_substring_regex(nonblank, NUMBER)
        if int(pc.sum(numbers).as_py() or 0) < least:
            clock = pc.match_substring_regex(nonblank, TIME_OF_DAY)
            return "timeofday" if int(pc.sum(clock).as_py() or 0) >= least else "datetime"
        numeric = nonblank.filter(numbers)
        integers = pc.match_substring_regex(numeric, INTEGER)
        if pc.all(integers).as_py():
            largest = pc.max(pc.abs(pc.cast(numeric, pa.float64()))).as_py()
            if largest is not None and largest > NS_THRESHOLD:
                return "ns"
        return "seconds"

    def _times_of_day(self, text: pa.Array) -> tuple[IntArray, np.ndarray]:
        """Nanoseconds of ``hh:mm:ss[.f]`` cells from the midnight before the first one.

        pandas would give such a cell today's date (a different absolute time on every
        run); it is a relative time instead, and a step back of more than half a day
        (23:59:59 to 00:00:00) starts the next day rather than sorting the rows after
        midnight before those of the evening."""
        import pandas as pd

        series = pd.Series(text.to_numpy(zero_copy_only=False), dtype=object)
        clock = pc.match_substring_regex(text, TIME_OF_DAY).to_numpy(zero_copy_only=False)
        parsed = pd.to_timedelta(series.where(clock, None), errors="coerce")
        keep = np.asarray(parsed.notna().to_numpy(), dtype=bool)
        out = np.zeros(len(series), dtype=np.int64)
        if not keep.any():
            return out, keep
        ns = parsed[keep].to_numpy().astype("timedelta64[ns]").astype(np.int64)
        days, last = self._clock
        back = np.diff(ns, prepend=last) < -DAY_NS // 2
        passed = days + np.cumsum(back)
        out[keep] = ns + passed * DAY_NS
        self._clock = (int(passed[-1]), int(ns[-1]))
        return out, keep

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


def _exact_ns(text: pa.Array, scale: int) -> tuple[IntArray, np.ndarray] | None:
    """The decimal numbers of ``text`` times ``10**scale``, exactly (Arrow's decimal
    cast, no float rounding), as int64 with the mask of those that int64 holds; None when
    the cast fails (exponent notation, more than ``scale`` decimals or 38 digits).

    The mask matters: of a number beyond int64 (seconds after the year 2262, such as
    epoch milliseconds read as seconds), the low 64 bits alone are a wrong time."""
    try:
        exact = pc.cast(text, pa.decimal128(38, scale))
    except pa.ArrowException:
        return None
    words = np.frombuffer(exact.buffers()[1], dtype="<i8")
    start = exact.offset * 2
    low = words[start : start + 2 * len(exact) : 2]
    high = words[start + 1 : start + 2 * len(exact) : 2]
    return low, high == (low >> 63)  # the high word only extends the sign: it fits


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
    """``names`` with each repeat of a name suffixed ``_2``, ``_3``, ..., skipping the
    suffixed names the header has itself (``a,a,a_2``: ``a``, ``a_3``, ``a_2``): two
    columns under one name would be read as one channel, their samples mixed."""
    taken = set(names)
    seen: set[str] = set()
    out = []
    for name in names:
        unique = name
        count = 1
        while unique in seen or (unique != name and unique in taken):
            count += 1
            unique = f"{name}_{count}"
        seen.add(unique)
        taken.add(unique)
        out.append(unique)
    return out


def _fields(line: str, separator: str) -> list[str]:
    """The fields of one line (a quote left open takes the rest of the line)."""
    return next(csv.reader([line], delimiter=separator), [])


def _header_line(lines: list[str], separator: str, open_end: bool) -> int:
    """The index of the header among the first non-blank ``lines``.

    The rows' field count is the most common one in the second half of ``lines`` (a
    closing remark such as ``end of log,done`` does not set it). Of the lines with that
    count (``#`` comments aside), the data are those at least as numeric (numbers and
    blank cells among their fields) as the last ten such lines are at the median; the
    header is the line just before the first of them, when it has that count too and
    is less numeric. Else the first line is the header (a header with a field count
    no row has is then refused by name: :meth:`CsvReader._inspect_first_block`). So
    the lines above it, a logger's metadata (``Sample rate: 100 Hz``, ``station,ABC``
    even with the rows' field count), Excel's ``sep=;``, comments or blank lines, are
    skipped, and a header may name columns by numbers (``time,100,200``).

    ``open_end``: the last line is the file's and has no line break, so it may be a row
    cut short (a power loss); with fewer fields than the line before, it is not counted.
    """
    counts = [len(_fields(line, separator)) for line in lines]
    if open_end and len(counts) > 1 and counts[-1] < counts[-2]:
        counts, lines = counts[:-1], lines[:-1]
    tail = counts[len(counts) // 2 :] or counts
    rows = max(set(tail), key=lambda c: (tail.count(c), -tail[::-1].index(c)))
    if rows < 2:
        return 0
    same = [
        i
        for i, (line, count) in enumerate(zip(lines, counts, strict=True))
        if count == rows and not line.lstrip().startswith("#")
    ]

    def numeric(i: int) -> float:
        fields = [f.strip() for f in _fields(lines[i], separator)]
        return sum(1 for f in fields if not f or _FINITE.match(f)) / len(fields)

    scores = {i: numeric(i) for i in same}
    typical = float(np.median([scores[i] for i in same[-10:]]))
    first = next((i for i in same if scores[i] >= typical), None)
    if first is None or first == 0:
        return 0
    before = first - 1
    if before in scores and scores[before] < typical:
        return before
    if first == same[0] and not any(
        _FINITE.match(f.strip()) for f in _fields(lines[first], separator)
    ):
        return first  # a header under a preamble, and no row (a header alone)
    return 0


def _time_column(names: list[str]) -> tuple[int, str]:
    """The index of the time column and its unit: the first of :data:`TIME_NAMES` among
    ``names`` (any case) but ``t``, else the first name :func:`_time_unit` accepts, else
    a column named ``t``, else the first column (in seconds). A bare ``t`` comes last: in
    ``Time (s),T,RH`` it is a temperature."""
    lowered = [n.strip().lower() for n in names]
    exact = next((lowered.index(n) for n in TIME_NAMES if n != "t" and n in lowered), None)
    if exact is not None:
        return exact, "s"
    for index, name in enumerate(names):
        unit = None if lowered[index] == "t" else _time_unit(name)
        if unit is not None:
            return index, unit
    return (lowered.index("t") if "t" in lowered else 0), "s"


def _time_unit(name: str) -> str | None:
    """The unit (a key of :data:`TIME_UNITS`) of a column whose name says it is the time,
    else None. Lowercased, less a bracketed unit (``Time (s)``, ``time [ms]``), zone or
    format (``Timestamp (UTC)``, ``Zeit [hh:mm:ss]``), or else a trailing unit or zone
    word (``time_s``, ``t_msec``, ``time_utc``), its words must be one of
    :data:`TIME_PHRASES` (``Date/Time``: ``date time``); or the name is a unit by itself
    (``seconds``). Conservative: ``time_offset_sensor``, ``timer_count``, ``runtime``,
    ``time (sensor a)`` and ``time_min`` (minutes, or the least time?) are channels."""
    text = name.strip().lower()
    unit = "s"
    bracketed = _BRACKETED.fullmatch(text)
    if bracketed:
        text, note = bracketed.groups()
        if note in _BRACKET_UNITS:
            unit = _BRACKET_UNITS[note]
        elif not _TIME_NOTE.fullmatch(note):
            return None
    words = [w for w in _WORD_BREAK.split(text) if w]
    if not bracketed and len(words) > 1 and words[-1] in _SUFFIX_UNITS:
        unit = _SUFFIX_UNITS[words.pop()]
    elif len(words) > 1 and words[-1] in _ZONE_WORDS:
        words.pop()
    phrase = " ".join(words)
    if phrase in TIME_PHRASES:
        return unit
    if not bracketed and phrase in _BARE_UNITS:
        return _BARE_UNITS[phrase]
    return None
