"""The CPU time a Linux control group (cgroup) allows this process, in CPUs: a
container's ``--cpus 2`` (``cpu.max`` ``200000 100000`` under cgroup v2,
``cpu.cfs_quota_us`` 200000 over ``cpu.cfs_period_us`` 100000 under v1) lets it use two
CPUs' worth of time however many CPUs it may run on. ``--jobs``' default counts it
(:func:`analyzer.parallel.usable_cpus`): a CI container given 2 CPUs of a 64-core host
ran 64 analysis threads, slowed down by the quota (the integrator's audit, int56 item 3,
the second half of ux59 item L4).

The files read are those of the process's own cgroup: ``/proc/self/cgroup`` names it,
``/proc/self/mountinfo`` says where its hierarchy is mounted, and the quota of every
cgroup from it up to the mount's root counts (a parent's limit holds for its children).
Any file missing or unreadable means no limit known: the quota is never a reason to
fail."""

from __future__ import annotations

import math
from pathlib import Path, PurePosixPath

CGROUP_ROOT = Path("/")
"""Where ``/proc`` and ``/sys`` are looked for (a test's fake tree in its place)."""


def cgroup_cpu_limit(root: Path | None = None) -> int | None:
    """The number of CPUs the process's cgroup quota allows (the quota over its period,
    rounded up, at least 1), the smallest along its cgroup's ancestors and over both
    cgroup versions; None when no quota is set or none can be read. ``root`` is where
    ``/proc`` and ``/sys`` are looked for (:data:`CGROUP_ROOT` by default)."""
    root = CGROUP_ROOT if root is None else root
    groups = _read(root / "proc/self/cgroup")
    mounts = _read(root / "proc/self/mountinfo")
    if groups is None or mounts is None:
        return None
    limits: list[float] = []
    for line in groups.splitlines():
        parts = line.split(":", 2)
        if len(parts) != 3:
            continue
        number, controllers, path = parts
        v2 = number == "0" and controllers == ""
        if not v2 and "cpu" not in controllers.split(","):
            continue
        for folder in _folders(root, mounts, path, v2):
            quota = _v2_quota(folder) if v2 else _v1_quota(folder)
            if quota is not None:
                limits.append(quota)
    if not limits:
        return None
    return max(1, math.ceil(min(limits)))


def _folders(root: Path, mounts: str, path: str, v2: bool) -> list[Path]:
    """The cgroup ``path``'s folder and its ancestors' up to the mount's root, in the
    hierarchy's mount that ``mounts`` (``/proc/self/mountinfo``) lists: a ``cgroup2``
    mount for v2, a ``cgroup`` mount with the ``cpu`` controller for v1."""
    for line in mounts.splitlines():
        fields = line.split()
        if " - " not in line or len(fields) < 5:
            continue
        after = line.split(" - ", 1)[1].split()
        if len(after) < 3:
            continue
        kind, options = after[0], after[2].split(",")
        if v2 != (kind == "cgroup2") or (not v2 and (kind != "cgroup" or "cpu" not in options)):
            continue
        mount_root, mount_point = PurePosixPath(fields[3]), fields[4]
        group = PurePosixPath(path)
        # (in a cgroup namespace the mount's root is the process's own cgroup, "/")
        inside = group.relative_to(mount_root) if group.is_relative_to(mount_root) else None
        base = root / mount_point.lstrip("/")
        if inside is None:
            return [base]
        leaf = base / inside
        return [leaf, *(p for p in leaf.parents if p == base or base in p.parents)]
    return []


def _v2_quota(folder: Path) -> float | None:
    """``cpu.max``'s quota in CPUs (``max`` or no file: None)."""
    text = _read(folder / "cpu.max")
    if text is None:
        return None
    fields = text.split()
    if len(fields) != 2 or fields[0] == "max":
        return None
    return _ratio(fields[0], fields[1])


def _v1_quota(folder: Path) -> float | None:
    """``cpu.cfs_quota_us`` over ``cpu.cfs_period_us`` in CPUs (-1 or no file: None)."""
    quota, period = _read(folder / "cpu.cfs_quota_us"), _read(folder / "cpu.cfs_period_us")
    if quota is None or period is None:
        return None
    return _ratio(quota.strip(), period.strip())


def _ratio(quota: str, period: str) -> float | None:
    """``quota / period`` where both are positive whole numbers, else None."""
    try:
        q, p = int(quota), int(period)
    except ValueError:
        return None
    return q / p if q > 0 and p > 0 else None


def _read(path: Path) -> str | None:
    """The text of ``path``, None where it cannot be read."""
    try:
        return path.read_text(encoding="ascii", errors="replace")
    except OSError:
        return None
