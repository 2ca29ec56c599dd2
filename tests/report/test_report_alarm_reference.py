"""The report tells the truth about what alarmed and what a healthy residual rejects.

* A finding's residual figure draws the statistic and band of the test that raised its
  alarm: a slow drift is first seen by the long window's mean while the short window's
  stays inside its (wider) band, and the figure drew the short one's, the residual
  inside the drawn band where the report said it alarmed. Where the mean-square test
  raised it (a large step), the panel draws the window's RMS and its bound.
* The windowed innovation tests' table sets each share of rejecting windows beside the
  share of the training window's (the healthy reference, measured): a residual that is
  not normal even when healthy rejects in far more than the nominal 5 % of windows, and
  the text said "about 5 %" next to 40-80 %.
"""

import html
import re
from pathlib import Path

import numpy as np
import pytest

from analyzer.diagnosis.changes import alarm_statistic, calibrate
from analyzer.pipeline import RunOptions, analyze, findings_document
from analyzer.report import format as fmt
from analyzer.report.view import build_view
from analyzer.report.view_figures import alarm_tests
from analyzer.report.view_tables import TableParts
from analyzer.simulate import inject_fault, simulate_building
from analyzer.stats import summarize, windowed_tests
from analyzer.writers import write_archive

RATE = 50.0


def _record(tmp_path_factory, y, t, names):
    path = tmp_path_factory.mktemp("r") / "r.csv"
    write_archive(
        path, "csv", np.round(t * 1e9).astype(np.int64), dict(zip(names, y.T, strict=True))
    )
    return path


@pytest.fixture(scope="module")
def drift(tmp_path_factory):
    """A building of 4 floors at 50 Hz whose s1 drifts slowly (0.02 sd/s) from 30 s:
    its leading detector first alarms on the long window's mean."""
    t, y, names = simulate_building(4, 60.0, RATE, seed=1)
    y[:, 1] = inject_fault(y[:, 1], RATE, "drift", 30.0, 0.02 * float(np.std(y[:, 1])))
    an = analyze([_record(tmp_path_factory, y, t, names)], RunOptions(train="0:15"))
    doc = findings_document(an)
    return an, doc, build_view(an, doc)


def test_alarm_tests_name_the_crossing_of_the_detectors_statistic():
    """At the first sample the detectors' alarm statistic passes 1, the test alarm_tests
    puts first is over its bound, and none was the sample before; a small lasting offset
    crosses on the long window first, its short window's mean still inside its band."""
    rng = np.random.default_rng(3)
    cal = calibrate(rng.standard_normal(8000), 16, 1e-4)
    x = rng.standard_normal(6000)
    x[3000:] += 0.35
    s = alarm_statistic(x, cal, raw=True, start=2000)
    at = 2000 + int(np.argmax(s[2000:] > 1.0))
    assert s[at] > 1.0
    th = cal.as_dict()
    crossed = alarm_tests(x, th, at)
    assert crossed[0].ratio >= 1.0
    assert crossed[0].window == cal.windows[-1] and crossed[0].kind == "mean"
    short = next(a for a in crossed if a.window == cal.windows[0] and a.kind == "mean")
    assert short.ratio < 1.0
    assert abs(crossed[0].bound - th["mean_threshold"][-1] * th["std"]) < 1e-12
    assert all(a.ratio < 1.0 for a in alarm_tests(x, th, at - 1))


def test_residual_figure_draws_and_names_the_window_that_alarmed(drift):
    an, doc, view = drift
    f = next(f for f in doc["faults"] if f["channel"] == "s1")
    lead = f["detector"]
    alarm_s = float(f["evidence"]["by_detector"][lead]["first_alarm_s"])
    result = next(r for r in an.results if r.detector == lead)
    th = result.thresholds["s1"]
    at = int(round(alarm_s * RATE))
    # measured here from the residual and the thresholds: the short window's mean is
    # inside its band at the first alarm, the long window's outside
    z = (np.asarray(result.residuals["s1"], dtype=np.float64) - th["mean"]) / th["std"]
    short, long_ = th["windows"]
    assert abs(z[at - short + 1 : at + 1].mean()) < th["mean_threshold"][0]
    assert abs(z[at - long_ + 1 : at + 1].mean()) > th["mean_threshold"][1]
    fv = next(v for v in view.findings if v.channel == "s1")
    fig = next(x for x in fv.figures if x.kind == "residual")
    caption = html.unescape(str(fig.caption))
    said = caption[caption.index(f"{lead}: first alarm") :]
    said = said[: said.index("(drawn)")]
    assert fmt.seconds(alarm_s, 3) in said
    assert f"its {long_}-sample" in said
    assert f"± {fmt.num(th['mean_threshold'][1] * th['std'])}" in said
    assert f"{short}-sample" not in said
    svg = str(fig.svg)
    assert f"{long_}-sample moving mean" in svg and "first alarm" in svg


@pytest.fixture(scope="module")
def heavy(tmp_path_factory):
    """A healthy building whose sensors' noise is heavy-tailed (Student t, 2.5 degrees
    of freedom): its residuals are not normal even when healthy, so the normality tests
    reject in far more than 5 % of the windows of the training window itself."""
    t, y, names = simulate_building(4, 120.0, RATE, seed=2, snr_db=60)
    rng = np.random.default_rng(5)
    y = y + rng.standard_t(2.5, size=y.shape) * 0.1 * y.std(axis=0)
    an = analyze([_record(tmp_path_factory, y, t, names)], RunOptions(train="0:40"))
    doc = findings_document(an)
    return doc, build_view(an, doc)


def test_windowed_table_compares_with_the_training_windows_share(heavy):
    doc, view = heavy
    det = doc["detectors"][0]
    wt = det["model"]["windowed_tests"]
    mv = next(m for m in view.models if m.detector == det["name"])
    col = mv.windowed.header.index("Anderson-Darling")
    shares = []
    for row in mv.windowed.rows:
        ad = wt[row[0]]["anderson_darling"]
        assert ad["training_windows"] > 0
        shares.append(ad["training_fraction"])
        assert row[col].endswith(
            f"; training {fmt.percent(ad['training_fraction'])} "
            f"({ad['training_rejected']}/{ad['training_windows']})"
        )
    # the healthy reference is far from the nominal 5 % on this record
    assert max(shares) > 0.3
    note = mv.windowed_note
    assert "about 5 %" not in note and "That measured share, not 5 %, is the reference" in note
    assert re.search(r"on the healthy training window, [^,]+ rejected \d+\.\d %", note)


def test_windowed_summary_counts_the_training_windows():
    """summarize(reference=) counts, per test, the rejecting windows wholly inside the
    reference span from the same per-window decisions."""
    rng = np.random.default_rng(0)
    z = rng.standard_normal(5000)
    z[3000:] += 0.5
    w = windowed_tests(z, 100)
    out = summarize(w, reference=(250, 2750))
    inside = w.valid & (w.start >= 250) & (w.start + 100 <= 2750)
    assert out["windows"]["training_span"] == [250, 2750]
    for name, stats in w.tests().items():
        assert out[name]["training_windows"] == int(inside.sum()) == 24
        assert out[name]["training_rejected"] == int(stats.reject[inside].sum())
    assert out["mean"]["training_fraction"] < out["mean"]["fraction"]


def test_windowed_note_says_when_there_is_no_reference():
    """A run with --model (no training window of the record's own: unwhitened, no
    training shares) says it has no healthy reference, rather than citing 5 %."""
    tables = TableParts()
    tables.rate = 100.0
    layout = {"count": 10, "valid": 10, "window": 100, "step": 100}
    test = {"rejected": 8, "windows": 10, "fraction": 0.8, "expected": 0.05}
    table, note = tables._windowed({"s0": {"windows": layout, "whiteness": test}})
    assert table.rows[0][4] == "80.0 % (8/10)"
    assert "No healthy reference" in note and "reused a model file" in note
    assert "about 5 %" not in note


def test_residual_figure_draws_the_rms_where_it_raised_the_alarm():
    """The additive sample's step of 10 first alarms on the mean-square test of the
    leading detector (its RMS over its bound before the window mean leaves its band):
    the panel draws that RMS and its bound, and the caption says so."""
    sample = Path(__file__).resolve().parents[2] / "samples" / "building_additive.mcap"
    an = analyze([sample], RunOptions())
    doc = findings_document(an)
    view = build_view(an, doc)
    f = doc["faults"][0]
    lead = f["detector"]
    at = int(round(float(f["evidence"]["by_detector"][lead]["first_alarm_s"]) * an.rate_hz))
    result = next(r for r in an.results if r.detector == lead)
    crossed = alarm_tests(result.residuals[f["channel"]], result.thresholds[f["channel"]], at)
    assert crossed[0].kind == "rms" and crossed[0].ratio >= 1.0
    fig = next(x for x in view.findings[0].figures if x.kind == "residual")
    caption = html.unescape(str(fig.caption))
    said = caption[caption.index(f"{lead}: first alarm") :]
    assert f"its {crossed[0].window}-sample" in said
    assert f"above its bound {fmt.num(crossed[0].bound)} (drawn)" in said
    assert f"{crossed[0].window}-sample RMS" in str(fig.svg)
