"""A fitted analysis saved to a file and reused on the next archive.

STYLE principle 2: a fitted model is a value that can be saved, reported and reused.
``analyzer run A --save-model M`` fits every detector on A's healthy window and writes
the fitted models to ``M``; ``analyzer run B --model M`` (or ``analyzer watch ... --model
M``) runs them over B without fitting anything on B. That is how an SHM archive of one
file per hour is audited: train once on a recording known to be healthy, then test each
new file whole, a fault present from a file's first sample included (training on the
file's own first minutes would take such a fault for the healthy state).

The file is the magic line :data:`MAGIC`, a line with the SHA-256 of the rest, and a
pickle of :class:`SavedModel` (:func:`framed`): a file damaged anywhere is refused.
The unpickler (:class:`_Restricted`) builds only the exact ``(module, name)`` pairs of
:data:`_ALLOWED`: the classes a saved model is made of, numpy's array, dtype and scalar
rebuilding and ``complex``, each of which only checks and stores its arguments; a file
that names anything else is refused before it is imported or called ("does not hold an
analyzer model"), and one that changes an allowed class or enum member (a pickle's
``BUILD`` can set attributes on them) is refused and the class put back
(:func:`_unpickle`). What this does not stop: a file may still ask for much memory or
time (an array or impulse-response bank of a huge declared size), and a model's numbers
decide the findings, so a forged model gives forged findings. The SHA-256 line finds
damage, not who wrote the file: load model files only from people you trust. A model
is tied to the analyzer version that wrote it (the fitted classes change between
versions): another version's model is refused with a message saying so.
"""

from __future__ import annotations

import enum
import hashlib
import importlib
import io
import pickle
from dataclasses import MISSING, dataclass, field, fields
from pathlib import Path
from typing import Any

from analyzer import __version__
from analyzer.errors import UsageError
from analyzer.outdir import write_atomic
from analyzer.timeutil import json_time

MAGIC = b"analyzer.model/3\n"
"""Format 3: a SHA-256 of the content after the magic line (:func:`framed`).
Format 2: an impulse-response bank holds its Markov parameters, not their spectrum
(:class:`~analyzer.detectors.lti.ImpulseResponseBank`; the 16-channel benchmark model
fitted on 10 minutes: 56.7 -> 20.4 MB).
Files of an earlier format are refused with the remedy: fit again."""

_ALLOWED: dict[str, frozenset[str]] = {
    "analyzer.modelfile": frozenset({"SavedModel"}),
    "analyzer.diagnosis.changes": frozenset({"Calibration"}),
    "analyzer.detectors.ar_kalman": frozenset({"ARKalmanBank", "FittedBank"}),
    "analyzer.detectors.ar_model": frozenset({"ARModel"}),
    "analyzer.detectors.assistant_observer": frozenset(
        {"AssistantObserver", "Pretreatment", "Relation"}
    ),
    "analyzer.detectors.beard_jones": frozenset({"ParkFilter"}),
    "analyzer.detectors.detection_filter": frozenset({"DetectionFilter", "FittedDetectionFilter"}),
    "analyzer.detectors.equivalent_model": frozenset(
        {"EquivalentModel", "FittedEquivalentModel", "TargetObserver"}
    ),
    "analyzer.detectors.error_function": frozenset(
        {"ErrorFunction", "ErrorFunctionModel", "SensorFunction"}
    ),
    "analyzer.detectors.kalman_bank": frozenset({"BankFilter", "LeaveOneOut"}),
    "analyzer.detectors.lti": frozenset(
        {"ImpulseResponseBank", "LiftedBank", "StackedLiftedSystem"}
    ),
    "analyzer.detectors.network": frozenset({"Propagation", "SensorNetwork"}),
    "analyzer.detectors.state_space": frozenset({"StateSpaceModel"}),
    "numpy": frozenset({"dtype", "ndarray"}),
    "numpy._core.numeric": frozenset({"_frombuffer"}),
    "numpy.core.numeric": frozenset({"_frombuffer"}),
    "numpy._core.multiarray": frozenset({"_reconstruct", "scalar"}),
    "numpy.core.multiarray": frozenset({"_reconstruct", "scalar"}),
    "builtins": frozenset({"complex"}),
}
"""Every ``(module, name)`` a model file may name, matched exactly (a pickle may call
what it names, with arguments of its choosing, so each is harmless with any): the
classes a saved model is made of (what ``pickletools`` lists in models saved by every
detector, alone and together, with and without a config's groups and ``[model]``; and
the bank's lifted form, which a filter with a long memory takes), numpy's array, dtype
and scalar rebuilding (under numpy 2's and numpy 1's module names) and ``complex``.
Each class only checks and stores its arguments. ``tests/cli/test_model_loader.py``
fails when a saved model names anything this table lacks. Before, any class reachable
from the analyzer's detector, diagnosis and statistics modules passed, through dotted
names too (``np.f2py.subprocess.Popen``, ``np.memmap``): a crafted file ran a command
(a security audit, ux63 item H1)."""


@dataclass(frozen=True, slots=True)
class SavedModel:
    """Everything ``--model`` needs to analyze another archive as the training run did.

    ``fits[group][detector]`` is ``(detector, fitted model)``: the detector object (its
    settings) and what its ``fit`` returned, per channel group (``""`` for the whole
    channel set, ``"-g0"``, ``"-g1"``... for the groups the training run partitioned the
    channels into, in ``groups``). ``healthy[channel]`` is the channel's mean and
    standard deviation over the training window (a frozen sensor is told by them);
    ``training_tests[detector][channel]`` are the residual tests of that window, shown
    again in the reports of the archives the model analyzes. A field added later goes
    last, with a default: an older file's pickle leaves it unset and :func:`load_model`
    gives it its default."""

    channels: tuple[str, ...]
    rate_hz: float
    train_s: tuple[float, float]
    """The training window's first and last sample, seconds from the record's start."""
    inputs: tuple[tuple[str, str], ...]
    """``(path, sha256)`` of each file of the training archive."""
    groups: tuple[tuple[str, ...], ...]
    fits: dict[str, dict[str, tuple[Any, Any]]]
    healthy: dict[str, tuple[float, float]]
    training_tests: dict[str, dict[str, Any]] = field(default_factory=dict)
    false_alarm_rate: float = 1e-6
    config: dict[str, Any] = field(default_factory=dict)
    """The config's context the detectors were fitted with (groups, state-space model)."""
    time_source: str = "log"
    analyzer_version: str = __version__
    created: str = ""
    reading_health: dict[str, dict[str, tuple[float, float, float]]] = field(default_factory=dict)
    """``reading_health[detector][channel]``: the healthy mean, standard deviation and
    correlation time of the residuals the readings rule reads (the equivalent model's, the
    bank's, the detection filter's: :func:`~analyzer.diagnosis.readings.residual_health`)
    over the training window, for the rule to judge the lone equivalent-model findings of
    a ``--model`` run by. Empty in a model saved before it was kept (the last field, so
    such a file still loads: :func:`load_model`): the rule is not applied then."""
    zero_at_rest: tuple[str, ...] | None = None
    """The channels whose healthy readings read zero for long over the training window
    (:func:`~analyzer.diagnosis.stuck.reads_zero_for_long`: exact zeros are a healthy
    state of theirs, a valve's flow meter, a coarse converter at rest), for the frozen
    checks of a ``--model`` run, which has no training readings. ``None`` in a model saved
    before it was kept: not known, and a dead sensor in an anomaly attributed to no sensor
    is then not looked for (:func:`~analyzer.diagnosis.stuck.dead_unattributed`)."""

    def train_window_s(self) -> tuple[float, float]:
        """The training window as the fit run's ``findings.json`` and last line said it:
        its first and last sample, to four decimals. (A model saved before this rule holds
        the window asked for, whose end can be one sample later: a ``--model`` run said
        0-120.000 s of a model saved "fitted on 0-119.995 s", a new user's audit, ux53
        item 10.)"""
        return json_time(self.train_s[0]), json_time(self.train_s[1])

    def detectors(self) -> list[str]:
        """The detectors fitted in this model, in the order they ran."""
        return list(dict.fromkeys(name for fits in self.fits.values() for name in fits))

    def describe(self) -> dict[str, Any]:
        """What ``findings.json`` and the report say about the model (JSON-friendly)."""
        return {
            "trained_on": [{"path": p, "sha256": h} for p, h in self.inputs],
            "train": dict(zip(("start_s", "end_s"), self.train_window_s(), strict=True)),
            "channels": list(self.channels),
            "rate_hz": self.rate_hz,
            "detectors": self.detectors(),
            "analyzer_version": self.analyzer_version,
            "created": self.created,
        }


class RefusedGlobal(pickle.UnpicklingError):
    """A model file named something :data:`_ALLOWED` lacks (refused before it is
    imported or called), or changed one of the analyzer's classes (put back)."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


class _Restricted(pickle.Unpickler):
    """Builds only what :data:`_ALLOWED` names, after the pickle documentation's
    "Restricting Globals"."""

    def find_class(self, module: str, name: str) -> Any:
        if name in _ALLOWED.get(module, ()):
            return super().find_class(module, name)
        what = f"{module}.{name}"  # the file's text: quoted, and cut if long
        shown = repr(what if len(what) <= 80 else what[:80] + "...")
        raise RefusedGlobal(f"it asks to build {shown}, which is not part of one")


def _shared_objects() -> list[Any]:
    """The analyzer's classes a model file may name and their enum members: objects a
    pickle could change for the whole process (its ``BUILD`` sets attributes on
    whatever it built, a class or an enum member too)."""
    objs: list[Any] = []
    for module, names in _ALLOWED.items():
        if not module.startswith("analyzer."):
            continue  # numpy's and builtin types cannot be changed
        mod = importlib.import_module(module)
        for name in sorted(names):
            cls = getattr(mod, name)
            objs.append(cls)
            if isinstance(cls, enum.EnumMeta):
                objs.extend(cls)
    return objs


def _restore(before: list[tuple[Any, dict[str, Any]]]) -> list[str]:
    """Put back any attribute of the objects of :func:`_shared_objects` that loading
    changed; the names of those changed."""
    changed = []
    for obj, attrs in before:
        now = dict(vars(obj))
        if now.keys() == attrs.keys() and all(now[k] is v for k, v in attrs.items()):
            continue
        changed.append(getattr(obj, "__qualname__", None) or f"{type(obj).__qualname__}.{obj}")
        for key in now.keys() - attrs.keys():
            delattr(obj, key)
        for key, value in attrs.items():
            if now.get(key) is not value:
                setattr(obj, key, value)
    return changed


def _unpickle(payload: bytes) -> Any:
    """``payload`` built by :class:`_Restricted`; :class:`RefusedGlobal` also when it
    changed one of the analyzer's classes (put back as they were)."""
    before = [(obj, dict(vars(obj))) for obj in _shared_objects()]
    try:
        return _Restricted(io.BytesIO(payload)).load()
    finally:
        changed = _restore(before)
        if changed:
            raise RefusedGlobal(f"it changed the analyzer's {changed[0]} (put back as it was)")


def save_model(path: Path, model: SavedModel, data: bytes | None = None) -> None:
    """Write ``model`` to ``path`` atomically (a reader never sees half a file): its
    :func:`model_bytes`, or ``data``, those bytes made before (whose SHA-256 the run's
    ``findings.json`` gives)."""
    write_atomic(path, model_bytes(model) if data is None else data)


def model_bytes(model: SavedModel) -> bytes:
    """The bytes of ``model``'s file (:func:`framed`)."""
    return framed(pickle.dumps(model, protocol=5))


def framed(payload: bytes) -> bytes:
    """A model file's bytes: :data:`MAGIC`, the SHA-256 of ``payload`` (a damaged byte
    anywhere is refused, not loaded as another model), ``payload``."""
    return MAGIC + b"sha256 " + hashlib.sha256(payload).hexdigest().encode() + b"\n" + payload


def check_model_path(path: Path, out: Path | None = None) -> None:
    """Before any work: ``--save-model``'s ``path`` must not be a directory, and its
    directory must exist or be ``out`` (the run's ``--out``, created before the work):
    :class:`UsageError` naming the option, so a long analysis does not fail at its end
    for want of a place to write its model. Without ``out`` (the options are checked
    before the run knows it) only the first."""
    if path.is_dir():
        raise UsageError(f"--save-model: {path} is a directory, expected a file name")
    if out is None or path.parent.is_dir():
        return
    if path.parent.resolve() != out.resolve():
        if path.parent.exists():
            raise UsageError(f"--save-model: {path.parent} is not a directory")
        raise UsageError(f"--save-model: directory {path.parent} does not exist")


MODEL_HEAD = b"analyzer.model/"
"""How every model file begins, of any format (:data:`MAGIC` is this format's)."""


def not_a_model(path: Path) -> None:
    """Before any work: ``--save-model`` replaces an existing file only if it is an
    analyzer model (of any format) or empty; any other file is refused
    (:class:`UsageError`), since the replaced file is not kept: ``--save-model data.csv``
    had replaced a recording with a model, saying so only afterwards (a QA audit's
    ux56 item 2)."""
    try:
        if not path.is_file():
            return
        with path.open("rb") as f:
            head = f.read(len(MODEL_HEAD))
    except OSError as err:
        raise UsageError(
            f"--save-model: cannot read {path}, which exists: {err.strerror or err}; "
            "name another file"
        ) from None
    if head and not head.startswith(MODEL_HEAD):
        raise UsageError(
            f"--save-model: {path} exists and is not an analyzer model (the replaced file "
            "would not be kept); name another file or remove it"
        )


def _later_fields(model: SavedModel) -> None:
    """Give the fields a file saved before they existed left unset (a slotted dataclass's
    pickle holds its fields' values in order, and an older one stops short) their
    defaults: ``reading_health`` (no saved health: the readings rule not applied),
    ``zero_at_rest`` (``None``: not known). A
    plain default too (a slotted class keeps no class attribute to fall back on)."""
    for f in fields(SavedModel):
        if hasattr(model, f.name):
            continue
        if f.default is not MISSING:
            object.__setattr__(model, f.name, f.default)
        elif f.default_factory is not MISSING:
            object.__setattr__(model, f.name, f.default_factory())


def load_model(path: str | Path) -> SavedModel:
    """The model saved in ``path`` by ``--save-model``; :class:`UsageError` naming the
    option and the file when it is missing, damaged, not a model, or of another analyzer
    version."""
    p = Path(path)
    try:
        data = p.read_bytes()
    except OSError as err:
        raise UsageError(f"--model: cannot read {p}: {err.strerror or err}") from None
    if not data.startswith(MAGIC):
        head = data[: len(MAGIC)].split(b"\n", 1)[0]
        if head.startswith(b"analyzer.model/"):
            raise UsageError(
                f"--model: {p} is a model of another format ({head.decode(errors='replace')}),"
                f" this analyzer reads {MAGIC.decode().strip()}: fit it again with --save-model"
            )
        raise UsageError(f"--model: {p} is not an analyzer model (written by --save-model)")
    line, _, payload = data[len(MAGIC) :].partition(b"\n")
    digest = hashlib.sha256(payload).hexdigest().encode()
    if line != b"sha256 " + digest:
        raise UsageError(
            f"--model: {p} is damaged (its content does not match the checksum written "
            "with it): fit it again with --save-model"
        )
    try:
        model = _unpickle(payload)
    except RefusedGlobal as err:
        raise UsageError(
            f"--model: {p} does not hold an analyzer model: {err.reason} (refused); load "
            "model files only from people you trust"
        ) from None
    except Exception as err:  # noqa: BLE001 - any failure to unpickle is a bad file
        raise UsageError(f"--model: {p} is damaged or not an analyzer model ({err})") from None
    if not isinstance(model, SavedModel):
        raise UsageError(f"--model: {p} does not hold an analyzer model")
    _later_fields(model)
    if model.analyzer_version != __version__:
        raise UsageError(
            f"--model: {p} was written by analyzer {model.analyzer_version}, this is "
            f"{__version__}: fit it again with --save-model"
        )
    return model
