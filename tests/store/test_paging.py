"""Releasing the resident pages of memory-mapped arrays (analyzer.paging)."""

import os
import sys

import numpy as np
import pytest

from analyzer.paging import finite_rows, release, spill


def _rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 / 1e6


def test_release_keeps_the_values_and_ignores_arrays_in_memory(tmp_path):
    a = np.lib.format.open_memmap(tmp_path / "a.npy", mode="w+", dtype=np.float64, shape=(5000, 7))
    a[:] = np.arange(35000.0).reshape(5000, 7)
    for view in (a, a[:, 3], np.asarray(a)[100:900], a[4999:]):
        release(view)
    np.testing.assert_array_equal(a, np.arange(35000.0).reshape(5000, 7))
    ro = np.lib.format.open_memmap(tmp_path / "a.npy", mode="r")
    release(ro[:, 2])
    np.testing.assert_array_equal(ro[:, 2], np.arange(2, 35000, 7.0))
    plain = np.ones(10)
    release(plain)  # not file-backed: nothing to do
    release(None)
    cow = np.load(tmp_path / "a.npy", mmap_mode="c")
    cow[0, 0] = -1.0
    release(cow)  # copy-on-write: a release would lose the change, so none happens
    assert cow[0, 0] == -1.0


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/statm")
def test_release_gives_the_pages_back(tmp_path):
    a = np.lib.format.open_memmap(
        tmp_path / "big.npy", mode="w+", dtype=np.float64, shape=(4_000_000, 4)
    )  # 128 MB
    a[:] = 1.0
    touched = _rss_mb()
    release(a)
    assert _rss_mb() < touched - 100
    assert float(a[:, 1].sum()) == 4_000_000.0  # read back from the file
    release(a[:, 1])
    assert _rss_mb() < touched - 100


def test_spill_writes_rows_and_returns_read_only_views(tmp_path):
    signals = {"b": np.arange(1000.0), "a": np.full(1000, 2.5)}
    rows = spill(signals, tmp_path / "s.npy", np.float32)
    assert list(rows) == ["b", "a"]
    for name, row in rows.items():
        assert row.dtype == np.float32 and not row.flags.writeable
        np.testing.assert_array_equal(row, signals[name].astype(np.float32))
    assert np.load(tmp_path / "s.npy").shape == (2, 1000)
    assert spill({}, tmp_path / "none.npy", np.float32) == {}


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/statm")
def test_spilled_rows_are_released_like_any_mapping(tmp_path):
    """The rows are views of a shared read-only mapping: reading them brings their pages
    into the resident set, :func:`release` hands them back, and they read the same."""
    n = 20_000_000  # 80 MB of float32
    rows = spill({"x": np.full(n, 1.5)}, tmp_path / "big.npy", np.float32)
    row = rows["x"]
    before = _rss_mb()
    assert float(row.sum(dtype=np.float64)) == 1.5 * n
    assert _rss_mb() > before + 50
    release(row)
    assert _rss_mb() < before + 30
    assert float(row[-1]) == 1.5


def test_spill_keeps_rows_already_mapped_in_its_precision(tmp_path):
    """A float32 row of a memory-mapped buffer is returned as a read-only view of its own
    map (no second copy), a whole float64 buffer is narrowed over its own file; the
    others go to the file, which holds only them."""
    from analyzer.paging import buffer, is_mapped

    n = 5000
    mapped = buffer(tmp_path, "kept", (n, 2), np.float32)
    mapped[:, 0] = np.arange(n)
    mapped[:, 1] = -1.0
    wide = buffer(tmp_path, "wide", (n, 1))  # float64: narrowed where it is
    wide[:, 0] = 0.25
    signals = {"a": mapped[:, 0], "w": wide[:, 0], "b": mapped[:, 1], "m": np.full(n, 3.0)}
    expected = {name: np.array(a, dtype=np.float32) for name, a in signals.items()}
    rows = spill(signals, tmp_path / "s.npy", np.float32)
    assert list(rows) == ["a", "w", "b", "m"]
    for name in ("a", "b"):
        assert np.shares_memory(rows[name], signals[name])
    for name in ("a", "b", "w"):
        assert is_mapped(rows[name])
    for name, row in rows.items():
        assert row.dtype == np.float32 and not row.flags.writeable
        np.testing.assert_array_equal(row, expected[name])
    assert np.load(tmp_path / "s.npy").shape == (1, n)  # only m
    only_kept = spill({"a": mapped[:, 0]}, tmp_path / "none.npy", np.float32)
    assert not (tmp_path / "none.npy").exists()
    np.testing.assert_array_equal(only_kept["a"], np.arange(n, dtype=np.float32))


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="fallocate, st_blocks")
def test_spill_narrows_a_whole_float64_buffer_over_its_own_file(tmp_path):
    """Every row of a float64 buffer handed over (in any order) is narrowed to float32
    over the buffer's own file: no new file, each value rounded once as a copy would
    have it (NaN, infinities and values beyond float32 too), and the wide values'
    second half given back to the kernel (the file's blocks halved)."""
    from analyzer import paging

    n, m = 3 * paging.RELEASE_ROWS + 77, 3
    values = np.random.default_rng(4).standard_normal((n, m)) * 1e3
    values[5, 1], values[6, 1], values[7, 2], values[8, 0] = np.nan, np.inf, -np.inf, 1e300
    src = paging.buffer(tmp_path, "src", (n, m))
    paging.write_rows(src, 0, values)
    found = paging._mapping(src)
    assert found is not None
    fd = paging._WRITERS[id(found[0])][0]
    blocks = os.fstat(fd).st_blocks
    with np.errstate(over="ignore"):
        expected = values.astype(np.float32)
        rows = spill(
            {"c": src[:, 2], "a": src[:, 0], "b": src[:, 1]}, tmp_path / "s.npy", np.float32
        )
    assert list(rows) == ["c", "a", "b"]
    assert not (tmp_path / "s.npy").exists()
    for k, name in enumerate("abc"):
        row = rows[name]
        assert row.dtype == np.float32 and not row.flags.writeable and paging.is_mapped(row)
        np.testing.assert_array_equal(row, expected[:, k])
    assert os.fstat(fd).st_blocks < 0.55 * blocks


def test_spill_copies_part_of_a_buffer_and_leaves_the_buffer_alone(tmp_path):
    """Rows of a float64 buffer that are not all of its rows, each once, are copied to
    the file as before: the buffer keeps its values."""
    from analyzer import paging

    n = 2 * paging.RELEASE_ROWS + 5
    values = np.random.default_rng(5).standard_normal((n, 2))
    src = paging.buffer(tmp_path, "src", (n, 2))
    paging.write_rows(src, 0, values)
    for k, signals in enumerate(({"x": src[:, 1]}, {"x": src[:, 0], "y": src[:, 0]})):
        rows = spill(signals, tmp_path / f"s{k}.npy", np.float32)
        assert (tmp_path / f"s{k}.npy").exists()
        for name, row in rows.items():
            np.testing.assert_array_equal(row, np.asarray(signals[name], dtype=np.float32))
        np.testing.assert_array_equal(src, values)


def test_spill_refuses_rows_of_unequal_length(tmp_path):
    with pytest.raises(ValueError, match="b has shape"):
        spill({"a": np.zeros(10), "b": np.zeros(9)}, tmp_path / "s.npy", np.float32)


def test_trim_heap_is_harmless():
    from analyzer.paging import trim_heap

    kept = [np.ones(1_000_000) for _ in range(3)]
    del kept[1]
    trim_heap()  # glibc: returns free heap memory; elsewhere: nothing
    assert all(float(k.sum()) == 1_000_000.0 for k in kept)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/statm")
def test_releasing_a_slice_drops_that_slice_s_pages(tmp_path):
    """A slice's pages, not the file's first ones: the mapping's start comes from the
    memmap that owns it (a slice carries the same ``offset`` but starts elsewhere)."""
    path = tmp_path / "t.bin"
    np.arange(20_000_000, dtype=np.int64).tofile(path)  # 160 MB
    t = np.memmap(path, dtype=np.int64, mode="r", offset=8)  # an offset, as in a .npy
    assert int(t[::512].sum()) > 0  # every page in
    touched = _rss_mb()
    half = t.shape[0] // 2
    for a in range(half, t.shape[0], 65536):  # the second half, a block at a time
        release(t[a : a + 65536])
    dropped = touched - _rss_mb()
    assert 60 < dropped < 100  # about the 80 MB released, not 65536 x 8 bytes
    assert int(t[::512][:10].sum()) == sum(range(1, 5121, 512))  # values intact
    release(np.asarray(t[: half // 2]))  # an ndarray view of a slice: found through .base
    assert touched - _rss_mb() > dropped + 25


def test_released_gives_back_behind_a_pass_in_steps(tmp_path, monkeypatch):
    """Released calls release on the rows a pass is done with, once a step's worth has
    gathered (and at the end), from its start on, along the given axis; arrays in memory
    are left out."""
    import analyzer.paging as paging

    calls = []
    monkeypatch.setattr(paging, "release", lambda a: calls.append(a.shape))
    monkeypatch.setattr(paging, "RELEASE_ROWS", 100)
    a = paging.buffer(tmp_path, "a", (1000, 3))  # (n, m) view of an (m, n) file
    b = np.lib.format.open_memmap(tmp_path / "b.npy", mode="w+", shape=(3, 1000)).T.T
    r = paging.Released(a, np.zeros((1000, 3)), None)
    assert len(r.arrays) == 1
    r.upto(50)
    assert calls == []
    r.upto(120)
    assert calls == [(120, 3)]
    r.upto(130, final=True)
    assert calls == [(120, 3), (10, 3)]
    calls.clear()
    c = paging.Released(b, axis=1, start=400)
    c.upto(450)
    c.upto(520)
    assert calls == [(3, 120)]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/statm")
def test_buffer_is_channel_major_unlinked_and_released_per_channel(tmp_path):
    """A buffer is an (n, m) view of an (m, n) memory map whose file is already gone;
    releasing a block of its rows gives back each channel's stretch."""
    from analyzer.paging import buffer

    a = buffer(tmp_path, "x", (2_000_000, 8))  # 128 MB
    assert a.shape == (2_000_000, 8) and a[:, 3].flags.c_contiguous
    assert list(tmp_path.iterdir()) == []
    a[:] = 2.0
    touched = _rss_mb()
    release(a[:1_000_000])
    assert _rss_mb() < touched - 50
    assert float(a[:, 5].sum()) == 4_000_000.0
    assert isinstance(buffer(None, "y", (10, 2)), np.ndarray)


def test_mapped_files_reserve_their_space_and_a_full_disk_is_an_error(tmp_path, monkeypatch):
    """A memory-mapped scratch file has its blocks reserved when it is made: a full disk
    is an OSError naming the file and TMPDIR then, instead of a SIGBUS at the first store
    into a page the disk has no room for. A file system without fallocate keeps the
    sparse file."""
    import errno
    import os

    from analyzer import paging

    ok = paging.mapped_file(tmp_path / "a.npy", (1000, 4), np.float64)
    assert os.stat(tmp_path / "a.npy").st_blocks * 512 >= ok.nbytes

    def full(fd, offset, size):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "posix_fallocate", full)
    with pytest.raises(OSError, match="No space left on device.*TMPDIR") as err:
        paging.buffer(tmp_path, "resid", (1000, 4))
    assert err.value.filename.startswith(str(tmp_path / "resid-"))
    assert [p.name for p in tmp_path.iterdir()] == ["a.npy"]  # the buffer's file is gone

    def unsupported(fd, offset, size):
        raise OSError(errno.EOPNOTSUPP, "Operation not supported")

    monkeypatch.setattr(os, "posix_fallocate", unsupported)
    b = paging.mapped_file(tmp_path / "b.npy", (10, 2), np.float32)
    b[:] = 1.0
    assert b.shape == (10, 2)


@pytest.mark.parametrize("in_memory", [False, True])
def test_scratch_rows_are_reused_and_go_with_the_pool(tmp_path, monkeypatch, in_memory):
    """A returned row is lent again (same memory, holding the last pass's values, so a
    user overwrites it whole); rows in use at once are distinct; without a workdir there
    is no row; a pickled pool arrives empty. Rows up to MEMORY_ROW_BYTES are in memory,
    longer ones in files (here the bound moved to put these 1000-sample rows on each
    side of it)."""
    import pickle
    import threading

    from analyzer import paging
    from analyzer.paging import ScratchRows, is_mapped

    monkeypatch.setattr(paging, "MEMORY_ROW_BYTES", 8000 if in_memory else 7999)
    pool = ScratchRows(tmp_path)
    with pool.row("a", 1000) as first:
        assert first is not None and is_mapped(first) != in_memory
        assert first.dtype == np.float64
        first[:] = 7.0
    with pool.row("b", 1000) as again:
        assert np.shares_memory(again, first)
        assert float(again[0]) == 7.0
        with pool.row("c", 1000) as other, pool.row("d", 500) as short:
            assert not np.shares_memory(other, again)
            assert short.shape == (500,) and not is_mapped(short)  # 4000 bytes: in memory
    assert pool.made == 3
    lent: list[np.ndarray] = []
    barrier = threading.Barrier(2)

    def use() -> None:
        with pool.row("t", 1000) as r:
            lent.append(r)
            barrier.wait()  # both threads hold a row at once

    threads = [threading.Thread(target=use) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not np.shares_memory(lent[0], lent[1])
    assert pool.made == 3  # both came from the free rows
    with ScratchRows(None).row("x", 10) as none:
        assert none is None
    copy = pickle.loads(pickle.dumps(pool))
    assert copy.workdir == tmp_path and copy.made == 0
    assert not any(tmp_path.iterdir())  # the files were unlinked as they were made


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/statm")
def test_write_rows_writes_every_byte_when_pwrite_writes_fewer(tmp_path, monkeypatch):
    """``os.pwrite`` may write fewer bytes than asked (Linux: at most 2 GiB a call): the
    rest is written by further calls, not lost."""
    import os

    from analyzer.paging import buffer, write_rows

    real = os.pwrite
    calls = []

    def short(fd, data, offset):
        calls.append(len(memoryview(data).cast("B")))
        return real(fd, memoryview(data).cast("B")[:1000], offset)  # 1000 bytes at most

    a = buffer(tmp_path, "w", (5000, 3))
    block = np.random.default_rng(1).standard_normal((4000, 3))
    monkeypatch.setattr(os, "pwrite", short)
    write_rows(a, 500, block)
    write_rows(a[:, 1], 4600, np.arange(300.0))  # one channel's column
    monkeypatch.undo()
    np.testing.assert_array_equal(a[500:4500], block)
    np.testing.assert_array_equal(a[4600:4900, 1], np.arange(300.0))
    assert max(calls) == 32_000 and len(calls) == 3 * 32 + 3  # 32 calls a column, 3 for one


def test_write_rows_writes_a_buffer_s_file_without_mapping_its_pages(tmp_path):
    """Rows written into a memory-mapped buffer go to its file (the map sees them at
    once, in its own precision), and none of the written pages joins the resident set;
    rows of a view (a block's rows) land at the view's place; anything else is a plain
    assignment."""
    from analyzer.paging import buffer, write_rows

    n, m = 1_000_000, 8  # 64 MB
    a = buffer(tmp_path, "w", (n, m))
    rng = np.random.default_rng(0)
    block = rng.standard_normal((n // 2, m))
    step = 50_000
    before = _rss_mb()
    for s in range(0, n // 2, step):  # as a detector writes: a block at a time
        write_rows(a, s, block[s : s + step])
        write_rows(a[n // 2 :], s, block[::-1][s : s + step])  # a view's rows: from n // 2
    assert _rss_mb() < before + 20  # a store through the map would add 64 MB
    np.testing.assert_array_equal(a[: n // 2], block)
    np.testing.assert_array_equal(a[n // 2 :], block[::-1])
    single = buffer(tmp_path, "s", (1000, 3), np.float32)
    part = np.arange(300.0).reshape(100, 3) / 7
    write_rows(single, 450, part)
    np.testing.assert_array_equal(single[450:550], part.astype(np.float32))
    write_rows(single, 999, part[:0])  # nothing to write
    write_rows(single[:, 1], 10, np.arange(5.0))  # one channel's column
    np.testing.assert_array_equal(single[10:15, 1], np.arange(5.0, dtype=np.float32))
    assert single[10:15, [0, 2]].sum() == 0.0
    plain = np.zeros((10, 3))
    write_rows(plain, 2, np.ones((3, 3)))  # in memory: an assignment
    assert plain.sum() == 9.0 and plain[2:5].all()
    rows_major = np.zeros((3, 10)).T  # an (n, m) view of a row-major array in memory
    write_rows(rows_major, 7, np.full((3, 3), 2.0))
    assert rows_major[7:].sum() == 18.0


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/statm")
def test_a_pass_by_row_blocks_holds_a_block_of_a_mapped_record(tmp_path):
    """finite_rows (and any pass by row_blocks) reads a memory-mapped record a block at a
    time and gives each back: the resident set grows by a block, not the record; the
    answer is np.isfinite(a).all(axis=1), for a record in memory too."""
    from analyzer.paging import finite_rows, row_blocks

    a = np.lib.format.open_memmap(
        tmp_path / "rec.npy", mode="w+", dtype=np.float64, shape=(1_000_000, 16)
    )  # 128 MB
    a[:] = 1.0
    a[123_456, 7] = np.nan
    a.flush()
    release(a)
    ro = np.lib.format.open_memmap(tmp_path / "rec.npy", mode="r")
    before = _rss_mb()
    got = finite_rows(ro)
    assert _rss_mb() < before + 40  # 128 MB read
    assert np.flatnonzero(~got).tolist() == [123_456]
    small = np.ones((10, 3))
    small[4, 1] = np.inf
    np.testing.assert_array_equal(finite_rows(small), np.isfinite(small).all(axis=1))
    assert [(lo, b.shape[0]) for lo, b in row_blocks(small, 4)] == [(0, 4), (4, 4), (8, 2)]


def test_finite_rows_of_some_columns_and_of_a_vector():
    rng = np.random.default_rng(4)
    a = rng.normal(size=(1000, 5))
    a[[3, 500, 999], [0, 2, 4]] = np.nan
    np.testing.assert_array_equal(finite_rows(a), np.isfinite(a).all(axis=1))
    some = [1, 2]
    np.testing.assert_array_equal(
        finite_rows(a, some, rows=97), np.isfinite(a[:, some]).all(axis=1)
    )
    np.testing.assert_array_equal(finite_rows(a[:, 4], rows=97), np.isfinite(a[:, 4]))


def test_spill_converts_a_long_row_a_piece_at_a_time(tmp_path, monkeypatch):
    """A row that is converted (float64 to float32 here) goes to the file a piece at a
    time, each piece of a memory-mapped source given back behind it: neither the row's
    pages nor a converted copy of the whole row are held (both as long as the
    archive); the file holds the row's values rounded once."""
    from analyzer import paging

    n = 3 * paging.RELEASE_ROWS + 77
    src = paging.buffer(tmp_path, "src", (n, 2))  # float64, channel-major, mapped
    values = np.random.default_rng(2).standard_normal((n, 2))
    src[:] = values
    released = []
    real = paging.release
    monkeypatch.setattr(paging, "release", lambda a: (released.append(a.shape), real(a)))
    rows = spill({"x": src[:, 0], "y": src[:, 1]}, tmp_path / "s.npy", np.float32)
    for k, name in enumerate(("x", "y")):
        np.testing.assert_array_equal(rows[name], values[:, k].astype(np.float32))
    assert released == [(paging.RELEASE_ROWS,)] * 3 + [(77,)] + [(paging.RELEASE_ROWS,)] * 3 + [
        (77,)
    ]


_FAULTS_OF_A_BLOCK_LOOP = """
import resource, sys
import numpy as np
from analyzer.paging import heap_tuned, tune_heap
def faults():
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt
def loop():
    np.ones(1 << 20).sum()  # 8 MB: the first one is mapped either way
    before = faults()
    for _ in range(40):  # a pass's block arrays: the same size allocated and freed again
        np.ones(1 << 20).sum()
    return faults() - before
if sys.argv[1] == "tuned":
    assert tune_heap()
if sys.argv[1] in ("block", "after"):
    with heap_tuned(), heap_tuned():  # (nested: restored when the outer one ends)
        inside = loop()
    print(inside if sys.argv[1] == "block" else loop())
else:
    print(loop())
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_tune_heap_keeps_freed_blocks_for_the_next_allocation():
    import subprocess

    counts = {}
    for how in ("default", "tuned"):
        out = subprocess.run(
            [sys.executable, "-c", _FAULTS_OF_A_BLOCK_LOOP, how],
            capture_output=True,
            text=True,
            check=True,
        )
        counts[how] = int(out.stdout.split()[-1])
    # by default each 8 MB block is mapped and unmapped again (its pages faulted in and
    # zeroed by the kernel each time); tuned, the freed block is reused from the heap
    assert counts["default"] >= 40, counts  # at least a fault per block (huge pages: few)
    assert counts["tuned"] < counts["default"] / 10, counts


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_heap_tuned_tunes_a_dask_worker_s_heap_for_a_block_then_restores_it():
    import os
    import subprocess

    env = dict(os.environ, MALLOC_TRIM_THRESHOLD_="65536")  # as Dask's nanny starts workers
    counts = {}
    for how in ("default", "block", "after"):
        out = subprocess.run(
            [sys.executable, "-c", _FAULTS_OF_A_BLOCK_LOOP, how],
            capture_output=True,
            text=True,
            check=True,
            env=env,
        )
        counts[how] = int(out.stdout.split()[-1])
    assert counts["default"] >= 40, counts
    assert counts["block"] < counts["default"] / 10, counts
    assert counts["after"] >= 40, counts  # the worker's own setting is back
