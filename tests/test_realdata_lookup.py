"""One rule for where the real-data corpus is (a maintainer's audit, ux61 item H3): it
was written five times (tests/conftest.py, tests/readers/conftest.py,
tests/test_data_ends.py and two benchmarks), in two orders, each skip saying something
else. Now: ``$ANALYZER_REALDATA`` where it is a folder, then ``../shared/realdata``
beside the checkout; a skip names both."""

from __future__ import annotations

from pathlib import Path

import _realdata  # (new: not on the base)
import pytest


def test_the_variable_comes_first_then_the_folder_beside_the_checkout(tmp_path, monkeypatch):
    given, beside = tmp_path / "given", tmp_path / "shared" / "realdata"
    given.mkdir()
    beside.mkdir(parents=True)
    monkeypatch.setattr(_realdata, "BESIDE", beside)
    monkeypatch.setenv("ANALYZER_REALDATA", str(given))
    assert _realdata.realdata_root() == given.resolve()
    monkeypatch.setenv("ANALYZER_REALDATA", str(tmp_path / "nowhere"))  # (no folder)
    assert _realdata.realdata_root() == beside.resolve()
    monkeypatch.delenv("ANALYZER_REALDATA")
    assert _realdata.realdata_root() == beside.resolve()


def test_a_skip_names_both_places(tmp_path, monkeypatch):
    monkeypatch.setattr(_realdata, "BESIDE", tmp_path / "shared" / "realdata")
    monkeypatch.setenv("ANALYZER_REALDATA", str(tmp_path / "nowhere"))
    with pytest.raises(pytest.skip.Exception) as skipped:
        _realdata.realdata_or_skip()
    reason = str(skipped.value)
    assert f"ANALYZER_REALDATA={tmp_path / 'nowhere'} is no folder" in reason
    assert str(tmp_path / "shared" / "realdata") in reason
    monkeypatch.delenv("ANALYZER_REALDATA")
    with pytest.raises(pytest.skip.Exception, match="ANALYZER_REALDATA is not set"):
        _realdata.realdata_or_skip("ros1/evo/ROS_example.bag")


def test_the_benchmarks_default_alike(tmp_path, monkeypatch):
    """The SKAB sweeps' ``--corpus`` default: the same order."""
    import importlib.util

    script = Path(__file__).resolve().parents[1] / "benchmarks" / "_corpus.py"
    spec = importlib.util.spec_from_file_location("bench_realdata", script)
    assert spec is not None and spec.loader is not None
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    monkeypatch.setenv("ANALYZER_REALDATA", str(tmp_path))
    assert bench.default_corpus() == tmp_path
    monkeypatch.setenv("ANALYZER_REALDATA", str(tmp_path / "nowhere"))
    assert bench.default_corpus() == bench.BESIDE == _realdata.BESIDE
