"""Connecting to a Dask scheduler for ``--scheduler``: the address checked, the client
started, a worker waited for, each a one-line :class:`~analyzer.errors.UsageError` naming
``--scheduler`` when it fails, and none of them waiting forever.

Dask's client waits for the scheduler's handshake without a limit, so it starts on a
thread of its own (:func:`_connect`) that the caller waits for with a deadline, and that
a signal (the watcher's ``stop``) or an interrupt ends at once. Used by
:class:`~analyzer.parallel_dask.DaskExecutor`.
"""

from __future__ import annotations

import contextlib
import os
import re
import socket
import threading
import time
from typing import Any

from analyzer.errors import UsageError

CONNECT_MARGIN_S = 2.0
"""Beyond the connection timeout, how long the connecting thread is given to say so."""


_LIST_REPR = re.compile(r"\[((?:'[^'\[\]]*'(?:, )?)+)\]")
"""A Python list of strings in a message (``['inproc', 'tcp']``)."""


def plain_lists(text: str) -> str:
    """``text`` with each Python list of strings in it as plain words: Dask's "unknown
    address scheme 'http' (known schemes: ['inproc', 'tcp', ...])" ended a user's error
    line with a list's repr (a new user's audit, ux53 item 13)."""
    return _LIST_REPR.sub(lambda m: m.group(1).replace("'", ""), text)


def _other_protocol(err: BaseException) -> bool:
    """Whether ``err`` (from starting a client) is Dask reading another protocol's bytes
    as its own: an HTTP server's ``HTTP/1.1`` read as a frame count asked numpy for
    "3.07 EiB" (the message the user got, ux62 LOW 9), or bytes that do not decode."""
    if isinstance(err, MemoryError | UnicodeDecodeError | EOFError):
        return True
    return type(err).__module__.split(".")[0] in ("msgpack", "struct", "_struct")


def _quiet_close(client: Any) -> None:
    """Close a client whose start failed, so its finalizer has nothing left to report."""
    with contextlib.suppress(Exception):  # best effort on an already broken client
        client.close(timeout=2)


def _close_later(client: Any) -> None:
    """:func:`_quiet_close` on a thread of its own: a client stuck in its start is not
    waited for (it is closed so that the process's end does not wait for it either)."""
    threading.Thread(
        target=_quiet_close, args=(client,), name="analyzer-dask-close", daemon=True
    ).start()


def _connect(
    address: str, wait: float, stop: threading.Event | None
) -> tuple[Any, dict[str, Any], dict[str, str | None]]:
    """A client of the scheduler at ``address``, its ``scheduler_info()`` and each
    worker's BLAS setting, or :class:`UsageError` naming ``--scheduler``.

    Dask's client waits for the scheduler's handshake without a limit whatever its
    ``timeout`` (a server that accepts the connection and says nothing held ``run``
    forever), so the client starts on a thread of its own that this one waits for at
    most ``wait`` seconds (and a margin) for the connection, as long again for a worker;
    ``stop`` set (the watcher's signal handler) or an interrupt (``run``'s) ends the
    wait at once with :class:`KeyboardInterrupt`."""
    from distributed import Client

    client = Client.__new__(Client)
    outcome: list[Any] = []
    connected: list[float] = []
    done = threading.Event()

    def start() -> None:
        try:
            try:
                client.__init__(address, timeout=wait, set_as_default=False)  # type: ignore[misc]
            except Exception as err:  # whatever answered there, it is not a usable scheduler
                why = plain_lists(" ".join(str(err).split()))[:200] or type(err).__name__
                if _other_protocol(err):
                    why = "no Dask scheduler answered there: the service there speaks another"
                    why += " protocol"
                elif not isinstance(err, OSError | TimeoutError):
                    why = f"no Dask scheduler answered there: {why}"
                raise UsageError(f"--scheduler {address}: cannot connect ({why})") from err
            connected.append(time.monotonic())
            info = client.scheduler_info()
            if not info.get("workers"):  # workers may still be starting: wait for one
                try:
                    client.wait_for_workers(1, timeout=wait)
                except Exception as err:  # noqa: BLE001 - Dask's timeout types vary by version
                    raise UsageError(
                        f"--scheduler {address}: no worker is connected to the scheduler "
                        f"(waited {wait:g} s); start some with 'dask worker {address}'"
                    ) from err
                info = client.scheduler_info()
            blas = dict(client.run(blas_threads_setting)) if info.get("workers") else {}
            outcome.append((info, blas))
        except BaseException as err:  # handed to the waiting thread
            outcome.append(err)
        finally:
            done.set()

    thread = threading.Thread(target=start, name="analyzer-dask-connect", daemon=True)
    began = time.monotonic()
    try:
        thread.start()
        while not done.wait(0.1):
            if stop is not None and stop.is_set():
                raise KeyboardInterrupt
            now = time.monotonic()
            if not connected and now - began > wait + CONNECT_MARGIN_S:
                raise UsageError(
                    f"--scheduler {address}: cannot connect (no answer within {wait:g} s)"
                )
            if connected and now - connected[0] > wait + 2 * CONNECT_MARGIN_S:
                raise UsageError(
                    f"--scheduler {address}: the scheduler stopped answering "
                    f"(waited {now - began:.0f} s)"
                )
    except BaseException:
        _close_later(client)
        raise
    result = outcome[0]
    if isinstance(result, BaseException):
        _close_later(client)
        raise result
    info, blas = result
    return client, info, blas


def _probe(address: str, timeout: float) -> None:
    """Check ``address`` is a scheduler address and, over TCP, that something listens
    there: an unreachable scheduler fails at once with a clear message (rather than
    after the client's retries)."""
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, location = parse_address(address)
        if scheme not in ("tcp", "tls"):
            return
        host, port = parse_host_port(location)
    except ValueError as err:
        raise UsageError(
            f"--scheduler {address}: expected an address like tcp://HOST:PORT ({err})"
        ) from err
    try:
        with socket.create_connection((host, port), timeout=timeout):
            pass
    except OSError as err:
        why = err.strerror or " ".join(str(err).split()) or type(err).__name__
        raise UsageError(f"--scheduler {address}: cannot connect ({why})") from err


def blas_threads_setting() -> str | None:
    """``OPENBLAS_NUM_THREADS`` of the process that runs this (asked of each worker)."""
    return os.environ.get("OPENBLAS_NUM_THREADS")
