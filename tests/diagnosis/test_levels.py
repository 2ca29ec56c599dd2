"""The response level of each analyzed channel over time against its training window's:
the report's map and the run's note naming where the channels' median level left the
training window's range (a load or structural change, which can look like one sensor's
fault)."""

from __future__ import annotations

import re

import numpy as np
import pytest

import analyzer.diagnosis.levels as lv
from analyzer.diagnosis.levels import LEVEL_CHANGE, Levels, binned_rms, level_note
from analyzer.pipeline import RunOptions, analyze, findings_document
from analyzer.report import render_report
from analyzer.simulate import simulate_building
from analyzer.writers import write_archive


@pytest.mark.parametrize(("n", "bins", "block"), [(103, 10, 7), (50, 50, 1 << 18), (10, 3, 4)])
def test_binned_rms_matches_direct_means(n, bins, block, monkeypatch):
    monkeypatch.setattr(lv, "RMS_ROWS", block)
    v = np.random.default_rng(1).normal(2.0, 3.0, (n, 3))
    v[v > 5.0] = np.nan
    v[: n // 3 + 1, 2] = np.nan  # a column with empty bins at the start
    center = np.array([2.0, 0.0, -1.0])
    got = binned_rms(v, bins, center)
    bins = min(bins, n)
    edges = (np.arange(bins + 1) * n) // bins
    with np.errstate(invalid="ignore"), pytest.warns(RuntimeWarning):
        want = np.array(
            [
                np.sqrt(np.nanmean((v[a:b] - center) ** 2, axis=0))
                for a, b in zip(edges[:-1], edges[1:], strict=True)
            ]
        )
    np.testing.assert_allclose(got, want)
    assert np.isnan(got[0, 2])


def test_binned_rms_reads_a_memmap(tmp_path):
    path = tmp_path / "v.npy"
    mm = np.lib.format.open_memmap(path, mode="w+", dtype=np.float64, shape=(10_000, 2))
    mm[:] = 1.0
    mm[5_000:, 1] = 4.0
    mm.flush()
    got = binned_rms(np.load(path, mmap_mode="r"), 4, [0.0, 1.0])
    np.testing.assert_allclose(got, [[1, 0], [1, 0], [1, 3], [1, 3]])


def _ratio(level_after: float, m: int = 6) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """60 bins of 10 s; the first 12 (training) vary 0.8-1.25x, the rest 1x, bins 36-39
    at ``level_after`` on every channel but one."""
    rng = np.random.default_rng(0)
    ratio = np.ones((60, m))
    ratio[:12] = rng.uniform(0.8, 1.25, (12, m))
    ratio[36:40, 1:] = level_after
    edges = np.arange(61) * 10.0
    train = np.zeros(60, dtype=bool)
    train[:12] = True
    return ratio, edges, train


def test_a_common_level_change_beyond_the_training_range_is_named():
    ratio, edges, train = _ratio(5.0)
    text = level_note(Levels(edges, ratio, train))
    assert "at 360.0-400.0 s (5x its training level)" in text, text
    assert "the load or the structure changed" in text
    # within LEVEL_CHANGE of the training window's range: not named
    high = float(np.max(np.median(ratio[:12], axis=1)))
    ratio, edges, train = _ratio(0.95 * LEVEL_CHANGE * high)
    assert level_note(Levels(edges, ratio, train)) == ""
    # a quiet night: under the lowest training level by as much
    ratio, edges, train = _ratio(0.1)
    assert "(0.1x its training level)" in level_note(Levels(edges, ratio, train))
    # without a training window of its own (a saved model), or with too few bins in it
    # to show the level's own spread: no sentence
    ratio, edges, train = _ratio(5.0)
    assert level_note(Levels(edges, ratio, None)) == ""
    train[5:] = False
    assert level_note(Levels(edges, ratio, train)) == ""


def _record(path, burst: float) -> str:
    t, y, _ = simulate_building(3, 360.0, 50.0, seed=3)  # 3 floors, 3 sensors
    rms = y[: int(0.25 * len(t))].std(axis=0)
    y[(t >= 200) & (t < 240)] *= burst  # the whole structure: a passing load
    y += np.random.default_rng(3).standard_normal(y.shape) * 0.05 * rms
    write_archive(
        path,
        "csv",
        np.round(t * 1e9).astype(np.int64),
        {f"s{i}": y[:, i] for i in range(y.shape[1])},
    )
    return str(path)


@pytest.mark.parametrize("burst", [1.0, 8.0])
def test_the_report_draws_the_level_map_and_names_a_burst(tmp_path, burst):
    analysis = analyze([_record(tmp_path / "r.csv", burst)], RunOptions(train="0:90"))
    html = render_report(analysis, findings_document(analysis))
    assert re.findall(r'<figure class="plot" data-kind="(\w+)">', html).count("levels") == 1
    start = html.index('data-kind="levels"')
    figure = html[start : html.index("</figure>", start)]
    assert "<image" in figure and "Response level over time." in figure
    said = [n for n in analysis.notes if "the load or the structure changed beyond" in n]
    assert len(said) == (burst > 1.0)
    if said:
        assert re.search(r"at 200\.0-240\.0 s \([\d.]+x its training level\)", said[0]), said
        assert said[0] in html.replace("&#39;", "'")  # among the report's notes
