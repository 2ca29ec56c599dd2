"""The one-line error stays readable (the realdata audit: exit-2 lines of 1.7 kB, every
dependent channel named twice, in the reason and in the --channels advice, and once per
detector): lists name their first few items and count the rest, and detectors that fail
for the same reason share one entry. Short messages are unchanged."""

from __future__ import annotations

import numpy as np
import pytest
from cli_helpers import one_line_error, run_cli

from analyzer.detector_runs import skip_reasons
from analyzer.detectors.ar_model import fit_ar
from analyzer.errors import DetectorError, capped
from analyzer.simulate import simulate_building


def test_capped_lists_the_first_few_and_counts_the_rest():
    assert capped(["a", "b", "c"]) == "a, b, c"
    assert capped(list("abcdef")) == "a, b, c, d and 2 more"
    assert capped(list("abcdef"), 3, "; ", "input errors") == "a; b; c and 3 more input errors"


def test_detectors_failing_alike_share_one_entry():
    skipped = {
        "error_function": "needs [[group]] reference/uncertain sensors",
        "ar_kalman_bank (a..z)": "singular AR regression: x",
        "detection_filter (a..z)": "singular AR regression: x",
        "equivalent_model (a..z)": "too little healthy data",
    }
    assert skip_reasons(skipped) == [
        "error_function: needs [[group]] reference/uncertain sensors",
        "ar_kalman_bank, detection_filter (a..z): singular AR regression: x",
        "equivalent_model (a..z): too little healthy data",
    ]
    # different reasons stay apart
    skipped["detection_filter (a..z)"] = "singular AR regression: y"
    assert len(skip_reasons(skipped)) == 4


def _with_twins(n: int):
    """A 3-floor building and ``n`` copies of its s1 (``c0``...)."""
    t, y, names = simulate_building(3, 30.0, 50.0, seed=4)
    twins = np.repeat(y[:, 1:2], n, axis=1)
    return t, np.column_stack([y, twins]), [*names, *(f"c{k}" for k in range(n))]


def test_a_long_list_of_dependent_channels_is_cut():
    _, y, names = _with_twins(7)
    with pytest.raises(DetectorError) as err:
        fit_ar(y, 2, names)
    text = str(err.value)
    assert "c0, c1, c2, c3 and 3 more are linear combinations" in text
    assert "leave them out with --channels ('!c0,!c1,!c2,!c3' and 3 more)" in text
    _, y, names = _with_twins(2)
    with pytest.raises(DetectorError, match=r", c0 are linear combinations.*'!s1,!c0'$"):
        fit_ar(y, 2, names)


def test_the_error_of_named_twins_is_one_short_line(tmp_path, capsys):
    t, y, names = _with_twins(7)
    path = tmp_path / "t.csv"
    header = "time," + ",".join(names)
    np.savetxt(path, np.column_stack([t, y]), delimiter=",", header=header, comments="")
    args = ["run", path, "--out", tmp_path / "o", "--no-progress", "--channels", "s*,c*"]
    code, _, err = run_cli(args, capsys)
    assert code == 2
    line = one_line_error(err, "ar_kalman_bank, detection_filter: singular AR regression")
    assert line.count("c0, c1, c2, c3 and 3 more") == 1
    assert len(line) < 900


def test_realdata_named_joint_copies_make_a_short_line(realdata, tmp_path, capsys):
    """fake_joint_state.bag with its six equal joints named: 1 579 characters before."""
    path = realdata / "ros1" / "plotjuggler" / "fake_joint_state.bag"
    args = ["run", path, "--out", tmp_path / "o", "--no-progress", "--channels", "*position*"]
    code, _, err = run_cli(args, capsys)
    assert code == 2
    line = one_line_error(err, "are linear combinations", "and 1 more")
    assert len(line) < 1100
