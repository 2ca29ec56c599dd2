"""The command line against CONTRACT.md: commands, exit codes, one-line errors."""

from __future__ import annotations

import hashlib
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_helpers import one_line_error, run_cli

from analyzer.cli import main
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

REPO = Path(__file__).resolve().parents[2]
SAMPLES = REPO / "samples"
RATE = 200.0


def _building_csv(
    path: Path, fault: str | None = None, seconds: float = 60.0, seed: int = 0
) -> Path:
    t, Y, names = simulate_building(n_floors=4, duration_s=seconds, seed=seed)
    if fault:
        Y[:, 2] = inject_fault(
            Y[:, 2],
            RATE,
            fault,
            30.0,
            {"additive": 3.0 * np.std(Y[:, 2]), "multiplicative": 0.0, "drift": 0.5}[fault],
        )
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(
        path,
        "csv",
        t_ns,
        {n: Y[:, j] for j, n in enumerate(names)},
        start_iso="2026-03-01T12:00:00Z",
    )
    return path


@pytest.fixture(scope="module")
def faulty_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _building_csv(tmp_path_factory.mktemp("in") / "faulty.csv", "additive")


def test_run_finds_the_fault_and_writes_the_contract(faulty_csv, tmp_path, capsys):
    code, _, err = run_cli(
        ["run", str(faulty_csv), "--out", str(tmp_path / "o"), "--no-progress"], capsys
    )
    assert code == 1, err
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    for key in (
        "schema",
        "analyzer_version",
        "inputs",
        "start",
        "duration_s",
        "rate_hz",
        "train",
        "channels",
        "faults",
        "detectors",
    ):
        assert key in doc
    assert doc["schema"] == "analyzer.findings/1"
    assert doc["inputs"][0]["format"] == "csv" and len(doc["inputs"][0]["sha256"]) == 64
    assert doc["start"] == "2026-03-01T12:00:00.000Z"
    assert doc["rate_hz"] == 200.0
    assert doc["train"] == {"start_s": 0.0, "end_s": pytest.approx(12.0, abs=0.01)}
    assert {c["name"] for c in doc["channels"]} == {"s0", "s1", "s2", "s3"}
    assert all(c["samples"] == 12000 for c in doc["channels"])
    (f,) = doc["faults"]
    assert f["channel"] == "s2" and f["type"] == "additive"
    assert abs(f["onset_s"] - 30.0) < 0.5 and f["end_s"] is None
    assert f["onset"].startswith("2026-03-01T12:00:3")
    assert 0.0 <= f["confidence"] <= 1.0
    assert f["detector"] in f["evidence"]["detectors"]
    assert (tmp_path / "o" / "report.html").stat().st_size > 500


def test_healthy_run_exits_zero(tmp_path, capsys):
    src = _building_csv(tmp_path / "ok.csv", None, seed=5)
    code, _, err = run_cli(["run", str(src), "--out", str(tmp_path / "o"), "--no-progress"], capsys)
    assert code == 0, err
    assert json.loads((tmp_path / "o" / "findings.json").read_text())["faults"] == []


@pytest.mark.parametrize(
    ("sample", "channel", "kind"),
    [
        ("building_additive.mcap", "/s4.data", "additive"),
        ("building_multiplicative.csv.gz", "s4", "multiplicative"),
        ("building_drift.bag", "/data.data[4]", "drift"),
    ],
)
def test_bundled_samples(sample, channel, kind, tmp_path, capsys):
    before = (SAMPLES / sample).read_bytes()
    code, _, err = run_cli(
        ["run", str(SAMPLES / sample), "--out", str(tmp_path), "--no-progress"], capsys
    )
    assert code == 1, err
    faults = json.loads((tmp_path / "findings.json").read_text())["faults"]
    assert [(f["channel"], f["type"]) for f in faults] == [(channel, kind)]
    assert abs(faults[0]["onset_s"] - 16.0) < 0.5
    assert (SAMPLES / sample).read_bytes() == before  # inputs are never modified


def test_healthy_ros2_sample(tmp_path, capsys):
    code, _, err = run_cli(
        ["run", str(SAMPLES / "building_healthy_ros2"), "--out", str(tmp_path), "--no-progress"],
        capsys,
    )
    assert code == 0, err


def test_corrected_csv(faulty_csv, tmp_path, capsys):
    code, _, _ = run_cli(
        [
            "run",
            str(faulty_csv),
            "--out",
            str(tmp_path),
            "--corrected",
            "--no-progress",
            "--detectors",
            "ar_kalman_bank",
        ],
        capsys,
    )
    assert code == 1
    corr = pd.read_csv(tmp_path / "corrected.csv")
    raw = pd.read_csv(faulty_csv)
    after = (corr["time"] > 31.0).to_numpy()
    offset = raw["s2"].to_numpy()[after].mean() - raw["s2"].to_numpy()[~after].mean()
    assert offset > 1.0
    # the offset is gone from the corrected channel, the others are untouched
    assert (
        abs(corr["s2"].to_numpy()[after].mean() - raw["s2"].to_numpy()[~after].mean())
        < 0.2 * offset
    )
    np.testing.assert_allclose(corr["s1"], raw["s1"], atol=1e-9)
    assert json.loads((tmp_path / "findings.json").read_text())["corrections"][0]["channel"] == "s2"


def test_inspect_json(faulty_csv, capsys):
    code, out, _ = run_cli(["inspect", str(faulty_csv), "--json"], capsys)
    assert code == 0
    doc = json.loads(out)
    assert doc["inputs"][0]["format"] == "csv" and doc["inputs"][0]["errors"] == []
    ch = {c["name"]: c for c in doc["channels"]}
    assert set(ch) == {"s0", "s1", "s2", "s3"}
    assert ch["s0"]["samples"] == 12000 and ch["s0"]["rate_hz"] == pytest.approx(200.0)
    assert ch["s0"]["start_s"] == 0.0 and ch["s0"]["end_s"] == pytest.approx(59.995)
    assert ch["s0"]["gaps"] == 0


def test_inspect_table(faulty_csv, capsys):
    code, out, _ = run_cli(["inspect", str(faulty_csv)], capsys)
    assert code == 0 and "s3" in out and "4 channel(s)" in out


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_export_round_trip(faulty_csv, tmp_path, capsys, suffix):
    out = tmp_path / f"x{suffix}"
    code, _, err = run_cli(["export", str(faulty_csv), "--out", str(out)], capsys)
    assert code == 0, err
    got = pd.read_csv(out) if suffix == ".csv" else pd.read_parquet(out)
    raw = pd.read_csv(faulty_csv)
    assert list(got.columns) == ["time", "s0", "s1", "s2", "s3"]
    np.testing.assert_allclose(got["time"], np.arange(12000) / RATE, atol=1e-9)
    np.testing.assert_allclose(got["s1"], raw["s1"], atol=1e-9)


def test_export_keeps_gaps(tmp_path, capsys):
    t, Y, names = simulate_building(n_floors=2, duration_s=10.0, seed=1)
    df = pd.DataFrame({"time": t, "a": Y[:, 0], "b": Y[:, 1]})
    df.loc[400:420, "a"] = np.nan  # 21 missing samples: a gap, never interpolated
    src = tmp_path / "g.csv"
    df.to_csv(src, index=False)
    out = tmp_path / "g_out.csv"
    assert main(["export", str(src), "--out", str(out)]) == 0
    got = pd.read_csv(out)
    assert got["a"].iloc[400:421].isna().all() and got["a"].iloc[[399, 421]].notna().all()
    code, o, _ = run_cli(["inspect", str(src), "--json"], capsys)
    assert {c["name"]: c["gaps"] for c in json.loads(o)["channels"]} == {"a": 1, "b": 0}


def test_export_clock_is_set_by_the_channels_that_vary(tmp_path):
    """Constant channels at a slower rate (an Odometry's covariance fields) are exported
    but do not set the clock: three of them at 20 Hz beside one varying channel at
    100 Hz made the clock 20 Hz (and decimated the varying one)."""
    t = np.arange(2000) / 100.0
    a = 9.81 + np.sin(3.0 * t)
    rows = [
        f"{t[i]:.2f},{a[i]:.6f}" + (",1.0,2.0,3.0" if i % 5 == 0 else ",,,")
        for i in range(t.shape[0])
    ]
    src = tmp_path / "mixed.csv"
    src.write_text("time,a,c1,c2,c3\n" + "\n".join(rows) + "\n")
    out = tmp_path / "mixed_out.csv"
    assert main(["export", str(src), "--out", str(out)]) == 0
    got = pd.read_csv(out)
    assert got.shape[0] == 2000
    np.testing.assert_allclose(got["a"], np.round(a, 6), atol=1e-9)
    # held to half its own period past its last sample (19.95 s), as on any clock
    assert (got["c2"].iloc[:1998] == 2.0).all() and got["c2"].iloc[1998:].isna().all()


# ----------------------------------------------------------------------------- bad input
def test_missing_file(tmp_path, capsys):
    code, _, err = run_cli(
        ["run", str(tmp_path / "nope.mcap"), "--out", str(tmp_path / "o")], capsys
    )
    assert code == 2
    one_line_error(err, "nope.mcap")


def test_empty_file(tmp_path, capsys):
    p = tmp_path / "empty.bag"
    p.write_bytes(b"")
    code, _, err = run_cli(["inspect", str(p)], capsys)
    assert code == 2
    one_line_error(err, "empty.bag")


def test_unknown_format(tmp_path, capsys):
    p = tmp_path / "data.xyz"
    p.write_bytes(b"\x00\x01garbage" * 10)
    code, _, err = run_cli(["run", str(p), "--out", str(tmp_path / "o")], capsys)
    assert code == 2
    one_line_error(err, "data.xyz")


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["run", "X", "--out", "O", "--rate", "-3"], "--rate"),
        (["run", "X", "--out", "O", "--jobs", "zero"], "--jobs"),
        (["run", "X"], "--out"),
        (["frobnicate"], "frobnicate"),
    ],
)
def test_bad_options(argv, needle, capsys):
    code, _, err = run_cli(argv, capsys)
    assert code == 2
    one_line_error(err, needle)


def test_bad_train_window(faulty_csv, tmp_path, capsys):
    code, _, err = run_cli(
        ["run", str(faulty_csv), "--out", str(tmp_path), "--train", "10"], capsys
    )
    assert code == 2
    one_line_error(err, "--train")
    code, _, err = run_cli(
        ["run", str(faulty_csv), "--out", str(tmp_path), "--train", "90:100"], capsys
    )
    assert code == 2
    one_line_error(err, "--train", "after the data ends")


def test_too_little_training_data(faulty_csv, tmp_path, capsys):
    code, _, err = run_cli(
        [
            "run",
            str(faulty_csv),
            "--out",
            str(tmp_path),
            "--train",
            "0:0.2",
            "--detectors",
            "ar_kalman_bank",
        ],
        capsys,
    )
    assert code == 2
    one_line_error(err, "too little healthy data")


def test_too_little_training_data_for_every_detector_names_train(faulty_csv, tmp_path, capsys):
    """When no detector can be calibrated on the healthy window, the one-line error says
    which window was used and how to give a longer one."""
    code, _, err = run_cli(
        ["run", str(faulty_csv), "--out", str(tmp_path), "--train", "0:1", "--no-progress"],
        capsys,
    )
    assert code == 2
    line = one_line_error(err, "no detector could run", "too little healthy data", "--train")
    assert "the training window 0.000-1.000 s is too short" in line
    assert "the default is" not in line  # the window was given


def test_unknown_detector(faulty_csv, tmp_path, capsys):
    code, _, err = run_cli(
        ["run", str(faulty_csv), "--out", str(tmp_path), "--detectors", "magic"], capsys
    )
    assert code == 2
    one_line_error(err, "--detectors", "magic", "ar_kalman_bank")


def test_channels_pattern_that_matches_nothing(faulty_csv, tmp_path, capsys):
    code, _, err = run_cli(
        ["run", str(faulty_csv), "--out", str(tmp_path), "--channels", "zz*"], capsys
    )
    assert code == 2
    one_line_error(err, "--channels", "zz*")


def test_channels_exclusion_leaves_a_channel_out(faulty_csv, tmp_path, capsys):
    code, _, err = run_cli(
        ["run", str(faulty_csv), "--out", str(tmp_path / "o"), "--channels", "!s0"], capsys
    )
    assert code in (0, 1), err
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    analyzed = [c["name"] for c in doc["channels"] if c["analyzed"]]
    assert "s0" not in analyzed and len(analyzed) == len(doc["channels"]) - 1
    assert doc["config"] is None  # no --config: nothing to name
    code, _, err = run_cli(
        ["run", str(faulty_csv), "--out", str(tmp_path / "p"), "--channels", "!zz*"], capsys
    )
    assert code == 2
    one_line_error(err, "--channels", "!zz*")


def test_config_unknown_key(faulty_csv, tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text("[thresholds]\nfalse_alarm_rat = 1e-6\n")
    code, _, err = run_cli(
        ["run", str(faulty_csv), "--out", str(tmp_path / "o"), "--config", str(cfg)], capsys
    )
    assert code == 2
    one_line_error(err, "false_alarm_rat")


def test_config_bad_matrix_shape(faulty_csv, tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text("[model]\nA = [[1.0, 0.0], [0.0, 1.0]]\nC = [[1.0, 0.0, 0.0]]\n")
    code, _, err = run_cli(
        ["run", str(faulty_csv), "--out", str(tmp_path / "o"), "--config", str(cfg)], capsys
    )
    assert code == 2
    one_line_error(err, "model.C", "(1, 3)")


def test_config_train_window_is_used(faulty_csv, tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text("[train]\nstart = 0.0\nend = 20.0\n\n[detectors.ar_kalman_bank]\norder = 5\n")
    code, _, err = run_cli(
        [
            "run",
            str(faulty_csv),
            "--out",
            str(tmp_path / "o"),
            "--config",
            str(cfg),
            "--detectors",
            "ar_kalman_bank",
        ],
        capsys,
    )
    assert code == 1, err
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    assert doc["train"]["end_s"] == pytest.approx(20.0, abs=0.01)
    assert doc["detectors"][0]["params"]["order"] == 5
    # the outputs name the config that set the run, as read, and what it set
    info = doc["config"]
    assert info["path"] == str(cfg)
    assert info["sha256"] == hashlib.sha256(cfg.read_bytes()).hexdigest()
    assert info["train"] == {"start_s": 0.0, "end_s": 20.0}
    assert info["detectors"] == {"ar_kalman_bank": {"order": 5}}
    assert info["groups"] == [] and info["model"] is None
    html = (tmp_path / "o" / "report.html").read_text()
    assert "Config file" in html and "[detectors.ar_kalman_bank] order = 5" in html


def test_single_channel_is_a_clear_error(tmp_path, capsys):
    t = np.arange(12000) / RATE
    pd.DataFrame({"time": t, "x": np.sin(t)}).to_csv(tmp_path / "one.csv", index=False)
    code, _, err = run_cli(["run", str(tmp_path / "one.csv"), "--out", str(tmp_path / "o")], capsys)
    assert code == 2
    one_line_error(err, "at least 2 channels")


def test_constant_channel_is_left_out(faulty_csv, tmp_path, capsys):
    df = pd.read_csv(faulty_csv)
    df["flat"] = 1.0
    src = tmp_path / "flat.csv"
    df.to_csv(src, index=False)
    code, _, err = run_cli(
        [
            "run",
            str(src),
            "--out",
            str(tmp_path / "o"),
            "--no-progress",
            "--detectors",
            "ar_kalman_bank",
        ],
        capsys,
    )
    assert code == 1, err
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    assert any("flat" in n for n in doc["notes"])
    assert {c["name"]: c["analyzed"] for c in doc["channels"]}["flat"] is False


def test_console_script_runs():
    proc = subprocess.run(
        [sys.executable, "-m", "analyzer", "--version"], capture_output=True, text=True, check=False
    )
    assert proc.returncode == 0 and "analyzer" in proc.stdout


def test_corrupt_mcap_is_a_one_line_error(tmp_path, capsys):
    magic = b"\x89MCAP0\r\n"
    p = tmp_path / "broken.mcap"
    p.write_bytes(magic + np.random.default_rng(0).bytes(20_000) + magic)
    code, _, err = run_cli(["run", str(p), "--out", str(tmp_path / "o")], capsys)
    assert code == 2
    one_line_error(err, "broken.mcap")


def test_two_channels_are_enough(tmp_path, capsys):
    t, Y, names = simulate_building(n_floors=2, duration_s=60.0, seed=2)
    Y[:, 1] = inject_fault(Y[:, 1], RATE, "additive", 40.0, 3.0 * np.std(Y[:, 1]))
    pd.DataFrame({"time": t, "a": Y[:, 0], "b": Y[:, 1]}).to_csv(tmp_path / "two.csv", index=False)
    code, _, err = run_cli(
        [
            "run",
            str(tmp_path / "two.csv"),
            "--out",
            str(tmp_path / "o"),
            "--no-progress",
            "--detectors",
            "ar_kalman_bank",
        ],
        capsys,
    )
    assert code in (0, 1), err
    assert "Traceback" not in err


@pytest.mark.parametrize("approach", ["direct", "indirect"])
def test_error_function_end_to_end_with_config(tmp_path, capsys, approach):
    """Li et al. (2007)'s 4-DOF example through the CLI: [[group]] and [model] from TOML."""
    from analyzer.simulate_mdof import chain_archive

    arch = chain_archive(noise=0.01, seed=0)
    t = np.arange(arch.values.shape[0]) / arch.rate_hz
    df = pd.DataFrame({"time": t, **{c: arch.values[:, j] for j, c in enumerate(arch.channels)}})
    df.to_csv(tmp_path / "chain.csv", index=False)
    A, B, C, D = (np.asarray(arch.config["model"][k]) for k in "ABCD")  # type: ignore[index]
    np.savez(tmp_path / "model.npz", A=A, B=B, C=C, D=D)
    model = arch.config["model"]
    outputs = ", ".join(f'"{c}"' for c in model["outputs"])  # type: ignore[index]
    (tmp_path / "c.toml").write_text(
        f"[train]\nstart = 0.0\nend = {arch.train[1] / arch.rate_hz - 0.01}\n\n"
        '[[group]]\nname = "chain"\nchannels = ["s1", "s2", "s3", "s4"]\n'
        'reference = ["s3", "s4"]\nuncertain = ["s1", "s2"]\n\n'
        f'[model]\nfile = "model.npz"\noutputs = [{outputs}]\n\n'
        f'[detectors.error_function]\napproach = "{approach}"\nwindow = 25\n'
    )
    code, _, err = run_cli(
        [
            "run",
            str(tmp_path / "chain.csv"),
            "--out",
            str(tmp_path / "o"),
            "--config",
            str(tmp_path / "c.toml"),
            "--detectors",
            "error_function",
            "--no-progress",
        ],
        capsys,
    )
    assert code == 1, err
    faults = json.loads((tmp_path / "o" / "findings.json").read_text())["faults"]
    truth = {(arch.channels[f.channel], round(f.start_s)) for f in arch.failures}
    got = {(f["channel"], round(f["onset_s"])) for f in faults}
    assert truth <= got, (truth, got)
    assert {f["channel"] for f in faults} <= {"s1", "s2"}
    assert "error_function" in (tmp_path / "o" / "report.html").read_text()
    info = json.loads((tmp_path / "o" / "findings.json").read_text())["config"]
    assert info["groups"][0]["name"] == "chain" and info["groups"][0]["reference"] == ["s3", "s4"]
    assert info["model"]["states"] == A.shape[0]
    assert info["model"]["file"] == str((tmp_path / "model.npz").resolve())


def test_progress_bar_on_a_terminal_shows_each_stage_and_the_time(tmp_path, monkeypatch, capsys):
    """On a terminal, ``run`` shows one bar per stage, from reading to the report, each
    ending at 100 % on its own line with the seconds since the run began; off a terminal
    (or with --no-progress) nothing."""
    import re

    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    code, _, err = run_cli(["run", SAMPLES / "building_additive.mcap", "--out", tmp_path], capsys)
    assert code == 1
    ended = [line for line in err.split("\n") if "100.0%" in line]
    stages = [line.rsplit("\r", 1)[-1].split()[0] for line in ended]
    assert stages == ["read", "align", "detect", "tests", "report"]
    seconds = [float(re.search(r"100\.0%\s+([0-9.]+) s$", line).group(1)) for line in ended]
    assert seconds == sorted(seconds) and seconds[0] >= 0.0
    code, _, err = run_cli(
        ["run", SAMPLES / "building_additive.mcap", "--out", tmp_path / "b", "--no-progress"],
        capsys,
    )
    assert code == 1 and "100.0%" not in err


def test_msg_path_reads_a_bag_without_definitions(tmp_path, capsys, monkeypatch):
    """``--msg-path`` (inspect, export, run, watch): the user's ``.msg`` files define the
    types a ROS 2 bag recorded without definitions uses; a missing directory or an
    unparsable file is a one-line usage error naming the option, before any reading."""
    import sqlite3

    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from analyzer.types import MSG_PATH_ENV

    monkeypatch.setenv(MSG_PATH_ENV, "")  # main() sets it: restored after the test
    definition = "float64 value\nstd_msgs/Header header\n"
    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg(definition, "plant_msgs/msg/Strain"))
    strain, header = store.types["plant_msgs/msg/Strain"], store.types["std_msgs/msg/Header"]
    stamp = store.types["builtin_interfaces/msg/Time"]
    bag = tmp_path / "bag"
    with Writer(bag, version=9) as writer:
        conn = writer.add_connection("/strain", "plant_msgs/msg/Strain", typestore=store)
        for i in range(40):
            msg = strain(value=0.5 * i, header=header(stamp=stamp(sec=i, nanosec=0), frame_id=""))
            writer.write(conn, 10**9 + i * 10**7, store.serialize_cdr(msg, msg.__msgtype__))
    for db in bag.glob("*.db3"):
        with sqlite3.connect(db) as sql:
            sql.execute("DELETE FROM message_definitions")  # as a pre-Iron recorder left it
    code, _, err = run_cli(["inspect", bag, "--json"], capsys)
    assert code == 2
    one_line_error(err, "plant_msgs/msg/Strain", "--msg-path")
    msgs = tmp_path / "msgs" / "plant_msgs" / "msg"
    msgs.mkdir(parents=True)
    (msgs / "Strain.msg").write_text(definition)
    code, out, _ = run_cli(["inspect", bag, "--json", "--msg-path", tmp_path / "msgs"], capsys)
    assert code == 0
    channels = {c["name"]: c["samples"] for c in json.loads(out)["channels"]}
    assert channels == {"/strain.value": 40}
    csv = tmp_path / "x.csv"
    code, _, _ = run_cli(["export", bag, "--out", csv, "--msg-path", tmp_path / "msgs"], capsys)
    assert code == 0
    np.testing.assert_allclose(pd.read_csv(csv)["/strain.value"], 0.5 * np.arange(40))
    code, _, err = run_cli(["inspect", bag, "--msg-path", tmp_path / "nowhere"], capsys)
    assert code == 2
    one_line_error(err, "--msg-path", "nowhere: no such directory")
    (msgs / "Broken.msg").write_text("int32 A=\n")
    code, _, err = run_cli(
        ["run", bag, "--out", tmp_path / "o", "--msg-path", msgs.parents[1]], capsys
    )
    assert code == 2
    one_line_error(err, "--msg-path", "Broken.msg: cannot parse")
    assert not (tmp_path / "o").exists()


def test_inspect_of_inputs_none_of_which_can_be_read_says_so_first(tmp_path, capsys, monkeypatch):
    """Where nothing at all could be read, inspect's error says that first, as run's does:
    it was the readers' reasons alone, each ending "; skipped", which read as warnings
    (an MCAP folder of an unsupported encoding). A cut line's full text would go to a file
    of the temporary folder: this test's own, never the real /tmp (before, one per run)."""
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    monkeypatch.chdir(tmp_path)  # short input names: the line names both before any cut
    folder = Path("in")
    folder.mkdir()
    for k in range(2):
        # (cut at 300 and 301 bytes: two copies of the same bytes would be read once)
        data = (SAMPLES / "building_additive.mcap").read_bytes()[: 300 + k]
        (folder / f"r{k}.mcap").write_bytes(data)
    code, stdout, err = run_cli(["inspect", str(folder)], capsys)
    assert code == 2 and stdout == ""
    line = one_line_error(err, "r0.mcap", "r1.mcap")
    assert line.startswith("analyzer: error: no channel could be read from any of 2 inputs: ")
    for named in re.findall(r"\S*analyzer-error-\S*?\.txt", line):
        assert Path(named).parent == scratch, named
