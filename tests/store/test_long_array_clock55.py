"""The elements of a long array (more than :data:`analyzer.store.LONG_ARRAY` numbers in one
field of a message: a laser scan's beams) vote for the common clock as one channel (ux58
#2: a 360-beam /scan at 10 Hz outvoted a 200-Hz IMU, odometry and joints, and the run was
refused, its training window too short at 10 Hz)."""

from __future__ import annotations

from analyzer.store import LONG_ARRAY, ChannelInfo, array_field, clock_rate, long_arrays


def _info(name: str, rate: float) -> ChannelInfo:
    return ChannelInfo(name, 100, 0, 10**9, rate, 0, 100, 0.0, 1.0)


def test_a_scan_votes_as_one_channel() -> None:
    robot = [_info(f"/imu.{f}.{k}", 200.0) for f in ("linear_acceleration", "gyro") for k in "xyz"]
    robot += [_info(f"/joint_states.position[{k}]", 100.0) for k in range(5)]
    robot += [_info(f"/odom.twist.twist.linear.{k}", 50.0) for k in "xy"]
    scan = [_info(f"/scan.ranges[{k}]", 10.0) for k in range(360)]
    assert clock_rate(robot + scan) == 200.0
    # with the scan's intensities too: two votes, still fewer than the IMU's six
    intensities = [_info(f"/scan.intensities[{k}]", 10.0) for k in range(360)]
    assert clock_rate(robot + scan + intensities) == 200.0


def test_an_array_at_the_limit_still_votes_per_element() -> None:
    """Up to :data:`LONG_ARRAY` elements, each element is a sensor of its own (a robot's
    joints, a data logger's channels in one array)."""
    array = [_info(f"/daq.data[{k}]", 10.0) for k in range(LONG_ARRAY)]
    others = [_info(f"/imu.x{k}", 200.0) for k in range(3)]
    assert clock_rate(array + others) == 10.0
    longer = array + [_info(f"/daq.data[{LONG_ARRAY}]", 10.0)]
    assert clock_rate(longer + others) == 200.0


def test_a_long_array_alone_sets_the_clock() -> None:
    assert clock_rate([_info(f"/scan.ranges[{k}]", 10.0) for k in range(360)]) == 10.0


def test_array_fields_and_long_arrays() -> None:
    assert array_field("/scan.ranges[148]") == "/scan.ranges[*]"
    assert array_field("/tf.transforms[3].transform.translation.x") == (
        "/tf.transforms[*].transform.translation.x"
    )
    assert array_field("/imu.linear_acceleration.x") is None
    names = [f"/tf.transforms[{k}].transform.translation.x" for k in range(70)]
    names += [f"/js.position[{k}]" for k in range(40)]
    assert list(long_arrays(names)) == ["/tf.transforms[*].transform.translation.x"]
