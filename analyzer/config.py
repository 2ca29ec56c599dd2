"""The TOML config file (``--config FILE``): channel groups, a known state-space model,
detector options and thresholds. Everything is optional; unknown keys are an error that
names the key, so a typo never passes silently (CONTRACT.md, "The config file")."""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from analyzer.errors import ConfigError

_TOP = {"train", "group", "model", "detectors", "thresholds"}
_TRAIN = {"start", "end"}
_GROUP = {"name", "channels", "reference", "uncertain", "inputs"}
_MODEL = {"file", "A", "B", "C", "D", "dt", "outputs", "inputs"}
_THRESHOLDS = {"false_alarm_rate"}


@dataclass(slots=True)
class Config:
    train: tuple[float, float] | None = None
    groups: list[dict[str, Any]] = field(default_factory=list)
    model: dict[str, Any] | None = None
    detectors: dict[str, dict[str, Any]] = field(default_factory=dict)
    false_alarm_rate: float = 1e-6
    path: Path | None = None

    def as_context(self) -> dict[str, Any]:
        """The parsed config as handed to detectors (``RunContext.config``)."""
        return {
            "group": self.groups,
            "model": self.model,
            "detectors": self.detectors,
            "thresholds": {"false_alarm_rate": self.false_alarm_rate},
        }


def _unknown(where: str, got: dict[str, Any], allowed: set[str], path: Path) -> None:
    extra = sorted(set(got) - allowed)
    if extra:
        raise ConfigError(
            f"{path}: unknown key {where}{extra[0]!r} (allowed: {', '.join(sorted(allowed))})"
        )


def _names(value: Any, key: str, path: Path) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ConfigError(f"{path}: {key} must be a list of channel names, got {value!r}")
    return list(value)


def _matrix(value: Any, key: str, path: Path) -> np.ndarray:
    try:
        arr = np.atleast_2d(np.asarray(value, dtype=np.float64))
    except (TypeError, ValueError) as err:
        raise ConfigError(f"{path}: model.{key} is not a numeric matrix ({err})") from err
    if arr.ndim != 2 or not np.isfinite(arr).all():
        raise ConfigError(f"{path}: model.{key} must be a finite 2-D matrix, got shape {arr.shape}")
    return arr


def load_model(raw: dict[str, Any], path: Path) -> dict[str, Any]:
    """``[model]``: A, B, C, D from ``file`` (.npz, relative to the config) or inline,
    with dimension checks that quote the shapes."""
    _unknown("model.", raw, _MODEL, path)
    mats: dict[str, Any] = {}
    if "file" in raw:
        mfile = (path.parent / str(raw["file"])).resolve()
        try:
            with np.load(mfile) as npz:
                for k in ("A", "B", "C", "D", "dt"):
                    if k in npz:
                        mats[k] = np.asarray(npz[k], dtype=np.float64)
        except (OSError, ValueError) as err:
            raise ConfigError(f"{path}: model.file {str(mfile)!r} cannot be read ({err})") from err
    for k in ("A", "B", "C", "D"):
        if k in raw:
            mats[k] = raw[k]
    if "A" not in mats or "C" not in mats:
        raise ConfigError(f"{path}: [model] needs at least A and C (inline or in file)")
    A = _matrix(mats["A"], "A", path)
    n = A.shape[0]
    if A.shape != (n, n):
        raise ConfigError(f"{path}: expected a square matrix for model.A, got {A.shape}")
    C = _matrix(mats["C"], "C", path)
    if C.shape[1] != n:
        raise ConfigError(
            f"{path}: expected a ({C.shape[0]}, {n}) matrix for model.C, got {C.shape}"
        )
    B = _matrix(mats["B"], "B", path) if "B" in mats else np.zeros((n, 0))
    if B.shape[0] != n:
        raise ConfigError(
            f"{path}: expected a ({n}, {B.shape[1]}) matrix for model.B, got {B.shape}"
        )
    D = _matrix(mats["D"], "D", path) if "D" in mats else np.zeros((C.shape[0], B.shape[1]))
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
    dt = raw.get("dt", mats.get("dt"))
    return {
        "A": A,
        "B": B,
        "C": C,
        "D": D,
        "dt": None if dt is None else float(dt),
        "outputs": outputs,
        "inputs": inputs,
    }


def load_config(path: str | Path | None, known_detectors: set[str] | None = None) -> Config:
    """Parse and validate ``path`` (None: the empty config)."""
    if path is None:
        return Config()
    p = Path(path)
    try:
        raw = tomllib.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ConfigError(f"--config: {p}: no such file") from None
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f"--config: {p}: cannot be read ({err})") from err
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(f"--config: {p}: not valid TOML ({err})") from err
    _unknown("", raw, _TOP, p)
    cfg = Config(path=p)
    if "train" in raw:
        t = raw["train"]
        if not isinstance(t, dict):
            raise ConfigError(f"{p}: [train] must be a table with start and end")
        _unknown("train.", t, _TRAIN, p)
        try:
            start = float(t.get("start", 0.0))
            end = float(t["end"])
        except (KeyError, TypeError, ValueError) as err:
            raise ConfigError(f"{p}: [train] needs numeric start and end seconds ({err})") from err
        if not end > start >= 0:
            raise ConfigError(f"{p}: [train] end ({end}) must be after start ({start}) >= 0")
        cfg.train = (start, end)
    for i, g in enumerate(raw.get("group", [])):
        if not isinstance(g, dict):
            raise ConfigError(f"{p}: [[group]] #{i + 1} must be a table")
        _unknown(f"group[{i}].", g, _GROUP, p)
        group: dict[str, Any] = {
            "name": str(g.get("name", f"group{i + 1}")),
            "channels": _names(g.get("channels", []), f"group[{i}].channels", p),
            "reference": _names(g.get("reference", []), f"group[{i}].reference", p),
            "uncertain": _names(g.get("uncertain", []), f"group[{i}].uncertain", p),
            "inputs": _names(g.get("inputs", []), f"group[{i}].inputs", p),
        }
        if not group["channels"]:
            group["channels"] = [*group["reference"], *group["uncertain"]]
        for earlier in cfg.groups:
            shared = [c for c in group["channels"] if c in earlier["channels"]]
            if shared:
                # each detector models a group on its own: a channel in two would be
                # analyzed (and reported) twice, under two different models
                raise ConfigError(
                    f"{p}: [[group]] {group['name']!r} and [[group]] {earlier['name']!r} "
                    f"share {', '.join(shared)}: a channel belongs to one group"
                )
        cfg.groups.append(group)
    if "model" in raw:
        cfg.model = load_model(raw["model"], p)
    dets = raw.get("detectors", {})
    if not isinstance(dets, dict):
        raise ConfigError(f"{p}: [detectors] must be a table of detector tables")
    for name, opts in dets.items():
        if known_detectors is not None and name not in known_detectors:
            raise ConfigError(
                f"{p}: unknown key 'detectors.{name}' (known detectors: "
                f"{', '.join(sorted(known_detectors))})"
            )
        if not isinstance(opts, dict):
            raise ConfigError(f"{p}: [detectors.{name}] must be a table of options")
        cfg.detectors[name] = dict(opts)
    th = raw.get("thresholds", {})
    _unknown("thresholds.", th, _THRESHOLDS, p)
    if "false_alarm_rate" in th:
        far = th["false_alarm_rate"]
        if not isinstance(far, (int, float)) or not 0.0 < float(far) < 0.5:
            raise ConfigError(f"{p}: thresholds.false_alarm_rate must be in (0, 0.5), got {far!r}")
        cfg.false_alarm_rate = float(far)
    return cfg
