import numpy as np
import pytest
from scipy import linalg
from statsmodels.tsa.api import VAR

from analyzer.detectors.ar_model import (
    _triangular_factor,
    fit_ar,
    required_samples,
    select_order,
)
from analyzer.errors import DetectorError
from analyzer.simulate import simulate_building


@pytest.fixture(scope="module")
def building():
    _, Y, _ = simulate_building(n_floors=4, duration_s=20.0, seed=3)
    return Y


def test_coefficients_match_statsmodels_var(building):
    ar = fit_ar(building, 6)
    Z = (building - ar.mean) / ar.scale
    ref = VAR(Z).fit(6, trend="n")
    np.testing.assert_allclose(ar.coefs, ref.coefs, atol=1e-10)
    # residual covariance with the same degrees-of-freedom correction
    np.testing.assert_allclose(ar.sigma, ref.sigma_u, rtol=1e-8)


@pytest.mark.parametrize("criterion", ["aic", "bic"])
def test_order_selection_matches_statsmodels(building, criterion):
    Z = (building - building.mean(0)) / building.std(0)
    ref = VAR(Z).select_order(12, trend="n").selected_orders[criterion]
    assert select_order(building, criterion, 12) == ref


def test_companion_form_reproduces_ar_prediction(building):
    ar = fit_ar(building, 3)
    A, C = ar.companion()
    Z = (building - ar.mean) / ar.scale
    k = 100
    x = np.concatenate([Z[k - 2], Z[k - 1], Z[k]])  # [y[k-2]; y[k-1]; y[k]]
    pred = C @ A @ x
    direct = sum(ar.coefs[i] @ Z[k - i] for i in range(3))
    np.testing.assert_allclose(pred, direct, atol=1e-12)


def test_too_little_training_data_is_refused():
    Y = np.random.default_rng(0).normal(size=(40, 5))
    with pytest.raises(DetectorError, match="too little healthy data"):
        fit_ar(Y, 7)
    assert required_samples(7, 5) > 40


def test_constant_channel_is_refused(building):
    Y = building.copy()
    Y[:, 2] = 1.5
    with pytest.raises(DetectorError, match=r"constant or empty"):
        fit_ar(Y, 3)


def test_duplicated_channel_is_singular(building):
    Y = np.column_stack([building, building[:, 0]])
    with pytest.raises(DetectorError, match="singular|linearly dependent"):
        fit_ar(Y, 3)


def test_singular_regression_names_the_dependent_channels(building):
    """The error says which channels make the regression singular: a sum of others at
    one instant, or a delayed copy of another (dependent only across lags)."""
    m = building.shape[1]
    names = [f"floor{i}" for i in range(m)] + ["sum"]
    Y = np.column_stack([building, building[:, 1] + 2.0 * building[:, 3]])
    with pytest.raises(DetectorError) as err:
        fit_ar(Y, 3, names)
    text = str(err.value)
    assert "is a linear combination of the other channels" in text
    assert any(n in text for n in ("sum", "floor1", "floor3"))
    assert "floor0," not in text and "floor2," not in text
    delayed = np.column_stack([building[1:], building[:-1, 2]])  # floor2 one sample late
    with pytest.raises(DetectorError) as err:
        fit_ar(delayed, 3, names[:m] + ["late"])
    text = str(err.value)
    assert "the other channels' past exactly" in text
    assert "late" in text or "floor2" in text
    assert "floor0" not in text


def test_bad_criterion():
    with pytest.raises(DetectorError, match="'aic' or 'bic'"):
        select_order(np.zeros((10, 2)), "hqic")


def test_select_order_is_remembered_per_training_window(monkeypatch):
    """The same window (by content, also from another array or thread) is scored once;
    another window, criterion or maximum order is scored again."""
    import threading

    import analyzer.detectors.ar_model as arm

    calls = []
    real = arm._select_order
    monkeypatch.setattr(arm, "_select_order", lambda *a: calls.append(1) or real(*a))
    monkeypatch.setattr(arm, "_ORDERS", type(arm._ORDERS)())
    rng = np.random.default_rng(5)
    Y = rng.standard_normal((3000, 3)).cumsum(axis=0)
    first = arm.select_order(Y, "bic", 6)
    got = []
    threads = [threading.Thread(target=lambda: got.append(arm.select_order(Y.copy(), "bic", 6)))]
    threads[0].start()
    threads[0].join()
    assert got == [first] and len(calls) == 1
    Z = Y.copy()
    Z[10, 1] += 1e-9
    arm.select_order(Z, "bic", 6)
    arm.select_order(Y, "aic", 6)
    arm.select_order(Y, "bic", 5)
    assert len(calls) == 4
    assert arm.select_order(Y, "bic", 6) == arm._select_order(Y, "bic", 6) == first


@pytest.mark.parametrize("ill", [False, True])
def test_triangular_factor_equals_qr_up_to_row_signs(ill):
    rng = np.random.default_rng(2)
    M = rng.normal(size=(3000, 12))
    if ill:  # nearly dependent columns: the Gram's Cholesky is refused, QR decides
        M[:, 5] = M[:, 4] + 1e-7 * rng.normal(size=3000)
    R = _triangular_factor(M)
    ref = linalg.qr(M, mode="r")[0][:12]
    assert np.allclose(np.tril(R, -1), 0.0)
    np.testing.assert_allclose(
        np.abs(R[:12]), np.abs(ref), rtol=1e-8, atol=1e-8 * np.abs(ref).max()
    )


def test_singular_regression_says_what_the_dependence_is(building):
    """The realdata audit (turtlesim ``example.bag`` trained on its first 12 s): only the
    up and left keys were pressed there, each teleop message one of them at 2, so
    ``cmd_vel.angular.z = 2 - cmd_vel.linear.x`` on every complete row; "a linear
    combination of the other channels" did not say of which, nor how. The error now
    gives the relation in the channels' own units."""
    m = building.shape[1]
    names = [f"floor{i}" for i in range(m)] + ["x"]
    Y = np.column_stack([building, 3.0 - 0.5 * building[:, 1]])
    with pytest.raises(DetectorError) as err:
        fit_ar(Y, 3, names)
    text = str(err.value)
    assert "is a linear combination of the other channels" in text
    assert "x = -0.5 floor1 + 3:" in text or "floor1 = -2 x + 6:" in text, text
    # an equal copy reads as one
    Y = np.column_stack([building, building[:, 2]])
    with pytest.raises(DetectorError) as err:
        fit_ar(Y, 3, names)
    assert "x = floor2:" in str(err.value) or "floor2 = x:" in str(err.value)
