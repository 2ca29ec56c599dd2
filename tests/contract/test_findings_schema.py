"""``findings.json`` against its published JSON Schema (``analyzer/schema/
findings.schema.json``, draft 2020-12).

The documents of real runs validate (each bundled sample, ``--corrected``,
``--save-model`` then ``--model``, ``--screen``, a damaged member of a multi-file
archive, a skipped detector), as does a synthetic analysis with every fault type;
documents that break the contract do not (so the schema is not vacuous); and every field
the code writes is declared in the schema, so none is added without being documented.

The runs are made in this process, once per module, each when a test first needs it.
"""

from __future__ import annotations

import copy
import importlib.resources
import json
import math
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from jsonschema import Draft202012Validator

from analyzer.cli import main
from analyzer.findings import SCHEMA, Analysis, findings_document
from analyzer.report.synthetic import SyntheticFault, synthetic_analysis
from analyzer.schema import findings_schema
from analyzer.simulate import inject_fault, simulate_building
from analyzer.types import FaultType, Format
from analyzer.writers import write_archive

REPO = Path(__file__).resolve().parents[2]
SAMPLES = REPO / "samples"
RATE = 200.0

SCHEMA_DOC = findings_schema()
VALIDATOR = Draft202012Validator(SCHEMA_DOC)

CORE = {
    (): ["schema", "analyzer_version", "inputs", "start", "duration_s", "rate_hz", "train"]
    + ["channels", "faults", "detectors"],
    ("train",): ["start_s", "end_s"],
    ("inputs", 0): ["path", "format", "sha256", "errors"],
    ("channels", 0): ["name", "samples", "rate_hz", "gaps"],
    ("faults", 0): ["channel", "type", "onset_s", "end_s", "onset", "magnitude"]
    + ["confidence", "detector", "evidence"],
    ("detectors", 0): ["name", "channels", "params"],
}
"""The fields of CONTRACT.md's findings.json, by the path of the object holding them:
each must be required by the schema."""


def problems(doc: dict[str, Any]) -> list[str]:
    """Each validation error of ``doc``: where, and what is wrong."""
    errors = sorted(VALIDATOR.iter_errors(doc), key=lambda e: [str(p) for p in e.absolute_path])
    return [f"/{'/'.join(map(str, e.absolute_path))}: {e.message[:300]}" for e in errors]


def as_written(doc: dict[str, Any]) -> dict[str, Any]:
    """``doc`` as ``findings.json`` holds it (JSON types only, no NaN)."""
    parsed: dict[str, Any] = json.loads(json.dumps(doc, allow_nan=False))
    return parsed


# ---------------------------------------------------------------------------- the runs


def _damaged_archive(folder: Path) -> Path:
    """A folder archive: a CSV of relative seconds (no absolute time, so ``start`` is
    null) whose sensor s1 sticks at 30 s, and a CSV member that is binary garbage (an
    input error; the analysis of the rest goes on)."""
    folder.mkdir()
    t, Y, names = simulate_building(n_floors=4, duration_s=60.0, rate_hz=RATE, seed=3)
    Y[:, 1] = inject_fault(Y[:, 1], RATE, "other", 30.0, 0.0)
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(folder / "a.csv", "csv", t_ns, {n: Y[:, j] for j, n in enumerate(names)})
    (folder / "b.csv").write_bytes(b"time,s0\n0.0,1.0\n0.005,\x00\x00\x00\xff\n")
    return folder


def _after_gap(folder: Path) -> Path:
    """A CSV of Unix times missing 60-70 s, s1 offset from 65 s: found after the gap
    (``evidence.after_gap_s``)."""
    folder.mkdir()
    t, Y, names = simulate_building(n_floors=4, duration_s=150.0, rate_hz=RATE, seed=2)
    Y[t >= 65.0, 1] += 4.0 * Y[:, 1].std()
    keep = (t < 60.0) | (t >= 70.0)
    t_ns = 1_767_225_600_000_000_000 + np.round(t[keep] * 1e9).astype(np.int64)
    write_archive(folder / "gap.csv", "csv", t_ns, {n: Y[keep, j] for j, n in enumerate(names)})
    return folder / "gap.csv"


def _clipping(folder: Path) -> Path:
    """A 3-floor building (two sensors a floor) whose s2 clips at half its peak from 60 %
    of the record: one finding with ``evidence.clipped``."""
    folder.mkdir()
    t, Y, names = simulate_building(3, 120.0, RATE, seed=1, sensors_per_floor=2)
    on, lim = int(0.6 * len(t)), 0.5 * np.abs(Y[:, 2]).max()
    Y[on:, 2] = np.clip(Y[on:, 2], -lim, lim)
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(folder / "clip.csv", "csv", t_ns, {n: Y[:, j] for j, n in enumerate(names)})
    return folder / "clip.csv"


CASES: dict[str, Callable[[Path], list[Any]]] = {
    # each bundled sample, by its format; --corrected and --save-model ride along
    "additive_mcap_corrected": lambda root: [SAMPLES / "building_additive.mcap", "--corrected"],
    "drift_ros1bag_save_model": lambda root: [
        SAMPLES / "building_drift.bag",
        "--save-model",
        root / "drift.model",
    ],
    # error_function (no [[group]] in a config) is skipped: skipped_detectors
    "multiplicative_csv": lambda root: [SAMPLES / "building_multiplicative.csv.gz"],
    "healthy_ros2bag": lambda root: [SAMPLES / "building_healthy_ros2"],
    # the drift bag's model on the ROS 2 sample (the same channel names)
    "model": lambda root: [SAMPLES / "building_healthy_ros2", "--model", root / "drift.model"],
    "screen": lambda root: [SAMPLES / "building_healthy_ros2", "--screen", "equivalent_model"],
    "damaged_member": lambda root: [_damaged_archive(root / "archive")],
    "after_gap": lambda root: [_after_gap(root / "gap")],
    "clipping": lambda root: [_clipping(root / "clip")],
}
"""The arguments of each ``analyzer run`` (before ``--out``), given the runs' folder."""

NEEDS = {"model": "drift_ros1bag_save_model"}
"""Runs that need another's output (``--model`` the file ``--save-model`` wrote)."""


class Runs:
    """``analyzer run`` of each of :data:`CASES`, made when first asked for, kept for the
    module."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.docs: dict[str, dict[str, Any]] = {}

    def doc(self, case: str) -> dict[str, Any]:
        if case not in self.docs:
            if case in NEEDS:
                self.doc(NEEDS[case])
            out = self.root / case
            argv = ["run", *CASES[case](self.root), "--out", out, "--no-progress"]
            code = main([str(a) for a in argv])
            assert code in (0, 1), f"{case}: exit {code}"
            self.docs[case] = json.loads((out / "findings.json").read_text(encoding="utf-8"))
        return self.docs[case]

    def all(self) -> Iterator[tuple[str, dict[str, Any]]]:
        for case in CASES:
            yield case, self.doc(case)


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> Runs:
    return Runs(tmp_path_factory.mktemp("runs"))


def _synthetic(**kwargs: Any) -> Analysis:
    """A synthetic analysis with a fault of every type (two of them ending)."""
    faults = [
        SyntheticFault(0, FaultType.ADDITIVE, 40.0, None, 2.0),
        SyntheticFault(1, FaultType.MULTIPLICATIVE, 50.0, None, 1.5),
        SyntheticFault(2, FaultType.DRIFT, 60.0, 100.0, 0.05),
        SyntheticFault(3, FaultType.OTHER, 70.0, 90.0, 0.0),
    ]
    return synthetic_analysis(faults=faults, **kwargs)


@pytest.fixture(scope="module")
def synthetic_doc() -> dict[str, Any]:
    return as_written(findings_document(_synthetic()))


# ---------------------------------------------------------------------------- the schema


def test_the_schema_is_a_draft_2020_12_schema_of_analyzer_findings_1():
    Draft202012Validator.check_schema(SCHEMA_DOC)
    assert SCHEMA_DOC["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    assert SCHEMA_DOC["$id"].endswith(SCHEMA) and SCHEMA == "analyzer.findings/1"
    assert SCHEMA_DOC["properties"]["schema"] == {
        "const": SCHEMA,
        "description": SCHEMA_DOC["properties"]["schema"]["description"],
    }


def test_the_schema_is_package_data_and_each_call_gives_a_new_dict():
    path = importlib.resources.files("analyzer").joinpath("schema/findings.schema.json")
    assert path.is_file()
    assert findings_schema() == json.loads(path.read_text(encoding="utf-8"))
    findings_schema()["properties"].clear()
    assert findings_schema()["properties"]


def test_loading_the_schema_does_not_import_jsonschema():
    """jsonschema is a test-only dependency: the accessor only reads the file."""
    code = (
        "import sys; from analyzer.schema import findings_schema; findings_schema(); "
        "print('jsonschema' in sys.modules)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=REPO
    )
    assert out.stdout.strip() == "False"


@pytest.mark.parametrize(("where", "key"), [(w, k) for w, keys in CORE.items() for k in keys])
def test_the_contract_fields_are_required(synthetic_doc, where, key):
    """Leaving out any field of CONTRACT.md's findings.json fails validation, where it
    was left out."""
    doc = copy.deepcopy(synthetic_doc)
    holder = doc
    for step in where:
        holder = holder[step]
    del holder[key]
    errors = [e for e in VALIDATOR.iter_errors(doc) if e.validator == "required"]
    assert [tuple(e.absolute_path) for e in errors] == [where], problems(doc)


# ---------------------------------------------------------------------------- real runs


def _has_format(fmt: Format) -> Callable[[dict[str, Any]], bool]:
    return lambda doc: [i["format"] for i in doc["inputs"]] == [str(fmt)]


EXERCISES: dict[str, Callable[[dict[str, Any]], bool]] = {
    "additive_mcap_corrected": lambda doc: (
        _has_format(Format.MCAP)(doc) and bool(doc["faults"]) and bool(doc["corrections"])
    ),
    "drift_ros1bag_save_model": lambda doc: (
        _has_format(Format.ROS1BAG)(doc)
        and doc["saved_model"] is not None
        and doc["saved_model"]["path"].endswith("drift.model")
    ),
    "multiplicative_csv": lambda doc: (
        _has_format(Format.CSV)(doc) and bool(doc["skipped_detectors"])
    ),
    "healthy_ros2bag": _has_format(Format.ROS2BAG),
    "model": lambda doc: doc["model"] is not None and doc["model"]["path"].endswith("drift.model"),
    "screen": lambda doc: (
        doc["screen"] is not None and doc["screen"]["detectors"] == ["equivalent_model"]
    ),
    "damaged_member": lambda doc: (
        doc["start"] is None and any(i["errors"] for i in doc["inputs"]) and bool(doc["faults"])
    ),
    "after_gap": lambda doc: any("after_gap_s" in f["evidence"] for f in doc["faults"]),
    "clipping": lambda doc: any("clipped" in f["evidence"] for f in doc["faults"]),
}
"""What each run must show for its document to test what it is there for (a sample's
format, corrections, a model, a screening, an input error, a skipped detector...)."""


@pytest.mark.parametrize("case", list(CASES))
def test_a_run_writes_a_valid_findings_json(runs, case):
    doc = runs.doc(case)
    assert EXERCISES[case](doc), f"{case} does not show what it is there for"
    assert problems(doc) == []


MAGNITUDE_KEY = {"additive": "offset", "multiplicative": "gain", "drift": "rate_per_s"}
"""The magnitude key each fault type must have (CONTRACT.md); ``other`` has any."""


def test_real_runs_give_each_type_its_magnitude_key_and_the_schema_asks_for_it(runs):
    """The real runs hold a fault of every type, each with its type's magnitude key (so
    the schema's rule, that an additive fault has an offset and so on, fits what the
    analyzer writes), and their documents validate; the same faults with that key taken
    out, or a fault of another type's magnitude, do not."""
    seen: set[str] = set()
    for case, doc in runs.all():
        for k, fault in enumerate(doc["faults"]):
            seen.add(fault["type"])
            key = MAGNITUDE_KEY.get(fault["type"])
            if key is None:
                continue
            assert key in fault["magnitude"], (case, fault)
            broken = copy.deepcopy(doc)
            del broken["faults"][k]["magnitude"][key]
            assert ("faults", k, "magnitude") in [
                tuple(e.absolute_path) for e in VALIDATOR.iter_errors(broken)
            ], (case, k)
        assert problems(doc) == [], case
    assert seen == set(MAGNITUDE_KEY) | {"other"}, seen


def test_a_fault_of_type_other_may_have_any_magnitude(synthetic_doc):
    """``other`` (erratic, stuck, clipping, a fault without a shape) has no key of its
    own: an empty magnitude, or one of offset and rms, is valid."""
    doc = copy.deepcopy(synthetic_doc)
    assert doc["faults"][3]["type"] == "other"
    for magnitude in ({}, {"offset": 1.0, "rms": 2.0}, {"gain": 0.5}):
        doc["faults"][3]["magnitude"] = magnitude
        assert problems(doc) == [], magnitude


def test_a_synthetic_analysis_with_every_fault_type_is_valid(synthetic_doc):
    types = {f["type"] for f in synthetic_doc["faults"]}
    assert types == {str(t) for t in FaultType}
    assert any(f["end_s"] is not None for f in synthetic_doc["faults"])
    assert problems(synthetic_doc) == []


def test_the_contract_s_numbers_are_never_written_null():
    """CONTRACT.md says a fault's ``confidence`` and ``magnitude.offset/gain/rate_per_s``
    are numbers; the schema allowed null there, and the writer wrote null for one not
    finite (a QA audit's ux59 item L7, int56 item 4). None was ever found not finite;
    should one be, it is written as a number (an infinite size as the largest double with
    its sign, one that is not a number as 0, a confidence as 0) and a note says so. The
    analyzer's own numbers (``rms``, a test's statistic) stay null where not finite."""
    analysis = _synthetic()
    sizes = {"offset": math.nan, "gain": math.inf, "rate_per_s": -math.inf, "rms": math.nan}
    f = analysis.findings[0]
    f.magnitude = dict(sizes)
    f.confidence = math.nan
    f.evidence["tests"][f.detector]["after"]["mean"]["statistic"] = math.nan
    doc = as_written(findings_document(analysis))
    fault = doc["faults"][0]
    largest = float(np.finfo(np.float64).max)
    expected = {"offset": 0.0, "gain": largest, "rate_per_s": -largest, "rms": None}
    assert fault["magnitude"] == expected
    assert fault["confidence"] == 0.0
    assert fault["evidence"]["tests"][f.detector]["after"]["mean"]["statistic"] is None
    said = [n for n in doc["notes"] if "could not be computed" in n]
    assert len(said) == 1 and "offset, gain, rate_per_s, confidence" in said[0], said
    assert problems(doc) == []
    assert not any("could not be computed" in n for n in synthetic_doc_notes())


def synthetic_doc_notes() -> list[str]:
    """The notes of the synthetic analysis as it is (every number finite)."""
    return list(findings_document(_synthetic())["notes"])


@pytest.mark.parametrize(
    ("path", "value"),
    [
        (("magnitude", "offset"), None),
        (("magnitude", "gain"), None),
        (("magnitude", "rate_per_s"), None),
        (("confidence",), None),
    ],
)
def test_the_schema_refuses_null_where_the_contract_says_a_number(synthetic_doc, path, value):
    doc = copy.deepcopy(synthetic_doc)
    fault = doc["faults"][0]
    holder = fault
    for step in path[:-1]:
        holder = holder[step]
    holder[path[-1]] = value
    assert problems(doc) != [], path


# ---------------------------------------------------------------------------- broken documents


def _set(path: tuple[Any, ...], value: Any) -> Callable[[dict[str, Any]], None]:
    def apply(doc: dict[str, Any]) -> None:
        holder = doc
        for step in path[:-1]:
            holder = holder[step]
        holder[path[-1]] = value

    return apply


AK_TESTS = ("faults", 0, "evidence", "tests", "ar_kalman_bank")

BROKEN: dict[str, tuple[Callable[[dict[str, Any]], None], tuple[Any, ...]]] = {
    "fault type bogus": (_set(("faults", 0, "type"), "bogus"), ("faults", 0, "type")),
    "confidence 1.5": (_set(("faults", 0, "confidence"), 1.5), ("faults", 0, "confidence")),
    "confidence -0.1": (_set(("faults", 0, "confidence"), -0.1), ("faults", 0, "confidence")),
    "onset_s a string": (_set(("faults", 0, "onset_s"), "40.0"), ("faults", 0, "onset_s")),
    "end_s a string": (_set(("faults", 0, "end_s"), "end"), ("faults", 0, "end_s")),
    "onset without Z": (
        _set(("faults", 0, "onset"), "2026-01-01T00:00:40.000"),
        ("faults", 0, "onset"),
    ),
    "offset a string": (
        _set(("faults", 0, "magnitude", "offset"), "2 m/s2"),
        ("faults", 0, "magnitude", "offset"),
    ),
    # each type's own magnitude key (CONTRACT.md; before, any magnitude object passed)
    "additive magnitude empty": (
        _set(("faults", 0, "magnitude"), {}),
        ("faults", 0, "magnitude"),
    ),
    "additive magnitude a gain": (
        _set(("faults", 0, "magnitude"), {"gain": 2.0}),
        ("faults", 0, "magnitude"),
    ),
    "multiplicative magnitude an offset": (
        _set(("faults", 1, "magnitude"), {"offset": 2.0}),
        ("faults", 1, "magnitude"),
    ),
    "drift magnitude empty": (
        _set(("faults", 2, "magnitude"), {}),
        ("faults", 2, "magnitude"),
    ),
    "no detectors in evidence": (
        _set(("faults", 0, "evidence", "detectors"), []),
        ("faults", 0, "evidence", "detectors"),
    ),
    "consistent_with bogus": (
        _set((*AK_TESTS, "consistent_with"), ["bogus"]),
        (*AK_TESTS, "consistent_with", 0),
    ),
    "whiteness without acf": (
        lambda doc: doc["faults"][0]["evidence"]["tests"]["ar_kalman_bank"]["after"][
            "whiteness"
        ].pop("acf"),
        (*AK_TESTS, "after", "whiteness"),
    ),
    "input format zip": (_set(("inputs", 0, "format"), "zip"), ("inputs", 0, "format")),
    "sha256 not hex": (_set(("inputs", 0, "sha256"), "x" * 64), ("inputs", 0, "sha256")),
    "another schema": (_set(("schema",), "analyzer.findings/2"), ("schema",)),
    "start in local time": (_set(("start",), "2026-01-01 00:00:00"), ("start",)),
    "negative samples": (_set(("channels", 0, "samples"), -1), ("channels", 0, "samples")),
    "rate_hz 0": (_set(("rate_hz",), 0.0), ("rate_hz",)),
    "params not an object": (_set(("detectors", 0, "params"), []), ("detectors", 0, "params")),
}
"""Documents that break the contract, each with where the schema must say so."""


def test_a_period_from_a_search_without_a_sensor_is_declared_and_valid():
    """``evidence.end_without`` and ``evidence.onset_without`` as the pipeline writes
    them (``pipeline._ends_without``, ``pipeline._onset_without``; no bundled run has two
    faults on coupled sensors): an end moved from the record's end, and a finding whose
    onset and end both moved. Before, neither was in the schema."""
    a = _synthetic()
    a.findings[0].evidence["end_without"] = {
        "left_out": "s3",
        "detector": "detection_filter",
        "was_s": None,
    }
    drift = a.findings[2]
    drift.evidence["end_without"] = {
        "left_out": "s3",
        "detector": "ar_kalman_bank",
        "was_s": 130.0,
    }
    drift.evidence["onset_without"] = {
        "left_out": "s1",
        "detector": "equivalent_model",
        "was_s": [55.5, 100.0],
    }
    doc = as_written(findings_document(a))
    assert problems(doc) == []
    parts = [(f["evidence"], p) for f in doc["faults"] for p in ("end_without", "onset_without")]
    shown = [(ev[p], DEFS["evidence"]["properties"].get(p)) for ev, p in parts if p in ev]
    assert len(shown) == 3
    assert all(d is not None and set(v) <= _declared(d) for v, d in shown)
    broken = copy.deepcopy(doc)
    broken["faults"][2]["evidence"]["onset_without"]["was_s"] = [55.5]
    assert problems(broken)


def test_a_shape_from_a_search_without_a_sensor_is_declared_and_valid():
    """``evidence.shape_without`` as the pipeline writes it (``pipeline._shape_without``:
    a type and size read without a later fault's sensor, Chang et al.'s Fig. 15 offset
    read as a gain with the drift in)."""
    a = _synthetic()
    a.findings[0].evidence["shape_without"] = {
        "left_out": "s5",
        "detector": "ar_kalman_bank",
        "was": {"type": "multiplicative", "magnitude": {"gain": 0.4145}, "detector": "x"},
    }
    doc = as_written(findings_document(a))
    assert problems(doc) == []
    declared = DEFS["evidence"]["properties"].get("shape_without")
    assert declared is not None and set(doc["faults"][0]["evidence"]["shape_without"]) <= (
        _declared(declared)
    )
    broken = copy.deepcopy(doc)
    del broken["faults"][0]["evidence"]["shape_without"]["was"]["type"]
    assert problems(broken)


@pytest.mark.parametrize("case", list(BROKEN))
def test_a_broken_document_is_invalid(synthetic_doc, case):
    assert problems(synthetic_doc) == []
    doc = copy.deepcopy(synthetic_doc)
    breaks, where = BROKEN[case]
    breaks(doc)
    assert where in [tuple(e.absolute_path) for e in VALIDATOR.iter_errors(doc)], problems(doc)


# ---------------------------------------------------------------------------- nothing undocumented


def _declared(definition: dict[str, Any]) -> set[str]:
    """The properties a schema object declares (itself and through its ``$ref``)."""
    names = set(definition.get("properties", {}))
    ref = definition.get("$ref")
    if ref:
        names |= _declared(DEFS[ref.rsplit("/", 1)[1]])
    return names


DEFS: dict[str, Any] = SCHEMA_DOC["$defs"]
TEST_DEFS = {"anderson_darling": "normality", "cramer_von_mises": "normality"}
TEST_DEFS |= {"mean": "meanTest", "covariance": "covarianceTest"}
TEST_DEFS |= {"mean_long_run": "longRunMeanTest"}
"""The definition of each innovation test's result (the others are named as the test)."""


def _objects(doc: dict[str, Any]) -> Iterator[tuple[str, dict[str, Any], dict[str, Any]]]:
    """``(where, its schema, object)`` of each object the analyzer builds itself (not the
    detectors' own ``params``, ``model`` and ``by_detector``)."""
    top = SCHEMA_DOC["properties"]
    yield "train", top["train"], doc["train"]
    for item in doc["inputs"]:
        yield "inputs[]", DEFS["input"], item
    for item in doc["channels"]:
        yield "channels[]", DEFS["channel"], item
    for item in doc["faults"]:
        evidence = item["evidence"]
        yield "faults[]", DEFS["fault"], item
        yield "faults[].magnitude", DEFS["magnitude"], item["magnitude"]
        yield "faults[].evidence", DEFS["evidence"], evidence
        for part in ("frozen", "clipped", "end_without", "onset_without", "shape_without"):
            if part in evidence:
                declared = DEFS["evidence"]["properties"][part]
                yield f"faults[].evidence.{part}", declared, evidence[part]
        for tests in evidence["tests"].values():
            yield "faults[].evidence.tests.*", DEFS["detectorTests"], tests
            for side in ("before", "after"):
                for name, result in (tests[side] or {}).items():
                    where = f"faults[].evidence.tests.*.{side}.{name}"
                    yield where, DEFS[TEST_DEFS.get(name, name)], result
    for item in doc["detectors"]:
        yield "detectors[]", DEFS["detector"], item
    for item in doc["corrections"]:
        yield "corrections[]", DEFS["correction"], item
    if doc["model"] is not None:
        yield "model", DEFS["model"], doc["model"]
    if doc.get("saved_model") is not None:
        yield "saved_model", DEFS["savedModel"], doc["saved_model"]
    if doc["screen"] is not None:
        yield "screen", DEFS["screen"], doc["screen"]


def test_every_top_level_field_findings_document_writes_is_declared(synthetic_doc):
    assert set(synthetic_doc) - set(SCHEMA_DOC["properties"]) == set()


def test_every_field_the_analyzer_writes_is_declared(runs, synthetic_doc):
    """Each key of each object the analyzer builds (not a detector's own) in every run's
    document is one the schema describes: a new field cannot go out undocumented."""
    undeclared = set()
    for case, doc in [("synthetic", synthetic_doc), *runs.all()]:
        assert set(doc) <= set(SCHEMA_DOC["properties"]), case
        for where, definition, obj in _objects(doc):
            undeclared |= {f"{case}: {where}.{key}" for key in set(obj) - _declared(definition)}
    assert sorted(undeclared) == []
