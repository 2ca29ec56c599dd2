"""Channels with no reading at all (ch56 item 1): a CSV column blank in every row, an
MCAP field NaN in every message, a column whose every value is a ``--missing-values``
code or beyond 1e30. stderr warned of each, but findings.json's ``channels[]`` left
them out (and for a blank column, ``notes`` did too): a script reading findings.json
never learnt a column of the file was dead. Each is now listed there (samples 0,
analyzed false, why "no reading" and what its values were), said in ``notes`` and in
the report's channel table."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.simulate import simulate_building
from analyzer.writers import write_archive
from tests.cli.cli_helpers import run_to, said, schema_valid

RATE = 50.0
SECONDS = 100.0


def _record(path, fmt, dead):
    """Three healthy sensors of a simulated building and a fourth channel ``dead``
    whose every value is the one given (NaN, a code, 1e31), as ``fmt``."""
    t, y, _ = simulate_building(3, SECONDS, RATE, seed=3)
    t_ns = np.round(t * 1e9).astype(np.int64)
    data = {f"s{j}": y[:, j] for j in range(3)}
    data["dead"] = np.full(len(t), dead)
    return write_archive(path, fmt, t_ns, data)


def _listed(doc, name):
    (entry,) = [c for c in doc["channels"] if c["name"] == name]
    return entry


@pytest.mark.parametrize(
    ("fmt", "value", "more", "words"),
    [
        ("csv", np.nan, [], "blank in every row"),
        ("mcap", np.nan, [], "NaN"),
        ("csv", -9999.0, ["--missing-values", "-9999"], "missing-value code"),
        ("csv", 1e31, [], "beyond 1e30"),
    ],
    ids=["blank-csv", "nan-mcap", "code-csv", "absurd-csv"],
)
def test_a_channel_with_no_reading_is_listed_in_findings_json(
    tmp_path, capsys, fmt, value, more, words
):
    """The dead channel is in ``channels[]`` with samples 0, analyzed false, why "no
    reading"; a line of ``notes`` names it for what it is; stderr says it without
    sending the user to --train; the report's channel table has its row."""
    names = _record(tmp_path / f"rec.{fmt}", fmt, value)
    dead = names["dead"]
    code, err, doc, out = run_to(tmp_path, capsys, tmp_path / f"rec.{fmt}", *more)
    assert code == 0, err
    entry = _listed(doc, dead)
    assert entry["samples"] == 0 and entry["analyzed"] is False, entry
    assert entry["why"] == "no reading" and words in entry["no_reading"], entry
    assert [c["name"] for c in doc["channels"] if c["analyzed"]] == [
        names[f"s{j}"] for j in range(3)
    ]
    (note,) = [n for n in doc["notes"] if n.startswith(f"{dead}:")]
    assert words in note and "not analyzed" in note, doc["notes"]
    warned = [w for w in said(err) if dead in w]
    assert warned and not any("--train" in w for w in warned), err
    html = (out / "report.html").read_text()
    assert f"no reading: {entry['no_reading']}" in html
    schema_valid(doc)
