"""The shared first-order recursions against ``scipy.signal``, bit for bit."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_array_equal
from scipy import signal

from analyzer.detectors.lowpass import (
    lowpass,
    lowpass_reference,
    recursion,
    recursion_reference,
    steady_state_zi,
)


def _phis() -> np.ndarray:
    """Poles over (0, 1) in every scale the detectors use (``exp(-lambda dt)``, near 0 and
    near 1), plus a few negative ones."""
    rng = np.random.default_rng(11)
    return np.concatenate(
        [
            rng.uniform(0.0, 1.0, 4000),
            np.exp(-rng.uniform(0.0, 20.0, 4000)),
            1.0 - np.exp(-rng.uniform(0.0, 30.0, 4000)),
            rng.uniform(-1.0, 0.0, 1000),
            [0.0, 0.5, np.exp(-1.0), 0.3, 0.999, 1e-300, np.nextafter(1.0, 0.0)],
        ]
    )


def test_steady_state_zi_is_lfilter_zi_bit_for_bit():
    phis = _phis()
    ours = np.array([steady_state_zi(float(p)) for p in phis])
    ref = np.array([signal.lfilter_zi([1.0 - float(p)], [1.0, -float(p)])[0] for p in phis])
    assert_array_equal(ours.view(np.uint64), ref.view(np.uint64))
    # the closed form is not simply phi: the two roundings matter
    assert (ours != phis).any()


def test_compiled_lowpass_equals_lfilter():
    rng = np.random.default_rng(4)
    x = np.cumsum(rng.standard_normal(5000))
    x[:3] = np.nan
    x[2000:2100] = np.nan
    x[3000] = np.inf
    for phi in (np.exp(-1.0), 0.3, 0.999, *rng.uniform(0.0, 1.0, 20)):
        assert_array_equal(lowpass(x, float(phi)), lowpass_reference(x, float(phi)))
    y = rng.standard_normal(300)
    for phi in (0.2, 0.95):  # finite from the first sample: started at steady state
        assert_array_equal(lowpass(y, phi), lowpass_reference(y, phi))
        assert lowpass(np.full(50, 3.0), phi)[0] == lowpass_reference(np.full(50, 3.0), phi)[0]
    assert np.isnan(lowpass(np.full(10, np.nan), 0.5)).all()
    assert np.isnan(lowpass_reference(np.full(10, np.nan), 0.5)).all()


def test_lowpass_in_place_equals_a_new_array():
    """``out=x`` filters in place (the detection filter's alarm search keeps one
    whole-record array, not two): the same bits as into a new array, gaps included; a
    record with nothing finite comes back as it was."""
    rng = np.random.default_rng(7)
    x = np.cumsum(rng.standard_normal(3000))
    x[:2] = np.nan
    x[1000:1040] = np.nan
    x[2000] = -np.inf
    for phi in (0.1, 0.9, 0.999):
        expected = lowpass(x, phi)
        y = x.copy()
        got = lowpass(y, phi, out=y)
        assert got is y
        assert_array_equal(got, expected)
        other = np.empty_like(x)
        assert lowpass(x, phi, out=other) is other
        assert_array_equal(other, expected)
    z = np.array([np.nan, np.inf, np.nan])
    assert_array_equal(lowpass(z.copy(), 0.5, out=np.zeros(3)), z)


def test_compiled_recursion_equals_lfilter():
    rng = np.random.default_rng(5)
    x = rng.standard_normal(4000) * 10.0 ** rng.uniform(-3, 3, 4000)
    for phi in (*rng.uniform(0.0, 1.0, 20), 0.0, -0.7, 0.99999):
        for z0 in (0.0, 1.3, float(rng.standard_normal()) * 1e3):
            assert_array_equal(
                recursion(x, float(phi), z0).view(np.uint64),
                recursion_reference(x, float(phi), z0).view(np.uint64),
            )
    xs = x[::2]  # a strided view
    assert_array_equal(recursion(xs, 0.9, 0.5), recursion_reference(xs, 0.9, 0.5))
    bad = x.copy()
    bad[100] = np.nan
    bad[200] = np.inf
    assert_array_equal(recursion(bad, 0.9, 0.5), recursion_reference(bad, 0.9, 0.5))


def test_lowpass_of_a_memory_mapped_record_in_pieces(tmp_path, monkeypatch):
    """A memory-mapped record is filtered a piece at a time with the state carried and
    given back behind the pass: the same bits as one pass in memory, with a leading gap
    (the start state decays through it, as lfilter's) and gaps across the pieces' edges."""
    from analyzer import paging
    from analyzer.detectors import lowpass as lp

    calls = []
    monkeypatch.setattr(lp, "release", lambda a: calls.append(a.shape[0]))
    writes = []

    def write_rows(out, a, block):
        writes.append(block.shape[0])
        paging.write_rows(out, a, block)

    monkeypatch.setattr(lp, "write_rows", write_rows)
    rng = np.random.default_rng(3)
    n = 3 * paging.RELEASE_ROWS + 123
    x = np.cumsum(rng.standard_normal(n))
    x[:5] = np.nan
    x[paging.RELEASE_ROWS - 10 : paging.RELEASE_ROWS + 10] = np.nan
    x[2 * paging.RELEASE_ROWS] = np.inf
    mapped = paging.buffer(tmp_path, "x", (n, 1))[:, 0]
    mapped[:] = x
    for phi in (0.3, 0.999):
        want = lowpass(x, phi)
        assert calls == [n] and writes == []  # in memory: one pass, stored directly
        calls.clear()
        assert_array_equal(lowpass(mapped, phi).view(np.uint64), want.view(np.uint64))
        assert len(calls) == 4 and max(calls) == paging.RELEASE_ROWS
        assert writes == []  # the output is in memory
        calls.clear()
        y = paging.buffer(tmp_path, "y", (n, 1))[:, 0]
        y[:] = x
        paging.release(y)
        assert lowpass(y, phi, out=y) is y
        assert_array_equal(y.view(np.uint64), want.view(np.uint64))
        # a mapped output goes to its file a piece at a time (pwrite), not through its
        # mapping (which faults every page in)
        assert writes == [paging.RELEASE_ROWS] * 3 + [123]
        calls.clear()
        writes.clear()
    gone = paging.buffer(tmp_path, "nan", (n, 1))[:, 0]
    gone[:] = np.nan
    assert np.isnan(lowpass(gone, 0.5)).all()


def test_lowpass_of_pieces_handed_in_equals_the_whole_record(tmp_path):
    """:class:`LowpassPieces` (the detectors low-pass their fault-free estimates as each
    piece is computed, without writing the record whole first): the same bits as
    :func:`lowpass` over the whole record, with pieces of uneven lengths, a leading run
    of non-finite samples (NaN and infinities) that spans several pieces, gaps across
    pieces' edges, into memory and into a memory-mapped row; a record with no finite
    sample stays as it is."""
    from analyzer import paging
    from analyzer.detectors.lowpass import LowpassPieces

    rng = np.random.default_rng(5)
    n = 5000
    x = np.cumsum(rng.standard_normal(n))
    x[:700] = np.nan
    x[[3, 450, 650]] = [np.inf, -np.inf, np.inf]  # before the first finite sample
    x[1990:2030] = np.nan
    x[3000] = np.inf
    cuts = [0, 200, 450, 699, 700, 1000, 2000, 2001, 4096, n]
    allbad = np.full(n, np.nan)
    allbad[[10, 4000]] = np.inf
    for record in (x, allbad):
        for phi in (0.3, 0.999):
            want = lowpass(record, phi)
            for mapped in (False, True):
                out = (
                    paging.buffer(tmp_path, f"o{phi}{mapped}", (n, 1))[:, 0]
                    if mapped
                    else (np.empty(n))
                )
                smooth = LowpassPieces(phi, out)
                for a, b in zip(cuts[:-1], cuts[1:], strict=True):
                    smooth.push(a, record[a:b].copy())
                got = smooth.finish()
                assert got is out
                assert_array_equal(np.isnan(got), np.isnan(want))
                assert_array_equal(
                    got.view(np.uint64)[~np.isnan(want)], want.view(np.uint64)[~np.isnan(want)]
                )
    assert np.isinf(lowpass(allbad, 0.3)).sum() == 2  # as it is
