"""One sign per quaternion, kept along time.

A rotation is given by a unit quaternion ``q`` and equally by ``-q``: both turn a vector
the same way. A ROS ``geometry_msgs/Quaternion`` (``pose.orientation``,
``transform.rotation``) and Foxglove's quaternion are written by their publishers with
whichever sign their maths gave, and motion-capture systems and pose estimators change it
from one message to the next when the rotation passes half a turn. Each of the four
channels ``x``, ``y``, ``z``, ``w`` then jumps (``ROS_example.bag``'s ground truth,
``orientation.y`` from +0.991 to -0.991 at 498.004 s), which the detectors took for an
offset of -1.87 on a sensor that did not fail (the ux52 audit), and the aligner's
interpolation across the jump made quaternions far from unit length.

:class:`QuaternionSigns` makes the sign continuous before the samples are stored: a
message's quaternion is negated (all four fields) where its dot product with the one
before it, as kept, is negative. It works on what the ROS and MCAP readers' reorderer
releases, each channel's samples in time order (the messages are decoded in the order of
the file's chunks, which may overlap in time: ``ROS_example.bag`` has a chunk of
9.5-889 s read before one of 425-814 s). Vectorized over a release: the sign of each dot
product of consecutive raw quaternions, their cumulative product the sign each is kept
with, the last quaternion kept carried to the next release (no Python per message).

A quaternion is recognised by its channels' names: the channels of one topic under a
prefix (a field such as ``pose.orientation``, or the topic itself) are exactly ``.x``,
``.y``, ``.z`` and ``.w``, released at the same times. A quaternion of zero length or
with a field not finite (unset, missing) keeps its value and takes no part. Each input is
made continuous on its own (the storage files of a split ROS 2 bag together): the first
message of a file keeps its sign (inputs are read ahead on threads, so no sign can be
carried from the file before).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from analyzer.errors import counted
from analyzer.readers.base import ChannelChunk

if TYPE_CHECKING:
    from analyzer.readers.base import InputInfo

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

FIELDS = ("x", "y", "z", "w")
"""The fields of a quaternion, in the order kept."""


@dataclass(slots=True)
class Flips:
    """What was done to one quaternion of a topic: ``changes`` (times its sign changed
    from one message to the next, each undone) and ``negated`` (messages kept negated) of
    ``messages`` seen."""

    changes: int = 0
    negated: int = 0
    messages: int = 0


def continuous(q: FloatArray, last: FloatArray | None) -> tuple[FloatArray, int]:
    """``q`` (rows of ``x, y, z, w`` in time order) with each row's sign chosen so that
    its dot product with the row before it (with ``last``, the quaternion kept before
    ``q``'s first row, where there is one) is not negative; and the number of sign
    changes undone. Rows not finite or of zero length are kept as they are and skipped."""
    finite = np.all(np.isfinite(q), axis=1, keepdims=False).astype(bool)
    zeroed = np.where(finite[:, None], q, 0.0)
    usable = finite & (np.einsum("ij,ij->i", zeroed, zeroed) > 0.0)
    rows = np.flatnonzero(usable)
    if rows.size == 0:
        return q, 0
    good = q[rows]
    before = np.empty_like(good)
    before[0] = good[0] if last is None else last
    before[1:] = good[:-1]
    dots = np.einsum("ij,ij->i", good, before)
    step = np.where(dots < 0.0, -1.0, 1.0)
    sign = np.cumprod(step)
    if not bool((sign < 0).any()):
        return q, 0
    out = q.copy()
    out[rows] = good * sign[:, None]
    return out, int(np.count_nonzero(step < 0))


class QuaternionSigns:
    """The quaternions of one input's topics made continuous in sign (:func:`continuous`)
    as its :class:`~analyzer.readers._common.Reorderer` releases them (in time order,
    each channel's samples after those released before), release after release; what was
    done, per quaternion, for the run's note (:meth:`changed`)."""

    def __init__(self, relabelled: Callable[[], list[str]] | None = None) -> None:
        self._relabelled = relabelled
        """The prefixes of the channels whose meaning changes between messages so far
        (:meth:`~analyzer.readers._common.TopicTracker.relabelled`)."""
        self._last: dict[str, FloatArray] = {}
        self._kind: dict[str, bool] = {}
        """Per prefix of channel names: whether its channels are a quaternion's."""
        self.flips: dict[str, Flips] = {}

    def released(
        self, chunks: Iterable[ChannelChunk], topics: Mapping[str, str]
    ) -> Iterator[ChannelChunk]:
        """``chunks`` (one release: each channel's next samples in time order) with each
        quaternion's sign made continuous with the samples released before; ``topics``
        (every channel pushed so far, to its topic) tells which channels are one
        message's fields. A quaternion's four channels are held until all four have come
        (one after the other: the fields of one message share their times); the others
        pass through at once, and so does, from the release on where it is known, one
        whose meaning changes between messages (``/tf.transforms[0]`` holding one
        frame's rotation, then another's: no sign can follow one rotation there)."""
        waiting: dict[str, dict[str, ChannelChunk]] = {}
        mixed: tuple[str, ...] | None = None
        for chunk in chunks:
            prefix, _, leaf = chunk.name.rpartition(".")
            if leaf not in FIELDS or not self._quaternion(prefix, chunk.name, topics):
                yield chunk
                continue
            if mixed is None:
                mixed = tuple(self._relabelled()) if self._relabelled is not None else ()
            if prefix.startswith(mixed):  # (several frames' rotations in turn: left alone)
                yield chunk
                continue
            group = waiting.setdefault(prefix, {})
            group[leaf] = chunk
            if len(group) == len(FIELDS):
                del waiting[prefix]
                yield from self._continued(prefix, [group[f] for f in FIELDS])
        for group in waiting.values():  # (not all four released: as they came)
            yield from group.values()

    def _continued(self, prefix: str, parts: list[ChannelChunk]) -> list[ChannelChunk]:
        """A quaternion's four chunks (``x, y, z, w``) made continuous in sign."""
        t = parts[0].t_ns
        if any(not _same_times(t, p.t_ns) for p in parts[1:]):
            return parts
        q = np.column_stack([p.values for p in parts])
        kept, changes = continuous(q, self._last.get(prefix))
        seen = self.flips.setdefault(prefix, Flips())
        seen.messages += int(q.shape[0])
        usable = np.flatnonzero(np.isfinite(kept).all(axis=1))
        if usable.size:
            self._last[prefix] = kept[usable[-1]].copy()
        if kept is q:
            return parts
        seen.changes += changes
        seen.negated += int(np.count_nonzero(np.einsum("ij,ij->i", kept, q) < 0))
        return [
            ChannelChunk(p.name, p.t_ns, np.ascontiguousarray(kept[:, j]))
            for j, p in enumerate(parts)
        ]

    def _quaternion(self, prefix: str, name: str, topics: Mapping[str, str]) -> bool:
        """Whether the channels under ``prefix`` (``name`` one of them) are exactly one
        topic's ``.x``, ``.y``, ``.z``, ``.w`` (decided once per prefix)."""
        kind = self._kind.get(prefix)
        if kind is None:
            topic = topics.get(name, "")
            head = f"{prefix}."
            fields = sorted(
                n[len(head) :] for n, tp in topics.items() if n.startswith(head) and tp == topic
            )
            kind = self._kind[prefix] = bool(prefix) and fields == sorted(FIELDS)
        return kind

    def changed(self) -> dict[str, Flips]:
        """The quaternions whose sign was changed, by the prefix of their channels'
        names (``/imu.orientation``)."""
        return {prefix: seen for prefix, seen in self.flips.items() if seen.changes}


def _same_times(a: IntArray, b: IntArray) -> bool:
    return a is b or (a.shape == b.shape and bool(np.array_equal(a, b)))


def flipped_note(inputs: Sequence[InputInfo], chosen: Sequence[str]) -> str:
    """The run's note on the quaternions of ``inputs`` made continuous in sign
    (:attr:`InputInfo.sign_flips`) of which a channel is analyzed (``chosen``), or
    ``""`` when none was."""
    names = set(chosen)
    flips: dict[str, Flips] = {}
    for info in inputs:
        for prefix, f in info.sign_flips.items():
            if not any(f"{prefix}.{x}" in names for x in FIELDS):
                continue
            seen = flips.setdefault(prefix, Flips())
            seen.changes += f.changes
            seen.negated += f.negated
            seen.messages += f.messages
    if not flips:
        return ""
    said = "; ".join(
        f"{prefix}.{{x,y,z,w}}: {counted(f.changes, 'sign change')}, "
        f"{f.negated} of {counted(f.messages, 'message')} negated"
        for prefix, f in sorted(flips.items())
    )
    return (
        "quaternions whose sign changed between messages (q and -q are the same "
        "rotation) were made continuous before the analysis, each message's four fields "
        f"negated where its dot product with the one before was negative: {said}"
    )
