"""What to look at on a sensor a finding names: findings.json's ``check`` and the
report's "What to check" line, worded by the fault's type and shape as what to inspect,
not as a certainty (the finding says what the readings did; why is for the person on
site). An engineer reading ``multiplicative`` or ``gain ×0 (dead sensor)`` had to turn it
into a job on their own; every report now says where to start.

Also the unit a channel's name carries at its end (``s2 (m/s2)``, ``disp [mm]``), which
the report writes after a size and on the charts' value axes.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping
from typing import Any

from analyzer.timeutil import seconds_text

UNIT_AT_END = re.compile(r"[(\[]\s*([A-Za-z°%µμΩ][\w/^°%µμΩ.*·-]{0,11})\s*[)\]]\s*$")
"""A unit in round or square brackets at the end of a channel's name: ``(m/s2)``,
``[mm]``, ``[degC]``, ``(%)``; one short word without spaces (``s2 (floor 3)`` names no
unit)."""

TYPE_WORDS: dict[str, str] = {
    "additive": "offset (zero shift)",
    "multiplicative": "gain (scale error)",
}
"""A fault type as a reader says it (the contract's words stay in findings.json)."""

ENDED = "came and went: check connector and cable"
"""A fault that ended: one that comes and goes is most often a loose contact."""
OTHER = "check the sensor and its wiring"


def unit_of(channel: str) -> str:
    """The unit at the end of ``channel``'s name (``m/s2`` of ``s2 (m/s2)``), else ""."""
    m = UNIT_AT_END.search(channel)
    return m.group(1) if m else ""


def channel_units(inputs: Iterable[Any], names: Iterable[str]) -> dict[str, str]:
    """The unit of each channel of ``names`` that has one: at the end of its name
    (:func:`unit_of`), else from its input's units line (``InputInfo.units``, where two
    inputs agree on it)."""
    given: dict[str, str] = {}
    clash: set[str] = set()
    for info in inputs:
        for name, unit in (getattr(info, "units", None) or {}).items():
            if given.setdefault(name, unit) != unit:
                clash.add(name)
    out = {}
    for name in names:
        unit = unit_of(name) or ("" if name in clash else given.get(name, ""))
        if unit:
            out[name] = unit
    return out


def type_words(kind: str) -> str:
    """``offset (zero shift)`` for additive, ``gain (scale error)`` for multiplicative;
    other types as they are."""
    return TYPE_WORDS.get(kind, kind)


def _number(v: Any, signed: bool = False) -> str:
    """Three significant digits: ``+3.56``, ``0.0322``."""
    try:
        x = float(v)
    except (TypeError, ValueError):
        return "n/a"
    if not math.isfinite(x):
        return "n/a"
    return f"{x:+.3g}" if signed else f"{x:.3g}"


def _since(f: Mapping[str, Any]) -> str:
    """When the fault began, as the finding gives it: its UTC time where the record has
    one, else seconds from the start; "the start" for a fault there from the first
    sample the detectors judged."""
    ev = f.get("evidence") or {}
    if ev.get("onset_at_or_before") or isinstance(ev.get("constant"), Mapping):
        return "the start of the record"
    if f.get("onset"):
        return str(f["onset"])
    try:
        return f"{seconds_text(float(f.get('onset_s') or 0.0))} s from the start"
    except (TypeError, ValueError):
        return "its onset"


def _dead(f: Mapping[str, Any]) -> bool:
    """A sensor that stopped reading: a gain of 0 (read as dead), readings that gave
    way to blanks (``no_data_s``) or froze (``evidence.frozen``)."""
    mag = f.get("magnitude") or {}
    if (
        "no_data_s" in mag
        or "stuck_at" in mag
        or isinstance((f.get("evidence") or {}).get("frozen"), Mapping)
    ):
        return True
    try:
        return "gain" in mag and abs(float(mag["gain"])) < 5e-5
    except (TypeError, ValueError):
        return False


def what_to_check(f: Mapping[str, Any], unit: str = "") -> str:
    """What to look at for the fault ``f`` (a findings.json fault), ``unit`` written
    after its size: by type (offset: mounting, cable and zero; gain: the sensitivity or
    calibration; drift: calibration, temperature and ageing; a sensor that stopped
    reading: power and cable; other: the sensor and its wiring), and for a fault that
    ended, connector and cable (one that comes and goes is most often a loose contact)."""
    kind = str(f.get("type", ""))
    mag = f.get("magnitude") or {}
    u = f" {unit}" if unit else ""
    what = ""
    advice = OTHER
    if _dead(f):
        what, advice = f"no reading since {_since(f)}", "check power and cable"
    elif kind == "additive" and "offset" in mag:
        what = f"its zero moved by {_number(mag['offset'], True)}{u}"
        advice = "check mounting, cable and zero"
    elif kind == "multiplicative" and "gain" in mag:
        what = f"reads {_number(mag['gain'])}× its true signal"
        advice = "check the sensitivity/calibration"
    elif kind == "drift" and "rate_per_s" in mag:
        what = f"creeping by {_number(mag['rate_per_s'], True)}{u} per s"
        advice = "check calibration, temperature and ageing"
    if f.get("end_s") is not None:
        return f"{what}, then ended: {ENDED}" if what else ENDED
    return f"{what}: {advice}" if what else advice


__all__ = ["TYPE_WORDS", "channel_units", "type_words", "unit_of", "what_to_check"]
