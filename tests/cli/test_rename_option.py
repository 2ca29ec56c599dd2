"""A sensor replaced under a new name from one hourly file on (ch56 item 2; the ux62
audit, LOW 11): ``s2`` is ``s2_new`` in the last file. The run warned "s2_new begins in
this file where s2 ends: the same sensor renamed?", but the finding of ``s2`` going
silent said "dead sensor" in findings.json with no hint. Its ``check`` now says the
other channel begins where it ends and names ``--rename NEW=OLD``, which reads NEW's
samples as OLD's channel (CSV columns and MCAP channel names alike; the config's
``[rename]`` too): the joined channel is analyzed across the seam."""

from __future__ import annotations

import numpy as np

from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive
from tests.cli.cli_helpers import one_line_error, run_to, said, schema_valid

RATE = 50.0
PIECE_S = 40.0
FIVE = ["s0", "s1", "s2", "s3", "s4"]
RENAMED = [FIVE, FIVE, ["s0", "s1", "s2_new", "s3", "s4"]]


def _folder(folder, names, fmt="csv", fault_on=None):
    """A 5-sensor building in three consecutive files of :data:`PIECE_S` seconds
    (absolute times), ``names[k]`` the channels of file ``k`` (sensor ``j``'s values
    under ``names[k][j]``); an additive fault on sensor ``fault_on`` from 100 s (in the
    last file). Returns the folder and the channel names the readers give."""
    folder.mkdir()
    t, y, _ = simulate_building(5, 3 * PIECE_S, RATE, seed=11)
    if fault_on is not None:
        sd = float(y[: int(20 * RATE), fault_on].std())
        y[:, fault_on] = inject_fault(y[:, fault_on], RATE, "additive", 100.0, 4 * sd)
    rows = int(PIECE_S * RATE)
    given: dict[str, str] = {}
    for k, cols in enumerate(names):
        part = slice(k * rows, (k + 1) * rows)
        t_ns = np.round(t[part] * 1e9).astype(np.int64)
        iso = np.datetime_as_string(np.datetime64(1_780_000_000 + int(k * PIECE_S), "s")) + "Z"
        data = {c: y[part, j] for j, c in enumerate(cols)}
        path = folder / f"log_{k:02d}.{fmt}"
        given.update(write_archive(path, fmt, t_ns, data, start_iso=iso))
    return folder, given


def test_the_dead_sensor_finding_of_a_renamed_column_names_the_option(tmp_path, capsys):
    """Without --rename: ``s2``'s silence is still a finding, but its ``check`` says
    ``s2_new`` begins where it ends and gives ``--rename s2_new=s2``; so does the
    warning."""
    folder, _ = _folder(tmp_path / "renamed", RENAMED)
    code, err, doc, _ = run_to(tmp_path, capsys, folder)
    assert code == 1, err
    (rename,) = [w for w in said(err) if "renamed?" in w]
    assert "give --rename s2_new=s2" in rename, rename
    (silent,) = [f for f in doc["faults"] if f["channel"] == "s2"]
    assert silent["detector"] == "silent_check", silent
    assert (
        "(another channel, s2_new, begins where it ends: renamed? give --rename s2_new=s2)"
        in silent["check"]
    ), silent["check"]
    schema_valid(doc)


def test_rename_joins_the_new_name_to_the_old_channel(tmp_path, capsys):
    """--rename s2_new=s2: one channel ``s2`` of the whole record's samples, analyzed, no
    finding, no ``s2_new`` and no rename warning (exit 0)."""
    folder, _ = _folder(tmp_path / "renamed", RENAMED)
    code, err, doc, _ = run_to(tmp_path, capsys, folder, "--rename", "s2_new=s2")
    assert code == 0, err
    assert doc["faults"] == [], doc["faults"]
    channels = {c["name"]: c for c in doc["channels"]}
    assert sorted(channels) == FIVE
    assert channels["s2"]["samples"] == int(3 * PIECE_S * RATE) and channels["s2"]["analyzed"]
    assert channels["s2"]["gaps"] == 0
    assert not any("renamed?" in w or "s2_new" in w for w in said(err)), err
    schema_valid(doc)


def test_a_fault_after_the_seam_is_found_on_the_joined_channel(tmp_path, capsys):
    """The fault on the replaced sensor from 100 s (in the file of its new name), the
    rename given by the config's ``[rename]`` table: found on ``s2`` near its onset,
    no dead-sensor finding."""
    folder, _ = _folder(tmp_path / "renamed", RENAMED, fault_on=2)
    config = tmp_path / "rename.toml"
    config.write_text('[rename]\ns2_new = "s2"\n')
    code, err, doc, _ = run_to(tmp_path, capsys, folder, "--config", config)
    assert code == 1, err
    assert not any(f["detector"] == "silent_check" for f in doc["faults"]), doc["faults"]
    (fault,) = doc["faults"]
    assert fault["channel"] == "s2" and fault["type"] == "additive", fault
    assert abs(fault["onset_s"] - 100.0) < 2.0, fault
    assert doc["config"]["rename"] == {"s2_new": "s2"}
    schema_valid(doc)


def test_rename_joins_mcap_channel_names(tmp_path, capsys):
    """MCAP files whose topic ``/s2`` becomes ``/s2_new``: --rename
    /s2_new.data=/s2.data joins them (one channel, the record's every sample)."""
    folder, given = _folder(tmp_path / "mcap", RENAMED, fmt="mcap")
    new, old = given["s2_new"], given["s2"]
    code, err, doc, _ = run_to(tmp_path, capsys, folder, "--rename", f"{new}={old}")
    assert code == 0, err
    channels = {c["name"]: c for c in doc["channels"]}
    assert new not in channels and channels[old]["samples"] == int(3 * PIECE_S * RATE)
    assert channels[old]["analyzed"] and doc["faults"] == []


def test_an_unknown_or_malformed_rename_is_one_line_and_exit_2(tmp_path, capsys):
    """A NEW name no input holds, a text without ``=``, and a file holding both names:
    one line naming --rename, exit 2."""
    folder, _ = _folder(tmp_path / "renamed", RENAMED)
    code, err, _, _ = run_to(tmp_path, capsys, folder, "--rename", "s9=s2")
    assert code == 2
    one_line_error(err, "--rename s9=s2", "no input has a channel s9")
    code, err, _, _ = run_to(tmp_path, capsys, folder, "--rename", "s2_new")
    assert code == 2
    one_line_error(err, "--rename s2_new", "NEW=OLD")
    both, _ = _folder(tmp_path / "both", [FIVE, FIVE, ["s0", "s1", "s2_new", "s2", "s4"]])
    code, err, _, _ = run_to(tmp_path, capsys, both, "--rename", "s2_new=s2")
    assert code == 2
    one_line_error(err, "--rename s2_new=s2", "holds both s2_new and s2")
