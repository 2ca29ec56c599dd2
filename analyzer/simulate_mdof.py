"""The spring-mass-damper chain of Li, Koh & Nagarajaiah (2007, "Simulation", Fig. 1-4):
a multi-degree-of-freedom chain driven by independent band-limited white-noise forces,
measured by one accelerometer per mass, with sensor failures injected on the records.

* :func:`chain_model`: continuous model of the chain (default: the paper's four masses,
  ``m = 1 kg``, ``k = 100 kN/m``, Rayleigh damping ``c = 0.05 m + 0.001 k``, forces on
  masses 1 and 2, absolute accelerations of every mass as outputs).
* :meth:`Chain.discrete`: exact zero-order-hold discretization ``(A, B, C, D)``, the model
  the indirect error function (Eq. 1-25) is built from.
* :func:`simulate_chain`: the sampled response to band-limited white-noise forces held
  over each sample (so the discrete model is exact and a noise-free healthy error
  function vanishes to rounding), optionally with white measurement noise.
* :func:`inject_failures`: the paper's failures (random data, zero reading) and the
  truss experiment's amplitude reduction (gain), per channel and time interval.

The response is computed mode by mode with ``scipy.signal.lfilter`` (no Python loop per
sample), as in :mod:`analyzer.simulate`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
import numpy.typing as npt
from scipy import linalg

from analyzer.simulate import band_limited_noise

FloatArray = npt.NDArray[np.float64]

DEFAULT_RATE_HZ = 250.0
"""Sampling rate of the simulated example. The paper's simulation section gives none (its
truss experiment samples at 1 kHz). 250 Hz puts the Nyquist frequency (125 Hz) above the
chain's highest mode (94.6 Hz) with forcing up to 100 Hz. The rate matters for sensor 1:
in a chain, once sensor 2 is eliminated, mass 1 reaches the references only through
mass 2, whose motion is then unknown, so the exact (indirect) error function of sensor 1
lives on the zero-order-hold structure between samples, which fades as the rate grows
(its response to a loss of the sensor, in healthy standard deviations under 1 % noise and
with p = 28, is about 11 at 250 Hz, 3 at 500 Hz and 0.5 at 1 kHz)."""


@dataclass(frozen=True, slots=True)
class Chain:
    """Continuous model ``x' = A x + B u``, ``y = C x + D u`` of a fixed-free chain
    (ground - k1 - m1 - k2 - m2 - ... - mn) with ``x = [displacements, velocities]``,
    ``u`` the forces on the masses in ``force_dofs`` and ``y`` the absolute accelerations
    of every mass (or the displacements, with ``output="displacement"``). The paper's
    Fig. 1 is not in its text; this arrangement (forces on masses 1 and 2) is the one its
    Eq. 3 needs, since the uncertain accelerometers must see every unmeasured force
    directly."""

    M: FloatArray
    K: FloatArray
    Cdamp: FloatArray
    A: FloatArray
    B: FloatArray
    C: FloatArray
    D: FloatArray
    force_dofs: tuple[int, ...]
    frequencies_hz: FloatArray
    damping_ratios: FloatArray

    @property
    def n_dof(self) -> int:
        return int(self.M.shape[0])

    def discrete(self, rate_hz: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Zero-order-hold discretization ``(Ad, Bd, C, D)`` at ``rate_hz``: exact for
        forces held constant over each sample, ``y(k) = C x(k) + D u(k)``."""
        n, r = self.B.shape
        h = 1.0 / rate_hz
        big = np.zeros((n + r, n + r))
        big[:n, :n] = self.A
        big[:n, n:] = self.B
        e = linalg.expm(big * h)
        return e[:n, :n], e[:n, n:], self.C.copy(), self.D.copy()


def chain_model(
    n_dof: int = 4,
    mass: float = 1.0,
    stiffness: float = 1.0e5,
    rayleigh: tuple[float, float] = (0.05, 0.001),
    force_dofs: Sequence[int] = (0, 1),
    output: str = "acceleration",
) -> Chain:
    """The chain of Li et al. (2007, Fig. 1): equal masses ``mass`` (kg) and springs
    ``stiffness`` (N/m), damping ``C = a M + b K`` with ``rayleigh = (a, b)`` (the paper's
    ``c_i = 0.05 m_i + 0.001 k_i``), forces on the masses ``force_dofs`` (0-based). With
    the defaults the natural frequencies are 17.5, 50.3, 77.1 and 94.6 Hz."""
    if n_dof < 1:
        raise ValueError(f"n_dof must be >= 1, got {n_dof}")
    if output not in ("acceleration", "displacement"):
        raise ValueError(f"output must be 'acceleration' or 'displacement', got {output!r}")
    n = n_dof
    M = mass * np.eye(n)
    k = 2.0 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    k[-1, -1] = 1.0
    K = stiffness * k
    a, b = rayleigh
    Cd = a * M + b * K
    Minv = np.linalg.inv(M)
    fd = tuple(int(i) for i in force_dofs)
    Bf = np.zeros((n, len(fd)))
    for col, dof in enumerate(fd):
        Bf[dof, col] = 1.0
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ Cd]])
    B = np.vstack([np.zeros((n, len(fd))), Minv @ Bf])
    if output == "acceleration":
        C = np.hstack([-Minv @ K, -Minv @ Cd])
        D = Minv @ Bf
    else:
        C = np.hstack([np.eye(n), np.zeros((n, n))])
        D = np.zeros((n, len(fd)))
    w2 = linalg.eigh(K, M, eigvals_only=True)
    w = np.sqrt(w2)
    zeta = a / (2.0 * w) + b * w / 2.0
    return Chain(M, K, Cd, A, B, C, D, fd, w / (2.0 * np.pi), zeta)


def simulate_discrete(
    A: FloatArray, B: FloatArray, C: FloatArray, D: FloatArray, u: FloatArray
) -> FloatArray:
    """Outputs ``(N, q)`` of ``x(k+1) = A x(k) + B u(k)``, ``y(k) = C x(k) + D u(k)`` from
    ``x(0) = 0`` for inputs ``u`` ``(N, r)``, by modal decomposition: each eigenvalue
    ``lam`` of ``A`` is the first-order recursion ``z(k+1) = lam z(k) + g(k)`` run by
    ``lfilter`` (``A`` must be diagonalizable, as a damped structure's is)."""
    from scipy import signal

    lam, V = np.linalg.eig(A)
    Vinv = np.linalg.inv(V)
    g = u @ (Vinv @ B).T  # (N, n) modal inputs
    z = np.empty(g.shape, dtype=np.complex128)
    for i, li in enumerate(lam):
        z[:, i] = signal.lfilter([0.0, 1.0], [1.0, -li], g[:, i])
    return np.real(z @ (C @ V).T) + u @ D.T


def simulate_chain(
    duration_s: float,
    rate_hz: float = DEFAULT_RATE_HZ,
    *,
    model: Chain | None = None,
    cutoff_hz: float | None = None,
    noise: float | Sequence[float] = 0.0,
    seed: int = 0,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Response of ``model`` (default: :func:`chain_model`) to independent unit-variance
    band-limited white-noise forces (Li et al. 2007: "Actuators 1 and 2 are driven by
    independent band-limited white noise"), held over each sample.

    ``cutoff_hz`` defaults to twice the highest natural frequency (at most 0.4 ``rate_hz``)
    so the healthy data spans the structure's band, as the direct approach needs.
    ``noise`` is the standard deviation of white measurement noise as a fraction of each
    channel's RMS (one value, or one per channel; the paper's "1 %" is 0.01).

    Returns ``(t_s, Y, U)``: times, measured outputs ``(N, n_out)``, forces ``(N, r)``."""
    rng = np.random.default_rng(seed)
    m = chain_model() if model is None else model
    n = int(round(duration_s * rate_hz))
    cut = cutoff_hz if cutoff_hz is not None else min(0.4 * rate_hz, 2.0 * m.frequencies_hz[-1])
    r = m.B.shape[1]
    U = np.column_stack([band_limited_noise(n, rate_hz, cut, rng) for _ in range(r)])
    Ad, Bd, Cd, Dd = m.discrete(rate_hz)
    Y = simulate_discrete(Ad, Bd, Cd, Dd, U)
    lev = np.broadcast_to(np.asarray(noise, dtype=np.float64), (Y.shape[1],))
    if np.any(lev > 0.0):
        rms = np.sqrt(np.mean(Y**2, axis=0))
        Y = Y + rng.standard_normal(Y.shape) * (lev * rms)
    return np.arange(n) / rate_hz, Y, U


class Failure(StrEnum):
    """Sensor failures of Li et al. (2007): ``random`` (the sensor gives arbitrary random
    data), ``zero`` (it reads zero: disconnected), ``gain`` (amplitude reduction, the
    truss experiment's "reduced by half")."""

    RANDOM = "random"
    ZERO = "zero"
    GAIN = "gain"


@dataclass(frozen=True, slots=True)
class FailureSpec:
    """One failure of one channel (column index) over ``[start_s, end_s)``; ``size`` is
    the gain for ``gain`` and the RMS of the random data as a fraction of the channel's
    RMS for ``random``."""

    channel: int
    kind: Failure
    start_s: float
    end_s: float
    size: float = 1.0


def inject_failures(
    Y: FloatArray, rate_hz: float, failures: Sequence[FailureSpec], *, seed: int = 0
) -> FloatArray:
    """A copy of ``Y`` ``(N, n_out)`` with ``failures`` applied (vectorized per failure;
    the part of a failure outside the record is ignored)."""
    rng = np.random.default_rng(seed)
    out = np.array(Y, dtype=np.float64, copy=True)
    rms = np.sqrt(np.mean(Y**2, axis=0))
    for f in failures:
        k0 = min(out.shape[0], max(0, int(round(f.start_s * rate_hz))))
        k1 = min(out.shape[0], max(k0, int(round(f.end_s * rate_hz))))
        seg = slice(k0, k1)
        kind = Failure(f.kind)
        if kind is Failure.RANDOM:
            out[seg, f.channel] = rng.standard_normal(k1 - k0) * (f.size * rms[f.channel])
        elif kind is Failure.ZERO:
            out[seg, f.channel] = 0.0
        else:
            out[seg, f.channel] *= f.size
    return out


PAPER_FAILURES = (
    FailureSpec(0, Failure.RANDOM, 2.0, 4.0),
    FailureSpec(0, Failure.RANDOM, 6.0, 8.0),
    FailureSpec(1, Failure.ZERO, 4.0, 6.0),
    FailureSpec(1, Failure.ZERO, 8.0, 10.0),
)
"""Li et al. (2007, Simulation): sensor 1 (mass 1) gives random data in 2-4 s and 6-8 s,
sensor 2 (mass 2) reads zero in 4-6 s and 8-10 s (times from the start of the test)."""


@dataclass(frozen=True, slots=True)
class ChainArchive:
    """A simulated archive of the paper's example: ``values`` (N, 4) for channels
    ``s1..s4`` (sensor ``k`` on mass ``k``), a healthy training stretch ``train``
    (index range) followed by the test record with ``failures`` (times from the start of
    the archive), and the matching config (one group, s1-s2 uncertain, s3-s4 reference,
    and the exact discrete ``[model]``)."""

    values: FloatArray
    channels: tuple[str, ...]
    rate_hz: float
    train: tuple[int, int]
    failures: tuple[FailureSpec, ...]
    config: dict[str, object]


def chain_archive(
    rate_hz: float = DEFAULT_RATE_HZ,
    *,
    failures: Sequence[FailureSpec] = PAPER_FAILURES,
    train_s: float = 20.0,
    test_s: float = 12.0,
    noise: float | Sequence[float] = 0.0,
    seed: int = 0,
) -> ChainArchive:
    """One continuous simulation: ``train_s`` healthy seconds, then ``test_s`` seconds with
    ``failures`` (given in seconds from the start of the test record, as in the paper,
    and shifted by ``train_s``). The paper does not say how long its healthy record is;
    the shared thresholds estimate the spread of 2 s window statistics from it, which
    needs ten or so such windows."""
    m = chain_model()
    _, Y, _ = simulate_chain(train_s + test_s, rate_hz, model=m, noise=noise, seed=seed)
    shifted = tuple(
        FailureSpec(f.channel, f.kind, f.start_s + train_s, f.end_s + train_s, f.size)
        for f in failures
    )
    values = inject_failures(Y, rate_hz, shifted, seed=seed + 1)
    names = tuple(f"s{k + 1}" for k in range(Y.shape[1]))
    A, B, C, D = m.discrete(rate_hz)
    config: dict[str, object] = {
        "group": [
            {
                "name": "chain",
                "channels": list(names),
                "reference": ["s3", "s4"],
                "uncertain": ["s1", "s2"],
                "inputs": [],
            }
        ],
        "model": {
            "A": A,
            "B": B,
            "C": C,
            "D": D,
            "dt": 1.0 / rate_hz,
            "outputs": list(names),
            "inputs": [],
        },
    }
    return ChainArchive(values, names, rate_hz, (0, int(round(train_s * rate_hz))), shifted, config)
