"""Inputs recorded years apart that share channel names (ux52, item 7): a channel of a
message in each file (a ``/tf_static`` in two bags 735 days apart) has a "period" of the
whole span, so ``inspect`` said nothing of the span (``span: null``), and a folder of
four bags 14 years apart was "58 % without data, 1 gap"; a run analyzed the later file
alone and said nothing of the earlier one."""

from __future__ import annotations

import json

import numpy as np
from cli_helpers import run_cli, said

from analyzer.simulate import simulate_building
from analyzer.writers import write_archive

OLD, NEW = "2024-05-03T13:00:00Z", "2026-05-08T10:00:00Z"


def _archive(folder):
    """A 60-s building of 2026, a constant channel of 2024 (30 s) and a channel of one
    sample in a file of each year."""
    folder.mkdir()
    t, y, _ = simulate_building(3, 60.0, 50.0, seed=7)
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(
        folder / "new.mcap", "mcap", t_ns, {f"s{j}": y[:, j] for j in range(3)}, start_iso=NEW
    )
    write_archive(
        folder / "old.mcap", "mcap", t_ns[:1500], {"c": np.full(1500, 2.0)}, start_iso=OLD
    )
    for name, iso in (("static_old.mcap", OLD), ("static_new.mcap", NEW)):
        write_archive(folder / name, "mcap", t_ns[:1], {"st": np.array([1.0])}, start_iso=iso)
    return folder


def test_inspect_counts_the_years_between_inputs_as_without_data(tmp_path, capsys):
    folder = _archive(tmp_path / "apart")
    code, out, err = run_cli(["inspect", folder, "--json"], capsys)
    assert code == 0, err
    span = json.loads(out)["span"]
    assert span is not None
    assert span["gaps"] == 1
    assert span["span_s"] > 734 * 86400
    assert span["without_data_s"] > 0.99 * span["span_s"]
    code, out, _ = run_cli(["inspect", folder], capsys)
    assert "100 % of the 735 days span has no data: 1 gap, 735 days in all" in out.splitlines()


def test_a_run_says_what_lies_outside_the_analyzed_span(tmp_path, capsys):
    folder = _archive(tmp_path / "apart")
    out = tmp_path / "o"
    code, _, err = run_cli(["run", folder, "--out", out, "--train", "0:40"], capsys)
    assert code in (0, 1), err
    lines = [ln for ln in said(err) if "outside the analyzed span" in ln]
    assert len(lines) == 1, err
    assert "the analysis spans 60 s from 2026-05-08T10:00:00.000Z" in lines[0]
    assert "735 days before it" in lines[0]
    notes = json.loads((out / "findings.json").read_text())["notes"]
    assert any("outside the analyzed span" in n for n in notes)
