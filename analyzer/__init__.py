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
from analyzer.mpl_config import ensure_config_dir
from analyzer.numba_cache import ensure_cache_dir

# before any kernel is compiled: a read-only install run by a user with no writable
# cache folder (a service account) gets a private one instead of an import error
ensure_cache_dir()
# before matplotlib is imported here or in the figure workers (which inherit the
# environment): such a user gets a private settings folder instead of matplotlib's
# warnings and a temporary folder left behind at every run
ensure_config_dir()

__all__ = [
    "AnalyzerError",
    "ConfigError",
    "DetectorError",
    "ReaderError",
    "StoreError",
    "UsageError",
    "__version__",
]
