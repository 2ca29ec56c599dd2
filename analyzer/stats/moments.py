"""Standardization of the innovation and the tests of its mean and covariance.

Seed 003 (IST Advanced Control Systems 2012/2013):

* "LDS - Statistics of the innovation sequence": the innovation r(t+1) = z(t+1) -
  C x(t+1|t) of a Kalman filter is zero-mean Gaussian white noise with covariance
  S(t+1) = C Sigma(t+1|t) C^T + Theta(t+1); the standardized innovation
  eta(t+1) = S(t+1)^{-1/2} r(t+1) has covariance I.
* "Tests of mean": the sample mean of eta is N(0, I/N) under the null, so a component is
  rejected at 5 % when |mean| > 1.96 / sqrt(N).
* "Tests of covariance": trace(N C0) with C0 = (1/N) sum eta eta^T is chi-square. The
  slides estimate C0 around the sample mean ((N - 1) r degrees of freedom); here the
  mean is known to be 0 under the null, so C0 is taken about 0 and trace(N C0) =
  sum of all squared entries is chi-square with N r degrees of freedom.

Both tests assume a white innovation: test whiteness first (the slides stop the test
sequence when whiteness is rejected). Where whiteness is rejected, the variance of
sqrt(N) mean is not the variance of one sample but the series' long-run variance (its
spectral density at frequency zero): :func:`long_run_mean_test` holds the mean against
a Newey-West (Bartlett) estimate of it, over the lags the whiteness test looked at.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from analyzer.errors import DetectorError
from analyzer.stats._checks import (
    ALPHA,
    Z_975,
    FloatArray,
    as_float_array,
    as_matrix,
    chi2_cdf,
    chi2_ppf,
    chi2_sf,
    frozen,
    norm_sf,
)
from analyzer.stats.results import CovarianceResult, LongRunMeanResult, MeanResult


def mean_test(x: Any) -> MeanResult:
    """Zero-mean test of a standardized innovation, 1-D or (N, r) (rows with NaN dropped).

    Per component j: ``z_j = sqrt(N) mean_j``, rejected when ``|z_j| > 1.96``
    (equivalently ``|mean_j| > 1.96 / sqrt(N)``), two-sided ``p_j = 2 (1 - Phi(|z_j|))``.
    ``reject`` is any component; for r > 1 the family-wise level is 1 - 0.95^r.
    Seed 003, "Tests of mean".
    """
    eta = as_matrix(x, "x")
    n = eta.shape[0]
    mean = eta.mean(axis=0)
    z = np.sqrt(n) * mean
    per_component = np.abs(z) > Z_975
    worst = float(np.max(np.abs(z)))
    return MeanResult(
        statistic=worst,
        critical=Z_975,
        reject=bool(per_component.any()),
        pvalue=float(2.0 * norm_sf(worst)),
        n=n,
        mean=frozen(mean),
        z=frozen(z),
        per_component=frozen(per_component),
    )


def long_run_variance(x: FloatArray, lags: int) -> float:
    """Newey-West estimate of the long-run variance of a 1-D series (finite samples):
    ``g_0 + 2 sum_{k=1}^{L} (1 - k / (L + 1)) g_k`` with ``g_k = sum_t d_t d_{t-k} / N``
    the autocovariances about the sample mean (``d = x - mean``) and ``L = lags`` (the
    Bartlett weights keep it positive). For a white series it is the variance; for a
    correlated one, ``N`` times the variance of its mean (Newey and West 1987; the
    estimator of ``statsmodels``' HAC covariance with ``use_correction=False``)."""
    d = x - float(np.mean(x))
    n = d.shape[0]
    top = max(0, min(int(lags), n - 1))
    acov = np.array([float(d[k:] @ d[: n - k]) for k in range(top + 1)]) / n
    return bartlett_sum(acov)


def bartlett_sum(acov: FloatArray) -> float:
    """``a_0 + 2 sum_{k=1}^{L} (1 - k / (L + 1)) a_k`` of the lagged sums or
    autocovariances ``a_0 .. a_L``: the Newey-West (Bartlett-weighted) long-run sum that
    :func:`long_run_variance` takes of a series' autocovariances, and
    :mod:`analyzer.diagnosis.spread` of a fit's score products (its HAC variance)."""
    top = acov.shape[0] - 1
    weights = 1.0 - np.arange(1, top + 1) / (top + 1.0)
    return float(acov[0] + 2.0 * np.sum(weights * acov[1:]))


def long_run_mean_test(x: Any, lags: int) -> LongRunMeanResult:
    """Zero-mean test of a 1-D standardized innovation that need not be white (NaN
    dropped): ``t = sqrt(N) |mean| / sqrt(V)`` with ``V`` the :func:`long_run_variance`
    over ``lags`` lags (the whiteness test's), rejected when ``t > 1.96``, two-sided
    ``p = 2 (1 - Phi(t))``. ``V`` is taken about the stretch's own mean, so a spread
    larger than the healthy one (a gain) widens the bound as the correlation does.
    This is the test :func:`analyzer.diagnosis.evidence.consistent_types` reads where the
    whiteness test rejected (seed 003: the mean test assumes whiteness)."""
    arr = as_float_array(x, "x")
    if arr.ndim != 1:
        raise DetectorError(f"expected a 1-D standardized innovation for x, got shape {arr.shape}")
    y = arr[np.isfinite(arr)]
    if y.shape[0] < 2:
        raise DetectorError(f"the long-run mean test needs 2 finite samples, got {y.shape[0]}")
    n = y.shape[0]
    variance = long_run_variance(y, lags)
    mean = float(np.mean(y))
    if variance > 0:
        t = float(np.sqrt(n) * abs(mean) / np.sqrt(variance))
    else:  # (a stretch of one value: no spread to judge it by; an all-zero one is no offset)
        t = 0.0 if mean == 0 else float("inf")
    return LongRunMeanResult(
        statistic=t,
        critical=Z_975,
        reject=t > Z_975,
        pvalue=float(2.0 * norm_sf(t)),
        n=n,
        lags=int(min(lags, n - 1)),
        variance=variance,
    )


def covariance_test(x: Any) -> CovarianceResult:
    """Unit-covariance test of a standardized innovation, 1-D or (N, r) (NaN rows dropped).

    ``statistic = trace(N C0) = sum_t eta_t^T eta_t`` with ``C0 = X^T X / N`` is
    chi-square with ``dof = N r`` under the null. Two-sided at 5 %: rejected outside
    [``critical_low``, ``critical``] (the 2.5 % and 97.5 % points), ``pvalue = 2 min(F,
    1 - F)``. Too large: noisy sensor or underestimated S; too small: a stuck or
    over-smoothed channel. Seed 003, "Tests of covariance".
    """
    eta = as_matrix(x, "x")
    n, r = eta.shape
    dof = n * r
    statistic = float(np.einsum("ij,ij->", eta, eta))
    tail = min(float(chi2_cdf(statistic, dof)), float(chi2_sf(statistic, dof)))
    pvalue = min(1.0, 2.0 * tail)
    return CovarianceResult(
        statistic=statistic,
        critical=float(chi2_ppf(1.0 - ALPHA / 2.0, dof)),
        reject=pvalue < ALPHA,
        pvalue=pvalue,
        n=n,
        critical_low=float(chi2_ppf(ALPHA / 2.0, dof)),
        dof=dof,
    )


def inverse_sqrt(s: Any) -> FloatArray:
    """Symmetric inverse square root ``S^{-1/2} = V diag(w^{-1/2}) V^T`` of a covariance
    (r, r) or a stack (N, r, r), from ``numpy.linalg.eigh``.

    Raises DetectorError when S is not square, not finite, not symmetric (to 1e-8 of its
    largest entry) or not positive definite.
    """
    mat = as_float_array(s, "S")
    if mat.ndim < 2 or mat.shape[-1] != mat.shape[-2] or mat.shape[-1] == 0:
        raise DetectorError(f"expected a square (r, r) or (N, r, r) matrix for S, got {mat.shape}")
    if not np.isfinite(mat).all():
        raise DetectorError(
            f"S has {int(np.size(mat) - np.isfinite(mat).sum())} non-finite entries"
        )
    asym = float(np.max(np.abs(mat - np.swapaxes(mat, -1, -2)), initial=0.0))
    scale = float(np.max(np.abs(mat), initial=0.0))
    if asym > 1e-8 * scale:
        raise DetectorError(f"S is not symmetric: max |S - S^T| = {asym:.3g}")
    if mat.shape[-1] == 1:
        w = mat[..., 0]
        _check_positive_definite(w, mat.ndim)
        root: FloatArray = 1.0 / np.sqrt(mat)
        return root
    w, v = np.linalg.eigh(0.5 * (mat + np.swapaxes(mat, -1, -2)))
    _check_positive_definite(w, mat.ndim)
    out: FloatArray = (v / np.sqrt(w)[..., np.newaxis, :]) @ np.swapaxes(v, -1, -2)
    return out


def _check_positive_definite(eigenvalues: FloatArray, ndim: int) -> None:
    if (eigenvalues > 0.0).all():
        return
    worst = np.unravel_index(int(np.argmin(eigenvalues)), eigenvalues.shape)
    at = f" (at S[{worst[0]}])" if ndim == 3 else ""
    raise DetectorError(
        f"S is not positive definite: smallest eigenvalue {float(eigenvalues.min()):.6g}{at}"
    )


def standardize(e: Any, s: Any) -> FloatArray:
    """Standardized innovation ``eta_t = S^{-1/2} e_t`` (seed 003, "LDS - Statistics of
    the innovation sequence"), with the symmetric inverse square root of :func:`inverse_sqrt`.

    ``e`` is (N, r) (or (N,) for one channel); ``S`` is the innovation covariance, fixed
    (r, r) or time-varying (N, r, r). For one channel ``S`` may also be a scalar variance
    or an (N,) array of variances. The result has the shape of ``e``; NaN rows stay NaN.
    """
    innov = as_float_array(e, "E")
    if innov.ndim not in (1, 2) or innov.shape[0] == 0:
        raise DetectorError(f"expected an (N,) or (N, r) innovation for E, got shape {innov.shape}")
    cov = as_float_array(s, "S")
    flat = innov.ndim == 1
    mat = innov[:, np.newaxis] if flat else innov
    n, r = mat.shape
    if r == 1 and cov.ndim <= 1:
        cov = cov.reshape(-1, 1, 1) if cov.ndim == 1 else cov.reshape(1, 1)
    if cov.shape not in ((r, r), (n, r, r)):
        raise DetectorError(
            f"expected S of shape ({r}, {r}) or ({n}, {r}, {r}) for E of shape "
            f"{innov.shape}, got {np.shape(s)}"
        )
    root = inverse_sqrt(cov)
    eta = mat @ root if root.ndim == 2 else np.einsum("nij,nj->ni", root, mat)
    out: FloatArray = eta[:, 0] if flat else eta
    return out
