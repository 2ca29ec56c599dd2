"""Simulated structures with injected sensor faults: the worked examples of the seed
papers, used for the bundled samples, the tests and the benchmarks.

* :func:`shear_building`: an n-story uniform lumped-mass shear building under ground
  excitation, floor absolute accelerations as outputs (Chang et al. 2017, Section 3: five
  stories, f1 = 1.01 Hz, 2 % damping, 200 Hz, ~20 dB SNR; the higher frequencies up to
  0.6 % above the paper's, see :func:`shear_building`).
* :func:`inject_fault`: additive, multiplicative and drifting faults (Chang et al. 2017,
  Eq. 11-13), plus stuck and erratic (``other``) faults.

The response is computed by exact modal discretization (zero-order hold per complex mode)
and ``scipy.signal.lfilter``: no Python loop per sample.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import linalg

from analyzer.types import FaultType

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Building:
    """Continuous model ``x' = A x + B ag``, ``y = C x + D ag`` of floor absolute
    accelerations under ground acceleration ``ag``; ``x = [displacements, velocities]``
    relative to the ground."""

    n_floors: int
    A: FloatArray
    B: FloatArray
    C: FloatArray
    D: FloatArray
    frequencies_hz: FloatArray
    damping: float

    def discrete(self, rate_hz: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Zero-order-hold discretization (Ad, Bd, C, D) at ``rate_hz``."""
        from scipy import signal

        ad, bd, cd, dd, _ = signal.cont2discrete((self.A, self.B, self.C, self.D), 1.0 / rate_hz)
        return ad, bd, cd, dd


def shear_building(
    n_floors: int = 5, f1_hz: float = 1.01, damping: float = 0.02, mass: float = 1.0
) -> Building:
    """Uniform shear building (equal floor masses and story stiffnesses) whose first
    natural frequency is ``f1_hz``, with ``damping`` in every mode (modal damping). For
    five floors the frequencies are 1.01, 2.948, 4.648, 5.970 and 6.809 Hz: close to Chang
    et al.'s (2017, Section 3) 1.01, 2.93, 4.63, 5.94 and 6.78 Hz, up to 0.6 % above them
    (2.948 for 2.93), since equal stories cannot space the modes as the paper's building
    does. The model is kept as it is, for every simulation (samples, tests, benchmarks)
    is made with it; ``tests/detectors/test_ar_kalman.py`` checks both sets."""
    n = n_floors
    # stiffness matrix of a uniform shear chain fixed at the ground, unit story stiffness
    k = 2.0 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    k[-1, -1] = 1.0
    w1_unit = 2.0 * np.sin(np.pi / (2.0 * (2 * n + 1)))
    kstory = mass * (2.0 * np.pi * f1_hz / w1_unit) ** 2
    K = kstory * k
    M = mass * np.eye(n)
    w2, phi = linalg.eigh(K, M)
    w = np.sqrt(w2)
    # modal damping: C = M phi diag(2 zeta w) phi^T M (phi mass-normalized)
    Cd = M @ phi @ np.diag(2.0 * damping * w) @ phi.T @ M
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ Cd]])
    B = np.concatenate([np.zeros(n), -np.ones(n)])[:, None]
    # absolute acceleration = relative acceleration + ground acceleration
    C = np.hstack([-Minv @ K, -Minv @ Cd])
    D = np.zeros((n, 1))
    return Building(n, A, B, C, D, w / (2.0 * np.pi), damping)


def band_limited_noise(
    n: int, rate_hz: float, cutoff_hz: float, rng: np.random.Generator
) -> FloatArray:
    """Unit-variance white noise low-passed at ``cutoff_hz`` (4th-order Butterworth)."""
    from scipy import signal

    b, a = signal.butter(4, cutoff_hz, fs=rate_hz)
    x = signal.lfilter(b, a, rng.standard_normal(n + 500))[500:]
    return x / np.std(x)


def simulate_response(model: Building, u: FloatArray, rate_hz: float) -> FloatArray:
    """Outputs (N, n_out) for ground acceleration ``u`` by exact modal ZOH discretization:
    each complex mode ``lambda`` is the first-order recursion
    ``z[k+1] = exp(lambda h) z[k] + b (exp(lambda h) - 1) / lambda u[k]`` run by lfilter."""
    from scipy import signal

    h = 1.0 / rate_hz
    lam, V = np.linalg.eig(model.A)
    Vinv = np.linalg.inv(V)
    bm = (Vinv @ model.B)[:, 0]
    cm = model.C @ V
    y = np.tile(model.D[:, 0], (u.shape[0], 1)) * u[:, None]
    for i, li in enumerate(lam):
        e = np.exp(li * h)
        g = bm[i] * (e - 1.0) / li
        # z[k] depends on u[k-1]: numerator [0, g]
        z = signal.lfilter([0.0, g], [1.0, -e], u.astype(np.complex128))
        y += np.real(np.outer(z, cm[:, i]))
    return y


def simulate_building(
    n_floors: int = 5,
    duration_s: float = 60.0,
    rate_hz: float = 200.0,
    *,
    seed: int = 0,
    snr_db: float = 20.0,
    sensors_per_floor: int = 1,
    f1_hz: float = 1.01,
    damping: float = 0.02,
    cutoff_hz: float | None = None,
) -> tuple[FloatArray, FloatArray, list[str]]:
    """Simulated accelerometer records of a shear building under band-limited white-noise
    ground excitation (unit variance), with white measurement noise at ``snr_db``.

    Returns ``(t_s, Y, names)``: times in seconds, (N, n_floors * sensors_per_floor)
    measurements, channel names ``s0, s1, ...`` (floor-major: s0 is floor 1's first sensor).
    Sensors on the same floor see the same motion with independent noise."""
    rng = np.random.default_rng(seed)
    model = shear_building(n_floors, f1_hz, damping)
    n = int(round(duration_s * rate_hz))
    cut = cutoff_hz if cutoff_hz is not None else min(0.4 * rate_hz, 2.0 * model.frequencies_hz[-1])
    u = band_limited_noise(n, rate_hz, cut, rng)
    clean = simulate_response(model, u, rate_hz)
    clean = np.repeat(clean, sensors_per_floor, axis=1)
    rms = np.sqrt(np.mean(clean**2, axis=0))
    noise = rng.standard_normal(clean.shape) * (rms / 10.0 ** (snr_db / 20.0))
    t = np.arange(n) / rate_hz
    names = [f"s{i}" for i in range(clean.shape[1])]
    return t, clean + noise, names


def inject_fault(
    y: FloatArray,
    rate_hz: float,
    kind: FaultType | str,
    onset_s: float,
    size: float,
    end_s: float | None = None,
) -> FloatArray:
    """A copy of the 1-D record ``y`` with a fault from ``onset_s`` to ``end_s``:

    * ``additive``: ``y + size`` (Eq. 11)
    * ``multiplicative``: ``size * y`` (Eq. 12; size 0 = dead sensor)
    * ``drift``: ``y + size * (t - onset)``, size in units per second (Eq. 13)
    * ``other``: stuck at the value at onset plus ``size`` (a frozen sensor).
    """
    out = np.array(y, dtype=np.float64, copy=True)
    k0 = int(round(onset_s * rate_hz))
    k1 = out.shape[0] if end_s is None else int(round(end_s * rate_hz))
    seg = slice(k0, k1)
    kind = FaultType(kind)
    if kind is FaultType.ADDITIVE:
        out[seg] += size
    elif kind is FaultType.MULTIPLICATIVE:
        out[seg] *= size
    elif kind is FaultType.DRIFT:
        out[seg] += size * np.arange(k1 - k0) / rate_hz
    else:
        out[seg] = out[k0] + size
    return out
