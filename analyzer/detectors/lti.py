"""Fast simulation of discrete linear time-invariant systems over long records.

``x[k+1] = F x[k] + G u[k]``, ``y[k] = H x[k] + J u[k]`` is run in *lifted* form: the
record is cut into blocks of ``T`` samples; the state at each block start follows
``x_{b+1} = F^T x_b + Gamma u_b`` (one small recursion per block, not per sample), and
all outputs of a block are ``O x_b + Toe u_b`` with the extended observability matrix
``O`` and the block-Toeplitz matrix of Markov parameters ``Toe``. Both products are
matrix-matrix multiplications over every block at once (BLAS), which is what makes a
bank of steady-state Kalman estimators run at millions of samples per second without a
compiled per-sample loop. Results equal the sample-by-sample recursion to rounding.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from numpy.lib.stride_tricks import sliding_window_view
from scipy import fft

FloatArray = npt.NDArray[np.float64]

MEMORY_TOL = 1e-14
"""The bank's filters are run as impulse responses cut after ``L`` samples, where the
Frobenius norm of ``F^L`` (how much of a state survives ``L`` samples) is below this: the
neglected tail is at rounding level (:class:`ImpulseResponseBank`)."""

MAX_TAPS = 2048
"""Longest impulse response run by FFT; filters with a longer memory (closed-loop poles
near the unit circle) are run as a stacked lifted system instead."""

MAX_BANK_BYTES = 96 << 20
"""Largest impulse-response bank (spectra plus Markov parameters) held in memory; a larger
one (many channels with a long memory: its size grows as ``channels^3 x taps``) runs as a
stacked lifted system, whose memory does not grow with the filters' memory. A 16-channel
bank of the usual 200-300 taps needs about 40 MB; 21 channels of 2048 taps needed 760 MB,
and a fit builds one per cross-validation fold."""

CHUNK = 1 << 12
"""Samples per chunk of the bank's outputs: the run's temporary memory does not grow with
the record length. Small enough for the frequency-domain products of a few frames to stay
in cache: on a 16-channel bank (288 outputs, 1024-point FFTs) 4096 samples ran at 3.3 M
values/s with 37 MB of temporaries, 32768 at 2.7 M values/s with 353 MB."""


@dataclass(frozen=True, slots=True)
class LiftedSystem:
    """Precomputed lifted matrices of ``(F, G, H, J)`` for block length ``T``."""

    F: FloatArray
    G: FloatArray
    H: FloatArray
    J: FloatArray
    T: int
    FT: FloatArray  # F^T
    Gamma: FloatArray  # (n, T * r): [F^{T-1} G, ..., F G, G]
    Obs: FloatArray  # (T * q, n): [H; H F; ...; H F^{T-1}]
    Toe: FloatArray  # (T * q, T * r): block lower triangular Markov parameters

    @classmethod
    def build(
        cls, F: FloatArray, G: FloatArray, H: FloatArray, J: FloatArray, T: int = 32
    ) -> LiftedSystem:
        n, r = G.shape
        q = H.shape[0]
        powers = [np.eye(n)]
        for _ in range(T):
            powers.append(F @ powers[-1])
        Gamma = np.hstack([powers[T - 1 - i] @ G for i in range(T)])
        Obs = np.vstack([H @ powers[t] for t in range(T)])
        markov = [J] + [H @ powers[i] @ G for i in range(T - 1)]  # h_0 = J, h_i = H F^{i-1} G
        Toe = np.zeros((T * q, T * r))
        for t in range(T):
            for i in range(t + 1):
                Toe[t * q : (t + 1) * q, i * r : (i + 1) * r] = markov[t - i]
        return cls(F, G, H, J, T, powers[T], Gamma, Obs, Toe)

    def run(
        self,
        u: FloatArray,
        x0: FloatArray | None = None,
        out: FloatArray | None = None,
        chunk: int = 1 << 15,
    ) -> tuple[FloatArray, FloatArray]:
        """Outputs (N, q) for inputs ``u`` (N, r) from state ``x0``; returns ``(y, x_end)``.

        Works through ``u`` in chunks of ``chunk`` samples (a multiple of ``T``) so the
        temporary memory is bounded whatever the record length; ``out`` may be a memmap."""
        n = self.F.shape[0]
        r = self.G.shape[1]
        q = self.H.shape[0]
        N = u.shape[0]
        T = self.T
        y = np.empty((N, q)) if out is None else out
        x = np.zeros(n) if x0 is None else np.asarray(x0, dtype=np.float64).copy()
        chunk = max(T, (chunk // T) * T)
        for s in range(0, N, chunk):
            e = min(N, s + chunk)
            nb_full = (e - s) // T
            if nb_full:
                ub = np.ascontiguousarray(u[s : s + nb_full * T]).reshape(nb_full, T * r)
                z = ub @ self.Gamma.T  # (nb, n)
                starts = np.empty((nb_full, n))
                FT = self.FT
                for b in range(nb_full):  # one step per block of T samples
                    starts[b] = x
                    x = FT @ x + z[b]
                yb = starts @ self.Obs.T + ub @ self.Toe.T  # (nb, T q)
                y[s : s + nb_full * T] = yb.reshape(nb_full * T, q)
            tail = s + nb_full * T
            for k in range(tail, e):  # fewer than T samples, at the record's very end
                uk = u[k]
                y[k] = self.H @ x + self.J @ uk
                x = self.F @ x + self.G @ uk
        return y, x


def _block_starts_numpy(
    FT: FloatArray, z: FloatArray, x0: FloatArray, starts: FloatArray
) -> FloatArray:
    """``starts[b] = x_b`` with ``x_{b+1} = FT x_b + z[b]`` for a stack of systems
    (FT: (k, n, n), z and starts: (nb, k, n)); returns the state after the last block."""
    x = x0.copy()
    for b in range(z.shape[0]):
        starts[b] = x
        x = np.matmul(FT, x[:, :, None])[:, :, 0] + z[b]
    return x


try:  # numba compiles the block recursion (2-3x faster than numpy's batched matmul)
    from numba import njit
except ImportError:  # pragma: no cover - numba is a dependency; keep working without
    _block_starts = _block_starts_numpy
else:

    @njit(cache=True, fastmath=True)
    def _block_starts(
        FT: FloatArray, z: FloatArray, x0: FloatArray, starts: FloatArray
    ) -> FloatArray:  # pragma: no cover - compiled
        k, n = x0.shape
        x = x0.copy()
        xn = np.empty(n)
        for b in range(z.shape[0]):
            for i in range(k):
                for c in range(n):
                    starts[b, i, c] = x[i, c]
                for c in range(n):
                    acc = 0.0
                    for d in range(n):
                        acc += FT[i, c, d] * x[i, d]
                    xn[c] = acc + z[b, i, c]
                for c in range(n):
                    x[i, c] = xn[c]
        return x


@dataclass(frozen=True, slots=True)
class StackedLiftedSystem:
    """``k`` systems of equal state and output size driven by one shared input, lifted
    together: ``x_i[t+1] = F_i x_i[t] + G_i u[t]``, ``y_i[t] = H_i x_i[t] + J_i u[t]``.

    A system that ignores part of the input has zero columns in ``G_i``/``J_i``. All
    systems' block products are one GEMM each (``u`` is read once for all of them) and the
    block-start recursion is a batched ``(k, n, n)`` product, so the Python loop runs once
    per block of ``T`` samples for the whole stack. This is what runs the AR-Kalman bank:
    its ``m`` leave-one-out estimators share the measured channels."""

    k: int
    n: int
    q: int
    r: int
    T: int
    FT: FloatArray  # (k, n, n): F_i^T
    GammaT: FloatArray  # (T r, k n)
    ObsT: FloatArray  # (k, n, T q)
    ToeT: FloatArray  # (T r, k T q)
    H: FloatArray  # (k, q, n)
    J: FloatArray  # (k, q, r)
    F: FloatArray  # (k, n, n)
    G: FloatArray  # (k, n, r)

    @classmethod
    def build(
        cls,
        systems: list[tuple[FloatArray, FloatArray, FloatArray, FloatArray]],
        T: int = 16,
    ) -> StackedLiftedSystem:
        lifted = [LiftedSystem.build(F, G, H, J, T) for F, G, H, J in systems]
        k = len(lifted)
        n, r = lifted[0].G.shape
        q = lifted[0].H.shape[0]
        return cls(
            k=k,
            n=n,
            q=q,
            r=r,
            T=T,
            FT=np.stack([s.FT for s in lifted]),
            GammaT=np.ascontiguousarray(np.vstack([s.Gamma for s in lifted]).T),
            ObsT=np.ascontiguousarray(np.stack([s.Obs.T for s in lifted])),
            # rows ordered (sample t, system i, output) so a block's outputs come out of
            # the GEMM already in time order
            ToeT=np.ascontiguousarray(
                np.stack([s.Toe.reshape(T, q, T * r) for s in lifted], axis=1)
                .reshape(T * k * q, T * r)
                .T
            ),
            H=np.stack([s.H for s in lifted]),
            J=np.stack([s.J for s in lifted]),
            F=np.stack([s.F for s in lifted]),
            G=np.stack([s.G for s in lifted]),
        )

    def run(self, u: FloatArray, x0: FloatArray | None = None) -> tuple[FloatArray, FloatArray]:
        """Outputs ``(N, k, q)`` for inputs ``u`` (N, r) from states ``x0`` (k, n); returns
        ``(y, x_end)``. The caller bounds memory by passing chunks of ``u`` and carrying
        ``x_end`` into the next call (results equal one call over the whole record)."""
        k, n, q, r, T = self.k, self.n, self.q, self.r, self.T
        N = u.shape[0]
        x = np.zeros((k, n)) if x0 is None else np.array(x0, dtype=np.float64)
        nb = N // T
        y = np.empty((N, k, q)) if nb * T != N else np.empty((0, k, q))
        if nb:
            ub = np.ascontiguousarray(u[: nb * T]).reshape(nb, T * r)
            z = (ub @ self.GammaT).reshape(nb, k, n)
            starts = np.empty((nb, k, n))
            x = _block_starts(self.FT, z, x, starts)  # one step per block of T samples
            yb = (ub @ self.ToeT).reshape(nb, T, k, q)
            free = np.matmul(starts.transpose(1, 0, 2), self.ObsT)  # (k, nb, T q)
            yb += free.reshape(k, nb, T, q).transpose(1, 2, 0, 3)
            if nb * T == N:
                return yb.reshape(N, k, q), x
            y[: nb * T] = yb.reshape(nb * T, k, q)
        for t in range(nb * T, N):  # fewer than T samples at the end of the chunk
            ut = u[t]
            y[t] = np.matmul(self.H, x[:, :, None])[:, :, 0] + self.J @ ut
            x = np.matmul(self.F, x[:, :, None])[:, :, 0] + self.G @ ut
        return y, x


class _Squares:
    """``A^(2^t)`` for ``t = 0, 1, ...``, each computed once (by squaring) and on demand;
    a power ``A^e`` is the product of the squares of the bits of ``e``: about ``log2 e``
    matrix products instead of ``e - 1``."""

    __slots__ = ("_items",)

    def __init__(self, A: FloatArray) -> None:
        self._items = [A]

    def __getitem__(self, t: int) -> FloatArray:
        """``A^(2^t)``."""
        items = self._items
        while len(items) <= t:
            items.append(items[-1] @ items[-1])
        return items[t]

    def power(self, e: int) -> FloatArray:
        """``A^e`` for ``e >= 1``."""
        t = (e & -e).bit_length() - 1  # the lowest set bit
        out = self[t]
        for u in range(t + 1, e.bit_length()):
            if e >> u & 1:
                out = out @ self[u]
        return out


def _decay_steps(powers: _Squares, tol: float, most: int, least: int) -> int | None:
    """``max(least, m)`` for the smallest ``m >= 1`` with ``||P^m||_F <= tol``
    (``powers``: the squares of ``P``), or None when ``m > most``; ``||P^m||_F`` must be
    non-increasing in ``m``.

    ``m <= least`` is one look at ``P^least``. Otherwise ``m`` is bracketed by the offsets
    ``1, 2, 4, ...`` from the last power known to be above ``tol`` (from ``P^0`` these are
    the squares themselves) and found by bisection inside the bracket, each step one
    product with a stored square."""

    def small(X: FloatArray) -> bool:
        return float(np.linalg.norm(X)) <= tol

    lo, base = 0, None  # base = P^lo (None: the identity), known to be above tol
    if least:
        base = powers.power(least)
        if small(base):
            return least
        lo = least
    t, above = 0, base
    while True:
        trial = powers[t] if base is None else base @ powers[t]  # P^(lo + 2^t)
        if small(trial):
            break
        if lo + (1 << t) >= most:  # and so every P^m with m <= most is above tol
            return None
        above, t = trial, t + 1
    hi = lo + (1 << t)
    if t and above is not None:  # bisect between P^(lo + 2^(t-1)) (above) and P^hi
        lo += 1 << (t - 1)
        for u in range(t - 2, -1, -1):
            trial = above @ powers[u]
            if small(trial):
                hi = lo + (1 << u)
            else:
                lo, above = lo + (1 << u), trial
    return hi if hi <= most else None


def _decay_steps_linear(P: FloatArray, tol: float, most: int) -> int | None:
    """The smallest ``m >= 1`` with ``||P^m||_F <= tol``, one product per step, or None
    when ``m > most``: for ``P`` whose powers may grow before they decay."""
    decay, m = P, 1
    while float(np.linalg.norm(decay)) > tol:
        if m >= most:
            return None
        decay = decay @ P
        m += 1
    return m


SUBSETS_KEPT = 4
"""Banks of subsets of a bank's systems kept for the next call (each ``len(systems) / k``
of the bank's spectrum)."""
_SUBSETS_LOCK = threading.Lock()


def _spectrum(markov: FloatArray, k: int, nfft: int) -> npt.NDArray[np.complex128]:
    """The ``(nfft // 2 + 1, k q, r)`` spectrum of the Markov parameters ``markov``
    (``(k q, r, taps)``), one system at a time: its responses zero-padded to the FFT
    length in a ``(q, r, nfft)`` array, transformed along time. The FFT runs over
    contiguous memory and the transposed write is one system's spectrum (2.4 MB at 16
    channels): one transform of the whole bank over its first axis (strided) took about
    1.5x as long as both. Each response's transform does not depend on the others in the
    array (tested bit for bit), so a bank's selected outputs transform to the same numbers
    as the whole bank's."""
    kq, r, taps = markov.shape
    q = kq // k
    spectrum = np.empty((nfft // 2 + 1, kq, r), dtype=np.complex128)
    h = np.zeros((q, r, nfft))
    for i in range(k):
        h[:, :, :taps] = markov[i * q : (i + 1) * q]
        spectrum[:, i * q : (i + 1) * q, :] = fft.rfft(h, axis=2).transpose(2, 0, 1)
    return spectrum


@dataclass(frozen=True, slots=True)
class ImpulseResponseBank:
    """``k`` stable LTI systems ``(F_i, G_i, H_i, J_i)`` of equal output size driven by one
    input, run as impulse responses cut after ``taps`` samples (overlap-save FFT
    convolution).

    The filters of a bank forget their past fast (spectral radius well below 1): the
    output at ``t`` is ``sum_{j < L} h_j v[t - j]`` with the Markov parameters ``h_0 = J``,
    ``h_j = H F^(j-1) G``, up to the term ``H F^L x[t - L]``, which is at rounding level once
    ``||F^L||`` is below :data:`MEMORY_TOL`. Per sample, the convolution of all ``k q``
    outputs with all ``r`` inputs costs one ``(k q, r)`` complex product per frequency bin
    and one inverse FFT per output: an order of magnitude fewer operations than the lifted
    state-space form (:class:`~analyzer.detectors.lti.LiftedSystem`), whose block-Toeplitz
    product grows with the block length and whose state recursion with the state size.
    The output at ``t`` depends on ``v[t - taps + 1 .. t]`` only, so any stretch of the
    record can be recomputed from ``taps - 1`` samples before it."""

    taps: int
    nfft: int
    k: int
    q: int
    spectrum: npt.NDArray[np.complex128]
    """``(nfft // 2 + 1, k q, r)``: the FFT of the Markov parameters of every output."""
    markov: FloatArray
    """``(k q, r, taps)``: the Markov parameters themselves. A pickle (a saved model, a
    task sent to a Dask worker) holds them instead of the spectrum, about a sixth of its
    size, and the spectrum is transformed again from them on loading, by the same FFT
    calls as :meth:`build`: the same numbers to the last bit (tested)."""
    subsets: dict[tuple[int, ...], ImpulseResponseBank] = field(
        default_factory=dict, compare=False, repr=False
    )
    """The last :data:`SUBSETS_KEPT` banks :meth:`subset` made, by their systems: a lasting
    fault asks for the same one at each of thousands of alarms (a copy of its part of the
    spectrum, 1-2 ms each)."""

    STEP = 16
    """The responses' length is a multiple of this; the Markov parameters are computed in
    blocks of this many taps."""

    @property
    def history(self) -> int:
        """Samples of past input an output depends on (besides its own)."""
        return self.taps - 1

    @classmethod
    def build(
        cls,
        systems: Sequence[tuple[FloatArray, FloatArray, FloatArray, FloatArray]],
        tol: float = MEMORY_TOL,
        max_taps: int = MAX_TAPS,
    ) -> ImpulseResponseBank | None:
        """The bank of ``systems``, or None when a filter remembers its input longer than
        ``max_taps`` samples (``||F^L||_F`` above ``tol`` at ``L = max_taps``).

        The Markov parameters of each system are computed in blocks of
        :data:`~ImpulseResponseBank.STEP` taps (:meth:`_markov`) in the layout the FFT
        wants (time last, contiguous), transformed, and written into the spectrum's
        ``(bins, k q, r)`` layout one system at a time; the powers of ``F`` squared to
        find the memory (:meth:`_taps`) are reused for the blocks. On the nine banks of a
        16-channel, 1 h run (16 systems of state size 160, 16 inputs, 160-240 taps) this
        took about half the time of the tap-by-tap recursion followed by one FFT of the
        whole bank over its first axis (1.21 -> 0.63 s), with the same taps and a spectrum
        equal to rounding (4e-16 of its largest value)."""
        k = len(systems)
        powers = [_Squares(F) for F, _, _, _ in systems]
        taps = cls._memory(powers, tol, max_taps, cls.STEP)
        if taps is None:
            return None
        q, r = systems[0][2].shape[0], systems[0][1].shape[1]
        nfft = cls._nfft(taps)
        size = (nfft // 2 + 1) * k * q * r * 16 + taps * k * q * r * 8
        if size > MAX_BANK_BYTES:
            return None  # spectra this large cost more memory than the lifted form's time
        markov = np.empty((k * q, r, taps))
        h = np.zeros((q, r, nfft))  # one system's responses, zero-padded to the FFT length
        for i, ((_, G, H, J), power) in enumerate(zip(systems, powers, strict=True)):
            cls._markov(power, G, H, J, taps, cls.STEP, h)
            markov[i * q : (i + 1) * q] = h[:, :, :taps]
        return cls(taps, nfft, k, q, _spectrum(markov, k, nfft), markov)

    def __getstate__(self) -> tuple[int, int, int, int, FloatArray]:
        """What a pickle holds: the Markov parameters, not their spectrum (nor the
        :attr:`subsets` cache)."""
        return (self.taps, self.nfft, self.k, self.q, self.markov)

    def __setstate__(self, state: tuple[int, int, int, int, FloatArray]) -> None:
        taps, nfft, k, q, markov = state
        markov = np.ascontiguousarray(markov, dtype=np.float64)
        if markov.ndim != 3 or markov.shape[0] != k * q or markov.shape[2] != taps:
            raise ValueError(f"impulse-response bank: Markov parameters of shape {markov.shape}")
        for name, value in (("taps", taps), ("nfft", nfft), ("k", k), ("q", q)):
            object.__setattr__(self, name, int(value))
        object.__setattr__(self, "markov", markov)
        object.__setattr__(self, "spectrum", _spectrum(markov, k, int(nfft)))
        object.__setattr__(self, "subsets", {})

    @staticmethod
    def _markov(
        powers: _Squares,
        G: FloatArray,
        H: FloatArray,
        J: FloatArray,
        taps: int,
        block: int,
        out: FloatArray,
    ) -> None:
        """The first ``taps`` Markov parameters of ``(F, G, H, J)`` (``powers``: the
        squares of ``F``) into ``out[:, :, :taps]`` (``out``: ``(q, r, length)``, time last,
        ``length >= taps + block - 1``): ``h_0 = J``, ``h_j = H F^(j-1) G``. The block
        after them is zeroed (the last block's surplus taps); beyond it ``out`` is left as
        it was (the caller's zero padding).

        In blocks of ``s = block`` taps, ``H F^(b s + c) G = (H P^b)(F^c G)`` with
        ``P = F^s``: the rows ``H P^b`` (one ``(q, n) (n, n)`` product per block) times the
        columns ``[G, F G, ..., F^(s-1) G]`` (built by doubling with the squares of ``F``)
        are one GEMM for every tap. That is about ``q n^2 / s + q n r`` multiplications per
        tap instead of the ``n^2 r + q n r`` of the recursion ``F^j G = F (F^(j-1) G)``, in
        a few large products instead of two small ones per tap; the results agree with the
        recursion to rounding (the products are associated differently)."""
        n, r = G.shape
        q = H.shape[0]
        s = block
        blocks = -(-(taps - 1) // s)  # blocks covering the taps 1 .. taps - 1
        out[:, :, 0] = J
        if blocks:
            width = 1 << (s - 1).bit_length()  # s rounded up to a power of two
            cols = np.empty((n, width, r))  # cols[:, c] = F^c G
            cols[:, 0] = G
            w = 1
            while w < s:  # [F^w G, ..., F^(2w - 1) G] = F^w [G, ..., F^(w - 1) G]
                prod = powers[w.bit_length() - 1] @ cols[:, :w].reshape(n, w * r)
                cols[:, w : 2 * w] = prod.reshape(n, w, r)
                w *= 2
            # columns ordered (input, c): a block's taps come out contiguous per input
            K = np.ascontiguousarray(cols[:, :s].transpose(0, 2, 1)).reshape(n, r * s)
            rows = np.empty((blocks, q, n))  # rows[b] = H P^b
            rows[0] = H
            P = powers.power(s)
            for b in range(1, blocks):
                rows[b] = rows[b - 1] @ P
            # a view of out (splitting one axis never copies): the GEMM's blocks go
            # straight to their taps
            taps_by_block = out[:, :, 1 : 1 + blocks * s].reshape(q, r, blocks, s)
            taps_by_block[...] = (
                (rows.reshape(blocks * q, n) @ K).reshape(blocks, q, r, s).transpose(1, 2, 0, 3)
            )
            out[:, :, taps : 1 + blocks * s] = 0.0

    @staticmethod
    def _nfft(taps: int) -> int:
        """FFT length for ``taps``-long responses: at least 1024 and 4 responses long."""
        nfft = 1024
        while nfft < 4 * taps:
            nfft *= 2
        return nfft

    @staticmethod
    def _taps(
        systems: Sequence[tuple[FloatArray, FloatArray, FloatArray, FloatArray]],
        tol: float,
        max_taps: int,
        step: int = 16,
    ) -> int | None:
        """Smallest multiple of ``step`` with ``||F_i^L||_F <= tol`` for every system, or
        None when that is above ``max_taps`` rounded up to a multiple of ``step`` (see
        :meth:`_memory`)."""
        return ImpulseResponseBank._memory(
            [_Squares(F) for F, _, _, _ in systems], tol, max_taps, step
        )

    @staticmethod
    def _memory(powers: Sequence[_Squares], tol: float, max_taps: int, step: int) -> int | None:
        """:meth:`_taps` for systems given by the squares of their ``F``.

        The same integer as the linear search ``L = step, 2 step, ...`` (one ``n^3``
        product per ``step`` taps per system), except when some ``||F^L||_F`` is within
        rounding of ``tol`` (the powers are multiplied in another order). With
        ``P = F^step`` (squarings), a system whose ``||P||_2`` is at most 1 (bounded by
        ``min(||P||_F, (||P||_1 ||P||_inf)^1/2)``, the case of every filter of the bank
        seen so far: about 0.6) has ``||P^m||_F`` non-increasing in ``m``, since
        ``||P^(m+1)||_F <= ||P||_2 ||P^m||_F``; its memory is then searched in about
        ``log2`` products (:func:`_decay_steps`), and for all but the first system only
        compared with the longest so far (one look at ``P^m``). Any other system (a
        transient growth longer than ``step``) gets the linear search."""
        most = max(1, -(-max_taps // step))  # the linear search stops at this multiple
        steps = 0
        for power in powers:
            P = power.power(step)
            bound = min(
                float(np.linalg.norm(P)),
                float(np.sqrt(np.linalg.norm(P, 1) * np.linalg.norm(P, np.inf))),
            )
            found = (
                _decay_steps(_Squares(P), tol, most, steps)
                if bound <= 1.0
                else _decay_steps_linear(P, tol, most)
            )
            if found is None:
                return None
            steps = max(steps, found)
        return max(1, steps) * step

    def select(self, outputs: Sequence[int]) -> ImpulseResponseBank:
        """The bank restricted to the outputs ``outputs`` of every system: the same
        numbers, at about ``len(outputs) / q`` of the cost of a run of the whole bank."""
        idx = (np.arange(self.k)[:, None] * self.q + np.asarray(outputs)[None, :]).ravel()
        spectrum = np.ascontiguousarray(self.spectrum[:, idx, :])
        return ImpulseResponseBank(
            self.taps, self.nfft, self.k, len(outputs), spectrum, self.markov[idx]
        )

    def subset(self, systems: Sequence[int]) -> ImpulseResponseBank:
        """The bank restricted to the systems ``systems`` (every output of each): the same
        numbers to rounding, at about ``len(systems) / k`` of the cost of a run of the
        whole bank."""
        key = tuple(int(i) for i in systems)
        with _SUBSETS_LOCK:  # threads may share the bank
            kept = self.subsets.pop(key, None)
            if kept is None:
                idx = (np.asarray(key)[:, None] * self.q + np.arange(self.q)[None, :]).ravel()
                spectrum = np.ascontiguousarray(self.spectrum[:, idx, :])
                kept = ImpulseResponseBank(
                    self.taps, self.nfft, len(key), self.q, spectrum, self.markov[idx]
                )
            self.subsets[key] = kept  # the most recent last
            while len(self.subsets) > SUBSETS_KEPT:
                self.subsets.pop(next(iter(self.subsets)))
        return kept

    def run(self, v: FloatArray) -> Iterator[tuple[int, FloatArray]]:
        """Outputs for inputs ``v`` (N, r) from rest, in chunks: yields ``(start, y)`` with
        ``y`` of shape ``(k, q, n)`` for samples ``start .. start + n - 1``."""
        N, r = v.shape
        hist = self.history
        frame = self.nfft - hist  # new samples per FFT frame
        per_chunk = max(1, CHUNK // frame)
        for start in range(0, N, per_chunk * frame):
            stop = min(N, start + per_chunk * frame)
            frames = -(-(stop - start) // frame)
            seg = np.zeros((frames * frame + hist, r))
            lo = max(0, start - hist)
            seg[hist - (start - lo) : hist + stop - start] = v[lo:stop]
            windows = sliding_window_view(seg, self.nfft, axis=0)[::frame]  # (frames, r, nfft)
            spec_u = fft.rfft(windows, axis=2).transpose(2, 1, 0)  # (bins, r, frames)
            spec_y = np.matmul(self.spectrum, spec_u).transpose(1, 2, 0)  # (k q, frames, bins)
            y = fft.irfft(np.ascontiguousarray(spec_y), n=self.nfft, axis=2)[:, :, hist:]
            y = y.reshape(self.k, self.q, frames * frame)[:, :, : stop - start]
            yield start, y


@dataclass(frozen=True, slots=True)
class LiftedBank:
    """The bank as one stacked lifted system (filters with a long memory), with the
    interface of :class:`ImpulseResponseBank`; an output depends on the whole past."""

    system: StackedLiftedSystem

    @property
    def history(self) -> int | None:
        return None

    def run(self, v: FloatArray) -> Iterator[tuple[int, FloatArray]]:
        x = None
        step = max(1, CHUNK // self.system.T) * self.system.T
        for start in range(0, v.shape[0], step):
            y, x = self.system.run(v[start : start + step], x)
            yield start, y.transpose(1, 2, 0)


MIN_TIME_BLOCK = 8
"""A time block handed to a worker is at least this many warm-ups long."""

CLUSTER_BLOCK_VALUES = 1 << 22
"""On a cluster, a time block holds at most about this many values (rows x channels: 32
MB of float64, 44 minutes of 16 channels at 100 Hz) unless its warm-ups ask for more:
each task's message, and what a worker holds for it, stays bounded however long the
archive (:meth:`~analyzer.detectors.base.RunContext.imap` keeps a few in flight)."""


def time_blocks(
    start: int, stop: int, warmup: int, context: Any, width: int = 1
) -> list[tuple[int, int, int]]:
    """``(a, b, warm)`` spans covering ``[start, stop)`` for a
    :class:`~analyzer.detectors.base.RunContext` ``context``: one span serially; with a
    parallel executor, about two per worker, each at least ``MIN_TIME_BLOCK`` warm-ups
    long so the warm-up overhead stays small, and on a cluster (an executor that does not
    share this process's memory) at most :data:`CLUSTER_BLOCK_VALUES` values of ``width``
    channels. ``warm`` samples before ``a`` (at most ``warmup``) let a block start where a
    run from the record's start would be."""
    executor = None if context is None else getattr(context, "executor", None)
    if executor is None or stop - start <= 2 * MIN_TIME_BLOCK * warmup:
        return [(start, stop, min(start, warmup))]
    workers = max(2, int(getattr(context, "jobs", 2) or 2))
    size = max(MIN_TIME_BLOCK * warmup, -(-(stop - start) // (2 * workers)))
    if not getattr(context, "shares_memory", True):
        size = min(size, max(MIN_TIME_BLOCK * warmup, CLUSTER_BLOCK_VALUES // max(1, width)))
    return warm_spans(start, stop, size, warmup)


def warm_spans(start: int, stop: int, size: int, warmup: int) -> list[tuple[int, int, int]]:
    """``[start, stop)`` cut into spans of ``size`` samples, each ``(a, b, warm)`` with
    ``warm`` (at most ``warmup``) samples before ``a`` to filter from: a bank that
    forgets its state within ``warmup`` samples gives each span what one pass from the
    record's start gives, to rounding."""
    return [(a, min(stop, a + size), min(a, warmup)) for a in range(start, stop, size)]


def system_bank(
    systems: Sequence[tuple[FloatArray, FloatArray, FloatArray, FloatArray]], block: int = 16
) -> ImpulseResponseBank | LiftedBank:
    """``systems`` run together over one input: as impulse responses when they all forget
    their past within :data:`MAX_TAPS` samples, else as a stacked lifted system of block
    length ``block``."""
    fir = ImpulseResponseBank.build(systems)
    return fir if fir is not None else LiftedBank(StackedLiftedSystem.build(list(systems), block))


def run_chunked(
    bank: ImpulseResponseBank | LiftedBank,
    inputs: Callable[[int, int], FloatArray],
    stop: int,
    start: int = 0,
) -> Iterator[tuple[int, FloatArray]]:
    """Outputs of ``bank`` over samples ``start .. stop - 1`` of a run from rest at sample 0,
    as ``(first sample, y (k, q, n))`` pieces. The input is asked for chunk by chunk
    (``inputs(a, b)``: samples ``a .. b - 1``), each chunk with only the history an
    impulse-response bank remembers before it, so the caller never holds the whole input;
    a lifted bank (whole past) gets one chunk from sample 0."""
    hist = bank.history
    # each chunk recomputes the history before it: keep that overhead at most a fifth
    step = max(stop - start, 1) if hist is None else max(CHUNK, 4 * hist)
    for s in range(start, stop, step):
        e = min(stop, s + step)
        a = 0 if hist is None else max(0, s - hist)
        for off, y in bank.run(inputs(a, e)):
            lo, hi = max(a + off, s), a + off + y.shape[2]
            if lo < hi:
                yield lo, y[:, :, lo - a - off :]


def simulate_reference(
    F: FloatArray, G: FloatArray, H: FloatArray, J: FloatArray, u: FloatArray
) -> FloatArray:
    """Sample-by-sample recursion (slow; the reference the lifted form is tested against)."""
    x = np.zeros(F.shape[0])
    y = np.empty((u.shape[0], H.shape[0]))
    for k in range(u.shape[0]):
        y[k] = H @ x + J @ u[k]
        x = F @ x + G @ u[k]
    return y
