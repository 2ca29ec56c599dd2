"""``--rename NEW=OLD`` beyond ``run`` and ``watch``, and what a run records of it (ch57).

A sensor ``s3`` logged as ``s3b`` from the third hourly file on: ``run --rename s3b=s3``
joined them, but ``inspect`` and ``export`` took no ``--rename``, so the joined channel
could be neither seen nor exported. Both take it now, with ``run``'s parsing and errors
(one line naming the option, exit 2). findings.json did not record a ``--rename``
given on the command line (only the config's table, ``config.rename``): a reader could
not tell that ``s3``'s later samples came from column ``s3b``. Each joined channel now
has ``renamed_from`` (the NEW name and the inputs that held it), whichever gave it.

And under ``--model``, a model channel whose column is blank in every row of the new
archive was missing from ``channels[]`` (listed, ``why`` "no reading", without
``--model``): it is listed now, and the run warns what the model lost with it."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from analyzer.simulate import simulate_building
from analyzer.writers import write_archive
from tests.cli.cli_helpers import one_line_error, run_cli, run_to, schema_valid

HOUR = 3600.0
SLOW = 0.5
"""The hourly files' rate (Hz): 1800 rows an hour, small files."""
FOUR = ["s0", "s1", "s2", "s3"]
RENAMED = [FOUR, FOUR, ["s0", "s1", "s2", "s3b"]]
BOTH = [FOUR, FOUR, ["s0", "s1", "s3b", "s3"]]


def _hourly(folder: Path, names: list[list[str]]) -> tuple[Path, np.ndarray]:
    """Hourly CSV files ``log_00.csv``... (absolute times, one after the other), file
    ``k`` holding sensor ``j``'s values under ``names[k][j]``. Returns the folder and
    every sensor's values over the record (rows, sensors)."""
    folder.mkdir()
    rows = int(HOUR * SLOW)
    rng = np.random.default_rng(5)
    y = np.cumsum(rng.normal(size=(len(names) * rows, len(names[0]))), axis=0)
    for k, cols in enumerate(names):
        t_ns = np.arange(rows, dtype=np.int64) * int(1e9 / SLOW)
        start = np.datetime64(1_780_000_000 + int(k * HOUR), "s")
        write_archive(
            folder / f"log_{k:02d}.csv",
            "csv",
            t_ns,
            {c: y[k * rows : (k + 1) * rows, j] for j, c in enumerate(cols)},
            start_iso=f"{np.datetime_as_string(start)}Z",
        )
    return folder, y


def _inspected(folder: Path, capsys: pytest.CaptureFixture[str], *more: str) -> dict:
    code, out, err = run_cli(["inspect", folder, "--json", *more], capsys)
    assert code == 0, err
    return json.loads(out)


def test_inspect_rename_lists_the_joined_channel(tmp_path, capsys):
    """inspect --rename s3b=s3: one channel s3 of the three hours' samples, named with
    where s3b was read (``renamed_from`` and a note; the table too); without it, s3b is
    a channel of its own and s3 ends after two hours."""
    folder, _ = _hourly(tmp_path / "logs", RENAMED)
    apart = _inspected(folder, capsys)
    assert sorted(c["name"] for c in apart["channels"]) == [*FOUR, "s3b"]
    doc = _inspected(folder, capsys, "--rename", "s3b=s3")
    channels = {c["name"]: c for c in doc["channels"]}
    assert sorted(channels) == FOUR
    assert channels["s3"]["samples"] == 3 * int(HOUR * SLOW)
    assert channels["s3"]["gaps"] == 0
    last = str(folder / "log_02.csv")
    assert channels["s3"]["renamed_from"] == [{"name": "s3b", "inputs": [last]}]
    assert not any("renamed_from" in c for n, c in channels.items() if n != "s3")
    assert "s3: read from s3b in log_02.csv (--rename s3b=s3)" in doc["notes"]
    assert not any("renamed?" in n for n in doc["notes"]), doc["notes"]
    code, table, err = run_cli(["inspect", folder, "--rename", "s3b=s3"], capsys)
    assert code == 0, err
    assert "note: s3: read from s3b in log_02.csv (--rename s3b=s3)" in table
    assert "s3b" not in table.replace("read from s3b", "").replace("--rename s3b=s3", "")


def test_export_rename_writes_one_column_across_the_seam(tmp_path, capsys):
    """export --rename s3b=s3: the columns time, s0..s3; s3 holds s3b's values in the
    last hour, no empty cell; without --rename s3 is empty there and s3b a column."""
    folder, y = _hourly(tmp_path / "logs", RENAMED)
    out = tmp_path / "joined.csv"
    code, _, err = run_cli(["export", folder, "--out", out, "--rename", "s3b=s3"], capsys)
    assert code == 0, err
    with out.open(newline="") as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["time", *FOUR]
    s3 = np.array([float(r[4]) for r in rows[1:]])
    assert len(s3) == len(y)
    np.testing.assert_allclose(s3, y[:, 3], rtol=1e-12)
    apart = tmp_path / "apart.csv"
    code, _, err = run_cli(["export", folder, "--out", apart], capsys)
    assert code == 0, err
    header = apart.read_text().splitlines()[0].replace('"', "").split(",")
    assert header == ["time", *FOUR, "s3b"]


@pytest.mark.parametrize("command", ["inspect", "export"])
def test_a_bad_rename_is_one_line_and_exit_2(tmp_path, capsys, command):
    """As ``run``'s: a NEW name no input holds, a text without ``=``, a name renamed to
    itself and an input holding both names are one line naming --rename, exit 2; an
    export writes no file."""
    folder, _ = _hourly(tmp_path / "logs", RENAMED)
    both, _ = _hourly(tmp_path / "both", BOTH)
    out = tmp_path / "x.csv"
    more = ["--out", out] if command == "export" else []
    cases = [
        (folder, "s9=s3", ["--rename s9=s3", "no input has a channel s9"]),
        (folder, "s3b", ["--rename s3b", "NEW=OLD"]),
        (folder, "s3=s3", ["--rename s3=s3", "renamed to itself"]),
        (both, "s3b=s3", ["--rename s3b=s3", "holds both s3b and s3"]),
    ]
    for where, text, words in cases:
        code, stdout, err = run_cli([command, where, *more, "--rename", text], capsys)
        assert code == 2, (text, err)
        assert stdout == ""
        one_line_error(err, *words)
        assert not out.exists()


def test_inspect_and_export_help_name_the_option(capsys):
    """Both commands' --help list --rename NEW=OLD (without run's config words)."""
    for command in ("inspect", "export"):
        with pytest.raises(SystemExit):
            run_cli([command, "--help"], capsys)
        out = capsys.readouterr().out
        assert "--rename NEW=OLD" in out and "[rename]" not in out, out


RATE = 50.0
PIECE_S = 40.0
FIVE = ["s0", "s1", "s2", "s3", "s4"]


def _pieces(folder: Path, names: list[list[str]], blank: str | None = None) -> Path:
    """A 5-sensor building in consecutive files of :data:`PIECE_S` seconds (long enough
    for ``run``'s detectors; as tests/cli/test_rename_option.py writes them); the last
    file has one more column, ``blank``, blank in every row, where it is given."""
    folder.mkdir()
    t, y, _ = simulate_building(5, len(names) * PIECE_S, RATE, seed=11)
    rows = int(PIECE_S * RATE)
    for k, cols in enumerate(names):
        part = slice(k * rows, (k + 1) * rows)
        iso = np.datetime_as_string(np.datetime64(1_780_000_000 + int(k * PIECE_S), "s")) + "Z"
        t_ns = np.round(t[part] * 1e9).astype(np.int64)
        data = {c: y[part, j] for j, c in enumerate(cols)}
        if blank is not None and k == len(names) - 1:
            data[blank] = np.full(rows, np.nan)
        write_archive(folder / f"log_{k:02d}.csv", "csv", t_ns, data, start_iso=iso)
    return folder


@pytest.mark.parametrize("given", ["option", "config"])
def test_run_records_the_renames_it_applied(tmp_path, capsys, given):
    """--rename s2_new=s2, or the config's [rename]: findings.json's s2 has
    ``renamed_from`` [{name s2_new, inputs [log_02.csv]}] (the option's was nowhere,
    the config's only in ``config.rename``), the other channels none; the report's
    channel table says it under s2's name."""
    folder = _pieces(tmp_path / "logs", [FIVE, FIVE, ["s0", "s1", "s2_new", "s3", "s4"]])
    if given == "option":
        more: list[object] = ["--rename", "s2_new=s2"]
    else:
        config = tmp_path / "rename.toml"
        config.write_text('[rename]\ns2_new = "s2"\n')
        more = ["--config", config]
    code, err, doc, out = run_to(tmp_path, capsys, folder, *more)
    assert code == 0, err
    schema_valid(doc)
    channels = {c["name"]: c for c in doc["channels"]}
    assert sorted(channels) == FIVE
    last = str(folder / "log_02.csv")
    assert last in [i["path"] for i in doc["inputs"]]
    assert channels["s2"]["renamed_from"] == [{"name": "s2_new", "inputs": [last]}]
    assert not any("renamed_from" in c for n, c in channels.items() if n != "s2")
    html = (out / "report.html").read_text()
    assert "read from s2_new in log_02.csv" in html


def test_run_records_two_names_joined_to_one_and_a_blank_one(tmp_path, capsys):
    """A sensor replaced twice (s2, then s2b, then s2c, a file each): both NEW names are
    recorded on s2, in the order read. A NEW column blank in every row read as a name
    no input has (t9 as t8): t8 is listed with no reading and its ``renamed_from``."""
    names = [FIVE, ["s0", "s1", "s2b", "s3", "s4"], ["s0", "s1", "s2c", "s3", "s4"]]
    folder = _pieces(tmp_path / "logs", names, blank="t9")
    renames = ["--rename", "s2b=s2", "--rename", "s2c=s2", "--rename", "t9=t8"]
    code, err, doc, _ = run_to(tmp_path, capsys, folder, *renames)
    assert code == 0, err
    schema_valid(doc)
    channels = {c["name"]: c for c in doc["channels"]}
    assert channels["s2"]["renamed_from"] == [
        {"name": "s2b", "inputs": [str(folder / "log_01.csv")]},
        {"name": "s2c", "inputs": [str(folder / "log_02.csv")]},
    ]
    assert channels["s2"]["samples"] == int(3 * PIECE_S * RATE)
    t8 = channels["t8"]
    assert (t8["samples"], t8["analyzed"], t8["why"]) == (0, False, "no reading"), t8
    assert t8["renamed_from"] == [{"name": "t9", "inputs": [str(folder / "log_02.csv")]}]
    assert "t9" not in channels


def test_a_config_rename_that_matches_nothing_is_an_error(tmp_path, capsys):
    """The config's [rename] with a NEW name no input has: one line, exit 2, as the
    option's (so only renames that matched a channel are recorded), naming the config's
    line, not a ``--rename`` the user did not give; the same pair given as ``--rename``
    too is named as the option."""
    folder = _pieces(tmp_path / "logs", [FIVE, FIVE])
    config = tmp_path / "rename.toml"
    config.write_text('[rename]\ns9 = "s2"\n')
    code, err, doc, _ = run_to(tmp_path, capsys, folder, "--config", config)
    assert code == 2 and doc is None
    line = one_line_error(err, f'{config}: [rename] s9 = "s2"', "no input has a channel s9")
    assert "--rename" not in line, line
    code, err, _, _ = run_to(tmp_path, capsys, folder, "--config", config, "--rename", "s9=s1")
    assert code == 2
    one_line_error(err, "--rename s9=s1", "no input has a channel s9")
