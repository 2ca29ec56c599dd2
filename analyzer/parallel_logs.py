"""Dask's own log lines, kept off stderr while a run uses a cluster.

When a worker dies mid-run, distributed logs in this process what it does about it, on
stderr through its own handlers, among the analyzer's one-line messages: ``distributed.client
- WARNING - Couldn't gather 1 keys, rescheduling (...)``; when the scheduler goes,
``distributed.batched - INFO - Batched Comm Closed ...`` with a traceback and
``distributed.client - ERROR - Failed to reconnect to scheduler after 10.00 seconds,
closing client``; with a cluster in this process (tests), its scheduler's and nannies'
lines too. The run works around those losses (:class:`~analyzer.parallel_dask.DaskExecutor`:
tasks sent again, or computed here, with the undisturbed results) and its findings say
so; an error that does end the run reaches the user as the analyzer's own line (the
exception is never held). So Dask's lines are noise on stderr.

A :class:`DaskLog` holds them while it is open: every record of the ``distributed`` and
``tornado`` loggers (tornado carries Dask's connections) that would have reached a
handler is kept in the log instead, the last :data:`KEPT_LINES` of them formatted as Dask
formats them, and every handler is as it was once the last open log closes (the library
also runs inside tests and the watcher, which may use Dask's logging themselves). Other
loggers' records pass as before. With ``ANALYZER_DEBUG`` set (the CLI's switch for
tracebacks) nothing is held.
"""

from __future__ import annotations

import logging
import os
import threading
from collections import deque

KEPT_LINES = 200
"""Lines a :class:`DaskLog` keeps (the latest): a long watch keeps a bounded log."""

DEBUG_ENV = "ANALYZER_DEBUG"
"""Set (to anything), Dask's log lines reach stderr as they would without the analyzer."""

DASK_LOGGERS = ("distributed", "tornado")
"""The loggers (with their children) whose records a :class:`DaskLog` holds."""

_FORMAT = logging.Formatter("%(asctime)s - %(name)s - %(levelname)s - %(message)s")
"""Dask's own format (``distributed.admin.log-format``)."""


def _from_dask(name: str) -> bool:
    return any(name == root or name.startswith(f"{root}.") for root in DASK_LOGGERS)


class DaskLog:
    """Dask's log records while open (:meth:`open` to :meth:`close`): ``lines`` the last
    :data:`KEPT_LINES` of them, formatted, ``count`` how many there were in all."""

    def __init__(self) -> None:
        self.lines: deque[str] = deque(maxlen=KEPT_LINES)
        self.count = 0
        self._is_open = False
        self._lock = threading.Lock()

    def open(self) -> DaskLog:
        """Hold Dask's records from now on (unless ``ANALYZER_DEBUG`` is set); itself."""
        if os.environ.get(DEBUG_ENV):
            return self
        with _state_lock:
            if not self._is_open:
                self._is_open = True
                _open_logs.append(self)
            # every open looks again: a handler added since (a cluster started in this
            # process configures one) is held too
            for handler in _reachable_handlers():
                if _HOLD not in handler.filters:
                    handler.addFilter(_HOLD)
                    _held_handlers.append(handler)
        return self

    def close(self) -> None:
        """Stop holding (idempotent); the handlers are as before once no log is open."""
        with _state_lock:
            if not self._is_open:
                return
            self._is_open = False
            _open_logs.remove(self)
            if not _open_logs:
                for handler in _held_handlers:
                    handler.removeFilter(_HOLD)
                _held_handlers.clear()

    def _keep(self, record: logging.LogRecord) -> None:
        try:
            line = _FORMAT.format(record)
        except Exception:  # noqa: BLE001 - a record whose arguments do not format
            line = f"{record.name} - {record.levelname} - {record.msg!r}"
        with self._lock:
            self.count += 1
            self.lines.append(line)


class _Hold(logging.Filter):
    """On every handler a Dask record can reach while a log is open: Dask's records are
    handed to the open logs (once, however many handlers they reach) and go no further;
    the others pass."""

    def filter(self, record: logging.LogRecord) -> bool:
        if not _from_dask(record.name):
            return True
        if not getattr(record, "_analyzer_held", False):
            setattr(record, "_analyzer_held", True)  # noqa: B010 - not a LogRecord field
            for log in tuple(_open_logs):
                log._keep(record)
        return False


_HOLD = _Hold()
_state_lock = threading.Lock()
_open_logs: list[DaskLog] = []
_held_handlers: list[logging.Handler] = []
"""The handlers :data:`_HOLD` was added to, to be taken off when the last log closes."""


def _reachable_handlers() -> list[logging.Handler]:
    """Every handler a record of a Dask logger reaches now: those of the Dask loggers
    (distributed gives each configured one its own) and of their ancestors up to where
    propagation stops (a root handler, when logging is configured to propagate), and
    the last resort (what prints a record no handler takes)."""
    manager = logging.Logger.manager
    found: dict[int, logging.Handler] = {}
    for name, logger in list(manager.loggerDict.items()):
        if not isinstance(logger, logging.Logger) or not _from_dask(name):
            continue  # (a placeholder: a parent no logger was asked for by name)
        node: logging.Logger | None = logger
        while node is not None:
            for handler in node.handlers:
                found.setdefault(id(handler), handler)
            if not node.propagate:
                break
            node = node.parent
    if logging.lastResort is not None:
        found.setdefault(id(logging.lastResort), logging.lastResort)
    return list(found.values())


__all__ = ["DASK_LOGGERS", "DEBUG_ENV", "KEPT_LINES", "DaskLog"]
