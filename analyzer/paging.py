"""Bounded resident memory for long arrays kept in memory-mapped files.

A long archive's aligned matrix and the signals the detectors keep (residuals, fault-free
estimates) are written to ``.npy`` files in the run's scratch directory and memory-mapped
(shared mappings). Every page a pass reads or writes stays in the process's resident set
until it is unmapped, so a pass over the whole record would hold the whole record. The
passes therefore hand the pages they are done with back to the operating system
(:func:`release`, ``madvise(MADV_DONTNEED)``): the data stays in the file and in the
kernel's page cache (reclaimable, not the process's), and a later read faults it back in.
What a pass holds at once is then its block, not the record.

:func:`spill` moves a detector's kept signals to such a file, one channel after the other
(a detector's whole float64 buffer is narrowed over its own file instead);
:func:`buffer` makes the channel-major file a detector writes its per-sample outputs
into, block by block (:func:`write_rows`: by ``pwrite``, not through the map), and
:class:`Released` gives back a pass's pages behind it.
:func:`mapped_file` reserves a new file's disk space up front (a full disk is then an
error, not a SIGBUS). Arrays that are not file-backed (in memory, private copies) are
left alone: :func:`release` is safe to call on anything.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import errno
import mmap
import os
import sys
import tempfile
import threading
import weakref
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.errors import ScratchFull
from analyzer.scratch import FULL

FOLIO = 2 << 20
"""What :func:`release` rounds its byte range out to (from the mapping's start, which is
at a file offset that is a multiple of it for every mapping made here). The page cache
of a recent kernel holds a file in *large folios* (up to 2 MB) and maps a whole folio on
a fault: reading one sample of a spilled channel maps up to 2 MB around it. A release of
just the bytes read left the rest of the folio in the resident set; on a day-long
archive that was 70 % of every channel's time file after the alignment. Releasing a
little more than was read costs a page fault on the next access, nothing else: the
data stays in the page cache."""

_SHARED_MODES = ("r", "r+", "w+")
"""np.memmap modes whose mapping is shared: dropping a page loses nothing (mode ``c`` is
copy-on-write, where it would drop the changes)."""


def _mapping(a: Any) -> tuple[mmap.mmap, int] | None:
    """The shared mapping ``a`` lives in and the address where that mapping starts.

    The start is found from the memmap that owns the mapping (its ``base`` is the
    ``mmap`` itself), the one array whose data begins at the mapping's start plus the
    file offset's remainder modulo the allocation granularity. A view (a row, a slice)
    also carries ``_mmap`` and ``offset``, but begins elsewhere: computed from the view,
    the start came out at the view's first byte, so releasing a slice dropped pages at
    the beginning of the file instead of the slice's own."""
    obj = a
    while obj is not None:
        base = getattr(obj, "base", None)
        if isinstance(obj, np.memmap) and isinstance(base, mmap.mmap):
            if getattr(obj, "mode", None) not in _SHARED_MODES:
                return None
            start = obj.__array_interface__["data"][0] - obj.offset % mmap.ALLOCATIONGRANULARITY
            return base, start
        obj = base
    return None


def is_mapped(a: Any) -> bool:
    """True when ``a`` is (a view of) a shared memory map, whose pages :func:`release`
    can give back."""
    return isinstance(a, np.ndarray) and _mapping(a) is not None


def release(a: npt.NDArray[Any] | None) -> None:
    """Drop the resident pages that hold ``a`` (a memory-mapped array or any view of one);
    a no-op for arrays in memory. The values stay readable: the next access reads them
    back from the page cache or the file."""
    if a is None or not hasattr(mmap, "MADV_DONTNEED") or a.size == 0:
        return
    if a.ndim == 2 and not (a.flags.c_contiguous or a.flags.f_contiguous):
        # rows ``a .. b`` of a channel-major buffer (:func:`buffer`): one stretch per
        # channel, not everything between the first channel's and the last's
        inner = int(np.argmin(np.abs(a.strides)))
        if abs(a.strides[1 - inner]) > mmap.PAGESIZE:
            for k in range(a.shape[1 - inner]):
                release(a[k] if inner == 1 else a[:, k])
            return
    found = _mapping(a)
    if found is None:
        return
    mm, start = found
    lo, hi = np.lib.array_utils.byte_bounds(a)
    first = max(0, (lo - start) // FOLIO * FOLIO)
    last = min(len(mm), -(-(hi - start) // FOLIO) * FOLIO)
    if last > first:
        mm.madvise(mmap.MADV_DONTNEED, first, last - first)


RELEASE_ROWS = 1 << 16
"""Rows a sequential pass works through between two releases (:class:`Released`): a
release per chunk of a few thousand rows cost a ``madvise`` per array and channel, and
each one interrupts the other core to flush its TLB."""


def read_column(values: npt.NDArray[Any], j: int, a: int, b: int) -> npt.NDArray[np.float64]:
    """Column ``j`` of rows ``a .. b - 1`` of a 2-D array as a new float64 array, read
    :data:`RELEASE_ROWS` rows at a time with each piece's pages given back (a no-op in
    memory): a column of a row-major matrix lies on every page of its rows, so reading a
    long stretch of it whole would map all of them."""
    out = np.empty(max(0, b - a))
    for p in range(a, b, RELEASE_ROWS):
        q = min(b, p + RELEASE_ROWS)
        rows = values[p:q]
        out[p - a : q - a] = rows[:, j]
        release(rows)
    return out


def row_blocks(
    a: npt.NDArray[Any], rows: int = RELEASE_ROWS
) -> Iterator[tuple[int, npt.NDArray[Any]]]:
    """``(lo, a[lo : lo + rows])`` for ``lo = 0, rows, ...``: a pass over a long array a
    block of rows at a time, each block's pages given back (:func:`release`) once the
    caller asks for the next, so a pass over a memory-mapped record holds a block of it,
    not the record. For an array in memory, the plain blocks."""
    for lo in range(0, a.shape[0], rows):
        block = a[lo : lo + rows]
        yield lo, block
        release(block)


def finite_rows(
    a: npt.NDArray[Any], columns: Sequence[int] | None = None, rows: int = RELEASE_ROWS
) -> npt.NDArray[np.bool_]:
    """``np.isfinite(a[:, columns]).all(axis=1)`` (every column by default; a 1-D ``a``
    is one column) taken ``rows`` rows at a time (:func:`row_blocks`): neither a boolean
    copy of ``a`` nor a memory-mapped record's pages are held."""
    out = np.empty(a.shape[0], dtype=bool)
    for lo, block in row_blocks(a, rows):
        part = np.asarray(block) if columns is None else np.asarray(block)[:, columns]
        finite = np.isfinite(part)
        out[lo : lo + part.shape[0]] = finite if finite.ndim == 1 else finite.all(axis=1)
    return out


class Released:
    """The pages of a pass's arrays given back behind it, :data:`RELEASE_ROWS` at a time:
    ``upto(k)`` once the pass is done with indices ``start .. k - 1`` along ``axis`` of
    each array (``final=True`` at the end). A no-op for arrays in memory."""

    def __init__(self, *arrays: npt.NDArray[Any] | None, axis: int = 0, start: int = 0) -> None:
        self.arrays = [a for a in arrays if a is not None and is_mapped(a)]
        self.axis = axis
        self.done = start

    def upto(self, stop: int, final: bool = False) -> None:
        if not self.arrays or (stop - self.done < RELEASE_ROWS and not final):
            return
        if stop > self.done:
            for a in self.arrays:
                index = [slice(None)] * a.ndim
                index[self.axis] = slice(self.done, stop)
                release(a[tuple(index)])
        self.done = max(self.done, stop)


def spill(
    signals: Mapping[str, npt.NDArray[Any]], path: Path, dtype: npt.DTypeLike
) -> dict[str, npt.NDArray[Any]]:
    """``signals`` (equal-length 1-D arrays) written as the rows of one ``.npy`` file at
    ``path`` and returned as read-only views of its memory map, in the same order; each
    in-memory array can be freed by the caller as soon as this returns.

    The rows go to the file by ``write`` (a copy into the page cache), not through a
    writable mapping: storing into a new file's mapping faults every page in (and the
    kernel zeroes each before the store overwrites it): 0.83 s of CPU against 0.69 s for
    the three detectors' signals of a 4-hour, 16-channel run. None of the rows' pages is
    in the process's resident set afterwards until it is read.

    A signal that already is a contiguous row of a shared memory map in ``dtype`` (a
    detector that wrote its outputs into :func:`buffer` in that precision) is not
    copied: it is returned as a read-only view of its own map, its pages given back.
    Copying it only wrote the same bytes a second time (1.7 GB of the 3.3 GB spilled
    by a 24-hour, 16-channel run). ``path`` is written only for the other signals.

    A detector's whole float64 :func:`buffer` handed over (each of its rows one of the
    signals: the bank's residuals or estimates, the detection filter's fault estimates)
    is narrowed over its own file instead (:func:`_narrowed`): the signals are handed
    over, and the wide values are not read again. A new file for them took pages the
    kernel had to find, and on this project's virtual machines a page the run had not
    touched yet costs a fault on the host too: 276 MB of the 1.53 GB a 4-hour,
    16-channel run wrote."""
    names = list(signals)
    if not names:
        return {}
    kind = np.dtype(dtype)
    n = int(np.asarray(signals[names[0]]).shape[0])
    kept: dict[str, npt.NDArray[Any]] = {}
    for name in names:
        a = signals[name]
        if np.shape(a) != (n,):
            raise ValueError(f"spill: {name} has shape {np.shape(a)}, expected ({n},)")
        if _in_place(a, kind):
            view = a.view()
            view.flags.writeable = False
            kept[name] = view
            release(a)
    kept.update(_narrowed({k: v for k, v in signals.items() if k not in kept}, kind))
    rest = [name for name in names if name not in kept]
    if rest:
        header = {"descr": np.lib.format.dtype_to_descr(kind), "fortran_order": False}
        with open(path, "wb") as f:
            np.lib.format.write_array_header_1_0(f, {**header, "shape": (len(rest), n)})
            for name in rest:
                # a piece at a time, each given back behind (a memory-mapped source): a
                # whole row converted at once held the row's pages and its copy, both
                # as long as the archive
                sig = signals[name]
                for at in range(0, n, RELEASE_ROWS):
                    piece = sig[at : at + RELEASE_ROWS]
                    f.write(np.ascontiguousarray(piece, dtype=kind).data)
                    release(piece)
        # no flush to disk (fsync): the file is scratch space read back through the same
        # page cache, so forcing its pages to disk would only wait on the disk; the kernel
        # writes them back in its own time (or drops the file with the work directory)
        out = np.load(path, mmap_mode="r")
        kept.update({name: out[i] for i, name in enumerate(rest)})
    return {name: kept[name] for name in names}


def _narrowed(
    signals: Mapping[str, npt.NDArray[Any]], kind: np.dtype[Any]
) -> dict[str, npt.NDArray[Any]]:
    """The signals that are the rows of a wider :func:`buffer` (every row of it, each
    once), as read-only rows of ``kind`` over the same file: row by row from the first,
    a piece at a time, each piece converted in memory and written by ``pwrite`` where
    the narrow rows lie, at or before the wide values still to be read (``kind`` is
    narrower: row ``r``'s piece at ``at`` goes to ``(r n + at) * size``, whose end is
    before the wide values not yet read, at ``(r n + at + piece) * wide``). The pages
    written are the buffer's own (no new ones), and those of the wide values' second
    half are given back to the kernel (a hole punched in the unlinked file: the old
    mapping reads zeros there, not a SIGBUS). The same values as a copy to a new file:
    each rounded once from the buffer's. The buffer's wide values are gone after:
    only for signals handed over (:func:`spill`). Others are left out of the result."""
    groups: dict[int, tuple[np.memmap[Any, Any], dict[int, str]]] = {}
    for name, a in signals.items():
        owner = _owner(a)
        if (
            owner is None
            or id(owner.base) not in _WRITERS
            or owner.ndim != 2
            or owner.dtype.kind != "f"
            or kind.kind != "f"
            or not owner.flags.c_contiguous
            or owner.dtype.itemsize <= kind.itemsize
            or a.dtype != owner.dtype
            or a.shape != owner.shape[1:]
            or a.strides != (owner.itemsize,)
        ):
            continue
        width = owner.shape[1] * owner.itemsize
        at = a.__array_interface__["data"][0] - owner.__array_interface__["data"][0]
        if at % width:
            continue
        rows = groups.setdefault(id(owner), (owner, {}))[1]
        rows.setdefault(at // width, name)
    out: dict[str, npt.NDArray[Any]] = {}
    for owner, rows in groups.values():
        m, n = owner.shape
        if sorted(rows) != list(range(m)) or len(rows) != sum(
            1 for a in signals.values() if _owner(a) is owner
        ):
            continue  # not the whole buffer, or a row handed over twice: copied instead
        fd = _WRITERS[id(owner.base)][0]
        start = int(owner.offset)
        for r in range(m):
            wide = owner[r]
            for at in range(0, n, RELEASE_ROWS):
                piece = wide[at : at + RELEASE_ROWS]
                narrow = np.ascontiguousarray(piece, dtype=kind)
                pwrite_all(fd, narrow.data, start + (r * n + at) * kind.itemsize)
                release(piece)
        with os.fdopen(os.dup(fd), "r+b") as f:
            narrowed = np.memmap(f, dtype=kind, mode="r+", offset=start, shape=(m, n))
            _punch(f.fileno(), start + m * n * kind.itemsize, start + m * n * owner.itemsize)
        for r, name in rows.items():
            view = narrowed[r].view()
            view.flags.writeable = False
            out[name] = view
    return out


def _owner(a: Any) -> np.memmap[Any, Any] | None:
    """The memory map that ``a`` is (a view of), made by ``np.memmap`` on a file."""
    obj = a
    while obj is not None:
        base = getattr(obj, "base", None)
        if isinstance(obj, np.memmap) and isinstance(base, mmap.mmap):
            return obj
        obj = base
    return None


_FALLOC_FL_KEEP_SIZE, _FALLOC_FL_PUNCH_HOLE = 0x01, 0x02  # linux/falloc.h


def _fallocate_function() -> Any:
    try:
        fn = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True).fallocate
    except (OSError, AttributeError):  # not Linux: the pages stay until the file goes
        return None
    fn.argtypes = (ctypes.c_int, ctypes.c_int, ctypes.c_int64, ctypes.c_int64)
    return fn


_FALLOCATE = _fallocate_function()


def _punch(fd: int, lo: int, hi: int) -> None:
    """Give back the pages of bytes ``lo .. hi - 1`` of the file (whole pages within
    them; the size is kept, the hole reads zeros); nothing where it cannot."""
    lo = -(-lo // mmap.PAGESIZE) * mmap.PAGESIZE
    if _FALLOCATE is not None and hi > lo:
        _FALLOCATE(fd, _FALLOC_FL_KEEP_SIZE | _FALLOC_FL_PUNCH_HOLE, lo, hi - lo)


def _in_place(a: Any, kind: np.dtype[Any]) -> bool:
    """Whether ``a`` is a contiguous 1-D array of ``kind`` in a shared memory map (what
    :func:`spill` would only copy)."""
    return (
        isinstance(a, np.ndarray)
        and a.ndim == 1
        and a.dtype == kind
        and a.flags.c_contiguous
        and is_mapped(a)
    )


def buffer(
    workdir: Path | None, name: str, shape: tuple[int, int], dtype: npt.DTypeLike = np.float64
) -> npt.NDArray[Any]:
    """A new ``(n, m)`` array for a detector's per-sample outputs (``m`` channels, ``n``
    samples). With ``workdir`` it is a channel-major memory map (the transpose of an
    ``(m, n)`` ``.npy`` file): each channel's samples are contiguous, so a pass over one
    channel reads one stretch of the file, and writing a block of rows touches ``m``
    stretches that :func:`release` gives back. The file is unlinked at once: its space
    lives as long as the mapping does, and nothing is left behind by a killed run.
    Without ``workdir``, an uninitialised array in memory."""
    n, m = shape
    if workdir is None:
        return np.empty(shape, dtype)
    fd, tmp = tempfile.mkstemp(prefix=f"{name}-", suffix=".npy", dir=workdir)
    path = Path(tmp)
    try:
        out = mapped_file(path, (m, n), dtype)
    except BaseException:
        os.close(fd)
        raise
    finally:
        with contextlib.suppress(OSError):  # where an open file cannot be unlinked: the
            path.unlink()  # scratch directory's removal takes it
    found = _mapping(out)
    if found is None:  # pragma: no cover - open_memmap always maps shared
        os.close(fd)
    else:  # kept open for write_rows; closed with the map
        mapped_at = int(out.offset) - int(out.offset) % mmap.ALLOCATIONGRANULARITY
        _WRITERS[id(found[0])] = (fd, mapped_at)
        weakref.finalize(out, _forget_writer, id(found[0]), fd)
    return out.T


_WRITERS: dict[int, tuple[int, int]] = {}
"""id of a :func:`buffer`'s ``mmap`` -> (a descriptor of its file, the file offset where
the mapping starts), for :func:`write_rows`; dropped when the map is."""


def _forget_writer(key: int, fd: int) -> None:
    _WRITERS.pop(key, None)
    with contextlib.suppress(OSError):
        os.close(fd)


def write_rows(out: npt.NDArray[Any], a: int, block: npt.ArrayLike) -> None:
    """``out[a : a + len(block)] = block`` for ``out`` made by :func:`buffer` (or a view
    of rows of it, or one channel's column). Into a memory-mapped buffer the rows go to
    its file by ``pwrite``, one stretch per channel, not through the mapping: a store
    into a new file's mapping faults every page in (the kernel zeroes each, then maps it
    into the process, which must then give it back), 0.25 s of system time per 184 MB
    channel-major buffer written a block at a time against 0.05 s for the same bytes by
    ``pwrite``. The map sees the new values at once (one page cache). Anything else: a
    plain assignment."""
    block = np.asarray(block)
    if block.shape[0] == 0:
        return
    found = _mapping(out) if out.ndim in (1, 2) else None
    writer = None if found is None else _WRITERS.get(id(found[0]))
    rows = block.shape[0]
    if (
        writer is None
        or block.shape != (rows, *out.shape[1:])
        or a < 0
        or a + rows > out.shape[0]
        or out.strides[0] != out.itemsize
    ):
        out[a : a + rows] = block
        return
    assert found is not None
    fd, file_at = writer
    base = out[a:].__array_interface__["data"][0] - found[1] + file_at
    if out.ndim == 1:
        pwrite_all(fd, np.ascontiguousarray(block, dtype=out.dtype).data, base)
        return
    # channel-major, as the file is (no copy when the block already is, in its dtype)
    cols = np.ascontiguousarray(block.T, dtype=out.dtype)
    for k in range(out.shape[1]):
        pwrite_all(fd, cols[k].data, base + k * out.strides[1])


def pwrite_all(fd: int, data: memoryview, at: int) -> None:
    """``os.pwrite`` of the C-contiguous buffer ``data`` at offset ``at`` until every byte
    is written: one call may write fewer (Linux writes at most 2 GiB per call, a month of
    one channel at 100 Hz), and the rest would be silently lost."""
    rest = data.cast("B")
    while rest:
        done = os.pwrite(fd, rest, at)
        rest, at = rest[done:], at + done


MEMORY_ROW_BYTES = 32 << 20
"""Scratch rows up to this size (4.2 M samples: 11.6 hours at 100 Hz) are kept in memory
by :class:`ScratchRows`, longer ones in files: as many exist as passes run at once, so
their memory is bounded whatever the record's length."""


class ScratchRows:
    """Float64 rows of the record's length for the passes of one detector run, in
    memory-mapped files in ``workdir`` (:func:`buffer`) that are reused: a pass borrows a
    row (:meth:`row`), fills it whole, and hands it back for the next pass. A row of at
    most :data:`MEMORY_ROW_BYTES` is an array in memory instead, reused the same way: a
    file row costs a copy into the page cache for every pass's write (``pwrite``) and a
    page fault for every page read back; at 4 hours of 16 channels (11.5 MB rows) the
    file rows took 0.5 s more of the kernel's time in a 7.5-8.5 s run (5 alternating pairs).

    A per-channel pass of a long archive (a filter's reference in sensor units, an
    observer's fault estimate) needs such a row only while it runs. A new file for each
    channel made the kernel zero every page of it on first touch and later write it
    back: at 24 hours, 16 channels, three rows of 69 MB per channel, 3.3 GB of the 13.6
    GB the run wrote. Reused, a row's pages are already in the page cache: as many rows
    exist as passes run at once (one per thread). The rows go when the pool does (the
    end of the detector's run). Without ``workdir`` a row is a new array in memory.

    Every user must overwrite the whole row before reading it: a borrowed row holds the
    previous pass's values. Pickled (a task shipped elsewhere), the pool arrives empty."""

    def __init__(self, workdir: Path | None) -> None:
        self.workdir = workdir
        self._free: list[npt.NDArray[np.float64]] = []
        self._lock = threading.Lock()
        self.made = 0
        """Rows created so far (the rest of the borrowing reused them)."""

    def __reduce__(self) -> tuple[type[ScratchRows], tuple[Path | None]]:
        return (ScratchRows, (self.workdir,))

    @contextlib.contextmanager
    def row(self, name: str, n: int) -> Iterator[npt.NDArray[np.float64] | None]:
        """A float64 row of ``n`` samples for the ``with`` block (None without a
        ``workdir``: the caller then uses memory); its pages are given back after."""
        if self.workdir is None:
            yield None
            return
        with self._lock:
            found = next((k for k, r in enumerate(self._free) if r.shape[0] == n), None)
            out = None if found is None else self._free.pop(found)
        if out is None:
            if n * np.dtype(np.float64).itemsize <= MEMORY_ROW_BYTES:
                out = np.empty(n)
            else:
                out = buffer(self.workdir, name, (n, 1))[:, 0]
            with self._lock:
                self.made += 1
        try:
            yield out
        finally:
            release(out)
            with self._lock:
                self._free.append(out)


_NO_FALLOCATE = {errno.EOPNOTSUPP, errno.EINVAL, errno.ENOSYS}


def mapped_file(path: Path, shape: tuple[int, ...], dtype: npt.DTypeLike) -> np.memmap[Any, Any]:
    """A new ``.npy`` file at ``path`` of ``shape`` and ``dtype``, memory-mapped for
    writing, with its disk blocks reserved up front (``posix_fallocate``). A store
    into a mapping of a sparse file that the disk has no room for kills the process
    with SIGBUS, no error, no clean-up; reserved, a full disk is an ``OSError`` here
    (naming the file and TMPDIR) that the CLI reports in one line. On a file system
    without ``fallocate`` the file stays sparse."""
    out = np.lib.format.open_memmap(path, mode="w+", dtype=dtype, shape=shape)
    size = int(out.offset) + int(out.nbytes)
    try:
        with open(path, "r+b") as f:
            os.posix_fallocate(f.fileno(), 0, size)
    except OSError as err:
        if err.errno in _NO_FALLOCATE:
            return out
        del out
        raise (ScratchFull if err.errno in FULL else OSError)(
            err.errno,
            f"{err.strerror} (scratch space for {size / 1e6:.0f} MB; set TMPDIR to a "
            "directory on a larger disk)",
            str(path),
        ) from err
    return out


def _malloc_trim() -> Any:
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        return libc.malloc_trim
    except (OSError, AttributeError):  # not glibc: nothing to trim
        return None


_TRIM = _malloc_trim()

_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3  # glibc's mallopt parameters (malloc.h)
HEAP_MMAP_THRESHOLD = 32 << 20
"""Allocations from this size on are mapped (and unmapped when freed) by glibc; smaller
ones come from its heaps (see :func:`tune_heap`)."""
HEAP_TRIM_THRESHOLD = 256 << 20
"""Free memory at the top of a heap that glibc keeps instead of giving back at each free
(the run gives it back itself between passes: :func:`trim_heap`)."""


def tune_heap() -> bool:
    """Let glibc keep freed memory for the next allocation instead of handing it back to
    the kernel at once (``mallopt``: a fixed mmap threshold of
    :data:`HEAP_MMAP_THRESHOLD`, a trim threshold of :data:`HEAP_TRIM_THRESHOLD`).

    A run allocates and frees the same few-MB block arrays thousands of times on its
    threads; by default glibc returns a thread heap's free top as soon as it exceeds twice
    the (dynamic) mmap threshold, so the next block's pages are faulted in and zeroed by
    the kernel again. Kept, they are reused: on the 4-hour 16-channel archives system
    time fell by 0.3-0.6 s and 11 of 13 alternating pairs of runs were faster, by 2-4 % at
    the median (within the machine's noise in a benchmark's medians); peak RSS rose by
    20-50 MB (it still falls back between passes, where :func:`trim_heap` trims every
    heap). On a Dask worker the difference is large (:func:`heap_tuned`). Process-wide, so it is
    called by the command line (``analyzer run``, the watcher's analyses), not by the
    library; in a process that is not the analyzer's own, :func:`heap_tuned`. Returns
    False where the C library is not glibc (nothing changed)."""
    return _mallopt(HEAP_TRIM_THRESHOLD, HEAP_MMAP_THRESHOLD)


_GLIBC_DEFAULT_THRESHOLD = 128 * 1024  # both thresholds' initial value (malloc.c)


def _mallopt_function() -> Any:
    if _TRIM is None:  # not glibc
        return None
    try:
        fn = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").mallopt
    except (OSError, AttributeError):
        return None
    fn.argtypes = (ctypes.c_int, ctypes.c_int)
    return fn


_MALLOPT = _mallopt_function()


def _mallopt(trim: int, mmap_at: int) -> bool:
    """glibc's trim and mmap thresholds set; False where there is no ``mallopt``."""
    if _MALLOPT is None:
        return False
    ok = _MALLOPT(_M_MMAP_THRESHOLD, mmap_at) == 1
    return bool(_MALLOPT(_M_TRIM_THRESHOLD, trim) == 1 and ok)


def _environment_threshold(name: str) -> int:
    """glibc's threshold as the environment sets it (``MALLOC_TRIM_THRESHOLD_``...), else
    its initial value."""
    try:
        return int(os.environ.get(name, ""))
    except ValueError:
        return _GLIBC_DEFAULT_THRESHOLD


_tuned_blocks = 0
_tuned_lock = threading.Lock()


@contextlib.contextmanager
def heap_tuned() -> Iterator[None]:
    """:func:`tune_heap` for the duration of the block, in a process that is not the
    analyzer's own: a Dask worker running its tasks. Dask's nanny starts workers with
    ``MALLOC_TRIM_THRESHOLD_=65536``, under which every freed block array goes back to
    the kernel: an hour of 16 channels took 14-15 s of CPU to analyze in a worker against
    8 s in a plain process, and 8.0-8.6 s tuned. When the last block that tuned the heap
    ends (blocks on several threads of a worker count), the thresholds go back to what
    the environment set (or glibc's initial 128 KiB; glibc's dynamic mmap threshold is
    then off)."""
    global _tuned_blocks
    with _tuned_lock:
        _tuned_blocks += 1
        if _tuned_blocks == 1:
            tune_heap()
    try:
        yield
    finally:
        with _tuned_lock:
            _tuned_blocks -= 1
            if _tuned_blocks == 0:
                _mallopt(
                    _environment_threshold("MALLOC_TRIM_THRESHOLD_"),
                    _environment_threshold("MALLOC_MMAP_THRESHOLD_"),
                )


def trim_heap() -> None:
    """Hand the C heap's free memory back to the operating system (glibc ``malloc_trim``).

    numpy's arrays of a few MB come from the heap once glibc has raised its mmap
    threshold (it does after the first large array is freed), and memory freed there
    stays in the process's resident set: between two passes over a long archive the
    freed per-sample arrays of the first would still count. Called between the passes;
    a no-op where the C library is not glibc."""
    if _TRIM is not None:
        _TRIM(0)
    arrow = sys.modules.get("pyarrow")
    if arrow is not None:  # Arrow's allocator (the CSV reader's) keeps freed blocks too
        arrow.default_memory_pool().release_unused()


__all__ = [
    "RELEASE_ROWS",
    "Released",
    "ScratchRows",
    "buffer",
    "heap_tuned",
    "is_mapped",
    "mapped_file",
    "read_column",
    "release",
    "spill",
    "trim_heap",
    "tune_heap",
]
