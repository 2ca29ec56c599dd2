"""What the watcher's fork server imports so that the analyses it forks find the compiled
kernels ready (:func:`analyzer.warm.warm`, run once here). A fork server stops on any
error but ``ImportError`` in its preloaded modules; :func:`~analyzer.warm.warm` raises
none."""

from __future__ import annotations

from analyzer.warm import warm

WARMED = warm()
"""Whether the warm-up went through (it is harmless either way)."""
