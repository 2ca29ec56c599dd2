"""``benchmarks/sweep_isolation.py --detectors``: every case runs only those detectors."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parent.parent / "benchmarks" / "sweep_isolation.py"
_spec = importlib.util.spec_from_file_location("sweep_isolation", SCRIPT)
assert _spec is not None and _spec.loader is not None
sweep = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(sweep)


class _Nothing:
    findings: list[object] = []


@pytest.mark.parametrize(
    "argv, wanted",
    [
        (["--detectors", "equivalent_model"], ["equivalent_model"]),
        (
            ["--detectors", "ar_kalman_bank,detection_filter"],
            ["ar_kalman_bank", "detection_filter"],
        ),
        ([], None),
    ],
)
def test_the_cases_run_the_detectors_asked_for(argv, wanted, monkeypatch, capsys):
    seen = []

    def analyze(inputs, options):
        seen.append(options.detectors)
        return _Nothing()

    monkeypatch.setattr(sweep, "analyze", analyze)
    args = ["--seeds", "0:2", "--floors", "2", "--minutes", "2", "--healthy", *argv]
    assert sweep.main(args) == 0
    assert seen == [wanted, wanted]
    head = capsys.readouterr().out.splitlines()[0]
    assert ("detectors" in head) == (wanted is not None)
    if wanted:
        assert head.endswith(f"detectors {','.join(wanted)}")
