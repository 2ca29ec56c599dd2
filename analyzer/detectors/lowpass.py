"""First-order recursions without ``scipy.signal``: the low-pass ``(1 - phi) / (1 - phi
q^-1)`` (DC gain 1) started at steady state, shared by the detection filter and the
equivalent-model detector, and ``y[k] = x[k] + phi y[k-1]`` from a given state (the
equivalent model's diagonal observer states in its pretreatment).

Both detectors apply their residual's own dynamics to the fault-free estimate over the
whole record (so the classifier's fault-free shape matches the residual), which is
``scipy.signal.lfilter`` started by ``lfilter_zi`` at the first finite sample. Here it is
one compiled pass that rounds every step as ``lfilter`` does (:func:`_lowpass_loop`,
bit-equal to the reference form :func:`lowpass_reference`), and the initial condition is
the closed form :func:`steady_state_zi`, bit-equal to ``lfilter_zi``: the default run
needs neither ``scipy.signal`` nor, through it, ``scipy.stats`` (~0.6-0.9 s at start-up).
:func:`recursion` is ``lfilter([1], [1, -phi], x, zi=[z0])`` the same way.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from analyzer.paging import RELEASE_ROWS, is_mapped, release, write_rows

FloatArray = npt.NDArray[np.float64]


def steady_state_zi(phi: float) -> float:
    """``lfilter_zi([1 - phi], [1, -phi])[0]``, the state for which a constant input of 1
    gives a constant output of 1, in closed form.

    ``lfilter_zi`` solves ``(I - A) zi = B`` with ``A = [[phi]]`` and
    ``B = b1 - a1 b0 = 0 - (-phi)(1 - phi) = phi (1 - phi)`` (both exact), and a 1x1
    LAPACK solve divides: ``zi = phi (1 - phi) / (1 - phi)``, rounded twice as there, which
    is not always ``phi``. tests/detectors/test_lowpass.py checks the bits over many
    ``phi``."""
    c = 1.0 - phi
    return (phi * c) / c


def lowpass(x: FloatArray, phi: float, out: FloatArray | None = None) -> FloatArray:
    """``(1 - phi) / (1 - phi q^-1)`` over ``x``, started at steady state at the first finite
    sample; NaN/inf samples count as 0 and are NaN in the output (all NaN when nothing is
    finite). One compiled pass (:func:`_lowpass_loop`), or :func:`lowpass_reference`
    without numba. ``out``: a float64 array of ``x``'s length to write into, which may be
    ``x`` itself (the pass reads each sample before it writes it): no second whole-record
    array. A memory-mapped ``x`` or ``out`` is worked through :data:`RELEASE_ROWS` samples
    at a time, the filter's state carried: ``x`` given back behind the pass, ``out``
    written from memory by ``pwrite`` (:func:`~analyzer.paging.write_rows`), not stored
    through its mapping, which faults every page in."""
    xx = np.asarray(x, dtype=np.float64)
    if _lowpass_kernel is None:  # pragma: no cover - numba is a dependency
        ref = lowpass_reference(xx, phi)
        if out is None:
            return ref
        out[:] = ref
        return out
    target = np.empty_like(xx) if out is None else out
    first = _first_finite_kernel(xx)
    if first < 0:
        target[:] = xx  # nothing finite: the input as it is
        return target
    n = xx.shape[0]
    state = np.array([steady_state_zi(phi) * xx[first]])
    step = RELEASE_ROWS if is_mapped(xx) or is_mapped(target) else max(n, 1)
    # a memory-mapped target is written from memory a piece at a time (pwrite), not
    # stored through its mapping, which faults every page in
    piece = np.empty(min(n, step)) if is_mapped(target) else None
    for a in range(0, n, step):
        b = min(n, a + step)
        into = target[a:b] if piece is None else piece[: b - a]
        _lowpass_kernel(xx[a:b], 1.0 - phi, phi, state, into)
        release(xx[a:b])  # no-ops in memory
        if piece is not None:
            write_rows(target, a, into)
    return target


class LowpassPieces:
    """:func:`lowpass` over a record handed in piece by piece (``push``, from its first
    sample on, in order), each piece's output written into ``out`` at its place (by
    ``pwrite`` where ``out`` is memory-mapped, :func:`~analyzer.paging.write_rows`) as it
    comes: the same output bit for bit, without the record being written whole first and
    read back (a long archive's scratch row: one pass of writes instead of two, and no
    read). ``finish`` returns ``out`` once every piece is in.

    The filter starts at steady state at the record's first finite sample, and its state
    decays through the non-finite samples before it (:func:`lowpass` runs from the first
    sample): pieces before it are written as they are and, once a finite sample comes,
    run through the filter as the non-finite samples they are (NaN out); a record with no
    finite sample stays as it is, as there."""

    def __init__(self, phi: float, out: FloatArray) -> None:
        self.phi = phi
        self.out = out
        self._state: FloatArray | None = None
        self._next = 0
        self._piece: FloatArray | None = None

    def push(self, at: int, x: FloatArray) -> None:
        """Filter ``x``, the record's samples ``at .. at + len(x) - 1``."""
        if at != self._next:
            raise ValueError(f"LowpassPieces: piece at {at}, expected the one at {self._next}")
        xx = np.asarray(x, dtype=np.float64)
        n = xx.shape[0]
        self._next = at + n
        if n == 0:
            return
        if _lowpass_kernel is None:  # pragma: no cover - numba is a dependency
            raise RuntimeError("LowpassPieces needs numba; use lowpass on the whole record")
        if self._state is None:
            first = _first_finite_kernel(xx)
            if first < 0:
                write_rows(self.out, at, xx)  # as it is, unless a finite sample comes
                return
            self._state = np.array([steady_state_zi(self.phi) * xx[first]])
            for a in range(0, at, RELEASE_ROWS):  # the samples before: non-finite all
                gap = np.full(min(RELEASE_ROWS, at - a), np.nan)
                self._filter(a, gap)
        self._filter(at, xx)

    def _filter(self, at: int, xx: FloatArray) -> None:
        n = xx.shape[0]
        if self._piece is None or self._piece.shape[0] < n:
            self._piece = np.empty(n)
        into = self._piece[:n]
        assert _lowpass_kernel is not None and self._state is not None
        _lowpass_kernel(xx, 1.0 - self.phi, self.phi, self._state, into)
        write_rows(self.out, at, into)

    def finish(self) -> FloatArray:
        """``out``, every piece in."""
        return self.out


def lowpass_reference(x: FloatArray, phi: float) -> FloatArray:
    """:func:`lowpass` with ``scipy.signal.lfilter`` started by ``lfilter_zi`` at the first
    finite sample (the reference form of :func:`_lowpass_loop`)."""
    from scipy import signal  # only without numba, and in tests (import: ~1 s)

    xx = np.asarray(x, dtype=np.float64)
    finite = np.isfinite(xx)
    if not finite.any():
        return xx.copy()
    xf = np.where(finite, xx, 0.0)
    b, a = [1.0 - phi], [1.0, -phi]
    zi = signal.lfilter_zi(b, a) * xf[int(np.argmax(finite))]
    out, _ = signal.lfilter(b, a, xf, zi=zi)
    out[~finite] = np.nan
    return np.asarray(out, dtype=np.float64)


def recursion(x: FloatArray, phi: float, z0: float) -> FloatArray:
    """``y[k] = x[k] + phi y[k-1]`` with the filter state ``z0`` before the first sample:
    ``lfilter([1], [1, -phi], x, zi=[z0])[0]`` bit for bit (NaN/inf propagate as there),
    one compiled pass, or :func:`recursion_reference` without numba."""
    xx = np.ascontiguousarray(x, dtype=np.float64)
    if _recursion_kernel is None:  # pragma: no cover - numba is a dependency
        return recursion_reference(xx, phi, z0)
    out = np.empty_like(xx)
    _recursion_kernel(xx, float(phi), float(z0), out)
    return out


def recursion_reference(x: FloatArray, phi: float, z0: float) -> FloatArray:
    """:func:`recursion` with ``scipy.signal.lfilter`` (the reference form of
    :func:`_recursion_loop`)."""
    from scipy import signal  # only without numba, and in tests (import: ~1 s)

    out, _ = signal.lfilter([1.0], [1.0, -phi], np.asarray(x, dtype=np.float64), zi=[z0])
    return np.asarray(out, dtype=np.float64)


def _recursion_loop(
    x: FloatArray, phi: float, z0: float, out: FloatArray
) -> None:  # pragma: no cover - compiled by numba
    """``out = lfilter([1], [1, -phi], x, zi=[z0])``, each step as ``lfilter`` rounds it
    (``b = [1, 0]``, ``a = [1, -phi]``)."""
    state = z0
    for k in range(x.shape[0]):
        v = x[k]
        y = state + 1.0 * v
        state = v * 0.0 - y * -phi
        out[k] = y


def _lowpass_loop(
    x: FloatArray, b0: float, phi: float, state: FloatArray, out: FloatArray
) -> None:  # pragma: no cover - compiled by numba
    """``out = lfilter([b0], [1, -phi], x, zi=state)`` with NaN/inf samples as 0 (and NaN
    in ``out``), each step as ``lfilter`` rounds it; ``state[0]`` is the filter's state
    before ``x[0]`` and after the pass the state after its last sample (a record is
    filtered in pieces with it carried)."""
    z = state[0]
    for k in range(x.shape[0]):
        v = x[k]
        finite = np.isfinite(v)
        if not finite:
            v = 0.0
        y = z + b0 * v
        z = 0.0 * v + phi * y  # b1 x - a1 y with b1 = 0, a1 = -phi
        out[k] = y if finite else np.nan
    state[0] = z


def _first_finite(x: FloatArray) -> int:  # pragma: no cover - compiled by numba
    """Index of the first finite sample of ``x``, -1 if there is none (reads no further)."""
    for k in range(x.shape[0]):
        if np.isfinite(x[k]):
            return k
    return -1


_lowpass_kernel: Callable[..., None] | None
_first_finite_kernel: Callable[[FloatArray], int]
_recursion_kernel: Callable[..., None] | None
try:  # numba compiles the per-sample passes; nogil lets threads filter at once
    from numba import njit
except ImportError:  # pragma: no cover - numba is a dependency; scipy without it
    _lowpass_kernel = _recursion_kernel = None
    _first_finite_kernel = _first_finite
else:
    _lowpass_kernel = njit(cache=True, nogil=True)(_lowpass_loop)
    _first_finite_kernel = njit(cache=True, nogil=True)(_first_finite)
    _recursion_kernel = njit(cache=True, nogil=True)(_recursion_loop)
