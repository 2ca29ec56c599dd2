"""One time unit per figure, on every panel: the SKAB record's residual figure read
minutes on its whole-record panel (onset at 12.0) above panels in seconds (onset at 719),
and the innovation tests' charts could do the same for a short stretch before the onset
and a long one after."""

import re

import numpy as np

from analyzer.report import figures as fg
from analyzer.report.decimate import Clock, envelope
from analyzer.report.jobs import ResidualPanel, Segment

RATE = 10.0
DURATION = 1200.0  # 20 minutes: the whole record reads minutes


def _units(svg: str) -> set[str]:
    return set(re.findall(r"time from start \((\w+)\)", svg))


def test_the_residual_figures_panels_share_the_records_unit():
    n = int(DURATION * RATE)
    r = np.random.default_rng(0).standard_normal(n)
    k0, k1 = int(690 * RATE), int(750 * RATE)  # a minute around the onset
    t = np.arange(k0, k1) / RATE
    panel = ResidualPanel("ar_kalman_bank", t, r[k0:k1], 0.0, 0.5, 16)
    svg = fg.residual_figure(
        envelope(Clock(n, RATE), r, fg.MAX_POINTS),
        "ar_kalman_bank",
        [panel, ResidualPanel("detection_filter", t, r[k0:k1])],
        719.0,
        None,
        (0.0, 718.0),
        DURATION,
        "k",
    )
    assert _units(str(svg)) == {"min"}


def test_the_tests_charts_share_one_unit():
    rng = np.random.default_rng(1)
    before = np.arange(0, 600 * RATE) / RATE  # 10 minutes: seconds alone
    after = np.arange(600 * RATE, 3600 * RATE) / RATE  # 50 minutes: minutes
    segments = [
        Segment("before", before, rng.standard_normal(before.size), {}),
        Segment("after", after, rng.standard_normal(after.size), {}),
    ]
    svg = fg.tests_figure(segments, "ar_kalman_bank", "k")
    assert _units(str(svg)) == {"min"}
