"""Statistical tests of the standardized innovation (model-based sensor validation).

Seed 003 (IST Advanced Control Systems 2012/2013): under normal operation the innovation
of a Kalman filter, standardized with its covariance S^{-1/2}, is zero-mean, unit
variance, Gaussian white noise. Faults (bias, noisy instrument, changed dynamics,
interference) break one of these properties, and each test below checks one of them at
the 5 % level:

* :func:`shewhart` - outliers beyond +-k (limit checking);
* :func:`anderson_darling`, :func:`cramer_von_mises` - normality (Stephens cases 1, 2);
* :func:`whiteness` - autocorrelation band and Ljung-Box Q;
* :func:`mean_test`, :func:`covariance_test` - zero mean and unit covariance;
* :func:`standardize` - eta = S^{-1/2} e;
* :func:`windowed_tests` - all of them per window over a long residual, vectorized;
* :func:`test_segment`, :func:`summarize` - JSON-friendly evidence for findings.
"""

from analyzer.stats._checks import ALPHA
from analyzer.stats.moments import covariance_test, inverse_sqrt, mean_test, standardize
from analyzer.stats.normality import anderson_darling, cramer_von_mises
from analyzer.stats.outliers import shewhart
from analyzer.stats.results import (
    CovarianceResult,
    MeanResult,
    NormalityResult,
    ShewhartResult,
    StatResult,
    WhitenessResult,
)
from analyzer.stats.summary import run_all, summarize, test_segment
from analyzer.stats.whiteness import autocorrelation, whiteness
from analyzer.stats.windowed import WindowedTests, WindowStats, windowed_tests

__all__ = [
    "ALPHA",
    "CovarianceResult",
    "MeanResult",
    "NormalityResult",
    "ShewhartResult",
    "StatResult",
    "WhitenessResult",
    "WindowStats",
    "WindowedTests",
    "anderson_darling",
    "autocorrelation",
    "covariance_test",
    "cramer_von_mises",
    "inverse_sqrt",
    "mean_test",
    "run_all",
    "shewhart",
    "standardize",
    "summarize",
    "test_segment",
    "whiteness",
    "windowed_tests",
]
