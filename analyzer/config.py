"""The TOML config file (``--config FILE``): channel groups, a known state-space model,
detector options and thresholds. Everything is optional; unknown keys are an error that
names the key, so a typo never passes silently (CONTRACT.md, "The config file")."""

from __future__ import annotations

import hashlib
import json
import math
import re
import tomllib
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from analyzer.errors import ConfigError, capped

_TOP = {"train", "group", "model", "detectors", "thresholds", "rename"}
_TRAIN = {"start", "end"}
_GROUP = {"name", "channels", "reference", "uncertain", "inputs"}
_MODEL = {"file", "A", "B", "C", "D", "dt", "outputs", "inputs"}
_THRESHOLDS = {"false_alarm_rate"}


@dataclass(slots=True)
class Config:
    """The parsed ``--config`` file (:func:`load_config`)."""

    train: tuple[float, float] | None = None
    groups: list[dict[str, Any]] = field(default_factory=list)
    model: dict[str, Any] | None = None
    detectors: dict[str, dict[str, Any]] = field(default_factory=dict)
    false_alarm_rate: float = 1e-6
    path: Path | None = None
    model_file: Path | None = None
    """The resolved ``[model] file`` (an input of the run: never overwritten)."""
    rename: dict[str, str] = field(default_factory=dict)
    """``[rename]``: ``NEW = "OLD"`` pairs, each NEW channel name read as the OLD one
    (``--rename NEW=OLD``'s table: a sensor replaced under a new name)."""
    sha256: str = ""
    """The config file's SHA-256 as read (``findings.json``'s ``config``: which file, as it
    was, set the run)."""

    def info(self) -> dict[str, Any] | None:
        """What ``findings.json`` says of the config (``config``; None without one): the
        file and its digest, and the settings it gave, so a result can be traced to the
        settings that made it (a run's outputs named no config before: two runs of one
        archive with different thresholds could not be told apart)."""
        if self.path is None:
            return None
        model = None
        if self.model is not None:
            a = np.asarray(self.model["A"])
            model = {
                "file": None if self.model_file is None else str(self.model_file),
                "states": int(a.shape[0]),
                "outputs": list(self.model.get("outputs") or []),
                "inputs": list(self.model.get("inputs") or []),
            }
        return {
            "path": str(self.path),
            "sha256": self.sha256,
            "train": None
            if self.train is None
            else {"start_s": self.train[0], "end_s": self.train[1]},
            "groups": [{k: v for k, v in g.items() if k in _GROUP} for g in self.groups],
            "model": model,
            "detectors": {name: dict(opts) for name, opts in self.detectors.items()},
            "false_alarm_rate": self.false_alarm_rate,
            # (where it has a [rename] table: NEW -> OLD channel names)
            **({"rename": dict(self.rename)} if self.rename else {}),
        }

    def as_context(self) -> dict[str, Any]:
        """The parsed config as handed to detectors (``RunContext.config``)."""
        return {
            "group": self.groups,
            "model": self.model,
            "detectors": self.detectors,
            "thresholds": {"false_alarm_rate": self.false_alarm_rate},
        }


def _unknown(where: str, got: dict[str, Any], allowed: set[str], path: Path) -> None:
    """Refuse a key of table ``where`` (``[train]``; ``""`` at the top) not ``allowed``,
    written as in the file: ``[train] bogus``, a table ``[bogus]`` (a QA audit read
    ``train.'bogus'``, a notation of no TOML file)."""
    extra = sorted(set(got) - allowed)
    if extra:
        key = extra[0]
        shown = key if _BARE_KEY.fullmatch(key) else json.dumps(key, ensure_ascii=False)
        if where:
            said = f"key {where} {shown}"
        else:  # (a table at the top is a section: [bogus])
            said = f"section [{shown}]" if isinstance(got[key], dict) else f"key {shown}"
        raise ConfigError(f"{path}: unknown {said} (allowed: {', '.join(sorted(allowed))})")


_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")
"""A TOML key written without quotes."""


def _names(value: Any, key: str, path: Path) -> list[str]:
    """A list of channel names, each named once (a name given twice is a typo for
    another: the channel it stands for would silently be left out)."""
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ConfigError(f"{path}: {key} must be a list of channel names, got {value!r}")
    twice = [v for i, v in enumerate(value) if v in value[:i]]
    if twice:
        raise ConfigError(f"{path}: {key} names {twice[0]!r} twice")
    return list(value)


def _number(value: Any) -> bool:
    """A TOML integer or float (a boolean is neither)."""
    return isinstance(value, int | float) and not isinstance(value, bool)


def _matrix(value: Any, key: str, path: Path, source: str | None = None) -> np.ndarray:
    """The matrix ``key`` of ``[model]`` (``source``: the .npz it was read from, if any),
    real, finite and 2-D."""
    what = f"model.{key}" if source is None else f"model.file {source!r}: {key}"
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError) as err:
        raise ConfigError(f"{path}: {what} is not a numeric matrix ({err})") from err
    if raw.dtype.kind == "c":
        # np.asarray(..., float64) would drop the imaginary part without a word
        raise ConfigError(
            f"{path}: {what} is complex-valued: expected a real matrix (the discrete "
            "state-space model x+ = A x + B u, y = C x + D u has real matrices)"
        )
    if raw.dtype.kind not in "iuf":
        raise ConfigError(
            f"{path}: {what} is not a numeric matrix (got {raw.dtype.kind!r} values: "
            f"{str(value)[:60]})"
        )
    arr = np.atleast_2d(np.asarray(raw, dtype=np.float64))
    if arr.ndim != 2 or not np.isfinite(arr).all():
        raise ConfigError(f"{path}: {what} must be a finite 2-D matrix, got shape {arr.shape}")
    return arr


NPZ_MAGIC = b"PK\x03\x04"
"""The first bytes of an .npz (a zip archive, as ``np.savez`` writes it)."""

NPZ_RECIPE = (
    "[model] file names an .npz of the structure's discrete state-space matrices, written by "
    'np.savez("model.npz", A=A, B=B, C=C, D=D, dt=dt) (C: one row per [model] outputs '
    "channel, B and D: one column per [model] inputs channel; README: The config file), "
    "or leave [model] out to run without a known model"
)
"""What a missing ``[model] file`` is and how to write one: the config examples name a
``model.npz`` a new user does not have."""


def _npz_arrays(mfile: Path, path: Path) -> dict[str, Any]:
    """A, B, C, D and dt of the .npz ``mfile`` (``[model] file``): :class:`ConfigError`
    naming the config and the file when it is missing, not an .npz of numeric arrays
    (a CSV, a pickle, a single .npy) or damaged."""
    where = f"{path}: model.file {str(mfile)!r}"
    try:
        with mfile.open("rb") as f:
            head = f.read(len(NPZ_MAGIC))
    except FileNotFoundError:
        raise ConfigError(f"{where} does not exist: {NPZ_RECIPE}") from None
    except OSError as err:
        raise ConfigError(f"{where} cannot be read ({err.strerror or err})") from None
    if head != NPZ_MAGIC:
        raise ConfigError(
            f"{where} is not an .npz of arrays (np.savez(file, A=..., B=..., C=..., D=...))"
        )
    mats: dict[str, Any] = {}
    try:
        with np.load(mfile, allow_pickle=False) as npz:
            for k in ("A", "B", "C", "D", "dt"):
                if k in npz:
                    mats[k] = npz[k]
    except (OSError, EOFError, zipfile.BadZipFile) as err:
        raise ConfigError(f"{where} is damaged (a truncated .npz?): {err}") from None
    except ValueError as err:
        # object arrays (a pickle inside): never loaded (allow_pickle would run code)
        raise ConfigError(f"{where} holds object arrays, not numeric ones ({err})") from None
    return mats


def _dt(value: Any, where: str, path: Path) -> float | None:
    """``[model] dt`` (inline or in the .npz): a positive number of seconds, or None."""
    if value is None:
        return None
    if isinstance(value, np.ndarray):
        if value.size != 1 or value.dtype.kind not in "iuf":
            raise ConfigError(
                f"{path}: {where} must be one number of seconds, got an array of "
                f"shape {value.shape} ({value.dtype})"
            )
        value = value.reshape(()).item()
    if not _number(value) or not math.isfinite(value) or value <= 0:
        raise ConfigError(f"{path}: {where} must be a number of seconds > 0, got {value!r}")
    return float(value)


def load_model(raw: Any, path: Path) -> dict[str, Any]:
    """``[model]``: A, B, C, D from ``file`` (.npz, relative to the config) or inline
    (not both: which would win?), with dimension checks that quote the shapes, and the
    channel names of the outputs and inputs checked for repeats and overlap."""
    if not isinstance(raw, dict):
        raise ConfigError(
            f'{path}: [model] must be a table (file = "model.npz", outputs = [...]), got {raw!r}'
        )
    _unknown("[model]", raw, _MODEL, path)
    mats: dict[str, Any] = {}
    if "file" in raw:
        if not isinstance(raw["file"], str):
            raise ConfigError(f"{path}: model.file must be a file name, got {raw['file']!r}")
        inline = [k for k in ("A", "B", "C", "D", "dt") if k in raw]
        if [k for k in inline if k != "dt"]:
            raise ConfigError(
                f"{path}: [model] gives both file and inline {', '.join(inline)}: give the "
                "matrices in one place"
            )
        mats = _npz_arrays((path.parent / raw["file"]).resolve(), path)
    for k in ("A", "B", "C", "D"):
        if k in raw:
            mats[k] = raw[k]
    if "A" not in mats or "C" not in mats:
        raise ConfigError(f"{path}: [model] needs at least A and C (inline or in file)")

    def src(key: str) -> str | None:
        return None if key in raw else raw.get("file")

    A = _matrix(mats["A"], "A", path, src("A"))
    n = A.shape[0]
    if A.shape != (n, n):
        raise ConfigError(f"{path}: expected a square matrix for model.A, got {A.shape}")
    C = _matrix(mats["C"], "C", path, src("C"))
    if C.shape[1] != n:
        raise ConfigError(
            f"{path}: expected a ({C.shape[0]}, {n}) matrix for model.C, got {C.shape}"
        )
    B = _matrix(mats["B"], "B", path, src("B")) if "B" in mats else np.zeros((n, 0))
    if B.shape[0] != n:
        raise ConfigError(
            f"{path}: expected a ({n}, {B.shape[1]}) matrix for model.B, got {B.shape}"
        )
    D = (
        _matrix(mats["D"], "D", path, src("D"))
        if "D" in mats
        else np.zeros((C.shape[0], B.shape[1]))
    )
    if D.shape != (C.shape[0], B.shape[1]):
        raise ConfigError(
            f"{path}: expected a ({C.shape[0]}, {B.shape[1]}) matrix for model.D, got {D.shape}"
        )
    outputs = _names(raw.get("outputs", []), "model.outputs", path)
    if outputs and len(outputs) != C.shape[0]:
        raise ConfigError(
            f"{path}: model.outputs names {len(outputs)} channels but C has {C.shape[0]} rows"
        )
    inputs = _names(raw.get("inputs", []), "model.inputs", path)
    if inputs and len(inputs) != B.shape[1]:
        raise ConfigError(
            f"{path}: model.inputs names {len(inputs)} channels but B has {B.shape[1]} columns"
        )
    both = [c for c in inputs if c in outputs]
    if both:
        raise ConfigError(
            f"{path}: model.outputs and model.inputs both name {both[0]!r}: a channel is "
            "an output (a row of C) or an input (a column of B)"
        )
    dt = _dt(raw.get("dt"), "model.dt", path)
    stored = _dt(mats.get("dt"), f"model.file {raw.get('file')!r}: dt", path)
    if dt is not None and stored is not None and dt != stored:
        raise ConfigError(
            f"{path}: model.dt = {dt:g} s but model.file {raw.get('file')!r} has dt = "
            f"{stored:g} s: give it in one place"
        )
    dt = stored if dt is None else dt
    return {
        "A": A,
        "B": B,
        "C": C,
        "D": D,
        "dt": dt,
        "outputs": outputs,
        "inputs": inputs,
    }


def model_file(raw: Any, path: Path) -> Path | None:
    """The resolved ``[model] file`` of the config ``path``, if it names one."""
    if isinstance(raw, dict) and isinstance(raw.get("file"), str):
        return (path.parent / raw["file"]).resolve()
    return None


def members(group: dict[str, Any]) -> list[str]:
    """Every channel of a ``[[group]]``: its ``channels``, then any reference, uncertain
    sensor or input they leave out (each belongs to the group: the measured excitation
    of a structure is analyzed with the structure it excites)."""
    names = [
        *group.get("channels", []),
        *group.get("reference", []),
        *group.get("uncertain", []),
        *group.get("inputs", []),
    ]
    return list(dict.fromkeys(names))


def group_inputs(groups: list[dict[str, Any]]) -> set[str]:
    """The channels the ``[[group]]`` tables name as measured inputs (excitation)."""
    return {c for g in groups for c in g.get("inputs", [])}


def measured_inputs(config: Mapping[str, Any]) -> frozenset[str]:
    """The channels a run's config (``RunContext.config``) names as measured inputs
    (excitation, not sensors under test): ``[[group]] inputs`` and ``[model] inputs``."""
    model = config.get("model") or {}
    return frozenset([*group_inputs(config.get("group") or []), *(model.get("inputs") or [])])


def load_config(path: str | Path | None, known_detectors: set[str] | None = None) -> Config:
    """Parse and validate ``path`` (None: the empty config)."""
    if path is None:
        return Config()
    p = Path(path)
    try:
        data = p.read_bytes()
        # (a byte-order mark, as Windows' Notepad saves, is no TOML: read past it)
        raw = tomllib.loads(data.decode("utf-8-sig"))
    except FileNotFoundError:
        raise ConfigError(f"--config: {p}: no such file") from None
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"--config: {p}: cannot be read ({err})") from err
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(f"--config: {p}: not valid TOML ({err})") from err
    _unknown("", raw, _TOP, p)
    cfg = Config(path=p, sha256=hashlib.sha256(data).hexdigest())
    if "train" in raw:
        cfg.train = _train(raw["train"], p)
    groups = raw.get("group", [])
    if isinstance(groups, dict):
        raise ConfigError(
            f"{p}: [group] is one table: use [[group]] (an array of tables, one per group)"
        )
    if not isinstance(groups, list):
        raise ConfigError(f"{p}: group must be [[group]] tables, got {groups!r}")
    for i, g in enumerate(groups):
        group = _group(g, i, p)
        for earlier in cfg.groups:
            # a measured input may excite two groups (one ground accelerometer under two
            # substructures): it is analyzed with the first (grouping.partition)
            # (an input of both: a sensor of one group is not the other's input)
            inputs = set(group.get("inputs", [])) & set(earlier.get("inputs", []))
            shared = [c for c in members(group) if c in members(earlier) and c not in inputs]
            if shared:
                # each detector models a group on its own: a channel in two would be
                # analyzed (and reported) twice, under two different models
                raise ConfigError(
                    f"{p}: [[group]] {group['name']!r} and [[group]] {earlier['name']!r} "
                    f"share {capped(shared)}: a channel belongs to one group"
                )
        cfg.groups.append(group)
    if "model" in raw:
        cfg.model = load_model(raw["model"], p)
        cfg.model_file = model_file(raw["model"], p)
    dets = raw.get("detectors", {})
    if not isinstance(dets, dict):
        raise ConfigError(f"{p}: [detectors] must be a table of detector tables")
    for name, opts in dets.items():
        if known_detectors is not None and name not in known_detectors:
            raise ConfigError(
                f"{p}: [detectors.{name}]: unknown detector '{name}' (known: "
                f"{', '.join(sorted(known_detectors))})"
            )
        if not isinstance(opts, dict):
            raise ConfigError(f"{p}: [detectors.{name}] must be a table of options")
        cfg.detectors[name] = dict(opts)
    if cfg.detectors.get("error_function", {}).get("approach") == "indirect" and cfg.model is None:
        # the indirect error functions come from the state-space model (Li et al. 2007,
        # Eq. 3-9): without one the detector could only be skipped
        raise ConfigError(
            f'{p}: [detectors.error_function] approach = "indirect" needs a [model] '
            '(A, B, C, D); or use approach = "direct"'
        )
    cfg.rename = _rename(raw.get("rename", {}), p)
    th = raw.get("thresholds", {})
    if not isinstance(th, dict):
        raise ConfigError(f"{p}: [thresholds] must be a table (false_alarm_rate = ...), got {th!r}")
    _unknown("[thresholds]", th, _THRESHOLDS, p)
    if "false_alarm_rate" in th:
        far = th["false_alarm_rate"]
        if not _number(far) or not 0.0 < float(far) < 0.5:
            raise ConfigError(f"{p}: thresholds.false_alarm_rate must be in (0, 0.5), got {far!r}")
        cfg.false_alarm_rate = float(far)
    return cfg


def _rename(table: Any, p: Path) -> dict[str, str]:
    """``[rename]``: a table of ``NEW = "OLD"`` channel names (``s3b = "s3"``), each a
    non-empty string; checked further with ``--rename``'s (:func:`analyzer.readers.
    parse_renames`)."""
    if not isinstance(table, dict):
        raise ConfigError(f'{p}: [rename] must be a table of NEW = "OLD" channel names')
    for new, old in table.items():
        if not isinstance(old, str) or not old.strip() or not new.strip():
            raise ConfigError(
                f'{p}: [rename] {new} = {old!r}: expected NEW = "OLD" (the channel\'s name in '
                'the later files, then the name it replaces: s3b = "s3")'
            )
    return {str(new).strip(): str(old).strip() for new, old in table.items()}


def _train(t: Any, p: Path) -> tuple[float, float]:
    """``[train]``: start (default 0) and end, seconds from the first sample."""
    if not isinstance(t, dict):
        raise ConfigError(f"{p}: [train] must be a table with start and end")
    _unknown("[train]", t, _TRAIN, p)
    if "end" not in t:
        raise ConfigError(f"{p}: [train] needs numeric start and end seconds (no end)")
    start, end = t.get("start", 0.0), t["end"]
    for key, val in (("start", start), ("end", end)):
        if not _number(val) or not math.isfinite(val):
            raise ConfigError(f"{p}: [train] {key} must be a number of seconds, got {val!r}")
    if not end > start >= 0:
        raise ConfigError(f"{p}: [train] end ({end}) must be after start ({start}) >= 0")
    return float(start), float(end)


def _group(g: Any, i: int, p: Path) -> dict[str, Any]:
    """The ``i``-th ``[[group]]`` table, its channel lists checked: a sensor is a
    reference (trusted) or uncertain (under test), and a measured input is neither."""
    if not isinstance(g, dict):
        raise ConfigError(f"{p}: [[group]] #{i + 1} must be a table, got {g!r}")
    _unknown(f"[[group]] #{i + 1}", g, _GROUP, p)
    name = g.get("name", f"group{i + 1}")
    if not isinstance(name, str):
        raise ConfigError(f"{p}: group[{i}].name must be a string, got {name!r}")
    group: dict[str, Any] = {
        "name": name,
        "channels": _names(g.get("channels", []), f"group[{i}].channels", p),
        "reference": _names(g.get("reference", []), f"group[{i}].reference", p),
        "uncertain": _names(g.get("uncertain", []), f"group[{i}].uncertain", p),
        "inputs": _names(g.get("inputs", []), f"group[{i}].inputs", p),
    }
    for a, b in (("reference", "uncertain"), ("inputs", "reference"), ("inputs", "uncertain")):
        both = [c for c in group[a] if c in group[b]]
        if both:
            raise ConfigError(
                f"{p}: [[group]] {name!r} lists {both[0]!r} as both {a} and {b}: "
                + (
                    "a sensor is trusted (reference) or under test (uncertain)"
                    if a == "reference"
                    else "a measured input (excitation) is not a sensor of the group"
                )
            )
    if not group["channels"]:
        group["channels"] = [*group["reference"], *group["uncertain"], *group["inputs"]]
    return group
