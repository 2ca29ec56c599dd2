"""A folder of CSV files in turn whose later file renames a column (``s2`` becomes
``s2_new``) or adds one (``s5``): the new name has no sample in the training window, so
no fault on it is searched for; a run said "no sensor fault found", exit 0, with nothing
on stderr, and a fault on the renamed sensor was lost (the ux55 audit, item 1). The run
now says which channels were not searched and why, names the likely rename, and reads
the old name's missing column in the later file as blank cells: a sensor that stops
reading while the others go on (:mod:`analyzer.silent`)."""

from __future__ import annotations

import numpy as np

from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive
from tests.cli.cli_helpers import run_to, said, schema_valid

RATE = 50.0
PIECE_S = 40.0


def _folder(folder, names, fault_on=None):
    """A 5-sensor building in three consecutive CSV files of :data:`PIECE_S` seconds,
    absolute times; ``names[k]`` the columns of file ``k`` (their values: ``s0``..``s4``
    of the simulation, then a sixth column copied from s0 plus noise where named ``s5``);
    an additive fault on sensor ``fault_on`` from 100 s."""
    folder.mkdir()
    t, y, _ = simulate_building(5, 3 * PIECE_S, RATE, seed=11)
    if fault_on is not None:
        sd = float(y[: int(20 * RATE), fault_on].std())
        y[:, fault_on] = inject_fault(y[:, fault_on], RATE, "additive", 100.0, 4 * sd)
    extra = y[:, 0] + np.random.default_rng(1).normal(0, 0.1, len(t))
    rows = int(PIECE_S * RATE)
    for k, cols in enumerate(names):
        part = slice(k * rows, (k + 1) * rows)
        t_ns = np.round(t[part] * 1e9).astype(np.int64)
        iso = np.datetime_as_string(np.datetime64(1_780_000_000 + int(k * PIECE_S), "s")) + "Z"
        data = {c: (extra if c == "s5" else y[:, j])[part] for j, c in enumerate(cols)}
        write_archive(folder / f"log_{k:02d}.csv", "csv", t_ns, data, start_iso=iso)
    return folder


FIVE = ["s0", "s1", "s2", "s3", "s4"]


def test_a_renamed_column_is_said_and_the_old_name_going_silent_is_a_finding(tmp_path, capsys):
    """``s2`` is ``s2_new`` in the last file, the fault on it from 100 s: stderr names
    ``s2_new`` as not searched (no data in the training window) and the likely rename;
    ``s2``'s column missing from the last file is ``silent_check``'s finding from the
    file's start (exit 1), and the last line does not read as every channel checked."""
    folder = _folder(tmp_path / "renamed", [FIVE, FIVE, ["s0", "s1", "s2_new", "s3", "s4"]], 2)
    code, err, doc, _ = run_to(tmp_path, capsys, folder)
    assert code == 1, err
    warned = said(err)
    (rename,) = [w for w in warned if "renamed?" in w]
    assert "log_02.csv: s2_new begins in this file where s2 ends" in rename
    (unsearched,) = [w for w in warned if "s2_new has no sample in the training window" in w]
    assert "a fault on it cannot be found" in unsearched and "--train" in unsearched
    last = err.splitlines()[-1]
    assert "1 channel not searched, with no data in the training window" in last
    silent = [f for f in doc["faults"] if f["detector"] == "silent_check"]
    assert [(f["channel"], f["onset_s"]) for f in silent] == [("s2", 2 * PIECE_S)], doc["faults"]
    assert {c["name"]: c.get("why") for c in doc["channels"]}["s2_new"] == "no training samples"
    schema_valid(doc)


def test_an_added_column_without_training_data_is_said_on_stderr(tmp_path, capsys):
    """``s5`` only in the middle file (no fault anywhere): exit 0 still, but stderr says
    ``s5`` was not searched, and the last line says a channel was not searched. Its
    column missing from the last file is no finding: it was never analyzed."""
    folder = _folder(tmp_path / "added", [FIVE, [*FIVE, "s5"], FIVE])
    code, err, doc, _ = run_to(tmp_path, capsys, folder)
    assert code == 0, err
    assert any("s5 has no sample in the training window" in w for w in said(err)), err
    last = err.splitlines()[-1]
    assert last.startswith("analyzer: no sensor fault found (1 channel not searched"), last
    assert not any("renamed?" in w for w in said(err)), err  # (nothing begins where s5 ends)
    assert doc["faults"] == []


def test_files_of_different_columns_over_the_same_time_are_not_marked(tmp_path, capsys):
    """One file per sensor node over the same time (``s0``-``s2`` and ``s3``-``s4``): the
    columns one file lacks are the other's, not silent sensors; no rename is suggested."""
    folder = tmp_path / "nodes"
    folder.mkdir()
    t, y, _ = simulate_building(5, 120.0, RATE, seed=11)
    t_ns = np.round(t * 1e9).astype(np.int64)
    iso = np.datetime_as_string(np.datetime64(1_780_000_000, "s")) + "Z"
    for k, cols in enumerate([FIVE[:3], FIVE[3:]]):
        data = {c: y[:, FIVE.index(c)] for c in cols}
        write_archive(folder / f"node{k}.csv", "csv", t_ns, data, start_iso=iso)
    code, err, doc, _ = run_to(tmp_path, capsys, folder)
    assert code == 0, err
    assert not any("renamed?" in w or "not searched" in w for w in err.splitlines()), err
    assert doc["faults"] == []
