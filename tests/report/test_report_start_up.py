"""The whole-record residual's axis leaves out the filters' start-up transient where it
would flatten the rest: on a ROS 2 bag the residual started at 1.0 beside a fault of 0.03,
and the top panel showed a flat line."""

import dataclasses

import numpy as np
import pytest
from report_helpers import RATE, offset_building

from analyzer.pipeline import findings_document
from analyzer.report import render_report
from analyzer.report.jobs import settled_limits

SAID = "axis is scaled without the filters&#39; start-up transient"


@pytest.fixture(scope="module")
def faulty(tmp_path_factory):
    analysis = offset_building(tmp_path_factory, 3)
    assert analysis.findings
    return analysis


def test_the_pipeline_knows_each_detectors_start_up(faulty):
    assert {r.detector for r in faulty.results} <= set(faulty.settling)
    assert all(rows >= 0 for rows in faulty.settling.values())
    assert max(faulty.settling.values()) > 0


def _with_transient(analysis, rows: int, size: float):
    """``analysis`` with the lead detector's residual of the first finding's sensor
    starting at ``size`` times its largest value after, for ``rows`` samples."""
    f = analysis.findings[0]
    results = []
    for r in analysis.results:
        if r.detector == f.detector:
            res = dict(r.residuals)
            x = np.array(res[f.channel], dtype=np.float32)
            x[: rows // 2] = size * float(np.nanmax(np.abs(x[rows:])))
            res[f.channel] = x
            r = dataclasses.replace(r, residuals=res)
        results.append(r)
    return dataclasses.replace(analysis, results=results, settling={f.detector: rows})


def test_a_start_up_transient_is_clipped_and_said(faulty):
    rows = int(2 * RATE)
    analysis = _with_transient(faulty, rows, 30.0)
    html = render_report(analysis, findings_document(analysis))
    assert SAID in html
    assert "(the first 2.000 s, hatched grey), which is drawn clipped" in html
    assert "filters&#39; start-up (clipped)" in html or "filters' start-up (clipped)" in html


def test_a_small_start_up_is_drawn_as_it_is(faulty):
    analysis = _with_transient(faulty, int(2 * RATE), 1.0)
    html = render_report(analysis, findings_document(analysis))
    assert SAID not in html and "start-up (clipped)" not in html


def test_the_limits_come_from_the_samples_after_the_start_up():
    t = np.arange(1000) / 10.0
    y = 0.03 * np.sin(t)
    y[:20] = 1.0
    lo, hi = settled_limits(t, y, y, 5.0)
    assert -0.04 < lo < -0.03 and 0.03 < hi < 0.04
    assert settled_limits(t, y, y, 0.0) is None  # no start-up known
    y[:20] = 0.035  # within the rest's scale: drawn as it is
    assert settled_limits(t, y, y, 5.0) is None
