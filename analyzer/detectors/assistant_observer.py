"""The assistant-state observer of Wang & Song (2014) for one target sensor, the
relation that gives its assistant state from other sensors, and the pretreatment that
tunes its output estimate: what :class:`~analyzer.detectors.equivalent_model.EquivalentModel`
runs for each sensor of the network.

Assistant state and perfect decoupling (Section 4.2, Eq. 26-32)
-----------------------------------------------------------------
Adding the assistant state ``xbar_i = int x_i dt`` (measured, or computed from other
sensors through an analytical relationship) gives (Eq. 26-27)::

    [xbar_i; x_i]' = [[0, 1], [0, a]] [xbar_i; x_i] + [0; b] u + [0; 1] d,
    [y_1; y_2]     = [xbar_i; x_i] + [fbar_s; f_s]

and the observer ``xhat' = A xhat + B u + K (y - C xhat)``, ``r = W (y - C xhat)``
(Eq. 28-29) with Theorem 6's gain ``W = [1 0]``, ``K = [[lambda1, 1], [0, a + lambda2]]``.
Then ``A - K C = diag(-lambda1, -lambda2)``, ``W C E = 0`` and ``W C`` is a left eigenvector
of ``A - K C`` (Lemma 1), so the disturbance, the model uncertainty and the input vanish
from the residual::

    r(s) = s / (s + lambda1) fbar_s(s) - 1 / (s + lambda1) f_s(s)          (Eq. 30)

which settles at ``-f_s / lambda1`` (Eq. 31-32), while a bias of the assistant state dies
out. Neither ``a`` nor ``b`` appears in Eq. 30: they shape only the output estimate
``xhat_2`` (Theory 3-4), which is what the pretreatment of Algorithm 1 tunes.

Discretization
--------------
The observer is discretized exactly (zero-order hold of the sampled inputs, ``expm``).
When the assistant state is given as samples of ``xbar`` (``mode="state"``), holding it
constant between samples while ``y_2`` is held too leaves an ``O(h)`` mismatch (the
integral and its rate are not both piecewise constant) -- the "potential risk" of Section
4.1; a first-order hold (``hold="foh"``) reduces it to ``O(h^2)``. When the assistant state is
the integral of a *rate* ``z`` computed from other sensors (``mode="rate"``, used by the
detector), ``xbar = int z`` is integrated inside the observer. In the coordinates
``r = xbar - xhat_1`` the integrator drops out: ``r' = -lambda1 r + z - y_2`` (the
integrator of the assistant state is unobservable from ``r`` and ``xhat_2``), so the exact
ZOH discretization of the whole chain is the stable two-state system
``r[k+1] = phi r[k] + (1 - phi) / lambda1 (z[k] - y_2[k])``, ``phi = exp(-lambda1 h)``:
``z`` and ``y_2`` share the same hold, so perfect decoupling survives sampling exactly and
a constant ``f_s`` gives ``-f_s / lambda1`` exactly.

Relation (Section 4.3)
----------------------
The rate ``z_i`` of the assistant state is a linear relation of the assistant sensors'
samples identified on the healthy window: a least-squares FIR whose lags are chosen among
:data:`LAG_CANDIDATES` (:func:`fit_relation`).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
from numpy.lib.stride_tricks import sliding_window_view
from scipy import linalg

from analyzer.detectors.lowpass import recursion
from analyzer.errors import DetectorError, TooLittleDataError
from analyzer.paging import (
    finite_rows,
    release,
    row_blocks,
)

FloatArray = npt.NDArray[np.float64]
Mode = Literal["state", "rate"]
Hold = Literal["zoh", "foh"]


# -- the observer ---------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class AssistantObserver:
    """The observer of Eq. 28 with the gain of Theorem 6 for the equivalent model
    ``x' = a x + b u + d`` (Eq. 13), sampled every ``dt`` seconds."""

    a: float
    b: float
    lambda1: float
    lambda2: float
    dt: float

    def __post_init__(self) -> None:
        if not (self.lambda1 > 0.0 and self.lambda2 > 0.0):
            raise DetectorError(
                f"lambda1 and lambda2 must be positive (Theorem 6), got {self.lambda1}, "
                f"{self.lambda2}"
            )
        if not self.dt > 0.0:
            raise DetectorError(f"sample period must be positive, got {self.dt}")

    # Eq. 27 and Theorem 6
    @property
    def A(self) -> FloatArray:
        return np.array([[0.0, 1.0], [0.0, self.a]])

    @property
    def B(self) -> FloatArray:
        return np.array([[0.0], [self.b]])

    @property
    def E(self) -> FloatArray:
        return np.array([[0.0], [1.0]])

    @property
    def C(self) -> FloatArray:
        return np.eye(2)

    @property
    def K(self) -> FloatArray:
        return np.array([[self.lambda1, 1.0], [0.0, self.a + self.lambda2]])

    @property
    def W(self) -> FloatArray:
        return np.array([[1.0, 0.0]])

    @property
    def Ac(self) -> FloatArray:
        """``A - K C = diag(-lambda1, -lambda2)``."""
        return self.A - self.K @ self.C

    def transfer(self, s: complex) -> tuple[complex, complex, complex]:
        """``(G_rd, G_r_fbar, G_r_fs)`` at the Laplace variable ``s`` (Eq. 25, 29-30):
        ``G_rd = W C (sI - Ac)^-1 E`` (0 by Lemma 1) and the fault transfers
        ``W (I - C (sI - Ac)^-1 K)`` split over ``[fbar_s, f_s]``."""
        res = np.linalg.inv(s * np.eye(2) - self.Ac)
        grd = complex((self.W @ self.C @ res @ self.E)[0, 0])
        grf = self.W @ (np.eye(2) - self.C @ res @ self.K)
        return grd, complex(grf[0, 0]), complex(grf[0, 1])

    def continuous(
        self, mode: Mode = "state"
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """``(A, B, C, D)`` of the observer as an LTI system.

        ``mode="state"``: inputs ``[xbar, y, u]``, state ``xhat``, outputs ``[r, xhat_2]``.
        ``mode="rate"``: inputs ``[z, y, u]`` with ``xbar = int z``, state ``[r, xhat_2]``
        (module docstring), outputs ``[r, xhat_2]``."""
        l1, l2 = self.lambda1, self.lambda2
        if mode == "state":
            Ao = self.Ac
            Bo = np.hstack([self.K, self.B])
            Co = np.array([[-1.0, 0.0], [0.0, 1.0]])
            Do = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
            return Ao, Bo, Co, Do
        if mode == "rate":
            Ao = np.diag([-l1, -l2])
            Bo = np.array([[1.0, -1.0, 0.0], [0.0, self.a + l2, self.b]])
            return Ao, Bo, np.eye(2), np.zeros((2, 3))
        raise DetectorError(f"observer mode must be 'state' or 'rate', got {mode!r}")

    def discrete(
        self, mode: Mode = "state", hold: Hold = "zoh"
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Exact discretization ``(F, G, H, J)`` for the given hold of the sampled inputs
        (``scipy.signal.cont2discrete``; the zero-order hold as it computes it, by
        :func:`_zoh`, without importing ``scipy.signal``)."""
        if hold not in ("zoh", "foh"):
            raise DetectorError(f"hold must be 'zoh' or 'foh', got {hold!r}")
        sysc = self.continuous(mode)
        if hold == "zoh":
            Ao, Bo, Co, Do = sysc
            F, G = _zoh(Ao, Bo, self.dt)
            return (F, G, np.asarray(Co), np.asarray(Do))
        from scipy import signal  # (import: ~1 s, with scipy.stats)

        F, G, H, J, _ = signal.cont2discrete(sysc, self.dt, method=hold)
        return (np.asarray(F), np.asarray(G), np.asarray(H), np.asarray(J))

    def run(
        self,
        assistant: FloatArray,
        measured: FloatArray,
        u: FloatArray | None = None,
        *,
        mode: Mode = "state",
        hold: Hold = "zoh",
    ) -> tuple[FloatArray, FloatArray]:
        """Residual ``r`` (Eq. 29) and output estimate ``xhat_2`` over the records.

        ``assistant`` is ``xbar`` (``mode="state"``) or its rate ``z`` (``mode="rate"``);
        the observer starts in the healthy steady state (``r = 0``, ``xhat_2 = y[0]``).
        The recursion runs as first-order IIR filters (``A - K C`` is diagonal): no Python
        loop per sample. Outputs are taken at the sample instants."""
        xa = np.asarray(assistant, dtype=np.float64)
        y = np.asarray(measured, dtype=np.float64)
        uu = np.zeros_like(y) if u is None else np.asarray(u, dtype=np.float64)
        V = np.column_stack([xa, y, uu])
        F, G, H, J = self.discrete(mode, hold)
        target = np.array([0.0, y[0]])
        x0 = np.linalg.solve(H, target - J @ V[0])
        X = _diag_states(F, G, V, x0)
        out = X[:-1] @ H.T + V @ J.T
        return out[:, 0], out[:, 1]

    def rate_residual(self, z: FloatArray, measured: FloatArray) -> FloatArray:
        """``r`` *after* each sample, ``r[k+1]`` (``mode="rate"``, ZOH): the residual at the
        end of sample ``k``'s hold interval, so it includes sample ``k`` (no one-sample
        lag); ``r[0] = 0`` before the first sample."""
        from scipy import signal

        phi = float(np.exp(-self.lambda1 * self.dt))
        gain = (1.0 - phi) / self.lambda1
        x = gain * (np.asarray(z, dtype=np.float64) - np.asarray(measured, dtype=np.float64))
        out, _ = signal.lfilter([1.0], [1.0, -phi], x, zi=[0.0])
        return np.asarray(out, dtype=np.float64)


def _zoh(A: FloatArray, B: FloatArray, dt: float) -> tuple[FloatArray, FloatArray]:
    """``(F, G)`` of ``scipy.signal.cont2discrete((A, B, C, D), dt, method="zoh")``, the same
    operations: ``expm(dt [[A, B], [0, 0]])``'s upper blocks (tests compare the bits)."""
    n, m = A.shape[0], B.shape[1]
    em = np.vstack((np.hstack((A, B)), np.zeros((m, n + m))))
    ms = linalg.expm(dt * em)[:n, :]
    return np.asarray(ms[:, :n]), np.asarray(ms[:, n:])


def _diag_states(F: FloatArray, G: FloatArray, V: FloatArray, x0: FloatArray) -> FloatArray:
    """States ``x[0..N]`` of ``x[k+1] = F x[k] + G v[k]`` for a diagonal ``F``, each state a
    first-order recursion (:func:`~analyzer.detectors.lowpass.recursion`, ``lfilter``'s
    bits)."""
    d = np.diag(F)
    if not np.allclose(F, np.diag(d), atol=1e-14 * max(1.0, float(np.abs(F).max()))):
        raise DetectorError("internal error: the observer's state matrix is not diagonal")
    N = V.shape[0]
    X = np.empty((N + 1, F.shape[0]))
    X[0] = x0
    for j in range(F.shape[0]):
        drive = V @ G[j]
        X[1:, j] = recursion(drive, d[j], d[j] * x0[j])
    return X


# -- pretreatment (Algorithm 1, Theory 3-4) ------------------------------------------------


@dataclass(frozen=True, slots=True)
class Pretreatment:
    """Observer parameters ``a``, ``b`` and the resulting RMS of ``e_y = y - yhat``."""

    a: float
    b: float
    ey_rms: float
    method: str

    def as_dict(self) -> dict[str, Any]:
        return {"a": self.a, "b": self.b, "ey_rms": self.ey_rms, "method": self.method}


PRETREAT_ROWS = 1 << 16
"""Samples the pretreatment's observers run through at a time (their states carried)."""

PRETREAT_MIN_SAMPLES = 16
"""Fewest finite healthy samples the pretreatment accepts: it fits two unknowns
``(a, b)`` by least squares to the output error of observers that start from a zero
state, and below this raises :class:`TooLittleDataError` (the count it names as needed).
A floor set with the code when it was first written, with no stated derivation."""


def _output_errors(
    y: FloatArray,
    u: FloatArray | None,
    pairs: Sequence[tuple[float, float]],
    lambda2: float,
    dt: float,
) -> Iterator[list[FloatArray]]:
    """``e_y = y - xhat_2`` of the output observer (Eq. 14 and 17 with ``k = a + lambda2``),
    exact ZOH, started at ``xhat_2 = y[0]``, for each ``(a, b)`` of ``pairs`` (``u`` 0 when
    None): :data:`PRETREAT_ROWS` samples at a time, each observer's state carried from
    block to block (the recursion of the whole series, cut), so a long training window is
    not copied."""
    systems = []
    for a, b in pairs:
        F, G, _, _ = AssistantObserver(a, b, 1.0, lambda2, dt).discrete("rate")
        systems.append((F[1:, 1:], G[1:]))
    states = [np.array([float(y[0])]) for _ in pairs]
    for lo in range(0, y.shape[0], PRETREAT_ROWS):
        yb = np.array(y[lo : lo + PRETREAT_ROWS], dtype=np.float64)
        ub = np.zeros_like(yb) if u is None else np.array(u[lo : lo + PRETREAT_ROWS], np.float64)
        release(y[lo : lo + PRETREAT_ROWS])  # a memory-mapped window's rows: copied above
        if u is not None:
            release(u[lo : lo + PRETREAT_ROWS])
        V = np.column_stack([np.zeros_like(yb), yb, ub])
        out = []
        for k, (F, G) in enumerate(systems):
            X = _diag_states(F, G, V, states[k])
            states[k] = X[-1].copy()
            out.append(yb - X[:-1, 0])
        yield out


def pretreat(
    y: FloatArray,
    u: FloatArray | None,
    dt: float,
    lambda2: float,
    table: Sequence[Sequence[float]] | None = None,
) -> Pretreatment:
    """Algorithm 1 / Theory 3-4: choose ``a``, ``b`` of the observer so the output error
    ``e_y = y - yhat`` (Eq. 20-22) is as small as possible on healthy data.

    With a ``table`` of candidate ``(a, b)`` pairs this is the paper's table approach (the
    pair with the smallest RMS ``e_y``). Without, the exact minimizer: ``xhat_2`` obeys
    ``xhat_2' = -lambda2 xhat_2 + (a + lambda2) y + b u``, so the sampled ``e_y`` is affine in
    ``(a, b)`` and three runs of the discrete observer give it in closed form; linear least
    squares then minimizes ``||e_y||`` (its normal equations, summed a block at a time:
    ``e_y = e_0 + M (a, b)`` with one or two columns in ``M``). ``a = 0`` is excluded by
    Theory 1 and reported. The RMS is that of the chosen observer's run. The observers run
    :data:`PRETREAT_ROWS` samples at a time: no copy of the window is held."""
    yy = np.asarray(y)
    ok = finite_rows(yy)  # a block of a memory-mapped window at a time
    if u is not None:
        ok &= finite_rows(np.asarray(u))
    if ok.sum() < PRETREAT_MIN_SAMPLES:
        raise TooLittleDataError(
            f"too little healthy data for the pretreatment: {int(ok.sum())} samples",
            int(ok.sum()),
            PRETREAT_MIN_SAMPLES,
        )
    # contiguous run with no gap (the observer needs consecutive samples)
    runs = np.flatnonzero(np.diff(np.concatenate(([0], ok.astype(np.int8), [0]))))
    lens = runs[1::2] - runs[::2]
    k = int(np.argmax(lens))
    seg = slice(int(runs[2 * k]), int(runs[2 * k + 1]))
    del ok
    yy = yy[seg]
    uu = None if u is None else np.asarray(u)[seg]

    def rms(pairs: Sequence[tuple[float, float]]) -> list[float]:
        sq = np.zeros(len(pairs))
        for errors in _output_errors(yy, uu, pairs, lambda2, dt):
            sq += [float(e @ e) for e in errors]
        return [float(np.sqrt(v / yy.shape[0])) for v in sq]

    if table is not None:
        pairs = []
        for row in table:
            if len(row) != 2:
                raise DetectorError(f"pretreatment table rows must be (a, b) pairs, got {row!r}")
            pairs.append((float(row[0]), float(row[1])))
        if not pairs:
            raise DetectorError("the pretreatment table is empty")
        found = rms(pairs)
        best = int(np.argmin(found))  # the first of equal ones, as a scan keeps
        return Pretreatment(*pairs[best], found[best], "table (Algorithm 1)")
    with_input = uu is not None and float(np.ptp(uu)) > 0.0
    pairs = [(0.0, 0.0), (1.0, 0.0)] + ([(0.0, 1.0)] if with_input else [])
    MtM = np.zeros((len(pairs) - 1, len(pairs) - 1))
    Mte = np.zeros(len(pairs) - 1)
    for e0, *runs_ab in _output_errors(yy, uu, pairs, lambda2, dt):
        M = np.column_stack([e - e0 for e in runs_ab])
        MtM += M.T @ M
        Mte += M.T @ e0
    coef, *_ = np.linalg.lstsq(MtM, -Mte, rcond=None)
    a = float(coef[0])
    b = float(coef[1]) if with_input else 0.0
    (ey_rms,) = rms([(a, b)])
    return Pretreatment(a, b, ey_rms, "least squares (Theory 4)")


# -- relations identified on healthy data (Section 4.3) -------------------------------------


@dataclass(frozen=True, slots=True)
class Relation:
    """``z[k] = c + sum_j sum_{l=0..L} h[j, l] y_j[k - l]``: the estimate of a target sensor
    from its assistant sensors (a causal FIR), least squares on the healthy window."""

    target: int
    assistants: tuple[int, ...]
    lags: int
    coef: FloatArray  # (len(assistants), lags + 1)
    intercept: float
    r_squared: float

    def estimate(self, values: FloatArray) -> FloatArray:
        """``z`` over ``values`` (N, m); NaN inputs count as 0 (mask afterwards)."""
        from scipy import signal

        N = values.shape[0]
        z = np.full(N, self.intercept)
        for j, col in enumerate(self.assistants):
            x = np.nan_to_num(np.asarray(values[:, col], dtype=np.float64), nan=0.0)
            z += signal.lfilter(self.coef[j], [1.0], x)
        return z

    def as_dict(self, names: Sequence[str]) -> dict[str, Any]:
        return {
            "target": names[self.target],
            "assistants": [names[j] for j in self.assistants],
            "lags": self.lags,
            "r_squared": self.r_squared,
            "dc_gain": {names[j]: float(self.coef[i].sum()) for i, j in enumerate(self.assistants)},
        }


LAG_CANDIDATES = (0, 1, 2, 4, 8, 16, 32, 64, 128)


def fit_relation(
    values: FloatArray,
    target: int,
    assistants: Sequence[int],
    lags: int | str = "bic",
    max_lags: int = 64,
) -> Relation:
    """Least-squares FIR relation of ``target`` on ``assistants`` (rows with a NaN dropped);
    ``lags="bic"`` picks the length among ``0, 1, 2, 4, ...`` up to ``max_lags`` by BIC, all
    candidates fitted on the same rows.

    One Gram matrix serves every candidate length, each solved by Cholesky on its
    unit-diagonal sub-matrix. Without a gap in the columns used it comes from lagged
    cross-products (:func:`_lagged_gram`, no design matrix); with one, from the design
    matrix of the rows that have no NaN (:func:`_rows_gram`)."""
    Y = np.asarray(values, dtype=np.float64)
    if isinstance(lags, str):
        if lags != "bic":
            raise DetectorError(f"lags must be an integer or 'bic', got {lags!r}")
        cands = [L for L in LAG_CANDIDATES if max_lags >= L]
    else:
        if int(lags) < 0:
            raise DetectorError(f"lags must be >= 0, got {lags}")
        cands = [int(lags)]
    Lmax = max(cands)
    N = Y.shape[0]
    need = Lmax + 4 * (len(assistants) * (Lmax + 1) + 1)
    if need >= N:
        raise TooLittleDataError(
            f"too little healthy data for a {Lmax}-lag relation of {len(assistants)} sensor(s): "
            f"{N} samples",
            N,
            need + 1,
        )
    width = Lmax + 1
    p = len(assistants)
    cols = [target, *assistants]
    used = np.empty((len(cols), N))  # one pass over the rows, a block at a time
    for lo, block in row_blocks(Y):
        used[:, lo : lo + block.shape[0]] = block[:, cols].T
    if p and np.isfinite(used).all():
        # no gap: every row counts and the Gram matrix follows from lagged products
        t = used[0, Lmax:]
        n = t.shape[0]
        G, h_all = _lagged_gram(used[0], used[1:], Lmax)
        every = True
    else:
        G, h_all, t, X = _rows_gram(Y, target, assistants, Lmax)
        n = t.shape[0]
        every = False
    if n < need:
        # rows with a gap anywhere in a lag history are left out: scattered losses
        # (dropped packets) leave few complete ones
        raise TooLittleDataError(
            f"too little healthy data for a {Lmax}-lag relation of {len(assistants)} "
            f"sensor(s): {n} of {N} training rows have every lagged value (gaps in "
            "these sensors' data)",
            n,
            need,
        )
    var_t = float(np.var(t))
    if not var_t > 0.0:
        raise DetectorError("the target sensor is constant in the training window")
    tt = float(t @ t)
    results = []
    for L in cands:
        idx = np.concatenate([[0], *[1 + j * width + np.arange(L + 1) for j in range(p)]])
        coef = _solve_normal(G[np.ix_(idx, idx)], h_all[idx])
        # |t - X c|^2 from the Gram matrix (no pass over the rows per candidate)
        rss = max(
            tt - 2.0 * float(coef @ h_all[idx]) + float(coef @ G[np.ix_(idx, idx)] @ coef), 0.0
        )
        bic = n * np.log(max(rss / n, 1e-300)) + idx.shape[0] * np.log(n)
        results.append((bic, L, coef, idx))
    _, L, coef, idx = min(results, key=lambda r: r[0])
    h = coef[1:].reshape(p, L + 1)
    # the chosen one's residual sum of squares, from the rows
    if every:
        fitted = np.full(n, coef[0])
        for j in range(p):  # sum_l h[j, l] y_j[k - l] for k >= Lmax
            fitted += np.convolve(used[1 + j, Lmax - L :], h[j], mode="valid")
        rss = float(np.sum((t - fitted) ** 2))
    else:
        rss = float(np.sum((t - X[:, idx] @ coef) ** 2))
    return Relation(target, tuple(assistants), L, h, float(coef[0]), float(1.0 - rss / (n * var_t)))


def _rows_gram(
    Y: FloatArray, target: int, assistants: Sequence[int], Lmax: int
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """``(X^T X, X^T t, t, X)`` of the lagged design ``X = [1, y_j[k - l] ...]`` (lags
    ``0 .. Lmax`` of each assistant) over the rows ``k >= Lmax`` without a NaN."""
    width = Lmax + 1
    t = Y[Lmax:, target]
    # row k of a window is y_j[k + Lmax - g] for g = Lmax .. 0: reversed, lags 0 .. Lmax
    windows = [sliding_window_view(Y[:, j], width)[:, ::-1] for j in assistants]
    ok = np.isfinite(t)
    for w in windows:
        ok &= np.isfinite(w).all(axis=1)
    t = t[ok]
    n = t.shape[0]
    X = np.empty((n, 1 + len(assistants) * width))
    X[:, 0] = 1.0
    every = bool(ok.all())  # no gap: the windows are copied as they are (no row gather)
    for j, w in enumerate(windows):
        X[:, 1 + j * width : 1 + (j + 1) * width] = w if every else w[ok]
    return X.T @ X, X.T @ t, t, X


def _lagged_gram(y_t: FloatArray, cols: FloatArray, Lmax: int) -> tuple[FloatArray, FloatArray]:
    """``(X^T X, X^T t)`` of :func:`_rows_gram` for a record without a gap (the target
    ``y_t`` and the assistants' rows ``cols``), without forming ``X``: the lagged columns
    are shifts of one another, so

        G_jk[a, b] = sum_{k=Lmax}^{N-1} y_j[k - a] y_k[k - b]
                   = G_jk[a - 1, b - 1] + y_j[Lmax - a] y_k[Lmax - b] - y_j[N - a] y_k[N - b]:

    one cross-correlation per pair of assistants gives the first row of each block and a
    recursion over the ``Lmax`` boundary samples the rest (``O(N Lmax)`` instead of
    ``O(N Lmax^2)``; the same sums, rounded differently)."""
    p, N = cols.shape
    width = Lmax + 1

    def first_row(u: FloatArray, v: FloatArray) -> FloatArray:
        """``sum_k u[k] v[k - b]`` over ``k >= Lmax``, ``b = 0 .. Lmax``."""
        return np.correlate(v, u[Lmax:], mode="valid")[::-1]

    # blocks[j, k] = G_jk (width x width); D: the boundary products added along diagonals
    blocks = np.zeros((p, p, width, width))
    heads = np.stack([c[:Lmax][::-1] for c in cols])  # heads[j, a - 1] = y_j[Lmax - a]
    tails = np.stack([c[N - Lmax :][::-1] for c in cols])  # tails[j, a - 1] = y_j[N - a]
    D = heads[:, None, :, None] * heads[None, :, None, :]
    D -= tails[:, None, :, None] * tails[None, :, None, :]
    for j in range(p):
        for k in range(j, p):
            blocks[j, k, 0, :] = first_row(cols[j], cols[k])
            blocks[j, k, :, 0] = blocks[j, k, 0, :] if j == k else first_row(cols[k], cols[j])
    for a in range(1, width):
        blocks[:, :, a, 1:] = blocks[:, :, a - 1, :-1] + D[:, :, a - 1, :]
    for j in range(p):  # G_kj = G_jk^T (only j <= k were computed)
        for k in range(j):
            blocks[j, k] = blocks[k, j].T
    G = np.empty((1 + p * width, 1 + p * width))
    G[0, 0] = N - Lmax
    h_all = np.empty(1 + p * width)
    h_all[0] = float(np.sum(y_t[Lmax:]))
    for j, c in enumerate(cols):
        sl = slice(1 + j * width, 1 + (j + 1) * width)
        # sum_k y_j[k - a]: the window slides back one sample per lag
        s = np.empty(width)
        s[0] = float(np.sum(c[Lmax:]))
        s[1:] = s[0] + np.cumsum(heads[j] - tails[j])
        G[0, sl] = s
        G[sl, 0] = s
        for k in range(p):
            G[sl, 1 + k * width : 1 + (k + 1) * width] = blocks[j, k]
        h_all[sl] = first_row(y_t, c)
    return G, h_all


def _solve_normal(G: FloatArray, h: FloatArray) -> FloatArray:
    """Least squares from the normal equations ``G b = h``: columns scaled to a unit
    diagonal, a ridge of ``1e-10`` against rounding (lagged samples of smooth signals are
    nearly collinear), Cholesky."""
    d = np.sqrt(np.maximum(np.diag(G), 1e-300))
    Gn = G / np.outer(d, d)
    Gn[np.diag_indices_from(Gn)] += 1e-10
    try:
        c = linalg.cho_solve(linalg.cho_factor(Gn), h / d)
    except linalg.LinAlgError:
        c = np.linalg.lstsq(Gn, h / d, rcond=None)[0]
    return np.asarray(c / d, dtype=np.float64)
