"""Result records of the innovation tests: small frozen values that carry the decision and
the numbers behind it, and turn themselves into JSON-friendly dicts for
``findings.json`` ``evidence.tests``.

Every result has ``statistic`` (what is compared with the threshold), ``critical`` (the
5 % threshold; the upper one for a two-sided test), ``reject`` (the null hypothesis "zero
mean, unit variance, white, Gaussian innovation" is rejected at 5 %), ``pvalue`` (for
Anderson-Darling and Cramer-von Mises from published approximations of their null laws,
:func:`analyzer.stats.normality.normality_pvalue`; the decision stays the tabulated
one) and ``n`` (finite samples used).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from analyzer.stats._checks import BoolArray, FloatArray

JsonScalar = float | int | bool | None
JsonValue = JsonScalar | list[JsonScalar] | str


def json_float(value: float) -> float | None:
    """``value`` as a plain float, or ``None`` when it is NaN or infinite (JSON has
    neither)."""
    out = float(value)
    return out if math.isfinite(out) else None


@dataclass(frozen=True, slots=True)
class StatResult:
    """What every test returns (see the module docstring for the field meanings)."""

    statistic: float
    critical: float
    reject: bool
    pvalue: float | None
    n: int

    def as_dict(self) -> dict[str, JsonValue]:
        """Plain floats, ints and bools; non-finite numbers become ``None``."""
        return {
            "statistic": json_float(self.statistic),
            "critical": json_float(self.critical),
            "reject": bool(self.reject),
            "pvalue": None if self.pvalue is None else json_float(self.pvalue),
            "n": int(self.n),
        }


@dataclass(frozen=True, slots=True)
class ShewhartResult(StatResult):
    """Shewhart chart on a standardized innovation: ``outliers`` has the input's shape
    (False at non-finite samples), ``count`` of them, ``fraction = count / n`` (also the
    statistic), ``critical`` the expected fraction ``2 (1 - Phi(k))``."""

    k: float
    count: int
    outliers: BoolArray

    @property
    def fraction(self) -> float:
        return self.statistic

    def as_dict(self) -> dict[str, JsonValue]:
        out = StatResult.as_dict(self)
        out.update(k=float(self.k), count=int(self.count))
        return out


@dataclass(frozen=True, slots=True)
class NormalityResult(StatResult):
    """Anderson-Darling or Cramer-von Mises test: ``raw`` is A^2 or W^2 before Stephens'
    modification, ``statistic`` the modified value compared with ``critical``."""

    test: str
    case: int
    raw: float

    def as_dict(self) -> dict[str, JsonValue]:
        out = StatResult.as_dict(self)
        out.update(case=int(self.case), raw=json_float(self.raw))
        return out


@dataclass(frozen=True, slots=True)
class WhitenessResult(StatResult):
    """Whiteness test: sample autocorrelations ``acf`` at lags 1..``lags``, the 95 % band
    ``1.96 / sqrt(n)``, the fraction of lags outside it, and the Ljung-Box Q (the
    statistic, compared with the chi-square(``lags``) 95 % point)."""

    lags: int
    acf: FloatArray
    band: float
    band_fraction: float

    @property
    def ljung_box(self) -> float:
        return self.statistic

    def as_dict(self) -> dict[str, JsonValue]:
        out = StatResult.as_dict(self)
        out.update(
            lags=int(self.lags),
            band=float(self.band),
            band_fraction=json_float(self.band_fraction),
            acf=[json_float(v) for v in self.acf],
        )
        return out


@dataclass(frozen=True, slots=True)
class MeanResult(StatResult):
    """Test of zero mean per component: ``mean`` and ``z = sqrt(n) mean`` of each of the
    r components, ``per_component`` rejections; ``statistic = max |z|``, ``critical =
    1.96``, ``pvalue`` the smallest per-component two-sided p-value (not adjusted for
    r > 1, so ``reject == any(per_component)``)."""

    mean: FloatArray
    z: FloatArray
    per_component: BoolArray

    def as_dict(self) -> dict[str, JsonValue]:
        out = StatResult.as_dict(self)
        out.update(
            mean=[json_float(v) for v in self.mean],
            per_component=[bool(v) for v in self.per_component],
        )
        return out


@dataclass(frozen=True, slots=True)
class LongRunMeanResult(StatResult):
    """Zero-mean test against the long-run variance (a residual that is not white):
    ``statistic = sqrt(n) |mean| / sqrt(variance)``, ``critical = 1.96``; ``variance``
    the Newey-West estimate over ``lags`` lags
    (:func:`analyzer.stats.moments.long_run_mean_test`)."""

    lags: int
    variance: float

    def as_dict(self) -> dict[str, JsonValue]:
        out = StatResult.as_dict(self)
        out.update(lags=int(self.lags), variance=json_float(self.variance))
        return out


@dataclass(frozen=True, slots=True)
class CovarianceResult(StatResult):
    """Two-sided test of unit covariance: ``statistic = trace(N C0)`` against
    chi-square(``dof``) with ``critical_low`` and ``critical`` its 2.5 % and 97.5 % points;
    ``ratio = statistic / dof`` estimates the variance scale (1 under the null)."""

    critical_low: float
    dof: int

    @property
    def ratio(self) -> float:
        return self.statistic / self.dof

    def as_dict(self) -> dict[str, JsonValue]:
        out = StatResult.as_dict(self)
        out.update(
            critical_low=json_float(self.critical_low),
            dof=int(self.dof),
            ratio=json_float(self.ratio),
        )
        return out
