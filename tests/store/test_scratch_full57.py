"""A full scratch folder (TMPDIR) is named in the run's error, with the advice to move it
(ux66 M1): the spill of the raw store said only "No space left on device", and an
operator looked at ``--out``'s disk, which had room. The seam: the spill files' writes
raise ENOSPC as a full disk's would (a write's error names no file)."""

from __future__ import annotations

import errno
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from analyzer.readers.base import ChannelChunk
from analyzer.store import store as store_module
from analyzer.store.store import ChannelStore


class _FullDisk:
    """A file opened for appending on a disk with no room: every write fails."""

    def __enter__(self) -> _FullDisk:
        return self

    def __exit__(self, *exc: object) -> None:
        return None

    def write(self, data: Any) -> int:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_a_full_scratch_folder_is_named_with_tmpdir_and_the_advice(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    original = Path.open

    def opened(self: Path, mode: str = "r", *args: Any, **kwargs: Any) -> Any:
        if mode == "ab":
            return _FullDisk()
        return original(self, mode, *args, **kwargs)

    monkeypatch.setattr(store_module.Path, "open", opened)
    t = np.arange(20_000, dtype=np.int64) * 10_000_000
    chunks = [ChannelChunk("a", t[k : k + 1000], np.ones(1000)) for k in range(0, len(t), 1000)]
    with pytest.raises(OSError) as caught:
        ChannelStore.from_chunks(chunks, spill_samples=4096).close()
    err = caught.value
    assert err.errno == errno.ENOSPC
    text = str(err.strerror)
    assert text.startswith("No space left on device: no room for the scratch folder ")
    assert str(tmp_path / "analyzer-store-") in text
    assert "set TMPDIR to a directory on a larger disk" in text
    from analyzer.errors import MachineLimit, ScratchFull

    assert isinstance(err, ScratchFull) and isinstance(err, MachineLimit)


def test_other_errors_of_scratch_space_are_left_as_they_are(tmp_path: Path) -> None:
    from analyzer.errors import ScratchFull
    from analyzer.scratch import scratch_full

    denied = PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(tmp_path / "x"))
    assert scratch_full(denied, tmp_path) is denied
    full = OSError(errno.EDQUOT, os.strerror(errno.EDQUOT), str(tmp_path / "ch00000.v"))
    said = scratch_full(full, None)
    assert isinstance(said, ScratchFull) and said.filename == str(tmp_path / "ch00000.v")
    assert f"the scratch folder {tmp_path}" in str(said.strerror)
