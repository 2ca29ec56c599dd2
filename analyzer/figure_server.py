"""The report's figure workers' fork server, startable before anything heavy is imported.

The CLI's ``run`` starts it first thing (:func:`start_server`), before it imports the
report and the pipeline: importing those is about a second of start-up on one core
(``analyzer.report`` alone pulls in the diagnosis, numba and scipy), and the server's own
preload (matplotlib and the figure module, 1.3-1.4 s of CPU) then runs on the core that
start-up leaves idle, rather than beside the run's reading, later, where both cores have
work. :class:`analyzer.report.workers.FigureWorkers` starts it the same way where the CLI
did not, and stops it when it was started here (:func:`claim_server`).

This module imports nothing of the analyzer and nothing outside the standard library.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import multiprocessing.forkserver
import os

PRELOAD_MODULE = "analyzer.report.preload"
"""What fork servers preload: the figure module, without stopping on its errors."""
NICENESS = 10
"""How much lower than the run the figure processes are scheduled (see
:func:`start_server`)."""

_unclaimed: int | None = None
"""The pid of a server :func:`start_server` started that no figure pool has claimed."""


def start_server() -> None:
    """Start the fork server, with :data:`PRELOAD_MODULE` preloaded, unless one runs (a
    fork and exec: milliseconds; its imports then run on their own). A server started
    here runs :data:`NICENESS` below this process, and its forked workers inherit that:
    its imports should take a core the run leaves idle, not compete with the run's
    reading (a CSV archive is parsed on every core); the figures are needed only at the
    end, when the workers have the cores to themselves. Without the permission or the
    call, the server keeps its priority. Raises what starting the server raises
    (``ValueError`` where there is no ``forkserver``, ``OSError``...)."""
    global _unclaimed
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload([PRELOAD_MODULE])
    server = getattr(multiprocessing.forkserver, "_forkserver", None)
    fresh = getattr(server, "_forkserver_pid", 0) is None
    multiprocessing.forkserver.ensure_running()
    if fresh:
        pid = getattr(server, "_forkserver_pid", None)
        if pid is not None:
            with contextlib.suppress(AttributeError, OSError):
                os.setpriority(os.PRIO_PROCESS, pid, os.getpriority(os.PRIO_PROCESS, 0) + NICENESS)
        _unclaimed = pid


def claim_server() -> bool:
    """Whether the running fork server was started by :func:`start_server` and no one has
    claimed it yet (the caller then stops it when done); claims it. False for a server
    started otherwise (the watcher's), which its starter stops."""
    global _unclaimed
    server = getattr(multiprocessing.forkserver, "_forkserver", None)
    pid = getattr(server, "_forkserver_pid", None)
    mine = _unclaimed is not None and pid == _unclaimed
    _unclaimed = None
    return mine
