"""A ``--channels`` pattern that matches no channel names the archive's channels (the
first four, ``and N more``) and, when channels hold the pattern inside their names, the
channel or the ``*PATTERN*`` that selects them: ``--channels s4`` said only "pattern 's4'
matches no channel" of an archive whose sensor is ``/s4.data``."""

from __future__ import annotations

import numpy as np
import pytest
from cli_helpers import one_line_error, run_cli

NAMES = ["floor1.acc", "floor2.acc", "floor3.acc", "floor4.acc", "floor5.acc", "wind.speed"]


@pytest.fixture
def archive(tmp_path):
    t = np.arange(200) / 10.0
    y = np.random.default_rng(0).standard_normal((t.size, len(NAMES)))
    path = tmp_path / "a.csv"
    np.savetxt(
        path, np.column_stack([t, y]), delimiter=",", header=",".join(["time", *NAMES]), comments=""
    )
    return path


LISTED = "the channels: floor1.acc, floor2.acc, floor3.acc, floor4.acc and 2 more)"


@pytest.mark.parametrize("command", ["run", "export"])
@pytest.mark.parametrize(
    "pattern, said",
    [
        ("wind", "pattern 'wind' matches no channel; did you mean wind.speed? ("),
        ("WIND*", "pattern 'WIND*' matches no channel; did you mean wind.speed? ("),
        (
            "acc",
            "pattern 'acc' matches no channel; did you mean '*acc*', which matches floor1.acc, "
            "floor2.acc, floor3.acc, floor4.acc and 1 more? (a pattern matches the whole name; ",
        ),
        ("!rain", "pattern '!rain' matches no channel ("),
    ],
)
def test_a_pattern_that_matches_nothing_names_the_channels(
    archive, tmp_path, capsys, command, pattern, said
):
    out = tmp_path / ("o" if command == "run" else "o.csv")
    code, _, err = run_cli([command, archive, "--out", out, "--channels", pattern], capsys)
    assert code == 2
    line = one_line_error(err, f"--channels: {said}")
    assert line.endswith(LISTED)
    assert not out.exists()
