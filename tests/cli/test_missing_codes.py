"""A logger's missing-value code (``-9999``) read as a value made confident faults: a
single ``-9999`` every thousand rows "s2 clipped at -9999", fifty rows of it "s4 stuck at
-9999" (the ux55 audit, item 6). The run now says, for a clipped or stuck value that is
a usual code or far outside the channel's other readings, how to declare it missing;
``--missing-values`` reads such samples as gaps, counted in a note."""

from __future__ import annotations

import numpy as np

from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive
from tests.cli.cli_helpers import one_line_error, run_cli, run_to, said, schema_valid

RATE = 50.0
CODE = -9999.0


def _sentinel_csv(path):
    """A 5-sensor building, 300 s at 50 Hz, an additive fault on s3 from 200 s; ``-9999``
    in s2 every 1009th row (15 cells) and in s4 for 50 rows from 180 s."""
    t, y, names = simulate_building(5, 300.0, RATE, seed=3)
    sd = float(y[: int(60 * RATE), 3].std())
    y[:, 3] = inject_fault(y[:, 3], RATE, "additive", 200.0, 4 * sd)
    y[::1009, 2] = CODE
    y[int(180 * RATE) : int(181 * RATE), 4] = CODE
    t_ns = np.round(t * 1e9).astype(np.int64)
    data = {n: y[:, j] for j, n in enumerate(names)}
    write_archive(path, "csv", t_ns, data, start_iso="2026-03-29T00:58:00Z")
    return path, int((y[:, 2] == CODE).sum()), int((y[:, 4] == CODE).sum())


def _coded(doc):
    """The findings whose clipped or stuck value is the code."""
    return [
        f
        for f in doc["faults"]
        if CODE in (f["magnitude"].get("clipped_low"), f["magnitude"].get("stuck_at"))
    ]


def test_a_finding_at_a_usual_code_says_how_to_declare_it(tmp_path, capsys):
    """Read as values, the codes' findings each come with a stderr line naming
    ``--missing-values -9999``."""
    path, _, _ = _sentinel_csv(tmp_path / "log.csv")
    code, err, doc, _ = run_to(tmp_path, capsys, path)
    assert code == 1, err
    coded = _coded(doc)
    assert coded, doc["faults"]  # (the fixture's codes are findings when read as values)
    hints = [w for w in said(err) if "give --missing-values -9999" in w]
    assert sorted(h.split(": ")[2] for h in hints) == sorted(f["channel"] for f in coded), err
    assert all("a usual missing-value code" in h for h in hints)
    schema_valid(doc)


def test_missing_values_takes_the_codes_as_gaps(tmp_path, capsys):
    """``--missing-values -9999``: no finding at the code, the fault on s3 found, and a
    note counts the samples taken as gaps by channel."""
    path, n2, n4 = _sentinel_csv(tmp_path / "log.csv")
    code, err, doc, _ = run_to(tmp_path, capsys, path, "--missing-values", "-9999")
    assert code == 1, err
    assert _coded(doc) == []
    assert [f["channel"] for f in doc["faults"]] == ["s3"], doc["faults"]
    assert (
        f"missing-value codes (-9999, --missing-values) taken as gaps: s2 ({n2}), s4 ({n4})"
        in doc["notes"]
    )
    assert not any("--missing-values" in w for w in said(err)), err


def test_missing_values_not_numbers_is_one_line(tmp_path, capsys):
    path = tmp_path / "x.csv"
    path.write_text("time,a\n0,1\n")
    code, _, err = run_cli(
        ["run", path, "--out", tmp_path / "o", "--missing-values", "-9999,none"], capsys
    )
    assert code == 2
    one_line_error(err, "--missing-values", "'none'")
