"""Channels that copy another over the whole record (the realdata audit: runs refused as
a whole because the entries [1] and [6] of a symmetric ROS covariance matrix, or six
joints of a fake joint-state publisher, are equal sample for sample): the default run
leaves the copies out with a note; a run whose channels the user named keeps them."""

from __future__ import annotations

import json
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from analyzer.cli import main
from analyzer.readers import open_archive
from analyzer.simulate import simulate_building
from analyzer.store import ChannelStore
from analyzer.store.copies import find_copies


def _save(path, t, columns, names):
    header = "time," + ",".join(names)
    np.savetxt(
        path, np.column_stack([t, columns]), delimiter=",", header=header, comments="", fmt="%.17g"
    )
    return path


def _record(tmp_path, late_fault: bool = False):
    """A 3-floor building (s0..s2) with ``dup`` equal to s1 (up to float rounding),
    ``kelvin`` = 1.8 s0 + 32 and ``neg`` = -s2; with ``late_fault`` ``dup`` parts from s1
    in the record's last quarter (a fault on one of two twins)."""
    t, y, names = simulate_building(3, 120.0, 50.0, seed=3)
    dup = y[:, 1] * (1 + 1e-15)
    if late_fault:
        dup = dup.copy()
        dup[3 * t.size // 4 :] += 5.0 * y[:, 1].std()
    extra = np.column_stack([dup, 1.8 * y[:, 0] + 32.0, -y[:, 2]])
    names = [*names, "dup", "kelvin", "neg"]
    return _save(tmp_path / "r.csv", t, np.column_stack([y, extra]), names)


def _findings(out):
    return json.loads((out / "findings.json").read_text())


def test_find_copies_names_equal_and_linear_copies(tmp_path):
    path = _record(tmp_path)
    with ChannelStore.from_chunks(open_archive([path]).chunks(), tmp_path / "st") as store:
        names = store.select(None)
        copies = {c.channel: c for c in find_copies(store, names)}
    assert set(copies) == {"dup", "kelvin", "neg"}
    assert copies["dup"].relation == "= s1"
    assert copies["neg"].relation == "= -s2"
    assert copies["kelvin"].of == "s0"
    assert copies["kelvin"].alpha == pytest.approx(1.8)
    assert copies["kelvin"].beta == pytest.approx(32)


def test_the_default_run_leaves_copies_out_with_a_note(tmp_path, capsys):
    path = _record(tmp_path)
    out = tmp_path / "o"
    assert main(["run", str(path), "--out", str(out), "--no-progress"]) in (0, 1)
    doc = _findings(out)
    analyzed = {c["name"] for c in doc["channels"] if c["analyzed"]}
    assert analyzed == {"s0", "s1", "s2"}
    (note,) = [n for n in doc["notes"] if n.startswith("copies of another channel")]
    assert "dup = s1" in note and "neg = -s2" in note and "kelvin = 1.8 s0 + 32" in note
    assert "copies of another channel" in (out / "report.html").read_text()


def test_a_copy_only_in_part_of_the_record_is_kept(tmp_path):
    """Twins that part later carry the fault that parts them: neither is a copy."""
    path = _record(tmp_path, late_fault=True)
    with ChannelStore.from_chunks(open_archive([path]).chunks(), tmp_path / "st") as store:
        copies = [c.channel for c in find_copies(store, store.select(None))]
    assert copies == ["kelvin", "neg"]


def test_named_copies_are_kept_and_refused_in_one_line(tmp_path, capsys):
    path = _record(tmp_path)
    out = tmp_path / "o"
    args = ["run", str(path), "--out", str(out), "--no-progress", "--channels", "s*,dup"]
    args += ["--detectors", "ar_kalman_bank"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "dup is a linear combination of the other channels" in err
    assert "--channels '!dup'" in err


def test_realdata_nav2_covariance_copy_is_left_out(realdata, tmp_path):
    """nav2_turtlebot.mcap: /amcl_pose's covariance [6] equals [1] (a symmetric matrix),
    and two quaternion components of /tf's second transform copy two others; the run was
    refused for a singular AR residual covariance. With a 40-s window (the default 20 %
    is too short for the detectors) it now runs, without the copies, on the odometry's
    27.6 Hz clock."""
    path = realdata / "mcap" / "evo" / "nav2_turtlebot.mcap"
    out = tmp_path / "o"
    args = ["run", str(path), "--out", str(out), "--no-progress", "--train", "0:40"]
    assert main(args) in (0, 1)
    doc = _findings(out)
    (note,) = [n for n in doc["notes"] if n.startswith("copies of another channel")]
    assert "/amcl_pose.pose.covariance[6] = /amcl_pose.pose.covariance[1]" in note
    assert doc["rate_hz"] == pytest.approx(27.63, abs=0.01)


def test_realdata_joints_that_all_copy_one_leave_one_channel(realdata, tmp_path, capsys):
    path = realdata / "ros1" / "plotjuggler" / "fake_joint_state.bag"
    assert main(["run", str(path), "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "one channel to analyze (/fake_joints_state.position[0])" in err
    assert "copies of another channel over the whole record not analyzed" in err


def test_find_copies_with_gaps_and_sparse_channels(tmp_path):
    """Gaps must sit at the same samples; a channel whose fingerprint rows are all gaps
    (two readings in 5 000 samples) is compared for equality, without a warning."""
    from analyzer.readers.base import ChannelChunk

    n = 5000
    t = np.arange(n, dtype=np.int64) * 10**7
    a = np.random.default_rng(0).standard_normal(n)
    a[::7] = np.nan
    other_gaps = a.copy()
    other_gaps[8] = np.nan
    sparse = np.full(n, np.nan)
    sparse[7], sparse[8] = 1.0, 2.0
    unlike = sparse.copy()
    unlike[8] = 3.0
    columns = {
        "a": a,
        "b": 3 * a - 1,
        "mirror": np.nanmin(a) + np.nanmax(a) - a,  # a's range: not a's equal, a's line
        "gaps": other_gaps,
        "sparse": sparse,
        "twin": sparse.copy(),
        "unlike": unlike,
    }
    chunks = [ChannelChunk(k, t, v) for k, v in columns.items()]
    with ChannelStore.from_chunks(chunks, tmp_path / "st") as store, warnings.catch_warnings():
        warnings.simplefilter("error")
        found = [(c.channel, c.relation) for c in find_copies(store, store.names)]
    assert [f[0] for f in found] == ["b", "mirror", "twin"]
    assert found[0][1] == "= 3 a - 1" and found[2][1] == "= sparse"
    assert found[1][1].startswith("= -1 a ")


def test_channels_flat_in_their_fingerprints_are_matched_by_their_sums(tmp_path, monkeypatch):
    """Channels of rare events on one level, none a copy: each is looked up among the
    earlier ones by its sums, not compared with every one of them (3000 such channels
    took 16 s pair by pair, the square of their number); a twin is still found."""
    from analyzer.readers.base import ChannelChunk
    from analyzer.store import copies

    compared = [0]

    class Counted(tuple):
        __hash__ = tuple.__hash__

        def __eq__(self, other):
            compared[0] += 1
            return tuple.__eq__(self, other)

    real = copies._sums
    monkeypatch.setattr(copies, "_sums", lambda store, info: Counted(real(store, info)))
    n, k = 2000, 200
    t = np.arange(n, dtype=np.int64) * 10**7
    columns = {}
    for c in range(k):
        v = np.zeros(n)
        v[1 + c] = 1.0  # (off the fingerprint's rows)
        columns[f"e{c:03d}"] = v
    columns["twin"] = columns["e007"].copy()
    chunks = [ChannelChunk(name, t, v) for name, v in columns.items()]
    with ChannelStore.from_chunks(chunks, tmp_path / "st") as store:
        found = find_copies(store, store.names)
    assert [(c.channel, c.of) for c in found] == [("twin", "e007")]
    assert compared[0] < 2 * k, compared[0]


def test_the_note_names_the_first_copies_and_counts_the_rest():
    """A record of 1000 copies made a note of 37 kB (the review): it names the first
    :data:`COPIES_LISTED` and counts the rest; its ``names`` keep every one."""
    from analyzer.selection import COPIES_LISTED, CopyNote
    from analyzer.store.copies import Copy

    copies = [Copy(f"c{k}", "a", 1.0, 0.0) for k in range(COPIES_LISTED + 5)]
    note = CopyNote(copies)
    assert "c0 = a" in note and f"c{COPIES_LISTED - 1} = a" in note
    assert f"c{COPIES_LISTED} " not in note and "and 5 more copies" in note
    assert len(note.names) == COPIES_LISTED + 5


def test_realdata_turtlesim_command_echo_is_no_copy(realdata, tmp_path, capsys):
    """example.bag (turtlesim): each turtle's pose velocity holds its last cmd_vel, but at
    62.5 Hz against the commands' 10 Hz or key repeats (and as float32), so it copies
    nothing sample by sample: only the colour sensors' g = 0.890909 r + 24.5273 are left
    out. Trained on 0-12 s the run is refused because the teleop's two components sum to
    2 on every complete row there (only the up and left keys were pressed), and the line
    now says so, with the relation, instead of "a linear combination" alone."""
    path = realdata / "ros1" / "rosbag.js" / "example.bag"
    with ChannelStore.from_chunks(open_archive([path]).chunks(), tmp_path / "st") as store:
        copies = [c.channel for c in find_copies(store, store.select(None))]
    assert copies == ["/turtle1/color_sensor.g", "/turtle2/color_sensor.g"]
    args = ["run", str(path), "--out", str(tmp_path / "o"), "--no-progress", "--train", "0:12"]
    assert main(args) == 2
    (line,) = [ln for ln in capsys.readouterr().err.splitlines() if "error:" in ln]
    # (the colour sensors' r and g, two whole numbers each, are left out as flags since
    # the fiftieth session: the line, longer, is cut and names the file that holds it)
    cut = re.search(r"the whole message: (.+)\]$", line)
    whole = Path(cut.group(1)).read_text(encoding="utf-8") if cut else line
    assert "/turtle1/cmd_vel.angular.z = -/turtle1/cmd_vel.linear.x + 2" in whole
    assert "--channels '!/turtle1/cmd_vel.angular.z'" in whole
