"""Checksums of the samples each channel hands from one stage to the next.

An analysis of a small CSV under heavy load came back wrong about once in 600 runs (the
first 2 265-2 397 rows of every channel missing, once 11 830 aligned values different)
and right on the same file again (benchmarks/README.md, ``stress_repeat.py``): samples
lost or changed *inside* the analyzer, between its own stages, without a word. A
:class:`Tally` counts what passes one point; two tallies of the same samples taken at
two points must agree, and where they do not, the stage between them corrupted them.

Per channel a tally keeps the number of samples and the sums, wrapping modulo 2**64, of
the bit patterns of their times (int64) and values (float64, viewed as uint64). Integer
addition is exact, commutative and associative, so the sums do not depend on the order
or the chunking of the samples (the reorderer sorts them, the store concatenates and
sorts them again) and need no tolerance: one bit changed anywhere, a NaN's payload, a
-0.0 for 0.0, a sample lost or doubled, changes them (short of two errors that cancel
exactly). One vectorised pass over each array, no Python per sample: of an hour of 16
channels at 100 Hz (5.76 M samples, a 123 MB CSV), one tally of the chunks took 3.3 ms
and the four a read takes (the reorderer's pushes and releases, the chunks handed to the
store, the store) 19 ms, beside 1.05-1.4 s to read the file into the store (the best of
runs on the loaded 2-core machine: ``benchmarks/README.md``, "stress_repeat").
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np
import numpy.typing as npt

from analyzer.errors import counted
from analyzer.readers.base import ChannelChunk

MOD = 1 << 64


def bitsum(a: npt.NDArray[np.int64] | npt.NDArray[np.float64]) -> int:
    """The sum of the 64-bit patterns of ``a``'s elements, modulo 2**64 (numpy's uint64
    sum wraps)."""
    if a.shape[0] == 0:
        return 0
    return int(np.add.reduce(a.view(np.uint64)))


class Tally:
    """Per channel: ``[samples, bitsum(times), bitsum(values)]`` of what it was given."""

    def __init__(self) -> None:
        self.sums: dict[str, list[int]] = {}
        self._last_t: npt.NDArray[np.int64] | None = None
        self._last_tsum = 0

    def add(self, name: str, t: npt.NDArray[np.int64], values: npt.NDArray[np.float64]) -> None:
        """Count the samples ``(t, values)`` of channel ``name``. The fields of one
        message (a CSV's columns) come with one time array: its sum is taken once (the
        array is held until the next one, so that its identity cannot be another
        array's)."""
        if t is self._last_t:
            tsum = self._last_tsum
        else:
            tsum = bitsum(t)
            self._last_t, self._last_tsum = t, tsum
        row = self.sums.setdefault(name, [0, 0, 0])
        row[0] += int(t.shape[0])
        row[1] = (row[1] + tsum) % MOD
        row[2] = (row[2] + bitsum(values)) % MOD

    def counted(self, chunks: Iterable[ChannelChunk]) -> Iterator[ChannelChunk]:
        """``chunks`` passed through, each counted as it passes."""
        for chunk in chunks:
            self.add(chunk.name, chunk.t_ns, chunk.values)
            yield chunk

    def differences(self, other: Tally, before: str, after: str) -> list[str]:
        """What differs between this tally (taken at ``before``) and ``other`` (taken at
        ``after``), one phrase per channel (channels with no samples count as absent)."""
        out = []
        names = [n for n in self.sums if self.sums[n][0]]
        names += [n for n in other.sums if other.sums[n][0] and n not in self.sums]
        for name in names:
            a = self.sums.get(name, [0, 0, 0])
            b = other.sums.get(name, [0, 0, 0])
            if a == b:
                continue
            if a[0] != b[0]:
                what = f"{counted(a[0], 'sample')} {before}, {b[0]} {after}"
            else:
                parts = [w for w, x, y in (("times", a[1], b[1]), ("values", a[2], b[2])) if x != y]
                what = (
                    f"{counted(a[0], 'sample')} {before} and {after}, but their "
                    f"{' and '.join(parts)} differ"
                )
            out.append(f"{name!r}: {what}")
        return out
