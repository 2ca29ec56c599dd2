"""A drift's onset is traced back to where its line meets zero, as far back as the
stretch handed to the classifier is long (Chang et al. 2017, Eq. 13: a drift ``b (t -
t_f)`` is zero at its onset ``t_f``).

Reference: the zero of the line ``b (tau + s0)``, at ``tau = -s0``, in closed form."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.diagnosis.classify import classify
from analyzer.types import FaultType


@pytest.mark.parametrize(("back", "traced"), [(0.3, 0.3), (0.8, 0.8), (1.5, 1.0)])
def test_a_drift_onset_is_traced_back_up_to_the_stretch_length(back, traced):
    """A noiseless drift ``0.2 (tau + s0)`` over a 20 s stretch at 50 Hz (``tau`` from the
    detected onset, ``s0 = back * L``, ``L`` the stretch's last ``tau``): the onset moves to
    the line's zero, ``-s0``, while that is within ``L`` before the detected onset (0.3 L,
    0.8 L); further back it stops at ``-L`` (1.5 L)."""
    rate, n = 50.0, 1000
    tau = np.arange(n) / rate
    last = tau[-1]
    c = classify(0.2 * (tau + back * last), None, 0.1, rate)
    assert c.type is FaultType.DRIFT
    assert c.onset_shift_s == pytest.approx(-traced * last, rel=1e-9)
    if back <= 1.0:
        assert c.magnitude["rate_per_s"] == pytest.approx(0.2, rel=1e-9)
