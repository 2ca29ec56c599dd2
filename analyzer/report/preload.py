"""What a fork server imports so the processes it forks draw figures without importing
matplotlib first: the figure module, if it imports at all.

A fork server stops on any error but ``ImportError`` in its preloaded modules, and with it
every process it was to fork: the watcher's analyses, not only their figures. An error
here (a broken matplotlib configuration, say) is therefore left for the process that draws
to meet, and report, where it does.
"""

from __future__ import annotations

import contextlib
import importlib

from analyzer.report.jobs import FIGURES_MODULE

with contextlib.suppress(Exception):
    importlib.import_module(FIGURES_MODULE)
