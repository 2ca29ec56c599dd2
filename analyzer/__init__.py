"""analyzer: post-hoc sensor fault audit of SHM and robot logs.

Data flows one way: readers -> store -> detectors -> diagnosis -> report.
"""

__version__ = "0.1.0"

from analyzer.errors import (
    AnalyzerError,
    ConfigError,
    DetectorError,
    ReaderError,
    StoreError,
    UsageError,
)

__all__ = [
    "AnalyzerError",
    "ConfigError",
    "DetectorError",
    "ReaderError",
    "StoreError",
    "UsageError",
    "__version__",
]
