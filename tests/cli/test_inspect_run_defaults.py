"""``inspect`` says what ``run`` analyzes by default (a new user's audit: it listed all
58 channels of a ROS 2 bag of which ``run`` analyzes 3, the others constant, and then
``run --channels`` naming constant ones failed): each channel marked with why ``run``
leaves it out, from ``run``'s own selection (:func:`analyzer.selection.select_channels`),
and the common clock's rate and the default training window ``run`` would use."""

from __future__ import annotations

import json

import numpy as np
import pytest

from analyzer.simulate import simulate_building
from tests.cli.cli_helpers import run_cli

RATE = 50.0


def _record(tmp_path, late_s=0.0):
    """A 4-floor building (s0..s3, 120 s at 50 Hz) with ``k`` constant, ``label`` a 0/1
    label, ``twice`` an exact linear copy of s1 and ``once`` a single value (blank cells
    around it); the building's channels and ``twice`` blank over their first ``late_s``
    seconds."""
    t, y, names = simulate_building(4, 120.0, RATE, seed=5)
    label = ((np.arange(t.size) * 10 // t.size) % 2).astype(float)
    cols = {n: y[:, j] for j, n in enumerate(names)}
    cols |= {"k": np.full(t.size, 3.5), "label": label, "twice": 2.0 * y[:, 1] + 1.0}
    cols["once"] = np.where(np.arange(t.size) == 7, 4.25, np.nan)
    late = t < late_s
    lines = ["time," + ",".join(cols)]
    for i in range(t.size):
        cells = [
            "" if (np.isnan(v[i]) or (late[i] and n in [*names, "twice"])) else repr(float(v[i]))
            for n, v in cols.items()
        ]
        lines.append(f"{float(t[i])!r}," + ",".join(cells))
    path = tmp_path / "r.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def _inspect(path, capsys, *extra):
    code, out, err = run_cli(["inspect", path, *extra], capsys)
    assert code == 0, err
    return out


def test_inspect_marks_what_run_leaves_out_as_run_does(tmp_path, capsys):
    path = _record(tmp_path)
    doc = json.loads(_inspect(path, capsys, "--json"))
    got = {c["name"]: (c["analyzed"], c.get("why"), c.get("copy_of")) for c in doc["channels"]}
    assert got == {
        "s0": (True, None, None),
        "s1": (True, None, None),
        "s2": (True, None, None),
        "s3": (True, None, None),
        "k": (False, "constant", None),
        "label": (False, "flag", None),
        "twice": (False, "copy", "s1"),
        "once": (False, "one sample", None),
    }
    # the contract's keys are all still there
    assert all(
        {"name", "samples", "start_s", "end_s", "rate_hz", "gaps"} <= set(c)
        for c in doc["channels"]
    )
    # and run analyzes exactly those
    out = tmp_path / "o"
    args = ["run", path, "--out", out, "--no-progress", "--detectors", "equivalent_model"]
    code, _, err = run_cli(args, capsys)
    assert code in (0, 1), err
    findings = json.loads((out / "findings.json").read_text())
    analyzed = {c["name"] for c in findings["channels"] if c["analyzed"]}
    assert analyzed == {c for c, (kept, _, _) in got.items() if kept}

    text = _inspect(path, capsys)
    rows = {ln.split()[0]: ln for ln in text.splitlines() if ln.split()[:1] in ([c] for c in got)}
    assert "[constant]" in rows["k"] and "[flag 0/1]" in rows["label"]
    assert "[copy of s1]" in rows["twice"] and "[one sample]" in rows["once"]
    assert "[" not in rows["s0"]
    assert (
        "left out by run by default: [constant] one value over the whole record; [one sample] "
        "a single value; [copy of X] equal to X on every sample, or an exact linear function "
        "of it (--channels naming it keeps it)"
    ) in text


def test_inspect_says_the_clock_and_training_window_run_uses(tmp_path, capsys):
    """The constant channel starts 10 s before the measurements: run's clock starts with
    the channels it analyzes, and its default window is 20 % of their span."""
    path = _record(tmp_path, late_s=10.0)
    doc = json.loads(_inspect(path, capsys, "--json"))
    defaults = doc["run_defaults"]
    assert defaults["channels"] == 4 and defaults["rate_hz"] == pytest.approx(RATE)
    assert defaults["clock_start_s"] == pytest.approx(10.0)
    # (the last sample at 119.98 s: 5500 rows of 20 ms from 10 s, 110 s)
    assert defaults["train"] == {"start_s": 0.0, "end_s": pytest.approx(22.0)}
    out = tmp_path / "o"
    args = ["run", path, "--out", out, "--no-progress", "--detectors", "equivalent_model"]
    code, _, err = run_cli(args, capsys)
    assert code in (0, 1), err
    findings = json.loads((out / "findings.json").read_text())
    assert findings["rate_hz"] == defaults["rate_hz"]
    assert findings["train"] == {"start_s": 0.0, "end_s": pytest.approx(22.0)}
    assert findings["duration_s"] == pytest.approx(110.0)
    text = _inspect(path, capsys)
    assert (
        "run by default: 4 of 8 channel(s) on a common clock of 50 Hz from 10.000 s (--rate), "
        "trained on 0-22 s of it (the first 20 %, at most 10 minutes: --train); at run time "
    ) in text
