"""CSV cells and times that passed without a word (signal-pathology probe):

* numpy.savetxt writes a missing value as ``nan``: a first row with one was taken for
  the header (the channels were named after the second line's numbers), and ``nan``
  cells counted as samples (a channel a fifth missing showed no gap), unlike blanks;
* rows at the time of the row before were collapsed silently (every tenth row
  repeated; a time column cut to whole seconds under 100 rows a second became 1 Hz,
  and the run then refused "1 Hz" without saying why)."""

import numpy as np

from analyzer.cli import main
from analyzer.inspect import inspect_archive


def _write(path, t, y, names=("a", "b", "c")):
    header = "time," + ",".join(names)
    np.savetxt(path, np.column_stack([t, y]), delimiter=",", header=header, comments="", fmt="%.9g")
    return path


def _table(y_rows=600, seed=0):
    rng = np.random.default_rng(seed)
    return np.arange(y_rows) / 100.0, rng.standard_normal((y_rows, 3))


def test_a_first_row_with_nan_is_data_and_nan_cells_are_gaps(tmp_path):
    t, y = _table()
    y[0, 1] = np.nan
    y[100:150, 1] = np.nan
    doc = inspect_archive([_write(tmp_path / "n.csv", t, y)])
    by = {c["name"]: c for c in doc["channels"]}
    assert sorted(by) == ["a", "b", "c"]
    assert by["a"]["samples"] == 600 and by["b"]["samples"] == 549 and by["b"]["gaps"] == 1
    blank = (tmp_path / "n.csv").read_text().replace(",nan", ",")
    (tmp_path / "b.csv").write_text(blank)
    same = {c["name"]: c for c in inspect_archive([tmp_path / "b.csv"])["channels"]}
    assert same["b"]["samples"] == 549 and same["b"]["gaps"] == 1


def test_repeated_times_are_counted_once_per_file(tmp_path):
    t, y = _table()
    t[10::10] = t[9::10][: t[10::10].size]
    doc = inspect_archive([_write(tmp_path / "r.csv", t, y)])
    (errors,) = [i["errors"] for i in doc["inputs"]]
    assert errors == [
        "59 of 600 rows give a channel a second value at the same time (a clock too coarse "
        "for the rows, or rows written twice); the aligned channels keep one value per time"
    ]


def test_a_sparse_wide_table_repeats_no_channel_value(tmp_path):
    """One row per channel per time, blanks elsewhere (a long table pivoted): 3000 of
    6000 rows were said to repeat the time of the row before, though no channel had two
    values at one time and nothing was collapsed."""
    rng = np.random.default_rng(1)
    rows = "".join(
        f"{i / 50:.2f},{rng.standard_normal():.5f},\n{i / 50:.2f},,{rng.standard_normal():.5f}\n"
        for i in range(3000)
    )
    path = tmp_path / "sparse.csv"
    path.write_text("time,a,b\n" + rows)
    doc = inspect_archive([path])
    assert doc["inputs"][0]["errors"] == []
    assert {c["name"]: c["samples"] for c in doc["channels"]} == {"a": 3000, "b": 3000}


def test_a_sparse_table_counts_the_channel_with_most_repeats(tmp_path):
    """Per channel, among its own cells: b's second value at a time is counted, a's
    cells (one a time) are not; the largest count is said."""
    lines = []
    for i in range(100):
        lines += [f"{i},{i},", f"{i},,{i}"] + ([f"{i},,{-i}"] if i % 4 == 0 else [])
    path = tmp_path / "sparse.csv"
    path.write_text("time,a,b\n" + "\n".join(lines) + "\n")
    (errors,) = [i["errors"] for i in inspect_archive([path])["inputs"]]
    assert errors == [
        "25 of 225 rows give a channel a second value at the same time (a clock too coarse "
        "for the rows, or rows written twice); the aligned channels keep one value per time"
    ]


def test_times_cut_to_whole_seconds_say_why_the_window_is_short(tmp_path, capsys):
    t, y = _table(6000)
    path = _write(tmp_path / "s.csv", np.floor(t), y)
    assert main(["run", str(path), "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "at 1 Hz" in err
    assert "5940 of 6000 rows give a channel a second value at the same time" in err
