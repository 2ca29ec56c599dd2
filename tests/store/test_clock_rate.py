"""The default common clock (:func:`analyzer.store.clock_rate`): the entries of ROS
covariance arrays do not vote (the realdata audit: nav2_turtlebot.mcap's /amcl_pose, its
pose and 4 varying covariance entries at 1.4 Hz, set the clock over a 27.6 Hz
odometry's 6 channels, and the default training window held 29 rows)."""

from __future__ import annotations

import pytest

from analyzer.store import ChannelInfo, clock_rate, dominant_rate


def _info(name: str, rate: float) -> ChannelInfo:
    return ChannelInfo(name, 100, 0, 10**9, rate, 0, 100, 0.0, 1.0)


def test_covariance_entries_do_not_vote():
    odom = [_info(f"/odom.pose.pose.position.{k}", 27.63) for k in "xyzuvw"]
    amcl = [_info(f"/amcl_pose.pose.pose.{k}", 1.41) for k in ("x", "y", "oz", "ow")]
    cov = [_info(f"/amcl_pose.pose.covariance[{k}]", 1.41) for k in (0, 1, 7, 35)]
    assert dominant_rate([i.rate_hz for i in odom + amcl + cov]) == pytest.approx(1.41)
    assert clock_rate(odom + amcl + cov) == pytest.approx(27.63)
    imu = [_info(f"/imu.orientation_covariance[{k}]", 5.0) for k in range(9)]
    assert clock_rate([_info("/imu.linear_acceleration.x", 200.0), *imu]) == 200.0


def test_only_covariance_entries_still_set_a_clock():
    assert clock_rate([_info(f"/p.pose.covariance[{k}]", 2.0) for k in range(3)]) == 2.0


def test_the_rate_most_channels_share_is_kept():
    """A 16-channel 100 Hz archive runs at 100 Hz beside fewer slower channels, and a
    channel merely named like a covariance (no array entry of a ROS message) votes."""
    fast = [_info(f"s{k}", 100.0) for k in range(16)]
    slow = [_info(f"t{k}", 5.0) for k in range(15)]
    assert clock_rate(fast + slow) == 100.0
    assert clock_rate([_info("covariance_estimate_gain", 10.0), _info("x", 20.0)]) == 20.0
    assert clock_rate([_info("a", 10.0), _info("b", 10.0), _info("c", 20.0)]) == 10.0


def test_export_and_run_clock_is_not_set_by_covariance_entries(tmp_path):
    """4 accelerometers at 100 Hz, a pose estimate's 2 fields and 6 covariance entries at
    5 Hz: the clock is 100 Hz (it was 5 Hz, 8 votes to 4)."""
    import json

    import numpy as np

    from analyzer.cli import main
    from analyzer.simulate import simulate_building

    t, y, names = simulate_building(2, 60.0, 100.0, seed=2, sensors_per_floor=2)
    rng = np.random.default_rng(0)
    slow = np.full((t.size, 8), np.nan)
    slow[::20] = rng.standard_normal((t[::20].size, 8)).cumsum(axis=0)
    cols = [*names, "/pose.x", "/pose.y", *(f"/pose.covariance[{k}]" for k in range(6))]
    path = tmp_path / "r.csv"
    np.savetxt(
        path,
        np.column_stack([t, y, slow]),
        delimiter=",",
        header="time," + ",".join(cols),
        comments="",
        fmt="%.17g",
    )
    out = tmp_path / "e.csv"
    assert main(["export", str(path), "--out", str(out)]) == 0
    rows = out.read_text().count("\n") - 1
    assert rows == pytest.approx(t.size, abs=2)
    assert main(["run", str(path), "--out", str(tmp_path / "o"), "--no-progress"]) in (0, 1)
    assert json.loads((tmp_path / "o" / "findings.json").read_text())["rate_hz"] == 100.0
