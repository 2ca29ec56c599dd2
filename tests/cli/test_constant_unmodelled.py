"""A sensor named that reads one value where the run cannot say it otherwise (a new
user's audit, items 4 and 12): a dead channel ``--channels`` names in a record too short
for every detector stopped the run with exit 2, naming it nowhere (the constant check
needs no healthy window: its finding is reported alone, exit 1); and a ``--channels``
glob's constant fields of no family (a dead IMU's six axes, ``'/imu.*'``) were left out
with a note in findings.json only (now one warning line names them)."""

from __future__ import annotations

import numpy as np

from analyzer.simulate import simulate_building
from analyzer.writers import write_archive
from tests.cli.cli_helpers import one_line_error, run_cli, run_to, said, schema_valid


def _record(tmp_path, value=0.0, extra=None, duration_s=60.0):
    """A 5-floor building at 200 Hz, written as an MCAP through the project's writer,
    with ``/s3.data`` at ``value`` over the whole record (``None``: healthy); ``extra``:
    more channels."""
    t, y, names = simulate_building(duration_s=duration_s, seed=31)
    if value is not None:
        y[:, 3] = value
    data = {k: y[:, i] for i, k in enumerate(names)} | (extra or {})
    path = tmp_path / "r.mcap"
    t_ns = (t * 1e9).round().astype(np.int64)
    write_archive(path, "mcap", t_ns, data, start_iso="2026-05-01T00:00:00Z")
    return path


SHORT = "/s0.data,/s1.data,/s3.data"


def test_a_named_dead_sensor_is_reported_when_no_detector_canrun_to(tmp_path, capsys):
    """12 s at 200 Hz: the default window (2.4 s) is too short for every detector, and
    the run stopped with exit 2, naming the dead /s3.data nowhere (a new user's audit,
    on a 12-s cart-pole record). The constant check needs no window: its finding is
    reported (exit 1), with why the others could not run on stderr and in the notes."""
    path = _record(tmp_path, duration_s=12.0)
    code, err, doc, out = run_to(tmp_path, capsys, path, "--channels", SHORT)
    assert code == 1, err
    (f,) = doc["faults"]
    assert (f["channel"], f["detector"], f["magnitude"]) == (
        "/s3.data",
        "constant_check",
        {"gain": 0.0},
    )
    assert [d["name"] for d in doc["detectors"]] == ["constant_check"]
    assert {"ar_kalman_bank", "equivalent_model"} <= set(doc["skipped_detectors"])
    (line,) = [ln for ln in said(err) if "no detector could run" in ln]
    assert line.startswith(
        "analyzer: warning: no fault but a dead or stuck sensor (/s3.data) was searched for"
    )
    assert "too short" in line
    assert any(n.startswith("no fault but a dead or stuck sensor") for n in doc["notes"])
    assert err.splitlines()[-1].startswith("analyzer: 1 sensor fault found on 1 sensor: /s3.data")
    page = (out / "report.html").read_text()
    assert "reads 0.0 on every one of its 2 400 samples" in page
    schema_valid(doc)


def test_no_detector_and_no_dead_sensor_is_still_refused(tmp_path, capsys):
    path = _record(tmp_path, value=None, duration_s=12.0)
    code, _, err = run_cli(["run", path, "--out", tmp_path / "o", "--channels", SHORT], capsys)
    assert code == 2
    one_line_error(err, "no detector could run")


def test_save_model_with_no_detector_is_still_refused(tmp_path, capsys):
    """--save-model has nothing to save when no detector ran: refused as before."""
    path = _record(tmp_path, duration_s=12.0)
    out = tmp_path / "o"
    args = ["run", path, "--out", out, "--channels", SHORT, "--save-model", tmp_path / "m.json"]
    code, _, err = run_cli(args, capsys)
    assert code == 2
    one_line_error(err, "no detector could run")


def test_a_watched_archive_too_short_waits_though_a_named_sensor_is_dead(tmp_path):
    """The watcher leaves a too-short archive in INBOX to grow (a file still being
    written), dead sensor or not: analyzed whole later, not cut in two."""
    from analyzer.options import load_options
    from analyzer.watch import EXIT_TOO_SHORT, analysis_into

    path = _record(tmp_path, duration_s=12.0)
    out, work = tmp_path / "out", tmp_path / "work"
    out.mkdir()
    work.mkdir()
    options = load_options(None, channels=SHORT.split(","))
    assert analysis_into([str(path)], options, out, work) == EXIT_TOO_SHORT
    assert "no detector could run" in (out / "error.txt").read_text()


def _lone_fields(tmp_path):
    """The 5-floor record, healthy, with a 'gyro' of three axes each at one value (a dead
    IMU's, or one nothing turned) and a 4-entry 'cov' table all 0.0 (a structure's
    constant entries), 12 000 samples each."""
    n = 12000
    extra = {f"gyro_{a}": np.full(n, v) for a, v in zip("xyz", (131.0, 132.0, 133.0), strict=True)}
    extra |= {f"cov{k}": np.zeros(n) for k in range(4)}
    return _record(tmp_path, value=None, extra=extra)


def test_constant_fields_a_glob_matches_are_warned_of(tmp_path, capsys):
    """A glob's constant fields of no family were left out with a note in findings.json
    only (a new user's audit: a dead IMU's six axes, ``--channels '/imu.*'``): one
    warning line names them with their values; no finding (nothing tells a dead sensor
    from a quantity nothing changed); a table's constant entries stay quiet."""
    code, err, doc, _ = run_to(
        tmp_path, capsys, _lone_fields(tmp_path), "--channels", "/s*,/gyro*,/cov*"
    )
    assert code == 0, err
    assert doc["faults"] == []
    (line,) = [ln for ln in said(err) if "gyro" in ln]
    assert line == (
        "analyzer: warning: --channels: /gyro_x.data (131.0), /gyro_y.data (132.0), "
        "/gyro_z.data (133.0) read one value on every one of their 12 000 samples: not "
        "analyzed, as constant (a dead or stuck sensor, or a quantity nothing changed in "
        "this record); name them exactly in --channels to have them reported as a fault"
    )
    assert "cov" not in err
    why = {c["name"]: c.get("why") for c in doc["channels"]}
    assert why["/gyro_x.data"] == why["/cov0.data"] == "constant"


def test_constant_fields_named_exactly_are_findings(tmp_path, capsys):
    """The warning's advice works: named exactly, beside varying channels, they are."""
    names = "/s0.data,/s1.data,/s2.data,/gyro_x.data,/gyro_y.data"
    code, err, doc, _ = run_to(tmp_path, capsys, _lone_fields(tmp_path), "--channels", names)
    assert code == 1, err
    assert {f["channel"] for f in doc["faults"]} == {"/gyro_x.data", "/gyro_y.data"}
    assert "read one value on every one of their" not in err


def test_an_all_constant_selection_names_its_channels(tmp_path, capsys):
    path = _lone_fields(tmp_path)
    code, _, err = run_cli(["run", path, "--out", tmp_path / "o", "--channels", "/gyro*"], capsys)
    assert code == 2
    line = one_line_error(err, "every channel '/gyro*' selects is constant or empty")
    assert "/gyro_x.data (131.0), /gyro_y.data (132.0), /gyro_z.data (133.0)" in line


def test_realdata_cart_pole_stuck_position_is_reported(tmp_path, capsys, realdata):
    """The audit's run: 12.2 s at 20 Hz, too short for every detector; the cart's
    position and velocity read 0.0 on all 244 samples (MANIFEST: a flatline case)."""
    path = realdata / "mcap" / "cart-pole" / "out_of_bounds.mcap"
    names = ",".join(
        f"/cartpole/state.{c}"
        for c in ("cart_position", "cart_velocity", "pole_angle", "pole_angular_velocity")
    )
    code, err, doc, _ = run_to(tmp_path, capsys, path, "--channels", names)
    assert code == 1, err
    found = {
        (f["channel"], f["detector"], f["evidence"]["constant"]["samples"]) for f in doc["faults"]
    }
    assert ("/cartpole/state.cart_position", "constant_check", 244) in found
    assert any("no detector could run" in ln for ln in said(err))


def test_realdata_dead_imu_a_glob_selects_is_warned_of(tmp_path, capsys, realdata):
    """The audit's run on plotjuggler's rosbag2_test: the IMU's axes each read one value
    on all 1 565 samples, and stderr said nothing of them."""
    path = realdata / "ros2" / "plotjuggler" / "rosbag2_test"
    args = ["--train", "0:29", "--channels", "/imu.*,/battery.voltage,/pose.pose.position.x"]
    code, err, doc, _ = run_to(tmp_path, capsys, path, *args)
    assert code in (0, 1), err
    (line,) = [ln for ln in said(err) if "/imu.angular_velocity.x" in ln]
    for axis in ("angular_velocity", "linear_acceleration"):
        for c in "xyz":
            assert f"/imu.{axis}.{c} (" in line
    assert "covariance" not in line
    assert not [f for f in doc["faults"] if f["channel"].startswith("/imu")]
