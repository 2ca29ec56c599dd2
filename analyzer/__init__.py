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
from analyzer.numba_cache import ensure_cache_dir

# before any kernel is compiled: a read-only install run by a user with no writable
# cache folder (a service account) gets a private one instead of an import error
ensure_cache_dir()

__all__ = [
    "AnalyzerError",
    "ConfigError",
    "DetectorError",
    "ReaderError",
    "StoreError",
    "UsageError",
    "__version__",
]
