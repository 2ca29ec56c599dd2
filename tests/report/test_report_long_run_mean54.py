"""A finding's innovation-test table shows the long-run zero-mean test (findings.json's
``mean_long_run``, the Newey-West test stat53 added) beside the plain one, and says in
plain words which of them the type vote read: the long-run one where whiteness is
rejected after the onset, else the plain one (the ux54 audit's left item)."""

import copy

import numpy as np
import pytest

from analyzer.pipeline import RunOptions, analyze, findings_document
from analyzer.report import render_report
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

RATE = 50.0


@pytest.fixture(scope="module")
def faulty(tmp_path_factory):
    t, y, names = simulate_building(3, 60.0, RATE, seed=1)
    y[:, 1] = inject_fault(y[:, 1], RATE, "additive", 36.0, 3.0 * float(np.std(y[:, 1])))
    path = tmp_path_factory.mktemp("faulty") / "faulty.csv"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: y[:, i] for i, n in enumerate(names)})
    analysis = analyze([path], RunOptions(train="0:15"))
    assert analysis.findings
    return analysis, findings_document(analysis)


def _section(html: str) -> str:
    return html[html.index('id="finding-1"') :]


def test_the_long_run_mean_test_is_shown_beside_the_plain_one(faulty):
    analysis, doc = faulty
    f = doc["faults"][0]
    lead = f["evidence"]["tests"][f["detector"]]["after"]
    assert "mean_long_run" in lead  # (findings.json has it)
    section = _section(render_report(analysis, doc))
    table = section[section.index(f"Innovation tests: {f['detector']}") :]
    table = table[: table.index("</table>")]
    assert "Zero mean, long-run" in table and "Newey-West" in table
    assert table.index("Zero mean<") < table.index("Zero mean, long-run")
    assert f"{lead['mean_long_run']['statistic']:.4g}" in table


@pytest.mark.parametrize("white", [False, True])
def test_the_report_says_which_mean_test_the_type_vote_read(faulty, white):
    from analyzer.diagnosis.evidence import mean_test_read

    analysis, doc = faulty
    doc = copy.deepcopy(doc)
    f = doc["faults"][0]
    for tests in f["evidence"]["tests"].values():
        tests["after"]["whiteness"]["reject"] = not white
    after = f["evidence"]["tests"][f["detector"]]["after"]
    assert mean_test_read(after) == ("mean" if white else "mean_long_run")
    section = _section(render_report(analysis, doc))
    said = "The type vote read the " + ("plain" if white else "long-run")
    other = "The type vote read the " + ("long-run" if white else "plain")
    assert said in section and other not in section
