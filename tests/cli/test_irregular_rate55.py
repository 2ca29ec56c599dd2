"""``inspect``'s rate of a channel sampled at irregular times says which mean it is (the
robotics audit ux58 item 8: ``tilt_laser.bag``'s ``/imu_data``, 356 messages over
17.694 s, showed 21.52 Hz, which README called "its mean rate", while 356 messages over
its span are 20.06 Hz: its two pauses of 0.6 s are gaps, left out of ``rate_hz``).
``rate_hz`` stays the rate the alignment uses (the mean rate between the gaps);
``mean_rate_hz`` is the samples over the whole span, and README says both."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from cli_helpers import run_cli

from analyzer.writers import write_archive


def _bursty(path: Path) -> tuple[int, float, float]:
    """A CSV of two channels at exponential steps (mean 10 ms) with two pauses of 3 s:
    its samples, span (s) and the mean of its steps between the pauses (s)."""
    rng = np.random.default_rng(8)
    steps = rng.exponential(0.01, 2999)
    steps[[1000, 2000]] = 3.0
    t = np.concatenate(([0.0], np.cumsum(steps)))
    write_archive(
        path,
        "csv",
        np.round(t * 1e9).astype(np.int64),
        {"a": rng.normal(size=3000), "b": rng.normal(size=3000)},
    )
    kept = np.delete(steps, [1000, 2000])
    return 3000, float(t[-1]), float(kept.mean())


def test_irregular_rate_is_named_and_the_whole_span_mean_given(tmp_path, capsys):
    n, span, between = _bursty(tmp_path / "b.csv")
    code, out, _ = run_cli(["inspect", "--json", tmp_path / "b.csv"], capsys)
    assert code == 0
    (a, b) = json.loads(out)["channels"]
    assert a["irregular"] is True
    assert abs(a["mean_rate_hz"] - (n - 1) / span) < 1e-6
    assert abs(a["rate_hz"] - 1 / between) / a["rate_hz"] < 0.01  # between the gaps
    assert a["rate_hz"] > a["mean_rate_hz"] * 1.1
    code, out, _ = run_cli(["inspect", tmp_path / "b.csv"], capsys)
    legend = next(ln for ln in out.splitlines() if ln.startswith("* sampled at irregular"))
    assert "rate_hz is the mean rate between its gaps" in legend
    assert f"a {(n - 1) / span:.3f} Hz, b {(n - 1) / span:.3f} Hz" in legend


def test_a_regular_channel_has_no_mean_rate_key(tmp_path, capsys):
    t = np.arange(2000) * 10_000_000
    write_archive(tmp_path / "r.csv", "csv", t, {"a": np.random.default_rng(1).normal(size=2000)})
    code, out, _ = run_cli(["inspect", "--json", tmp_path / "r.csv"], capsys)
    assert code == 0 and "mean_rate_hz" not in json.loads(out)["channels"][0]


def test_readme_says_which_mean():
    readme = " ".join((Path(__file__).resolve().parents[2] / "README.md").read_text().split())
    assert (
        '"irregular": true` (sampled at irregular times: `rate_hz` is its mean rate)' not in readme
    )
    assert "`mean_rate_hz`" in readme
