"""Helpers the detectors share (analyzer.detectors.base)."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.detectors.base import dilate_forward


@pytest.mark.parametrize("n", [0, 1, 3, 25])
def test_dilate_forward_marks_the_samples_a_gap_is_remembered_in(n: int) -> None:
    rng = np.random.default_rng(n)
    mask = rng.random(200) < 0.03
    mask[0] = mask[-1] = False
    got = dilate_forward(mask, n)
    # by the definition: sample k is marked when one of k - n .. k is
    want = np.array([mask[max(0, k - n) : k + 1].any() for k in range(mask.shape[0])])
    np.testing.assert_array_equal(got, want)


def test_dilate_forward_of_no_gap_is_no_gap() -> None:
    mask = np.zeros(50, dtype=bool)
    assert not dilate_forward(mask, 10).any()
