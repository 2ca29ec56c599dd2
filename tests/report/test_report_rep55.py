"""What an engineer who must act on a report reads in it (ux60): a "What to check" line
per finding (findings.json's ``check``), the type in plain words, the unit a channel's
name ends in after its sizes and on its charts' axes, what a gain's "noise only" range
is, the time zone the input's clock used, and a few cells that read two ways."""

from __future__ import annotations

import json
import re
from datetime import UTC, datetime, timedelta
from html import unescape
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from report_helpers import RATE

from analyzer.pipeline import RunOptions, analyze, findings_document
from analyzer.readers.csv_reader import CsvReader
from analyzer.report import format as fmt
from analyzer.report import render_report
from analyzer.report.view import _Access
from analyzer.report.workers import FigureBatch
from analyzer.simulate import inject_fault, simulate_building

SCHEMA = Path(__file__).resolve().parents[2] / "analyzer" / "schema" / "findings.schema.json"


def _text(html: str) -> str:
    return " ".join(unescape(re.sub(r"<[^>]+>", " ", html)).split())


def _csv(path: Path, zone: str, unit: str, units_line: bool = False) -> Path:
    """A 4-floor building at 50 Hz whose s1 takes an offset of 3 sd at 36 s of 60, its
    times date-times ending in ``zone`` (``+02:00``, or "" for none) and each channel's
    name ending in `` (unit)``, or with ``units_line`` followed by a units line."""
    t, y, names = simulate_building(4, 60.0, RATE, seed=1)
    y[:, 1] = inject_fault(y[:, 1], RATE, "additive", 36.0, 3.0 * float(np.std(y[:, 1])))
    start = datetime(2026, 11, 30, 14, 0, 0, tzinfo=UTC)
    rows = [
        ",".join(
            [(start + timedelta(seconds=float(s))).strftime("%Y-%m-%dT%H:%M:%S.%f") + zone]
            + [f"{v:.6f}" for v in y[i]]
        )
        for i, s in enumerate(t)
    ]
    if units_line:
        header = ",".join(["time", *names]) + "\n" + ",".join(["", *[unit] * len(names)])
    else:
        header = ",".join(["time", *[f"{n} ({unit})" for n in names]])
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    path = _csv(tmp_path_factory.mktemp("u") / "b.csv", "+02:00", "m/s2")
    analysis = analyze([path], RunOptions(train="0:15"))
    doc = findings_document(analysis)
    return analysis, doc, render_report(analysis, doc)


# -- what to check ----------------------------------------------------------------------


def test_each_fault_says_what_to_check_in_findings_json_and_the_report(page):
    _, doc, html = page
    (f,) = [f for f in doc["faults"] if f["channel"] == "s1 (m/s2)"]
    assert f["type"] == "additive"  # (the contract's word stays)
    assert f["check"].startswith("its zero moved by +")
    assert f["check"].endswith(" m/s2: check mounting, cable and zero")
    text = _text(html)
    assert "what to check" in text and "What to check" in text
    assert text.count(f["check"]) >= 2  # the verdict's row and the finding's line
    assert "offset (zero shift)" in text
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.validate(json.loads(json.dumps(doc)), json.loads(SCHEMA.read_text()))
    assert "check" in json.loads(SCHEMA.read_text())["$defs"]["fault"]["properties"]


def test_what_to_check_by_type_and_shape():
    from analyzer.what_to_check import type_words, what_to_check

    off = {"type": "additive", "magnitude": {"offset": 3.5587}, "onset_s": 100.0, "end_s": None}
    assert what_to_check(off, "mm") == "its zero moved by +3.56 mm: check mounting, cable and zero"
    gain = {"type": "multiplicative", "magnitude": {"gain": 1.498}, "end_s": None}
    assert what_to_check(gain) == "reads 1.5× its true signal: check the sensitivity/calibration"
    drift = {"type": "drift", "magnitude": {"rate_per_s": 0.03219}, "end_s": None}
    assert what_to_check(drift, "degC") == (
        "creeping by +0.0322 degC per s: check calibration, temperature and ageing"
    )
    dead = {
        "type": "multiplicative",
        "magnitude": {"gain": 0.0},
        "onset": "2026-11-30T12:02:30.000Z",
        "onset_s": 150.0,
        "end_s": None,
    }
    assert what_to_check(dead) == (
        "no reading since 2026-11-30T12:02:30.000Z: check power and cable"
    )
    frozen = {"type": "other", "magnitude": {"stuck_at": 2.0}, "onset_s": 12.5, "end_s": None}
    assert (
        what_to_check(frozen) == "no reading since 12.500 s from the start: check power and cable"
    )
    ended = {**gain, "end_s": 200.13}
    assert what_to_check(ended) == (
        "reads 1.5× its true signal, then ended: came and went: check connector and cable"
    )
    other = {"type": "other", "magnitude": {"rms": 0.4}, "end_s": None}
    assert what_to_check(other) == "check the sensor and its wiring"
    assert what_to_check({**other, "end_s": 3.0}) == "came and went: check connector and cable"
    assert type_words("additive") == "offset (zero shift)"
    assert type_words("multiplicative") == "gain (scale error)"
    assert type_words("drift") == "drift"


# -- units ------------------------------------------------------------------------------


def test_a_unit_at_the_end_of_a_channel_name():
    from analyzer.what_to_check import unit_of

    assert unit_of("s2 (m/s2)") == "m/s2"
    assert unit_of("disp [mm]") == "mm"
    assert unit_of("T [degC]") == "degC"
    assert unit_of("s2 (floor 3)") == ""  # (a label, not a unit)
    assert unit_of("s2") == ""


def test_sizes_and_value_axes_carry_the_channels_unit(page):
    _, doc, html = page
    (f,) = [f for f in doc["faults"] if f["channel"] == "s1 (m/s2)"]
    said = fmt.magnitude(f["magnitude"], f["magnitude_interval"], unit="m/s2")
    assert re.fullmatch(r"offset \+[\d.]+ m/s2 \(95 %: [\d.]+ to [\d.]+ m/s2\)", said)
    assert said in html
    assert ">m/s2<" in html  # a chart's value axis (svg text)
    assert "measured minus fault-free estimate, m/s2" in html
    assert "s1 (m/s2)" in html  # (the channel's name stays its whole header)


def test_a_csv_units_line_gives_the_unit_too(tmp_path):
    from analyzer.what_to_check import channel_units

    path = _csv(tmp_path / "l.csv", "Z", "mm", units_line=True)
    info = CsvReader(path).info
    assert info.units == {f"s{i}": "mm" for i in range(4)}
    assert channel_units([info], ["s1", "x (g)", "other"]) == {"s1": "mm", "x (g)": "g"}
    analysis = analyze([path], RunOptions(train="0:15"))
    doc = findings_document(analysis)
    (f,) = [f for f in doc["faults"] if f["channel"] == "s1"]
    assert f["check"].endswith(" mm: check mounting, cable and zero")
    text = _text(render_report(analysis, doc))
    assert re.search(r"offset \+[\d.]+ mm \(95 %", text)
    assert "clock was" not in text and "read as UTC" not in text  # (Z is UTC: nothing to add)


# -- time zones -------------------------------------------------------------------------


def test_the_offset_the_inputs_clock_used_is_said_beside_the_utc_times(page):
    _, doc, html = page
    assert doc["start"] == "2026-11-30T12:00:00.000Z"  # (findings.json's ISO times: UTC)
    text = _text(html)
    assert "times in UTC; the input's clock was UTC+02:00" in text
    assert "absolute UTC" not in text


def test_times_without_a_zone_are_said_to_be_read_as_utc(tmp_path):
    path = tmp_path / "z.csv"
    path.write_text("time,a\n" + "".join(f"2020-02-08 13:30:{s:02d},{s % 3}\n" for s in range(30)))
    info = CsvReader(path).info
    assert info.time_zone == ""
    access = _Access(SimpleNamespace(inputs=[info]), {}, FigureBatch(None))
    assert access.zone_words() == "read as UTC (the file gives no time zone)"
    assert access.utc_words() == "the time read as UTC (the file gives no time zone)"
    offset = tmp_path / "o.csv"
    offset.write_text(path.read_text().replace(",", "+02:00,").replace("time+02:00", "time"))
    assert CsvReader(offset).info.time_zone == "+02:00"


# -- a gain's noise-only range, mixed formats, missing ranges, the AR captions -----------


def _as_gain(doc):
    """``doc`` with its s1 fault as a gain whose range counts noise only."""
    faults = []
    for f in doc["faults"]:
        if f["channel"] == "s1 (m/s2)":
            f = {
                **f,
                "type": "multiplicative",
                "magnitude": {"gain": 1.51},
                "magnitude_interval": {"level": 0.95, "gain": [1.50, 1.52]},
                "interval_notes": {"magnitude": "counts the fit's noise only"},
            }
            f.pop("check", None)
        faults.append(f)
    return {**doc, "faults": faults}


def test_a_gains_noise_only_range_is_explained(page):
    from analyzer.diagnosis.spread import GAIN_COVERAGE

    analysis, doc, _ = page
    text = _text(render_report(analysis, _as_gain(doc)))
    assert "gain ×1.51 (noise only: 1.50 to 1.52)" in text
    assert f"held the true gain in {GAIN_COVERAGE} of cases" in text
    assert "gain (scale error)" in text
    assert "reads 1.51× its true signal: check the sensitivity/calibration" in text
    plain = _text(render_report(analysis, doc))
    assert GAIN_COVERAGE not in plain  # (no gain, no sentence)


def test_one_number_format_per_cell():
    said = fmt.magnitude({"rate_per_s": -2.664e-06}, {"rate_per_s": [-4.9854e-06, -3.429e-07]})
    assert said == "drift -2.664e-06 per s (95 %: -4.985e-06 to -3.429e-07)"
    assert fmt.magnitude({"offset": 0.609}, {"offset": [0.2468, 0.9712]}) == (
        "offset +0.609 (95 %: 0.2468 to 0.9712)"
    )


def test_a_fitted_size_without_a_range_says_why():
    from analyzer.report.view import no_range

    f = {
        "magnitude": {"offset": 2.632},
        "magnitude_interval": None,
        "interval_notes": {
            "magnitude": "the size came from a step after the fitted shape, which gives no interval"
        },
    }
    assert no_range(f) == " (no range: measured after the fit, which gives none)"
    assert no_range({**f, "magnitude": {"gain": 0.0}}) == ""  # (a dead sensor: nothing to say)
    assert no_range({**f, "magnitude_interval": {"offset": [2.6, 2.7]}}) == ""


def test_the_whitening_filter_is_named_apart_from_the_detectors_model(page):
    _, doc, html = page
    orders = {
        d["name"]: d["model"]["order"]
        for d in doc["detectors"]
        if isinstance(d.get("model", {}).get("order"), int)
    }
    assert orders  # (the AR detectors keep their order)
    text = _text(html)
    assert re.search(r"one-step error of a \d+-term whitening filter", text)
    assert "AR(" not in text.split("Innovation tests before and after the onset")[1][:400]
    det = re.search(r"Whitened residual of (\w+)", text).group(1)
    if det in orders:
        assert f"apart from the detector's own order-{orders[det]} model of the signals" in text


def test_the_healthy_reports_note_on_a_detector_that_needs_a_config_is_plain(page):
    _, _, html = page
    text = _text(html)
    assert "runs only when configured" not in text
    assert "One more check, error_function , was not run" in text
