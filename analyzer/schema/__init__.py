"""The published JSON Schemas of the analyzer's machine-readable outputs, shipped as
package data.

:func:`findings_schema` is the JSON Schema (draft 2020-12) of ``findings.json``
(``analyzer.findings/1``, CONTRACT.md): the contract's fields required, with their units,
the extension fields described. Any draft 2020-12 validator checks a document against it,
for example ``jsonschema.Draft202012Validator(findings_schema()).validate(doc)``; the
analyzer itself never validates (jsonschema is a test-only dependency).
"""

from __future__ import annotations

import json
from importlib import resources
from typing import Any

FINDINGS_SCHEMA_FILE = "findings.schema.json"


def findings_schema() -> dict[str, Any]:
    """The JSON Schema of ``findings.json``: a new dict each call (the caller may change it)."""
    text = resources.files(__name__).joinpath(FINDINGS_SCHEMA_FILE).read_text(encoding="utf-8")
    schema: dict[str, Any] = json.loads(text)
    return schema


__all__ = ["FINDINGS_SCHEMA_FILE", "findings_schema"]
