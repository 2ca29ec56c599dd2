"""Decoupled sensor error functions (Li, Koh & Nagarajaiah 2007).

The sensors of a group are split into *reference* sensors (trusted) and *uncertain*
sensors (under test). For each uncertain sensor ``i`` an *error function* ``e_i(k)`` is a
linear combination of a window of ``p + 1`` samples of the reference sensors and of
sensor ``i`` (plus measured inputs, if any) that vanishes whenever sensor ``i`` measures
the structure correctly, whatever the other uncertain sensors read (Eq. 25-27). Its
response to a failure of sensor ``i`` is what the detector watches; a failure of another
uncertain sensor cannot raise it, because that sensor is not in the combination
(decoupling, Eq. 17 and 21).

Two ways to get the coefficients ``[beta_i, alpha_i]``:

* **indirect** (Eq. 1-25), from a known discrete model ``(A, B, C, D)``: the inverse
  model treats the uncertain sensors as inputs (Eq. 3-9), the stacked observability and
  Toeplitz matrices (Eq. 10-14) express a window of reference samples, and an interaction
  matrix (Eq. 15-18) together with a vector ``N_i`` (Eq. 21) eliminates the state and the
  other uncertain sensors. Eq. 17 and Eq. 21 are linear in the row vector
  ``w = [N_i^T, N_i^T C_s M_i]``, so every decoupled error function is a vector of the
  left null space of ``[[C_s A^p, C_s tau_j, D_j], [O, T_j, 0]]`` (``j != i``). That space
  is computed by SVD; the paper's own construction (Eq. 18 by pseudoinverse, then Eq. 21)
  is one of its vectors and is available as ``direction="paper"``.
* **direct** (Eq. 26-29), from healthy data only: the windows of the training data form
  ``W_NY`` (Eq. 28) and the coefficients lie in its (near-)left null space (Eq. 29).

Choosing the vector (``direction="sensitive"``, the default)
-------------------------------------------------------------
The null space is rarely one-dimensional. On noise-free data any vector works (Eq. 29's
remark), but on noisy, band-limited data the paper's choice (the smallest singular
vector) is poor: the excitation leaves no energy above its band, so high-pass
combinations of the *reference* sensors alone, or of sensor ``i``'s own samples alone,
are nearly null too. Their healthy output is tiny, but so is their response to an
in-band failure of sensor ``i`` (a zero reading or a gain change is as band-limited as
the signal): the smallest singular vector can be blind to the very sensor it examines.
The detector therefore picks the vector that maximizes the error function's response to
a failure of sensor ``i`` relative to its healthy variance::

    max_w  (w^T S w) / (w^T R w),   w in the candidate space

where ``R`` is the covariance of the (standardized) training windows plus a floor
``NOISE_FLOOR**2 * I`` (the resolution of a 20-bit converter, so noise-free simulated data
stay well posed) and ``S`` is the covariance of sensor ``i``'s own window embedded in
zeros (the response energy when sensor ``i`` is lost, or reads a scaled copy of the
truth). This generalized eigenproblem is a regularized canonical correlation between
sensor ``i``'s window and the rest; for the direct approach the candidate space is every
direction (directions with large singular values lose automatically), for the indirect
approach it is the model's exact decoupling null space. Either way the choice is made on
the training data only and does not depend on any failure.

Choosing the window (direct approach)
-------------------------------------
Eq. 19 counts samples. On a record sampled well above its modes its ``p`` spans a sliver
of their period, and the most sensitive function that short still carries part of the
structure's response, whose level wanders over seconds on a lightly damped structure:
the healthy residual then grows and shrinks with it, and reads as a gain on a healthy
sensor. The default ``p`` is therefore doubled, every doubling scored, up to the longest
that gained more sensitivity than averaging twice the samples could
(:meth:`ErrorFunction._direct_p`).

Units, alignment and vectorization
----------------------------------
``e_i`` is scaled to read in sensor ``i``'s units as ``measured - estimated``. Its
response to a gain change ``y_i -> g y_i`` is ``(g - 1)`` times the sensor seen through
the error function's own taps on it (:meth:`SensorFunction.sensor_view`); lag and scale
are fitted (least squares on the training data) so that this view is as close as possible
to ``y_i`` itself. The lag is the sample that plays "sensor ``i``'s current sample"
(``s_cur``); the share of ``y_i``'s variance the view matches is reported
(``unit_fit_r2``). The paper normalizes nothing, and a literal "coefficient of the current
sample = 1" fails: that coefficient (``-N_i^T C_s B_i``, Eq. 24) is a reference's one-step
response to the examined sensor, 3e-6 to 3e-3 of the largest coefficient in the paper's
example at 1 kHz. ``reference`` (the fault-free estimate handed to the shared classifier)
is the view minus the residual, i.e. what the references predict of it: a gain change
``g`` then gives ``residual = (g - 1) * reference`` exactly, so the classifier reads the
gain (0 for a dead sensor) even where the view differs from the raw sensor.

An error function passes a constant offset of its sensor with the gain ``dc_gain``
(reported), not 1: the unit fit matches the sensor's band, not its level. Offsets and
drift rates are therefore reported divided by it (:func:`_in_sensor_units`), so they read
in the sensor's units like every detector's. For accelerometers ``dc_gain`` is close to 0
(the relations among accelerations involve their differences in time): offsets move the
residual little, and are seen late or not at all.

The window also smears a fault's edges: the residual moves from ``p - s_cur`` samples
before a fault's onset to ``s_cur`` after it. The first alarm is dated by the newest
sample it read, and the onset and end of an offset or a gain by the fault whose response
through the taps fits the residual best (:func:`_in_sensor_time`), not by the first
samples the smear moved.

Each examined sensor's residual reads its references and inputs too: a fault on one of
them reaches it (``model["reach"]``, read by :func:`analyzer.detector_runs.coupled`, so
that one fault at a time holds for the findings).

Applying an error function is a sliding dot product, i.e. an FIR filter: it runs by
overlap-add convolution per channel (``scipy.signal.oaconvolve``), with windows that touch
a gap (NaN) set to NaN. Decisions use the shared path
:func:`analyzer.diagnosis.events.events_from_residual`.

Without a ``[[group]]`` in the config every channel is examined in turn with all the
others as references. Then the error function of one sensor uses every other sensor,
so a failed sensor also raises the others' error functions: isolation needs the groups.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt
from numpy.lib.stride_tricks import sliding_window_view
from scipy import linalg

from analyzer.detectors.base import Dataset, DetectorResult, Event, RunContext
from analyzer.detectors.decoupling import (
    decoupling_basis,
    decoupling_system,
    inverse_model,
    model_matrices,
    paper_coefficients,
    unmeasured_inputs,
)
from analyzer.diagnosis.changes import Calibration, calibrate, default_window
from analyzer.diagnosis.classify import MIN_GAIN, correlation_time
from analyzer.diagnosis.events import events_from_residual
from analyzer.errors import (
    ArchiveConfigError,
    ConfigError,
    DetectorError,
    TooLittleDataError,
)
from analyzer.stats.results import json_float
from analyzer.timeutil import seconds_text, spoken_duration
from analyzer.types import FaultType

FloatArray = npt.NDArray[np.float64]

APPROACHES = ("direct", "indirect")
DIRECTIONS = ("sensitive", "paper")

NOISE_FLOOR = 1e-6
"""Relative noise assumed on every standardized channel on top of the measured training
covariance (a 20-bit converter's resolution): regularizes the choice of the error
function on noise-free data, negligible on real data."""

P_FACTOR = 2
"""Default ``p`` is this many times the smallest ``p`` of Eq. 19 (the paper: "normally, p
is selected to be several times larger than the required number"). Where the data allow
it, larger windows buy little (the paper's example at 250 Hz, 1 % noise: sensor 1's
response to its loss is 11 healthy standard deviations at p = 20, 12.5 at p = 40) but
smear a failure's onset and end over the ``p + 1`` samples of the window; where they buy
much (a record sampled well above its modes), the direct approach doubles it
(:meth:`ErrorFunction._direct_p`)."""


SQRT2 = math.sqrt(2.0)
"""What doubling an error function's window gains at most in sensitivity when its
healthy residual is measurement noise (twice the samples averaged): :meth:`ErrorFunction.
_direct_p` doubles the direct approach's default ``p`` only while it gains more."""

MAX_COEFFICIENTS = 1000
"""A doubled window (:meth:`ErrorFunction._direct_p`) holds at most this many
coefficients (channels x (p + 1)): the covariance grows with their square and its
eigenproblem with their cube (5 channels: p up to 160; 32 channels: up to 30)."""

WINDOW_WORK = 4e9
"""Multiply-adds (windows x coefficients^2) a doubled window's covariance may cost before
it is read from every few windows only (:func:`_stride`): about a second."""

MIN_WINDOWS_PER_COEFFICIENT = 20
"""The stride of :func:`_stride` keeps at least this many windows per coefficient."""

WEAK_SENSITIVITY = 2.0
"""An error function whose response to the loss of its sensor is below this many healthy
standard deviations is reported as weak (a loss then raises the residual's RMS only about
twofold: easy to miss, hard to time)."""

_CHUNK = 4096
_RUN_CHUNK = 1 << 18


# --------------------------------------------------------------------------- groups


@dataclass(frozen=True, slots=True)
class Group:
    """Sensors analyzed together: ``uncertain`` are examined, ``reference`` trusted,
    ``inputs`` measured excitation channels (trusted, kept in every error function).
    ``explicit`` is False for the no-config default (one sensor uncertain at a time)."""

    name: str
    uncertain: tuple[str, ...]
    reference: tuple[str, ...]
    inputs: tuple[str, ...] = ()
    explicit: bool = True


def _names(value: Any, what: str) -> tuple[str, ...]:
    if value is None:
        return ()
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise ConfigError(f"{what}: expected a list of channel names, got {value!r}")
    return tuple(str(v) for v in value)


def resolve_groups(channels: Sequence[str], config: Mapping[str, Any]) -> list[Group]:
    """The groups to analyze. From ``[[group]]`` entries: ``uncertain`` defaults to the
    group's channels that are not ``reference`` and vice versa. Without groups: one group
    per channel, that channel uncertain and every other channel a reference."""
    raw = config.get("group", []) or []
    if isinstance(raw, Mapping):
        raw = [raw]
    chans = tuple(channels)
    if not raw:
        return [
            Group(f"{c}|rest", (c,), tuple(o for o in chans if o != c), (), explicit=False)
            for c in chans
        ]
    out: list[Group] = []
    seen: dict[str, str] = {}
    for k, g in enumerate(raw):
        name = str(g.get("name", f"group{k}"))
        members = _names(g.get("channels"), f"group {name!r} channels")
        ref = _names(g.get("reference"), f"group {name!r} reference")
        unc = _names(g.get("uncertain"), f"group {name!r} uncertain")
        inp = _names(g.get("inputs"), f"group {name!r} inputs")
        if not unc and not ref:
            raise ConfigError(
                f"group {name!r}: the error_function detector needs 'reference' or "
                f"'uncertain' sensors"
            )
        if not unc:
            unc = tuple(c for c in members if c not in ref and c not in inp)
        if not ref:
            ref = tuple(c for c in members if c not in unc and c not in inp)
        both = sorted(set(ref) & set(unc))
        if both:
            raise ConfigError(f"group {name!r}: {both} listed as both reference and uncertain")
        for c in (*unc, *ref, *inp):
            if c not in chans:
                raise ArchiveConfigError(
                    f"group {name!r}: channel {c!r} is not in the data (have {list(chans)})"
                )
        for c in unc:
            if c in seen:
                raise ConfigError(
                    f"channel {c!r} is uncertain in groups {seen[c]!r} and {name!r}; "
                    f"each sensor can be examined in one group only"
                )
            seen[c] = name
        if not unc or not ref:
            raise ConfigError(
                f"group {name!r}: needs at least one uncertain and one reference sensor "
                f"(uncertain={list(unc)}, reference={list(ref)})"
            )
        out.append(Group(name, unc, ref, inp, explicit=True))
    return out


# ------------------------------------------------------------------- conditions


def minimal_p(n: int, n_s: int, n_d: int) -> int:
    """Smallest window satisfying Eq. 19, ``p (n_s - n_d + 1) >= n - n_d + 1``."""
    return max(1, math.ceil((n - n_d + 1) / (n_s - n_d + 1)))


def check_conditions(
    *, n: int | None, n_s: int, n_d: int, r: int | None, p: int, approach: str, group: str = ""
) -> None:
    """The paper's necessary conditions, raising :class:`DetectorError` with the numbers:
    ``n_d >= r`` (Eq. 3, indirect only: the inverse model needs as many uncertain sensors
    as unmeasured inputs), ``n_s >= n_d`` and ``p (n_s - n_d + 1) >= n - n_d + 1``
    (Eq. 19; checked when the order ``n`` is known)."""
    where = f"group {group!r}: " if group else ""
    if approach == "indirect" and r is not None and n_d < r:
        raise DetectorError(
            f"{where}the inverse model (Li et al. 2007, Eq. 3) needs n_d >= r: "
            f"{n_d} uncertain sensor(s) < {r} unmeasured input(s)"
        )
    if n_s < n_d:
        raise DetectorError(
            f"{where}decoupling (Li et al. 2007, Eq. 19) needs n_s >= n_d: "
            f"{n_s} reference sensor(s) < {n_d} uncertain sensor(s)"
        )
    if p < 1:
        raise DetectorError(f"{where}window length p must be >= 1, got {p}")
    if n is not None and p * (n_s - n_d + 1) < n - n_d + 1:
        raise DetectorError(
            f"{where}Eq. 19 fails: p (n_s - n_d + 1) = {p} * {n_s - n_d + 1} = "
            f"{p * (n_s - n_d + 1)} < n - n_d + 1 = {n - n_d + 1} (n={n}); "
            f"use p >= {minimal_p(n, n_s, n_d)}"
        )


def _sees_unmeasured(
    g: Group, rows: Sequence[int], D: FloatArray, free: Sequence[int], inputs: Sequence[str]
) -> None:
    """Refuses an uncertain sensor that no unmeasured input reaches directly (its row of
    ``D_d``, the rows of the uncertain sensors and the columns of the unmeasured inputs,
    zero): the inverse model takes the uncertain sensors in only through ``D_d^+`` (Li et
    al. 2007, Eq. 3), whose column for that sensor is then zero, so no error function of
    the indirect approach could respond to it. The paper's square, invertible ``D_d``
    has no such row; it takes more uncertain sensors than unmeasured inputs (the chain
    with one of its two forces measured). A ``D_d`` without full column rank is left to
    :func:`~analyzer.detectors.decoupling.inverse_model`, which refuses it whole."""
    Dd = D[np.ix_(list(rows), list(free))]
    scale = float(np.max(np.abs(Dd))) if Dd.size else 0.0
    if not scale > 0.0 or np.linalg.matrix_rank(Dd / scale) < len(free):
        return
    for c, row in zip(g.uncertain, Dd, strict=True):
        if not np.any(np.abs(row) > 1e-12 * scale):
            names = ", ".join(inputs[k] or f"input {k + 1}" for k in free)
            raise DetectorError(
                f'[detectors.error_function] approach = "indirect": uncertain sensor {c!r} '
                f"of group {g.name!r} sees no unmeasured input of [model] directly ({names}: "
                f"zero in its row of D), so it does not enter the inverse model (Li et al. "
                f'2007, Eq. 3); use approach = "direct"'
            )


# ----------------------------------------------------------------- data windows


def _windows_gram(z: FloatArray, p: int, stride: int = 1) -> tuple[FloatArray, int]:
    """``(sum of outer products, count)`` of the complete windows of ``p + 1`` samples of
    the standardized data ``z`` (N, n_ch): the Gram matrix ``W_NY W_NY^T`` of Eq. 28 with
    one column per window (windows touching a NaN are left out). A window's vector is
    channel-major, ``c * (p + 1) + s`` with ``s = 0`` the oldest sample. Accumulated in
    chunks, so memory does not grow with the training length. ``stride``: only every
    ``stride``-th window is used (:func:`_stride`; 1, all of them, for Eq. 19's window)."""
    n_ch = z.shape[1]
    m = n_ch * (p + 1)
    gram = np.zeros((m, m))
    count = 0
    for a in range(0, z.shape[0] - p, _CHUNK):
        b = min(z.shape[0], a + _CHUNK + p)
        win = sliding_window_view(z[a:b], p + 1, axis=0)[(-a) % stride :: stride]
        win = win.reshape(-1, m)
        win = win[np.all(np.isfinite(win), axis=1)]
        gram += win.T @ win
        count += int(win.shape[0])
    return gram, count


def _stride(n_windows: int, m: int) -> int:
    """Every how many windows a doubled window's covariance (:meth:`ErrorFunction.
    _direct_p`) reads, so that it costs at most about ``WINDOW_WORK`` multiply-adds
    (windows x coefficients^2) while keeping at least ``MIN_WINDOWS_PER_COEFFICIENT``
    windows per coefficient: neighbouring windows share all but one sample, so a long
    training window read at a stride loses little."""
    by_work = math.ceil(n_windows * m * m / WINDOW_WORK)
    by_count = n_windows // (MIN_WINDOWS_PER_COEFFICIENT * m)
    return max(1, min(by_work, by_count))


def _select(S: FloatArray, R: FloatArray, basis: FloatArray) -> tuple[FloatArray, float]:
    """The combination ``w = basis @ c`` maximizing ``w^T S w / w^T R w`` (symmetric
    generalized eigenproblem, ``R`` positive definite on the basis); ``(w, ratio)``."""
    Sb = basis.T @ S @ basis
    Rb = basis.T @ R @ basis
    try:
        vals, vecs = linalg.eigh(0.5 * (Sb + Sb.T), 0.5 * (Rb + Rb.T))
    except (linalg.LinAlgError, ValueError) as err:
        raise DetectorError(
            f"the healthy-data covariance of the error-function candidates is singular or "
            f"not finite ({err})"
        ) from err
    return basis @ vecs[:, -1], float(vals[-1])


def _unit_fit(w_i: FloatArray, R_ii: FloatArray) -> tuple[int, float, float]:
    """Lag and scale that make the error function's response to a gain change of sensor
    ``i`` closest (least squares over the training covariance ``R_ii`` of its window) to
    ``(g - 1) y_i``; returns ``(s_cur, scale, r2)``: the step playing the sensor's current
    sample, the factor to sensor units and the share of the sensor's variance matched."""
    cross = R_ii @ w_i
    var_f = float(w_i @ R_ii @ w_i)
    if not var_f > 0.0:
        raise DetectorError(
            "the error function does not respond to its own sensor (its taps on the "
            "examined sensor are zero)"
        )
    corr = cross / np.sqrt(var_f * np.maximum(np.diag(R_ii), np.finfo(np.float64).tiny))
    s_cur = int(np.argmax(np.abs(corr)))
    return s_cur, float(cross[s_cur] / var_f), float(corr[s_cur] ** 2)


def apply_taps(values: FloatArray, taps: FloatArray, means: FloatArray, s_cur: int) -> FloatArray:
    """Residual series of one error function over ``values`` (N, n_ch): ``r(t) = sum_c
    sum_s taps[c, s] (y_c(t - s_cur + s) - mean_c)``, an FIR filter per channel run by
    overlap-add convolution. Outputs whose window is incomplete or touches a NaN are NaN."""
    from scipy import signal

    n = values.shape[0]
    p = taps.shape[1] - 1
    e = np.zeros(n + p)
    bad = np.zeros(n + p)
    for c in range(values.shape[1]):
        x = np.asarray(values[:, c], dtype=np.float64) - means[c]
        nan = ~np.isfinite(x)
        e += signal.oaconvolve(np.where(nan, 0.0, x), taps[c, ::-1], mode="full")
        if nan.any():
            bad += signal.oaconvolve(nan.astype(np.float64), np.ones(p + 1), mode="full")
    out = np.full(n, np.nan)
    # e[k] (k >= p) is the window ending at sample k; the residual at t is the window
    # ending at t + (p - s_cur)
    ends = np.arange(max(p, p - s_cur), min(n, n + p - s_cur))
    if ends.size:
        t = ends - (p - s_cur)
        out[t] = np.where(bad[ends] > 0.5, np.nan, e[ends])
    return out


# ------------------------------------------------------------------ fitted model


@dataclass(frozen=True, slots=True)
class SensorFunction:
    """The fitted error function of one uncertain sensor (``channels[0]``): its residual
    ``apply_taps(values[:, channels], taps, means, s_cur)`` is in the sensor's units, and
    ``calibration`` holds its healthy statistics."""

    channel: str
    group: str
    channels: tuple[str, ...]
    taps: FloatArray
    means: FloatArray
    s_cur: int
    calibration: Calibration
    tau_corr: float
    summary: dict[str, Any] = field(default_factory=dict)

    @property
    def p(self) -> int:
        return int(self.taps.shape[1] - 1)

    def residual(self, values: FloatArray) -> FloatArray:
        """The error function over ``values`` (N, len(channels)), in sensor units."""
        return apply_taps(values, self.taps, self.means, self.s_cur)

    @property
    def dc_gain(self) -> float:
        """What the residual reads for a unit offset of the examined sensor: the sum of
        its taps on that sensor (an offset ``D`` reads ``D * dc_gain``, a drift of rate
        ``b`` as a slope ``b * dc_gain``)."""
        return float(np.sum(self.taps[0]))

    def sensor_view(self, y: FloatArray) -> FloatArray:
        """The examined sensor as its error function sees it: its own taps applied to
        ``y`` (plus the DC they pass). For a gain change ``y -> g y`` the residual is
        ``(g - 1)`` times the fault-free value of this view, so ``view - residual`` is the
        fault-free estimate handed to the classifier (``reference``); ``unit_fit_r2``
        says how close the view is to the raw sensor."""
        dc = self.dc_gain
        view = apply_taps(
            np.asarray(y, dtype=np.float64)[:, None], self.taps[:1], self.means[:1], self.s_cur
        )
        return view + dc * float(self.means[0])


@dataclass(frozen=True, slots=True)
class ErrorFunctionModel:
    """What :meth:`ErrorFunction.fit` learns: one error function per uncertain sensor."""

    approach: str
    direction: str
    window: int
    functions: tuple[SensorFunction, ...]
    notes: tuple[str, ...] = ()
    isolating: bool = True
    """False without ``[[group]]``: each sensor was examined against all the others, so
    one failed sensor disturbs every error function that uses it as a reference."""

    @property
    def p(self) -> int:
        return max((f.p for f in self.functions), default=0)


# ---------------------------------------------------------------------- detector


class ErrorFunction:
    """Sensor failure detection by decoupled error functions (Li, Koh & Nagarajaiah 2007).

    Settings (``[detectors.error_function]``):

    * ``approach``: ``"direct"`` (coefficients from healthy data, Eq. 26-29) or
      ``"indirect"`` (from ``[model]``, Eq. 1-25).
    * ``p``: window length in samples. Default: ``P_FACTOR`` times the smallest ``p`` of
      Eq. 19, with the model's order ``n`` (or, without ``[model]``, ``n = 2 x`` the
      group's sensors: one second-order degree of freedom per sensor); the direct
      approach doubles it, up to the detection window, to the longest window whose own
      doubling raised the function's sensitivity more than ``sqrt(2)`` (:meth:`_direct_p`).
    * ``l``: training samples (from the start of the training window) used for the
      direct SVD (default: the whole training window).
    * ``direction``: ``"sensitive"`` (default, see the module docstring) or ``"paper"``
      (Eq. 29's smallest singular vector; Eq. 18 then Eq. 21 for the indirect approach).
    * ``window``: detection window in samples (default
      :func:`~analyzer.diagnosis.changes.default_window`). The shared detector also
      watches ``8 x window``: failures of one sensor closer together than that (the
      paper's are 2 s apart, the default long window is 2 s) are reported as one.

    Groups come from ``[[group]]`` (``reference``, ``uncertain``, ``inputs``); without
    groups every channel is examined in turn against all the others (no isolation).
    """

    name: ClassVar[str] = "error_function"

    def __init__(
        self,
        approach: str = "direct",
        p: int | None = None,
        l: int | None = None,  # noqa: E741 - the paper's name
        direction: str = "sensitive",
        window: int | None = None,
    ) -> None:
        if approach not in APPROACHES:
            raise ConfigError(
                f"[detectors.error_function] approach: expected one of {list(APPROACHES)}, "
                f"got {approach!r}"
            )
        if direction not in DIRECTIONS:
            raise ConfigError(
                f"[detectors.error_function] direction: expected one of {list(DIRECTIONS)}, "
                f"got {direction!r}"
            )
        for key, val in (("p", p), ("l", l), ("window", window)):
            if val is not None and (isinstance(val, bool) or not isinstance(val, int) or val < 1):
                raise ConfigError(
                    f"[detectors.error_function] {key}: expected a positive integer, got {val!r}"
                )
        self.approach = approach
        self.p = p
        self.l = l
        self.direction = direction
        self.window = window

    # ---------------------------------------------------------------- checks

    def applicable(self, data: Dataset, context: RunContext) -> str | None:
        try:
            self._check(data, context)
        except (ConfigError, DetectorError) as err:
            return str(err)
        if not context.explicit and not context.config.get("group"):
            # without reference/uncertain groups every error function involves every
            # sensor: it detects but cannot isolate, so it runs only when asked for
            return (
                "needs [[group]] reference/uncertain sensors in the config to isolate "
                "faults (or --detectors error_function to run it on every sensor in turn)"
            )
        return None

    def _check(self, data: Dataset, context: RunContext) -> list[Group]:
        """The groups to analyze; raises when the detector's needs are not met (cheap:
        no data is read)."""
        if len(data.channels) < 2:
            raise DetectorError(
                f"needs at least 2 channels (one examined, one reference), got {len(data.channels)}"
            )
        if self.approach == "indirect" and not context.config.get("model"):
            raise DetectorError("approach 'indirect' needs a [model] (A, B, C, D) in the config")
        groups = resolve_groups(data.channels, context.config)
        if self.approach == "indirect":
            A, B, _, D, outputs, inputs = model_matrices(context.config["model"])
            for g in groups:
                unc, _, meas = self._model_rows(g, outputs, inputs)
                free = unmeasured_inputs(B.shape[1], meas)
                if not free:
                    # the uncertain sensors would not enter the inverse model (Eq. 3-8)
                    measured = ", ".join(inputs[c] for c in meas)
                    why = (
                        f"group {g.name!r} measures every input: {measured}"
                        if meas
                        else "the model has no input"
                    )
                    raise ConfigError(
                        f'[detectors.error_function] approach = "indirect" needs at least '
                        f"one unmeasured input in [model] ({why}); use approach = "
                        f'"direct"'
                    )
                check_conditions(
                    n=A.shape[0],
                    n_s=len(g.reference),
                    n_d=len(g.uncertain),
                    r=B.shape[1] - len(meas),
                    p=self._p_for(g, A.shape[0]),
                    approach="indirect",
                    group=g.name,
                )
                _sees_unmeasured(g, unc, D, free, inputs)
        return groups

    def _p_for(self, g: Group, n: int | None) -> int:
        if self.p is not None:
            return self.p
        n_eff = n if n is not None else 2 * (len(g.uncertain) + len(g.reference))
        n_d, n_s = len(g.uncertain), len(g.reference)
        if n_s < n_d:
            return 1  # check_conditions reports the real problem
        return P_FACTOR * minimal_p(n_eff, n_s, n_d)

    @staticmethod
    def _model_rows(
        g: Group, outputs: list[str], inputs: list[str]
    ) -> tuple[list[int], list[int], list[int]]:
        for c in (*g.uncertain, *g.reference):
            if c not in outputs:
                raise DetectorError(
                    f"group {g.name!r}: channel {c!r} is not an output of [model] "
                    f"(outputs: {outputs})"
                )
        for c in g.inputs:
            if c not in inputs:
                raise DetectorError(
                    f"group {g.name!r}: input {c!r} is not an input of [model] (inputs: {inputs})"
                )
        return (
            [outputs.index(c) for c in g.uncertain],
            [outputs.index(c) for c in g.reference],
            [inputs.index(c) for c in g.inputs],
        )

    # ------------------------------------------------------------------- fit

    def fit(self, data: Dataset, context: RunContext) -> ErrorFunctionModel:
        """Coefficients and healthy calibration of every uncertain sensor's error
        function, from ``data.train_values()`` only."""
        groups = self._check(data, context)
        train = np.asarray(data.train_values(), dtype=np.float64)
        window = self.window if self.window is not None else default_window(data.rate_hz)
        model_cfg = context.config.get("model") if self.approach == "indirect" else None
        if model_cfg is not None and model_cfg.get("dt") is not None:
            dt = float(model_cfg["dt"])
            if not math.isclose(dt, 1.0 / data.rate_hz, rel_tol=1e-6):
                raise DetectorError(
                    f"[model] dt = {dt:g} s does not match the data's sample time "
                    f"{1.0 / data.rate_hz:g} s (rate {data.rate_hz:g} Hz)"
                )
        functions: list[SensorFunction] = []
        notes: list[str] = []
        for g in groups:
            names = [*g.uncertain, *g.reference, *g.inputs]
            stats = _channel_stats(train[:, [data.index(c) for c in names]], names)
            for k, ch in enumerate(g.uncertain):
                chans = [ch, *g.inputs, *g.reference]
                mean = np.array([stats[c][0] for c in chans])
                std = np.array([stats[c][1] for c in chans])
                z = (train[:, [data.index(c) for c in chans]] - mean) / std
                held_out = None
                if self.approach == "indirect":
                    w_std, cov, summary = self._indirect(g, k, z, std, context)
                else:
                    p, tried = self._direct_p(g, z, window, context)
                    w_std, cov, summary = self._direct(g, ch, z, context, p)
                    held_out = self._held_out(g, ch, z, std, chans, mean, data, context, p)
                    held = held_out is not None
                    summary["calibration"] = "out-of-sample" if held else "in-sample"
                    if tried:
                        summary["p_tried"] = [{"p": q, "sensitivity": v} for q, v in tried]
                f = self._finish(
                    ch, g, chans, w_std, cov, mean, std, data, context, window, summary, held_out
                )
                if f.summary["sensitivity"] < WEAK_SENSITIVITY:
                    notes.append(
                        f"{ch}: weak error function (losing the sensor moves its residual "
                        f"by only {f.summary['sensitivity']:.2g} healthy standard "
                        f"deviations): the references carry little information about it"
                    )
                functions.append(f)
        isolating = any(g.explicit for g in groups)
        if not isolating:
            notes.append(
                "no [[group]] configured: each sensor was examined with all the others as "
                "references, so a failed sensor also disturbs the others' error functions "
                "(no isolation)"
            )
        return ErrorFunctionModel(
            self.approach, self.direction, window, tuple(functions), tuple(notes), isolating
        )

    def _direct_p(
        self, g: Group, z: FloatArray, window: int, context: RunContext
    ) -> tuple[int, list[tuple[int, float]]]:
        """The direct approach's window for the examined sensor (column 0 of ``z``) and
        the sensitivities tried, ``[(p, sensitivity), ...]`` (empty when none was).

        Eq. 19's ``p`` counts samples, not seconds: on a record sampled well above its
        modes, ``P_FACTOR`` times it spans a sliver of their period (11 samples, 55 ms, of
        a 1 Hz building's at 200 Hz), and a function that short cannot tell the sensor
        from its references without amplifying their noise, so the sensitive choice
        leaves part of the structure's response in it. That part follows the response's
        level, which wanders over seconds on a lightly damped structure: on the bundled
        additive sample s3's function read 0.78 on its training window (0.63 of it the
        response, 0.45 the noise) and up to 1.38 from 20 to 36 s, where the building
        swung three times as hard, a false gain of 1.20 on the healthy s3 (the fault on
        s4 plays no part: s4 is in no other function).

        So ``p`` is doubled from that default where doubling raises the function's
        sensitivity (its response to the loss of its sensor, in healthy standard
        deviations) more than ``sqrt(2)``: a residual that is measurement noise gains at
        most that from twice the samples (what the detector's own averaging also gives),
        so more means the shorter function was leaking the response. Doubling stops at
        the detection window (``window``: a longer function smears a fault beyond what
        the detector times) and where either half of the training window would hold too
        few windows for the out-of-sample calibration (:meth:`_held_out`). On that
        sample 10 -> 40 (sensitivity 2.1 -> 17); the paper's chain keeps its 14 (10.3 at
        14, 11.0 at 28). Every candidate is scored and the longest whose own doubling
        gained more than ``sqrt(2)`` is kept: the gain is not even (5 floors at 1000 Hz:
        1.75, 1.83, 2.79, 12.8, 50.2 at p = 10 ... 160, flat before it takes off), so
        stopping at the first doubling that gains less would keep 10. The candidates are
        grown one at a time up to ``MAX_COEFFICIENTS``, and a doubled window's covariance
        is read at a stride on a long training window (:func:`_stride`), so the search
        costs a few of Eq. 19's fits, not one of the longest window's. Skipped when the config sets
        ``p`` or ``direction = "paper"`` (no sensitivity to compare)."""
        model = context.config.get("model")
        n_model = int(model_matrices(model)[0].shape[0]) if model else None
        p0 = self._p_for(g, n_model)
        if self.p is not None or self.direction != "sensitive":
            return p0, []
        used = z if self.l is None else z[: self.l]
        n_ch = z.shape[1]
        rows = min(z.shape[0] // 2, used.shape[0])  # the halves of _held_out

        def fits(p: int) -> bool:
            return p <= window and n_ch * (p + 1) <= MAX_COEFFICIENTS and rows - p > n_ch * (p + 1)

        candidates = [p0]
        while fits(2 * candidates[-1]):
            candidates.append(2 * candidates[-1])
        if len(candidates) == 1:
            return p0, []
        chosen = p0
        tried: list[tuple[int, float]] = []
        for p in candidates:  # grown one at a time: the cost follows what is scored
            m = n_ch * (p + 1)
            gram, n_win = _windows_gram(used, p, _stride(used.shape[0] - p, m))
            if n_win <= m:
                break
            cov = gram / n_win
            S = np.zeros_like(cov)
            S[: p + 1, : p + 1] = cov[: p + 1, : p + 1]
            try:
                _, ratio = _select(S, cov + NOISE_FLOOR**2 * np.eye(m), np.eye(m))
            except DetectorError:
                break
            sens = float(np.sqrt(max(ratio, 0.0)))
            if tried and sens > SQRT2 * tried[-1][1]:
                chosen = p  # the longest window whose own doubling gained more than sqrt(2)
            tried.append((p, sens))
        if len(tried) < 2:
            return p0, []
        return chosen, tried

    def _direct(
        self, g: Group, channel: str, z: FloatArray, context: RunContext, p: int | None = None
    ) -> tuple[FloatArray, FloatArray, dict[str, Any]]:
        """Eq. 26-29 for the examined sensor (column 0 of the standardized training data
        ``z``): ``W_NY`` from its windows, SVD, choice of the left null vector. The window
        holds ``p + 1`` samples of every channel; Eq. 26 leaves out the examined sensor's
        newest sample because in the paper's example no reference sees the input
        directly, and then its coefficient simply comes out near zero. ``p``: the
        window (:meth:`_direct_p`); None for the default of Eq. 19."""
        model = context.config.get("model")
        n_model = int(model_matrices(model)[0].shape[0]) if model else None
        p0 = self._p_for(g, n_model)
        p = p0 if p is None else p
        check_conditions(
            n=n_model,
            n_s=len(g.reference),
            n_d=len(g.uncertain),
            r=None,
            p=p,
            approach="direct",
            group=g.name,
        )
        used = z if self.l is None else z[: self.l]
        m = z.shape[1] * (p + 1)
        # a window doubled by _direct_p reads its covariance at a stride on long records
        stride = 1 if p == p0 or self.p is not None else _stride(used.shape[0] - p, m)
        gram, n_win = _windows_gram(used, p, stride)
        if n_win <= m:
            raise DetectorError(
                f"{channel}: too little training "
                f"data for the SVD of W_NY (Li et al. 2007, Eq. 28-29): {n_win} complete windows "
                f"of p + 1 = {p + 1} samples for {m} coefficients ({z.shape[1]} channels); "
                f"need more than {m} windows (a longer training window, or a smaller p)"
            )
        cov = gram / n_win
        evals, evecs = np.linalg.eigh(0.5 * (cov + cov.T))
        sv = np.sqrt(np.maximum(evals, 0.0) * n_win)  # singular values of W_NY, ascending
        if self.direction == "paper":
            w_std = evecs[:, 0]
            ratio = math.nan
        else:
            S = np.zeros_like(cov)
            S[: p + 1, : p + 1] = cov[: p + 1, : p + 1]
            w_std, ratio = _select(S, cov + NOISE_FLOOR**2 * np.eye(m), np.eye(m))
        w_sv = float(np.sqrt(max(w_std @ gram @ w_std, 0.0) / (w_std @ w_std)))
        summary: dict[str, Any] = {
            "approach": "direct",
            "direction": self.direction,
            "p": p,
            "l": n_win + p,
            "coefficients": m,
            "singular_values_smallest": [float(v) for v in sv[: min(m, 2 * (p + 1))]],
            "singular_value_largest": float(sv[-1]),
            "selected_singular_value": w_sv,
            "condition_number": json_float(sv[-1] / sv[0]) if sv[0] > 0 else None,
            "response_ratio": json_float(ratio),
        }
        return w_std, cov, summary

    def _held_out(
        self,
        g: Group,
        channel: str,
        z: FloatArray,
        std: FloatArray,
        chans: list[str],
        mean: FloatArray,
        data: Dataset,
        context: RunContext,
        p: int | None = None,
    ) -> FloatArray | None:
        """The training residual of the direct approach out of sample: the error function
        (window ``p``, as the whole window's) fitted on each half of the training window
        (:meth:`_direct`, :func:`_unit_fit`) and applied to the other half (None when a
        half is too short for the SVD).

        The direct approach chooses the direction of least variance of the training
        windows themselves, so its residual there is smaller than on any other data: on
        the bundled gain sample with the contract's example config (12 s of training at
        200 Hz) the thresholds calibrated in sample gave a false ``other`` finding on the
        healthy s3 right after the window, four with a 10 s window. The bank calibrates
        out of sample for the same reason (5-fold)."""
        n = z.shape[0]
        half = n // 2
        p_rows = slice(0, half), slice(half, n)
        out = np.full(n, np.nan)
        idx = [data.index(c) for c in chans]
        values = np.asarray(data.train_values(), dtype=np.float64)[:, idx]
        for fit_rows, test_rows in (p_rows, p_rows[::-1]):
            try:
                w, cov, summary = self._direct(g, channel, z[fit_rows], context, p)
            except DetectorError:
                return None
            p = int(summary["p"])
            sl = slice(0, p + 1)
            s_cur, scale, _ = _unit_fit(w[sl], cov[sl, sl])
            taps = (w * scale * std[0]).reshape(len(chans), p + 1) / std[:, None]
            out[test_rows] = apply_taps(values[test_rows], taps, mean, s_cur)
        return out

    def _indirect(
        self, g: Group, i: int, z: FloatArray, std: FloatArray, context: RunContext
    ) -> tuple[FloatArray, FloatArray, dict[str, Any]]:
        """Eq. 1-25 for uncertain sensor ``i`` of ``g``: inverse model, stacked matrices,
        decoupled null space (or the paper's Eq. 18 and 21), choice on the training data
        ``z`` (standardized; ``std`` converts physical taps to standardized ones)."""
        A, B, C, D, outputs, inputs = model_matrices(context.config["model"])
        unc, ref, meas = self._model_rows(g, outputs, inputs)
        p = self._p_for(g, A.shape[0])
        inv = inverse_model(A, B, C, D, unc, ref, meas)
        gram, n_win = _windows_gram(z, p)
        if n_win < 1:
            raise DetectorError(
                f"{g.uncertain[i]}: the training window ({z.shape[0]} samples) is shorter "
                f"than one error-function window (p + 1 = {p + 1})"
            )
        cov = gram / n_win
        m = cov.shape[0]
        to_std = np.repeat(std, p + 1)  # taps on standardized data = physical taps * std
        n_ref = len(ref)
        summary: dict[str, Any] = {
            "approach": "indirect",
            "direction": self.direction,
            "p": p,
            "n": int(A.shape[0]),
            "cond_Dd": json_float(inv.cond_Dd),
        }
        if self.direction == "paper":
            w, info = paper_coefficients(inv, p, i)
            _, F, _ = decoupling_system(inv, p, i)
            w_std = (F @ w) * to_std
            summary.update(info)
            summary["response_ratio"] = None
        else:
            basis, F, info = decoupling_basis(inv, p, i, std[-n_ref:])
            S = np.zeros_like(cov)
            S[: p + 1, : p + 1] = cov[: p + 1, : p + 1]
            w_std, ratio = _select(
                S, cov + NOISE_FLOOR**2 * np.eye(m), (F @ basis) * to_std[:, None]
            )
            summary.update(info)
            summary["response_ratio"] = json_float(ratio)
        return w_std, cov, summary

    def _finish(
        self,
        channel: str,
        g: Group,
        chans: list[str],
        w_std: FloatArray,
        cov: FloatArray,
        mean: FloatArray,
        std: FloatArray,
        data: Dataset,
        context: RunContext,
        window: int,
        summary: dict[str, Any],
        held_out: FloatArray | None = None,
    ) -> SensorFunction:
        """Sensor units and alignment (:func:`_unit_fit`), healthy calibration on the
        training residual (``held_out``: out of sample, :meth:`_held_out`), summary."""
        p = int(summary["p"])
        sl = slice(0, p + 1)  # the examined sensor is the first window channel
        s_cur, scale, r2 = _unit_fit(w_std[sl], cov[sl, sl])
        taps = (w_std * scale * std[0]).reshape(len(chans), p + 1) / std[:, None]
        idx = [data.index(c) for c in chans]
        resid = apply_taps(np.asarray(data.train_values()[:, idx]), taps, mean, s_cur)
        healthy = float(w_std @ cov @ w_std) + NOISE_FLOOR**2 * float(w_std @ w_std)
        lost = float(w_std[sl] @ cov[sl, sl] @ w_std[sl])
        # Data are trusted to NOISE_FLOOR of each channel's spread: a healthy residual
        # below what that resolution propagates to (noise-free simulation, duplicated
        # channels) is calibrated as if it carried that resolution noise, so thresholds
        # and change points stay finite and meaningful.
        floor = NOISE_FLOOR * abs(scale) * float(std[0]) * float(np.linalg.norm(w_std))
        if held_out is not None and int(np.isfinite(held_out).sum()) >= 4 * 8 * window:
            resid = held_out
        ok = np.isfinite(resid)
        spread = float(np.std(resid[ok])) if ok.any() else 0.0
        cal_resid = resid
        if spread < floor:
            dither = np.random.default_rng(0).standard_normal(resid.shape[0]) * floor
            cal_resid = resid + dither
        try:
            cal = calibrate(cal_resid, window, context.false_alarm_rate)
        except TooLittleDataError as err:  # (its numbers kept: the run's hint reads them)
            raise TooLittleDataError(f"{channel}: {err}", err.have, err.need) from err
        except DetectorError as err:
            raise DetectorError(f"{channel}: {err}") from err
        summary.update(
            {
                "group": g.name,
                "channels": list(chans),
                "s_cur": s_cur,
                "unit_fit_r2": r2,
                "sensitivity": float(np.sqrt(lost / healthy)),
                "dc_gain": float(np.sum(taps[0])),
                "resolution_floor": floor,
                "floor_used": bool(spread < floor),
            }
        )
        return SensorFunction(
            channel,
            g.name,
            tuple(chans),
            taps,
            mean,
            s_cur,
            cal,
            correlation_time(cal_resid),
            summary,
        )

    # ------------------------------------------------------------------- run

    def run(self, model: ErrorFunctionModel, data: Dataset, context: RunContext) -> DetectorResult:
        """Error functions over the whole archive, then events per examined sensor by the
        shared path (:func:`~analyzer.diagnosis.events.events_from_residual`)."""
        residuals: dict[str, FloatArray] = {}
        reference: dict[str, FloatArray] = {}
        sigma: dict[str, float] = {}
        thresholds: dict[str, Any] = {}
        events: list[Event] = []
        sensors: dict[str, Any] = {}
        unweighed: list[str] = []  # notes on alarms too thin to weigh (no events)
        for k, f in enumerate(model.functions):
            missing = [c for c in f.channels if c not in data.channels]
            if missing:
                raise DetectorError(
                    f"error_function of {f.channel!r} needs channel(s) {missing}, "
                    f"absent from the data"
                )
            r, ref = _residual_and_reference(f, data, context, k)
            residuals[f.channel] = r
            reference[f.channel] = ref
            sigma[f.channel] = f.calibration.std
            thresholds[f.channel] = f.calibration.as_dict()
            sensors[f.channel] = dict(f.summary)
            found = events_from_residual(
                f.channel,
                r,
                ref,
                f.calibration,
                data.rate_hz,
                self.name,
                search_start=data.search_start,
                healthy_start=data.healthy_start,
                healthy_stop=data.train[1],
                before_onset=not data.healthy,
                tau_corr=f.tau_corr,
                evidence={"group": f.group, "references": list(f.channels[1:])},
                scratch=context.workdir if context.map_outputs else None,
                notes=unweighed,
            )
            y = data.values[:, data.index(f.channel)]
            for ev in found:
                _in_sensor_time(ev, f, r, y, data.rate_hz, data.search_start)
                _in_sensor_units(ev, f)
            events.extend(found)
            context.report(
                f"error functions {k + 1}/{len(model.functions)}", (k + 1) / len(model.functions)
            )
        notes = [*model.notes, *unweighed]
        unattributed: list[tuple[float, tuple[str, ...], tuple[str, ...]]] = []
        if model.functions:
            span = model.functions[0].calibration.long_window / data.rate_hz
            if not model.isolating:
                events = _one_per_fault(events, span, notes)
            else:
                events = _all_at_once(events, model.functions, span, notes, unattributed)
        params = {
            "approach": model.approach,
            "p": model.p,
            "l": self.l,
            "direction": model.direction,
            "window": model.window,
        }
        return DetectorResult(
            detector=self.name,
            channels=tuple(f.channel for f in model.functions),
            params=params,
            events=events,
            residuals=residuals,
            reference=reference,
            sigma=sigma,
            thresholds=thresholds,
            model={
                "approach": model.approach,
                "p": model.p,
                "sensors": sensors,
                # the channels whose readings enter each error function: a fault on any
                # of them reaches it (detector_runs.coupled)
                "reach": {f.channel: list(f.channels) for f in model.functions},
            },
            notes=notes,
            unattributed=unattributed,
        )


def _first_alarm(e: Event) -> float:
    return float(e.evidence.get("first_alarm_s", e.onset_s))


def _all_at_once(
    events: list[Event],
    functions: Sequence[SensorFunction],
    span_s: float,
    notes: list[str],
    unattributed: list[tuple[float, tuple[str, ...], tuple[str, ...]]],
) -> list[Event]:
    """With ``[[group]]``: the events of a group's uncertain sensors when every one of
    them begins to alarm within ``span_s`` of the first and every one ends within
    ``span_s`` of the others (or all last to the end). A failure of one uncertain sensor
    raises its own error function only (the others are decoupled from it: Eq. 17 and
    21), so every function of the group at once, from start to end, is no single
    uncertain sensor's fault: a reference sensor's, all the uncertain ones at once (a
    shared acquisition unit), or a change of the structure or excitation that the
    training window did not hold. Those events are dropped, and each such anomaly is
    returned in ``unattributed`` (at its earliest onset) with a note, as the other
    detectors leave such alarms. An event that outlasts the others (a lasting fault
    beside another function's transient) keeps the cluster as it was. A group with one
    uncertain sensor has nothing to compare: its events stay."""

    def together(near: list[Event]) -> bool:
        ends = [e.end_s for e in near if e.end_s is not None]
        if len(ends) < len(near):  # all last to the end, or one outlasts the others
            return not ends
        return max(ends) - min(ends) <= span_s

    # a group's functions share its references (two groups of one name stay apart)
    members: dict[tuple[str, tuple[str, ...]], set[str]] = {}
    for f in functions:
        members.setdefault((f.group, tuple(sorted(f.channels[1:]))), set()).add(f.channel)
    dropped: set[int] = set()
    for (group, _), sensors in members.items():
        if len(sensors) < 2:
            continue
        mine = sorted((e for e in events if e.channel in sensors), key=_first_alarm)
        k = 0
        while k < len(mine):
            t0 = _first_alarm(mine[k])
            near = [e for e in mine[k:] if _first_alarm(e) <= t0 + span_s]
            if {e.channel for e in near} == sensors and together(near):
                dropped.update(id(e) for e in near)
                names = tuple(sorted(sensors))
                onset = min(e.onset_s for e in near)
                unattributed.append((onset, names, ()))
                notes.append(
                    f"alarms from {seconds_text(onset)} s on every uncertain sensor of group "
                    f"{group!r} ({', '.join(names)}), beginning within {spoken_duration(span_s)} "
                    "and ending together: not attributed (a failure of one uncertain sensor "
                    "raises its own error function only; all of them at once is a reference "
                    "sensor, the uncertain sensors failing together, or a change of the structure "
                    "or excitation)"
                )
                k += len(near)
            else:
                k += 1
    return [e for e in events if id(e) not in dropped]


UNISOLATED_FACTOR = 0.5
"""Confidence factor of a fault the error functions saw without ``[[group]]``: which
sensor failed is a best guess (the strongest alarm), not an isolation."""


def _one_per_fault(events: list[Event], span_s: float, notes: list[str]) -> list[Event]:
    """Without groups, alarms of several sensors' error functions that start within
    ``span_s`` of each other are one physical fault (the failed sensor is a reference of
    every other function): one event, on the sensor whose alarm is the strongest, with
    the others as candidates and a lower confidence."""

    out: list[Event] = []
    pending = sorted(events, key=_first_alarm)
    while pending:
        t0 = _first_alarm(pending[0])
        group = [e for e in pending if _first_alarm(e) <= t0 + span_s]
        best = max(group, key=lambda e: float(e.evidence.get("peak_over_threshold", 0.0)))
        if len(group) > 1:
            others = sorted({e.channel for e in group} - {best.channel})
            best.evidence["isolated"] = False
            best.evidence["candidates"] = sorted({e.channel for e in group})
            best.confidence *= UNISOLATED_FACTOR
            notes.append(
                f"alarms near {seconds_text(t0)} s on {best.channel} and {', '.join(others)}: "
                f"reported once, on the strongest ({best.channel}); without [[group]] the error "
                "functions cannot tell which sensor failed"
            )
        # while that fault lasts, every function that uses the sensor may alarm later
        # (a growing disturbance): the same fault, as far as these functions can tell
        until = np.inf if best.end_s is None else best.end_s
        later = [e for e in pending if t0 + span_s < _first_alarm(e) < until]
        pending = [e for e in pending if _first_alarm(e) > t0 + span_s and _first_alarm(e) >= until]
        for e in later:
            notes.append(
                f"alarm on {e.channel} at {seconds_text(_first_alarm(e))} s, during the fault "
                f"reported on {best.channel}: taken as its effect (without [[group]] the error "
                "functions cannot tell a second failure from it)"
            )
        out.append(best)
    return out


DC_VISIBLE = 1e-6
"""An error function whose taps on its sensor sum to less than this share of their
absolute sum passes no offset (a pure difference in time): its offsets and drift rates
are left as its residual reads them, not divided by that sum (:func:`_in_sensor_units`)."""


def _in_sensor_units(ev: Event, f: SensorFunction) -> None:
    """``ev``'s offset and drift rate in the sensor's units: the residual reads an offset
    ``D`` of the sensor as ``D * dc_gain`` and a drift ``b t`` as ``b * dc_gain * t`` (the
    taps' response at frequency 0), where the unit fit (:func:`_unit_fit`) made the taps
    read the sensor's *band* in its units, not its level. An offset of 2.427 on a floor
    sensor of a 3-floor building read 3.136 at p = 50 (taps summing to 1.30) and 0.0146
    for 0.802 on an accelerometer of the paper's chain (taps summing to 0.018). A gain
    (the residual over the reference, both seen through the same taps) and the ``rms``
    of an ``other`` fault are left as they are. The residual's own reading is kept in
    the evidence (``residual_magnitude``)."""
    dc = f.dc_gain
    if not abs(dc) > DC_VISIBLE * float(np.sum(np.abs(f.taps[0]))):
        return
    scaled = {k: v / dc for k, v in ev.magnitude.items() if k in ("offset", "rate_per_s")}
    if scaled:
        ev.evidence["residual_magnitude"] = dict(ev.magnitude)
        ev.evidence["dc_gain"] = dc
        ev.magnitude = {**ev.magnitude, **scaled}


EDGE_BLOCK = 256
"""Candidate onsets (or ends) fitted at a time by :func:`_edge_fit`."""


def _in_sensor_time(
    ev: Event, f: SensorFunction, r: FloatArray, y: FloatArray, rate_hz: float, start: int
) -> None:
    """``ev``'s first alarm, onset and end as the sensor saw them, not as the error
    function's window smears them.

    The residual at ``t`` reads the sensor from ``t - s_cur`` to ``t + p - s_cur``: a
    fault from ``t0`` moves it from ``t0 - (p - s_cur)`` on, and reaches its full size
    only at ``t0 + s_cur``. The shared change-point search (:func:`~analyzer.diagnosis.
    changes.change_point`) takes the first samples that moved: a strong fault's onset
    came out up to ``p - s_cur`` samples early (an offset from 100.00 s on a building's
    floor sensor at 99.82 s with p = 50), and it then led the merged finding for alarming
    first. So:

    * the first alarm is moved to when its newest sample was read (``+ p - s_cur``);
    * the onset and end of an offset or a gain are those whose response through the
      sensor's taps fits the residual best (:func:`_edge_fit`): the fault signal is
      known up to its size (a constant; the reading ``y`` times ``1 - 1/g``), so its
      response to a fault from each candidate ``t0`` is too;
    * a drift keeps the onset its line was traced back to (the taps delay a slope by
      their centroid less ``s_cur``, a fraction of a sample), as do faults without a
      shape (``other``) and dead sensors (gain near 0: the reading no longer carries the
      fault signal); an onset in the healthy window's end (traced into it, or present
      when the search began) stays where it is."""
    p, s_cur = f.p, f.s_cur
    ahead = p - s_cur
    alarm = int(round(float(ev.evidence.get("first_alarm_s", ev.onset_s)) * rate_hz)) + ahead
    if "first_alarm_s" in ev.evidence:
        ev.evidence["first_alarm_s"] = alarm / rate_hz
    if ev.type is FaultType.ADDITIVE:
        x = None  # a constant
    elif ev.type is FaultType.MULTIPLICATIVE and abs(ev.magnitude.get("gain", 0.0)) >= MIN_GAIN:
        x = y  # the reading, times 1 - 1/g
    else:
        return
    n = r.shape[0]
    onset = int(round(ev.onset_s * rate_hz))
    end = None if ev.end_s is None else int(round(ev.end_s * rate_hz))
    stop = n if end is None else end
    taps = f.taps[0]
    mean = f.calibration.mean
    new_onset = onset
    if onset > start and not ev.evidence.get("starts_in_training"):
        lo = max(start + 1, onset - p, s_cur)
        hi = min(alarm, onset + p, stop - 1)
        # up to p samples of the full response after the latest candidate, none of the end's
        span = (max(lo - ahead, s_cur), min(hi + s_cur + p, stop - ahead, n - ahead))
        got = _edge_fit(r, x, taps, s_cur, mean, range(lo, hi + 1), span, rising=True)
        if got is not None:
            new_onset = got
            ev.evidence["change_point_onset_s"] = ev.onset_s
            ev.onset_s = got / rate_hz
    if end is not None:
        lo = max(new_onset + 1, end - p)
        hi = min(n - ahead - 1, end + p)
        span = (max(lo - ahead - p, new_onset + s_cur, s_cur), min(hi + s_cur, n - ahead))
        got = _edge_fit(r, x, taps, s_cur, mean, range(lo, hi + 1), span, rising=False)
        if got is not None:
            ev.evidence["change_point_end_s"] = ev.end_s
            ev.end_s = got / rate_hz


def _edge_fit(
    r: FloatArray,
    x: FloatArray | None,
    taps: FloatArray,
    s_cur: int,
    mean: float,
    candidates: range,
    span: tuple[int, int],
    *,
    rising: bool,
) -> int | None:
    """The candidate edge whose response best fits ``r - mean`` over ``span`` (least
    squares, the size fitted for each, beside the whole of ``x`` through the taps): with
    ``rising`` the first faulty sample ``t0``, whose response is ``sum_s taps[s]
    x(t - s_cur + s) [t - s_cur + s >= t0]``, else the first healthy one ``t1``
    (``[... < t1]``); ``x`` None is a constant (an offset). None when the span or
    candidates are empty, or a sample it reads is missing."""
    a, b = span
    p = taps.shape[0] - 1
    n = r.shape[0] if x is None else x.shape[0]
    cands = np.array([c for c in candidates if a - p + s_cur <= c <= b + s_cur], dtype=np.int64)
    if b - a < 2 or cands.size == 0 or a - s_cur < 0 or b - s_cur + p > n:
        return None
    rr = np.asarray(r[a:b], dtype=np.float64) - mean
    read = np.ones(b - a + p) if x is None else x[a - s_cur : b - s_cur + p]
    xw = sliding_window_view(np.asarray(read, dtype=np.float64), p + 1)
    if not (np.all(np.isfinite(rr)) and np.all(np.isfinite(xw))):
        return None
    terms = xw * taps  # terms[t, s]: sample t - s_cur + s of x through tap s
    # tail[t, k]: the response at t to the fault signal from sample t - s_cur + k on
    tail = np.zeros((b - a, p + 2))
    tail[:, : p + 1] = np.cumsum(terms[:, ::-1], axis=1)[:, ::-1]
    rows = np.arange(b - a)[:, None]
    # the whole signal through the taps, fitted beside each edge's response: it takes up
    # what the healthy residual shares with the signal (the sensor's own noise through
    # its taps, for a gain's reading; the level left of the healthy mean, for an
    # offset), which would otherwise pull the edge to wherever the span is longest
    whole = tail[:, 0]
    ww, wr = float(whole @ whole), float(whole @ rr)
    best, best_score = None, -np.inf
    for c0 in range(0, cands.size, EDGE_BLOCK):
        block = cands[c0 : c0 + EDGE_BLOCK]
        k = np.clip(block[None, :] - (np.arange(a, b)[:, None] - s_cur), 0, p + 1)
        u = tail[rows, k]
        if not rising:
            u = whole[:, None] - u  # the fault signal before t1
        uu = np.einsum("ij,ij->j", u, u)
        uw = whole @ u
        ur = rr @ u
        det = uu * ww - uw * uw
        # what the least-squares fit of r on (u, whole) explains, for each candidate
        solvable = det > 1e-12 * np.maximum(uu * ww, np.finfo(np.float64).tiny)
        safe = np.where(solvable, det, 1.0)
        both = (ur * ur * ww - 2.0 * ur * uw * wr + wr * wr * uu) / safe
        alone = wr * wr / ww if ww > 0.0 else 0.0
        score = np.where(solvable, both, alone)
        j = int(np.argmax(score))
        if score[j] > best_score:
            best, best_score = int(block[j]), float(score[j])
    return best


def _residual_and_reference(
    f: SensorFunction, data: Dataset, context: RunContext, k: int
) -> tuple[FloatArray, FloatArray]:
    """Residual and fault-free estimate of ``f`` over the whole archive, computed chunk by
    chunk (each chunk reads the ``p`` samples of context it needs) into arrays from
    ``context.allocate`` (memory-mapped when the pipeline has a work directory)."""
    n = data.n
    idx = [data.index(c) for c in f.channels]
    r = context.allocate(f"error_function_{k}_residual", (n,))
    ref = context.allocate(f"error_function_{k}_reference", (n,))
    back, ahead = f.s_cur, f.p - f.s_cur
    for a in range(0, n, _RUN_CHUNK):
        b = min(n, a + _RUN_CHUNK)
        lo, hi = max(0, a - back), min(n, b + ahead)
        vals = np.asarray(data.values[lo:hi][:, idx], dtype=np.float64)
        rr = f.residual(vals)
        r[a:b] = rr[a - lo : b - lo]
        ref[a:b] = f.sensor_view(vals[:, 0])[a - lo : b - lo] - rr[a - lo : b - lo]
    return r, ref


def _channel_stats(x: FloatArray, names: list[str]) -> dict[str, tuple[float, float]]:
    """Training mean and standard deviation per channel; refuses NaN-only and constant
    channels (no information to build an error function from)."""
    out: dict[str, tuple[float, float]] = {}
    for c, name in enumerate(names):
        col = x[:, c]
        ok = np.isfinite(col)
        if not ok.any():
            raise DetectorError(f"channel {name!r} has no finite sample in the training window")
        sd = float(np.std(col[ok]))
        if not sd > 0.0:
            raise DetectorError(
                f"channel {name!r} is constant in the training window: no dynamics to build "
                f"an error function from"
            )
        out[name] = (float(np.mean(col[ok])), sd)
    return out
