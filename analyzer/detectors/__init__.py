"""Detectors: each turns the aligned archive into residuals and events.

Adding a detector is adding its module and one line in :data:`REGISTRY` (the method
it builds on may have modules of its own: the bank's estimators in
:mod:`~analyzer.detectors.kalman_bank`, the detection filter's design in
:mod:`~analyzer.detectors.beard_jones`, the equivalent model's observers in
:mod:`~analyzer.detectors.assistant_observer`, the error functions' inverse model in
:mod:`~analyzer.detectors.decoupling`).
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

from analyzer.detectors.base import (
    Dataset,
    Detector,
    DetectorResult,
    Event,
    RunContext,
)
from analyzer.errors import UsageError

REGISTRY: dict[str, str] = {
    "ar_kalman_bank": "analyzer.detectors.ar_kalman:ARKalmanBank",
    "error_function": "analyzer.detectors.error_function:ErrorFunction",
    "detection_filter": "analyzer.detectors.detection_filter:DetectionFilter",
    "equivalent_model": "analyzer.detectors.equivalent_model:EquivalentModel",
}
"""Detector name -> ``module:Class`` (imported on first use)."""


def detector_class(name: str) -> Any:
    """The detector class registered as ``name``."""
    try:
        target = REGISTRY[name]
    except KeyError:
        known = ", ".join(sorted(REGISTRY))
        raise UsageError(f"--detectors: unknown detector {name!r} (known: {known})") from None
    module, _, cls = target.partition(":")
    return getattr(import_module(module), cls)


__all__ = [
    "REGISTRY",
    "Dataset",
    "Detector",
    "DetectorResult",
    "Event",
    "RunContext",
    "detector_class",
]
