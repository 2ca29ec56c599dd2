"""A record with one channel to analyze is refused for that, not for its training window
(the realdata audit: NAB's one-column files were told to give a longer --train, and with
one the detectors then said they need 2 channels)."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.cli import main


@pytest.mark.parametrize("rows", [40, 5000])
def test_one_channel_is_refused_as_one_channel(tmp_path, capsys, rows):
    path = tmp_path / "one.csv"
    t = np.arange(rows) / 10.0
    y = np.random.default_rng(0).standard_normal(rows)
    np.savetxt(path, np.column_stack([t, y]), delimiter=",", header="time,value", comments="")
    assert main(["run", str(path), "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "one channel to analyze (value)" in err and "--train" not in err
    assert err.count("\n") == 1


def test_the_constant_channels_left_out_are_named_with_it(tmp_path, capsys):
    path = tmp_path / "flat.csv"
    t = np.arange(2000) / 10.0
    y = np.random.default_rng(0).standard_normal(2000)
    flat = np.column_stack([t, y] + [np.full(2000, k) for k in range(7)])
    header = "time,value," + ",".join(f"c{k}" for k in range(7))
    np.savetxt(path, flat, delimiter=",", header=header, comments="")
    assert main(["run", str(path), "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "one channel to analyze (value)" in err
    assert "constant or empty channels not analyzed: c0, c1, c2, c3, c4, ... (7)" in err


def test_a_constant_channel_whose_name_holds_a_comma_is_named_whole(tmp_path, capsys):
    path = tmp_path / "comma.csv"
    t = np.arange(2000) / 10.0
    y = np.random.default_rng(1).standard_normal(2000)
    flat = ",".join(["20.0"] * 6)
    header = 'time,value,"Temp, C",' + ",".join(f"c{k}" for k in range(1, 6))
    lines = [header] + [f"{a},{b},{flat}" for a, b in zip(t, y, strict=True)]
    path.write_text("\n".join(lines) + "\n")
    assert main(["run", str(path), "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "constant or empty channels not analyzed: Temp, C, c1, c2, c3, c4, ... (6)\n" in err
