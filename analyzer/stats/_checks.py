"""Input checks shared by the innovation tests: the one place where bad input becomes a
:class:`~analyzer.errors.DetectorError` that quotes the bad value.

Non-finite samples (NaN gaps of the aligned archive, infinities) are dropped by the
order-free tests; :func:`as_series` and :func:`as_matrix` return the finite samples only,
so a result's ``n`` is the number of samples actually tested.

It also holds the few distribution functions the tests need (normal, chi-square and
binomial tails and quantiles), written as the :mod:`scipy.special` functions that
``scipy.stats``' distributions evaluate, with the same handling of the support's edges
and of NaN: the same bits, without importing ``scipy.stats`` (~0.6 s at start-up) or
its per-call argument handling (tests/stats/test_stats_distributions.py compares them).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import special

try:  # the Boost binomial tail scipy.stats.binom.sf evaluates: a private ufunc
    from scipy.special import _ufuncs as _scu
except ImportError:  # pragma: no cover - depends on the scipy version
    _scu = None

from analyzer.errors import DetectorError

FloatArray = npt.NDArray[np.float64]
_BINOM_SF: Any = getattr(_scu, "_binom_sf", None)
"""``scipy.special._ufuncs._binom_sf`` where this scipy has it; :func:`binom_sf` falls back
to ``scipy.stats.binom.sf`` (imported on first use) where not."""
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]

ALPHA = 0.05
"""Significance level of every test in :mod:`analyzer.stats` (the seed's 5 per cent)."""


def norm_sf(x: Any) -> Any:
    """``scipy.stats.norm.sf(x)``: ``Phi(-x)`` (1 at -inf, 0 at +inf, NaN at NaN)."""
    return special.ndtr(-np.asarray(x, dtype=np.float64))[()]


def norm_ppf(q: Any) -> Any:
    """``scipy.stats.norm.ppf(q)``: the standard normal quantile (``ndtri``; NaN outside
    [0, 1], as the distribution's)."""
    q = np.asarray(q, dtype=np.float64)
    out = np.where((q >= 0.0) & (q <= 1.0), special.ndtri(q), np.nan) + 0.0
    return out[()]


def _chi2_args(x: Any, df: Any) -> tuple[FloatArray, FloatArray, BoolArray]:
    x = np.asarray(x, dtype=np.float64)
    dfa = np.asarray(df, dtype=np.float64)
    inside = (x > 0.0) & (x < np.inf) & (dfa > 0.0)
    return x, dfa, inside


def chi2_sf(x: Any, df: Any) -> Any:
    """``scipy.stats.chi2.sf(x, df)``: ``chdtrc(df, x)`` inside the support, 1 at or below
    zero, 0 at +inf, NaN at NaN or ``df <= 0``."""
    x, dfa, inside = _chi2_args(x, df)
    edge = np.where(x <= 0.0, 1.0, 0.0)
    out = np.where(inside, special.chdtrc(dfa, np.where(inside, x, 1.0)), edge)
    out = np.where(np.isnan(x) | ~(dfa > 0.0), np.nan, out)
    return out[()]


def chi2_cdf(x: Any, df: Any) -> Any:
    """``scipy.stats.chi2.cdf(x, df)``: ``chdtr(df, x)`` inside the support, 0 at or below
    zero, 1 at +inf, NaN at NaN or ``df <= 0``."""
    x, dfa, inside = _chi2_args(x, df)
    edge = np.where(x == np.inf, 1.0, 0.0)
    out = np.where(inside, special.chdtr(dfa, np.where(inside, x, 1.0)), edge)
    out = np.where(np.isnan(x) | ~(dfa > 0.0), np.nan, out)
    return out[()]


def chi2_ppf(q: Any, df: Any) -> Any:
    """``scipy.stats.chi2.ppf(q, df)``: ``2 gammaincinv(df / 2, q)`` for 0 < q < 1, 0 at
    q = 0, +inf at q = 1, NaN otherwise."""
    q = np.asarray(q, dtype=np.float64)
    dfa = np.asarray(df, dtype=np.float64)
    inside = (q > 0.0) & (q < 1.0) & (dfa > 0.0)
    edge = np.where(q == 0.0, 0.0, np.where(q == 1.0, np.inf, np.nan))
    edge = np.where(dfa > 0.0, edge, np.nan)
    out = np.where(inside, 2 * special.gammaincinv(dfa / 2, np.where(inside, q, 0.5)), edge)
    return out[()]


def binom_sf(k: Any, n: Any, p: Any) -> Any:
    """``scipy.stats.binom.sf(k, n, p)`` = P(X > k): the same Boost ufunc, 1 for
    ``k < 0``, 0 for ``k >= n``, NaN for NaN ``k`` or invalid ``n``, ``p``. A scipy
    without the private ufunc gets ``scipy.stats.binom.sf`` itself."""
    if _BINOM_SF is None:
        from scipy.stats import binom  # (import: ~0.6 s)

        return binom.sf(k, n, p)
    k = np.asarray(k, dtype=np.float64)
    na = np.asarray(n, dtype=np.float64)
    pa = np.asarray(p, dtype=np.float64)
    valid = (na >= 0) & (na == np.floor(na)) & (pa >= 0) & (pa <= 1)
    inside = valid & (k >= 0) & (k < na) & np.isfinite(k)
    kk = np.floor(np.where(inside, k, 0.0))
    tail = np.clip(_BINOM_SF(kk, na, pa), 0, 1)
    edge = np.where(valid & (k < 0), 1.0, 0.0)
    out = np.where(inside, tail, edge)
    out = np.where(~valid | np.isnan(k), np.nan, out)
    return out[()]


Z_975 = float(norm_ppf(1.0 - ALPHA / 2.0))
"""Two-sided 5 % point of the standard normal, 1.95996... (the slides' "1.96")."""

NORMALITY_MIN_N = 8
"""Fewest samples for the Anderson-Darling and Cramer-von Mises tests; Stephens' (1974)
modified statistics are tabulated for n >= 5, 8 keeps a margin."""


def standardize(x: Any, mean: float, std: float) -> FloatArray:
    """``(x - mean) / std`` as a new float64 array, in two operations per sample (the
    subtraction computed in float64 whatever ``x``'s precision): the one form every
    caller uses, so a residual standardized whole or a piece at a time gives the same
    bits."""
    out: FloatArray = np.subtract(x, mean, dtype=np.float64)
    out /= std
    return out


def as_float_array(x: Any, name: str) -> FloatArray:
    """``x`` as a float64 array, or a DetectorError naming what could not be converted."""
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise DetectorError(
            f"expected numeric samples for {name}, got {type(x).__name__}: {err}"
        ) from err
    return arr


def as_series(x: Any, name: str, min_n: int = 1) -> FloatArray:
    """The finite samples of a 1-D standardized innovation ``x`` (NaN and inf dropped).

    Raises DetectorError when ``x`` is not 1-D, holds no finite sample, or holds fewer
    than ``min_n`` finite samples.
    """
    arr = as_float_array(x, name)
    if arr.ndim != 1:
        raise DetectorError(
            f"expected a 1-D standardized innovation for {name}, got shape {arr.shape}"
        )
    return _finite(arr, arr[np.isfinite(arr)], name, min_n)


def as_matrix(x: Any, name: str, min_n: int = 1) -> FloatArray:
    """The finite rows of an (N, r) innovation matrix; a 1-D ``x`` is read as (N, 1).

    Rows with any non-finite component are dropped. Raises DetectorError when ``x`` is
    not 1-D or 2-D, has no column, or keeps fewer than ``min_n`` finite rows.
    """
    arr = as_float_array(x, name)
    if arr.ndim == 1:
        arr = arr[:, np.newaxis]
    if arr.ndim != 2 or arr.shape[1] == 0:
        raise DetectorError(
            f"expected an (N,) or (N, r) innovation matrix for {name}, got shape {arr.shape}"
        )
    finite_rows = arr[np.isfinite(arr).all(axis=1)]
    return _finite(arr, finite_rows, name, min_n)


def _finite(arr: FloatArray, finite: FloatArray, name: str, min_n: int) -> FloatArray:
    if arr.size == 0:
        raise DetectorError(f"{name} is empty (shape {arr.shape}); expected samples")
    if finite.shape[0] == 0:
        raise DetectorError(
            f"all {arr.size} values of {name} are NaN or infinite; expected finite samples"
        )
    if finite.shape[0] < min_n:
        raise DetectorError(f"{name} needs at least {min_n} finite samples, got {finite.shape[0]}")
    return finite


def check_positive(value: float, name: str) -> float:
    """``value`` as a float if it is finite and > 0, else a DetectorError quoting it."""
    try:
        out = float(value)
    except (TypeError, ValueError) as err:
        raise DetectorError(f"expected a number for {name}, got {value!r}") from err
    if not np.isfinite(out) or out <= 0.0:
        raise DetectorError(f"expected a finite {name} > 0, got {value!r}")
    return out


def check_int(value: int, name: str, minimum: int) -> int:
    """``value`` as an int if it is an integer >= ``minimum``, else a DetectorError."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise DetectorError(f"expected an integer {name}, got {value!r}")
    if value < minimum:
        raise DetectorError(f"expected {name} >= {minimum}, got {value}")
    return int(value)


def check_case(case: int) -> int:
    """The Stephens case of a normality test: 1 (known mean 0, variance 1) or 2 (estimated)."""
    if isinstance(case, bool) or case not in (1, 2):
        raise DetectorError(
            f"expected case 1 (known mean and variance) or 2 (estimated), got {case!r}"
        )
    return int(case)


def frozen(a: npt.NDArray[Any]) -> npt.NDArray[Any]:
    """``a`` made read-only, so result objects stay values."""
    a.flags.writeable = False
    return a
