"""The distribution functions of :mod:`analyzer.stats._checks` give scipy.stats' bits.

They evaluate the scipy.special functions scipy.stats wraps (to avoid importing
scipy.stats); these tests compare them with scipy.stats itself, bit for bit, over the
arguments the tests use and the support's edges (zero, negative, infinite, NaN)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_array_equal
from scipy import stats

import analyzer
from analyzer.diagnosis import changes
from analyzer.stats import _checks
from analyzer.stats._checks import (
    Z_975,
    binom_sf,
    chi2_cdf,
    chi2_ppf,
    chi2_sf,
    norm_ppf,
    norm_sf,
)

EDGES = np.array([-np.inf, -1.0, -0.0, 0.0, 1e-300, np.nan, np.inf])


def _same(ours: object, ref: object) -> None:
    """Equal bits (NaN where NaN), same shape and dtype; scalars stay scalars."""
    a, b = np.asarray(ours), np.asarray(ref)
    assert a.shape == b.shape and a.dtype == b.dtype
    assert np.isscalar(ours) == np.isscalar(ref)
    assert_array_equal(a.view(np.uint64), b.view(np.uint64))


def test_norm_sf_bits() -> None:
    x = np.concatenate([np.linspace(-40.0, 40.0, 20001), EDGES])
    _same(norm_sf(x), stats.norm.sf(x))
    for v in (0.0, 1.7, 3.0, 39.0, -2.5, np.inf, np.nan):
        _same(norm_sf(v), stats.norm.sf(v))
    _same(norm_sf(np.arange(-5, 6)), stats.norm.sf(np.arange(-5, 6)))


def test_norm_ppf_bits() -> None:
    q = np.concatenate([np.linspace(0.0, 1.0, 20001), [1e-300, 1 - 1e-16, -0.5, 1.5, np.nan]])
    _same(norm_ppf(q), stats.norm.ppf(q))
    _same(norm_ppf(0.975), stats.norm.ppf(0.975))
    assert float(stats.norm.ppf(0.975)) == Z_975


@pytest.mark.parametrize("df", [1, 2, 3, 10, 20, 50, 100, 500, 3000])
def test_chi2_bits(df: int) -> None:
    x = np.concatenate([np.linspace(0.0, 8.0 * df + 50.0, 20001), EDGES, [df - 1e-9, df]])
    _same(chi2_sf(x, df), stats.chi2.sf(x, df))
    _same(chi2_cdf(x, df), stats.chi2.cdf(x, df))
    q = np.concatenate([np.linspace(0.0, 1.0, 2001), [0.025, 0.975, 0.95, 0.4, 0.6, np.nan]])
    _same(chi2_ppf(q, df), stats.chi2.ppf(q, df))
    for v in (0.0, 0.5 * df, float(df), 3.0 * df, np.nan):
        _same(chi2_sf(v, df), stats.chi2.sf(v, df))
        _same(chi2_cdf(v, df), stats.chi2.cdf(v, df))
    for p in (0.025, 0.95, 0.975):
        _same(chi2_ppf(p, df), stats.chi2.ppf(p, df))
    _same(chi2_ppf([0.4, 0.6], df), stats.chi2.ppf([0.4, 0.6], df))


def test_chi2_invalid_df() -> None:
    for df in (0, -1):
        _same(chi2_sf(np.array([1.0, 2.0]), df), stats.chi2.sf(np.array([1.0, 2.0]), df))
        _same(chi2_cdf(1.0, df), stats.chi2.cdf(1.0, df))
        _same(chi2_ppf(0.5, df), stats.chi2.ppf(0.5, df))


@pytest.mark.parametrize("n", [1, 5, 50, 200, 1000, 3000])
@pytest.mark.parametrize("p", [0.0, 0.0027, 0.0455, 0.3, 1.0])
def test_binom_sf_bits(n: int, p: float) -> None:
    k = np.arange(-3, n + 3)
    _same(binom_sf(k - 1, n, p), stats.binom.sf(k - 1, n, p))
    kf = np.concatenate([k + 0.5, [np.nan, np.inf, -np.inf]])
    _same(binom_sf(kf, n, p), stats.binom.sf(kf, n, p))
    for c in (-1, 0, 1, n // 2, n - 1, n):
        _same(binom_sf(c, n, p), stats.binom.sf(c, n, p))


def test_binom_sf_invalid() -> None:
    for n, p in ((-1, 0.5), (2.5, 0.5), (10, -0.1), (10, 1.5)):
        _same(binom_sf(np.arange(-1, 4), n, p), stats.binom.sf(np.arange(-1, 4), n, p))


def test_binom_sf_without_the_private_ufunc(monkeypatch: pytest.MonkeyPatch) -> None:
    """A scipy without ``special._ufuncs._binom_sf`` gets ``scipy.stats.binom.sf``."""
    monkeypatch.setattr(_checks, "_BINOM_SF", None)
    k = np.concatenate([np.arange(-2.0, 23.0), [2.5, np.nan, np.inf]])
    _same(binom_sf(k, 20, 0.0455), stats.binom.sf(k, 20, 0.0455))
    _same(binom_sf(3, 20, 0.3), stats.binom.sf(3, 20, 0.3))


def test_changes_tail_is_norm_sf() -> None:
    """The change detector's peak tail (``special.ndtr(-z)``) is scipy's ``norm.sf(z)``."""
    z = np.linspace(-10.0, 40.0, 5001)
    _same(changes.special.ndtr(-z), stats.norm.sf(z))


def test_the_pipeline_does_not_import_scipy_stats() -> None:
    """Importing the pipeline (what every run does first) leaves scipy.stats out: about
    0.6-0.8 s of start-up (a whole default run leaves out scipy.signal and scipy.stats
    too: tests/cli/test_cli_imports.py). In a fresh interpreter."""
    code = (
        "import sys\n"
        "from analyzer import pipeline\n"
        "assert 'scipy.stats' not in sys.modules\n"
        "assert 'scipy.signal' not in sys.modules\n"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(analyzer.__file__).parent.parent)}
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )
    assert done.returncode == 0, done.stderr
