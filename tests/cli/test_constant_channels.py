"""A sensor that reads one value over the whole record (a new user's audit: a dead
accelerometer named in ``--channels`` was dropped with a note only, exit 0 "no sensor
fault found"; one dead in the training window only, the same). Named, it is a finding of
its own (``constant_check``); by default it stays out (the contract) with a warning when
it is a sibling of analyzed channels; and findings.json says why each channel was left
out, in ``inspect --json``'s words."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.cli import main
from analyzer.selection import constant_siblings, model_stuck
from analyzer.simulate import simulate_building
from analyzer.store import ChannelInfo
from analyzer.writers import write_archive
from tests.cli.cli_helpers import one_line_error, run_cli, run_to, said, schema_valid

ALL = "/s0.data,/s1.data,/s2.data,/s3.data,/s4.data"


def _record(tmp_path, value=0.0, until=None, name="r.mcap", extra=None):
    """A 5-floor building, 60 s at 200 Hz (12 000 samples a channel), written as an MCAP
    through the project's writer, with ``/s3.data`` at ``value`` over the whole record
    (or over its first ``until`` samples only); ``extra``: more channels."""
    t, y, names = simulate_building(duration_s=60.0, seed=31)
    y[: until if until is not None else len(t), 3] = value
    data = {k: y[:, i] for i, k in enumerate(names)} | (extra or {})
    path = tmp_path / name
    t_ns = (t * 1e9).round().astype(np.int64)
    write_archive(path, "mcap", t_ns, data, start_iso="2026-05-01T00:00:00Z")
    return path


@pytest.mark.parametrize("channels", [ALL, "/s*"])
def test_a_named_dead_sensor_is_a_finding(tmp_path, capsys, channels):
    code, err, doc, out = run_to(tmp_path, capsys, _record(tmp_path), "--channels", channels)
    assert code == 1, err
    (f,) = [f for f in doc["faults"] if f["channel"] == "/s3.data"]
    assert f["type"] == "multiplicative"
    assert f["magnitude"] == {"gain": 0.0}
    assert (f["onset_s"], f["end_s"], f["onset"]) == (0.0, None, "2026-05-01T00:00:00.000Z")
    assert f["detector"] == "constant_check"
    assert f["evidence"]["detectors"] == ["constant_check"]
    assert f["evidence"]["onset_at_or_before"] is True
    assert f["evidence"]["constant"]["value"] == 0.0
    assert f["evidence"]["constant"]["samples"] == 12000
    assert "constant_check" in [d["name"] for d in doc["detectors"]]
    # the line says "dead", and "the start" (it read "from 0.000 s or earlier", ux53)
    assert err.splitlines()[-1].startswith(
        "analyzer: 1 sensor fault found on 1 sensor: /s3.data multiplicative (gain ×0: dead "
        "sensor) from the start; report: "
    )
    words = "reads 0.0 on every one of its 12 000 samples: dead or stuck, or a signal below"
    assert words in (out / "report.html").read_text()
    (s3,) = [c for c in doc["channels"] if c["name"] == "/s3.data"]
    assert (s3["analyzed"], s3["why"]) == (False, "constant")
    schema_valid(doc)


def test_a_named_sensor_stuck_at_another_value_is_other_stuck_at(tmp_path, capsys):
    code, err, doc, _ = run_to(tmp_path, capsys, _record(tmp_path, 2.5), "--channels", ALL)
    assert code == 1, err
    (f,) = [f for f in doc["faults"] if f["channel"] == "/s3.data"]
    assert (f["type"], f["magnitude"]) == ("other", {"stuck_at": 2.5})
    assert f["evidence"]["constant"]["samples"] == 12000
    schema_valid(doc)


def test_a_named_constant_channel_alone_is_refused_as_before(tmp_path, capsys):
    path = _record(tmp_path)
    code, _, err = run_cli(["run", path, "--out", tmp_path / "o", "--channels", "/s3.data"], capsys)
    assert code == 2
    one_line_error(err, "constant or empty")


def test_few_samples_at_one_value_are_no_finding(tmp_path, capsys):
    """A channel of one value on fewer than 100 samples (a status read a few times) is
    left out as before: no finding, no warning."""
    t, y, names = simulate_building(duration_s=60.0, seed=31)
    path = tmp_path / "r.csv"
    few = np.full(t.size, np.nan)
    few[::200] = 0.0  # (60 samples)
    header = "time," + ",".join([*names, "status"])
    np.savetxt(
        path, np.column_stack([t, y, few]), delimiter=",", header=header, comments="", fmt="%.17g"
    )
    code, err, doc, _ = run_to(tmp_path, capsys, path, "--channels", "s*")
    assert code in (0, 1), err
    assert "status" not in {f["channel"] for f in doc["faults"]}
    (status,) = [c for c in doc["channels"] if c["name"] == "status"]
    assert (status["analyzed"], status["why"]) == (False, "constant")


def test_by_default_a_constant_sibling_stays_out_with_a_warning(tmp_path, capsys):
    extra = {"temperature": np.full(12000, 21.0)}
    code, err, doc, _ = run_to(tmp_path, capsys, _record(tmp_path, extra=extra))
    assert code == 0, err
    assert doc["faults"] == []
    warnings = [ln for ln in said(err) if "/s3.data" in ln]
    assert len(warnings) == 1, err
    assert warnings[0].startswith("analyzer: warning: /s3.data (0.0 on all 12 000 samples)")
    assert "name it in --channels to have it reported as a fault" in warnings[0]
    # (a constant channel of another name is no sibling: left out without a warning)
    assert not any("/temperature.data" in ln for ln in said(err))
    whys = {c["name"]: c.get("why") for c in doc["channels"] if not c["analyzed"]}
    assert whys == {"/s3.data": "constant", "/temperature.data": "constant"}


def test_a_sensor_dead_in_the_training_window_only_is_warned_of(tmp_path, capsys):
    code, err, doc, _ = run_to(tmp_path, capsys, _record(tmp_path, until=3000))
    assert code in (0, 1), err
    (line,) = [ln for ln in said(err) if "/s3.data" in ln]
    assert line == (
        "analyzer: warning: /s3.data reads one value in the training window "
        "0.000-12.000 s but varies later: not analyzed; a --train where it varies analyzes it"
    )
    (s3,) = [c for c in doc["channels"] if c["name"] == "/s3.data"]
    assert (s3["analyzed"], s3["why"]) == (False, "constant in the training window")
    schema_valid(doc)


def test_findings_json_says_why_a_copy_or_an_unselected_channel_was_left_out(tmp_path, capsys):
    t, y, names = simulate_building(duration_s=60.0, seed=31)
    extra = {"s4f": 1.8 * y[:, 4] + 32.0}
    path = _record(tmp_path, value=0.0, until=0, extra=extra)
    code, err, doc, _ = run_to(tmp_path, capsys, path)
    assert code in (0, 1), err
    (copy,) = [c for c in doc["channels"] if not c["analyzed"]]
    assert copy == copy | {"name": "/s4f.data", "why": "copy", "copy_of": "/s4.data"}
    schema_valid(doc)
    code, err, doc, _ = run_to(tmp_path, capsys, path, "--channels", "/s0.data,/s1.data,/s2.data")
    assert code in (0, 1), err
    whys = {c["name"]: c.get("why") for c in doc["channels"] if not c["analyzed"]}
    assert whys == {n: "not selected" for n in ("/s3.data", "/s4.data", "/s4f.data")}
    schema_valid(doc)


def _info(name, value=0.0, finite=12000):
    return ChannelInfo(name, finite, 0, 1, 200.0, 0, finite, value, value)


@pytest.mark.parametrize(
    ("constant", "analyzed", "sibling"),
    [
        ("/s3.data", ["/s0.data", "/s1.data"], True),
        ("s3", ["s0", "s1"], True),
        ("/a.data[3]", ["/a.data[0]", "/a.data[1]"], True),
        ("/temperature", ["/s0.data", "/s1.data"], False),
        ("/b.data[3]", ["/a.data[0]", "/a.data[1]"], False),
    ],
)
def test_a_sibling_is_named_as_analyzed_ones_but_for_its_digits(constant, analyzed, sibling):
    infos = {n: _info(n) for n in analyzed} | {constant: _info(constant)}
    for n in analyzed:  # (varying)
        infos[n] = ChannelInfo(n, 12000, 0, 1, 200.0, 0, 12000, -1.0, 1.0)
    found = [i.name for i in constant_siblings(infos, analyzed)]
    assert found == ([constant] if sibling else [])


def test_a_sibling_of_few_samples_is_not_named():
    infos = {"/s0.data": ChannelInfo("/s0.data", 500, 0, 1, 200.0, 0, 500, -1.0, 1.0)}
    infos["/s1.data"] = _info("/s1.data", finite=99)
    assert constant_siblings(infos, ["/s0.data"]) == []


def _covariance_like():
    """Nine entries of a covariance-like family, two varying and seven reading 0.0 (as
    nav2's ``/amcl_pose.pose.covariance[i]``: mostly constant by construction)."""
    rng = np.random.default_rng(5)
    return {
        f"cov{k}": (rng.normal(0.0, 1.0, 12000) if k in (0, 4) else np.zeros(12000))
        for k in range(9)
    }


def test_a_mostly_constant_family_is_no_dead_sensor(tmp_path, capsys):
    """A family whose constant members outnumber its varying ones is a structure with
    constant entries, not a set of sensors one of which died: no warning by default
    (nav2's covariance entries were each warned of as a dead sensor), and a glob over it
    reports none as a fault, while the dead ``/s3.data`` among its varying siblings still is."""
    path = _record(tmp_path, extra=_covariance_like())
    code, err, doc, _ = run_to(tmp_path, capsys, path)
    assert not any("/cov" in ln for ln in said(err)), err
    assert any(ln.startswith("analyzer: warning: /s3.data") for ln in said(err)), err
    code, err, doc, _ = run_to(tmp_path, capsys, path, "--channels", "/*")
    assert code == 1, err
    stuck = {f["channel"] for f in doc["faults"] if f["detector"] == "constant_check"}
    assert stuck == {"/s3.data"}
    whys = {c["name"]: c.get("why") for c in doc["channels"] if not c["analyzed"]}
    assert whys["/cov1.data"] == "constant"


def test_a_constant_channel_named_exactly_is_a_finding_whatever_its_family(tmp_path, capsys):
    path = _record(tmp_path, value=1.0, extra=_covariance_like())
    code, err, doc, _ = run_to(tmp_path, capsys, path, "--channels", ALL + ",/cov1.data,/cov0.data")
    assert code == 1, err
    stuck = {f["channel"] for f in doc["faults"] if f["detector"] == "constant_check"}
    assert stuck == {"/s3.data", "/cov1.data"}


def test_the_constant_minority_of_a_family_is_named():
    varying = [f"/c.data[{k}]" for k in (0, 4)]
    infos = {n: ChannelInfo(n, 12000, 0, 1, 200.0, 0, 12000, -1.0, 1.0) for n in varying}
    infos |= {f"/c.data[{k}]": _info(f"/c.data[{k}]") for k in (1, 2, 3)}
    assert constant_siblings(infos, varying) == []  # (3 constant, 2 varying)
    infos = {k: v for k, v in infos.items() if k not in ("/c.data[2]", "/c.data[3]")}
    assert [i.name for i in constant_siblings(infos, varying)] == ["/c.data[1]"]


def test_the_report_says_what_the_constant_check_is_where_it_reported(tmp_path, capsys):
    """The report's Method section describes each detector; the check had only its name
    and "ran" (stuck51's own note): now what it does, where it reported a channel."""
    code, err, _, out = run_to(tmp_path, capsys, _record(tmp_path), "--channels", ALL)
    assert code == 1, err
    html = (out / "report.html").read_text()
    assert "A sensor that reads one value" in html
    assert "reported 1 channel" in html
    code, err, _, out = run_to(tmp_path, capsys, _record(tmp_path, value=None, until=0))
    assert "A sensor that reads one value" not in (out / "report.html").read_text()


@pytest.fixture(scope="module")
def saved_model(tmp_path_factory):
    """A model saved on the healthy 5-floor record (its ``/s3.data`` varies)."""
    where = tmp_path_factory.mktemp("model")
    path = _record(where, value=None, until=0)
    model = where / "model.json"
    code = main(
        ["run", str(path), "--out", str(where / "o"), "--no-progress"]
        + ["--save-model", str(model)]
    )
    assert code == 0
    return model


@pytest.mark.parametrize(
    ("value", "kind", "magnitude"),
    [(0.0, "multiplicative", {"gain": 0.0}), (2.5, "other", {"stuck_at": 2.5})],
)
def test_a_model_channel_dead_since_the_model_was_saved_is_the_constant_check_finding(
    tmp_path, capsys, saved_model, value, kind, magnitude
):
    """A sensor that died after the model was saved: the model's detectors found it from
    their warm-up's end (3.47 s), with a warning that its spread was 0x the model's ("another
    unit, a sensor's gain"); now one finding, the constant check's, from the record's
    start, naming the detectors that saw it too; the channel stays analyzed (the saved
    model needs it), without the spread warning."""
    path = _record(tmp_path, value)
    code, err, doc, out = run_to(tmp_path, capsys, path, "--model", saved_model)
    assert code == 1, err
    (f,) = [f for f in doc["faults"] if f["channel"] == "/s3.data"]
    assert (f["type"], f["magnitude"], f["detector"]) == (kind, magnitude, "constant_check")
    assert (f["onset_s"], f["end_s"], f["confidence"]) == (0.0, None, 1.0)
    assert f["evidence"]["onset_at_or_before"] is True
    assert f["evidence"]["constant"]["samples"] == 12000
    assert f["evidence"]["detectors"][0] == "constant_check"
    assert len(f["evidence"]["detectors"]) > 1  # (the model's detectors saw it too)
    assert f["evidence"]["constant"]["seen_from_s"] > 0.0
    assert not any("/s3.data" in ln for ln in said(err)), err
    (s3,) = [c for c in doc["channels"] if c["name"] == "/s3.data"]
    assert s3["analyzed"] is True and "why" not in s3
    assert [d["channels"] for d in doc["detectors"] if d["name"] == "constant_check"] == [
        ["/s3.data"]
    ]
    html = (out / "report.html").read_text()
    assert "A sensor that reads one value" in html and "saved model" in html
    schema_valid(doc)


def test_a_healthy_record_with_the_model_has_no_constant_check(tmp_path, capsys, saved_model):
    code, err, doc, _ = run_to(
        tmp_path, capsys, _record(tmp_path, None, until=0), "--model", saved_model
    )
    assert code in (0, 1), err
    assert not any(f["detector"] == "constant_check" for f in doc["faults"])


def _config(tmp_path, group):
    path = tmp_path / "groups.toml"
    path.write_text(group)
    return path


TOWER = (
    '[[group]]\nname = "tower"\n'
    'channels = ["/s0.data", "/s1.data", "/s2.data", "/s3.data", "/s4.data"]\n'
)


def test_a_dead_sensor_a_config_group_names_is_a_finding(tmp_path, capsys):
    """A constant channel a ``[[group]]`` names is a sensor the user named, as with
    ``--channels``: a finding (it was left out with the sibling warning, exit 0)."""
    config = _config(tmp_path, TOWER)
    code, err, doc, out = run_to(tmp_path, capsys, _record(tmp_path), "--config", config)
    assert code == 1, err
    (f,) = [f for f in doc["faults"] if f["channel"] == "/s3.data"]
    assert (f["type"], f["magnitude"], f["detector"]) == (
        "multiplicative",
        {"gain": 0.0},
        "constant_check",
    )
    assert (f["onset_s"], f["end_s"]) == (0.0, None)
    assert f["evidence"]["detectors"] == ["constant_check"]
    assert not any(ln.startswith("analyzer: warning: /s3.data") for ln in said(err)), err
    (s3,) = [c for c in doc["channels"] if c["name"] == "/s3.data"]
    assert (s3["analyzed"], s3["why"]) == (False, "constant")
    assert "A sensor that reads one value" in (out / "report.html").read_text()
    schema_valid(doc)


def test_a_group_sensor_of_any_name_is_one_but_not_a_group_input(tmp_path, capsys):
    """Named by the config, a constant channel is a finding whatever its name (no
    sibling of an analyzed one: it had no warning either); a group's measured input that
    reads one value (no excitation applied) is left out as before."""
    extra = {"t": np.full(12000, 21.0), "f": np.zeros(12000)}
    group = TOWER.replace('"/s4.data"]', '"/s4.data", "/t.data"]') + 'inputs = ["/f.data"]\n'
    config = _config(tmp_path, group)
    code, err, doc, _ = run_to(tmp_path, capsys, _record(tmp_path, extra=extra), "--config", config)
    assert code == 1, err
    stuck = {
        f["channel"]: f["magnitude"] for f in doc["faults"] if f["detector"] == "constant_check"
    }
    assert stuck == {"/s3.data": {"gain": 0.0}, "/t.data": {"stuck_at": 21.0}}
    whys = {c["name"]: c.get("why") for c in doc["channels"] if not c["analyzed"]}
    assert whys == {"/s3.data": "constant", "/t.data": "constant", "/f.data": "constant"}
    schema_valid(doc)


def test_a_model_channel_is_stuck_only_beside_a_varying_one():
    varying = ChannelInfo("/s0.data", 12000, 0, 1, 200.0, 0, 12000, -1.0, 1.0)
    dead, few = _info("/s3.data"), _info("/s4.data", finite=99)
    found = model_stuck([varying, dead, few], ["/s0.data", "/s3.data", "/s4.data"])
    assert [i.name for i in found] == ["/s3.data"]
    assert model_stuck([varying, dead], ["/s3.data"]) == []  # (no channel of it varies)
    assert model_stuck([dead], ["/s3.data"]) == []
    # (a measured input, or a channel the model saw read zero at rest: no dead sensor)
    both = ["/s0.data", "/s3.data"]
    assert model_stuck([varying, dead], both, inputs={"/s3.data"}) == []
    assert model_stuck([varying, dead], both, zero_at_rest={"/s3.data"}) == []
    stuck = _info("/s3.data", value=2.5)
    assert model_stuck([varying, stuck], both, zero_at_rest={"/s3.data"}) == [stuck]
