"""A channel missing for a long stretch: the other channels are searched again without it
(``analyzer.reconfigure``), so a fault on another sensor while it is missing is found.

Before, the bank and the detection filter lost their view of every channel where one was
missing: a 2-sd offset on s3 24 s after s4 died went unreported (exit 0, a note). The
dead channel, blank or NaN to the end, is itself a finding (``silent_check``,
:mod:`analyzer.silent`, since the ux53 audit): the detectors' findings are the others."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import rounded, run_cli

from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

RATE = 100.0


def _archive(path: Path, seed: int, dead: int, faulty: int | None, kind: str = "additive") -> str:
    """A 6-channel building of 120 s whose channel ``dead`` has no sample from 48 s on
    (empty cells), with a fault on ``faulty`` from 72 s (none when None)."""
    t, Y, names = simulate_building(
        n_floors=3, duration_s=120.0, rate_hz=RATE, seed=seed, sensors_per_floor=2
    )
    sd = Y[: int(24 * RATE)].std(axis=0)
    if faulty is not None:
        size = {"additive": 2 * sd[faulty], "multiplicative": 1.5, "drift": sd[faulty] / 10}[kind]
        Y[:, faulty] = inject_fault(Y[:, faulty], RATE, kind, 72.0, size)
    Y[int(48 * RATE) :, dead] = np.nan
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {c: Y[:, j] for j, c in enumerate(names)})
    return names[dead]


def _detected(faults: list) -> list:
    """The detectors' findings: all but the dead channel's own (``silent_check``)."""
    return [f for f in faults if f["detector"] != "silent_check"]


def _silent(faults: list, lost: str) -> None:
    """The one ``silent_check`` finding: ``lost``, from 48 s to the end (72 s)."""
    (f,) = [f for f in faults if f["detector"] == "silent_check"]
    assert (f["channel"], f["type"], f["end_s"]) == (lost, "other", None)
    assert f["onset_s"] == pytest.approx(48.0, abs=0.02)
    assert f["magnitude"]["no_data_s"] == pytest.approx(72.0, abs=0.05)


def _run(capsys, path: Path, out: Path, *extra: str) -> tuple[int, dict]:
    code, _, err = run_cli(["run", path, "--out", out, "--no-progress", *extra], capsys)
    assert code in (0, 1), err
    return code, json.loads((out / "findings.json").read_text())


@pytest.mark.parametrize(
    ("seed", "dead", "faulty", "kind"),
    [(0, 4, 3, "additive"), (1, 2, 3, "multiplicative"), (2, 1, 4, "drift")],
)
def test_a_fault_while_a_channel_is_missing_is_found(tmp_path, capsys, seed, dead, faulty, kind):
    lost = _archive(tmp_path / "a.csv", seed, dead, faulty, kind)
    code, doc = _run(capsys, tmp_path / "a.csv", tmp_path / "out")
    assert code == 1
    (f,) = _detected(doc["faults"])
    _silent(doc["faults"], lost)
    assert (f["channel"], f["type"]) == (f"s{faulty}", kind)
    assert abs(f["onset_s"] - 72.0) < 1.0
    assert f["evidence"]["searched_without"] == [lost]
    assert f["evidence"]["tests"], "the second search's residual tests are its evidence"
    assert any(
        n.startswith(f"the other channels were searched again without {lost} ({lost} missing 48")
        and f"1 finding(s) added from it: {kind} on s{faulty}" in n
        for n in doc["notes"]
    ), doc["notes"]


@pytest.mark.parametrize("seed", [3, 4, 5])
def test_a_healthy_record_with_a_missing_channel_stays_healthy(tmp_path, capsys, seed):
    lost = _archive(tmp_path / "a.csv", seed, seed % 6, None)
    code, doc = _run(capsys, tmp_path / "a.csv", tmp_path / "out")
    assert code == 1 and not _detected(doc["faults"]), doc["faults"]
    _silent(doc["faults"], lost)
    assert any(
        n.startswith(f"the other channels were searched again without {lost}")
        and "nothing more was found there" in n
        for n in doc["notes"]
    ), doc["notes"]


def test_the_second_search_is_the_same_on_threads(tmp_path, capsys):
    _archive(tmp_path / "a.csv", 0, 4, 3)
    _, serial = _run(capsys, tmp_path / "a.csv", tmp_path / "one", "--jobs", "1")
    _, threads = _run(capsys, tmp_path / "a.csv", tmp_path / "two", "--jobs", "2")
    # the same document, its numbers to rounding: threads split the filters' work into
    # time blocks whose sums differ in the last bits (a peak of 32.24675235349832 on
    # one machine's BLAS was 32.246752353498294 on threads)
    assert rounded(serial["faults"]) == rounded(threads["faults"])


def test_a_saved_model_keeps_its_channel_set(tmp_path, capsys):
    """With --save-model the model is the run's channels: no second search, and the note
    names the --channels that searches the others (as before)."""
    lost = _archive(tmp_path / "a.csv", 0, 4, 3)
    _, doc = _run(
        capsys, tmp_path / "a.csv", tmp_path / "out", "--save-model", str(tmp_path / "m.model")
    )
    assert not any(n.startswith("the other channels were searched again") for n in doc["notes"])
    assert any(f"--channels '!{lost}' searches the others there" in n for n in doc["notes"])
    assert all("searched_without" not in f["evidence"] for f in doc["faults"])


def test_the_second_search_on_a_mapped_matrix_and_in_groups(tmp_path, monkeypatch):
    """A long archive's path (the matrix memory-mapped, the left-out copy written a block
    at a time) and channel groups give the in-memory run's findings."""
    from analyzer import grouping, pipeline
    from analyzer.options import RunOptions

    _archive(tmp_path / "a.csv", 0, 4, 3)
    memory = pipeline.analyze([tmp_path / "a.csv"], RunOptions(jobs=2))
    monkeypatch.setattr(pipeline, "MATERIALIZE_IN_MEMORY", 1000)
    work = tmp_path / "work"
    work.mkdir()
    mapped = pipeline.analyze([tmp_path / "a.csv"], RunOptions(jobs=2), work)
    assert (work / "aligned-without.npy").exists()
    monkeypatch.setattr(pipeline, "partition", lambda *a, **k: grouping.partition(*a, **k, size=3))
    grouped = pipeline.analyze([tmp_path / "a.csv"], RunOptions(jobs=2))
    found = {}
    for name, run in (("memory", memory), ("mapped", mapped), ("grouped", grouped)):
        pairs = [(f.channel, f.type.value, f.detector == "silent_check") for f in run.findings]
        assert pairs == [("s4", "other", True), ("s3", "additive", False)]
        found[name] = run.findings[1]
        assert found[name].evidence["searched_without"] == ["s4"]
    assert found["mapped"].onset_s == found["memory"].onset_s
    assert found["mapped"].magnitude["offset"] == pytest.approx(
        found["memory"].magnitude["offset"], rel=1e-6
    )


@pytest.mark.parametrize(("seed", "first", "second"), [(6, 3, 1), (7, 0, 3)])
def test_two_faults_from_one_instant_are_both_found(tmp_path, seed, first, second):
    """Two sensors faulty from the same instant: the first search found one of them (the
    other's alarms attributed to no sensor); searched again without the one found, the
    second stands out. The 6-channel cases of benchmarks/sweep_isolation.py that failed."""
    from analyzer import pipeline
    from analyzer.options import RunOptions

    t, Y, names = simulate_building(
        n_floors=3, duration_s=400.0, rate_hz=RATE, seed=seed, sensors_per_floor=2
    )
    sd = Y.std(axis=0)
    Y[:, first] = inject_fault(Y[:, first], RATE, "additive", 240.0, 0.5 * sd[first])
    Y[:, second] = inject_fault(Y[:, second], RATE, "multiplicative", 240.0, 1.3)
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(tmp_path / "a.csv", "csv", t_ns, {c: Y[:, j] for j, c in enumerate(names)})
    analysis = pipeline.analyze([tmp_path / "a.csv"], RunOptions(jobs=2))
    found = {(f.channel, f.type.value) for f in analysis.findings}
    assert found == {(f"s{first}", "additive"), (f"s{second}", "multiplicative")}, found
    assert all(abs(f.onset_s - 240.0) < 2.0 for f in analysis.findings)
    again = [f for f in analysis.findings if "searched_without" in f.evidence]
    assert len(again) == 1
    assert any("isolated one fault at a time" in n for n in analysis.notes)


def test_a_sensor_that_publishes_nan_after_it_died(tmp_path, capsys):
    """A dead sensor may go on publishing NaN rather than stop: its last sample is at the
    record's end, its values are missing. The same note and second search."""
    t, Y, names = simulate_building(
        n_floors=3, duration_s=120.0, rate_hz=RATE, seed=0, sensors_per_floor=2
    )
    sd = Y[: int(24 * RATE)].std(axis=0)
    Y[:, 3] = inject_fault(Y[:, 3], RATE, "additive", 72.0, 2 * sd[3])
    Y[int(48 * RATE) :, 4] = np.nan
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(tmp_path / "a.mcap", "mcap", t_ns, {c: Y[:, j] for j, c in enumerate(names)})
    code, doc = _run(capsys, tmp_path / "a.mcap", tmp_path / "out")
    assert code == 1
    assert [(f["channel"], f["type"]) for f in doc["faults"]] == [
        ("/s4.data", "other"),
        ("/s3.data", "additive"),
    ]
    _silent(doc["faults"], "/s4.data")
    assert doc["faults"][1]["evidence"]["searched_without"] == ["/s4.data"]
    assert any(
        n.startswith("/s4.data has no reading in its last 72 s (after 48 s) of the record")
        for n in doc["notes"]
    ), doc["notes"]


def test_lost_stretches_read_from_both_ends_of_a_long_matrix():
    from analyzer.reconfigure import lost_stretches

    n = 3 * 65_536 + 17  # several blocks of rows
    values = np.random.default_rng(0).standard_normal((n, 4))
    values[: n // 3, 1] = np.nan  # started late
    values[n // 2 :, 2] = np.nan  # stopped early
    values[100:200, 3] = np.nan  # a short gap: no stretch
    got = lost_stretches(values, 100.0)
    assert got == [[], [(0, n // 3)], [(n // 2, n)], []]
    short = values[: 2 * 100 * 5]  # 10 s of 100 Hz: nothing lasts 10 s
    assert lost_stretches(short, 100.0) == [[], [], [], []] or all(
        b - a >= 1000 for rows in lost_stretches(short, 100.0) for a, b in rows
    )


def test_the_second_search_keeps_the_first_searchs_results_and_the_schema(tmp_path, capsys):
    """Its long results in a scratch directory of their own: the first search's residual
    files were overwritten (the serial run's tests of error_function's s4 read another
    sensor's values, --jobs 2's did not); and its evidence is in the published schema."""
    from jsonschema import Draft202012Validator

    from analyzer.schema import findings_schema

    _archive(tmp_path / "a.csv", 0, 4, 3)
    docs = []
    for jobs in ("1", "2"):
        _, doc = _run(
            capsys,
            tmp_path / "a.csv",
            tmp_path / f"j{jobs}",
            "--jobs",
            jobs,
            "--detectors",
            "ar_kalman_bank,error_function",
        )
        docs.append(doc)
        errors = list(Draft202012Validator(findings_schema()).iter_errors(doc))
        assert not errors, [e.message for e in errors]
    serial, threads = docs
    for a, b in zip(serial["detectors"], threads["detectors"], strict=True):
        if a["name"] == "silent_check":  # (a check, no model: the same channels)
            assert a == b
            continue
        for key in ("training_tests", "windowed_tests"):
            assert json.dumps(a["model"][key], sort_keys=True) == json.dumps(
                b["model"][key], sort_keys=True
            )
    assert _detected(serial["faults"])[0]["evidence"]["searched_without"] == ["s4"]


def test_no_second_search_for_a_channel_missing_only_in_the_healthy_window(tmp_path, monkeypatch):
    """A channel that starts 15 s late in a 120 s record is missing only inside the
    healthy window (0-24 s), where no fault is searched: noted, not searched again."""
    from analyzer import pipeline
    from analyzer.options import RunOptions

    t, Y, names = simulate_building(
        n_floors=3, duration_s=120.0, rate_hz=RATE, seed=3, sensors_per_floor=2
    )
    Y[: int(15 * RATE), 2] = np.nan
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(tmp_path / "a.csv", "csv", t_ns, {c: Y[:, j] for j, c in enumerate(names)})
    calls = []
    real = pipeline._searched_without
    monkeypatch.setattr(
        pipeline, "_searched_without", lambda *a, **k: calls.append(a) or real(*a, **k)
    )
    analysis = pipeline.analyze([tmp_path / "a.csv"], RunOptions(jobs=1))
    assert not calls
    assert "s2 has no reading in its first 15 s of the record (inside the healthy window" in (
        "\n".join(analysis.notes)
    )


def test_a_screened_run_is_not_searched_again(tmp_path, capsys):
    """--screen's verdict is given before any second search: a screen that finds nothing
    stays the analysis (the second search would have added a fault the verdict missed),
    and the note names the --channels that searches the others."""
    lost = _archive(tmp_path / "a.csv", 0, 4, 3)
    _, doc = _run(capsys, tmp_path / "a.csv", tmp_path / "out", "--screen", "equivalent_model")
    assert not any(n.startswith("the other channels were searched again") for n in doc["notes"])
    assert any(f"--channels '!{lost}' searches the others there" in n for n in doc["notes"])
    assert all("searched_without" not in f["evidence"] for f in doc["faults"])


def test_the_report_does_not_draw_the_first_search_s_blind_residual_as_tested(tmp_path, capsys):
    """The tests of a second search's finding ran on that search's residuals, which the
    report does not keep: it drew the first search's (NaN where the fault is) as what
    was tested. A remark says so instead, and the tests figure is left out."""
    _archive(tmp_path / "a.csv", 0, 4, 3)
    _run(capsys, tmp_path / "a.csv", tmp_path / "out")
    html = (tmp_path / "out" / "report.html").read_text(encoding="utf-8")
    assert "Found by the second search, without s4" in html
    assert 'data-kind="tests"' not in html
