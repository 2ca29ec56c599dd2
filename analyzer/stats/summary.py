"""JSON-friendly summaries of the innovation tests, for ``findings.json`` ``evidence.tests``.

Only plain floats, ints, bools, lists and ``None`` come out (NaN and infinities become
``None``), so the dicts go to :func:`json.dumps` as they are and the report templates
only display them.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from analyzer.stats._checks import ALPHA, as_series, binom_sf
from analyzer.stats.moments import covariance_test, mean_test
from analyzer.stats.normality import anderson_darling, cramer_von_mises
from analyzer.stats.outliers import expected_fraction, shewhart
from analyzer.stats.results import JsonValue, StatResult, json_float
from analyzer.stats.whiteness import whiteness
from analyzer.stats.windowed import WindowedTests


def summarize(
    results: Mapping[str, StatResult] | WindowedTests,
    *,
    reference: tuple[int, int] | None = None,
) -> dict[str, dict[str, JsonValue]]:
    """JSON-friendly summary of named test results or of a windowed run.

    * ``{name: StatResult}`` gives ``{name: result.as_dict()}``, e.g.
      ``{"anderson_darling": {"statistic": 0.41, "critical": 2.492, "reject": false,
      "pvalue": 0.84, "n": 1000, "case": 1, "raw": 0.41}, ...}``.
    * a :class:`~analyzer.stats.windowed.WindowedTests` gives, per test, how many of the
      valid windows reject (``rejected``, ``windows``, ``fraction``, against the 5 %
      expected by chance), the ``critical`` value and the largest ``max_statistic``,
      plus a ``"windows"`` entry with the window layout. ``reference=(lo, hi)`` (samples,
      a healthy stretch such as the training window): each test also gets the same
      count over the windows that lie inside it (``training_rejected``,
      ``training_windows``, ``training_fraction``), and the layout ``training_span``
      (``[lo, hi]``): what a healthy residual of this model rejects, the reference a
      residual that is not white or normal even when healthy is read against, rather
      than the nominal 5 %.
    """
    if isinstance(results, WindowedTests):
        return _summarize_windows(results, reference)
    return {name: result.as_dict() for name, result in results.items()}


def _summarize_windows(
    results: WindowedTests, reference: tuple[int, int] | None = None
) -> dict[str, dict[str, JsonValue]]:
    valid = results.valid
    n_valid = int(valid.sum())
    inside = None
    if reference is not None:
        # the windows wholly inside the healthy stretch (valid ones: a window holding a
        # gap is not tested), counted from the same per-window decisions, nothing rerun
        lo, hi = int(reference[0]), int(reference[1])
        inside = valid & (results.start >= lo) & (results.start + results.window <= hi)
        n_inside = int(inside.sum())
    out: dict[str, dict[str, JsonValue]] = {
        "windows": {
            "count": results.n_windows,
            "valid": n_valid,
            "window": results.window,
            "step": results.step,
            "lags": results.lags,
            "k": float(results.k),
            "case": results.case,
        }
    }
    for name, stats in results.tests().items():
        rejected = int(stats.reject[valid].sum())
        finite = stats.statistic[valid & np.isfinite(stats.statistic)]
        out[name] = {
            "rejected": rejected,
            "windows": n_valid,
            "fraction": json_float(rejected / n_valid) if n_valid else None,
            "expected": _expected(name, results),
            "critical": json_float(stats.critical),
            "max_statistic": json_float(finite.max()) if finite.size else None,
        }
        if stats.critical_low is not None:
            out[name]["critical_low"] = json_float(stats.critical_low)
        if inside is not None:
            held = int(stats.reject[inside].sum())
            out[name]["training_rejected"] = held
            out[name]["training_windows"] = n_inside
            out[name]["training_fraction"] = json_float(held / n_inside) if n_inside else None
    if reference is not None:
        out["windows"]["training_span"] = [int(reference[0]), int(reference[1])]
    return out


def _expected(name: str, results: WindowedTests) -> float:
    """The share of a healthy residual's windows test ``name`` rejects: its level, 5 %,
    except for the Shewhart chart, whose binomial test of a count cannot reach it: the
    chance of the first count whose p-value falls below 5 % or more (1.7 % for windows
    of 200 samples at k = 3)."""
    if name != "shewhart":
        return ALPHA
    counts = np.arange(results.window + 1)
    tail = binom_sf(counts - 1, results.window, expected_fraction(results.k))
    return json_float(tail[np.argmax(tail < ALPHA)]) or 0.0


def run_all(
    z: Any, *, lags: int | None = None, k: float = 3.0, case: int = 1
) -> dict[str, StatResult]:
    """Every test on a 1-D standardized residual segment, in the seed's order (outliers,
    normality, whiteness, then mean and covariance, which assume whiteness); ``lags``
    None: :func:`~analyzer.stats.whiteness.default_lags` of the segment."""
    segment = as_series(z, "z")
    return {
        "shewhart": shewhart(segment, k),
        "anderson_darling": anderson_darling(segment, case),
        "cramer_von_mises": cramer_von_mises(segment, case),
        "whiteness": whiteness(segment, lags),
        "mean": mean_test(segment),
        "covariance": covariance_test(segment),
    }


def test_segment(
    z: Any, *, lags: int | None = None, k: float = 3.0, case: int = 1
) -> dict[str, dict[str, JsonValue]]:
    """``summarize(run_all(z))``: the evidence dict of one segment of a standardized
    residual (e.g. before or after a fault onset). NaN samples are dropped; raises
    DetectorError when fewer than ``max(8, lags + 1)`` finite samples remain."""
    return summarize(run_all(z, lags=lags, k=k, case=case))


test_segment.__test__ = False  # type: ignore[attr-defined]  # not a pytest test
