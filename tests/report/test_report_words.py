"""Words of the report a newcomer stumbled on: "law: law 0" (a doubled word), "Seed 003"
(the project's internal name of a source paper) in the Method section, and the error
functions' "needs [[group]] ..." under "Detectors not run" on every report of a run
without a config, which read as a configuration error (it is the normal case)."""

import re

import pytest
from report_helpers import offset_building

from analyzer.pipeline import findings_document
from analyzer.report import render_report


@pytest.fixture(scope="module")
def page(tmp_path_factory):
    analysis = offset_building(tmp_path_factory, 4)
    doc = findings_document(analysis)
    return doc, render_report(analysis, doc)


def _text(html: str) -> str:
    return " ".join(re.sub(r"<[^>]+>", " ", html).split())


def test_a_detector_that_needs_a_config_is_the_normal_case(page):
    doc, html = page
    assert str(doc["skipped_detectors"]["error_function"]).startswith("needs [[group]]")
    text = _text(html)
    assert "Detectors not run" not in text
    assert "One more check, error_function , was not run, as usual without a config" in text


def test_the_method_names_the_tests_not_the_seed(page):
    _, html = page
    assert "Seed 003" not in html
    assert "Innovation sequence tests (IST)" in html


def test_the_laws_are_named_once(page):
    doc, html = page
    laws = [
        x["law"]
        for f in doc["faults"]
        for x in (f["evidence"].get("by_detector") or {}).values()
        if "law" in x
    ]
    assert laws, "the equivalent model's evidence must name its laws for this test to mean much"
    text = _text(html)
    assert not re.search(r"\blaw law\b", text)
    assert f"sensor-network diagnosis laws applied {laws[0].replace('law ', '')}" in text
