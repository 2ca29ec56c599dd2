"""What a cluster task is made of: the functions that run on a worker, the size of what
goes with a task, and which errors are the cluster's rather than the task's.

Used by :class:`~analyzer.parallel_dask.DaskExecutor`. The functions here that run on a
worker (:func:`_apply`, :func:`_on_worker`) are sent by reference, so they stay
module-level and picklable.
"""

from __future__ import annotations

import pickle
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

from analyzer.errors import one_line
from analyzer.paging import heap_tuned

R = TypeVar("R")


def _apply(fn: Callable[[tuple[Any, ...]], R], *parts: Any) -> R:
    """``fn`` on the tuple of ``parts`` (a task of :func:`~analyzer.parallel_dask._stream_on`)."""
    with heap_tuned():
        return fn(parts)


def _on_worker(fn: Callable[..., R], *args: Any) -> R:
    """``fn(*args)`` as a task on a worker, whose heap Dask leaves set to give every freed
    block back to the kernel (:func:`~analyzer.paging.heap_tuned`: twice the CPU)."""
    with heap_tuned():
        return fn(*args)


class _Sizer(pickle.Pickler):
    """Pickles into nothing, counting bytes: an array (a memory-mapped one too) counts
    its ``nbytes`` without its data being read or copied."""

    def __init__(self) -> None:
        self.size = 0
        super().__init__(self, protocol=pickle.HIGHEST_PROTOCOL)

    def write(self, data: bytes) -> int:  # the file pickled into: itself
        self.size += len(data)
        return len(data)

    def reducer_override(self, obj: Any) -> Any:
        if isinstance(obj, np.ndarray):
            self.size += obj.nbytes
            return np.empty, (0,)
        return NotImplemented


def _pickled_nbytes(x: Any) -> int:
    """About the bytes ``x`` takes pickled, its arrays counted, not read; 0 when plain
    pickle cannot take it (Dask's cloudpickle packs it with the task)."""
    sizer = _Sizer()
    try:
        sizer.dump(x)
    except Exception:  # noqa: BLE001 - whatever plain pickle refuses
        return 0
    return sizer.size


def _said(err: BaseException) -> str:
    """``err``'s message on one line (at most 200 characters), else its type's name."""
    try:
        return one_line(str(err))[:200] or type(err).__name__
    except Exception:  # noqa: BLE001 - a message that cannot be formatted
        return type(err).__name__


def _killed_worker(err: BaseException) -> bool:
    return type(err).__name__ == "KilledWorker" and type(err).__module__.startswith("distributed")


def _raise_unless_from_the_cluster(err: Exception) -> None:
    """Re-raise ``err`` (from sending a task or its data) unless it is the cluster's
    trouble: what cannot be pickled is a bug here, not a lost worker."""
    if isinstance(err, TypeError | pickle.PicklingError):
        raise err


def _tasks(n: int) -> str:
    return f"{n} task{'s' if n != 1 else ''}"
