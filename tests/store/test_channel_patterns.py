"""``--channels`` patterns over array channels and the names suggested for a pattern that
matches none (a new user's audit, ux52 items 11 and 15): ``[`` read as a character class
made ``'/imu.orientation_covariance[*]'``, ``'*covariance[0]'`` and ``'/scan.ranges[10*]'``
match nothing, with no hint; ``odom.*`` was answered ``did you mean '*odom.**'`` and the
PlotJuggler form ``/odom/pose/*`` got no suggestion."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.errors import ArchiveUsageError
from analyzer.readers.base import ChannelChunk
from analyzer.selection import select_channels
from analyzer.store import ChannelStore

NAMES = [
    *(f"/imu.orientation_covariance[{i}]" for i in range(9)),
    "/imu.orientation.x",
    *(f"/scan.ranges[{i}]" for i in (1, 10, 11, 100, 101, 200)),
    "/gps.sats[0].snr",
    "/gps.sats[1].snr",
    "/odom.pose.x",
    "/odom.pose.y",
    "/odom.twist.x",
    "/turtle1/pose.x",
    "/s1.data",
    "/s2.data",
    "/sx.data",
]


@pytest.fixture(scope="module")
def store():
    t = np.arange(50, dtype=np.int64) * 10_000_000
    rng = np.random.default_rng(0)
    chunks = [ChannelChunk(n, t, rng.standard_normal(t.size)) for n in NAMES]
    with ChannelStore.from_chunks(chunks) as s:
        yield s


@pytest.mark.parametrize(
    "pattern, expected",
    [
        ("/imu.orientation_covariance[*]", [f"/imu.orientation_covariance[{i}]" for i in range(9)]),
        ("*covariance[0]", ["/imu.orientation_covariance[0]"]),
        ("/scan.ranges[10*]", ["/scan.ranges[10]", "/scan.ranges[100]", "/scan.ranges[101]"]),
        ("/scan.ranges[1?]", ["/scan.ranges[10]", "/scan.ranges[11]"]),
        ("/gps.sats[*].snr", ["/gps.sats[0].snr", "/gps.sats[1].snr"]),
        ("/scan.ranges[[]10*", ["/scan.ranges[10]", "/scan.ranges[100]", "/scan.ranges[101]"]),
        # (a set of characters where no index reads so: as before)
        ("/s[12].data", ["/s1.data", "/s2.data"]),
        ("/s[!12].data", ["/sx.data"]),
        ("/s[0-9].data", ["/s1.data", "/s2.data"]),
    ],
)
def test_array_indexes_match_as_written_and_sets_still_work(store, pattern, expected):
    assert store.unmatched([pattern]) == []
    assert store.select([pattern]) == expected


def test_an_index_glob_leaves_out_as_well(store):
    chosen = store.select(["/imu.*", "!/imu.orientation_covariance[*]"])
    assert chosen == ["/imu.orientation.x"]


def test_a_bracket_pattern_that_matches_nothing_says_how_brackets_read(store):
    line = store.unmatched_line(["/scan.ranges[7*]"])
    assert "brackets holding digits, * or ? match an array's index as written" in line
    assert "'[[]' matches a '['" in line


@pytest.mark.parametrize(
    "pattern, near",
    [
        ("odom.*", "'/odom.*', which matches /odom.pose.x, /odom.pose.y, /odom.twist.x"),
        ("/odom/pose/*", "'/odom.pose.*', which matches /odom.pose.x, /odom.pose.y"),
        ("/odom/pose/x", "/odom.pose.x"),
        ("/turtle1/pose/x", "/turtle1/pose.x"),
        ("odom/twist/x", "/odom.twist.x"),
    ],
)
def test_a_name_written_another_way_is_suggested_as_the_channels_are_named(store, pattern, near):
    line = store.unmatched_line([pattern])
    assert f"did you mean {near}?" in line, line
    assert "**" not in line


def test_a_wildcard_ending_pattern_is_not_wrapped_twice(store):
    line = store.unmatched_line(["twist*"])
    assert "did you mean /odom.twist.x?" in line, line
    line = store.unmatched_line(["pose.*"])
    assert "'*pose.*', which matches" in line and "**" not in line, line


def test_select_channels_takes_an_index_glob(store):
    notes: list[str] = []
    assert select_channels(store, ["/gps.sats[*].snr"], notes) == [
        "/gps.sats[0].snr",
        "/gps.sats[1].snr",
    ]
    with pytest.raises(ArchiveUsageError, match="matches no channel"):
        select_channels(store, ["/gps.sats[9*].snr"], [])
