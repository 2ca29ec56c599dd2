"""Channels that are flags or labels, not measurements (a new user's audit: SKAB's CSVs
carry the benchmark's own ``anomaly`` and ``changepoint`` columns, 0 and 1, which the
analyzer modelled as sensors: ``anomaly`` was found faulty, and a constant 0 in a training
window made the AR regressions singular). A channel of two whole-number values over the
whole record is left out by default, with one warning; naming it in --channels keeps it."""

from __future__ import annotations

import json

import numpy as np
import pytest

from analyzer.readers import open_archive
from analyzer.simulate import simulate_building
from analyzer.store import ChannelStore
from analyzer.store.store import _summarize
from tests.cli.cli_helpers import one_line_error, run_cli, said

WARNING = (
    "label holds only 0 and 1 over the record: a flag or label, not a measurement; left "
    "out of the analysis; name it in --channels to analyze it"
)


def _record(tmp_path, label=None, second=False):
    """A 4-floor building (s0..s3, 120 s at 50 Hz) with a 0/1 ``label`` column (1 over
    every other tenth of the record, as a benchmark marks its anomalies: 0 and 1 in the
    training window too) or ``label`` given."""
    t, y, names = simulate_building(4, 120.0, 50.0, seed=3)
    if label is None:
        label = ((np.arange(t.size) * 10 // t.size) % 2).astype(float)
    path = tmp_path / "r.csv"
    header = "time," + ",".join([*names, "label"])
    data = np.column_stack([t, y, label])
    if second:  # (a second label, 1 and 2, ``level``)
        header += ",level"
        data = np.column_stack([data, 1.0 + label[::-1]])
    np.savetxt(path, data, delimiter=",", header=header, comments="", fmt="%.17g")
    return path


def _findings(out):
    return json.loads((out / "findings.json").read_text())


def _analyzed(doc):
    return {c["name"] for c in doc["channels"] if c["analyzed"]}


def test_the_default_run_leaves_a_label_column_out_with_one_warning(tmp_path, capsys):
    path = _record(tmp_path)
    out = tmp_path / "o"
    code, _, err = run_cli(["run", path, "--out", out, "--no-progress"], capsys)
    assert code in (0, 1), err
    doc = _findings(out)
    assert _analyzed(doc) == {"s0", "s1", "s2", "s3"}
    assert "label" not in {f["channel"] for f in doc["faults"]}
    assert [n for n in doc["notes"] if "label" in n] == [WARNING]
    assert [ln for ln in said(err) if "label" in ln] == [f"analyzer: warning: {WARNING}"]
    assert "a flag or label, not a measurement" in (out / "report.html").read_text()


@pytest.mark.parametrize("channels", ["s*,label", "label,s0,s1,s2,s3"])
def test_a_label_named_in_channels_is_analyzed(tmp_path, capsys, channels):
    path = _record(tmp_path)
    out = tmp_path / "o"
    args = ["run", path, "--out", out, "--no-progress", "--channels", channels]
    code, _, err = run_cli(args, capsys)
    assert code in (0, 1), err
    doc = _findings(out)
    assert _analyzed(doc) == {"s0", "s1", "s2", "s3", "label"}
    assert not any("flag or label" in n for n in doc["notes"])


@pytest.mark.parametrize("channels", ["*", "!s2", "l*"])
def test_a_glob_or_an_exclusion_does_not_keep_a_label(tmp_path, capsys, channels):
    """A glob selects sensors (``*`` every channel); a label beside them stays out."""
    path = _record(tmp_path, second=True)
    out = tmp_path / "o"
    args = ["run", path, "--out", out, "--no-progress", "--channels", channels]
    args += ["--detectors", "equivalent_model"]
    code, _, err = run_cli(args, capsys)
    if channels == "l*":  # (it selects the two labels alone)
        one_line_error(err, "--channels: every channel it selects is a flag or label")
        assert code == 2
        return
    assert code in (0, 1), err
    doc = _findings(out)
    assert not {"label", "level"} & _analyzed(doc)
    assert (
        "label (0 and 1), level (1 and 2) hold only two whole numbers each: flags or labels, "
        "not measurements; left out of the analysis; name them in --channels to analyze them"
    ) in doc["notes"]


def test_a_lone_flag_is_refused_as_one_channel(tmp_path, capsys):
    """A record of one channel of two whole numbers (NAB's art_increase_spike_density:
    spikes of 20 on 0) is refused as a record of one channel, as before."""
    path = tmp_path / "one.csv"
    t = np.arange(1000) * 0.1
    spikes = np.where(np.arange(1000) % 37 == 0, 20.0, 0.0)
    np.savetxt(
        path,
        np.column_stack([t, spikes]),
        delimiter=",",
        header="time,value",
        comments="",
        fmt="%.17g",
    )
    code, _, err = run_cli(["run", path, "--out", tmp_path / "o", "--no-progress"], capsys)
    assert code == 2
    one_line_error(err, "one channel to analyze (value)")
    assert "flag or label" not in err


def test_a_sensor_of_many_values_or_two_fractions_is_no_flag(tmp_path):
    """Only two whole numbers make a flag: a sensor quantized to 0.5 and 1.5, or to three
    levels, is measured (the coarse-values note speaks of it)."""
    n = 6000
    half = np.where(np.arange(n) % 7 < 3, 0.5, 1.5)
    three = np.arange(n) % 3.0
    for values in (half, three):
        path = _record(tmp_path, values)
        with ChannelStore.from_chunks(open_archive([path]).chunks(), tmp_path / "st") as store:
            info = store.info("label")
            assert not info.flag and not info.constant, info


def test_the_values_are_told_block_by_block():
    """The summary reads a long channel a block at a time: a flag whose 1s come only in
    a later block is one, and a third value in the last block undoes it."""
    t = np.arange(10_000, dtype=np.int64) * 10_000_000
    v = np.zeros(10_000)
    v[7_500:] = 1.0
    info = _summarize("f", t, v, block=1000)
    assert info.levels == (0.0, 1.0) and info.flag
    v[-1] = 2.0
    info = _summarize("f", t, v, block=1000)
    assert info.levels is None and not info.flag
    assert _summarize("c", t, np.full(10_000, 3.0), block=1000).levels == (3.0,)
    minus = np.where(np.arange(10_000) % 2 == 0, -1.0, 1.0)
    minus[::5] = np.nan  # (gaps are no value)
    info = _summarize("m", t, minus, block=1000)
    assert info.levels == (-1.0, 1.0) and info.flag
    # a few samples show few values whatever the channel (an AIS topic's two timestamps)
    info = _summarize("few", t[:99], v[7_450:7_549])
    assert info.levels == (0.0, 1.0) and not info.flag


def test_inspect_shows_a_flag(tmp_path, capsys):
    path = _record(tmp_path)
    code, out, _ = run_cli(["inspect", path, "--json"], capsys)
    assert code == 0
    flags = {c["name"]: c.get("flag") for c in json.loads(out)["channels"]}
    assert flags == {"s0": None, "s1": None, "s2": None, "s3": None, "label": [0, 1]}
    code, out, _ = run_cli(["inspect", path], capsys)
    assert code == 0
    assert "label [flag 0/1]" in out
    assert "[flag a/b]: only the whole numbers a and b over the record" in out


def test_a_saved_model_with_a_label_is_reused(tmp_path, capsys):
    """A model fitted with the label named keeps it: --model analyzes it again; a model
    fitted without it says the label of the new archive was not analyzed."""
    path = _record(tmp_path)
    with_label = tmp_path / "with.model"
    args = ["run", path, "--out", tmp_path / "o1", "--no-progress"]
    args += ["--channels", "s*,label", "--detectors", "equivalent_model"]
    code, _, err = run_cli([*args, "--save-model", with_label], capsys)
    assert code in (0, 1), err
    code, _, err = run_cli(
        ["run", path, "--out", tmp_path / "o2", "--no-progress", "--model", with_label], capsys
    )
    assert code in (0, 1), err
    assert "label" in _analyzed(_findings(tmp_path / "o2"))
    without = tmp_path / "without.model"
    args = ["run", path, "--out", tmp_path / "o3", "--no-progress"]
    code, _, err = run_cli(
        [*args, "--detectors", "equivalent_model", "--save-model", without], capsys
    )
    assert code in (0, 1), err
    code, _, err = run_cli(
        ["run", path, "--out", tmp_path / "o4", "--no-progress", "--model", without], capsys
    )
    assert code in (0, 1), err
    doc = _findings(tmp_path / "o4")
    assert _analyzed(doc) == {"s0", "s1", "s2", "s3"}
    assert any(
        n.startswith("flags or labels of this archive") and "label" in n for n in doc["notes"]
    )


def test_a_config_group_naming_a_flag_keeps_it(tmp_path, capsys):
    """A [[group]] names its channels one by one: a 0/1 channel it names (a measured
    step input, a valve's state) is analyzed."""
    path = _record(tmp_path)
    config = tmp_path / "c.toml"
    config.write_text('[[group]]\nname = "g"\nchannels = ["s0", "s1", "s2", "s3", "label"]\n')
    out = tmp_path / "o"
    args = ["run", path, "--out", out, "--no-progress", "--config", config]
    code, _, err = run_cli([*args, "--detectors", "equivalent_model"], capsys)
    assert code in (0, 1), err
    assert "label" in _analyzed(_findings(out))


def test_realdata_skab_labels_are_left_out(realdata, tmp_path, capsys):
    """SKAB valve1/0.csv with the window the run suggests: the label columns, which the
    run found faulty (``anomaly``, multiplicative), are left out; the eight sensors stay."""
    path = realdata / "benchmark" / "SKAB" / "data" / "valve1" / "0.csv"
    out = tmp_path / "o"
    code, _, err = run_cli(["run", path, "--out", out, "--no-progress", "--train", "0:718"], capsys)
    assert code in (0, 1), err
    doc = _findings(out)
    assert len(_analyzed(doc)) == 8 and not {"anomaly", "changepoint"} & _analyzed(doc)
    assert {f["channel"] for f in doc["faults"]}.isdisjoint({"anomaly", "changepoint"})
    assert doc["notes"][0].startswith("anomaly, changepoint hold only 0 and 1 over the record")
