"""What the command-line tests share: running ``main`` in-process, and the contract's
one-line error."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest
from jsonschema import Draft202012Validator

from analyzer.cli import main
from analyzer.schema import findings_schema


def run_cli(argv: list[Any], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """``analyzer ARGV`` in this process: exit code, stdout, stderr."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_line_error(err: str, *needles: str) -> str:
    """The contract's error: one line, no traceback, holding each of ``needles``."""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    for n in needles:
        assert n in lines[0], (n, lines[0])
    return lines[0]


def said(err: str) -> list[str]:
    """The lines of a run's stderr before its last one, which says what it found and
    where the report is (:func:`analyzer.pipeline.summary_line`): the warnings."""
    lines = err.splitlines()
    assert lines and re.match(r"analyzer: (no sensor fault|\d+ sensor faults?) found", lines[-1])
    return lines[:-1]


def rounded(doc: Any, digits: int = 9) -> Any:
    """A JSON document with every float to ``digits`` significant digits: runs on
    threads split the filters' work into time blocks, whose sums differ from the serial
    run's in the last bits."""
    if isinstance(doc, dict):
        return {k: rounded(v, digits) for k, v in doc.items()}
    if isinstance(doc, list):
        return [rounded(v, digits) for v in doc]
    if isinstance(doc, float):
        return float(f"{doc:.{digits}g}")
    return doc


def run_to(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], path: Path, *more: Any
) -> tuple[int, str, Any, Path]:
    """``analyzer run PATH --out TMP/o MORE``: exit code, stderr, findings.json (None
    unless the exit code is 0 or 1) and the output folder."""
    out = tmp_path / "o"
    code, _, err = run_cli(["run", path, "--out", out, "--no-progress", *more], capsys)
    doc = json.loads((out / "findings.json").read_text()) if code in (0, 1) else None
    return code, err, doc, out


def schema_valid(doc: Any) -> None:
    """``doc`` passes the findings.json schema (the first errors shown otherwise)."""
    errors = list(Draft202012Validator(findings_schema()).iter_errors(doc))
    assert errors == [], [e.message[:200] for e in errors]
