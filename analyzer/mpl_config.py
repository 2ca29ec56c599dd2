"""Where matplotlib keeps its settings and font cache when the user's home cannot be written.

matplotlib keeps both in ``$XDG_CONFIG_HOME/matplotlib`` and ``$XDG_CACHE_HOME/matplotlib``
(``~/.config`` and ``~/.cache`` by default). Where it cannot make them, as for a service
account (``nobody``, a systemd ``DynamicUser``, a container's user) whose HOME does not
exist or is read-only, it prints two warnings on stderr and makes a ``matplotlib-XXXXXXXX``
folder in the temporary directory, removed at interpreter exit. The report's figure
workers import matplotlib in a fork server that ends without that clean-up, so every
``analyzer run`` left one such folder behind, and the user saw matplotlib's lines before
the analyzer's own.

:func:`ensure_config_dir` sees that case first and sets ``MPLCONFIGDIR`` to a private
folder of the temporary directory, ``analyzer-mpl-UID``, the way
:mod:`analyzer.numba_cache` does for numba: mode 0700, used only when it is a real folder
owned by this user that no one else can write, else a fresh folder of its own. The
environment is inherited by the figure workers. The folder stays, so the font cache is
built once, not at every run. An explicit ``MPLCONFIGDIR`` is always left alone.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from analyzer.numba_cache import _writable, private_dir

PREFIX = "analyzer-mpl"


def _home_folder(environ: Mapping[str, str], variable: str, default: str) -> Path | None:
    """matplotlib's folder under ``$variable`` (else ``~/default``); None when there is
    no home to put it in."""
    base = environ.get(variable)
    if not base:
        home = environ.get("HOME") or os.path.expanduser("~")
        if not home or home.startswith("~"):
            return None
        base = os.path.join(home, default)
    return Path(base) / "matplotlib"


def needs_fallback(environ: Mapping[str, str]) -> bool:
    """True when matplotlib would make a temporary folder of its own: no ``MPLCONFIGDIR``,
    and its settings or cache folder cannot be made or written."""
    if environ.get("MPLCONFIGDIR"):
        return False
    for variable, default in (("XDG_CONFIG_HOME", ".config"), ("XDG_CACHE_HOME", ".cache")):
        folder = _home_folder(environ, variable, default)
        if folder is None or not _writable(folder):
            return True
    return False


def ensure_config_dir() -> str | None:
    """Set ``MPLCONFIGDIR`` to a private folder when matplotlib could not use the user's
    own; the folder, or None when nothing had to be done. Never raises: a failure leaves
    matplotlib to its own fallback."""
    try:
        if not needs_fallback(os.environ):
            return None
        folder = private_dir(PREFIX)
    except OSError:
        return None
    os.environ["MPLCONFIGDIR"] = folder
    return folder
