"""Channel groups: which sensors the multi-sensor detectors analyze together.

The bank of Kalman estimators, the detection filter and the equivalent-model observers
each model all of their channels jointly: an AR model of order ``p`` over ``m`` channels
has ``p m`` states, and the bank solves one Riccati equation of that size per channel,
so their cost grows like ``m^4`` and their memory like ``m^3``. 16 channels of 10 minutes
fit in ~5 s; 48 took 83 s and 9.7 GB for the bank alone (measured, see the README). A
structure with hundreds of sensors is therefore analyzed in groups of sensors that see
the same structure (the contract's ``[[group]]``):

* the groups of the config file, as given (restricted to the analyzed channels): a
  group's ``channels`` with its reference and uncertain sensors and its measured
  ``inputs`` (the excitation belongs with the structure it excites: the detection
  filter of a ``[model]`` with measured inputs needs them beside its outputs);
* the analyzed channels in no configured group, when there are more than
  :data:`GROUP_SIZE` of them, cut into ``ceil(n / GROUP_SIZE)`` groups of near-equal
  size by their correlation in the training window: average-linkage clustering on
  ``1 - |r|`` with the optimal leaf ordering (scipy; Bar-Joseph et al. 2001) orders the
  channels so that the most correlated ones are adjacent, and the order is cut into
  consecutive runs. Sensors on the same floor, or on neighbouring floors, end up
  together (on a 48-floor building the plain dendrogram order put floors 0-2 with
  floors 24-27 and 32 in one group, and a group's model then missed the neighbours that
  predict a sensor best: one false finding at 96 channels that contiguous floors did not
  give):
  each sensor's estimators then have the sensors that predict it best. The ordering
  takes 0.2 s at 500 channels and 2.4 s at 1000.

A single leftover channel joins the configured group it correlates with most (a group of
one cannot be analyzed by detectors that estimate a sensor from the others).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.config import members as group_members

FloatArray = npt.NDArray[np.float64]

GROUP_SIZE = 16
"""Most channels the multi-sensor detectors analyze together when no ``[[group]]`` says
otherwise (the size the detectors' benchmarks are run at)."""


def partition(
    channels: Sequence[str],
    train: FloatArray,
    configured: Sequence[dict[str, Any]] = (),
    size: int = GROUP_SIZE,
    model: dict[str, Any] | None = None,
) -> tuple[list[tuple[str, ...]], list[str]]:
    """The channel groups of ``channels`` (in their order within each group) and notes.

    ``train``: the training window's values, one column per channel. ``configured``:
    the config's ``[[group]]`` tables (their channels, reference and uncertain sensors
    and inputs: :func:`analyzer.config.members`). One group holding every
    channel means the detectors run on all of them at once, as without grouping.
    ``model``: the config's ``[model]``; its measured inputs that no group names join
    the group of its outputs (the detection filter needs them together)."""
    if size < 2:
        raise ValueError(f"group size must be at least 2, got {size}")
    names = list(channels)
    index = {c: i for i, c in enumerate(names)}
    groups: list[list[int]] = []
    notes: list[str] = []
    placed: dict[str, str] = {}  # a shared measured input stays with its first group
    for g in configured:
        declared = group_members(g)
        for c in g.get("inputs", []):
            if c in placed and c in index:
                notes.append(
                    f"[[group]] {g.get('name', '?')}: its input {c} is analyzed with "
                    f"[[group]] {placed[c]} (a channel is modelled in one group)"
                )
        declared = [c for c in declared if c not in placed]
        placed.update({c: str(g.get("name", "?")) for c in g.get("inputs", []) if c not in placed})
        absent = [c for c in declared if c not in index]
        if absent:
            notes.append(
                f"[[group]] {g.get('name', '?')}: {', '.join(absent)} not analyzed (not in "
                "the archive, left out by --channels, or constant: over the record or in the "
                "training window)"
            )
        members = sorted({index[c] for c in declared if c in index})
        if len(members) >= 2:
            groups.append(members)
        elif members:
            notes.append(
                f"[[group]] {g.get('name', '?')}: only {names[members[0]]} of its channels "
                "is analyzed; a group needs two, so it is grouped as a channel in no [[group]]"
            )
    _join_model_inputs(groups, index, model)
    grouped = {i for g in groups for i in g}
    rest = [i for i in range(len(names)) if i not in grouped]
    if not groups and len(rest) <= size:
        return [tuple(names)], notes
    corr = _abs_correlation(train)
    if len(rest) == 1 and groups:
        i = rest[0]
        best = max(range(len(groups)), key=lambda k: float(np.mean(corr[i, groups[k]])))
        groups[best] = sorted([*groups[best], i])
        notes.append(
            f"{names[i]} is in no [[group]]: analyzed with the group of {names[groups[best][0]]}"
        )
    elif len(rest) >= 2:
        auto = _cut(rest, corr, size)
        groups.extend(auto)
        if len(auto) > 1:
            notes.append(
                f"{len(rest)} channels analyzed in {len(auto)} groups of at most {size} "
                "correlated sensors (each detector models one group at a time): "
                + "; ".join(", ".join(names[i] for i in g) for g in auto)
            )
    return [tuple(names[i] for i in g) for g in groups], notes


def _join_model_inputs(
    groups: list[list[int]], index: dict[str, int], model: dict[str, Any] | None
) -> None:
    """The ``[model]``'s measured inputs that are in no configured group join the group
    holding all of its analyzed outputs (in place), where there is one."""
    if not model or not groups or not model.get("inputs"):
        return
    outputs = {index[c] for c in model.get("outputs", []) if c in index}
    home = next((g for g in groups if outputs and outputs <= set(g)), None)
    if home is None:
        return
    grouped = {i for g in groups for i in g}
    extra = {index[c] for c in model["inputs"] if c in index and index[c] not in grouped}
    home[:] = sorted({*home, *extra})


def _cut(members: list[int], corr: FloatArray, size: int) -> list[list[int]]:
    """``members`` in ``ceil(n / size)`` groups of near-equal size, correlated channels
    together (see the module docstring); each group in the channels' order."""
    n = len(members)
    k = math.ceil(n / size)
    if k <= 1:
        return [sorted(members)]
    from scipy.cluster.hierarchy import leaves_list, linkage
    from scipy.spatial.distance import squareform

    sub = corr[np.ix_(members, members)]
    dist = np.clip(1.0 - sub, 0.0, None)
    np.fill_diagonal(dist, 0.0)
    dist = 0.5 * (dist + dist.T)
    # the optimal leaf ordering (Bar-Joseph, Gifford & Jaakkola 2001) puts the most similar
    # leaves next to each other: on a chain of sensors (the floors of a building) it
    # recovers the chain, where the plain dendrogram order mixed far floors into a group
    tree = linkage(squareform(dist, checks=False), method="average", optimal_ordering=True)
    order = leaves_list(tree)
    bounds = np.linspace(0, n, k + 1).round().astype(int)
    groups = [
        sorted(members[j] for j in order[a:b]) for a, b in zip(bounds, bounds[1:], strict=False)
    ]
    return sorted(groups, key=lambda g: g[0])


def _abs_correlation(train: FloatArray) -> FloatArray:
    """``|r|`` between the columns of ``train`` over its rows without a NaN (0 where a
    column does not vary there, 1 on the diagonal)."""
    x = np.asarray(train, dtype=np.float64)
    x = x[np.isfinite(x).all(axis=1)]
    m = x.shape[1]
    if x.shape[0] < 2:
        out = np.zeros((m, m))
    else:
        x = x - x.mean(axis=0)
        sd = np.sqrt((x * x).sum(axis=0))
        sd[sd == 0] = np.inf
        out = np.abs((x.T @ x) / np.outer(sd, sd))
    np.fill_diagonal(out, 1.0)
    return np.asarray(out, dtype=np.float64)


__all__ = ["GROUP_SIZE", "partition"]
