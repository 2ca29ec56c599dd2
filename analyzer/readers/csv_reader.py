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
no row has is refused by name. A units line right under the header (``s,m/s^2,mm``,
``[s];[V]``; catman, DEWESoft, LabVIEW exports) is skipped and named in ``info.errors``
with each column's unit (there is no other place for units): under the time column a
time unit, zone or format or nothing, elsewhere short unit-shaped cells, none a number
or ``nan``, and known units among them (all of them where the time column's cell is
blank: see :func:`_is_units`); its time unit scales numeric times as one in the
column's name does. A Campbell Scientific TOA5 file (first line ``"TOA5",...``, the
station, quoted or not) has its header on line 2, then a units line and a processing
line, which are skipped without a note (the format places them); its ``RECORD`` column
(units ``RN``) is a row counter, not a channel. A repeated name gets ``_2``, ``_3``, ...
so that two columns never share a channel.

The time column is the first column named ``time``, ``timestamp``, ``__time``, ``%time``
or ``datetime`` (any case); else the first whose name, lowercased and less a
unit, zone or format in brackets (``Time (s)``, ``time [ms]``, ``Timestamp (UTC)``) or a
unit or zone word at its end (``time_s``, ``elapsed_ms``, ``time_utc``), is one of
:data:`TIME_PHRASES` (``time``, ``t [s]``, ``Date/Time``, ``Elapsed Time``, ``Zeit``,
``tiempo``...), or that is ``seconds``; else a column named ``t`` (in ``Time (s),T,RH``
it is a temperature); else the first column. ``timer_count``, ``time_offset_sensor`` or
``temps`` (temperatures, in English) is a channel. A unit in the name scales numeric times:
``ms``, ``us``, ``ns`` and, in brackets only, ``min`` and ``h``. Relative times there
beside another column named as a time that holds date-times (``time,timestamp``) take
their absolute start from it where the two agree (see :meth:`CsvReader._anchor`).
A file whose columns besides the time are all text opens (``InputInfo.no_numeric``
says so) and yields no channel: ``inspect`` lists it, ``run`` and ``export`` refuse it.

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
gives a unit other than seconds: since 1970 where as nanoseconds they are dates after
1973; where they are no such date as nanoseconds but are as microseconds, refused
naming both readings, epoch microseconds or nanoseconds since boot; else nanoseconds
from another start, relative; epoch milliseconds are refused by name), times of day or elapsed
times without a date (``hh:mm:ss[.f]``: relative times, a step back of more than half a
day being the next day) or date-time strings (ISO 8601 or any format pandas recognises;
UTC where no zone is given). Its kind is that of at least 90 % of the first block's
non-blank cells, so that a units line, a repeated header or a run of zero bytes under
the header costs its rows (counted in ``info.errors``), not the file. Times below 1e8 s
(before 1973: :data:`~analyzer.timeutil.EPOCH_LINE_NS`) are taken as relative time:
``InputInfo.absolute_time`` is False. Times
after the year 2262 (epoch milliseconds in a column whose name does not say ``ms``, say)
are not times: int64 nanoseconds cannot hold them. Times that step back by more than the
reorder window are named in ``info.errors``, with what became of the rows behind; a clock
set back by hours, zone-less local times set back an hour (the change to winter time)
and relative times that start again from the file's first time, or more than half the
way back to it (a logger restarted, :meth:`_Steps._fold`), are
refused by ``run`` and ``export`` (``info.set_back``, see :meth:`CsvReader._set_back`).
A column of dates beside a time column of times of day (``Date,Time``) is joined with it
into date-times (:meth:`CsvReader._join_date`).

Damage: a ``.gz`` whose stream Arrow cannot inflate to its end (cut short, corrupt) is
read again by :class:`_Gunzip`, which stops at the last whole line before the damage, so
that every row before it is read (and the note says how many, up to which time; see
:meth:`CsvReader._blocks`). Of a corrupt stream (not merely cut short), what zlib
inflated between the damage and its error is garbage: the rows are read up to the first
sign of it, the rest of the file dropped (see :class:`_Garbage`). A file that ends
without a line break in a row whose last cell looks cut (see :meth:`CsvReader._cut_row`)
loses that row, as a row cut in an earlier field does. A first line that is a row (every
field a number or a time: a piece of a file without its header) is refused by name, not
taken for channel names.
"""

from __future__ import annotations

import bisect
import contextlib
import csv
import hashlib
import os
import re
import warnings
import zlib
from collections.abc import Callable, Generator, Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv

from analyzer.errors import IntegrityError, ReaderError, capped, counted
from analyzer.readers._common import (
    CLOCKS_APART_NS,
    DST_STEP_NS,
    HASH_BLOCK,
    LEAD_GLITCH_MESSAGES,
    REORDER_WINDOW_NS,
    FloatArray,
    IntArray,
    Reorderer,
    hour_skipped,
    one_line,
)
from analyzer.readers.base import ChannelChunk, InputInfo, TimeSource, check_limit
from analyzer.timeutil import iso_utc, plausible_epoch, seconds_text, spoken_duration

if TYPE_CHECKING:  # pandas is imported where a time column needs it: MCAP and bag runs,
    import pandas as pd  # and CSVs with numeric or ISO times, never load it (~0.3 s)
from analyzer.types import NS_PER_S, Format

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
"""Integer times above this are nanoseconds, since 1970 when as such they are dates after
1973 (:func:`~analyzer.timeutil.plausible_epoch`), from another start when they are no
such date as microseconds either; epoch microseconds (1.77e15), which nanoseconds since
boot may be too, are refused naming both (see :meth:`CsvReader._time_kind_of`)."""

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
DATE_NAMES = frozenset({"date", "datum", "fecha", "data"})
"""Names of a column of dates that goes with a column of times of day (any case; English,
German, Spanish, Italian and Portuguese), see :meth:`CsvReader._join_date`."""
DATE_ONLY = r"^(?:\d{4}[-/.]\d{1,2}[-/.]\d{1,2}|\d{1,2}[-/.]\d{1,2}[-/.]\d{2}(?:\d{2})?)$"
"""A date without a time (``2026-03-29``, ``29.03.2026``, ``03/29/26``)."""
FORMAT_SAMPLE = 200
TAIL_BYTES = 65536
"""The end of a file read for its last time cells (:meth:`CsvReader._tail_cells`)."""
EITHER_WAY = "dates whose day and month could be either way round (no day above 12):"
"""How the line on such dates begins (:meth:`CsvReader.read_day_first` replaces it)."""
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
_INTEGER = re.compile(INTEGER)
_NOT_A_NUMBER = re.compile(r"^(?i:[-+]?(nan|inf|infinity)|na|n/a|#n/a|null|none)$")
"""How writers spell a missing or infinite value in a numeric column (numpy's ``nan``,
R's ``NA``, Excel's ``#N/A``): as numeric as a number where the header is sought."""
LAYOUT_LINES = 200
"""Non-blank lines (of the 64 KiB sample) from which the separator and the header are
found: a logger's preamble may be tens of lines long."""
TOA5 = ('"TOA5",', "TOA5,")
LVM = "LabVIEW Measurement"
"""The first line of an NI LabVIEW measurement file (``.lvm``): its header's ``Date``
and ``Time`` are the start of relative times (:func:`_lvm_start`)."""
LVM_END = "***End_of_Header***"
"""The line that ends each header of an ``.lvm`` file."""
COMMENT_NAMES = frozenset({"comment", "comments"})
"""Header names of a column of remarks, not readings (LabVIEW's ``.lvm`` writes one,
``Comment``, after the channels): blank in every row, it is no channel, said once in
``inspect`` (:attr:`~analyzer.readers.base.InputInfo.skipped`), not called a dead
sensor at every run."""
_LVM_DATE = re.compile(r"^(\d{4})[/-](\d{1,2})[/-](\d{1,2})$")
_LVM_TIME = re.compile(r"^(\d{1,2}):(\d{2}):(\d{2})(?:[.,](\d+))?$")
"""How a Campbell Scientific TOA5 file starts: its station line, then the header, a
units line and a processing line (``Smp``, ``Avg``...) above the rows. Unquoted: the
same table opened in a spreadsheet and saved as CSV again."""
UNIT_CELL_CHARS = 20
"""The longest cell of a units line (``m/s^2``, ``[mV/V]``, ``Deg C``, ``microstrain``)."""
_UNIT_POWER = r"(?:\^\(?[-+]?\d{1,2}\)?|[-+]?[1-9]|[⁻⁺]?[⁰¹²³⁴⁵⁶⁷⁸⁹]+)?"
_UNIT_ATOM = r"(?:[°º]?[^\W\d_]+|[%‰°])" + _UNIT_POWER
_UNIT_SHAPE = re.compile(rf"(?:1\s*/\s*)?{_UNIT_ATOM}(?:(?:\s*[/*·.]\s*|\s+){_UNIT_ATOM})*")
"""A cell shaped as a unit: symbols or words, with powers (``m/s^2``, ``m s-2``, ``m/s²``,
``kN*m``, ``1/s``, ``°C``, ``%``), no number, no underscore."""
_UNIT_WORD = re.compile(r"[°º]?[^\W\d_]+|[%‰°]")
_UNIT_LETTERS = frozenset("mgsAKNJWCVFΩSTHLlh%‰°ε")
"""Units of one character, in their case: a lone ``a`` or ``b`` names a channel."""
_UNIT_PREFIXES = ("", "da", *"kmgthdcuµμnp")
"""SI prefixes (the common ones), lowercased: a unit of several characters is read
without regard to case (``kPa``, ``kpa``, ``MV``, ``mv``)."""
_UNIT_SYMBOLS = frozenset(
    {
        *("m", "g", "s", "a", "k", "mol", "cd", "hz", "n", "pa", "j", "w", "c", "v", "f"),
        *("ω", "ohm", "ohms", "wb", "t", "h", "lm", "lx", "bq", "gy", "sv", "rad", "sr"),
        *("l", "bar", "ev", "var", "va", "wh", "ah", "bit", "bits", "strain"),
    }
)
"""Units that take an SI prefix (``mm``, ``kN``, ``MPa``, ``mV``, ``µstrain``), lowercased."""
_UNIT_NAMES_ALONE = frozenset(
    {
        *("°", "°c", "°f", "ºc", "ºf", "deg", "degc", "degf", "degk", "celsius", "kelvin"),
        *("%", "‰", "percent", "pct", "ppm", "ppb", "rpm", "db", "dba", "dbv", "dbm"),
        *("ue", "µe", "μe", "µε", "με", "uε", "ε", "microstrain"),
        *("psi", "psia", "psig", "ksi", "atm", "mmhg", "inhg", "mmh2o", "inh2o"),
        *("in", "inch", "ft", "yd", "mi", "mph", "kph", "kmh", "knot", "knots", "kt"),
        *("lb", "lbs", "lbf", "kip", "kips", "oz", "gal", "gn", "gauss", "lux"),
        *("sec", "secs", "min", "mins", "hr", "hrs", "d", "day", "days"),
        *("count", "counts", "cnt", "cts", "lsb", "digit", "digits", "dps"),
        *("volt", "volts", "amp", "amps", "watt", "watts", "hertz", "meter", "metre"),
        *("meters", "metres", "newton", "newtons", "pascal", "degree", "degrees"),
    }
)
"""Units without a prefix, lowercased."""
UNIT_LABELS = ("unit", "units", "einheit", "einheiten", "unité", "unités", "unidad", "unidades")
"""What a units line may hold under the time column to say what it is (``Unit,g,g``)."""
UNITS_NOTE_CHARS = 200
"""Of the columns' units, as many as fit in this many characters are named in the note
on a units line (the rest counted)."""
_LINE_BREAK = re.compile(r"\r\n|\r|\n")
_DATA_TIME = re.compile(
    r"^(?:\d{1,4}[-/.]\d{1,2}[-/.]\d{1,4}(?:[T ]+\d{1,2}:\d{2}.*)?|\d{1,2}:\d{2}(?::\d{2}.*)?)$"
)
"""A cell that is a date, a date-time or a time of day (for :func:`_is_data`)."""
CLOCK_SET_BACK_NS = CLOCKS_APART_NS + REORDER_WINDOW_NS
"""A time that steps back further than this (an hour, as a header clock's step in a
recording, :data:`~analyzer.readers._common.CLOCKS_APART_NS`, and the reorder window:
beyond any change from summer to winter time, :data:`DST_STEP_NS`) is a clock set back
during the recording: the rows after it cannot be sorted in among those before (they
would interleave with them, or lie before them in reverse order), so the file is refused
(:meth:`CsvReader._set_back`) once more than
:data:`~analyzer.readers._common.LEAD_GLITCH_MESSAGES` rows in a row lie that far back
(fewer are outliers, a row stamped 0, as before). A shorter step is sorted in and said,
as before, but in times without a zone (:data:`DST_STEP_NS`) and a restart of relative
times (:meth:`_Steps._fold`)."""
_CLOCK_TAIL = re.compile(r"\d{1,2}:\d{2}(?::\d{2}(?:[.,]\d*)?)?\s*(?:[AaPp]\.?[Mm]\.?)?\s*(\S.*)?$")
"""A time of day and what follows it in a cell: a zone (``Z``, ``+01:00``, ``CET``) or nothing."""
CUT_ROW_LINES = 100
"""Lines above a last row without a line break that show whether its last cell was cut
short (see :meth:`CsvReader._cut_row`)."""
GZIP_MAGIC = b"\x1f\x8b"
"""How a gzip stream (each member of one) starts."""
GZIP_WBITS = 16 + zlib.MAX_WBITS
"""zlib's window bits for a gzip stream (its header and trailer checked)."""
GZIP_READ_BYTES = 1 << 18
"""Compressed bytes read from a ``.gz`` at a time (see :class:`_Gunzip`)."""
GZIP_RETRY_BYTES = 512
"""Compressed bytes inflated at a time where a corrupt stretch was met, to keep the
text before it."""


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
    units: tuple[str, ...] = ()
    """The unit of each column from a units line under the header (``""``: none given)."""
    units_line: int = 0
    """The line (from 1) read as units under the header, which ``info.errors`` names so
    that a wrong guess shows (0: none, or a TOA5 table's, which its format places)."""
    renamed: tuple[tuple[str, str], ...] = ()
    """Header names given to more than one column, and the name each repeat is read as
    (:func:`_unique`): said in ``info.errors``."""
    header_start_ns: int | None = None
    """The start an ``.lvm`` file's header gives (its ``Date`` and ``Time``, read as UTC),
    for relative times (:func:`_lvm_start`); None: none."""


@dataclass(slots=True)
class _Steps:
    """Where the times of a CSV step back by more than the reorder window (a clock set
    back, local times across the change from summer to winter time), found block by
    block (see :meth:`push`)."""

    newest: int | None = None
    """The latest time read so far."""
    count: int = 0
    """Steps back: rows more than the window before a time read earlier, after a row
    that was not."""
    behind: int = 0
    """Rows more than the window before a time read earlier."""
    size_ns: int = 0
    """How far the first step goes back, from the latest time before it."""
    before_ns: int = 0
    """The latest time before the first step."""
    after_ns: int = 0
    """The time of the row of the first step."""
    row: int = 0
    """The data row of the first step (1: the first row under the header)."""
    set_back: tuple[int, int] | None = None
    """Of the times last pushed: where the first run of more than
    :data:`~analyzer.readers._common.LEAD_GLITCH_MESSAGES` rows in a row that lie more
    than :data:`CLOCK_SET_BACK_NS` before a time read earlier starts (its index, -1: in
    an earlier push, see :attr:`far_start`), and the latest time before it (None: none)."""
    far_open: tuple[int, int] | None = None
    """Of the times last pushed: where a run of rows that far back that is still open at
    their end starts (its index, and the latest time before it), for the caller to keep
    in :attr:`far_start`."""
    far_start: tuple[int, str, int, int] | None = None
    """The open run's first row: its data row, time cell, the latest time before it and
    its time (kept by the caller)."""
    far_rows: int = 0
    """Rows of the run still open at the end of the times pushed so far."""
    text: str = ""
    """Its time cell."""
    far_ns: int = CLOCK_SET_BACK_NS
    """How far back a row lies, at least, to count in :attr:`set_back`'s runs: a clock set
    back by more than an hour; in times without a zone, more than half an hour (the
    change from summer to winter time, :data:`DST_STEP_NS`, whose two hours cannot be
    told apart)."""
    restarts: bool = False
    """Whether restarts are looked for (relative times: seconds from a start, no date)."""
    fold_from: int | None = None
    """Of such times: the time of the file's first row. A run of rows behind that starts
    at it (to within the reorder window) and goes on past it over times already read is
    a restart (see :meth:`_fold`)."""
    fold: tuple[int, int] | None = None
    """Of the times last pushed: where the first such restart starts (its index, -1: in an
    earlier push, see :attr:`fold_start`) and the latest time before it, as
    :attr:`set_back`."""
    fold_open: tuple[int, int] | None = None
    """Of the times last pushed: a run that may be a restart, still open at their end (its
    index and the latest time before it), for the caller to keep in :attr:`fold_start`."""
    fold_start: tuple[int, str, int, int] | None = None
    """That run's first row: its data row, time cell, the latest time before it and its
    time (kept by the caller)."""
    _fold_rows: int = 0
    """Rows of such a run open at the end of the times pushed so far (0: none)."""
    _fold_t0: int = 0
    """The time of that open run's first row."""
    _was_behind: bool = False

    def push(self, t: IntArray) -> int | None:
        """Take the next times read; the index in ``t`` of the file's first step back
        when it is there, else None."""
        self.set_back = self.far_open = self.fold = self.fold_open = None
        if t.size == 0:
            return None
        if self.restarts and self.fold_from is None:
            self.fold_from = int(t[0])
        last = int(t[-1])
        if (self.newest is None or int(t[0]) >= self.newest - REORDER_WINDOW_NS) and bool(
            (t[1:] >= t[:-1]).all()
        ):  # in order (the common case, a single pass)
            self.newest = last if self.newest is None else max(self.newest, last)
            self._was_behind = False
            self.far_rows = self._fold_rows = 0
            return None
        newest = np.maximum.accumulate(t)
        if self.newest is not None:
            np.maximum(newest, self.newest, out=newest)
        before = np.empty_like(newest)
        before[0] = t[0] if self.newest is None else self.newest
        before[1:] = newest[:-1]
        behind = (before - t) > REORDER_WINDOW_NS
        self._far(before, t)
        self._fold(before, t, behind)
        self.newest = int(newest[-1])
        if not bool(behind.any()):
            self._was_behind = False
            return None
        starts = np.flatnonzero(behind & ~np.concatenate(([self._was_behind], behind[:-1])))
        self._was_behind = bool(behind[-1])
        self.behind += int(np.count_nonzero(behind))
        if not starts.size:
            return None
        self.count += int(starts.size)
        if self.count > starts.size:
            return None
        first = int(starts[0])
        self.before_ns, self.after_ns = int(before[first]), int(t[first])
        self.size_ns = self.before_ns - self.after_ns
        return first

    def _far(self, before: IntArray, t: IntArray) -> None:
        """Runs of rows more than :data:`CLOCK_SET_BACK_NS` before the latest time read
        before each (``before``): :attr:`set_back`, :attr:`far_open` and
        :attr:`far_rows` for the times ``t`` of a push, the run open before counted on."""
        far = before - t > self.far_ns
        if not bool(far.any()):
            self.far_rows = 0
            return
        rise = far & ~np.concatenate(([self.far_rows > 0], far[:-1]))
        run = np.cumsum(rise)  # each row's run: 0 the one open before this push
        lengths = np.bincount(run[far], minlength=int(run[-1]) + 1)
        lengths[0] += self.far_rows
        starts = np.flatnonzero(rise)
        long = np.flatnonzero(lengths > LEAD_GLITCH_MESSAGES)
        if long.size:
            k = int(long[0])
            at = int(starts[k - 1]) if k else -1
            self.set_back = (at, int(before[at]) if k else 0)
        last = int(run[-1]) if bool(far[-1]) else -1
        self.far_rows = int(lengths[last]) if last >= 0 else 0
        if last > 0:
            at = int(starts[last - 1])
            self.far_open = (at, int(before[at]))

    def _fold(self, before: IntArray, t: IntArray, behind: np.ndarray) -> None:
        """Of relative times (:attr:`fold_from`): :attr:`fold` and :attr:`fold_open`
        for the times ``t`` of a push (``before``: the latest time read before each,
        ``behind``: the rows more than the reorder window before it).

        A logger that restarts counts its seconds from its start again: a run of rows
        behind begins at (about) the file's first time and goes on over the times
        already read, each of them falling on a time of the stretch before the restart
        (before, they were sorted in among those rows and one of the two values kept at
        each time: half the record lost, said as rows "written in batches"). The run
        begins at the file's first time (to within the window), or nearer to it than to
        the latest time read before it: its step back is more than half the way to the
        first time, more than half of the times read so far (a counter that starts
        again at 5 s or 37 s, the logger's boot taking that long, or the file starting
        at 0 s of a clock that restarts later; a batch written late steps back by a
        small share of them). Such a run is a restart once it holds more than
        :data:`~analyzer.readers._common.LEAD_GLITCH_MESSAGES` rows and one of them lies
        past both the first time and the run's own first time by more than the window
        (it counts on over the times already read). A run that stays before the first
        time (rows of the file's start written late, a step back before the start), or
        within the window of its own start, is sorted in as before."""
        if self.fold_from is None:
            return
        if not bool(behind.any()):
            self._fold_rows = 0
            return
        near = self.fold_from + REORDER_WINDOW_NS
        rise = behind & ~np.concatenate(([self._was_behind], behind[:-1]))
        run = np.cumsum(rise)  # each row's run: 0 the one open before this push
        starts = np.flatnonzero(rise)
        first = t[starts]
        # (back more than half the way to the first time: nearer to it than to the latest)
        halfway = first - self.fold_from < before[starts] - first
        restart = np.concatenate(([self._fold_rows > 0], (first <= near) | halfway))
        begins = np.concatenate(([-self._fold_rows], starts))
        rows = np.arange(t.size) - begins[run] + 1  # of each row of a run: its rows so far
        t0 = np.concatenate(([self._fold_t0], first))  # each run's first time
        past = t > np.maximum(near, t0[run] + REORDER_WINDOW_NS)
        fire = behind & restart[run] & past & (rows > LEAD_GLITCH_MESSAGES)
        if bool(fire.any()):
            k = int(run[int(np.argmax(fire))])
            at = int(starts[k - 1]) if k else -1
            self.fold = (at, int(before[at]) if k else 0)
        last = int(run[-1]) if bool(behind[-1]) and bool(restart[run[-1]]) else -1
        self._fold_rows = int(rows[-1]) if last >= 0 else 0
        self._fold_t0 = int(t0[last]) if last >= 0 else 0
        if last > 0:
            at = int(starts[last - 1])
            self.fold_open = (at, int(before[at]))


GARBAGE_BACK_STEPS = 3.0
"""In the text of a corrupt ``.gz``: a time more than this many median steps behind the
row before is garbage (see :class:`_Garbage`)."""
GARBAGE_AHEAD_STEPS = 1000.0
"""... and so is one more than this many median steps ahead of it."""


@dataclass(slots=True)
class _Garbage:
    """Where the rows of a corrupt ``.gz`` turn to garbage.

    zlib notices damage only at the next invalid block or at the member's checksum: the
    text it inflates between the damage and its error is garbage, mostly copies of
    earlier text run together (a 4 KiB sector of zeros: times stepping back seconds at
    once, rows of five fields, times on to 6.6e9 s). Such text is kept up to the first
    sign of garbage: a row without a readable time, a time more than
    :data:`GARBAGE_BACK_STEPS` median steps behind the row before (and that row too
    where it had itself jumped more than that ahead), or more than
    :data:`GARBAGE_AHEAD_STEPS` ahead of it, or a cell of a numeric column that is no
    number. The median step is that of the file's first block (of its readable times
    up to the first such row where the first block is the garbled one)."""

    step_ns: float | None = None
    """The median of the first block's steps forward (None: not known yet)."""
    last_ns: int | None = None
    """The time of the last row passed on."""

    def learn(self, t: IntArray) -> None:
        """Take the times of the rows passed on (in file order)."""
        if t.size == 0:
            return
        if self.step_ns is None:
            self.step_ns = _median_step(t)
        self.last_ns = int(t[-1])

    def start(
        self,
        t: IntArray,
        keep: np.ndarray,
        bad: np.ndarray | None = None,
        broken: int | None = None,
    ) -> tuple[int, str] | None:
        """The index in this block of the first row that is garbage and why, or None.
        ``t``: the block's times, ``keep``: the rows with a readable time, ``bad``: the
        rows with a cell of a numeric column that is no number, ``broken``: the index of
        the first row before which a line was skipped for its number of fields. Rows
        without a readable time above the file's first readable time (a units line) are
        no sign."""
        end, why = t.size, ""
        if broken is not None and broken < end:
            end, why = broken, "a line with the wrong number of fields"
        unread = np.flatnonzero(~keep)
        if self.last_ns is None and unread.size:
            unread = unread[unread > int(np.argmax(keep))]
        if unread.size and int(unread[0]) < end:
            end, why = int(unread[0]), "a row without a readable time"
        if bad is not None:
            wrong = np.flatnonzero(bad[:end])
            if wrong.size:
                end, why = int(wrong[0]), "a cell of a numeric column that is no number"
        rows = np.flatnonzero(keep[:end])
        times = t[rows]
        step = (self.step_ns if self.step_ns is not None else _median_step(times)) or 0.0
        if self.last_ns is not None:
            rows = np.concatenate(([-1], rows))
            times = np.concatenate(([self.last_ns], times))
        if times.size > 1:
            d = np.diff(times)  # d[i]: the step into the row rows[i + 1]
            back = d < -GARBAGE_BACK_STEPS * step
            ahead = d > GARBAGE_AHEAD_STEPS * step if step > 0 else np.zeros(d.size, bool)
            odd = np.flatnonzero(back | ahead)
            if odd.size:
                i = int(odd[0])
                way = "behind" if back[i] else "ahead of"
                end, why = (
                    int(rows[i + 1]),
                    f"a time {abs(int(d[i])) / 1e9:.6g} s {way} the row before",
                )
                if back[i] and i > 0 and d[i - 1] > GARBAGE_BACK_STEPS * step:
                    end = int(rows[i])  # the row before had jumped ahead: garbage too
                    why = f"a time {d[i - 1] / 1e9:.6g} s ahead of the row before, then back"
        return (end, why) if end < t.size else None


def _median_step(t: IntArray) -> float | None:
    """The median of the steps forward of ``t`` (None: no step forward)."""
    d = np.diff(t)
    d = d[d > 0]
    return float(np.median(d)) if d.size else None


class _Gunzip:
    """The text of a gzip file (one member or several), inflated as it is read, up to
    the damage. ``read`` hands out whole lines only (but at a clean end, or a line
    longer than it was asked for): a stream cut short (a power loss while writing) or
    corrupt ends at the last line break before the damage, which :attr:`damage` then
    names. zlib inflates in C, at most ``size`` bytes per call: bounded memory, no
    Python per line; a corrupt stretch is inflated again from a copy of the state
    before it in small pieces, so that what precedes it is kept. Used for the layout's
    sample and where Arrow's own inflation fails (see :meth:`CsvReader._blocks`)."""

    def __init__(self, path: Path) -> None:
        self._raw = path.open("rb")
        self._zlib = zlib.decompressobj(GZIP_WBITS)
        self._pieces: list[bytes] = []
        self._buffered = 0
        self._end = False
        self.closed = False
        self.damage: str | None = None
        """What stopped the text before the end of the file (None: it ended cleanly)."""
        self.corrupt = False
        """Whether the damage is corrupt data (zlib's error), not a stream cut short: then
        the text zlib inflated between the damage and its error is garbage."""
        self.text_bytes = 0
        """Bytes of text handed out."""
        self.cut_bytes = 0
        """Bytes of a line cut by the damage, which were not handed out."""
        self.tail: bytes | memoryview = b""
        """The last :data:`SAMPLE_BYTES` (or more) of the text handed out."""

    @property
    def position(self) -> int:
        """How far the compressed file has been read, in bytes."""
        return self._raw.tell()

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return False

    def close(self) -> None:
        self.closed = True
        self._raw.close()

    def skip(self, count: int) -> None:
        """Inflate the first ``count`` bytes of text and drop them (fewer where the
        text ends before)."""
        while count > 0 and (part := self.read(min(count, BLOCK_BYTES))):
            count -= len(part)

    def read(self, size: int = -1) -> bytes | memoryview:
        """Up to ``size`` bytes of text (all of it: -1) ending with a line break, unless
        the text ends there cleanly or a line is longer than ``size``: a view of the
        text inflated, not a copy (Arrow takes any buffer)."""
        if size is None or size < 0:
            size = 1 << 62
        while self._buffered < size and not self._end:
            piece = self._inflate(max(size - self._buffered, GZIP_READ_BYTES))
            if piece:
                self._pieces.append(piece)
                self._buffered += len(piece)
        text = self._pieces[0] if len(self._pieces) == 1 else b"".join(self._pieces)
        rest = b""
        cut = len(text)
        if not self._end or len(text) > size:  # more to come: whole lines only
            end = _last_line_break(text, size)
            cut = end + 1 if end >= 0 else size
            rest = text[cut:]
        elif self.damage is not None:  # the line the damage cut is not handed out
            cut = _last_line_break(text, len(text)) + 1
            self.cut_bytes += len(text) - cut
        self._pieces = [rest] if rest else []
        self._buffered = len(rest)
        self.text_bytes += cut
        out = memoryview(text)[:cut]
        if cut < SAMPLE_BYTES:
            self.tail = b"".join((self.tail[-SAMPLE_BYTES:], out))[-SAMPLE_BYTES:]
        else:
            self.tail = out
        return out

    def _inflate(self, most: int) -> bytes:
        """Up to ``most`` more bytes of text; b"" at the end of the file or the damage
        (then :attr:`_end` is set)."""
        while not self._end:
            data = self._zlib.unconsumed_tail
            if not data and self._zlib.eof:  # a member ends: another, or the end
                data = self._zlib.unused_data or self._raw.read(GZIP_READ_BYTES)
                if not data.strip(b"\x00"):  # zero bytes after the last member are padding
                    self._end = True
                    return b""
                if not data.startswith(GZIP_MAGIC[: len(data)]):
                    self._end = True
                    self.damage = "bytes after the end of the gzip stream that are no gzip data"
                    return b""
                self._zlib = zlib.decompressobj(GZIP_WBITS)
            elif not data:
                data = self._raw.read(GZIP_READ_BYTES)
                if not data:
                    self._end = True
                    self.damage = "the compressed stream ends early: the file is cut short"
                    return b""
            before = self._zlib.copy()
            try:
                out = self._zlib.decompress(data, most)
            except zlib.error as err:
                self._end = True
                self.corrupt = True
                self.damage = f"corrupt compressed data ({one_line(err)})"
                if str(err).endswith(("incorrect data check", "incorrect length check")):
                    # the CRC or the length at a member's end: the damage is before it
                    self.damage += ": a stretch of it is damaged, and what follows it is garbage"
                return _inflate_up_to_error(before, data, most)
            if out:
                return out
        return b""


def _inflate_up_to_error(state: Any, data: bytes, most: int) -> bytes:
    """What ``state`` (a zlib decompressor) inflates of ``data`` before the error it
    meets there, fed in pieces of :data:`GZIP_RETRY_BYTES` (zlib drops the output of the
    call that fails)."""
    pieces: list[bytes] = []
    got = 0
    with contextlib.suppress(zlib.error):
        for start in range(0, len(data), GZIP_RETRY_BYTES):
            piece = state.decompress(state.unconsumed_tail + data[start : start + GZIP_RETRY_BYTES])
            pieces.append(piece)
            got += len(piece)
            if got >= most or state.eof:
                break
    return b"".join(pieces)[:most]


def _decimals(cell: str, separator: str) -> int | None:
    """Digits after the decimal mark of a number (a comma too under a ``;``, tab or
    ``|`` separator), None when ``cell`` is no number."""
    number = _FINITE.match(cell.strip().replace(",", ".") if separator != "," else cell.strip())
    if number is None:
        return None
    mantissa = number.group(1)
    point = mantissa.find(".")
    return 0 if point < 0 else len(mantissa) - point - 1


def _last_line_break(text: bytes, end: int) -> int:
    """The index of the last line break (``\\n``, else ``\\r``) in ``text[:end]``, -1 if none."""
    found = text.rfind(b"\n", 0, end)
    return found if found >= 0 else text.rfind(b"\r", 0, end)


class CsvReader:
    """One CSV/TSV file."""

    damage: ClassVar[tuple[type[Exception], ...]] = (pa.ArrowException, csv.Error)
    """Its libraries' errors on a damaged file (:func:`~analyzer.readers.base.damage_of`)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        try:
            size = self.path.stat().st_size
        except OSError as err:
            check_limit(err)  # (the machine's limit, not the file's)
            raise ReaderError(f"{self.path}: cannot read: {one_line(err.strerror or err)}") from err
        if size == 0:
            raise ReaderError(f"{self.path}: empty file (0 bytes)")
        self._size = size
        self.fraction_read = 0.0
        """The share of the file :meth:`chunks` has got through (see ``Reader``)."""
        self._notes: list[str] = []
        """What the row handler of :meth:`_batches` found, for ``info.errors``."""
        self._damage: str | None = None
        """What stopped a ``.gz`` before its end (see :class:`_Gunzip`)."""
        self._damage_cut = 0
        """Bytes of the line the damage cut (not read)."""
        self._corrupt = False
        """Whether the damage is corrupt data, not a stream cut short (see :class:`_Garbage`)."""
        self.stop_at_set_back = False
        """Whether a time column set back stops the reading, raised (an input of a
        multi-file archive: see ``Reader``), instead of said in ``info.set_back``."""
        self._set_back_row = 0
        """The data row :attr:`InputInfo.set_back` names (see :meth:`_set_back`)."""
        self._invalid_at: list[int] = []
        """Of a corrupt ``.gz``: before which data row (0: the first) each line skipped
        for its number of fields came, as Arrow's reader met them."""
        self._lines_skipped = 0
        """Lines skipped for their number of fields by the reader of the file so far."""
        self._gzip_state: tuple[str | None, bool] | None = None
        """Of a ``.gz`` inflated to its end once: its damage and whether it is corrupt."""
        self._gzip_tail: bytes | memoryview = b""
        """The end of a ``.gz``'s text where :class:`_Gunzip` read it (see :meth:`_blocks`)."""
        self._layout = self._detect()
        self._numeric: dict[int, bool] = {}
        self._fast: tuple[int, ...] = ()
        self._time_kind = ""
        self._time_format: str | None = None
        self._day_first: str | None = None
        """The day-first format of dates whose day and month could be either way round,
        read month first (:func:`_datetime_format`); an archive may switch to it
        (:meth:`read_day_first`)."""
        self._iso_type: pa.DataType = pa.timestamp("ns", "UTC")
        self._clock = (0, 0)
        """Of a time-of-day column: (days passed, last time of day read), for midnight."""
        self._offset = 0
        """Nanoseconds added to every time of the time column: the absolute start that
        another time column, of date-times that agree with it, gives (:meth:`_anchor`)."""
        self._anchor_text = ""
        """What :meth:`_time_text` adds of that column."""
        self._anchored: tuple[int, int, int] | None = None
        """Of that column: its index, the resolution to which the two agreed (ns) and the
        rows compared on the first block, for :meth:`_check_anchor` on every block."""
        self._parted = (0, 0)
        """The least and largest date-time less time (ns) of the blocks read so far."""
        self._no_numeric = ""
        """Why no column is a channel (:attr:`InputInfo.no_numeric`), else ""."""
        self._date_column: int | None = None
        """A column of dates whose cells are joined with the time column's times of day
        (``Date,Time``: see :meth:`_join_date`); None: none."""
        self._date_note = ""
        """Why a column named as a date was not joined with the times (said in
        ``info.errors``), else ""."""
        self._zone: str | None = None
        """The zone of the time column's first date-time (``+02:00``), "" for none; None:
        no date-times (:attr:`InputInfo.time_zone`)."""
        self._zoneless = False
        """Whether the time column holds date-times or times of day without a zone
        (local times, read as UTC): a step back of about an hour there is refused
        (:meth:`_set_back`)."""
        first_time = self._inspect_first_block()
        total, sha, self._lines = _digest_and_lines(self.path, self._layout.compressed)
        self.info = InputInfo(self.path, Format.CSV, size_bytes=total, sha256=sha)
        self.info.no_numeric = self._no_numeric
        self.info.units = {
            n: u
            for i, (n, u) in enumerate(zip(self._layout.names, self._layout.units, strict=False))
            if u and i != self._layout.time_column
        }
        if self._date_note:
            self._error(self._date_note)
        if self._layout.units_line:  # a guess (a units line has no readable time): said
            self._error(_units_note(self._layout))
        if self._layout.renamed:
            self._error(
                "columns named alike, a repeat read under a name of its own: "
                + ", ".join(f"{g!r} as {n!r}" for g, n in self._layout.renamed[:8])
                + (f", ... ({len(self._layout.renamed)})" if len(self._layout.renamed) > 8 else "")
            )
        self.info.absolute_time = self._time_kind == "datetime" or (
            self._time_kind in ("ns", "seconds")
            and first_time is not None
            and plausible_epoch(first_time)
        )
        if self._time_kind in ("seconds", "ns") and not self.info.absolute_time:
            self._anchor()
            if self._offset and first_time is not None:
                first_time += self._offset
                self.info.absolute_time = True
        start = self._layout.header_start_ns
        if (
            self._time_kind == "seconds"
            and not self.info.absolute_time
            and start is not None
            and first_time is not None
        ):  # (an .lvm's X_Value counts seconds from its header's Date and Time)
            self._offset = start
            first_time += start
            self.info.absolute_time = True
            self._anchor_text = (
                f"; absolute times from the LabVIEW header's Date and Time: 0 s is "
                f"{iso_utc(start)} (the header gives no zone: read as UTC)"
            )
        self._first_time = first_time
        self.info.time = self._time_text()
        self.info.time_zone = self._zone if self._time_kind == "datetime" else None
        if self._day_first is not None:
            self._error(
                f"{EITHER_WAY} read month first, {self._time_format!r}; a file of the same "
                "archive with a day above 12 there makes them read day first"
            )

    def _check_rows(self, parsed: int) -> None:
        """Raise :class:`IntegrityError` when Arrow's reader passed on fewer rows
        (``parsed``: rows, rows skipped for their fields and a last row cut short) than
        the file has lines under its header (:attr:`_lines`, counted from the bytes as
        they were hashed; None where that count is not exact).

        Under heavy load an analysis once in several hundred read a 30 000-row CSV
        with 2 340-2 390 rows missing from its middle, the two cut ends skipped as one
        row with the wrong number of fields, and the same file right when read again
        (benchmarks/README.md, ``stress_repeat.py``): lost before any sample reached
        the reordering, where the pipeline's tallies begin. The pipeline reads the
        inputs again once (:func:`analyzer.pipeline._checked`). A count that comes out
        short the same way twice for the same file is not such a read but something
        this count does not foresee: said in a note, and not raised again."""
        if self._lines is None:
            return
        expected = self._lines - self._layout.skip_rows
        if parsed >= expected:
            return
        key = (str(self.path), self._size, expected, parsed)
        what = (
            f"{self.path}: {counted(parsed, 'row')} read of the "
            f"{counted(expected, 'line')} under its header"
        )
        if key in _SHORT_READS:
            self._error(f"{what} (the same on a second read: lines this count cannot tell)")
            return
        _SHORT_READS.add(key)
        raise IntegrityError(f"internal check failed in the CSV reader: {what}")

    def _when(self, ns: int) -> str:
        """A time read, as it is said in ``info.errors``."""
        if self.info.absolute_time:
            return iso_utc(ns) or ""
        return f"{seconds_text(ns / NS_PER_S)} s"

    def _so_far(self, rows: int, newest: int | None) -> str:
        """How much was read: rows, up to which time."""
        return counted(rows, "row") + (
            f", up to {self._when(newest)}" if newest is not None else ""
        )

    def _damage_note(self, so_far: str, garbled: tuple[int, str] | None) -> str:
        """What :meth:`chunks` says of a damaged ``.gz``: a stream cut short is read up
        to its last whole line; of a corrupt one (see :class:`_Garbage`) the rows are
        read up to the first that looks like garbage, and the rest of the file is
        dropped."""
        if not self._corrupt:
            cut = f"; the {counted(self._damage_cut, 'byte')} of the line it cut dropped"
            cut = cut if self._damage_cut else ""
            return (
                f"unreadable from some point on ({self._damage}); the rows before it were "
                f"read ({so_far}){cut}"
            )
        where = (
            f" (the rows turn to garbage at data row {garbled[0]}: {garbled[1]})"
            if garbled is not None
            else ""
        )
        return (
            f"unreadable from some point on ({self._damage}); the rows before the damage "
            f"were read ({so_far}), the rest of the file from the damage on dropped{where}"
        )

    def _garbage_at(
        self, garbage: _Garbage, batch: pa.RecordBatch, t_ns: IntArray, keep: np.ndarray, rows: int
    ) -> tuple[int, str] | None:
        """Of a ``.gz`` whose stream is corrupt: where the rows of ``batch`` (after
        ``rows`` rows) turn to garbage and why (see :class:`_Garbage`), else None.

        zlib may notice the damage only at the member's checksum, after Arrow has passed
        on many blocks inflated from garbage: so the blocks of every ``.gz`` are checked
        as they come (a comparison of times, a few ms a block), and where one shows a
        sign of garbage while the stream is not known to be corrupt, the stream is
        inflated once to its end (:meth:`_gzip_check`, at C speed: only such a file pays
        it). A sign in a sound stream (a clock set back, a line with a field too many),
        or in one merely cut short, is no garbage: then nothing is cut."""
        if not self._layout.compressed:
            return None
        at = bisect.bisect_left(self._invalid_at, rows)
        broken = self._invalid_at[at] - rows if at < len(self._invalid_at) else None
        found = garbage.start(t_ns, keep, self._bad_rows(batch) if self._corrupt else None, broken)
        if found is None or self._corrupt:
            return found
        damage, corrupt = self._gzip_check()
        if not corrupt:
            return None
        self._damage, self._corrupt = damage, True
        return garbage.start(t_ns, keep, self._bad_rows(batch), broken)

    def _gzip_check(self) -> tuple[str | None, bool]:
        """What damages the ``.gz`` (None: nothing) and whether it is corrupt data (not
        a stream cut short): the whole stream inflated once, the answer kept."""
        if self._gzip_state is None:
            with contextlib.closing(_Gunzip(self.path)) as probe:
                probe.skip(1 << 62)
            self._gzip_state = (probe.damage, probe.corrupt)
        return self._gzip_state

    def _bad_rows(self, batch: pa.RecordBatch) -> np.ndarray:
        """The rows of ``batch`` with a cell of a numeric column that is neither blank
        nor a number (see :class:`_Garbage`)."""
        bad = np.zeros(batch.num_rows, dtype=bool)
        for index, numeric in self._numeric.items():
            column = batch.column(index)
            if not numeric or column.type == pa.float64():
                continue
            text = self._clean(column)
            wrong = pc.and_(
                pc.not_equal(text, ""), pc.invert(pc.match_substring_regex(text, NUMBER_OR_BOOLEAN))
            )
            bad |= np.asarray(wrong.to_numpy(zero_copy_only=False), dtype=bool)
        return bad

    def _row_cell(
        self, batch: pa.RecordBatch, keep: np.ndarray, rows: int, at: int
    ) -> tuple[int, str]:
        """The data row and time cell of the ``at``-th row kept of ``batch`` (after
        ``rows`` rows)."""
        row = int(np.flatnonzero(keep)[at])
        return rows + row + 1, str(self._time_cells(batch)[row].as_py()).strip()

    def _set_back(
        self, row: int, cell: str, newest: int, time: int, *, restart: int | None = None
    ) -> None:
        """Note a time column set back (:attr:`_Steps.set_back`: by more than
        :data:`CLOCK_SET_BACK_NS`, or, in times without a zone, by more than half an
        hour; with ``restart``, the time of the file's first row, :attr:`_Steps.fold`:
        relative times counting from there again) at data row ``row`` (time cell ``cell``, read as
        ``time``; ``newest`` the latest time before it) in :attr:`InputInfo.set_back`:
        the column, the row, both times, what to do. Reading goes on (its rows sorted in
        or dropped as a smaller step's), so that ``inspect`` lists the file and says this
        (as it says a header clock set during a recording), while ``run`` and ``export``
        refuse it (:func:`~analyzer.readers.base.one_clock`). Before the refusal, its
        rows were analyzed sorted in among those before (an hour of local times at the
        change to winter time merged into the hour before it, a restarted logger's
        second stretch laid over its first, one value kept at each time). With
        :attr:`stop_at_set_back` (one input of several), raised instead: the reading
        stops there, the rows of the blocks before analyzed (as before the refusal in a
        folder)."""
        name = self._layout.names[self._layout.time_column]
        self._set_back_row = row
        back = newest - time
        if restart is not None:
            to = (  # (to it, or more than half the way back to it: _Steps._fold)
                "to the"
                if time - restart <= REORDER_WINDOW_NS
                else "more than half the way back to the"
            )
            line = (
                f"the time column {name!r} steps back by {spoken_duration(back / NS_PER_S)} at "
                f"data row {row} ({cell!r}: from {self._when(newest)} to {self._when(time)}), {to} "
                f"time of its first row ({self._when(restart)}), and counts on over the times "
                "already read: a logger restarted, its clock counting from its start again? Its "
                "rows would fall on those before at the same times; split the file at that row "
                "and analyze the parts apart"
            )
        elif self._zoneless and DST_STEP_NS[0] < back <= DST_STEP_NS[1]:
            line = (
                f"the time column {name!r} steps back by {spoken_duration(back / NS_PER_S)} at "
                f"data row {row} "
                f"({cell!r}: from {self._when(newest).removesuffix('Z')} to "
                f"{self._when(time).removesuffix('Z')}), in times without a zone: local "
                "times set back an hour, as at the change from summer to winter time? The "
                "hour after the step repeats the times of the hour before, which cannot be "
                "told apart; write the times in UTC, or as date-times with their offset "
                "from UTC (such as +02:00 before the change and +01:00 after it)"
            )
        else:
            line = (
                f"the time column {name!r} steps back by {spoken_duration(back / NS_PER_S)} "
                f"at data row {row} ({cell!r}: from {self._when(newest)} to "
                f"{self._when(time)}): a clock set back during the recording? Its rows cannot "
                "be placed among those before it; correct the times, or split the file at "
                "that row"
            )
        if self.stop_at_set_back:
            raise ReaderError(f"{self.path}: {line}")
        self.info.set_back = line

    def _spring_note(self, row: int, cell: str, before: int, time: int) -> str:
        """What :meth:`chunks` says where times without a zone skip a whole clock hour
        (:func:`~analyzer.readers._common.hour_skipped`, at data row ``row``, time cell
        ``cell`` read as ``time``, ``before`` the time of the row before): most likely
        local times set forward at the change to summer time, which, read as UTC, leave
        an hour without data and UTC times that are the file's local times (ux55 item 11:
        the gap was said, not what it may be). The reading is unchanged."""
        return (
            f"the time jumps forward by {spoken_duration((time - before) / NS_PER_S)} at data row "
            f"{row} ({cell!r}: from {self._when(before).removesuffix('Z')} to "
            f"{self._when(time).removesuffix('Z')}), over a whole hour of the clock, in times "
            "without a zone: local times set forward, as at the change from winter to summer "
            "time? Read as UTC, that hour is a gap and every time said in UTC is the file's local "
            "time; write the times in UTC, or as date-times with their offset from UTC, for true "
            "UTC times"
        )

    def _step_note(self, steps: _Steps, dropped: bool) -> str:
        """What :meth:`chunks` says of times that step back (see :class:`_Steps`): where,
        by how much, and what became of the rows behind (the reorderer sorts them in
        among the rows it still holds, and drops those behind the rows it has passed
        on). An hour back in times without a zone is most likely a local clock set back
        at the change to winter time, which the rule "no zone: UTC" cannot see."""
        back = steps.size_ns / 1e9
        zoned = self._time_kind not in ("datetime", "timeofday") or bool(
            (found := _CLOCK_TAIL.search(steps.text)) and found.group(1)
        )
        dst = (
            ": an hour back in times without a zone, which are read as UTC (a local clock "
            "set back, as at the change from summer to winter time?)"
            if not zoned and DST_STEP_NS[0] < steps.size_ns <= DST_STEP_NS[1]
            else ""
        )
        more = f" ({steps.count} such steps)" if steps.count > 1 else ""
        fate = (
            "sorted in by time among the rows before them where those were still held, "
            "else dropped (counted below)"
            if dropped
            else "sorted in by time among the rows before them"
        )
        window = REORDER_WINDOW_NS / 1e9
        return (
            f"the time steps back by {spoken_duration(back)} at data row {steps.row} "
            f"({steps.text!r}: "
            f"from {self._when(steps.before_ns)} to {self._when(steps.after_ns)}){dst}; "
            f"the {steps.behind} "
            f"rows stamped more than {window:g} s before a time read earlier{more} are {fate}"
        )

    def _time_text(self) -> str:
        """Which column holds the time and how its cells are read (``InputInfo.time``)."""
        name = self._layout.names[self._layout.time_column]
        kind = self._time_kind
        which = f"column {name!r}"
        if self._date_column is not None:
            which = f"columns {self._layout.names[self._date_column]!r} and {name!r} joined"
        if kind == "ns":
            how = "integer nanoseconds " + (
                "since 1970 (UTC)"
                if self.info.absolute_time and not self._offset
                else "from another start" + ("" if self._offset else ", relative")
            )
        elif kind == "datetime":
            how = "date-times (UTC where no zone is given)"
            order = date_order(self._time_format)
            if order:
                how += f", {order} first"
                if self._day_first:
                    how += " (either way round: no day above 12)"
        elif kind == "timeofday":
            how = "times of day, relative"
        else:
            how = _UNIT_NAMES[self._layout.time_unit] + (
                " since 1970 (UTC)" if self.info.absolute_time and not self._offset else ""
            )
            how += ", relative" if not self.info.absolute_time else ""
        return f"{which}: {how}{self._anchor_text}"

    def _anchor(self) -> None:
        """Of a file whose time column holds relative times (``time``: seconds from the
        start) beside another column named as a time (``timestamp``, ``datetime``, see
        :func:`_time_column`) that holds date-times: where the two agree on the first
        block's rows (every row's date-time less its time the same, to within the
        coarser of the two columns' resolutions: ``12:00:01`` beside ``1.25`` agrees to
        the second), the largest of those differences (date-times are written cut to
        their resolution, as ``strftime`` and ``isoformat`` do: the largest is the least
        cut) is added to every time (:attr:`_offset`), which makes the times absolute
        and the findings' ISO times exist; where they do not agree, the time column's
        times are kept, relative, and a line in ``info.errors`` says which column gave
        the time and that the other was ignored. Before, the other column was dropped
        as a text column, unsaid. Where they agree, every later block is compared too
        (:meth:`_check_anchor`)."""
        names = self._layout.names
        column = self._layout.time_column
        others = [
            i
            for i, name in enumerate(names)
            if i != column
            and self._numeric.get(i) is False
            and (name.strip().lower() in TIME_NAMES or _time_unit(name) is not None)
        ]
        if not others:
            return
        batch = self._first_batch()
        if batch is None:
            return
        kind, clock = self._time_kind, self._clock
        t_ns, keep = self._times(batch.column(column))
        self._time_kind, self._clock = kind, clock
        for other in others:
            absolute, present = _date_times(self._clean(batch.column(other)))
            both = keep & present
            if not bool(both.any()):
                continue
            diff = absolute[both] - t_ns[both]
            spread = int(diff.max()) - int(diff.min())
            allowed = max(_resolution(absolute[both]), _resolution(t_ns[both]))
            mine, theirs = names[column], names[other]
            if spread <= allowed:
                # (the date-times cut to their resolution, as strftime and isoformat
                # write them: the largest difference is the one least cut)
                self._offset = int(diff.max())
                self._anchored = (other, allowed, int(both.sum()))
                self._anchor_text = (
                    f"; absolute times from column {theirs!r}, whose date-times agree with "
                    f"it (to {allowed / 1e9:g} s): {int(t_ns[both][0]) / 1e9:g} s is "
                    f"{iso_utc(int(t_ns[both][0]) + self._offset)}"
                )
                return
            self._error(
                f"two time columns: {mine!r} gave the time "
                f"({self._time_text().removeprefix(f'column {mine!r}: ')}); {theirs!r} "
                f"(date-times) was ignored: its date-times less the times of {mine!r} vary by "
                f"{spoken_duration(spread / NS_PER_S)} over the first "
                f"{counted(int(both.sum()), 'row')} "
                f"(more than the {allowed / 1e9:g} s resolution of the two), so they do not agree"
            )
            return

    def _check_anchor(
        self,
        other: int,
        allowed: int,
        compared: int,
        batch: pa.RecordBatch,
        t_ns: IntArray,
        keep: np.ndarray,
        rows: int,
    ) -> None:
        """Raise :class:`ReaderError` where the two time columns that agreed on the first
        block (:meth:`_anchor`) part later in the file (the date-times jump by an hour,
        the seconds restart), at the first row whose date-time less its time lies
        further than the two columns' resolution from those of every row before: which
        of the two is right cannot be told, and the times read so far hold the first
        block's offset. ``other``, ``allowed`` and ``compared`` are :attr:`_anchored`;
        ``t_ns`` the block's times (with the offset), ``rows`` the data rows before it.
        Before, only the first block was compared, and the findings' ISO times were off
        by the jump from there on, unsaid."""
        absolute, present = _iso_date_times(self._clean(batch.column(other)))
        both = np.flatnonzero(keep & present)
        if not both.size:
            return
        diff = absolute[both] - t_ns[both]
        lo = np.minimum(np.minimum.accumulate(diff), self._parted[0])
        hi = np.maximum(np.maximum.accumulate(diff), self._parted[1])
        apart = hi - lo > allowed
        if not bool(apart[-1]):  # (the spread only grows: the last row tells)
            self._parted = (int(lo[-1]), int(hi[-1]))
            return
        first = int(np.argmax(apart))
        row = int(both[first])
        names = self._layout.names
        mine, theirs = names[self._layout.time_column], names[other]
        cell = str(batch.column(self._layout.time_column)[row].as_py()).strip()
        stamp = str(batch.column(other)[row].as_py()).strip()
        raise ReaderError(
            f"{self.path}: two time columns part at data row {rows + row + 1}: {theirs!r} "
            f"{stamp!r} lies {int(diff[first]) / 1e9:+.3f} s from {mine!r} {cell!r} "
            f"({iso_utc(int(t_ns[row]))}), after they agreed (to {allowed / 1e9:g} s) over "
            f"the first {counted(compared, 'row')}, which made the times absolute: one of the "
            "two jumps "
            f"there; correct the file, or leave {theirs!r} out of it for relative times from "
            f"{mine!r}"
        )

    def _join_date(self, batch: pa.RecordBatch) -> None:
        """Of a file whose time column holds times of day beside a column named as a date
        (``Date``, ``Datum``, ``Fecha``, ``Data``; any case, a format in brackets
        allowed) that holds dates alone (``2026-03-29``, ``29.03.2026``, ``03/29/2026``)
        in at least :data:`NUMERIC_SHARE` of its non-blank cells of the first block
        (``batch``): the two are read as one date-time, ``"{date} {time}"``
        (:meth:`_time_cells`), as a spreadsheet or logger that writes them apart means
        them (absolute times, UTC where no zone is given; the day first or the month
        first as for any date-time, see :func:`_datetime_format`), and the date column is
        no channel. Before, the date column was skipped as text without a word and the
        times were relative times of day: no start, no UTC onset, the day lost. A date
        column beside times that are no times of day (seconds) is said in
        ``info.errors``, not joined."""
        names = self._layout.names
        date = _date_column(names, self._layout.time_column)
        if date is None:
            return
        cells = self._clean(batch.column(date))
        cells = cells.filter(pc.cast(pc.utf8_length(cells), pa.bool_()))
        dates = int(pc.sum(pc.match_substring_regex(cells, DATE_ONLY)).as_py() or 0)
        if not len(cells) or dates < NUMERIC_SHARE * len(cells):
            return
        clock = self._clean(batch.column(self._layout.time_column))
        if self._time_kind_of(clock) != "timeofday":
            self._date_note = (
                f"column {names[date]!r} holds dates, not joined with the time column "
                f"{names[self._layout.time_column]!r}, which holds no times of day; "
                "skipped as text"
            )
            return
        self._date_column = date
        self._layout = replace(self._layout, ignored=(*self._layout.ignored, date))

    def _time_cells(self, batch: pa.RecordBatch) -> pa.Array:
        """The time cells of ``batch``: the time column's, or, where a date column goes
        with it (:meth:`_join_date`), each row's date and time of day joined by a space
        (blank where either is blank: a row without a readable time)."""
        column = batch.column(self._layout.time_column)
        if self._date_column is None:
            return column
        date = pc.utf8_trim_whitespace(batch.column(self._date_column))
        clock = pc.utf8_trim_whitespace(column)
        blank = pc.or_(pc.equal(date, ""), pc.equal(clock, ""))
        joined = pc.binary_join_element_wise(date, clock, " ")
        return pc.if_else(blank, pa.scalar("", pa.string()), joined)

    def _tail_cells(self, most: int = 50) -> list[str]:
        """The time cells of the file's last lines (up to ``most``, from its last 64 KiB;
        none of a compressed file): the dates at its end may tell the day from the month
        where those at its start do not."""
        if self._layout.compressed:
            return []
        try:
            with self.path.open("rb") as handle:
                size = handle.seek(0, os.SEEK_END)
                handle.seek(max(0, size - TAIL_BYTES))
                text = handle.read().decode(self._layout.encoding, errors="replace")
        except OSError:
            return []
        lines = text.splitlines()[1 if size > TAIL_BYTES else 0 :]
        lines = [line for line in lines if line.strip()][-most:]
        width = len(self._layout.names)
        column = self._layout.time_column
        date = self._date_column
        return [
            fields[column].strip()
            if date is None
            else f"{fields[date].strip()} {fields[column].strip()}"
            for fields in csv.reader(lines, delimiter=self._layout.separator)
            if len(fields) == width
            and fields[column].strip()
            and (date is None or fields[date].strip())
        ]

    @property
    def dates_first(self) -> str:
        """``"day"`` or ``"month"``: which its dates are read with first (``""``: not
        dates of both)."""
        return date_order(self._time_format)

    @property
    def either_way_dates(self) -> bool:
        """Whether its dates, read month first, could be read day first as well."""
        return self._day_first is not None

    def read_day_first(self) -> None:
        """Read its dates day first (another file of its archive has a day above 12 in
        that place, ``13/03/2026``): its first time again, and what ``inspect`` says."""
        if self._day_first is None:
            return
        self._time_format, self._day_first = self._day_first, None
        batch = self._first_batch()
        if batch is not None:
            t_ns, keep = self._times(self._time_cells(batch), first=True)
            if bool(keep.any()):
                self._first_time = int(t_ns[keep].min())
        self.info.errors = [e for e in self.info.errors if not e.startswith(EITHER_WAY)]
        self.info.errors.append(
            f"{EITHER_WAY} read day first, as another file of the archive has a day above 12"
        )
        self.info.time = self._time_text()

    # ------------------------------------------------------------------ protocol
    def start_ns(self) -> int | None:
        return self._first_time

    def column_names(self) -> list[str]:
        """The names of the columns besides the time column (and those left out): the
        channels a file may hold, from its header (an archive's seams: whether two
        files share a channel)."""
        layout = self._layout
        return [
            name
            for index, name in enumerate(layout.names)
            if index != layout.time_column and index not in layout.ignored
        ]

    def chunks(self, time: TimeSource = "log") -> Iterator[ChannelChunk]:
        del time  # CSV rows have one time only
        self.fraction_read = 0.0
        if self._no_numeric:
            return
        reorder = Reorderer()
        skipped = 0  # rows without a readable time
        broken = 0  # lines with the wrong number of fields
        bad_cells: dict[str, int] = {}
        text_cells: dict[str, tuple[int, int]] = {}  # skipped columns: (non-blank, numbers)
        filled: set[int] = set()  # columns Arrow parsed as numbers in some block
        rows = 0
        spring = ""  # zone-less times that skip a clock hour (the change to summer time)
        previous: int | None = None  # of such times: the last time of the block before
        steps = _Steps(
            far_ns=DST_STEP_NS[0] if self._zoneless else CLOCK_SET_BACK_NS,
            restarts=not self.info.absolute_time and self._time_kind in ("seconds", "ns"),
        )
        # of each channel: values at the time of its value before, and its last time
        repeats: dict[str, int] = {}
        latest: dict[str, int] = {}
        read_to: dict[str, int] = {}  # of each numeric column: its latest time with a reading
        # and its rows with a reading, and the rows up to its last one (a sparse table's
        # column, one topic a row, is blank on the other topics' rows: no silence)
        dense: dict[str, tuple[int, int]] = {}
        newest = -(2**63)  # the latest time of any row kept
        garbage = _Garbage()
        garbled: tuple[int, str] | None = None  # of a corrupt .gz: (data row, why)
        self._clock = (0, 0)
        self._rows_cut = 0
        self.info.set_back = ""
        self._parted = (0, 0)
        whole = False  # read to the end without an error
        blocks = self._stream()
        try:
            for batch, invalid in blocks:
                clock = self._clock
                t_ns, keep = self._times(self._time_cells(batch))
                found = self._garbage_at(garbage, batch, t_ns, keep, rows)
                if found is not None:  # a corrupt .gz: the rest is not read
                    cut, why = found
                    garbled = (rows + cut + 1, why)
                    batch = batch.slice(0, cut)
                    # again without the garbage (a cell of it sends the times through
                    # float64, a midnight in it moves a time of day's clock)
                    self._clock = clock
                    t_ns, keep = self._times(self._time_cells(batch))
                    # lines skipped in the garbage are not counted (Arrow counts them as
                    # it parses, which it may do ahead of the block it passes on)
                    broken = bisect.bisect_left(self._invalid_at, rows + cut)
                    invalid = 0
                broken += invalid
                if self._anchored is not None:
                    self._check_anchor(*self._anchored, batch, t_ns, keep, rows)
                dropped = int(np.count_nonzero(~keep))
                skipped += dropped
                # one time array for every float64 column (the reorderer works out the
                # order of shared times once); the values are Arrow's, viewed
                t_kept = t_ns[keep] if dropped else t_ns
                if self._layout.compressed:
                    garbage.learn(t_kept)
                # values at the time of the value before, of the float64 columns (which
                # have a value on every row kept): the same count for each but at the
                # block's start
                inside = int(np.count_nonzero(t_kept[1:] == t_kept[:-1]))
                if self._zoneless and not spring and t_kept.size:
                    at = hour_skipped(t_kept, previous)
                    if at is not None:
                        row, cell = self._row_cell(batch, keep, rows, at)
                        before = int(t_kept[at - 1]) if at else previous
                        spring = self._spring_note(row, cell, before or 0, int(t_kept[at]))
                    previous = int(t_kept[-1])
                first = steps.push(t_kept)
                for run, began, restart in (
                    (steps.set_back, steps.far_start, None),
                    (steps.fold, steps.fold_start, steps.fold_from),
                ):
                    if run is None or self.info.set_back:
                        continue
                    at, newest = run
                    if at >= 0:
                        where = self._row_cell(batch, keep, rows, at)
                        self._set_back(*where, newest, int(t_kept[at]), restart=restart)
                    elif began is not None:  # (the run began in an earlier block)
                        self._set_back(*began, restart=restart)
                if steps.far_open is not None:  # (such a run, open at the block's end)
                    at, newest = steps.far_open
                    where = self._row_cell(batch, keep, rows, at)
                    steps.far_start = (*where, newest, int(t_kept[at]))
                if steps.fold_open is not None:
                    at, newest = steps.fold_open
                    where = self._row_cell(batch, keep, rows, at)
                    steps.fold_start = (*where, newest, int(t_kept[at]))
                if first is not None:  # the first step back: where, and its cells
                    row = int(np.flatnonzero(keep)[first])
                    steps.row = rows + row + 1
                    steps.text = str(self._time_cells(batch)[row].as_py())
                rows += batch.num_rows
                if t_kept.size:
                    newest = max(newest, int(t_kept.max()))
                for index, name in enumerate(self._layout.names):
                    if index == self._layout.time_column or index in self._layout.ignored:
                        continue
                    column = batch.column(index)
                    if column.type == pa.float64():  # parsed by Arrow: all finite numbers
                        filled.add(index)
                        values = _numpy(column)
                        reorder.push(name, t_kept, values[keep] if dropped else values)
                        if t_kept.size:
                            read_to[name] = max(read_to.get(name, -(2**63)), int(t_kept.max()))
                            had = dense.get(name, (0, 0))[0]
                            dense[name] = (had + t_kept.size, rows)
                            again = inside + int(latest.get(name) == int(t_kept[0]))
                            repeats[name] = repeats.get(name, 0) + again
                            latest[name] = int(t_kept[-1])
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
                    times = t_ns[present]
                    reorder.push(name, times, values[present])
                    read_to.setdefault(name, -(2**63))
                    if times.size:
                        read_to[name] = max(read_to[name], int(times.max()))
                        had = dense.get(name, (0, 0))[0]
                        at = rows - batch.num_rows + int(np.flatnonzero(present)[-1]) + 1
                        dense[name] = (had + times.size, at)
                        again = int(np.count_nonzero(times[1:] == times[:-1]))
                        again += int(latest.get(name) == int(times[0]))
                        repeats[name] = repeats.get(name, 0) + again
                        latest[name] = int(times[-1])
                yield from reorder.release(None)
                if garbled is not None:
                    break  # the rest of the file, from the damage on, is not read
            else:
                whole = True
        except (pa.ArrowException, OSError, EOFError, ValueError) as err:
            check_limit(err)  # (the machine's limit is not the file's damage)
            self._error(
                f"unreadable from some point on ({self._arrow_words(err)}); the rows before "
                "it were read"
                f" ({self._so_far(rows, steps.newest)})"
            )
        finally:
            blocks.close()
        yield from reorder.flush()
        # columns written as no reading (blank or nan cells) in the file's last rows, read
        # on most rows before (more than half: at most one topic of a sparse table is)
        self.info.blank_until = {
            name: newest
            for name, at in read_to.items()
            if at < newest and 2 * dense.get(name, (0, 0))[0] > dense.get(name, (0, 0))[1]
        }
        if whole and self._damage is None:
            self._check_rows(rows + broken + self._rows_cut)
        if self._damage is not None:
            self._error(self._damage_note(self._so_far(rows, steps.newest), garbled))
        if self.info.set_back:
            self._error(self.info.set_back)  # (its step's note, where the same row, left out)
        if steps.count and not (self.info.set_back and steps.row == self._set_back_row):
            self._error(self._step_note(steps, bool(reorder.dropped)))
        if spring:
            self._error(spring)
        most = max(repeats.values(), default=0)
        if most:
            # (collapsed without a word: a time column cut to whole seconds under 100 rows
            # a second became one sample a second; rows of a sparse table, one channel a
            # row, repeat the time with no channel collapsed)
            self._error(
                f"{most} of {counted(rows, 'row')} {'gives' if most == 1 else 'give'} a channel a "
                "second value at the same time (a "
                "clock too coarse for the rows, or rows written twice); the aligned channels "
                "keep one value per time"
            )
        for note in self._notes:
            self._error(note)
        if skipped + broken:
            self._error(
                f"{counted(skipped + broken, 'row')} without a readable time or with the wrong "
                "number of fields skipped"
            )
        for name, count in bad_cells.items():
            self._error(f"{name}: {counted(count, 'non-numeric cell')} treated as gaps")
        for name, (nonblank, numbers) in text_cells.items():
            if 2 * numbers > nonblank:  # at most half numbers: a text column by any reading
                self._error(
                    f"{name}: skipped as a text column, though {numbers} of its "
                    f"{counted(nonblank, 'non-blank cell')} "
                    + ("is a number" if numbers == 1 else "are numbers")
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
        remarks = [name for name in blank if name.strip().lower() in COMMENT_NAMES]
        if rows and remarks:  # (LabVIEW's Comment column: no sensor, said in inspect)
            blank = [name for name in blank if name not in remarks]
            self.info.skipped = (
                f"{', '.join(repr(r) for r in remarks)}: a column of comments, blank in "
                "every row: not a channel"
            )
        if rows and blank:
            # (a column blank in every row had no note: it vanished from inspect)
            self._error(
                f"{', '.join(blank)}: blank in every row (no reading at all: a dead sensor, "
                "or one not recorded); not analyzed"
            )
            self.info.blank_until.update(dict.fromkeys(blank, newest))
        for line in reorder.drop_report():
            self._error(line)

    # ------------------------------------------------------------------ layout
    def _detect(self) -> _Layout:
        damage = None
        try:
            with self.path.open("rb") as raw:
                compressed = raw.read(2) == GZIP_MAGIC
                if not compressed:
                    raw.seek(0)
                    head = raw.read(SAMPLE_BYTES)
            if compressed:
                with contextlib.closing(_Gunzip(self.path)) as text:
                    parts = []
                    got = 0
                    while got < SAMPLE_BYTES and (part := text.read(SAMPLE_BYTES - got)):
                        parts.append(part)
                        got += len(part)
                    head = b"".join(parts)
                    damage = text.damage
        except OSError as err:
            raise ReaderError(f"{self.path}: cannot read as text ({one_line(err)})") from err
        if not head.strip() and damage is not None:
            raise ReaderError(f"{self.path}: cannot read as gzip ({damage}): no line before it")
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
        units_at: int | None = None  # the index in lines of a units line under the header
        if toa5:
            separator, header, first_row = ",", 1, 4
            units_at = 2
        else:
            separator = self._separator(lines[:LAYOUT_LINES])
            open_end = not cut and len(lines) <= LAYOUT_LINES and bool(physical[-1].strip())
            header = _header_line(lines[:LAYOUT_LINES], separator, open_end)
            header, units_at = _units_under(lines, header, separator)
            first_row = header + 1 if units_at is None else units_at + 1
        if not toa5 and _open_quote(lines[header], separator):
            # (an RFC 4180 field may hold a line break inside its quotes: the header is
            # found line by line, and such a name would split the header in two)
            raise ReaderError(
                f"{self.path}: the header line {_shorten(lines[header])!r} leaves a quote "
                "open: a column name with a line break inside its quotes is not read; put "
                "each name on one line"
            )
        if not toa5 and (
            _is_data(_fields(lines[header], separator), separator)
            or _counted_on(lines[header : header + 3], separator)
        ):
            raise ReaderError(
                f"{self.path}: no header line: the first line is data "
                f"({_shorten(lines[header])!r}: every field a number or a time): add a line "
                "naming the columns above it (such as 'time,a,b')"
            )
        if first_row >= len(lines) and (toa5 or not cut):  # a header alone
            damaged = f", before the damage ({damage})" if damage is not None else ""
            what = "a header line" if toa5 or units_at is None else "a header and a units line"
            raise ReaderError(f"{self.path}: no data rows ({what} only{damaged})")
        given = [h.strip() or f"column{i}" for i, h in enumerate(_fields(lines[header], separator))]
        names = _unique(given)
        if len(names) < 2:
            raise ReaderError(f"{self.path}: no numeric column (a single column {names[0]!r})")
        time_column, time_unit = _time_column(names)
        units: tuple[str, ...] = ()
        if units_at is not None:
            cells = _fields(lines[units_at], separator)[: len(names)]
            units = tuple(
                "" if i == time_column and c.strip().lower() in UNIT_LABELS else _unbracketed(c)
                for i, c in enumerate(cells + [""] * (len(names) - len(cells)))
            )
        ignored: tuple[int, ...] = ()
        if toa5:  # the row counter: RECORD, its units RN
            ignored = tuple(i for i, u in enumerate(units) if u == "RN" or names[i] == "RECORD")
        elif units and time_unit == "s":  # a unit there scales numeric times as one in the name
            time_unit = _time_unit_cell(units[time_column]) or time_unit
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
            units=units,
            units_line=numbered[units_at][0] + 1 if units_at is not None and not toa5 else 0,
            renamed=tuple((g, n) for g, n in zip(given, names, strict=True) if g != n),
            header_start_ns=_lvm_start(lines[:header]) if lines[0].startswith(LVM) else None,
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
    def _stream(self) -> Generator[tuple[pa.RecordBatch, int], None, None]:
        """The blocks of the body with the count of rows skipped for a wrong number of
        fields since the previous block; the columns of :attr:`_fast` as float64 as long
        as every cell of theirs parses as a finite number, else (from the first block
        where one does not) every column as text.

        Arrow's parse of a float64 column accepts exactly the cells that
        :func:`_all_numbers` accepts after trimming blanks and tabs, with the same
        value, so a fast block equals the text block converted. A block that fails
        (or holds nan/inf, which the text path treats apart) is read again as text by a
        second reader, which parses the rows before it again without yielding them (by
        their count: where a ``.gz`` is damaged, the blocks are not cut at the same
        places on every read, see :meth:`_blocks`). Its row-skip count restarts from the
        file's beginning; the first block it yields carries the difference, so that the
        total is that of the text read.
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
                    done += batch.num_rows
                    counted += invalid
                else:
                    return
            except (pa.ArrowException, OSError, EOFError, ValueError):
                pass  # the text read below meets the same error at the same row
            finally:
                fast.close()
        invalid_total = 0
        for batch, invalid in self._batches():
            invalid_total += invalid
            if done and done >= batch.num_rows:  # rows the float64 read passed on
                done -= batch.num_rows
                continue
            yield batch.slice(done) if done else batch, invalid_total - counted
            done = 0
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
        self._invalid_at, self._lines_skipped = [], 0

        def skip_row(row: Any) -> str:
            # a cell opening a quote that is never closed joins the lines up to the next
            # quote (or the end of the file) into this one bad row: count them all
            lines = len(_LINE_BREAK.split(str(getattr(row, "text", "") or "").rstrip("\r\n")))
            number = getattr(row, "number", None)
            if layout.compressed and isinstance(number, int) and number > 0:
                # Arrow's number counts the lines skip_rows skips, then non-blank lines
                self._invalid_at.append(number - layout.skip_rows - 1 - self._lines_skipped)
            self._lines_skipped += lines
            invalid[0] += lines
            if lines > 1:
                at = f" at line {number}" if isinstance(number, int) and number > 0 else ""
                note = f"a quote opened{at} is never closed: {lines} lines read as one row, skipped"
                if note not in self._notes:
                    self._notes.append(note)
            return "skip"

        # a block is passed on once the next one is read: the last one may lose a row
        # cut short (see _cut_row)
        held: tuple[pa.RecordBatch, int] | None = None
        blocks = self._blocks(column_types, skip_row, invalid)
        try:
            for block in blocks:
                if held is not None:
                    yield held
                held = block
        except (pa.ArrowException, OSError, EOFError, ValueError):
            if held is not None:  # the rows before the error are read
                yield held
            raise
        finally:
            blocks.close()
        if held is None:
            return
        batch, count = held
        if batch.num_rows and self._damage is None:
            tail = self._gzip_tail if layout.compressed else self._tail()
            note = self._cut_row(tail)
            if note is not None:
                batch = batch.slice(0, batch.num_rows - 1)
                self._rows_cut = 1
                if note not in self._notes:
                    self._notes.append(note)
        yield batch, count

    def _blocks(
        self, column_types: dict[str, pa.DataType], skip_row: Any, invalid: list[int]
    ) -> Generator[tuple[pa.RecordBatch, int], None, None]:
        """Arrow's blocks of the body, each with the count of rows ``skip_row`` skipped
        while it was parsed (``invalid[0]``).

        A ``.gz`` is inflated by Arrow (``CompressedInputStream``, in C++). Where that
        fails (a stream cut short by a power loss, or corrupt), Arrow fails the block
        being read, and its streaming reader loses the blocks it had read ahead: a
        ``.csv.gz`` cut at 70 % gave 9 371 of its 20 980 whole rows, one cut at 50 %
        none. The file is then read again by :class:`_Gunzip`, which stops at the last
        whole line before the damage (and names it: :attr:`_damage`), passing over the
        rows already passed on. (Inflating every ``.gz`` by :class:`_Gunzip` through a
        Python file cost 5 % more time on a 57 MB file, which this way only a damaged
        file pays.)"""
        self._damage, self._damage_cut, self._gzip_tail = None, 0, b""
        self._corrupt = False
        passed = 0  # rows passed on
        counted = 0  # rows skipped while they were parsed
        arrow = self._arrow_blocks(column_types, skip_row, invalid)
        try:
            for batch, count in arrow:
                yield batch, count
                passed += batch.num_rows
                counted += count
            return  # a clean end (whose tail _cut_row does not see in a .gz)
        except (pa.ArrowException, OSError):
            if not self._layout.compressed:
                raise
        finally:
            arrow.close()
        yield from self._inflated_blocks(column_types, skip_row, invalid, passed, counted)

    def _arrow_blocks(
        self, column_types: dict[str, pa.DataType], skip_row: Any, invalid: list[int]
    ) -> Generator[tuple[pa.RecordBatch, int], None, None]:
        """Arrow's blocks of the file, read (and a ``.gz`` inflated) by Arrow alone.

        The file is not closed here: it closes when the last of Arrow's references to it
        goes. Arrow's streaming reader reads the file ahead on its I/O threads, and a
        reader closed before the end (:meth:`_first_batch`, a float64 read given up) can
        still have a read in flight; closed by hand, its descriptor went back to the
        system in the middle of that read, whose loop then asked the descriptor for the
        rest of its block (``read`` again after a short read at the end of the file) when
        the number was already the next reader's file of the same CSV: the next read lost
        exactly ``BLOCK_BYTES`` less the file's size modulo ``BLOCK_BYTES`` from wherever
        it had got to (about 1 in 600 stressed analyses: 2 265-2 397 rows of 30 000 gone,
        at the start or in the middle; of the two losses logged with their file, 2 340
        and 2 390 rows where that many bytes are 2 344 and 2 389 rows of it;
        benchmarks/README.md, ``stress_repeat.py``). Arrow's lock around a file's reads
        and its close checks nothing in a release build. :meth:`_check_rows` catches such
        a read, should it happen some other way."""
        raw = _arrow_file(self.path)
        stream = pa.CompressedInputStream(raw, "gzip") if self._layout.compressed else raw
        reader = self._open(stream, column_types, skip_row)
        try:
            for blocks, batch in enumerate(reader, start=1):
                count, invalid[0] = invalid[0], 0
                # how far the reader has got: a block is BLOCK_BYTES of the text
                # (Arrow reads the file itself far ahead); of a .gz, the position in
                # the compressed file
                with contextlib.suppress(OSError, pa.ArrowException):
                    at = raw.tell() if self._layout.compressed else blocks * BLOCK_BYTES
                    self.fraction_read = max(self.fraction_read, min(1.0, at / self._size))
                yield batch, count
        finally:
            reader.close()

    def _inflated_blocks(
        self,
        column_types: dict[str, pa.DataType],
        skip_row: Any,
        invalid: list[int],
        passed: int,
        counted: int,
    ) -> Generator[tuple[pa.RecordBatch, int], None, None]:
        """The blocks of a ``.gz`` inflated by :class:`_Gunzip` after the first
        ``passed`` rows (and ``counted`` rows skipped): see :meth:`_blocks`. The stream is
        inflated once to its damage first (at C speed, only a damaged file pays it): what
        the damage is must be known before the first block (:attr:`_corrupt`: the rows
        read are then checked for garbage, see :class:`_Garbage`).

        The files are closed by hand at the end, unlike :meth:`_arrow_blocks`'s, and
        safely. Arrow's reader reads ahead on its I/O threads here too: a reader given
        up after its first block (:meth:`_first_batch`) often has a read of the
        ``_Gunzip`` in flight, and left open it asked for 33 more blocks of a 55 MB text
        within half a second, until its read-ahead queue was full. But each read is a call of
        ``_Gunzip.read`` (Python, under the GIL), never a read of a descriptor number:
        after ``PythonFile.close`` Arrow refuses the reads ("operation on closed Python
        file"), and a read already inside ``_Gunzip.read`` gets the rest of its own
        stream or ``ValueError: read of closed file`` (a buffered file's close waits for
        a read in progress; a closed Python file holds no number). With
        ``benchmarks/gunzip_close_race.py``, 1 110 readers given up and closed by hand,
        each followed by full reads of the plain CSV through an ``OSFile`` on the number
        the ``.gz`` had just given back and of the damaged ``.gz``: 1 039 reads ended
        after a close (464 with text of their own stream, 575 raised), no row lost.
        Closing also stops that wasted inflation and frees the descriptor at once."""
        self._damage, self._corrupt = self._gzip_check()
        self._invalid_at, self._lines_skipped = [], 0  # a new reader from the file's start
        invalid[0] = 0
        gunzip = _Gunzip(self.path)
        source = pa.PythonFile(gunzip, mode="r")
        total = 0
        last: pa.RecordBatch | None = None
        try:
            reader = self._open(source, column_types, skip_row)
            try:
                for batch in reader:
                    total += invalid[0]
                    invalid[0] = 0
                    last = batch
                    with contextlib.suppress(OSError, ValueError):
                        at = gunzip.position
                        self.fraction_read = max(self.fraction_read, min(1.0, at / self._size))
                    if passed >= batch.num_rows:
                        passed -= batch.num_rows
                        continue
                    yield batch.slice(passed) if passed else batch, total - counted
                    passed = 0
                    counted = total
            finally:
                reader.close()
            total += invalid[0]
            if last is not None and total > counted:  # rows skipped after the last row
                yield last.slice(0, 0), total - counted
        finally:
            if gunzip.damage is not None:  # (None: closed before the end)
                self._damage = gunzip.damage
                self._damage_cut = gunzip.cut_bytes
                self._gzip_tail = gunzip.tail
            source.close()
            gunzip.close()

    def _tail(self) -> bytes:
        """The last :data:`SAMPLE_BYTES` of a plain (not compressed) file."""
        with self.path.open("rb") as handle:
            handle.seek(max(0, self._size - SAMPLE_BYTES))
            return handle.read(SAMPLE_BYTES)

    def _cut_row(self, tail: bytes | memoryview) -> str | None:
        """What to say when the last row of the file (``tail`` ends the text) is cut
        short in its last field, else None: the file ends without a line break, that
        row has all its fields, and its last cell is blank or has fewer decimals than
        every one of the (at least :data:`CUT_ROW_LINES` // 10) non-blank numbers of
        that column in the lines above it (``-0.8`` under ``-0.8417832579164083``, a
        power loss in the middle of writing it). Such a row is dropped, as a row cut
        in an earlier field is (its field count is wrong). Many writers end the file
        without a line break: a last row that looks whole is read without a word. The
        end of a ``.gz`` that Arrow inflated to its end is not seen (``tail`` is empty):
        a gzip stream cut by a power loss has no end, and is read up to its last whole
        line (see :meth:`_blocks`)."""
        tail = bytes(tail[-SAMPLE_BYTES:])
        if not tail or tail.endswith((b"\n", b"\r")):
            return None
        text = tail.decode(self._layout.encoding, errors="replace")
        lines = [line for line in _LINE_BREAK.split(text)[1:] if line.strip()]
        if len(lines) < 2:
            return None
        width = len(self._layout.names)
        separator = self._layout.separator
        last = _fields(lines[-1], separator)
        if len(last) != width:
            return None  # skipped for its field count (and counted) already
        above = [_fields(line, separator) for line in lines[-CUT_ROW_LINES - 1 : -1]]
        decimals = [_decimals(f[-1], separator) for f in above if len(f) == width]
        if len(decimals) < CUT_ROW_LINES // 10 or None in decimals:
            return None
        fewest = min(d for d in decimals if d is not None)
        cell = last[-1].strip()
        mine = _decimals(cell, separator) if cell else -1
        if mine is None or mine >= fewest:
            return None
        name = self._layout.names[-1]
        return (
            f"the last line (no line break after it) dropped: its cell {cell!r} of column "
            f"{name!r} has fewer decimals than that column in any of the {len(decimals)} "
            "lines above it (cut short when writing stopped?)"
        )

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

    def _arrow_words(self, err: BaseException) -> str:
        """Arrow's error ``err`` in plain words where it is about a line longer than its
        block (:data:`BLOCK_BYTES`): "straddling object straddles two block boundaries
        (try to increase block size?)" for a data line, "header is larger than block
        size" for the header (a line of a million columns: only the head of the file is
        split into names, so their count is not said); else its own, on one line."""
        text = one_line(err)
        most = f"{BLOCK_BYTES >> 20} MiB, the most one line may hold"
        if "straddl" in text:
            return f"a line longer than {most}: damaged, or not a table of readings?"
        if "header is larger than block size" in text:
            return f"its header line is longer than {most}: a table of too many columns?"
        return text

    def _first_batch(self) -> pa.RecordBatch | None:
        """The body's first block with rows, every column as text (None: none has)."""
        with contextlib.closing(self._batches()) as blocks:
            return next((b for b, _ in blocks if b.num_rows), None)

    def _inspect_first_block(self) -> int | None:
        try:
            batch = self._first_batch()
        except (pa.ArrowException, OSError, EOFError, ValueError) as err:
            check_limit(err)  # (the machine's limit is not the file's damage)
            why = self._arrow_words(err)
            raise ReaderError(f"{self.path}: cannot parse as CSV ({why})") from err
        if batch is None:
            # the rows are there (a header alone is found by _detect) but Arrow skipped
            # them all for their number of fields: a damaged header, or lines above it
            # that _header_line did not tell from the header
            raise ReaderError(
                f"{self.path}: no data rows: no line under the first has its "
                f"{len(self._layout.names)} fields (is the first line the header?)"
            )
        self._join_date(batch)
        if self._layout.compressed:
            # the rows inflated after a damage may be garbage: the rows before it alone
            # say what the columns and the times are (whether they are absolute, above all)
            t_ns, keep = self._times(self._time_cells(batch), first=True)
            found = self._garbage_at(_Garbage(), batch, t_ns, keep, 0)
            if found is not None:
                batch = batch.slice(0, found[0])
            if batch.num_rows == 0:
                raise ReaderError(f"{self.path}: no data rows before the damage ({self._damage})")
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
        if not numeric:  # readable, nothing to analyze: said where it is listed or used
            text = [
                name
                for index, name in enumerate(self._layout.names)
                if self._numeric.get(index) is False
            ]
            self._no_numeric = (
                "no numeric column besides the time column "
                f"{self._layout.names[self._layout.time_column]!r}"
                + (f" (text: {capped(text, 4, what='columns')})" if text else "")
            )
        time_column = self._time_cells(batch)
        t_ns, keep = self._times(time_column, first=True)
        if self._time_kind in ("datetime", "timeofday"):
            cells = self._clean(time_column)
            cells = cells.filter(pc.cast(pc.utf8_length(cells), pa.bool_()))
            tail = _CLOCK_TAIL.search(str(cells[0].as_py())) if len(cells) else None
            self._zoneless = not (tail and tail.group(1))
            self._zone = (tail.group(1) or "").strip() if tail else ""
        if not bool(keep.any()):
            name = self._layout.names[self._layout.time_column]
            text = self._clean(time_column)
            numbers = text.filter(pc.match_substring_regex(text, FINITE))
            if self._time_kind in ("seconds", "ns") and len(numbers):
                # numbers that int64 nanoseconds cannot hold, such as epoch milliseconds
                # read as seconds: say so, not that there are no numbers
                unit = "ns" if self._time_kind == "ns" else self._layout.time_unit
                cell = numbers[0].as_py()
                raise ReaderError(
                    f"{self.path}: time column {name!r}: {cell!r} is no time: "
                    f"as {_UNIT_NAMES[unit]} it lies outside the years 1677-2262"
                    + (_epoch_unit_hint(cell) if unit == "s" else "")
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
        # a "nan" cell is no reading, as a blank one is (numpy.savetxt writes missing
        # values so: counted as samples, its channel showed no gap)
        present &= ~np.isnan(out)
        return present, out, bad

    def _times(self, column: pa.Array, *, first: bool = False) -> tuple[IntArray, np.ndarray]:
        """:meth:`_own_times` plus the absolute start another column gave (:meth:`_anchor`)."""
        out, keep = self._own_times(column, first=first)
        if self._offset:
            out[keep] += self._offset
        return out, keep

    def _own_times(self, column: pa.Array, *, first: bool = False) -> tuple[IntArray, np.ndarray]:
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
            # as nanoseconds, epoch microseconds (1.77e15) are 1970: seconds then, which
            # int64 nanoseconds cannot hold, and the file is refused by name (naming
            # both readings: nanoseconds since boot are such integers too); integers
            # that are no date either way are nanoseconds from another start
            if (
                largest is not None
                and largest > NS_THRESHOLD
                and (plausible_epoch(int(largest)) or not _epoch_microseconds(largest))
            ):
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
            self._time_format, self._day_first = _datetime_format(series, self._tail_cells)
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


def _epoch_microseconds(value: float) -> bool:
    """Whether ``value`` as microseconds is a date after 1973
    (:func:`~analyzer.timeutil.plausible_epoch`) that int64 nanoseconds hold."""
    return value * 1e3 < _NS_MAX and plausible_epoch(int(value * 1e3))


def _epoch_unit_hint(cell: str) -> str:
    """What a number that is no time in seconds may be: epoch milliseconds or
    microseconds (the unit that gives a date after 1973, where one does), and how to say
    so in the column's name."""
    try:
        value = abs(float(cell))
    except ValueError:
        value = 0.0
    boot = (
        "; 'time [ns]' if they are nanoseconds counted from another start, such as since boot"
        if _INTEGER.match(cell.strip())
        else ""
    )
    for unit, digits, name in (("ms", 3, "milliseconds"), ("us", 6, "microseconds")):
        if plausible_epoch(int(value * 10.0 ** (9 - digits))) and value < 10.0 ** (10 + digits):
            return f" (epoch {name}? a name such as 'time [{unit}]' says so{boot})"
    return (
        " (epoch milliseconds or microseconds? a name such as 'time [ms]' or 'time [us]' "
        "says so; 'time [ns]' for nanoseconds from a start other than 1970)"
    )


def _date_times(text: pa.Array) -> tuple[IntArray, np.ndarray]:
    """Nanoseconds of the cells of ``text`` that are ISO 8601 date-times (UTC where no
    zone is given) and the mask of those that are; none when fewer than
    :data:`NUMERIC_SHARE` of the non-blank cells are (not a column of date-times)."""
    import pandas as pd

    series = pd.Series(text.to_numpy(zero_copy_only=False), dtype=object)
    series = series.where(series != "", None)
    out = np.zeros(len(series), dtype=np.int64)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        parsed = pd.to_datetime(series, utc=True, format="ISO8601", errors="coerce")
    lo, hi = pd.Timestamp(_NS_MIN, tz="UTC"), pd.Timestamp(_NS_MAX, tz="UTC")
    keep = np.asarray((parsed.notna() & (parsed >= lo) & (parsed <= hi)).to_numpy(), dtype=bool)
    if int(keep.sum()) < NUMERIC_SHARE * int(series.notna().sum()) or not keep.any():
        return out, np.zeros(len(series), dtype=bool)
    out[keep] = parsed[keep].dt.as_unit("ns").astype("int64").to_numpy()
    return out, keep


def _iso_date_times(text: pa.Array) -> tuple[IntArray, np.ndarray]:
    """:func:`_date_times`, by Arrow's own cast where every cell is an ISO 8601
    date-time of one kind (all with a zone, or all without: UTC), else by pandas: every
    block of a file that :meth:`CsvReader._anchor` made absolute is compared, and Arrow
    parses 60 000 cells in 1.6 ms, pandas in 54 ms (the same nanoseconds)."""
    for kind in (pa.timestamp("ns", "UTC"), pa.timestamp("ns")):
        try:
            ns = pc.cast(pc.cast(text, kind), pa.int64())
        except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
            continue
        if not ns.null_count:
            return np.asarray(_numpy(ns), dtype=np.int64), np.ones(len(ns), dtype=bool)
    return _date_times(text)


def _resolution(ns: IntArray) -> int:
    """The largest power of ten nanoseconds, up to a second, that every time of ``ns``
    is a multiple of: the resolution the times were written with (``12:00:01.250``:
    10 ms)."""
    for digits in range(9, 0, -1):
        if not bool(np.any(ns % 10**digits)):
            return 10**digits
    return 1


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


def _datetime_format(
    series: pd.Series, tail: Callable[[], Sequence[str]] = list
) -> tuple[str, str | None]:
    """A format that parses ``series`` (ISO 8601 if it does, else pandas' inference),
    and, where the day and the month of its dates could be either way round
    (``01/03/2026``) and neither the sample nor ``tail()`` (the file's last time cells,
    read only then) has a day above 12 to tell, the day-first format, the other reading
    (the month-first one is returned first, pandas' own default): else None."""
    import pandas as pd

    sample = series.dropna().iloc[:FORMAT_SAMPLE]
    for fmt in ("ISO8601", None):
        if not _parses(sample, fmt):
            continue
        if fmt is None:
            if not len(sample):
                return "mixed", None
            month, day = _date_orders(str(sample.iloc[0]))
            if month and day and month != day:
                # the tail's cells that are dates either way (not a header line of a
                # short file, nor a last line cut short)
                ends = [c for c in tail() if _parses_one(c, month) or _parses_one(c, day)]
                cells = pd.concat([sample, pd.Series(ends, dtype=object)])
                fits_month, fits_day = _parses(cells, month), _parses(cells, day)
                if fits_day and not fits_month:  # a day above 12 somewhere (13/03)
                    return day, None
                if fits_month and fits_day:
                    return month, day
            return (month or day or "mixed"), None
        return fmt, None
    return "mixed", None


def _parses(cells: pd.Series, fmt: str | None) -> bool:
    """Whether pandas parses every cell of ``cells`` with ``fmt``."""
    import pandas as pd

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "could not infer format"
            pd.to_datetime(cells, utc=True, format=fmt)
    except (ValueError, TypeError):
        return False
    return True


def _parses_one(cell: str, fmt: str) -> bool:
    """Whether ``cell`` is a date-time of ``fmt`` (:func:`datetime.strptime`'s rules, as
    pandas' for an explicit format)."""
    import datetime as dt

    try:
        dt.datetime.strptime(cell, fmt)
    except ValueError:
        return False
    return True


def _date_orders(cell: str) -> tuple[str | None, str | None]:
    """pandas' month-first and day-first formats of the date-time ``cell``."""
    from pandas.tseries.api import guess_datetime_format

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # (its own "could not infer")
        return guess_datetime_format(cell), guess_datetime_format(cell, dayfirst=True)


def date_order(fmt: str | None) -> str:
    """``"day"`` or ``"month"`` first in a strptime format with both, else ``""``."""
    if not fmt or "%d" not in fmt or "%m" not in fmt:
        return ""
    return "day" if fmt.index("%d") < fmt.index("%m") else "month"


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


def _open_quote(line: str, separator: str) -> bool:
    """Whether a field of ``line`` opens a quote that the line does not close: a field
    that begins with ``"`` (after blanks) whose closing quote never comes (``""`` inside
    it is a quote). A literal quote inside an unquoted field (``Diameter (")``), or text
    after a closing quote (``"Temp"C``, ``"time" ,``), opens nothing."""
    quoted, at_start, k = False, True, 0
    while k < len(line):
        ch = line[k]
        if quoted:
            if ch == '"':
                if k + 1 < len(line) and line[k + 1] == '"':
                    k += 1  # an escaped quote
                else:
                    quoted = False
        elif ch == separator:
            at_start = True
        elif ch == '"' and at_start:
            quoted, at_start = True, False
        elif not ch.isspace():
            at_start = False
        k += 1
    return quoted


def _lvm_start(lines: Sequence[str]) -> int | None:
    """The start an ``.lvm`` file's first header gives, ``Date`` (``2026/03/29``) and
    ``Time`` (``00:58:00.000``, to as many decimals as LabVIEW writes), in nanoseconds
    since 1970 read as UTC (the header says no zone); None where either is missing or
    unreadable. Only the lines before the first :data:`LVM_END` are read (a segment's
    header may repeat them)."""
    fields: dict[str, str] = {}
    for line in lines:
        if line.strip().startswith(LVM_END):
            break
        parts = re.split(r"[\t,;]", line.strip(), maxsplit=1)
        value = parts[1].strip() if len(parts) > 1 else ""
        fields.setdefault(parts[0].strip().lower(), value)
    date = _LVM_DATE.match(fields.get("date", ""))
    time = _LVM_TIME.match(fields.get("time", ""))
    if date is None or time is None:
        return None
    try:
        day = np.datetime64(
            f"{int(date[1]):04d}-{int(date[2]):02d}-{int(date[3]):02d}", "ns"
        ).astype(np.int64)
    except ValueError:
        return None
    hours, minutes, seconds = int(time[1]), int(time[2]), int(time[3])
    if hours > 23 or minutes > 59 or seconds > 60:
        return None
    fraction = int((time[4] or "0")[:9].ljust(9, "0"))
    return int(day) + ((hours * 60 + minutes) * 60 + seconds) * 1_000_000_000 + fraction


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
        # (a first row with a "nan" cell was taken for the header: numpy.savetxt)
        return sum(1 for f in fields if not f or _FINITE.match(f) or _NOT_A_NUMBER.match(f)) / len(
            fields
        )

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


def _is_data(fields: list[str], separator: str) -> bool:
    """Whether the fields of a would-be header are those of a row: the time column's
    (:func:`_time_column` of them) a number, date-time or time of day, every other one a
    number or blank, at least one of them a number. A header may name some columns by
    numbers (``time,100,200``) or all of them: fields that are all distinct integers in
    increasing order (``0,1,2,3``, ``1,2,3``, ``101,102,103``, ``2024,2025,2026``,
    ``-1,0,1``) number the columns, which a row's values, its time among them,
    practically never do (``0.0,1,2`` is a row)."""
    cells = [f.strip() for f in fields]
    if len(cells) < 2:
        return False
    time_column, _ = _time_column(cells)
    values = cells[:time_column] + cells[time_column + 1 :]
    if not any(values) or any(v and _decimals(v, separator) is None for v in values):
        return False
    when = cells[time_column]
    if _decimals(when, separator) is None and not _DATA_TIME.match(when):
        return False
    if all(_INTEGER.match(c) for c in cells):
        numbers = [int(c) for c in cells]
        return not all(a < b for a, b in zip(numbers, numbers[1:], strict=False))
    return True


def _counted_on(lines: list[str], separator: str) -> bool:
    """Whether a would-be header of increasing integers, which :func:`_is_data` takes
    for column numbers, is the first row of a header-less integer export: its fields
    not consecutive (``0,1,2`` and ``1,2,3`` number columns, as pandas writes a frame's
    default names: a header), the two lines under it all integers as well, with as many
    fields, and its first field and theirs equally spaced (a sample counter:
    ``0,500,514`` over ``1,496,494`` and ``2,503,511``). Such a file was read with its
    first row for a header, the channels named by two readings and that row lost,
    without a word."""
    if len(lines) < 3:
        return False
    rows = [[c.strip() for c in _fields(line, separator)] for line in lines]
    if len(rows[0]) < 2 or any(len(r) != len(rows[0]) for r in rows):
        return False
    if not all(_INTEGER.match(c) for r in rows for c in r):
        return False
    head = [int(c) for c in rows[0]]
    if all(b - a == 1 for a, b in zip(head, head[1:], strict=False)):
        return False
    a, b, c = (int(r[0]) for r in rows)
    return b - a == c - b != 0


def _units_under(lines: list[str], header: int, separator: str) -> tuple[int, int | None]:
    """The index of the header among ``lines`` and that of a units line right under it
    (None: none), from the header :func:`_header_line` found. A units line has no
    number, so that function takes it for the header where it has the rows' field
    count (the header above it for a line of a preamble), and for the first row where
    the rows have many blank cells: both are looked at (see :func:`_is_units`)."""
    if header > 0 and not lines[header - 1].lstrip().startswith("#"):
        names = _fields(lines[header - 1], separator)
        if _is_units(names, _fields(lines[header], separator)) and not _is_data(names, separator):
            return header - 1, header
    if header + 1 < len(lines):
        below = _fields(lines[header + 1], separator)
        if _is_units(_fields(lines[header], separator), below):
            return header, header + 1
    return header, None


def _is_units(names: list[str], cells: list[str]) -> bool:
    """Whether ``cells``, the fields of the line under a header of ``names``, are units:
    as many fields; under the time column (:func:`_time_column` of ``names``) a time unit
    (``s``, ``[ms]``), zone, format (``UTC``, ``hh:mm:ss``) or nothing; in the other
    columns a blank or a short cell shaped as a unit (:data:`_UNIT_SHAPE`, at most
    :data:`UNIT_CELL_CHARS` characters; no number, no ``nan``), one at least not blank.
    Where the time column's cell is blank, every other cell must be a known unit
    (:func:`_known_unit`), else one of them. A row has a number somewhere; a preamble
    line above the header puts a name under the time column (``time,s0,s1`` is no units
    line), as a second header line naming the channels does (``Time,north,south``)."""
    if len(cells) != len(names) or len(cells) < 2:
        return False
    units = [_unbracketed(cell) for cell in cells]
    when = units.pop(_time_column(names)[0])
    if _time_unit_cell(when) is None:
        return False
    values = [unit for unit in units if unit]
    if not values or not all(_unit_like(unit) for unit in values):
        return False
    known = [_known_unit(unit) for unit in values]
    return any(known) if when else all(known)


def _unbracketed(cell: str) -> str:
    """A units line's cell without blanks and brackets around it (``[m/s2]``: ``m/s2``)."""
    text = cell.strip()
    if len(text) > 1 and text[0] + text[-1] in ("[]", "()", "{}"):
        return text[1:-1].strip()
    return text


def _time_unit_cell(cell: str) -> str | None:
    """Of a units line's cell under the time column: the unit of numeric times (a key of
    :data:`TIME_UNITS`), ``""`` where it gives none (blank; a zone or format such as
    ``UTC`` or ``yyyy-mm-dd hh:mm:ss``; Campbell's ``TS``; a ``Unit`` label), None where
    it is no such cell."""
    text = cell.strip().lower()
    if text in _BRACKET_UNITS:
        return _BRACKET_UNITS[text]
    if not text or text == "ts" or text in UNIT_LABELS or _TIME_NOTE.fullmatch(text):
        return ""
    return None


def _unit_like(cell: str) -> bool:
    """Whether a units line's cell (unbracketed, not blank) is shaped as a unit: short,
    symbols or words with powers (:data:`_UNIT_SHAPE`), or a dash (dimensionless); not
    ``nan``, ``NA``, ``true``."""
    if cell in ("-", "--", "–", "—"):
        return True
    return (
        len(cell) <= UNIT_CELL_CHARS
        and _UNIT_SHAPE.fullmatch(cell) is not None
        and not _NOT_A_NUMBER.match(cell)
        and cell.lower() not in ("true", "false")
    )


def _known_unit(cell: str) -> bool:
    """Whether every word of ``cell`` (powers aside) is a unit: one of
    :data:`_UNIT_LETTERS` in its case, or, any case, an SI prefix and one of
    :data:`_UNIT_SYMBOLS` (``mm``, ``kN``, ``mV/V``) or one of :data:`_UNIT_NAMES_ALONE`
    (``°C``, ``Deg C``, ``ue``, ``psi``, ``counts``)."""
    words = [word.rstrip("⁰¹²³⁴⁵⁶⁷⁸⁹⁻⁺") for word in _UNIT_WORD.findall(cell)]
    return bool(words) and all(_known_word(word) for word in words)


def _known_word(word: str) -> bool:
    """Whether one word of a unit is a unit (see :func:`_known_unit`)."""
    if len(word) == 1:
        return word in _UNIT_LETTERS
    word = word.lower()
    return word in _UNIT_NAMES_ALONE or any(
        word.startswith(p) and word[len(p) :] in _UNIT_SYMBOLS for p in _UNIT_PREFIXES
    )


def _units_note(layout: _Layout) -> str:
    """What ``info.errors`` says of a units line: which line, and each column's unit."""
    named = [f"{n} [{u}]" for n, u in zip(layout.names, layout.units, strict=True) if u]
    shown, size = 0, 0
    while shown < len(named) and size + len(named[shown]) <= UNITS_NOTE_CHARS:
        size += len(named[shown]) + 2
        shown += 1
    shown = max(shown, 1)
    text = ", ".join(named[:shown])
    if shown < len(named):
        text += f", ... ({len(named) - shown} more)"
    return f"line {layout.units_line} read as units, not as data: {text}"


def _shorten(text: str, most: int = 60) -> str:
    """``text`` cut to ``most`` characters, ``...`` saying so."""
    return text if len(text) <= most else text[: most - 3] + "..."


def _date_column(names: Sequence[str], time_column: int) -> int | None:
    """The first column other than ``time_column`` whose name, lowercased and less a
    format in brackets (``Date (dd.mm.yyyy)``), is one of :data:`DATE_NAMES` (None:
    none), for :meth:`CsvReader._join_date`."""
    for i, name in enumerate(names):
        base = name.strip().lower()
        if found := _BRACKETED.fullmatch(base):
            base = found.group(1).strip()
        if i != time_column and base in DATE_NAMES:
            return i
    return None


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


def _arrow_file(path: Path) -> pa.NativeFile:
    """``path`` opened for Arrow: its own file reader, or, for a name that is no UTF-8
    (a Latin-1 name from an SMB share, which Python holds with surrogates), Python's
    (Arrow encodes the name as UTF-8 and refused it: "cannot parse as CSV")."""
    name = str(path)
    if any("\udc80" <= c <= "\udcff" for c in name):  # (bytes that are no UTF-8)
        return pa.PythonFile(open(path, "rb"), mode="r")  # noqa: SIM115 - closed as Arrow lets go
    return pa.OSFile(name)


_SHORT_READS: set[tuple[str, int, int, int]] = set()
"""(file, size, lines, rows read) of the reads :meth:`CsvReader._check_rows` found short
in this process: the same shortfall again is the count's blind spot, not a lost read."""


def _digest_and_lines(path: Path, compressed: bool) -> tuple[int, str, int | None]:
    """Size and sha256 of the file's bytes (read in :data:`HASH_BLOCK` blocks, as
    :func:`~analyzer.readers._common.file_digest` does) and, in the same pass, its count
    of lines, where the count is exact: None for a ``.gz`` (its bytes are not the text),
    a file with a quote (a field may hold a line break), a lone carriage return (an
    old Mac line end, which Arrow counts as a line break too) or a blank line (which
    Arrow skips without counting). A last line without a line break counts. One numpy
    comparison per block, a pass over the line breaks' positions and two byte
    searches: a 124 MB file hashed in 0.166 s instead of 0.089 s (the best of 4; 46 ms
    of it the line breaks, the fastest of three ways tried: ``bytes.count`` with a
    search for blank lines took 0.19 s, numpy's neighbouring line breaks 0.16 s)."""
    digest = hashlib.sha256()
    total = 0
    lines = 0
    exact = not compressed
    last_break = -1  # the position of the line break before the block's (-1: none yet)
    last_byte = 10  # the byte before the block's first (as if after a line break)
    with path.open("rb") as handle:
        while block := handle.read(HASH_BLOCK):
            digest.update(block)
            if exact:
                if b'"' in block:
                    exact = False
                else:
                    text = np.frombuffer(block, dtype=np.uint8)
                    at = np.flatnonzero(text == 10)
                    # the byte before each line break (a CRLF's carriage return)
                    before = text[np.maximum(at - 1, 0)]
                    if at.size and at[0] == 0:
                        before[0] = last_byte
                    if b"\r" in block:  # every carriage return ends a CRLF, or inexact
                        crs = int(np.count_nonzero(text == 13))
                        carried = int(at.size > 0 and at[0] == 0 and last_byte == 13)
                        ending = int(text[-1] == 13)  # (its line feed opens the next block)
                        exact = crs == int(np.count_nonzero(before == 13)) - carried + ending
                    if exact and at.size:
                        steps = np.diff(at + total, prepend=last_break)
                        exact = not bool(np.any((steps == 1) | ((steps == 2) & (before == 13))))
                        lines += int(at.size)
                        last_break = int(at[-1]) + total
                    last_byte = int(text[-1])
            total += len(block)
    if not exact or last_byte == 13:  # (a carriage return at the end: a lone one)
        return total, digest.hexdigest(), None
    if total and last_byte != 10:
        lines += 1  # the last line, without a line break
    return total, digest.hexdigest(), lines
