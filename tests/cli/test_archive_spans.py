"""What a run and ``inspect`` say of an archive's time and names where they are not what
they look like (a new user's audit, items 2, 9 and 10):

* a folder of MCAP pieces with one CSV piece of the same sensors under other names
  (``s0`` for ``/s0.data``): the CSV's channels were left out as "constant or empty in
  the training window", with no word on the file, and ``inspect`` said 10 of 10
  channels would be analyzed where ``run`` analyzed 5;
* a CSV of relative times that start at 100 s: nothing said where 0 s is, and
  ``--train 100:112`` (the file's own seconds) was refused as after the data's end;
* a folder of pieces an hour apart: ``duration_s`` the whole span, most of it without
  data, and nothing said so."""

from __future__ import annotations

import json

import numpy as np

from analyzer.simulate import simulate_building
from analyzer.writers import write_archive
from tests.cli.cli_helpers import one_line_error, run_cli, said

RATE = 50.0
PIECE_S = 30.0


def _pieces(folder, formats, gap_s=0.0, names=None):
    """A 5-sensor building cut into consecutive pieces of :data:`PIECE_S` seconds, one
    file per piece in ``formats`` (``mcap`` or ``csv``), absolute times, each piece
    ``gap_s`` after the previous one's end; ``names`` (per piece) the sensors' columns."""
    folder.mkdir()
    n = len(formats)
    t, y, _ = simulate_building(5, n * PIECE_S, RATE, seed=7)
    rows = int(PIECE_S * RATE)
    for k, fmt in enumerate(formats):
        part = slice(k * rows, (k + 1) * rows)
        t_ns = np.round(t[part] * 1e9).astype(np.int64)
        start = 1_780_000_000 + k * (PIECE_S + gap_s)
        iso = np.datetime_as_string(np.datetime64(int(start), "s")) + "Z"
        cols = names[k] if names else [f"s{j}" for j in range(5)]
        data = {c: y[part, j] for j, c in enumerate(cols)}
        write_archive(folder / f"part{k}.{fmt}", fmt, t_ns, data, start_iso=iso)
    return folder


def test_a_csv_piece_beside_mcap_pieces_is_named_and_its_channels_said_without_data(
    tmp_path, capsys
):
    """The MCAP pieces' channels are ``/s0.data``..., the CSV's ``s0``...: the run warns
    naming the CSV file and the likely cause, its channels' note says they have no
    samples in the training window (not "constant or empty"), and ``inspect`` marks
    them and counts what ``run`` analyzes."""
    folder = _pieces(tmp_path / "mixed", ["mcap", "mcap", "csv", "mcap"])
    code, _, err = run_cli(["run", folder, "--out", tmp_path / "o", "--no-progress"], capsys)
    assert code in (0, 1), err
    warned = [w for w in said(err) if "part2.csv" in w]
    assert len(warned) == 1, err
    assert "shares no channel name with the archive's other files" in warned[0]
    assert "other names for the same sensors" in warned[0]
    assert not any("part0.mcap" in w or "part1.mcap" in w for w in said(err)), err
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    csv = [f"s{j}" for j in range(5)]
    (note,) = [n for n in doc["notes"] if n.startswith("no samples in the training window")]
    assert ", ".join(csv) in note
    assert not any("constant" in n and "s0," in n for n in doc["notes"]), doc["notes"]
    # (no note on the span without data: the CSV's piece fills the MCAP pieces' gap;
    # the analyzed MCAP channels' own silence there is said, "... 1 % of the record")
    assert not any("span has no data" in n for n in doc["notes"]), doc["notes"]
    assert any("part2.csv shares no channel name" in n for n in doc["notes"])
    analyzed = [c["name"] for c in doc["channels"] if c["analyzed"]]
    assert analyzed == [f"/s{j}.data" for j in range(5)]
    assert doc["time_origin_s"] is None  # (absolute times: start says it)

    code, out, err = run_cli(["inspect", folder, "--json"], capsys)
    assert code == 0, err
    listed = json.loads(out)
    why = {c["name"]: c.get("why") for c in listed["channels"]}
    assert all(why[c] == "no training samples" for c in csv), why
    assert listed["run_defaults"]["channels"] == len(analyzed)
    assert any("part2.csv shares no channel name" in n for n in listed["notes"])
    assert "span" not in listed  # (the CSV's piece fills the others' gap)
    code, out, _ = run_cli(["inspect", folder], capsys)
    assert "s0 [no training samples]" in out
    assert "run by default: 5 of 10 channel(s)" in out


def test_files_of_other_sensors_over_the_same_time_are_not_warned_of(tmp_path, capsys):
    """One file per sensor node, over the same time, is how such archives are meant to
    be: no file is named."""
    folder = tmp_path / "nodes"
    folder.mkdir()
    t, y, _ = simulate_building(4, 60.0, RATE, seed=3)
    t_ns = np.round(t * 1e9).astype(np.int64)
    for k in range(2):
        data = {f"n{k}_{j}": y[:, 2 * k + j] for j in range(2)}
        write_archive(
            folder / f"node{k}.mcap", "mcap", t_ns, data, start_iso="2026-05-01T00:00:00Z"
        )
    code, out, err = run_cli(["inspect", folder, "--json"], capsys)
    assert code == 0, err
    assert json.loads(out)["notes"] == []


def _from_100(path):
    """The CSV at ``path`` with its times (seconds from 0) moved to start at 100 s."""
    lines = path.read_text().splitlines()
    moved = [lines[0]]
    for line in lines[1:]:
        time, rest = line.split(",", 1)
        moved.append(f"{float(time) + 100.0:.6f},{rest}")
    path.write_text("\n".join(moved) + "\n")


def test_relative_times_from_100_s_keep_their_origin(tmp_path, capsys):
    """Times count from the first sample (the contract), and findings.json and
    ``inspect`` say that sample's own time; ``--train 100:112`` is refused saying it is
    ``0:12`` here."""
    t, y, names = simulate_building(4, 60.0, 2 * RATE, seed=4)
    src = tmp_path / "rel100.csv"
    write_archive(
        src, "csv", np.round(t * 1e9).astype(np.int64), {n: y[:, j] for j, n in enumerate(names)}
    )
    _from_100(src)
    code, _, err = run_cli(["run", src, "--out", tmp_path / "o", "--no-progress"], capsys)
    assert code in (0, 1), err
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    assert doc["start"] is None
    assert doc["time_origin_s"] == 100.0
    assert doc["train"]["start_s"] == 0.0

    code, out, err = run_cli(["inspect", src, "--json"], capsys)
    assert code == 0, err
    assert json.loads(out)["time_origin_s"] == 100.0
    code, out, _ = run_cli(["inspect", src], capsys)
    assert "from the first sample, which is at 100.000 s in the input" in out

    code, _, err = run_cli(["run", src, "--out", tmp_path / "t", "--train", "100:112"], capsys)
    assert code == 2
    one_line_error(
        err,
        "--train 100:112 is 0:12 here: times count from the first sample, 100.000 s in the file",
    )


def test_a_folder_of_pieces_far_apart_says_how_much_of_its_span_has_no_data(tmp_path, capsys):
    """Four 30-s pieces 90 s apart: 120 s of data in a 390-s span; 69 % without data,
    said in a note, on stderr (most of the span) and in ``inspect``'s summary."""
    folder = _pieces(tmp_path / "far", ["mcap"] * 4, gap_s=3 * PIECE_S)
    code, _, err = run_cli(["run", folder, "--out", tmp_path / "o", "--no-progress"], capsys)
    assert code in (0, 1), err
    line = "69 % of the 6.5 min span has no data: 3 gaps, 4.5 min in all"
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    assert doc["duration_s"] > 380.0
    assert any(n.startswith(line) for n in doc["notes"]), doc["notes"]
    assert any(line in w for w in said(err)), err

    code, out, err = run_cli(["inspect", folder, "--json"], capsys)
    assert code == 0, err
    span = json.loads(out)["span"]
    assert span["gaps"] == 3
    assert abs(span["without_data_s"] - 3 * 3 * PIECE_S) < 1.0
    code, out, _ = run_cli(["inspect", folder], capsys)
    assert line in out.splitlines()


def test_a_folder_of_pieces_one_after_the_other_says_nothing_of_gaps(tmp_path, capsys):
    """Consecutive pieces: no line on the span."""
    folder = _pieces(tmp_path / "next", ["mcap"] * 3)
    code, out, err = run_cli(["inspect", folder, "--json"], capsys)
    assert code == 0, err
    assert "span" not in json.loads(out)
