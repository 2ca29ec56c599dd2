"""A finding's ``confidence`` is an agreement score from 0 to 1, not a probability
(ux54 item 3): the report writes it as such, not as "100.0 %"; findings.json keeps the
field and its value (CONTRACT)."""

from __future__ import annotations

import html
import re

from analyzer.findings import findings_document
from analyzer.report import format as fmt
from analyzer.report import render_report
from analyzer.report.synthetic import SyntheticFault, synthetic_analysis
from analyzer.types import FaultType


def test_the_score_is_written_from_0_to_1() -> None:
    assert fmt.score(0.98) == "0.98"
    assert fmt.score(0.9996) == "> 0.99"  # never rounded up to a certainty
    assert fmt.score(1.0) == "1.00"
    assert fmt.score(None) == "n/a"


def test_the_report_calls_it_an_agreement_score() -> None:
    a = synthetic_analysis(120.0, 2, 50.0, [SyntheticFault(1, FaultType.ADDITIVE, 75.5, None, 1.0)])
    doc = findings_document(a)
    (f,) = doc["faults"]
    assert 0.0 <= f["confidence"] <= 1.0  # the field as CONTRACT.md has it
    page = render_report(a, doc)
    assert "agreement score (0 to 1)" in page and "not a probability" in page
    assert html.escape(fmt.score(f["confidence"])) in page
    assert not re.search(r"Confidence</dt>", page)
    assert "%" not in re.sub(
        r"\s+", " ", page.split("agreement score (0 to 1)</th>")[1].split("</table>")[0]
    )
