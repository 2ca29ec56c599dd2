"""Infinities, NaN and ``--missing-values`` codes are gaps as blank cells are (the ux56
audit, items 3, 6 and 12): an infinity or a -9999 every 250 rows of one channel left no
detector able to run (exit 2, "the training window ... is too short", the channel named
with "0 %" of gaps), while blank cells at the same rows gave the finding; a channel of
values beyond 1e30 was said to have "no sample in the training window ... give
--train"; ``export`` said a blank column was "not analyzed"."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from cli_helpers import one_line_error, run_cli, run_to, said, schema_valid

from analyzer.detectors.detection_filter import _percent
from analyzer.missing_codes import Unread, as_gaps
from analyzer.readers.base import ChannelChunk
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

RATE = 200.0
EVERY = 250
"""A sample of s4 in every this many rows is no reading (0.4 % of its rows)."""
START = "2026-01-01T00:00:00Z"


def _record() -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Five floors, 60 s at 200 Hz, an additive fault of 3 sd on s1 from 36 s (the
    audit's record)."""
    t, y, names = simulate_building(n_floors=5, duration_s=60.0, rate_hz=RATE, seed=3)
    y[:, 1] = inject_fault(y[:, 1], RATE, "additive", 36.0, 3 * float(y[:, 1].std()))
    t_ns = np.round(t * 1e9).astype(np.int64)
    return t_ns, {n: y[:, j].copy() for j, n in enumerate(names)}


def _with(data: dict[str, np.ndarray], channel: str, fill: np.ndarray) -> dict[str, np.ndarray]:
    """``data`` with ``channel``'s every :data:`EVERY`-th sample replaced by ``fill``'s
    (repeated over them)."""
    out = dict(data)
    col = out[channel].copy()
    rows = np.arange(0, col.shape[0], EVERY)
    col[rows] = np.resize(fill, rows.shape[0])
    out[channel] = col
    return out


@pytest.fixture(scope="module")
def record() -> tuple[np.ndarray, dict[str, np.ndarray]]:
    return _record()


def _faults(doc: dict) -> list[dict]:
    return doc["faults"]


def test_infinities_and_codes_give_the_blank_cells_findings(tmp_path, capsys, record):
    """The same record with blank cells, +-inf, or -9999 (with ``--missing-values``) at
    the same rows of s4: exit 1 each, the same findings (s1 additive from 36 s); the
    infinities and the codes each counted by channel in a note."""
    t_ns, data = record
    runs = {}
    for kind, fill, more in (
        ("blank", np.array([np.nan]), ()),
        ("inf", np.array([np.inf, -np.inf]), ()),
        ("code", np.array([-9999.0]), ("--missing-values", "-9999")),
    ):
        path = tmp_path / f"{kind}.csv"
        write_archive(path, "csv", t_ns, _with(data, "s4", fill), start_iso=START)
        code, err, doc, _ = run_to(tmp_path / kind, capsys, path, *more)
        assert code == 1, (kind, err)
        schema_valid(doc)
        runs[kind] = doc
    blank = _faults(runs["blank"])
    assert [(f["channel"], f["type"]) for f in blank] == [("s1", "additive")], blank
    assert _faults(runs["inf"]) == blank
    assert _faults(runs["code"]) == blank
    n = -(-t_ns.shape[0] // EVERY)
    assert (
        f"infinite or absurd values (beyond 1e30: an overrange or error code?) taken as "
        f"gaps: s4 ({n})" in runs["inf"]["notes"]
    ), runs["inf"]["notes"]
    assert (
        f"missing-value codes (-9999, --missing-values) taken as gaps: s4 ({n})"
        in (runs["code"]["notes"])
    )
    # (the samples dropped as blank cells are: s4's raw count the same in all three)
    counts = {k: {c["name"]: c["samples"] for c in d["channels"]} for k, d in runs.items()}
    assert counts["inf"] == counts["blank"] == counts["code"]
    assert counts["blank"]["s4"] == t_ns.shape[0] - n


def test_an_infinity_or_nan_in_an_mcap_field_is_a_gap_as_a_missing_message(
    tmp_path, capsys, record
):
    """An MCAP's float64 field holding an infinity, or NaN, every 250 messages: exit 1
    and the same findings as the record without those messages' values (both were exit
    2, no detector could run)."""
    t_ns, data = record
    docs = {}
    for kind, fill in (("inf", np.array([np.inf, -np.inf])), ("nan", np.array([np.nan]))):
        path = tmp_path / f"{kind}.mcap"
        write_archive(path, "mcap", t_ns, _with(data, "s4", fill), start_iso=START)
        code, err, doc, _ = run_to(tmp_path / kind, capsys, path)
        assert code == 1, (kind, err)
        docs[kind] = doc
    found = [(f["channel"], f["type"]) for f in docs["inf"]["faults"]]
    assert found == [("/s1.data", "additive")], found
    assert docs["inf"]["faults"] == docs["nan"]["faults"]
    n = -(-t_ns.shape[0] // EVERY)
    assert any(n_.endswith(f"taken as gaps: /s4.data ({n})") for n_ in docs["inf"]["notes"])


def test_a_channel_of_absurd_values_is_said_so_not_blamed_on_the_training_window(
    tmp_path, capsys, record
):
    """s2 multiplied by 1e300 (a value in every row, each beyond 1e30): stderr says every
    value was taken as a gap, and advises no --train for it; the fault on s1 is found."""
    t_ns, data = record
    data = dict(data)
    data["s2"] = data["s2"] * 1e300
    path = tmp_path / "huge.csv"
    write_archive(path, "csv", t_ns, data, start_iso=START)
    code, err, doc, _ = run_to(tmp_path, capsys, path)
    assert code == 1, err
    about = [w for w in said(err) if "s2" in w]
    assert about, err
    assert any(
        f"s2: every one of its {t_ns.shape[0]} values is infinite or beyond 1e30" in w
        for w in about
    ), about
    assert not any("--train" in w or "training window 0" in w for w in about), about
    assert [f["channel"] for f in doc["faults"]] == ["s1"], doc["faults"]
    schema_valid(doc)


def test_a_small_share_of_gaps_is_not_zero_percent():
    """The gap hint's shares: 0.4 % of rows was "0 %", beside the one channel at fault."""
    assert _percent(0.4) == "0.4 %"
    assert _percent(0.01) == "under 0.1 %"
    assert _percent(12.4) == "12 %"


def test_as_gaps_drops_what_is_no_reading_and_counts_it():
    """NaN, infinities, values beyond 1e30 and the codes are dropped with their times,
    counted by kind; a chunk with nothing to drop is handed on as it is; a channel none
    of whose samples is a reading is named."""
    t = np.arange(6, dtype=np.int64)
    dirty = ChannelChunk("a", t, np.array([1.0, np.nan, np.inf, -2e30, -9999.0, 3.0]))
    clean = ChannelChunk("b", t, np.arange(6, dtype=np.float64))
    dead = ChannelChunk("c", t, np.full(6, np.inf))
    unread = Unread()
    out = list(as_gaps(iter([dirty, clean, dead]), (-9999.0,), unread))
    assert [c.name for c in out] == ["a", "b"]
    assert out[0].t_ns.tolist() == [0, 5] and out[0].values.tolist() == [1.0, 3.0]
    assert out[1] is clean
    assert unread.nan == {"a": 1}
    assert unread.absurd == {"a": 2, "c": 6}
    assert unread.coded == {"a": 1}
    assert list(unread.lost()) == ["c"]


def test_export_does_not_call_a_blank_column_not_analyzed(tmp_path: Path, capsys):
    """A column blank in every row: ``export`` says it is not exported (it writes no
    column for it), not "not analyzed" (export analyzes nothing)."""
    t_ns, data = _record()
    data = dict(data)
    data["s3"] = np.full(t_ns.shape[0], np.nan)
    path = tmp_path / "blank.csv"
    write_archive(path, "csv", t_ns, data, start_iso=START)
    out = tmp_path / "x.csv"
    code, _, err = run_cli(["export", path, "--out", out], capsys)
    assert code == 0, err
    line = next(w for w in err.splitlines() if "blank in every row" in w)
    assert "not analyzed" not in line and "not exported" in line, line
    assert "s3" not in out.read_text().splitlines()[0].split(",")


def test_a_record_with_no_reading_at_all_says_why(tmp_path: Path, capsys):
    """Every value infinite in one column and a code in the other: one line, exit 2,
    naming each column and what its values were (not a training window to change)."""
    path = tmp_path / "dead.csv"
    rows = "".join(f"{i * 0.01:.2f},inf,-9999\n" for i in range(3000))
    path.write_text("time,a,b\n" + rows)
    code, _, err = run_cli(
        ["run", path, "--out", tmp_path / "o", "--missing-values", "-9999"], capsys
    )
    assert code == 2, err
    line = one_line_error(err, "no channel has a reading", "a: every one of its 3000 values")
    assert "b: every one of its 3000 values is a missing-value code" in line, line
    assert "--train" not in line, line
