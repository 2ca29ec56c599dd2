"""Input checks shared by the innovation tests: the one place where bad input becomes a
:class:`~analyzer.errors.DetectorError` that quotes the bad value.

Non-finite samples (NaN gaps of the aligned archive, infinities) are dropped by the
order-free tests; :func:`as_series` and :func:`as_matrix` return the finite samples only,
so a result's ``n`` is the number of samples actually tested.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.stats import norm

from analyzer.errors import DetectorError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]

ALPHA = 0.05
"""Significance level of every test in :mod:`analyzer.stats` (the seed's 5 per cent)."""

Z_975 = float(norm.ppf(1.0 - ALPHA / 2.0))
"""Two-sided 5 % point of the standard normal, 1.95996... (the slides' "1.96")."""

NORMALITY_MIN_N = 8
"""Fewest samples for the Anderson-Darling and Cramer-von Mises tests; Stephens' (1974)
modified statistics are tabulated for n >= 5, 8 keeps a margin."""


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
