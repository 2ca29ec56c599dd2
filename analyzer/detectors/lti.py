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

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
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
        ``max_taps`` samples (``||F^L||_F`` above ``tol`` at ``L = max_taps``)."""
        taps = cls._taps(systems, tol, max_taps)
        if taps is None:
            return None
        k = len(systems)
        q, r = systems[0][2].shape[0], systems[0][1].shape[1]
        nfft = cls._nfft(taps)
        size = (nfft // 2 + 1) * k * q * r * 16 + taps * k * q * r * 8
        if size > MAX_BANK_BYTES:
            return None  # spectra this large cost more memory than the lifted form's time
        h = np.empty((taps, k, q, r))
        for i, (F, G, H, J) in enumerate(systems):
            h[0, i] = J
            FjG = G
            for j in range(1, taps):
                h[j, i] = H @ FjG
                FjG = F @ FjG
        spectrum = fft.rfft(h.reshape(taps, k * q, r), n=nfft, axis=0)
        return cls(taps, nfft, k, q, np.ascontiguousarray(spectrum))

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
        """Smallest multiple of ``step`` with ``||F_i^L||_F <= tol`` for every system."""
        taps = step
        for F, _, _, _ in systems:
            power = np.linalg.matrix_power(F, step)
            decay, length = power, step
            while float(np.linalg.norm(decay)) > tol:
                if length >= max_taps:
                    return None
                decay = decay @ power
                length += step
            taps = max(taps, length)
        return taps

    def select(self, outputs: Sequence[int]) -> ImpulseResponseBank:
        """The bank restricted to the outputs ``outputs`` of every system: the same
        numbers, at about ``len(outputs) / q`` of the cost of a run of the whole bank."""
        idx = (np.arange(self.k)[:, None] * self.q + np.asarray(outputs)[None, :]).ravel()
        spectrum = np.ascontiguousarray(self.spectrum[:, idx, :])
        return ImpulseResponseBank(self.taps, self.nfft, self.k, len(outputs), spectrum)

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


def time_blocks(start: int, stop: int, warmup: int, context: Any) -> list[tuple[int, int, int]]:
    """``(a, b, warm)`` spans covering ``[start, stop)`` for a
    :class:`~analyzer.detectors.base.RunContext` ``context``: one span serially; with a
    parallel executor, about two per worker, each at least ``MIN_TIME_BLOCK`` warm-ups
    long so the warm-up overhead stays small. ``warm`` samples before ``a`` (at most
    ``warmup``) let a block start where a run from the record's start would be."""
    executor = None if context is None else getattr(context, "executor", None)
    if executor is None or stop - start <= 2 * MIN_TIME_BLOCK * warmup:
        return [(start, stop, min(start, warmup))]
    workers = max(2, int(getattr(context, "jobs", 2) or 2))
    size = max(MIN_TIME_BLOCK * warmup, -(-(stop - start) // (2 * workers)))
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


def bank_segment(
    bank: ImpulseResponseBank | LiftedBank, v: FloatArray, lo: int, hi: int
) -> FloatArray:
    """Outputs ``(k, q, hi - lo)`` of the bank over samples ``lo .. hi - 1`` of the run over
    ``v``, recomputed from the input the bank remembers only."""
    parts = [y for _, y in run_chunked(bank, lambda a, b: v[a:b], hi, lo)]
    return np.concatenate(parts, axis=2)


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
