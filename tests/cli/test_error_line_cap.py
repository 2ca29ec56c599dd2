"""The exit-2 line has a length limit (the realdata audit: ``tilt_laser.bag`` refused in
1.1 kB: four detectors' reasons, the error function's wish for a ``[[group]]`` first, and
the hint that fixes the run, ``--rate 43.2``, last). The line now puts the hint first and
reasons a config answers last, and is cut at :data:`~analyzer.errors.LINE_MOST`
characters after the file it names."""

from __future__ import annotations

import numpy as np
from cli_helpers import one_line_error, run_cli

from analyzer.errors import LINE_MOST, clipped_line
from analyzer.simulate import simulate_building


def test_clipped_line_cuts_at_a_clause_and_closes_what_it_opened():
    assert clipped_line("short; line") == "short; line"
    text = "f.csv: refused (" + "; ".join(f"reason {k} " + "x" * 40 for k in range(30)) + ")"
    cut = clipped_line(text, 200)
    assert len(cut) <= 200
    assert cut.startswith("f.csv: refused (reason 0 ")
    assert cut.endswith(f" ...) [{len(text):,} characters in all]")
    head = cut.removesuffix(f" ...) [{len(text):,} characters in all]")
    assert head.endswith("x" * 40)  # a whole reason: cut at "; ", not inside one
    assert cut.count("(") == cut.count(")")
    # no boundary at all: cut where the room ends
    assert len(clipped_line("y" * 1000, 100)) <= 100


def _save(path, t, columns, names):
    header = "time," + ",".join(names)
    np.savetxt(
        path, np.column_stack([t, columns]), delimiter=",", header=header, comments="", fmt="%.17g"
    )
    return path


def test_a_long_refusal_is_cut_with_the_hint_first(tmp_path, capsys):
    """Fast channels with long names beside slow ones: the clock runs at the slow
    channels' rate and the window is too short for every detector; the line's reasons
    and lists ran past 800 characters."""
    t, y, _ = simulate_building(2, 120.0, 100.0, seed=1, sensors_per_floor=2)
    slow = np.full((t.size, 8), np.nan)
    slow[::20] = np.random.default_rng(0).standard_normal((t[::20].size, 8)).cumsum(axis=0)
    fast = [
        f"/a/rather/long/topic/name/of/an/accelerometer_{k}.linear_acceleration.x" for k in range(4)
    ]
    names = [*fast, *(f"/slow/topic/with/a/long/name/c{k}.data" for k in range(8))]
    path = _save(tmp_path / "s.csv", t, np.column_stack([y, slow]), names)
    code, _, err = run_cli(["run", path, "--out", tmp_path / "o", "--no-progress"], capsys)
    assert code == 2
    line = one_line_error(err, str(path), "--rate 100")
    assert len(line) <= len("analyzer: error: ") + LINE_MOST
    # (120 s at the slow 5 Hz clock are too short for any window: the line says so)
    assert line.startswith(f"analyzer: error: {path}: no detector could run: the archive's ")
    # the error function's wish for a config comes after the reasons the data answer
    if "needs [[group]]" in line:
        assert line.index("needs [[group]]") > line.index("too little healthy data")


def test_realdata_tilt_laser_line(realdata, tmp_path, capsys):
    path = realdata / "ros1" / "plotjuggler" / "tilt_laser.bag"
    code, _, err = run_cli(["run", path, "--out", tmp_path / "o", "--no-progress"], capsys)
    assert code == 2
    # (17.7 s at the common 21.5 Hz are too short for any window: the faster clock is the
    # fix; the laser's beams, long arrays, no longer set the clock to 10 Hz: ros55a)
    archive = "the archive's 17.702 s at 21.5 Hz are too short for these detectors, which need"
    line = one_line_error(err, str(path), archive, "--rate 43.2")
    assert len(line) <= len("analyzer: error: ") + LINE_MOST


def test_the_refusal_orders_its_parts_by_use():
    """The hint first, reasons a config answers last; a singular regression before a
    gappy-channel hint (its dependence is the cause: turtlesim ``example.bag`` trained on
    0-12 s, whose cmd_vel misses 43 % of the window and whose two components sum to 2)."""
    from analyzer.pipeline import RunOptions, _no_detector_error

    wish = "needs [[group]] reference/uncertain sensors in the config"
    gappy = "; channels with samples missing in the training window (s2 20 %)"
    short = {"error_function": wish, "ar_kalman_bank": "too little healthy data: 9 rows"}
    text = str(_no_detector_error(short, (0.0, 1.0), RunOptions()))
    assert text.startswith("no detector could run: the training window 0.000-1.000 s")
    assert text.index("too little healthy data: 9 rows") < text.index(wish)
    text = str(_no_detector_error(short, (0.0, 1.0), RunOptions(), gappy))
    assert text.startswith("no detector could run: channels with samples missing")
    singular = {"error_function": wish, "ar_kalman_bank": "singular AR regression: x = -y + 2"}
    text = str(_no_detector_error(singular, (0.0, 1.0), RunOptions(), gappy))
    assert text.startswith("no detector could run (ar_kalman_bank: singular AR regression")
    assert text.endswith(gappy)


def test_the_cut_keeps_the_file_it_names_whatever_its_length():
    path = "/data/" + "/".join(["a rather long folder name"] * 30) + "/rec.mcap"
    text = f"{path}: " + "; ".join(f"reason {k} " + "x" * 30 for k in range(40))
    cut = clipped_line(text, keep=len(path))
    assert cut.startswith(f"{path}: reason 0 ") and len(cut) < len(text)
    # a cut that would not shorten the line leaves it whole
    assert clipped_line("y" * 700, keep=690) == "y" * 700


def test_a_long_refusal_of_a_deep_file_names_it(tmp_path, capsys):
    """A path longer than the line's limit (folders of 200 characters): the cut was made
    inside it, and the line named no file (the contract: it names the file)."""
    t, y, _ = simulate_building(2, 120.0, 100.0, seed=1, sensors_per_floor=2)
    slow = np.full((t.size, 8), np.nan)
    slow[::20] = np.random.default_rng(0).standard_normal((t[::20].size, 8)).cumsum(axis=0)
    names = [*(f"fast_{k}" for k in range(4)), *(f"slow_{k}" for k in range(8))]
    deep = tmp_path / ("d" * 200) / ("e" * 200) / ("f" * 200)
    deep.mkdir(parents=True)
    path = _save(deep / "s.csv", t, np.column_stack([y, slow]), names)
    code, _, err = run_cli(["run", path, "--out", tmp_path / "o", "--no-progress"], capsys)
    assert code == 2
    line = one_line_error(err, str(path), "no detector could run")
    assert "characters in all; the whole message: " in line
