"""A damaged MCAP member whose first record claims a length past the end of the file, in
a folder with a relative-time CSV: placing the member in time seeked by that length and
stopped the whole archive with an internal error (or "Invalid argument", naming no
file). The member is damage, reported; the CSV is read."""

import numpy as np

from analyzer.inspect import inspect_archive


def test_a_record_length_past_the_end_is_damage_not_a_seek(tmp_path):
    t = np.arange(0, 60, 0.02)
    rows = "\n".join(f"{x:.2f},{np.sin(x):.6f}" for x in t)
    (tmp_path / "rel.csv").write_text("time,a\n" + rows + "\n")
    garbage = (2**63).to_bytes(8, "little") + bytes(range(200))
    (tmp_path / "bad.mcap").write_bytes(b"\x89MCAP0\r\n" + b"\x01" + garbage)
    doc = inspect_archive([tmp_path])
    errors = {i["path"].rsplit("/", 1)[-1]: i["errors"] for i in doc["inputs"]}
    assert errors["rel.csv"] == []
    assert any("damaged" in e for e in errors["bad.mcap"]), errors
    assert [(c["name"], c["samples"]) for c in doc["channels"]] == [("a", t.size)]
