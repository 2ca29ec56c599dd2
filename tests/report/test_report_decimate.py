"""Decimation, formatting and SVG helpers of the report, against direct computations."""

import re

import numpy as np
import pytest

import analyzer.report.decimate as dec
from analyzer.report import format as fmt
from analyzer.report.decimate import binned_nan_fraction, envelope, moving_mean, runs
from analyzer.report.svg import clean_svg, label, new_figure, style, to_svg


def _naive_envelope(y, max_points):
    per = -(-len(y) // max_points)
    lo, hi = [], []
    for a in range(0, len(y), per):
        seg = y[a : a + per]
        seg = seg[np.isfinite(seg)]
        lo.append(seg.min() if seg.size else np.nan)
        hi.append(seg.max() if seg.size else np.nan)
    return np.array(lo), np.array(hi)


@pytest.mark.parametrize("n", [1, 999, 1000, 1001, 12_345])
def test_envelope_matches_a_loop_over_bins(n, monkeypatch):
    monkeypatch.setattr(dec, "CHUNK_VALUES", 64)  # several chunks even on short input
    rng = np.random.default_rng(n)
    y = rng.standard_normal(n)
    y[n // 3 : n // 3 + 50] = np.nan  # a gap, some bins entirely NaN
    t = np.arange(n) / 100.0
    env = envelope(t, y, 100)
    if n <= 100:
        assert not env.decimated
        np.testing.assert_array_equal(env.lo, y)
        return
    lo, hi = _naive_envelope(y, 100)
    assert env.decimated and env.t.shape == lo.shape and len(env.t) <= 100
    np.testing.assert_array_equal(env.lo, lo)
    np.testing.assert_array_equal(env.hi, hi)
    assert np.all(np.diff(env.t) > 0) and env.t[0] >= t[0] and env.t[-1] <= t[-1]


@pytest.mark.parametrize("n", [1, 99, 100, 101, 12_345])
def test_envelope_of_a_clock_and_a_mapped_float32_signal_is_the_arrays_envelope(
    n, tmp_path, monkeypatch
):
    """A uniform clock (``dec.Clock``) and a float32 memory-mapped signal, read and
    converted a chunk at a time: the envelope of the float64 times and float64 copy of
    the signal, bit for bit, with no array as long as the signal made on the way."""
    from analyzer import paging

    monkeypatch.setattr(dec, "CHUNK_VALUES", 64)
    rng = np.random.default_rng(n)
    y = rng.standard_normal(n).astype(np.float32)
    y[n // 3 : n // 3 + 7] = np.nan
    mapped = paging.buffer(tmp_path, "y", (n, 1), np.float32)[:, 0]
    mapped[:] = y
    want = envelope(np.arange(n, dtype=np.float64) / 100.0, y.astype(np.float64), 100)
    made = []
    real_arange = np.arange
    monkeypatch.setattr(np, "arange", lambda *a, **k: made.append(real_arange(*a, **k)) or made[-1])
    got = envelope(dec.Clock(n, 100.0), mapped, 100)
    monkeypatch.setattr(np, "arange", real_arange)
    assert got.decimated == want.decimated
    for a, b in zip(got[:3], want[:3], strict=True):
        np.testing.assert_array_equal(a.view(np.uint64), b.view(np.uint64))
    if n > 100:
        assert max(len(m) for m in made) <= 100  # no arange of every sample


def test_envelope_keeps_a_single_sample_spike():
    y = np.zeros(1_000_000)
    y[654_321] = 7.0
    env = envelope(np.arange(y.size, dtype=float), y, 500)
    assert env.hi.max() == 7.0 and np.count_nonzero(env.hi) == 1 and len(env.t) <= 500


def test_envelope_errors():
    with pytest.raises(ValueError, match=r"same length, got shapes \(3,\) and \(2,\)"):
        envelope(np.arange(3.0), np.arange(2.0), 10)
    with pytest.raises(ValueError, match="max_points must be >= 1, got 0"):
        envelope(np.arange(3.0), np.arange(3.0), 0)


@pytest.mark.parametrize(
    ("n", "bins", "block"),
    [(103, 10, 7), (50, 50, 1 << 18), (10, 3, 4), (1000, 999, 64), (5, 20, 2)],
)
def test_binned_nan_fraction_matches_direct_means(n, bins, block, monkeypatch):
    monkeypatch.setattr(dec, "ROW_BLOCK", block)
    v = np.random.default_rng(0).random((n, 3))
    v[v > 0.7] = np.nan
    got = binned_nan_fraction(v, bins)
    bins = min(bins, n)
    edges = (np.arange(bins + 1) * n) // bins
    want = np.array(
        [np.isnan(v[a:b]).mean(axis=0) for a, b in zip(edges[:-1], edges[1:], strict=True)]
    )
    np.testing.assert_allclose(got, want)


def test_binned_nan_fraction_reads_a_memmap(tmp_path):
    path = tmp_path / "v.npy"
    mm = np.lib.format.open_memmap(path, mode="w+", dtype=np.float64, shape=(10_000, 2))
    mm[:] = 1.0
    mm[2_000:3_000, 1] = np.nan
    mm.flush()
    frac = binned_nan_fraction(np.load(path, mmap_mode="r"), 10)
    assert frac[:, 0].sum() == 0 and frac[2, 1] == 1.0 and frac[:, 1].sum() == 1.0
    with pytest.raises(ValueError, match=r"expected an \(N, m\) array, got shape \(4,\)"):
        binned_nan_fraction(np.zeros(4), 2)


def test_runs_and_moving_mean():
    assert runs([0, 1, 1, 0, 1]) == [(1, 3), (4, 5)]
    assert runs(np.zeros(3, dtype=bool)) == []
    x = np.array([1.0, 2.0, np.nan, 4.0, 5.0])
    np.testing.assert_allclose(moving_mean(x, 2), [1.0, 1.5, 2.0, 4.0, 4.5])
    np.testing.assert_allclose(moving_mean(np.arange(6.0), 3)[2:], [1, 2, 3, 4])


def test_formatting():
    assert fmt.num(None) == "n/a" and fmt.num(float("nan")) == "n/a"
    assert fmt.num(9.988431600954293) == "9.988" and fmt.num(0.0) == "0"
    assert fmt.seconds(16.0) == "16.000 s" and fmt.seconds(None) == "n/a"
    assert fmt.duration(59.995) == "59.995 s" and fmt.duration(86399) == "23 h 59 min 59 s"
    assert fmt.size(1_500_000) == "1.5 MB" and fmt.size(12) == "12 B"
    assert fmt.percent(0.98) == "98.0 %" and fmt.percent(0.99996) == "> 99.9 %"
    assert fmt.clock(34560.5) == "+09:36:00.500" and fmt.clock(None) == ""
    assert fmt.magnitude({"offset": -5.2}) == "offset -5.2"
    assert fmt.magnitude({"gain": 0.0}) == "gain ×0 (dead sensor)"
    assert fmt.magnitude({"rate_per_s": 0.5}) == "drift +0.5 per s"


def test_svg_is_inlinable_and_escaped():
    with style():
        fig = new_figure(3, 2)
        ax = fig.add_subplot()
        ax.plot([0, 1], [0, 1], label=label("<script>$x$</script>"))
        ax.legend()
        svg = str(to_svg(fig, "fig-1"))
    assert svg.startswith("<svg") and "http://www.w3.org/Graphics" not in svg
    assert "<metadata" not in svg and "<!DOCTYPE" not in svg
    assert "<script" not in svg and "&lt;script&gt;$x$&lt;/script&gt;" in svg
    assert 'viewBox="' in svg and not re.search(r'<svg[^>]*\swidth="', svg)
    ids = re.findall(r'\sid="([^"]+)"', svg)
    assert ids and all(i.startswith("fig-1-") for i in ids)
    refs = re.findall(r'(?:href="#|url\(#)([^")]+)', svg)
    assert refs and set(refs) <= set(ids)


def test_clean_svg_prefixes_references():
    raw = (
        '<?xml version="1.0"?>\n<!DOCTYPE svg>\n'
        '<svg width="10pt" height="5pt" viewBox="0 0 10 5">'
        '<metadata>http://x</metadata><defs><path id="m1" d="M 0.123456 1.98765 L 2 3"/></defs>'
        '<use xlink:href="#m1" x="1.23456" y="2"/><g clip-path="url(#p1)"/></svg>'
    )
    out = clean_svg(raw, "k")
    assert out.startswith('<svg viewBox="0 0 10 5">')
    assert 'id="k-m1"' in out and 'href="#k-m1"' in out and "url(#k-p1)" in out
    assert 'd="M 0.1 1.9 L 2 3"' in out and 'x="1.2"' in out


@pytest.mark.parametrize("block", [7, 1 << 18])
def test_binned_nan_fraction_counts_sparse_nans_and_infinities(block, monkeypatch):
    """Columns and blocks without NaN are skipped (a column sum is NaN only where a NaN
    or ``inf - inf`` is): the fractions stay those of the direct count."""
    monkeypatch.setattr(dec, "ROW_BLOCK", block)
    v = np.random.default_rng(1).random((500, 4))
    v[40:43, 1] = np.nan  # one short gap in one column
    v[400, 3] = np.nan
    v[100, 2], v[101, 2] = np.inf, -np.inf  # a NaN sum without a NaN sample
    v[200, 0] = np.inf
    got = binned_nan_fraction(v, 37)
    edges = (np.arange(38) * 500) // 37
    want = np.array(
        [np.isnan(v[a:b]).mean(axis=0) for a, b in zip(edges[:-1], edges[1:], strict=True)]
    )
    np.testing.assert_array_equal(got, want)
    assert got[:, 0].sum() == 0 and got[:, 2].sum() == 0 and np.count_nonzero(got[:, 1]) >= 1


def test_compact_path_matches_the_group_form():
    """The literal-replacement regex cuts every coordinate to one decimal exactly as the
    straightforward ``(\\d+\\.\\d)\\d+ -> \\1`` substitution does."""
    rng = np.random.default_rng(2)
    nums = [f"{x:f}".rstrip("0").rstrip(".") for x in rng.normal(0, 300, 400)]
    nums += ["0", "-0.5", "12.3", "7.05", "100", "-3.999999"]
    pairs = zip(nums[::2], nums[1::2], strict=True)
    d = " ".join(f"{'L' if i else 'M'} {a} {b}" for i, (a, b) in enumerate(pairs))
    raw = f'<svg viewBox="0 0 1 1"><path d="{d} z" /><text x="1.2345" y="-0.98">a</text></svg>'
    want_d = re.sub(r"(\d+\.\d)\d+", r"\1", d)
    out = clean_svg(raw, "k")
    assert f'd="{" ".join((want_d + " z").split())}"' in out
    assert 'x="1.2"' in out and 'y="-0.9"' in out


def test_durations_are_rounded_before_they_are_split():
    """599.99 s read "9 min 60.0 s" in the report."""
    from analyzer.report.format import duration

    assert duration(59.995) == "59.995 s"
    assert duration(599.99) == "10 min 0.0 s"
    assert duration(725.0) == "12 min 5.0 s"
    assert duration(3599.96) == "1 h 0 min 0 s"
    assert duration(86399.4) == "23 h 59 min 59 s"
    assert duration(86399.6) == "24 h 0 min 0 s"
