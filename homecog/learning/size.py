"""Sizes checked before any work: a home too large for the machine's memory is
refused at once, with one line naming its largest group and the sizes, instead of running for
minutes and then failing.

The estimate counts what learning a group holds at once — its Q values (float32), tried
marks, rule tables over its classes of contexts (:mod:`homecog.home.classes`) — for as many
groups as are learned in parallel, plus every group's finished table (float16). It is computed
from the home's sizes and the values its rules name, without evaluating a rule over any
context, so it takes milliseconds whatever the home.

>>> from homecog.home import load_home
>>> report = estimate(load_home("paper"))
>>> report.largest.devices, report.largest_states, report.contexts    # 24 of 2,592 contexts
(('window', 'ac_living', 'ac_bedroom'), 192, 24)
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass

from homecog.errors import HomeTooLargeError
from homecog.home.classes import group_classes, home_classes
from homecog.home.groups import Group, device_groups, whole
from homecog.home.model import Home
from homecog.home.scenes import scene_services

#: Largest Q table (states × services) one group may have: as the joint table's limit.
MAX_GROUP_ENTRIES = 2**31
#: Most devices one group may hold (its device states are bits of one machine word).
MAX_GROUP_DEVICES = 30


@dataclass(frozen=True)
class SizeReport:
    """The largest group's size and the memory learning needs."""

    contexts: int
    largest: Group
    largest_states: int
    largest_entries: int
    needed_bytes: int
    groups: int


def _needs_count(home: Home, group: Group) -> int:
    return sum(1 for a in group.service_index if home.needs[a])


def contexts(home: Home, group: Group, *, joint: bool = False) -> int:
    """The contexts a group learns over: its classes (:mod:`homecog.home.classes`), or every
    context of the home for the joint table."""
    return home.context_count if joint else group_classes(home, group).count


def group_states(home: Home, group: Group, *, joint: bool = False) -> int:
    """An upper bound on a group's states: contexts × 2^devices × 2^(services that can be needed)."""
    return contexts(home, group, joint=joint) << (len(group.devices) + _needs_count(home, group))


def exact_states(home: Home, group: Group, *, joint: bool = False) -> int:
    """A group's states: every context (class) × 2^devices × 2^(services that context needs)."""
    need = [a for a in group.service_index if home.needs[a]]
    base = contexts(home, group, joint=joint) << len(group.devices)
    if not need:
        return base
    import numpy as np

    from homecog.environment.tables import condition_contexts

    # the joint table has a row per context: summed over the classes no rule tells apart
    cls = home_classes(home) if joint else group_classes(home, group)
    codes = np.stack(np.unravel_index(np.arange(cls.count), cls.radices), axis=1)
    count = np.zeros(cls.count, dtype=np.int64)
    for a in need:
        needed = np.zeros(cls.count, dtype=bool)
        for cond in home.needs[a]:
            needed |= condition_contexts(codes, cls.condition(cond))
        count += needed
    weights = cls.weights() if joint else 1
    return int(((np.int64(1) << count) * weights).sum()) << len(group.devices)


def sizes(home: Home) -> dict[str, object]:
    """The sizes ``home show`` and ``home check`` report: the joint space and the groups'."""
    groups = device_groups(home)
    states = [exact_states(home, g) for g in groups]
    largest = max(range(len(groups)), key=lambda i: (states[i] * len(groups[i].services), -i))
    return {
        "start_states": home.context_count << len(home.devices),
        "states": exact_states(home, whole(home), joint=True),
        "groups": len(groups),
        "scenes": len(scene_services(home)),
        "largest_group": groups[largest].label,
        "largest_group_states": states[largest],
        "group_states": sum(states),
        "q_table_bytes": sum(n * len(g.services) * 2 for n, g in zip(states, groups, strict=True)),
    }


def _working_bytes(home: Home, group: Group, states: int, joint: bool) -> int:
    services = len(group.services)
    words = (services + 31) // 32
    rules = sum(len(home.prohibited[a]) for a in group.service_index)
    n = contexts(home, group, joint=joint)
    return states * (4 * services + 8 * words) + n * (9 * services + 40 + rules) + (n << len(group.devices))


def estimate(home: Home, *, joint: bool = False, workers: int | None = None) -> SizeReport:
    """What learning the home needs (see the module's docstring)."""
    groups = (whole(home),) if joint else device_groups(home)
    sized = [(group_states(home, g, joint=joint), g) for g in groups]
    states, largest = max(sized, key=lambda x: (x[0] * max(1, len(x[1].services)), -x[1].index))
    workers = 1 if joint else max(1, min(len(groups), workers or os.cpu_count() or 1))
    working = sorted((_working_bytes(home, g, s, joint) for s, g in sized), reverse=True)[:workers]
    finished = sum(s * len(g.services) * (4 if joint else 2) for s, g in sized)
    return SizeReport(
        contexts=contexts(home, largest, joint=joint),
        largest=largest,
        largest_states=states,
        largest_entries=states * len(largest.services),
        needed_bytes=sum(working) + finished,
        groups=len(groups),
    )


def memory_budget() -> int:
    """Bytes learning may use: ``$HOMECOG_MEMORY`` (e.g. ``2G``) or what the machine has free."""
    text = os.environ.get("HOMECOG_MEMORY", "").strip()
    if text:
        match = re.fullmatch(r"(\d+(?:\.\d+)?)\s*([kKmMgGtT]?)[bB]?", text)
        if not match:
            raise HomeTooLargeError(f"HOMECOG_MEMORY: {text!r} is not a size such as 2G or 512M")
        scale = {"": 1, "k": 2**10, "m": 2**20, "g": 2**30, "t": 2**40}[match.group(2).lower()]
        return int(float(match.group(1)) * scale)
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") // 2
    except (ValueError, OSError, AttributeError):
        return 8 * 2**30


def human_bytes(n: float) -> str:
    """``1.5 GB`` and the like (powers of 1024).

    >>> human_bytes(3 * 2**30), human_bytes(512)
    ('3.0 GB', '512 B')
    """
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if n < 1024 or unit == "PB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} PB"  # pragma: no cover


def big_number(n: int) -> str:
    """A count as people read it: ``663,552``, or ``1.6e+60`` past a trillion, however large
    (a home of 10,000 devices has 2^10000 device states: no float holds that).

    >>> big_number(663552), big_number(2**200), big_number(3 * 2**10000)
    ('663,552', '1.6e+60', '6.0e+3010')
    """
    if n < 10**12:
        return f"{n:,}"
    exponent = math.log10(n)  # exact enough for any int, where float(n) overflows
    whole = math.floor(exponent)
    mantissa = round(10 ** (exponent - whole), 1)
    if mantissa >= 10:
        mantissa, whole = mantissa / 10, whole + 1
    return f"{mantissa:.1f}e+{whole:02d}"


def check_size(home: Home, *, joint: bool = False) -> SizeReport:
    """Refuse, with one line naming the largest group and the sizes, a home that cannot be
    learned here; otherwise the size report."""
    if not home.devices:
        raise HomeTooLargeError(f"{home.name}: the home has no devices; there is nothing to learn")
    if not home.services:
        raise HomeTooLargeError(f"{home.name}: the home has no services; the robot can do nothing")
    report = estimate(home, joint=joint)
    g = report.largest
    what = "the joint table" if joint else f"its largest group, {g.label},"
    needs = _needs_count(home, g)
    shape = (
        f"{big_number(report.largest_states)} states ({big_number(report.contexts)} "
        + ("contexts" if joint else "class of contexts" if report.contexts == 1 else "classes of contexts")
        + f" × 2^{len(g.devices)} device states"
        + (f" × 2^{needs} pending needs" if needs else "")
        + f") × {len(g.services)} services"
    )
    hint = (
        "learn it group by group (without --joint)"
        if joint
        else "fewer devices tied together by one service or prohibited rule, or fewer context values"
    )
    if len(g.devices) > MAX_GROUP_DEVICES or report.largest_entries > MAX_GROUP_ENTRIES:
        raise HomeTooLargeError(f"{home.name}: too large to learn: {what} has {shape}; {hint}")
    budget = memory_budget()
    if report.needed_bytes > budget:
        raise HomeTooLargeError(
            f"{home.name}: too large for this machine's memory: {what} has {shape}, and learning "
            f"needs about {human_bytes(report.needed_bytes)} of the {human_bytes(budget)} free; {hint}"
        )
    return report


def describe(report: SizeReport) -> str:
    """One line about the size, for ``home show`` and ``home check``."""
    g = report.largest
    return (
        f"{report.groups} groups; the largest, {g.label}, has {big_number(report.largest_states)} states × "
        f"{len(g.services)} services; learning needs about {human_bytes(report.needed_bytes)}"
    )
