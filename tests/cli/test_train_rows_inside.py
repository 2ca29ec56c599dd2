"""``--train A:B`` trains on the rows whose times lie inside A-B (the ux52 audit, item 17):
rows were rounded to the nearest sample, so ``--train 20:300`` on a 16.67 Hz clock trained
from 19.98 s, a sample before the window asked for; findings.json's ``train`` says the
rows used, to four decimals as ``onset_s``."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.simulate import simulate_building
from analyzer.writers import write_archive
from tests.cli.cli_helpers import run_to

RATE = 100.0


def test_rows_within_round_inward() -> None:
    """The first row at or after the start, the last at or before the end; a window
    end on a row's time (within float error) keeps that row."""
    from analyzer.timeutil import rows_within

    assert rows_within(20.004, 40.006, RATE) == (2001, 4001)
    assert rows_within(20.0, 40.0, RATE) == (2000, 4001)
    assert rows_within(0.1 * 3, 0.7, 10.0) == (3, 8)  # (0.30000000000000004 s, 7.0 rows)
    a, b = rows_within(20.0, 300.0, 16.666525686804974)
    assert a / 16.666525686804974 >= 20.0 and (b - 1) / 16.666525686804974 <= 300.0


def test_train_window_between_samples_trains_inside_it(tmp_path, capsys) -> None:
    """--train 20.004:40.006 on a 100 Hz record: the training rows are 20.01-40.0 s (the
    nearest rows, 20.0 and 40.01 s, lay outside the window)."""
    t, y, names = simulate_building(3, 60.0, RATE, seed=3, sensors_per_floor=2)
    path = tmp_path / "b.csv"
    write_archive(
        path,
        "csv",
        np.round(t * 1e9).astype(np.int64),
        {n: y[:, i] for i, n in enumerate(names)},
        start_iso="2026-03-03T14:00:00Z",
    )
    code, err, doc, _ = run_to(tmp_path, capsys, path, "--train", "20.004:40.006")
    assert code in (0, 1), err
    assert doc["train"] == {"start_s": pytest.approx(20.01), "end_s": pytest.approx(40.0)}
    assert doc["train"]["start_s"] >= 20.004 and doc["train"]["end_s"] <= 40.006
