""":func:`_isolates`, the rule that decides whether a filter whose residual changed still
names its own sensor (a fault going on through another sensor's change): the alarmed
filter closest to its direction, not the farthest (test audit ux65 D6: ``min`` made
``max`` passed every test, no case making the two disagree)."""

from __future__ import annotations

import pytest

from analyzer.detectors.detection_filter import _isolates

# filter 0 close to its direction, filter 1 near but under 1, three others far off theirs
# (fewer than SEPARATION_OTHERS others: confirmed by the largest of them, not their median)
FEW = [0.1, 0.5, 3.0, 3.0, 3.0]
# eight filters: the typical other (the median) far off its direction
MANY = [4.0, 0.05, 0.3, 5.0, 6.0, 5.5, 4.5, 7.0]


@pytest.mark.parametrize(
    ("viol", "chans", "j", "isolates"),
    [
        (FEW, [0, 1], 0, True),  # j the nearest of the alarmed
        (FEW, [0, 1], 1, False),  # j the farthest, itself clear of the others
        (FEW, [1, 0], 1, False),  # (the order of the alarmed filters says nothing)
        (MANY, [1, 2], 1, True),
        (MANY, [1, 2], 2, False),
        (MANY, [2, 1, 0], 1, True),
    ],
)
def test_the_alarmed_filter_closest_to_its_direction_isolates(
    viol: list[float], chans: list[int], j: int, isolates: bool
) -> None:
    assert _isolates(viol, j, chans) is isolates


def test_the_farthest_alone_is_not_enough_even_where_it_separates() -> None:
    """Filter 1 alone among the alarms would isolate (clear of the typical other), and it
    does not while filter 0, also alarmed, is closer to its own direction."""
    assert _isolates(FEW, 1, [1]) is True
    assert _isolates(FEW, 1, [0, 1]) is False
