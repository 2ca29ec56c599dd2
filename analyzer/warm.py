"""Compiled kernels made ready before an analysis needs them.

The first call of a numba-compiled function in a process costs about 0.3 s even when its
machine code comes from numba's cache: numba's code generator starts then (every later
kernel loads in ~10 ms). :func:`warm` pays that once, on tiny inputs, for the kernels of
every run (the alarm statistic in double and single precision, the windowed innovation
tests). The watcher's fork server imports :mod:`analyzer.warm_preload`, which calls it,
so each analysis process forked from the server starts with them ready instead of paying
it per archive.

A warm-up is never an error: whatever it raises is dropped, and the analysis then pays
the cost where it would have anyway.
"""

from __future__ import annotations

import contextlib


def warm() -> bool:
    """Call the hot compiled kernels once on tiny inputs; False if any step failed."""
    with contextlib.suppress(Exception):
        import numpy as np

        from analyzer.diagnosis.changes import alarm_statistic, calibrate
        from analyzer.stats.windowed import windowed_tests

        x = np.sin(np.arange(4000) * 0.37) + np.cos(np.arange(4000) * 0.011)
        cal = calibrate(x, 20, 1e-3)
        for dtype in (np.float64, np.float32):
            alarm_statistic(x.astype(dtype), cal, raw=True)
            windowed_tests(x.astype(dtype), 100, standardize=(0.0, 1.0))
        return True
    return False
