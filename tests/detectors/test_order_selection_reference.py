"""The AR order chosen by AIC and BIC is statsmodels' choice on a model where the penalty
decides.

The building data of ``test_ar_model.py`` gives the same order whatever the penalty
counts. Here a 4-channel VAR(2) carries a weak lag-4 coupling: a penalty of ``p m``
parameters per order instead of ``p m**2`` lets the weak lags in (BIC 4, AIC 12). The
reference is ``statsmodels.tsa.api.VAR.select_order`` with the same maximum order on the
standardized channels, no trend (Lutkepohl 2005, Sec. 4.3: ``p m**2`` free parameters).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from statsmodels.tsa.api import VAR

from analyzer.detectors.ar_model import select_order

MAX_ORDER = 12


@pytest.fixture(scope="module")
def weak_lag_var() -> np.ndarray:
    """3000 samples of a 4-channel VAR with lags 1 and 2 and a weak lag 4 (seed 0)."""
    rng = np.random.default_rng(0)
    m, n = 4, 3000
    Y = np.zeros((n, m))
    A1 = 0.5 * np.eye(m) + 0.1 * rng.normal(size=(m, m))
    A2 = -0.3 * np.eye(m)
    A4 = 0.06 * rng.normal(size=(m, m))
    for t in range(4, n):
        Y[t] = A1 @ Y[t - 1] + A2 @ Y[t - 2] + A4 @ Y[t - 4] + rng.normal(size=m)
    return Y


@pytest.mark.parametrize("criterion", ["aic", "bic"])
def test_order_is_statsmodels_choice_when_the_penalty_decides(weak_lag_var, criterion):
    """``select_order`` equals ``VAR(Z).select_order(12, trend="n")`` for AIC and BIC, on
    a model where counting ``p m`` instead of ``p m**2`` parameters changes both."""
    Y = weak_lag_var
    Z = (Y - Y.mean(0)) / Y.std(0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # statsmodels' frequency and future warnings
        ref = VAR(Z).select_order(MAX_ORDER, trend="n").selected_orders[criterion]
    # the model is built so that BIC and AIC disagree and neither picks the largest order
    assert ref == {"bic": 2, "aic": 4}[criterion]
    assert select_order(Y, criterion, MAX_ORDER) == ref
