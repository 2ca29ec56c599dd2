"""Numbers as the report prints them. Templates show these strings as they are, so every
rounding decision lives here, next to the code that computed the number."""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from analyzer.diagnosis.classify import MIN_GAIN
from analyzer.timeutil import TIME_DECIMALS, seconds_text

MISSING = "n/a"

_CONTROLS = re.compile("[\x00-\x08\x0a-\x1f\x7f-\x9f\u061c\u200e\u200f\u202a-\u202e\u2066-\u2069]")
"""C0 and C1 control characters but the tab, and the bidi formatting characters (marks,
embeddings, overrides, isolates): in a channel name they would garble or reverse the
display of whatever follows them on the page (a time ``30.000 s`` shown as
``s 000.03``), and XML does not allow most C0 characters in an SVG text."""


def visible_controls(text: str) -> str:
    """``text`` with each control or bidi formatting character (:data:`_CONTROLS`)
    replaced by its visible escape (``\\u202e``): data from a recorder is shown as it
    is, but cannot reorder or hide the text around it."""
    return _CONTROLS.sub(lambda m: f"\\u{ord(m.group()):04x}", text)


def shorten(text: str, limit: int = 48) -> str:
    """``text`` cut to ``limit`` characters with an ellipsis in the middle (a deep ROS
    path keeps its root and its leaf), for figure labels; tables show the full name."""
    if len(text) <= limit:
        return text
    head = (limit - 1) // 2
    return text[:head] + "…" + text[len(text) - (limit - 1 - head) :]


_DIGITS = re.compile(r"(\d+)")


def natural_key(name: str) -> tuple[Any, ...]:
    """Sort key reading the numbers in a name as numbers: ``s2`` before ``s10`` (the
    headline listed "s0, s1, s10, s11, s2")."""
    parts = _DIGITS.split(name)
    # (kind, value) pairs: a number never meets a string (``acc1_x`` and ``acc1_x2`` once
    # compared the one's name with the other's 2, and the report was not written)
    return (tuple((1, int(p)) if i % 2 else (0, p) for i, p in enumerate(parts)), name)


def num(x: Any, digits: int = 4) -> str:
    """``x`` with ``digits`` significant digits; ``n/a`` for None, NaN or non-numbers."""
    if isinstance(x, bool):
        return "yes" if x else "no"
    try:
        v = float(x)
    except (TypeError, ValueError):
        return MISSING if x is None else str(x)
    if not math.isfinite(v):
        return MISSING
    if v == 0.0:
        return "0"
    return f"{v:.{digits}g}"


def num_range(lo: Any, hi: Any, digits: int = 4) -> str:
    """``lo to hi`` with at least ``digits`` significant digits and, when they differ
    but read alike, as many more (up to a double's 17) as make them read apart, and one
    more for their difference to read too: a barometer at 101321 to 101329 Pa read
    ``1.013e+05 to 1.013e+05``, a constant channel; now ``101321 to 101329``."""
    a, b = num(lo, digits), num(hi, digits)
    try:
        differ = float(lo) != float(hi)
    except (TypeError, ValueError):
        differ = False
    if not differ or a != b:
        return f"{a} to {b}"
    while a == b and digits < 17:
        digits += 1
        a, b = num(lo, digits), num(hi, digits)
    digits = min(digits + 1, 17)
    return f"{num(lo, digits)} to {num(hi, digits)}"


def seconds(x: float | None, decimals: int = 3) -> str:
    """``16.000 s``; ``n/a`` for None. Rounded as every line of the run rounds a time
    (:func:`analyzer.timeutil.seconds_text`: half up, as the ISO times): an onset at
    300.0625 s read ``300.062 s`` here and ``300.063 s`` on stderr."""
    if x is None or not math.isfinite(float(x)):
        return MISSING
    return f"{seconds_text(float(x), decimals)} s"


def time_decimals(rate_hz: float | None) -> int:
    """Decimals a time of a record sampled at ``rate_hz`` needs for one sample to read
    apart from the next, and no more: none at 1 Hz or slower, 2 at 100 Hz, 3 at 1 kHz, 4
    above (as many as findings.json keeps); 3 where the rate is not known. At 2 kHz an
    onset at 20.0005 s was shown as ``20.000 s`` above its ISO time
    ``...T00:00:20.001Z``: two times in one cell; at 1 Hz ``2121.000 s`` claimed
    a millisecond the record does not have (ux60 item 8)."""
    if rate_hz is None or not math.isfinite(float(rate_hz)) or rate_hz <= 0:
        return 3
    return min(TIME_DECIMALS, max(0, math.ceil(math.log10(float(rate_hz)) - 1e-9)))


TIME_UNITS = (("d", 86400.0, 3 * 86400.0), ("h", 3600.0, 3 * 3600.0), ("min", 60.0, 15 * 60.0))
"""(unit, seconds per unit, shortest span shown in it): a span below the last is shown
in seconds."""


def time_unit(span_s: float) -> tuple[str, float]:
    """The unit a span of ``span_s`` seconds reads best in and its length in seconds:
    ``("s", 1.0)`` below a quarter of an hour, then minutes, hours, days (findings.json
    keeps seconds; figures and captions of long records use these)."""
    for unit, scale, shortest in TIME_UNITS:
        if span_s >= shortest:
            return unit, scale
    return "s", 1.0


@dataclass(frozen=True, slots=True)
class Clock:
    """How the report writes a time from the record's start: in the unit its charts of
    the whole record use (:func:`time_unit`), rounded to the sample period
    (:func:`time_decimals`). A short record's times are seconds (``16.00 s`` at
    100 Hz); a long one's read as its charts' axes do, in minutes (or hours, days) and
    the seconds left: ``35 min 21 s`` at 1 Hz, ``30 min 0.00 s`` at 100 Hz, where the
    verdict table said ``2121.000 s`` beside charts in minutes (ux60 item 8).
    findings.json keeps seconds (``onset_s``)."""

    decimals: int = 3
    unit: str = "s"

    @classmethod
    def of(cls, span_s: float, rate_hz: float | None) -> Clock:
        """The clock of a record ``span_s`` long sampled at ``rate_hz``."""
        return cls(time_decimals(rate_hz), time_unit(span_s)[0])

    @property
    def long(self) -> bool:
        """Whether times are written in minutes or longer units."""
        return self.unit != "s"

    def __call__(self, x: float | None) -> str:
        """``x`` seconds from the start: ``16.00 s``, ``35 min 21 s``,
        ``2 h 5 min 21 s``; ``n/a`` for None or NaN."""
        if not self.long or x is None or not math.isfinite(float(x)):
            return seconds(x, self.decimals)
        return _split_time(float(x), self.decimals, self.unit)

    def words(self) -> str:
        """What the times are in, for a sentence: ``seconds``, ``minutes and seconds``."""
        return {
            "s": "seconds",
            "min": "minutes and seconds",
            "h": "hours, minutes and seconds",
        }.get(self.unit, "days, hours, minutes and seconds")

    def range(self, lo: float, hi: float) -> str:
        """``151.20 to 151.40 s``; ``29 min 59.99 s to 30 min 0.00 s`` in a long record."""
        if self.long:
            return f"{self(lo)} to {self(hi)}"
        return f"{seconds_text(float(lo), self.decimals)} to {seconds(hi, self.decimals)}"


def as_clock(when: Clock | int) -> Clock:
    """``when`` as a :class:`Clock`: a number of decimals is a short record's seconds."""
    return when if isinstance(when, Clock) else Clock(int(when))


_UNIT_SECONDS = {"d": 86400, "h": 3600, "min": 60}


def _split_time(x: float, decimals: int, unit: str) -> str:
    """``x`` seconds as whole units from ``unit`` down to minutes and the seconds left
    with ``decimals`` decimals: rounded before it is split (1799.999 s at 100 Hz is
    ``30 min 0.00 s``, not ``29 min 60.00 s``); a negative time keeps its sign."""
    sign = "-" if x < 0 else ""
    ticks = round(abs(x) * 10**decimals)
    whole, frac = divmod(ticks, 10**decimals)
    parts = []
    for name in ("d", "h", "min"):
        if _UNIT_SECONDS[name] > _UNIT_SECONDS[unit]:
            continue
        n, whole = divmod(whole, _UNIT_SECONDS[name])
        parts.append(f"{n} {name}")
    sec = f"{whole}" + (f".{frac:0{decimals}d}" if decimals else "")
    return sign + " ".join([*parts, f"{sec} s"])


def at(x: float | None, span_s: float) -> str:
    """A time from the start in the unit of :func:`time_unit` for ``span_s``:
    ``16.000 s`` (as :func:`seconds`), ``137.60 h``, ``5.733 d``."""
    unit, scale = time_unit(span_s)
    if unit == "s" or x is None or not math.isfinite(float(x)):
        return seconds(x)
    return f"{float(x) / scale:.{3 if unit == 'd' else 2}f} {unit}"


def clock(x: float | None, decimals: int = 3) -> str:
    """Seconds from the start as ``+HH:MM:SS.mmm`` (``decimals`` digits of the second:
    :func:`time_decimals`; empty for None): a time in a long record without absolute
    timestamps."""
    if x is None or not math.isfinite(float(x)):
        return ""
    unit = 10**decimals
    ticks = int(round(float(x) * unit))
    h, rem = divmod(ticks, 3600 * unit)
    m, rem = divmod(rem, 60 * unit)
    s, frac = divmod(rem, unit)
    return f"+{h:02d}:{m:02d}:{s:02d}" + (f".{frac:0{decimals}d}" if decimals else "")


def duration(x: float) -> str:
    """A duration for people: ``59.995 s``, ``12 min 5.0 s``, ``23 h 59 min 59 s``."""
    s = float(x)
    if not math.isfinite(s):
        return MISSING
    if s < 120:
        return seconds(s)
    # rounded to what is shown before it is split: 599.99 s is 10 min 0.0 s, not 9 min 60.0 s
    tenths = round(s * 10)
    if tenths < 36000:
        m, rest = divmod(tenths, 600)
        return f"{m} min {rest / 10:.1f} s"
    h, rem = divmod(round(s), 3600)
    m, sec = divmod(rem, 60)
    return f"{h} h {m} min {sec} s"


def size(n_bytes: int | None) -> str:
    """``1.2 MB`` (decimal units, as file managers show)."""
    if n_bytes is None or n_bytes < 0:
        return MISSING
    v = float(n_bytes)
    for unit in ("B", "kB", "MB", "GB"):
        if v < 1000 or unit == "GB":
            return f"{int(v)} B" if unit == "B" else f"{v:.1f} {unit}"
        v /= 1000
    return f"{v:.1f} TB"  # pragma: no cover


def percent(p: float | None) -> str:
    """A probability as a percentage: ``98.0 %``; never rounds a value below 1 up to 100."""
    if p is None or not math.isfinite(float(p)):
        return MISSING
    v = 100.0 * float(p)
    if 99.95 <= v < 100.0:
        return "> 99.9 %"
    return f"{v:.1f} %"


def score(x: float | None) -> str:
    """A finding's ``confidence`` as what it is, an agreement score from 0 to 1 (``0.98``),
    not a percentage: it combines the detectors that agree as if they were independent
    evidence and is lowered where the tests point to another type, but it is not a
    calibrated probability (near the detection limit wrong findings reached 1.0).
    Never rounds a value below 1 up to 1."""
    if x is None or not math.isfinite(float(x)):
        return MISSING
    v = float(x)
    if 0.995 <= v < 1.0:
        return "> 0.99"
    return f"{v:.2f}"


def rate(hz: float | None) -> str:
    return MISSING if hz is None else f"{num(hz, 6)} Hz"


def magnitude(
    mag: Mapping[str, Any],
    interval: Mapping[str, Any] | None = None,
    partial: bool = False,
    unit: str = "",
) -> str:
    """``offset +9.988``, ``gain x1.546``, ``drift +0.4998 per s`` (channel units), each
    with its 95 % interval where ``interval`` (findings.json's ``magnitude_interval``)
    has one: ``offset +9.992 (95 %: 9.887 to 10.097)``, the bounds to the size's own
    digits. ``partial`` (findings.json's ``interval_notes.magnitude`` beside a given
    interval: a gain's, or one from an older model) labels it ``(noise only: ...)``,
    since it counts only part of the size's error. ``unit`` (the one a channel's name
    ends in: :func:`analyzer.what_to_check.unit_of`) follows an offset's and a drift's
    size and interval: ``offset +3.559 m/s2 (95 %: 3.553 to 3.565 m/s2)``."""
    label = "noise only" if partial else "95 %"
    u = f" {unit}" if unit else ""
    parts = []
    for key, v in mag.items():
        if key == "offset":
            parts.append(f"offset {_signed(v)}{u}{_within(interval, key, label, u, _sci(v))}")
        elif key == "gain":
            parts.append(gain_words(v) + _within(interval, key, label))
        elif key == "rate_per_s":
            parts.append(f"drift {_signed(v)}{u} per s{_within(interval, key, label, u, _sci(v))}")
        elif key == "no_data_s":  # (analyzer.silent: blank or NaN to the record's end)
            parts.append(f"no reading for {num(v)} s (dead sensor: silent)")
        else:
            parts.append(f"{key} {num(v)}")
    return ", ".join(parts) or MISSING


def _within(
    interval: Mapping[str, Any] | None,
    key: str,
    label: str = "95 %",
    unit: str = "",
    sci: bool = False,
) -> str:
    """`` (95 %: lo to hi)`` of ``interval[key]``, or nothing where it has none. The
    bounds keep a fixed number of decimals, as many as four significant digits give the
    wider bound (``9.887 to 10.097``, not ``9.887 to 10.1``), more where they would read
    alike; in powers of ten as the size itself where it is shown so (``sci``): one cell
    read ``drift -2.664e-06 per s (95 %: -0.0000049854 to -0.0000003429)``."""
    pair = (interval or {}).get(key)
    if not isinstance(pair, (list, tuple)) or len(pair) != 2 or None in pair:
        return ""
    if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in pair) or sci:
        return f" ({label}: {num_range(pair[0], pair[1])}{unit})"
    lo, hi = float(pair[0]), float(pair[1])
    return f" ({label}: {_fixed_range(lo, hi)}{unit})"


def _sci(v: Any) -> bool:
    """Whether :func:`num` shows ``v`` in powers of ten (``-2.664e-06``)."""
    return "e" in num(v)


def _fixed_range(lo: float, hi: float, digits: int = 4) -> str:
    """``lo to hi`` with the same decimals: enough for ``digits`` significant digits of
    the smaller magnitude (at least), and more (to 15) until the two read apart; zeros
    both end in are dropped."""
    small = min(abs(lo), abs(hi)) or max(abs(lo), abs(hi))
    if small == 0.0 or abs(math.log10(small)) > 12:
        return num_range(lo, hi, digits)
    decimals = max(0, digits - 1 - math.floor(math.log10(small)))
    while f"{lo:.{decimals}f}" == f"{hi:.{decimals}f}" and lo != hi and decimals < 15:
        decimals += 1
    a, b = f"{lo:.{decimals}f}", f"{hi:.{decimals}f}"
    while "." in a and a.endswith("0") and b.endswith("0"):  # (0.9100 to 0.9500: 0.91 to 0.95)
        a, b = a[:-1].rstrip("."), b[:-1].rstrip(".")
    return f"{a} to {b}"


def onset_interval(pair: Any, when: Clock | int) -> str:
    """`` (95 %: 151.2 to 151.4 s)`` of findings.json's ``onset_interval_s``, or nothing
    where it is null (the onset a bound, or from no fit: ``interval_notes`` says which);
    ``when``: the record's :class:`Clock`, or the decimals of its seconds."""
    if not isinstance(pair, (list, tuple)) or len(pair) != 2 or None in pair:
        return ""
    if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in pair):
        return ""
    return f" (95 %: {as_clock(when).range(float(pair[0]), float(pair[1]))})"


SMALL_SIZE = 0.1
"""A finding whose size is below this fraction of its sensor's standard deviation in the
healthy training window (findings.json's ``size_relative``) is called small. The value
is the tool's own yardstick of "fine" in those units, not one tuned here: readings spaced
by under 0.1 of their healthy standard deviation are finely resolved and those spaced
wider are coarse (:data:`analyzer.diagnosis.clipping.COARSE`); a sensor whose mean comes
back within 0.15 of it is taken as healthy again (:data:`analyzer.diagnosis.stuck.
ALIVE_MEAN`); and the smallest offsets the project's sweeps inject are 0.25 of it
(``sweep_isolation.py --scale 0.5``). A fault below 0.1 is finer than what the tool
calls finely resolved and under half the smallest fault it is tested on."""

CLEAR_CONFIDENCE = 0.95
"""A confidence from which a small finding is called "statistically clear": the 5 %
level at which the report's innovation tests reject."""


def relative_size(size: Any, confidence: Any = None) -> str:
    """A finding's ``size_relative`` for people: ``9.99 × the sensor's usual spread``,
    ``0.4 of the sensor's usual spread``; below :data:`SMALL_SIZE` it says so, and with
    a confidence of :data:`CLEAR_CONFIDENCE` or more that the evidence is nonetheless
    clear (``statistically clear but small: 0.0205 of the sensor's usual spread``): a
    finding of rms 0.00085 read ">99.9 %" and nothing told whether it mattered. Empty
    for None (no size to measure, or no spread to measure it by)."""
    v = _size(size)
    if v is None:
        return ""
    # (never in exponent notation: "1.2e-05 of the sensor's usual spread" reads as noise)
    shown = f"{v:.0f}" if v >= 100 else num(v, 3) if v >= 0.001 or v == 0 else "under 0.001"
    text = (
        f"{shown} × the sensor's usual spread"
        if v >= 1
        else f"{shown} of the sensor's usual spread"
    )
    if v >= SMALL_SIZE:
        return text
    try:
        clear = float(confidence) >= CLEAR_CONFIDENCE
    except (TypeError, ValueError):
        clear = False
    return ("statistically clear but small: " if clear else "small: ") + text


def is_small(size: Any) -> bool:
    """True for a ``size_relative`` below :data:`SMALL_SIZE` (None: False)."""
    v = _size(size)
    return v is not None and v < SMALL_SIZE


def _size(size: Any) -> float | None:
    """A ``size_relative`` as a finite, non-negative number; None for anything else."""
    try:
        v = float(size)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) and v >= 0 else None


def gain_words(v: Any, inside: bool = False) -> str:
    """``gain ×1.546``, ``gain ×0 (dead sensor)``: a gain as the report, the watcher's
    index and ``analyzer run``'s last line say it; ``inside`` a parenthesis (the line's),
    its note after a colon, ``gain ×0: dead sensor``, not in a second one, and the note's
    own colon a comma (``gain ×0.0256: reads 2.56 % of its signal, nearly dead``: it
    read two colons)."""
    note = _gain_note(v)
    if inside and note:
        note = f": {note.strip()[1:-1].replace(': ', ', ')}"
    return f"gain ×{gain_num(v)}{note}"


def gain_num(v: Any) -> str:
    """A gain with :func:`num`'s 4 significant digits, and as many more as make one that
    is not 1 (nor -1) read apart from it: a gain of 1.0004 read ``×1``, no change at all;
    now ``×1.0004``."""
    said = num(v)
    if said not in ("1", "-1") or abs(float(v)) == 1:
        return said
    digits = 4
    while said in ("1", "-1") and digits < 17:
        digits += 1
        said = num(v, digits)
    return said


def _gain_note(v: Any) -> str:
    """What a gain below the classifier's :data:`~analyzer.diagnosis.classify.MIN_GAIN`
    means: a dead sensor only at 0 (the contract's gain 0, a sensor frozen at zero), else
    the share of its signal it still reads. A gain of 0.0256 (0.05 injected) was labelled
    "(dead sensor)" while the sensor read its signal, scaled down."""
    try:
        g = float(v)
    except (TypeError, ValueError):
        return ""
    if not math.isfinite(g) or abs(g) >= MIN_GAIN:
        return ""
    if num(g) == "0":
        return " (dead sensor)"
    inverted = ", inverted" if g < 0 else ""
    return f" (reads {num(100 * abs(g), 3)} % of its signal{inverted}: nearly dead)"


def _signed(v: Any) -> str:
    s = num(v)
    return s if s.startswith("-") or s == MISSING else f"+{s}"


def scalar(v: Any) -> str:
    """A model summary value: numbers rounded, short lists joined, the rest as text."""
    if isinstance(v, (list, tuple)):
        return ", ".join(scalar(x) for x in v)
    if v is None:
        return "none"
    if isinstance(v, (float, bool)):
        return num(v)
    return str(v)


def is_scalar(v: Any) -> bool:
    return v is None or isinstance(v, (str, int, float, bool))


def is_short_list(v: Any, limit: int = 8) -> bool:
    return isinstance(v, (list, tuple)) and len(v) <= limit and all(is_scalar(x) for x in v)


__all__ = [
    "CLEAR_CONFIDENCE",
    "MISSING",
    "Clock",
    "SMALL_SIZE",
    "TIME_DECIMALS",
    "TIME_UNITS",
    "as_clock",
    "at",
    "clock",
    "duration",
    "is_scalar",
    "is_short_list",
    "is_small",
    "magnitude",
    "natural_key",
    "num",
    "num_range",
    "percent",
    "score",
    "rate",
    "relative_size",
    "scalar",
    "seconds",
    "shorten",
    "size",
    "time_decimals",
    "time_unit",
    "visible_controls",
]
