"""The sensor network of Wang & Song (2014, Section 6): which sensors serve as assistant
sensors for which target sensors, the roles and structures this graph has, and the
diagnosis laws 0-4 that isolate a single sensor fault from the pattern of residual alarms.

Graph (Section 6.1)
-------------------
``O_i: xbar_i(s_ass_1, ..., s_ass_q) -> x_i(s_i)``: the observer of target sensor ``s_i`` takes
its assistant state from the assistant sensors; an edge runs from every assistant sensor to
its target (the *positive order*). Sensor roles:

* dot: no assistant sensors and no target sensors;
* head: no assistant sensors, but target sensors;
* foot: assistant sensors, but no target sensors;
* link: both.

Structures: *dots* (dot-sensors), *circles* (cycles of link-sensors; here any strongly
connected set of two or more sensors), *lines* (from a head-sensor along the positive order
to a foot-sensor) and *branches* (lines hanging from a link- or head-sensor that already
belongs to a circle or a line).

Diagnosis logic (Section 6.2), under the paper's assumption of one fault at a time
----------------------------------------------------------------------------------
* Law 0: if all assistant sensors' residuals of a (non-head) sensor are 0, its residual is
  influenced only by its own fault.
* Law 1: a dot-sensor cannot be diagnosed by the observers.
* Law 2: in a line, a non-zero residual indicates its target sensor's fault if all its
  upstream sensors' residuals are 0; head-sensors cannot be diagnosed by the observers.
* Law 3: in a circle a fault makes every residual of the circle non-zero; choosing one
  sensor as *quasi-head* (diagnosed by estimation) turns the circle into a line (Law 2).
* Law 4: a branch is a line once the sensor it hangs from is diagnosed.

Where law 0 isolates no sensor (every alarming residual depends on an alarming sensor),
the smallest sets of one or two alarming sensors whose faults explain every alarm are
sought: a sensor in every such set is faulty, one in some of them ambiguous
(:meth:`SensorNetwork.diagnose`). So two faults from the same instant, which the paper's
one-at-a-time logic leaves unattributed, are isolated where the network tells them apart.

Which residuals a fault reaches depends on how the assistant states are computed, which the
paper leaves implicit. Two propagation models are supported:

* ``direct``: the assistant state of ``s`` is computed from its assistant sensors'
  *measurements* (as in the paper's example, ``xbar_2 = x_4 + int x_4`` from sensor 4 alone),
  so a fault on ``j`` reaches only ``j``'s own residual and those of ``j``'s targets. Law 0
  with the immediate assistants then isolates a fault anywhere, also inside a circle of
  three or more sensors; two sensors that assist each other can never be told apart.
* ``chained``: an assistant state is built from other *assistant states*, so a fault reaches
  everything downstream: Law 2's "all upstream residuals" and Law 3's "every residual of the
  circle" hold literally, and circles need a quasi-head.

The equivalent-model detector builds its relations from measurements: ``direct``.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np
import numpy.typing as npt


class Role(StrEnum):
    """Sensor roles of Section 6.1."""

    DOT = "dot"
    HEAD = "head"
    FOOT = "foot"
    LINK = "link"


class StructureKind(StrEnum):
    """The four structures of Section 6.1."""

    DOTS = "dots"
    LINES = "lines"
    CIRCLES = "circles"
    BRANCHES = "branches"


class Propagation(StrEnum):
    """How far a sensor fault reaches through the assistant states (module docstring)."""

    DIRECT = "direct"
    CHAINED = "chained"


LAW_TEXT = {
    StructureKind.LINES: "law 2 (line): upstream residuals are 0",
    StructureKind.BRANCHES: "law 4 (branch): treated as a line",
    StructureKind.CIRCLES: "law 3 (circle)",
}


@dataclass(frozen=True, slots=True)
class Structure:
    """One structure: ``sensors`` in positive order (upstream first); a branch hangs from
    ``attach``; a circle may have a ``quasi_head`` (Law 3)."""

    kind: StructureKind
    sensors: tuple[str, ...]
    attach: str | None = None
    quasi_head: str | None = None

    def as_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"kind": self.kind.value, "sensors": list(self.sensors)}
        if self.attach is not None:
            out["attach"] = self.attach
        if self.quasi_head is not None:
            out["quasi_head"] = self.quasi_head
        return out


@dataclass(frozen=True, slots=True)
class NetworkDiagnosis:
    """The decision block's conclusion for one set of alarming residuals.

    ``faulty``: sensors isolated as faulty, with the law that decided in ``laws``;
    ``propagated``: alarming sensors whose alarm is explained by an alarming sensor their
    residual depends on (not their own fault); ``ambiguous``: alarming sensors left when no
    law isolates anything (for example two sensors that assist each other);
    ``ignored``: alarms on sensors that have no residual in this network."""

    faulty: tuple[str, ...]
    propagated: dict[str, tuple[str, ...]]
    ambiguous: tuple[str, ...]
    laws: dict[str, str]
    ignored: tuple[str, ...] = ()

    def as_dict(self) -> dict[str, Any]:
        return {
            "faulty": list(self.faulty),
            "propagated": {k: list(v) for k, v in self.propagated.items()},
            "ambiguous": list(self.ambiguous),
            "laws": dict(self.laws),
            "ignored": list(self.ignored),
        }


@dataclass(frozen=True)
class SensorNetwork:
    """A sensor network: ``assistants[target]`` are the assistant sensors of ``target``."""

    sensors: tuple[str, ...]
    assistants: Mapping[str, tuple[str, ...]]
    quasi_heads: tuple[str, ...] = ()
    propagation: Propagation = Propagation.DIRECT
    _targets: dict[str, tuple[str, ...]] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        known = set(self.sensors)
        if len(known) != len(self.sensors):
            raise ValueError(f"duplicate sensor names in {list(self.sensors)}")
        clean: dict[str, tuple[str, ...]] = {}
        for target, ass in self.assistants.items():
            if target not in known:
                raise ValueError(f"assistants: unknown target sensor {target!r}")
            seen: list[str] = []
            for a in ass:
                if a not in known:
                    raise ValueError(f"assistants of {target!r}: unknown sensor {a!r}")
                if a == target:
                    raise ValueError(f"sensor {target!r} cannot be its own assistant sensor")
                if a not in seen:
                    seen.append(a)
            if seen:
                clean[target] = tuple(seen)
        for q in self.quasi_heads:
            if q not in known:
                raise ValueError(f"quasi_heads: unknown sensor {q!r}")
        object.__setattr__(self, "assistants", clean)
        object.__setattr__(self, "propagation", Propagation(self.propagation))
        targets: dict[str, list[str]] = {s: [] for s in self.sensors}
        for t in self.sensors:
            for a in clean.get(t, ()):
                targets[a].append(t)
        object.__setattr__(self, "_targets", {k: tuple(v) for k, v in targets.items()})

    # -- construction ----------------------------------------------------------------------
    @classmethod
    def ring(cls, order: Sequence[str], k: int = 1) -> SensorNetwork:
        """A circle in ``order``: each sensor's assistants are the ``k`` sensors before it
        (cyclically). With ``len(order) > 2 k`` no two sensors assist each other, so under
        direct propagation Law 0 isolates a fault on any sensor and none is a head or dot."""
        n = len(order)
        if n < 3:
            raise ValueError(f"a ring needs at least 3 sensors, got {n}")
        k = max(1, min(int(k), (n - 1) // 2))
        ass = {order[i]: tuple(order[(i - d) % n] for d in range(1, k + 1)) for i in range(n)}
        return cls(tuple(order), ass)

    @classmethod
    def design(cls, names: Sequence[str], similarity: npt.ArrayLike, k: int = 2) -> SensorNetwork:
        """A network in which every sensor is diagnosable by Law 0 under direct
        propagation, built from a ``similarity`` of the sensors (for example ``|corr|`` of
        the healthy records): each pair of sensors is one edge at most (no two sensors
        assist each other) and every sensor has at least one assistant (no heads or dots).

        1. Max-min base: the largest threshold ``theta`` such that every sensor can get an
           assistant at least ``theta`` similar. Sensors can all get an in-edge from the
           graph of pairs with similarity ``>= theta`` iff each of its connected components
           has at least as many pairs as sensors (a tree always leaves one sensor out);
           then a maximum spanning tree plus the strongest other pair of each component
           form one cycle, oriented around the cycle and away from it along the tree.
        2. Up to ``k`` assistants per sensor from the remaining pairs, most similar first,
           each pointing to the sensor whose remaining alternatives are worse."""
        S = np.abs(np.nan_to_num(np.asarray(similarity, dtype=np.float64)))
        n = len(names)
        if S.shape != (n, n):
            raise ValueError(f"expected a ({n}, {n}) similarity matrix, got {S.shape}")
        if n < 3:
            raise ValueError(f"an isolating network needs at least 3 sensors, got {n}")
        k = max(1, int(k))
        S = 0.5 * (S + S.T)
        pairs = sorted(
            ((float(S[i, j]), i, j) for i in range(n) for j in range(i + 1, n)),
            key=lambda p: -p[0],
        )
        theta = next(
            v for v, _, _ in pairs if _feasible(n, [(i, j) for w, i, j in pairs if w >= v])
        )
        strong = [(w, i, j) for w, i, j in pairs if w >= theta]
        edges = _unicyclic_orientation(n, strong)  # (assistant, target)
        indeg = [0] * n
        for _, t in edges:
            indeg[t] += 1
        used = {(min(a, t), max(a, t)) for a, t in edges}
        undecided = {(i, j) for _, i, j in pairs} - used

        def alternatives(t: int, other: int) -> float:
            free = k - indeg[t]
            cands = sorted(
                (
                    S[t, c]
                    for c in range(n)
                    if c not in (t, other) and (min(t, c), max(t, c)) in undecided
                ),
                reverse=True,
            )
            return float(sum(cands[:free]))

        for _, i, j in pairs:
            if (i, j) not in undecided:
                continue
            undecided.discard((i, j))
            open_i, open_j = indeg[i] < k, indeg[j] < k
            if not (open_i or open_j):
                continue
            if open_i and open_j:
                key_i = (alternatives(i, j), indeg[i], i)
                key_j = (alternatives(j, i), indeg[j], j)
                t, a = (i, j) if key_i <= key_j else (j, i)
            else:
                t, a = (i, j) if open_i else (j, i)
            edges.add((a, t))
            indeg[t] += 1
        ass = {
            names[t]: tuple(
                names[a] for a in sorted(range(n), key=lambda c: -S[t, c]) if (a, t) in edges
            )
            for t in range(n)
        }
        return cls(tuple(names), ass)

    # -- graph queries ---------------------------------------------------------------------
    def targets(self, sensor: str) -> tuple[str, ...]:
        """The target sensors ``sensor`` is an assistant sensor for."""
        return self._targets[sensor]

    def assistant_sensors(self, sensor: str) -> tuple[str, ...]:
        return self.assistants.get(sensor, ())

    def role(self, sensor: str) -> Role:
        has_in = bool(self.assistant_sensors(sensor))
        has_out = bool(self.targets(sensor))
        if has_in and has_out:
            return Role.LINK
        if has_in:
            return Role.FOOT
        if has_out:
            return Role.HEAD
        return Role.DOT

    def roles(self) -> dict[str, Role]:
        return {s: self.role(s) for s in self.sensors}

    def _reach(self, start: str, step: Mapping[str, Sequence[str]]) -> set[str]:
        seen: set[str] = set()
        stack = list(step.get(start, ()))
        while stack:
            s = stack.pop()
            if s in seen:
                continue
            seen.add(s)
            stack.extend(step.get(s, ()))
        seen.discard(start)
        return seen

    def upstream(self, sensor: str) -> set[str]:
        """Every sensor from which ``sensor`` can be reached along the positive order."""
        return self._reach(sensor, self.assistants)

    def downstream(self, sensor: str) -> set[str]:
        return self._reach(sensor, self._targets)

    def circles(self) -> list[tuple[str, ...]]:
        """Strongly connected sets of two or more sensors, in sensor order."""
        out: list[tuple[str, ...]] = []
        done: set[str] = set()
        for s in self.sensors:
            if s in done:
                continue
            comp = {s} | (self.upstream(s) & self.downstream(s))
            if len(comp) > 1:
                members = tuple(x for x in self.sensors if x in comp)
                out.append(members)
                done |= comp
        return out

    def structures(self) -> list[Structure]:
        """Decomposition into dots, circles, lines and branches (Section 6.1). A line walks
        from a head-sensor along the first target not yet placed; a branch starts at a
        sensor already placed in a line or circle."""
        out: list[Structure] = []
        placed: set[str] = set()
        for s in self.sensors:
            if self.role(s) is Role.DOT:
                out.append(Structure(StructureKind.DOTS, (s,)))
                placed.add(s)
        for members in self.circles():
            q = next((x for x in members if x in self.quasi_heads), None)
            out.append(
                Structure(StructureKind.CIRCLES, self._cycle_order(members, q), quasi_head=q)
            )
            placed |= set(members)

        def walk(first: str) -> list[str]:
            path = [first]
            cur = first
            while True:
                nxt = [t for t in self.targets(cur) if t not in placed and t not in path]
                if not nxt:
                    return path
                cur = nxt[0]
                path.append(cur)

        for s in self.sensors:
            if s not in placed and self.role(s) is Role.HEAD:
                path = walk(s)
                placed |= set(path)
                out.append(Structure(StructureKind.LINES, tuple(path)))
        changed = True
        while changed:
            changed = False
            for s in self.sensors:
                if s not in placed:
                    continue
                for t in self.targets(s):
                    if t not in placed:
                        path = walk(t)
                        placed |= set(path)
                        out.append(Structure(StructureKind.BRANCHES, tuple(path), attach=s))
                        changed = True
        return out

    def _cycle_order(self, members: tuple[str, ...], start: str | None) -> tuple[str, ...]:
        """Members in positive order from ``start`` (depth-first along targets)."""
        inside = set(members)
        order: list[str] = []
        stack = [start or members[0]]
        while stack:
            s = stack.pop()
            if s in order:
                continue
            order.append(s)
            stack.extend(reversed([t for t in self.targets(s) if t in inside and t not in order]))
        order.extend(x for x in members if x not in order)
        return tuple(order)

    # -- diagnosis -------------------------------------------------------------------------
    def has_residual(self, sensor: str) -> bool:
        """True for sensors with an observer (they have assistant sensors) and for
        quasi-heads (a residual from the estimations block, Section 6.3)."""
        return bool(self.assistant_sensors(sensor)) or sensor in self.quasi_heads

    def dependencies(self, sensor: str) -> set[str]:
        """Sensors other than ``sensor`` whose faults reach its residual: the assistant
        sensors (direct propagation) or every upstream sensor (chained), edges into a
        quasi-head being cut (its residual comes from the estimations block)."""
        if sensor in self.quasi_heads or not self.has_residual(sensor):
            return set()
        if self.propagation is Propagation.DIRECT:
            return set(self.assistant_sensors(sensor))
        cut = {t: a for t, a in self.assistants.items() if t not in self.quasi_heads}
        return self._reach(sensor, cut)

    def undiagnosable(self) -> dict[str, str]:
        """Sensors the observers alone cannot diagnose, with the reason (Laws 1-3)."""
        out: dict[str, str] = {}
        for s in self.sensors:
            role = self.role(s)
            if s in self.quasi_heads:
                continue
            if role is Role.DOT:
                out[s] = (
                    "law 1: dot-sensor (no assistant or target sensors); needs an "
                    "analytical relationship, an estimation-based method or hardware redundancy"
                )
            elif role is Role.HEAD:
                out[s] = (
                    "law 2: head-sensor (no assistant sensors); needs an estimation-based "
                    "method or hardware redundancy"
                )
        for s in self.sensors:
            if s in out or not self.has_residual(s):
                continue
            deps = self.dependencies(s)
            twins = [
                t
                for t in sorted(deps)
                if self.has_residual(t) and s in self.dependencies(t) and t not in self.quasi_heads
            ]
            if twins:
                why = (
                    "law 3: in a circle every residual depends on every member; choose a quasi-head"
                    if self.propagation is Propagation.CHAINED
                    else "assists and is assisted by"
                )
                out[s] = f"{why} ({', '.join(twins)}): a fault on either alarms both"
        return out

    def diagnose(self, alarming: Iterable[str], blind: Iterable[str] = ()) -> NetworkDiagnosis:
        """Apply Laws 0-4 to the set of sensors whose residuals alarm (one fault at a time):
        an alarming sensor is faulty when no sensor its residual depends on alarms (Law 0;
        in a line that is Law 2, in a branch Law 4, in a circle with direct propagation or
        after choosing a quasi-head Law 3); otherwise its alarm is propagated. Where that
        isolates none, the smallest explanations decide (:meth:`_smallest_explanations`).

        ``blind``: sensors whose residual cannot alarm at that time, though the sensor
        itself reads (an assistant of theirs has no data): their silence is not that of a
        healthy sensor. An alarming sensor whose residual depends on one of them is not
        faulty by law 0 (the blind one may be), and the smallest explanations may hold
        them: the decision stays ambiguous unless an alarming sensor is in every one. (A
        column missing from 200 s, s4, left s3's residual empty; s3's offset at 400 s
        alarmed s0, which s3 assists, and law 0 named s0.)"""
        wanted = set(alarming)
        alarms = [s for s in self.sensors if s in wanted]
        unknown = (wanted | set(blind)) - set(self.sensors)
        if unknown:
            raise ValueError(f"diagnose: unknown sensor(s) {sorted(unknown)}")
        dark = [s for s in self.sensors if s in set(blind) and s not in wanted]
        ignored = tuple(s for s in alarms if not self.has_residual(s))
        live = [s for s in alarms if self.has_residual(s)]
        faulty: list[str] = []
        propagated: dict[str, tuple[str, ...]] = {}
        laws: dict[str, str] = {}
        undecided: dict[str, tuple[str, ...]] = {}
        kinds = {s: st for st in self.structures() for s in st.sensors}
        for s in live:
            reasons = tuple(d for d in sorted(self.dependencies(s)) if d in live)
            if reasons:
                propagated[s] = reasons
                continue
            hidden = tuple(d for d in sorted(self.dependencies(s)) if d in dark)
            if hidden:
                undecided[s] = hidden
                continue
            faulty.append(s)
            st = kinds.get(s)
            if s in self.quasi_heads:
                laws[s] = "law 3: quasi-head residual from the estimations block"
            elif st is None:
                laws[s] = "law 0"
            else:
                laws[s] = f"law 0; {LAW_TEXT.get(st.kind, st.kind.value)}"
        if undecided:
            return self._smallest_explanations(live, ignored, dark, undecided)
        if not faulty and len(live) > 1:
            return self._smallest_explanations(live, ignored)
        ambiguous = tuple(live) if not faulty else ()
        if ambiguous:
            propagated = {}
        return NetworkDiagnosis(tuple(faulty), propagated, ambiguous, laws, ignored)

    def _smallest_explanations(
        self,
        live: Sequence[str],
        ignored: tuple[str, ...],
        dark: Sequence[str] = (),
        undecided: Mapping[str, tuple[str, ...]] | None = None,
    ) -> NetworkDiagnosis:
        """Law 0 where it isolates nothing alone (every alarming residual depends on an
        alarming sensor): the smallest sets of alarming sensors, one or two, whose faults
        explain every alarm (each alarming sensor is in the set or its residual depends
        on one in it). A sensor in every such set is faulty whichever the others are; one
        in some of them stays ambiguous (it may be the other fault), and the alarms of the
        rest that a faulty sensor explains are propagated. Two sensors
        that assist each other are each a smallest explanation of their two alarms:
        neither is in both, so both stay ambiguous, as law 0 leaves them.

        (Offsets on s1 and a gain on s3 of a 3-floor building from the same instant,
        ``sweep_isolation.py --floors 3 --onset 0.6 --second 0.6001``, seed 0: every
        alarming residual, s0 s1 s3 s4 s5, depends on an alarming sensor, and law 0
        named none; no single sensor explains the five alarms, the pairs {s0, s3} and
        {s1, s3} do: s3 is faulty, s1 and s0 stay ambiguous, as a fault on s1 shows in
        s0's residual.)"""
        deps = {s: self.dependencies(s) for s in live}
        # blind sensors (``dark``) may explain alarms but have none to explain
        pool = [*live, *dark]

        def explains(group: set[str]) -> bool:
            return all(s in group or deps[s] & group for s in live)

        sets = [{a} for a in pool if explains({a})]
        if not sets:
            sets = [{a, b} for i, a in enumerate(pool) for b in pool[i + 1 :] if explains({a, b})]
        certain = set.intersection(*sets) if sets else set()
        faulty = tuple(s for s in live if s in certain)
        if not faulty:
            why = {
                s: f"undecided: its residual depends on {', '.join(hidden)}, whose own "
                "residual has no data then"
                for s, hidden in (undecided or {}).items()
            }
            return NetworkDiagnosis((), {}, tuple(live), why, ignored)
        # a sensor in some smallest explanation but not all may be the other fault
        maybe = set().union(*sets) - certain
        propagated = {
            s: tuple(sorted(deps[s] & certain))
            for s in live
            if s not in certain and s not in maybe and deps[s] & certain
        }
        law = (
            "law 0: the one sensor whose fault explains every alarm"
            if len(sets[0]) == 1
            else "law 0 for two faults at once: in every pair that explains the alarms"
        )
        laws = dict.fromkeys(faulty, law)
        ambiguous = tuple(s for s in live if s not in certain and s not in propagated)
        return NetworkDiagnosis(faulty, propagated, ambiguous, laws, ignored)

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly description of the graph, roles, structures and the sensors the
        observers cannot diagnose."""
        return {
            "sensors": list(self.sensors),
            "assistants": {t: list(a) for t, a in self.assistants.items()},
            "edges": [{"from": a, "to": t} for t, ass in self.assistants.items() for a in ass],
            "roles": {s: r.value for s, r in self.roles().items()},
            "structures": [st.as_dict() for st in self.structures()],
            "quasi_heads": list(self.quasi_heads),
            "propagation": self.propagation.value,
            "undiagnosable": self.undiagnosable(),
        }


def _components(n: int, pairs: Sequence[tuple[int, int]]) -> list[int]:
    """Union-find labels of the sensors' connected components."""
    parent = list(range(n))

    def root(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for i, j in pairs:
        parent[root(i)] = root(j)
    return [root(x) for x in range(n)]


def _feasible(n: int, pairs: Sequence[tuple[int, int]]) -> bool:
    """Whether every sensor can get an in-edge from ``pairs`` (each pair used once): every
    connected component needs at least as many pairs as sensors."""
    comp = _components(n, pairs)
    nodes: dict[int, int] = {}
    count: dict[int, int] = {}
    for x in range(n):
        nodes[comp[x]] = nodes.get(comp[x], 0) + 1
    for i, _ in pairs:
        count[comp[i]] = count.get(comp[i], 0) + 1
    return all(count.get(c, 0) >= m for c, m in nodes.items())


def _unicyclic_orientation(
    n: int, strong: Sequence[tuple[float, int, int]]
) -> set[tuple[int, int]]:
    """Edges ``(assistant, target)`` giving every sensor exactly one assistant from
    ``strong`` (sorted by decreasing similarity, feasible by :func:`_feasible`): per
    component a maximum spanning tree plus its strongest other pair, the cycle this closes
    oriented around, the tree edges oriented away from the cycle."""
    comp_of = list(range(n))

    def root(x: int) -> int:
        while comp_of[x] != x:
            comp_of[x] = comp_of[comp_of[x]]
            x = comp_of[x]
        return x

    tree: dict[int, list[int]] = {x: [] for x in range(n)}
    extra: dict[int, tuple[int, int]] = {}
    for _, i, j in strong:  # Kruskal, strongest first
        ri, rj = root(i), root(j)
        if ri != rj:
            comp_of[ri] = rj
            tree[i].append(j)
            tree[j].append(i)
    for _, i, j in strong:
        r = root(i)
        if r not in extra and j not in tree[i]:
            extra[r] = (i, j)
    edges: set[tuple[int, int]] = set()
    for r, (u, v) in extra.items():
        # the tree path from v to u, closed by the extra pair u -> v
        prev = {v: v}
        queue = [v]
        while queue:
            x = queue.pop(0)
            for y in tree[x]:
                if y not in prev:
                    prev[y] = x
                    queue.append(y)
        path = [u]
        while path[-1] != v:
            path.append(prev[path[-1]])
        cycle = path[::-1]  # v ... u
        edges.add((u, v))
        for a, t in zip(cycle, cycle[1:], strict=False):
            edges.add((a, t))
        seen = set(cycle)
        queue = list(cycle)
        while queue:
            x = queue.pop(0)
            for y in tree[x]:
                if y not in seen:
                    seen.add(y)
                    edges.add((x, y))
                    queue.append(y)
        del r
    return edges


def network_from_config(
    names: Sequence[str],
    assistants: Mapping[str, Collection[str]],
    quasi_heads: Sequence[str] = (),
    propagation: str = "direct",
) -> SensorNetwork:
    """A network from a ``{target: [assistant, ...]}`` table (config keys)."""
    return SensorNetwork(
        tuple(names),
        {t: tuple(a) for t, a in assistants.items()},
        tuple(quasi_heads),
        Propagation(propagation),
    )


__all__ = [
    "NetworkDiagnosis",
    "Propagation",
    "Role",
    "SensorNetwork",
    "Structure",
    "StructureKind",
    "network_from_config",
]
