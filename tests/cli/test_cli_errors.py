"""Bad input and bad options found by a contract audit: each is exit 2 with one line that
names the file or the option (never a traceback, never exit 1, which means "fault
found"), checked before the work where it can be, and nothing left behind."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import one_line_error, run_cli, said

from analyzer.simulate import simulate_building
from analyzer.timeutil import iso_utc
from analyzer.writers import write_archive

REPO = Path(__file__).resolve().parents[2]
SAMPLES = REPO / "samples"
RATE = 200.0


def _csv(path: Path, seconds: float = 60.0, seed: int = 0, epoch: bool = False) -> Path:
    t, Y, names = simulate_building(n_floors=3, duration_s=seconds, seed=seed)
    t_ns = np.round(t * 1e9).astype(np.int64)
    start = "2026-03-01T12:00:00Z" if epoch else None
    write_archive(path, "csv", t_ns, {n: Y[:, j] for j, n in enumerate(names)}, start_iso=start)
    return path


@pytest.mark.parametrize("rate", ["inf", "nan", "-1"])
def test_rate_must_be_finite_and_positive(rate, tmp_path, capsys):
    code, _, err = run_cli(
        ["run", _csv(tmp_path / "a.csv"), "--out", tmp_path / "o", "--rate", rate], capsys
    )
    assert code == 2
    one_line_error(err, "--rate")


def test_rate_too_low_or_too_high_is_refused_before_aligning(tmp_path, capsys):
    src = _csv(tmp_path / "a.csv")
    code, _, err = run_cli(["export", src, "--out", tmp_path / "x.csv", "--rate", "1e-9"], capsys)
    assert code == 2
    one_line_error(err, "--rate", "too low")
    code, _, err = run_cli(["export", src, "--out", tmp_path / "x.csv", "--rate", "1e12"], capsys)
    assert code == 2
    one_line_error(err, "rows")
    assert not (tmp_path / "x.csv").exists()
    # one whose row count is no finite number (an OverflowError, "internal error", before)
    for cmd, out in (("export", tmp_path / "x.csv"), ("run", tmp_path / "o")):
        code, _, err = run_cli([cmd, src, "--out", out, "--rate", "1e308"], capsys)
        assert code == 2
        one_line_error(err, str(src), "e+30", "rows", "--rate")


def test_an_outlier_timestamp_is_an_error_not_a_disk_full_of_gaps(tmp_path, capsys):
    """One row at time 0 in an epoch-time log would span decades on the common clock."""
    t, Y, _ = simulate_building(n_floors=3, duration_s=30.0, seed=0)
    rows = [f"{1767225600.0 + ti:.3f},{y[0]},{y[1]},{y[2]}" for ti, y in zip(t, Y, strict=True)]
    src = tmp_path / "epoch.csv"
    src.write_text("\n".join(["epoch,s0,s1,s2", *rows, "0,1,2,3"]) + "\n")
    for argv in (
        ["run", src, "--out", tmp_path / "o"],
        ["export", src, "--out", tmp_path / "x.csv"],
    ):
        code, _, err = run_cli(argv, capsys)
        assert code == 2
        one_line_error(err, str(src), "timestamp", "the first sample of s0 lies", "outlier")
    assert not (tmp_path / "o").exists() and not (tmp_path / "x.csv").exists()


def test_files_far_apart_in_time_are_an_error_that_says_so(tmp_path, capsys):
    """Two records of one directory taken a month apart: one clock cannot hold them, and
    the error names the gap and what to do."""
    t, Y, _ = simulate_building(n_floors=3, duration_s=60.0, seed=0)
    for name, start in (("a.csv", 1767225600.0), ("b.csv", 1767225600.0 + 30 * 86400.0)):
        rows = [f"{start + ti:.3f},{y[0]},{y[1]},{y[2]}" for ti, y in zip(t, Y, strict=True)]
        (tmp_path / name).write_text("\n".join(["epoch,s0,s1,s2", *rows]) + "\n")
    code, _, err = run_cli(["run", tmp_path, "--out", tmp_path / "o"], capsys)
    assert code == 2
    one_line_error(err, "s0 has no sample for 30 days after 59.995 s", "analyzed one at a time")


@pytest.mark.parametrize("command", ["run", "export"])
def test_unwritable_out_is_refused_before_the_work(command, tmp_path, capsys):
    src = _csv(tmp_path / "a.csv")
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    out = blocker / ("sub" if command == "run" else "x.csv")
    t0 = time.perf_counter()
    code, _, err = run_cli([command, src, "--out", out], capsys)
    assert code == 2
    one_line_error(err, "--out")
    assert time.perf_counter() - t0 < 5.0  # refused up front, not after the analysis


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["run", "{csv}", "--out", ""], "argument --out: an empty path"),
        (["run", "", "--out", "{out}"], "argument INPUT: an empty path"),
        (["run", "{csv}", "--out", "{out}", "--config", ""], "argument --config: an empty"),
        (["run", "{csv}", "--out", "{out}", "--save-model", ""], "--save-model: an empty"),
        (["export", "{csv}", "--out", ""], "argument --out: an empty path"),
        (["inspect", " "], "argument INPUT: an empty path"),
        (["watch", "", "--out", "{out}", "--once"], "argument INBOX: an empty path"),
    ],
)
def test_an_empty_path_is_refused(argv, needle, tmp_path, capsys, monkeypatch):
    """CLI audit: ``run --out ''`` wrote report.html and findings.json into the current
    folder (``Path("")`` is "."), as an empty shell variable would; an empty input
    analyzed the current folder."""
    monkeypatch.chdir(tmp_path)
    csv = _csv(tmp_path / "a.csv", seconds=30.0)
    argv = [a.format(csv=csv, out=tmp_path / "o") for a in argv]
    code, _, err = run_cli(argv, capsys)
    assert code == 2 and needle in err and len(err.strip().splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv"]


def test_a_failed_run_leaves_no_empty_out_dir(tmp_path, capsys):
    src = tmp_path / "bad.mcap"
    src.write_bytes(b"\x89MCAP0\r\n" + b"\0" * 50)
    code, _, err = run_cli(["run", src, "--out", tmp_path / "o"], capsys)
    assert code == 2
    one_line_error(err, str(src))
    assert not (tmp_path / "o").exists()


def test_a_failed_run_says_that_out_holds_an_earlier_run_s_findings(tmp_path, capsys):
    """A failed run leaves ``--out`` as it was (the folder may be the user's): its
    error line says the findings there are not this run's."""
    src = _csv(tmp_path / "a.csv")
    out = tmp_path / "o"
    out.mkdir()
    (out / "findings.json").write_text("{}\n")
    os.utime(out / "findings.json", (time.time() - 60, time.time() - 60))
    code, _, err = run_cli(["run", src, "--out", out, "--train", "0:9999"], capsys)
    assert code == 2
    one_line_error(err, "--train", f"{out} keeps an earlier run's findings.json, not this run's")
    assert (out / "findings.json").read_text() == "{}\n"  # (nothing in it is deleted)
    code, _, err = run_cli(["run", src, "--out", tmp_path / "new", "--train", "0:9999"], capsys)
    assert code == 2 and "earlier run" not in err


def test_exact_channel_names_with_brackets_select_the_element(tmp_path, capsys):
    """``/data.data[4]`` is the contract's name of an array element: it selects it (as a
    shell pattern ``[4]`` would be a character class and match nothing)."""
    out = tmp_path / "x.csv"
    src = SAMPLES / "building_drift.bag"
    code, _, err = run_cli(["export", src, "--out", out, "--channels", "/data.data[4]"], capsys)
    assert code == 0, err
    assert out.read_text().splitlines()[0] == '"time","/data.data[4]"'


@pytest.mark.parametrize(
    "option,needle",
    [
        (["--detectors", "nope"], "--detectors"),
        (["--train", "abc"], "--train"),
        (["--train", "5:2"], "--train"),
    ],
)
def test_watch_refuses_bad_options_up_front(option, needle, tmp_path, capsys):
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    _csv(inbox / "a.csv")
    code, _, err = run_cli(["watch", inbox, "--out", tmp_path / "rep", "--once", *option], capsys)
    assert code == 2
    one_line_error(err, needle)
    assert not (tmp_path / "rep" / "index.json").exists()  # no archive was recorded


@pytest.mark.parametrize(
    "section,text,needle",
    [
        ("equivalent_model", "bogus_option = 7", "'bogus_option'"),
        ("ar_kalman_bank", "ordr = 7", "'ordr'"),
        ("error_function", 'approach = "sideways"', "sideways"),
    ],
)
def test_config_typos_in_any_detector_section_are_errors(section, text, needle, tmp_path, capsys):
    """Even for a detector that does not run, and naming the file and the section."""
    cfg = tmp_path / "c.toml"
    cfg.write_text(f"[detectors.{section}]\n{text}\n")
    argv = ["run", _csv(tmp_path / "a.csv"), "--out", tmp_path / "o", "--config", cfg]
    code, _, err = run_cli([*argv, "--detectors", "detection_filter"], capsys)
    assert code == 2
    line = one_line_error(err, str(cfg), f"[detectors.{section}]", needle)
    assert "__init__" not in line and "keyword argument" not in line


def test_config_groups_sharing_a_channel_are_an_error(tmp_path, capsys):
    """Each detector models a [[group]] on its own: a channel in two would be analyzed
    (and reported) twice, under two models. The error names both groups and the channel."""
    cfg = tmp_path / "c.toml"
    cfg.write_text(
        '[[group]]\nname = "east"\nchannels = ["s0", "s1"]\n'
        '[[group]]\nname = "west"\nreference = ["s2"]\nuncertain = ["s1"]\n'
    )
    argv = ["run", _csv(tmp_path / "a.csv"), "--out", tmp_path / "o", "--config", cfg]
    code, _, err = run_cli(argv, capsys)
    assert code == 2
    one_line_error(err, str(cfg), "'west'", "'east'", "s1")
    assert not (tmp_path / "o" / "findings.json").exists()


def test_an_ar_order_the_bank_cannot_afford_is_refused(tmp_path, capsys):
    """order 500 on 3 channels (1500 states) ran for minutes without a word: asked for
    explicitly, the bank is an error naming the setting; by default it is skipped with the
    reason and the other detectors run."""
    cfg = tmp_path / "c.toml"
    cfg.write_text("[detectors.ar_kalman_bank]\norder = 500\n")
    src = _csv(tmp_path / "a.csv")
    argv = ["run", src, "--out", tmp_path / "o", "--config", cfg]
    code, _, err = run_cli([*argv, "--detectors", "ar_kalman_bank"], capsys)
    assert code == 2
    one_line_error(err, "ar_kalman_bank", "order 500", "1500 states", "lower")
    code, _, err = run_cli(argv, capsys)
    assert code in (0, 1)
    skipped = json.loads((tmp_path / "o" / "findings.json").read_text())["skipped_detectors"]
    assert "order 500" in skipped["ar_kalman_bank"]
    # a criterion's search is bounded by the limit instead: the bank runs
    cfg.write_text('[detectors.ar_kalman_bank]\norder = "bic"\nmax_order = 500\n')
    code, _, err = run_cli([*argv[:-2], "--out", tmp_path / "o2", "--config", cfg], capsys)
    assert code in (0, 1), err
    doc = json.loads((tmp_path / "o2" / "findings.json").read_text())
    assert "ar_kalman_bank" not in doc["skipped_detectors"]


def test_weak_findings_of_a_lenient_false_alarm_rate_are_named(tmp_path, capsys):
    """A false-alarm rate of 5e-2 per sample reports chance peaks of healthy data, with
    confidences of 0.0: a note names those below 0.05 and the rate, and only those. (At
    1e-2 this record's chance peaks were the detection filter's, each confirmed by one
    other filter over its threshold; most other filters must leave their directions now.)"""
    cfg = tmp_path / "c.toml"
    cfg.write_text("[thresholds]\nfalse_alarm_rate = 5e-2\n")
    src = _csv(tmp_path / "a.csv", seconds=600.0, seed=1)
    code, _, _ = run_cli(["run", src, "--out", tmp_path / "o", "--config", cfg], capsys)
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    weak = [f for f in doc["faults"] if f["confidence"] < 0.05]
    assert code == 1 and weak  # the healthy record's chance peaks
    notes = [n for n in doc["notes"] if "confidence below 0.05" in n]
    assert len(notes) == 1 and notes[0].startswith(f"{len(weak)} of {len(doc['faults'])} ")
    assert "false-alarm rate of 0.05" in notes[0]
    for f in weak[:5]:
        assert f"{f['channel']} at {f['onset_s']:.1f} s" in notes[0]
    cfg.write_text("[thresholds]\nfalse_alarm_rate = 1e-6\n")  # the default: no such note
    run_cli(["run", src, "--out", tmp_path / "o2", "--config", cfg], capsys)
    doc = json.loads((tmp_path / "o2" / "findings.json").read_text())
    assert not [n for n in doc["notes"] if "confidence below" in n]


def test_config_train_window_after_the_data(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text("[train]\nstart = 100.0\nend = 200.0\n")
    code, _, err = run_cli(
        ["run", _csv(tmp_path / "a.csv"), "--out", tmp_path / "o", "--config", cfg], capsys
    )
    assert code == 2
    one_line_error(err, str(cfg), "[train]", "after the data ends")


def test_a_detector_named_twice_runs_once(tmp_path, capsys):
    out = tmp_path / "o"
    src = _csv(tmp_path / "a.csv")
    code, _, err = run_cli(
        ["run", src, "--out", out, "--detectors", "ar_kalman_bank,ar_kalman_bank"], capsys
    )
    assert code in (0, 1), err
    doc = json.loads((out / "findings.json").read_text())
    assert [d["name"] for d in doc["detectors"]] == ["ar_kalman_bank"]


def test_duration_is_samples_over_rate(tmp_path, capsys):
    """12000 samples at 200 Hz last 60 s (as the contract's example: 36000 at 200 Hz,
    180 s), not 59.995; the default training window is 20 % of that."""
    out = tmp_path / "o"
    code, _, err = run_cli(
        [
            "run",
            _csv(tmp_path / "a.csv", seconds=60.0),
            "--out",
            out,
            "--detectors",
            "ar_kalman_bank",
        ],
        capsys,
    )
    assert code in (0, 1), err
    doc = json.loads((out / "findings.json").read_text())
    assert doc["duration_s"] == pytest.approx(60.0, abs=1e-9)
    assert doc["train"]["end_s"] == pytest.approx(12.0, abs=1e-9)


def test_iso_times_round_to_the_millisecond():
    base = 1767225600 * 10**9  # 2026-01-01T00:00:00Z
    assert iso_utc(base + 15_961_800_000) == "2026-01-01T00:00:15.962Z"
    assert iso_utc(base + 15_961_200_000) == "2026-01-01T00:00:15.961Z"
    assert iso_utc(base + 59_999_600_000) == "2026-01-01T00:01:00.000Z"


def test_finding_onset_agrees_with_onset_s(tmp_path, capsys):
    out = tmp_path / "o"
    code, _, err = run_cli(["run", SAMPLES / "building_drift.bag", "--out", out], capsys)
    assert code == 1, err
    doc = json.loads((out / "findings.json").read_text())
    start = doc["start"]
    for f in doc["faults"]:
        base = np.datetime64(start.rstrip("Z"), "ms")
        expect = base + np.timedelta64(int(round(f["onset_s"] * 1000)), "ms")
        assert f["onset"] == str(expect) + "Z"


def test_inspect_of_an_unreadable_input_is_an_input_error(tmp_path, capsys):
    src = tmp_path / "head.mcap"
    src.write_bytes((SAMPLES / "building_additive.mcap").read_bytes()[:100])
    code, _, err = run_cli(["inspect", src], capsys)
    assert code == 2
    one_line_error(err, str(src))


def test_truncated_mcap_counts_the_messages_it_read(tmp_path, capsys):
    src = tmp_path / "trunc.mcap"
    data = (SAMPLES / "building_additive.mcap").read_bytes()
    src.write_bytes(data[: len(data) * 2 // 3])
    code, out, err = run_cli(["inspect", src, "--json"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    (errors,) = [i["errors"] for i in doc["inputs"]]
    read = sum(c["samples"] for c in doc["channels"])
    assert read > 0 and errors and f"the {read} messages before it were read" in errors[0]


def test_error_function_without_groups_reports_one_fault(tmp_path, capsys):
    """Without [[group]] the error functions cannot isolate: the one fault of the sample
    is one entry (on the strongest alarm, with the other sensors as candidates)."""
    out = tmp_path / "o"
    argv = [
        "run",
        SAMPLES / "building_additive.mcap",
        "--out",
        out,
        "--detectors",
        "error_function",
    ]
    code, _, err = run_cli(argv, capsys)
    assert code == 1, err
    doc = json.loads((out / "findings.json").read_text())
    assert len(doc["faults"]) == 1
    ev = doc["faults"][0]["evidence"]["by_detector"]["error_function"]
    assert ev["isolated"] is False and doc["faults"][0]["channel"] in ev["candidates"]
    assert doc["faults"][0]["confidence"] <= 0.5


def test_sigterm_stops_cleanly_without_leftovers(tmp_path):
    """``timeout``/``kill`` (SIGTERM) unwinds like Ctrl-C: exit 130, no scratch files, no
    half-written outputs.

    The signal goes as soon as the run's own scratch directory (``analyzer-*``) is there,
    about 1.3 s before a 10-minute archive's run ends. A run that ends before the signal
    could go (this process kept off the CPU that long on a loaded machine: seen once in
    CI, exit 0 and nothing on stderr) tested nothing: then again, on an archive 4x as
    long."""
    for attempt, seconds in enumerate((600.0, 2400.0)):
        case = tmp_path / f"try{attempt}"
        case.mkdir()
        src = _csv(case / "long.csv", seconds=seconds)
        scratch = case / "tmp"
        scratch.mkdir()
        env = {**os.environ, "TMPDIR": str(scratch)}
        proc = subprocess.Popen(
            [sys.executable, "-m", "analyzer", "run", str(src), "--out", str(case / "o")],
            env=env,
            stderr=subprocess.PIPE,
            text=True,
        )
        deadline = time.monotonic() + 60
        while (
            not any(p.name.startswith("analyzer-") for p in scratch.iterdir())
            and proc.poll() is None
            and time.monotonic() < deadline
        ):
            time.sleep(0.01)
        sent = proc.poll() is None
        if sent:
            proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
        if not sent:
            assert proc.returncode == 0, err  # it ended before the signal: once more
            continue
        assert proc.returncode == 130, err
        assert "interrupted" in err and "Traceback" not in err
        assert not any(scratch.iterdir()), [str(p) for p in scratch.rglob("*")]
        assert not (case / "o").exists()
        return
    pytest.fail("the run ended before SIGTERM could be sent, twice")


def test_a_training_window_of_a_few_samples_names_train(tmp_path, capsys):
    """Sparse data (NAB: one value every 30 min) leaves the default 10 minutes a sample or
    two: the error says so and names --train (not "constant or empty")."""
    rng = np.random.default_rng(0)
    rows = [f"{k * 1800.0},{rng.normal()},{rng.normal()},{rng.normal()}" for k in range(500)]
    src = tmp_path / "sparse.csv"
    src.write_text("\n".join(["time,a,b,c", *rows]) + "\n")
    code, _, err = run_cli(["run", src, "--out", tmp_path / "o"], capsys)
    assert code == 2
    line = one_line_error(err, str(src), "--train", "holds 1 sample")
    assert "constant" not in line


def test_samples_crowding_onto_fewer_ticks_are_noted():
    """Log times written in batches (cart-pole kinda_works.mcap: 9,989 samples on 931
    distinct times): the alignment keeps one value per tick, and a note says so."""
    from analyzer.pipeline import _crowded_channels
    from analyzer.store import ChannelInfo

    ns = 10**9
    batched = ChannelInfo("a", 9989, 0, 93 * ns, 10.0, 0, 9989, -1.0, 1.0)
    regular = ChannelInfo("b", 931, 0, 93 * ns, 10.0, 0, 931, -1.0, 1.0)
    faster = ChannelInfo("c", 18601, 0, 93 * ns, 200.0, 0, 18601, -1.0, 1.0)  # decimated
    notes = _crowded_channels([batched, regular, faster], ["a", "b", "c"], 10.0)
    assert len(notes) == 1
    assert notes[0].startswith("a: 9,989 samples on only about 931 distinct log times")
    assert _crowded_channels([batched], ["b"], 10.0) == []  # not analyzed: not noted


def test_a_full_scratch_disk_is_a_one_line_error(tmp_path, capsys, monkeypatch):
    """A long archive's memory-mapped scratch files reserve their space when made: with
    no room left the run stops with one line naming the file and TMPDIR (exit 2), not a
    SIGBUS at the first store into a page the disk cannot hold."""
    import errno

    import analyzer.pipeline as pl

    def full(fd, offset, size):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(pl, "MATERIALIZE_IN_MEMORY", 1000)  # any archive is "long"
    monkeypatch.setattr(os, "posix_fallocate", full)
    code, _, err = run_cli(
        ["run", SAMPLES / "building_additive.mcap", "--out", tmp_path / "o"], capsys
    )
    assert code == 2
    one_line_error(err, "aligned.npy", "No space left on device", "TMPDIR")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_a_full_disk_while_signals_go_to_files_is_a_one_line_error(
    tmp_path, capsys, monkeypatch, jobs
):
    """A long archive's finished detector moves its signals to files (on threads, on the
    pool while the next detector runs): a disk that fills up then still stops the run
    with one line naming the file (exit 2), whichever thread met it."""
    import errno

    import analyzer.detector_runs as runs
    import analyzer.pipeline as pl

    def full(result, spill_dir, tag=""):
        raise OSError(errno.ENOSPC, "No space left on device", str(spill_dir / "x.npy"))

    monkeypatch.setattr(pl, "MATERIALIZE_IN_MEMORY", 1000)  # any archive is "long"
    monkeypatch.setattr(runs, "_spill", full)
    code, _, err = run_cli(
        ["run", SAMPLES / "building_additive.mcap", "--out", tmp_path / "o", "--jobs", jobs],
        capsys,
    )
    assert code == 2
    one_line_error(err, "x.npy", "No space left on device")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("code", ["inf", "-1e300", "1e90", "-5e38"])
def test_an_infinite_value_is_a_gap_not_a_fault(code, tmp_path, capsys):
    """One ``inf`` cell (a logger's overrange code) entered the equivalent model's
    observers as the largest float: a "drift" of 1e296 per second on another channel,
    a NaN confidence, and findings.json could not be written (an internal error); a
    ``1e300`` was a "drift" too. Now the aligned value is a gap, named in the notes: the
    faults of the same file with ``nan`` in that cell. So is a reading beyond float32's
    range, where the detectors keep their residuals (1e90 left every residual figure
    blank and the innovation tests empty)."""
    t, Y, names = simulate_building(n_floors=3, duration_s=60.0, seed=0)
    t_ns = np.round(t * 1e9).astype(np.int64)
    Y[len(t) // 2, 0] = np.inf
    write_archive(tmp_path / "inf.csv", "csv", t_ns, {n: Y[:, j] for j, n in enumerate(names)})
    text = (tmp_path / "inf.csv").read_text()
    assert text.count(",inf") == 1
    (tmp_path / "bad.csv").write_text(text.replace(",inf", f",{code}"))
    (tmp_path / "nan.csv").write_text(text.replace(",inf", ",nan"))
    docs, codes = [], []
    for name in ("bad", "nan"):
        out = tmp_path / f"o{name}"
        code, _, err = run_cli(["run", tmp_path / f"{name}.csv", "--out", out], capsys)
        assert code in (0, 1), err
        codes.append(code)
        docs.append(json.loads((out / "findings.json").read_text()))
    assert docs[0]["notes"] == [
        "infinite or absurd values (beyond 1e30: an overrange or error code?) taken as "
        f"gaps: {names[0]} (1)",
        *docs[1]["notes"],
    ]
    assert codes[0] == codes[1]
    # (a "nan" cell is no sample, as a blank one: the aligner may bridge it where an
    # overrange value stays a gap, so the tests' statistics differ a little, not the faults)
    same = [[(f["channel"], f["type"], round(f["onset_s"], 1)) for f in d["faults"]] for d in docs]
    assert same[0] == same[1]
    assert not any(f["channel"] == names[0] for f in docs[0]["faults"])


def test_a_channel_at_one_value_through_the_training_window_is_left_out(tmp_path, capsys):
    """A sensor at rest at one value through the healthy window but for one sample (the
    window's last row) is no flat channel by its spread, yet it made the bank's and the
    detection filter's regressions singular: both were skipped and an offset on another
    sensor went unreported. Now it is left out with a note, and the offset is found."""
    t, Y, names = simulate_building(n_floors=3, duration_s=60.0, seed=1)
    n = len(t)
    train_rows = int(0.2 * n)
    Y[:train_rows, 2] = 0.5  # the first 20 %: the default window, but for its last row
    Y[n // 2 :, 0] += 3.0 * Y[:train_rows, 0].std()
    t_ns = np.round(t * 1e9).astype(np.int64)
    src = tmp_path / "rest.csv"
    write_archive(src, "csv", t_ns, {c: Y[:, j] for j, c in enumerate(names)})
    code, _, err = run_cli(["run", src, "--out", tmp_path / "o"], capsys)
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    assert code == 1, err
    assert (
        "constant (or one value in 99 % of the samples) in the training window, "
        f"not analyzed: {names[2]}" in doc["notes"]
    )
    assert "ar_kalman_bank" not in doc["skipped_detectors"]
    assert [f["channel"] for f in doc["faults"]][:1] == [names[0]]


@pytest.mark.parametrize("kind", ["elapsed", "row counter"])
def test_a_counter_or_second_clock_is_left_out(tmp_path, capsys, kind):
    """A column that steps by the same amount every sample (``Elapsed Time`` beside
    ``time``, a row counter, a pandas index written as a column) made the bank's and the
    detection filter's regressions singular (both skipped) and the equivalent model
    reported it as a drift: it is left out with a note, and an offset on a sensor is
    found by all three."""
    t, Y, names = simulate_building(n_floors=3, duration_s=120.0, seed=1)
    n = len(t)
    Y[n // 2 :, 0] += 3.0 * Y[: n // 5, 0].std()
    ramp = t + 5.0 if kind == "elapsed" else np.arange(n, dtype=np.float64)
    t_ns = np.round(t * 1e9).astype(np.int64)
    src = tmp_path / "ramp.csv"
    write_archive(src, "csv", t_ns, {"ramp": ramp, **{c: Y[:, j] for j, c in enumerate(names)}})
    code, _, err = run_cli(["run", src, "--out", tmp_path / "o"], capsys)
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    assert code == 1, err
    assert (
        "a counter or clock in the training window (the same step from each sample to the "
        "next), not analyzed: ramp" in doc["notes"]
    )
    assert set(doc["skipped_detectors"]) <= {"error_function"}
    assert [(f["channel"], f["type"]) for f in doc["faults"]] == [(names[0], "additive")]


def test_what_a_training_window_leaves_unsearched_is_noted(tmp_path, capsys):
    """Faults are searched from the training window's end on: an offset before a window
    that starts later went unreported without a word, and so did everything when the
    window reached the end of the data."""
    t, Y, names = simulate_building(n_floors=3, duration_s=60.0, seed=1)
    Y[(t > 10) & (t < 20), 0] += 5.0 * Y[:, 0].std()
    src = tmp_path / "early.csv"
    write_archive(
        src, "csv", np.round(t * 1e9).astype(np.int64), {c: Y[:, j] for j, c in enumerate(names)}
    )
    code, _, err = run_cli(["run", src, "--out", tmp_path / "a", "--train", "40:50"], capsys)
    assert code in (0, 1), err
    notes = json.loads((tmp_path / "a" / "findings.json").read_text())["notes"]
    assert (
        "the 40 s before the training window are not searched for faults (the search runs "
        "from the window's end): a window at the start covers them" in notes
    )
    # a window over all the data leaves nothing to search: a refusal, not a healthy exit 0
    # (a note in findings.json was all it said)
    code, _, err = run_cli(["run", src, "--out", tmp_path / "b", "--train", "0:60"], capsys)
    assert code == 2
    one_line_error(err, "--train", "covers all the data")


def test_an_analysis_written_into_its_archive_folder_is_not_read_back(tmp_path, capsys):
    """``--out`` the archive's own folder with ``--corrected``: the next run of that
    folder read ``corrected.csv`` as data (its times from 0 beside the archive's epoch
    times: a clock of 20 000 days, exit 2). Now the analyzer's output beside its
    ``findings.json`` is not an input, and a run that writes no ``corrected.csv`` says
    that the one in its folder is an earlier run's."""
    t, Y, names = simulate_building(n_floors=3, duration_s=60.0, seed=1)
    Y[len(t) // 2 :, 0] += 5.0 * Y[:, 0].std()
    folder = tmp_path / "archive"
    folder.mkdir()
    write_archive(
        folder / "part.mcap",
        "mcap",
        np.round(t * 1e9).astype(np.int64),
        {c: Y[:, j] for j, c in enumerate(names)},
        start_iso="2026-03-01T12:00:00Z",
    )
    code, _, err = run_cli(["run", folder, "--out", folder, "--corrected"], capsys)
    assert code == 1, err
    assert (folder / "corrected.csv").is_file()
    first = json.loads((folder / "findings.json").read_text())
    code, _, err = run_cli(["run", folder, "--out", tmp_path / "again"], capsys)
    assert code == 1, err
    again = json.loads((tmp_path / "again" / "findings.json").read_text())
    assert [i["path"] for i in again["inputs"]] == [str(folder / "part.mcap")]
    assert f"{folder / 'corrected.csv'} not read: the analyzer's output beside " in " ".join(
        again["notes"]
    )
    assert [f["channel"] for f in again["faults"]] == [f["channel"] for f in first["faults"]]
    code, _, err = run_cli(["run", folder, "--out", folder], capsys)
    assert code == 1, err
    notes = json.loads((folder / "findings.json").read_text())["notes"]
    assert any("corrected.csv is not this run's" in n for n in notes)


def test_a_channel_that_stops_early_is_noted(tmp_path, capsys):
    """A sensor that stops reporting halfway (its samples cut from the file) left the
    detectors that model it with the others blind there without a word."""
    t, Y, names = simulate_building(n_floors=3, duration_s=60.0, seed=2)
    channels = {c: Y[:, j] for j, c in enumerate(names)}
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(tmp_path / "whole.csv", "csv", t_ns, channels)
    text = (tmp_path / "whole.csv").read_text().splitlines()
    header, rows = text[0], text[1:]
    cut = [
        r if k < len(rows) // 2 else ",".join(r.split(",")[:-1] + [""]) for k, r in enumerate(rows)
    ]
    (tmp_path / "cut.csv").write_text("\n".join([header, *cut]) + "\n")
    for name in ("whole", "cut"):
        code, _, err = run_cli(["run", tmp_path / f"{name}.csv", "--out", tmp_path / name], capsys)
        assert code in (0, 1), err
    whole = json.loads((tmp_path / "whole" / "findings.json").read_text())["notes"]
    cut_notes = json.loads((tmp_path / "cut" / "findings.json").read_text())["notes"]
    assert not any("has no reading in" in n for n in whole)
    last = names[-1]
    assert any(
        n.startswith(f"{last} has no reading in its last 30 s (after 30 s) of the record")
        and "too few channels would be left to search the others without it" in n
        for n in cut_notes
    ), cut_notes
    # two channels left are too few to search again (the bank isolates nothing with two)
    assert not any(n.startswith("the other channels were searched again") for n in cut_notes)


def test_a_run_that_goes_on_says_what_went_wrong_with_its_inputs(tmp_path, capsys):
    """A truncated file is analyzed up to the damage (exit 0 or 1), and what was lost
    was only in findings.json and the report: a run from a terminal said nothing."""
    t, Y, names = simulate_building(n_floors=6, duration_s=240.0, seed=1)
    src = tmp_path / "whole.mcap"
    write_archive(
        src, "mcap", np.round(t * 1e9).astype(np.int64), {c: Y[:, j] for j, c in enumerate(names)}
    )
    data = src.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: 3 * len(data) // 4])
    code, _, err = run_cli(["run", src, "--out", tmp_path / "a"], capsys)
    assert code in (0, 1) and said(err) == []
    code, _, err = run_cli(["run", cut, "--out", tmp_path / "b"], capsys)
    assert code in (0, 1), err
    errors = json.loads((tmp_path / "b" / "findings.json").read_text())["inputs"][0]["errors"]
    assert errors and said(err) == [f"analyzer: warning: {cut}: {e}" for e in errors]


@pytest.mark.parametrize("debug", ["", "1"])
def test_an_internal_error_exits_2_with_or_without_its_traceback(
    tmp_path, capsys, monkeypatch, debug
):
    """A bug is one line and exit 2, never 1 ("fault found"); ANALYZER_DEBUG=1 adds the
    traceback, and the exit code stays 2 (re-raising it made Python exit 1)."""
    import analyzer.pipeline as pipeline

    def bug(*args, **kwargs):
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(pipeline, "analyze", bug)
    monkeypatch.setenv("ANALYZER_DEBUG", debug)
    code, _, err = run_cli(["run", _csv(tmp_path / "a.csv"), "--out", tmp_path / "o"], capsys)
    assert code == 2
    last = err.strip().splitlines()[-1]
    assert last.startswith("analyzer: error: internal error: ZeroDivisionError")
    assert ("Traceback (most recent call last)" in err) == bool(debug)


def test_readings_near_1e90_do_not_crash_the_classifier():
    """Readings of about 1e90 (given to the classifier: the store takes them as gaps) overflowed the
    gain's squared sums, and the scaled gain divided by zero: an internal error at the end
    of a run that had found a fault."""
    from analyzer.diagnosis import classify

    rng = np.random.default_rng(3)
    y = 1e90 * (1.0 + 0.01 * rng.standard_normal(4000))
    f = 5.0 + 0.3 * rng.standard_normal(4000)
    c = classify(f, y, 0.3, 100.0)
    assert c.type.value == "additive" and c.magnitude["offset"] == pytest.approx(5.0, abs=0.05)


def test_export_never_writes_over_or_into_its_inputs(tmp_path, capsys):
    """``export x.csv --out x.csv`` read the file, then replaced it by its export (absolute
    times turned relative), without a word; an export into an archive's folder is read
    with the archive the next time."""
    src = _csv(tmp_path / "a.csv", epoch=True)
    before = src.read_bytes()
    code, _, err = run_cli(["export", src, "--out", src], capsys)
    assert code == 2 and src.read_bytes() == before
    one_line_error(err, f"--out: {src} is an input", "never modified")
    folder = tmp_path / "archive"
    folder.mkdir()
    _csv(folder / "part.csv")
    code, _, err = run_cli(["export", folder, "--out", folder / "all.csv"], capsys)
    assert code == 2 and sorted(p.name for p in folder.iterdir()) == ["part.csv"]
    one_line_error(err, "inside the input", "never modified")


def test_a_fault_after_a_gap_in_the_data_says_it_may_have_begun_in_the_gap(tmp_path, capsys):
    """An offset from 205 s on a record missing 200-260 s was reported from 260.78 s
    without a word (a sensor that comes back from an outage with an offset)."""
    t, Y, names = simulate_building(n_floors=4, duration_s=600.0, seed=2)
    Y[t >= 205.0, 1] += 4.0 * Y[:, 1].std()
    keep = (t < 200.0) | (t >= 260.0)
    src = tmp_path / "outage.csv"
    t_ns = np.round(t[keep] * 1e9).astype(np.int64)
    write_archive(src, "csv", t_ns, {c: Y[keep, j] for j, c in enumerate(names)})
    code, _, err = run_cli(["run", src, "--out", tmp_path / "o"], capsys)
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    assert code == 1, err
    (fault,) = doc["faults"]
    assert fault["channel"] == names[1] and fault["onset_s"] >= 260.0
    late = fault["onset_s"] - 260.0
    assert late > 0.1  # the detectors settle again after the gap
    # (the note said "its onset is where the data resumed" of an onset 0.78 s later)
    assert (
        f"the additive fault on {names[1]} found from {fault['onset_s']:.1f} s follows a gap "
        "in its data (200.0-260.0 s): it may have begun during the gap (found "
        f"{late:.2f} s after the data resumed, while the detectors settle again after a gap: "
        "it may have been there from the resumption)" in doc["notes"]
    )
    assert fault["evidence"]["after_gap_s"] == [200.0, 260.0]


def test_an_iso_train_window_before_the_data_says_where_the_data_starts(tmp_path, capsys):
    """It said "must satisfy 0 <= START < END" to a user who gave no seconds."""
    src = _csv(tmp_path / "a.csv", epoch=True)  # from 2026-03-01T12:00:00Z
    train = "2026-03-01T11:00:00Z:2026-03-01T12:00:10Z"
    code, _, err = run_cli(["run", src, "--out", tmp_path / "o", "--train", train], capsys)
    assert code == 2
    one_line_error(err, "--train", "3600.000 s before the data", "2026-03-01T12:00:00.000Z")


def test_channels_never_present_together_are_named_when_nothing_can_run(tmp_path, capsys):
    """A channel recorded 0-100 s and four others from 100 s: the error advised a longer
    --train, though the channels are simply never present at the same time."""
    t, Y, names = simulate_building(n_floors=4, duration_s=700.0, seed=1)
    early, late = t < 100.0, t >= 100.0
    folder = tmp_path / "apart"
    folder.mkdir()
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(
        folder / "a.mcap",
        "mcap",
        t_ns[early],
        {"early": Y[early, 0]},
        start_iso="2026-01-01T00:00:00Z",
    )
    write_archive(
        folder / "b.mcap",
        "mcap",
        t_ns[late],
        {c: Y[late, j] for j, c in enumerate(names)},
        start_iso="2026-01-01T00:01:40Z",  # 100 s later, as its first sample
    )
    code, _, err = run_cli(["run", folder, "--out", tmp_path / "o"], capsys)
    assert code == 2
    one_line_error(err, "row(s) hold every channel", "0.0-100.0 s", "--channels")


def test_usage_errors_say_analyzer_once_and_name_the_command(tmp_path, capsys):
    """'analyzer: error: analyzer: argument command: ...' and '... analyzer:
    unrecognized arguments: --bogus' (for an option of ``run``) before."""
    code, _, err = run_cli(["demo"], capsys)
    assert code == 2
    line = one_line_error(err, "invalid choice: 'demo'")
    assert line.startswith("analyzer: error: argument command")
    src = _csv(tmp_path / "a.csv", seconds=5.0)
    code, _, err = run_cli(["run", src, "--out", tmp_path / "o", "--bogus"], capsys)
    assert code == 2
    assert one_line_error(err) == "analyzer: error: run: unrecognized arguments: --bogus"
    code, _, err = run_cli(["run", src, "--out", tmp_path / "o", "--jobs", "0"], capsys)
    assert one_line_error(err).startswith("analyzer: error: run: argument --jobs: must be >= 1")
    assert not (tmp_path / "o").exists()


def test_a_reader_that_closes_stdout_ends_the_listing_quietly(tmp_path):
    """``analyzer inspect X | head -1``: 'analyzer: error: Broken pipe', exit 2, before;
    now nothing on stderr and the status of a process SIGPIPE ended (128 + 13)."""
    wide = tmp_path / "wide.csv"
    names = [f"c{k}" for k in range(3000)]  # a listing far beyond a pipe's buffer
    rows = ["time," + ",".join(names)] + [
        f"{i}," + ",".join(str((i * k) % 7) for k in range(3000)) for i in range(5)
    ]
    wide.write_text("\n".join(rows) + "\n")
    proc = subprocess.Popen(
        [sys.executable, "-m", "analyzer", "inspect", str(wide)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.readline()
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141, err
    assert err == ""


def test_an_unknown_option_before_the_command_is_the_top_parser_s(capsys):
    code, _, err = run_cli(["--bogus", "run", "x", "--out", "o"], capsys)
    assert code == 2
    assert one_line_error(err) == "analyzer: error: unrecognized arguments: --bogus"


def test_a_broken_pipe_not_stdout_s_is_an_error(monkeypatch, capsys):
    """Exit 141 in silence only for stdout's own broken pipe: one raised in a library
    (a worker's pipe) while stdout happened to be closed too is an error, exit 2."""
    from analyzer import cli

    def worker_pipe(args):
        raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(cli, "_stdout_gone", lambda: True)
    monkeypatch.setitem(cli.COMMANDS, "inspect", worker_pipe)  # raised outside analyzer/
    code, _, err = run_cli(["inspect", str(SAMPLES / "building_additive.mcap")], capsys)
    assert code == 2
    one_line_error(err, "BrokenPipeError")


@pytest.mark.parametrize(
    ("extra", "needle"),
    [
        (["--channels", "!*"], "--channels: '!*' leaves no channel to analyze"),
        (["--channels", "s0,!s0"], "--channels: 's0,!s0' leaves no channel to analyze"),
        (["--save-model", "{afile}/m"], "--save-model: {afile} is not a directory"),
        (["--msg-path", "{afile}"], "--msg-path: {afile}: not a directory"),
    ],
)
def test_errors_say_what_is_wrong(extra, needle, tmp_path, capsys, monkeypatch):
    """CLI audit: '!*' said "all selected channels are constant or empty", and a file
    where a folder was expected "does not exist" / "no such directory"."""
    # (--msg-path sets ANALYZER_MSG_PATH for the process: put back what it was after)
    monkeypatch.setenv("ANALYZER_MSG_PATH", os.environ.get("ANALYZER_MSG_PATH", ""))
    afile = tmp_path / "afile"
    afile.write_text("x")
    csv = _csv(tmp_path / "a.csv", seconds=30.0)
    extra = [a.format(afile=afile) for a in extra]
    code, _, err = run_cli(["run", csv, "--out", tmp_path / "o", *extra], capsys)
    assert code == 2 and needle.format(afile=afile) in err, err


@pytest.mark.parametrize("as_json", [True, False])
def test_a_stdout_that_cannot_be_written_is_named(as_json, tmp_path, capsys, monkeypatch):
    """``analyzer inspect X --json > FILE`` on a full disk (or ``> /dev/full``) ended
    with ``analyzer: error: No space left on device``, naming nothing: the contract's
    error line names the file, here stdout."""
    import errno

    class Full:
        def write(self, text: str) -> int:
            raise OSError(errno.ENOSPC, "No space left on device")

        def flush(self) -> None:
            raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(sys, "stdout", Full())
    argv = ["inspect", _csv(tmp_path / "a.csv", seconds=5.0)] + (["--json"] if as_json else [])
    code, _, err = run_cli(argv, capsys)
    assert code == 2
    one_line_error(err, "stdout: No space left on device")


@pytest.mark.parametrize(
    "option, value, said",
    [
        ("--train", "-5:10", "--train: the window '-5:10' must satisfy 0 <= START < END"),
        ("--train", "-0.5:-0.1", "must satisfy 0 <= START < END"),
        ("--rate", "-1e3", "--rate: must be a finite number > 0, got '-1e3'"),
        ("--rate", "-inf", "--rate: must be a finite number > 0, got '-inf'"),
        ("--channels", "-x", "--channels: pattern '-x' matches no channel"),
    ],
)
def test_a_value_starting_with_a_dash_is_the_options_value(option, value, said, tmp_path, capsys):
    """argparse takes a word starting with ``-`` for an option unless it is a negative
    number of its own pattern (``-5``, not ``-5:10`` or ``-1e3``): ``--train -5:10``
    said ``argument --train: expected one argument``, which is not what is wrong. The
    value is now checked as any other, and the line says what is wrong with it."""
    a = _csv(tmp_path / "a.csv", seconds=5.0)
    code, _, err = run_cli(["run", a, "--out", tmp_path / "o", option, value], capsys)
    assert code == 2
    one_line_error(err, said)
    assert not (tmp_path / "o").exists()


def test_an_option_without_its_value_is_still_named(tmp_path, capsys):
    """The option a value starting with ``-`` is given to must take a value, and the
    word must be no option of the command (``-h``): those are errors as before."""
    a = _csv(tmp_path / "a.csv", seconds=5.0)
    for argv in (["--train", "-h"], ["--channels", "--rate", "5"], ["--train"]):
        code, _, err = run_cli(["run", a, "--out", tmp_path / "o", *argv], capsys)
        assert code == 2
        one_line_error(err, f"argument {argv[0]}: expected one argument")
