"""Benchmark of HTN planning on the paper home (the paper's Fig. 10): our planner beside GTPyhop and
unified-planning with Aries, on the same requests, against the number of services and the plan length.

    bin/bench planning         # or: .venv/bin/python benchmarks/bench_planning.py [--quick] [--json F]

The requests are services of the paper home drawn in a fixed seeded order (repeats allowed); a
request of n services is the first n of that order, from the home's initial state with the user
at the reading table. Times are medians of repeated runs in this one process:

* ours: ``plan_services`` with the domain built once (as the robot does);
* GTPyhop 2.0.2: the very action and method functions of ``make_domain(home)`` declared into a
  ``gtpyhop.Domain``, so that only the planners differ; its recursive DFS (the same search as
  ours; it is faster than its iterative one here). GTPyhop leaves out of the plan every action
  that leaves the state as it was (pour, speak, a move to where the robot is when not docked,
  switching a device to the state it is in); its plans are checked to be ours without those;
* Aries 0.5.0 through unified-planning 1.3.0 on the HDDL export (``homecog.planning.hddl``),
  at a few sizes only: wall time of ``OneshotPlanner.solve`` (the solver binary started, the
  problem sent over gRPC, grounded and solved), parsing not included; its plans are mapped back
  and checked to equal ours.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import random
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from homecog.home import load_home
from homecog.home.model import Home
from homecog.planning import State, initial_state, make_domain, plan_services
from homecog.planning.hddl import actions_from_hddl, domain_hddl, problem_hddl
from homecog.planning.planner import Domain, Task

ROOT = Path(__file__).resolve().parent.parent
SEED = 2024
SERVICE_COUNTS = list(range(1, 21))
PLAN_LENGTHS = [25, 50, 75, 100, 150, 200, 250, 300]  # the shortest request with at least so many actions
ARIES_SERVICE_COUNTS = [1, 5, 10, 20]


def request_order(home: Home, n: int, seed: int = SEED) -> list[str]:
    """The home's services in a fixed seeded order, repeats allowed."""
    rng = random.Random(seed)
    return [rng.choice(home.service_names) for _ in range(n)]


def median_seconds(fn: Callable[[], object], *, budget: float = 0.3, most: int = 200) -> float:
    """Median wall seconds of ``fn()`` after one warm-up call: at least 5 runs, then more while the
    budget lasts."""
    fn()
    times: list[float] = []
    start = time.perf_counter()
    while len(times) < 5 or (len(times) < most and time.perf_counter() - start < budget):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def services_for_length(home: Home, domain: Domain, state: State, order: list[str], length: int) -> int:
    """The number of services of the shortest prefix of ``order`` whose plan has ``length`` actions
    or more (plans only grow with the request)."""
    lo, hi = 1, len(order)
    while lo < hi:
        mid = (lo + hi) // 2
        if len(plan_services(home, order[:mid], state=state, domain=domain).actions) >= length:
            hi = mid
        else:
            lo = mid + 1
    return lo


# -- GTPyhop --------------------------------------------------------------------------------
def import_gtpyhop() -> Any:
    with contextlib.redirect_stdout(io.StringIO()):  # it prints a banner on import
        import gtpyhop

        gtpyhop.set_verbose_level(0)
        gtpyhop.set_recursive_planning("recursive_dfs")
    return gtpyhop


def gtpyhop_domain(gtpyhop: Any, domain: Domain) -> Any:
    """Our domain's actions and methods declared into a fresh ``gtpyhop.Domain``.

    GTPyhop declares into a global current domain; the domain object is returned and made
    current again before each ``find_plan`` (its API allows no more than that)."""
    with contextlib.redirect_stdout(io.StringIO()):
        gdomain = gtpyhop.Domain(f"{domain.name}-gtpyhop")
        gtpyhop.set_current_domain(gdomain)
        for name, action in domain.actions.items():
            if action.__name__ != name:  # GTPyhop names an action by its function
                raise ValueError(f"action {name!r} is a function named {action.__name__!r}")
        gtpyhop.declare_actions(*domain.actions.values())
        for task, methods in domain.methods.items():
            gtpyhop.declare_task_methods(task, *methods)
    return gdomain


def gtpyhop_state(gtpyhop: Any, state: State) -> Any:
    return gtpyhop.State(
        "start",
        robot=state.robot,
        user=state.user,
        holding=state.holding,
        objects=dict(state.objects),
        devices=dict(state.devices),
        docked=state.docked,
    )


def gtpyhop_plan(gtpyhop: Any, gdomain: Any, gstate: Any, services: Sequence[str]) -> list[Task]:
    gtpyhop.set_current_domain(gdomain)
    plan = gtpyhop.find_plan(gstate, [(name,) for name in services])
    if plan is False or plan is None:
        raise RuntimeError(f"GTPyhop found no plan for {services}")
    return [tuple(a) for a in plan]


def without_no_ops(domain: Domain, state: State, actions: list[Task]) -> list[Task]:
    """Our plan less the actions that leave the state as it was (what GTPyhop 2.x keeps)."""
    out = []
    for action in actions:
        after = domain.actions[action[0]](state.copy(), *action[1:])
        if after != state:
            out.append(action)
        state = after
    return out


# -- unified-planning with Aries ------------------------------------------------------------
def aries_solver() -> tuple[Any, Any] | str:
    """(the PDDL reader, a started Aries planner), or why they cannot be had."""
    try:
        import unified_planning.shortcuts as up
        from unified_planning.io import PDDLReader

        up.get_environment().credits_stream = None
        planner = up.OneshotPlanner(name="aries")
    except Exception as e:  # report and go on without Aries
        return f"{type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}"
    return PDDLReader(), planner


def aries_plan(
    reader: Any, planner: Any, home: Home, services: Sequence[str], state: State, timeout: float
) -> tuple[float, list[Task] | None, str]:
    """(solve seconds, the plan in our terms or None, the result status)."""
    problem = reader.parse_problem_string(domain_hddl(home), problem_hddl(home, services, state))
    start = time.perf_counter()
    result = planner.solve(problem, timeout=timeout)
    seconds = time.perf_counter() - start
    if result.plan is None:
        return seconds, None, result.status.name
    steps = [(a.action.name, [str(p) for p in a.actual_parameters]) for a in result.plan.action_plan.actions]
    return seconds, actions_from_hddl(home, steps), result.status.name


# -- measuring ------------------------------------------------------------------------------
def measure(
    home: Home,
    counts: list[int],
    aries_counts: set[int],
    aries: tuple[Any, Any] | str,
    args: argparse.Namespace,
    console: Console,
) -> list[dict[str, Any]]:
    domain = make_domain(home)
    state = initial_state(home, user="table")
    gtpyhop = import_gtpyhop()
    gdomain = gtpyhop_domain(gtpyhop, domain)
    gstate = gtpyhop_state(gtpyhop, state)
    order = request_order(home, max(counts))
    rows = []
    aries_over = False
    for n in counts:
        services = order[:n]
        ours = plan_services(home, services, state=state, domain=domain).actions
        t_ours = median_seconds(lambda s=services: plan_services(home, s, state=state, domain=domain))
        theirs = gtpyhop_plan(gtpyhop, gdomain, gstate, services)
        t_gtpyhop = median_seconds(
            lambda s=services: gtpyhop_plan(gtpyhop, gdomain, gstate, s), budget=0.3, most=50
        )
        row: dict[str, Any] = {
            "services": n,
            "actions": len(ours),
            "ours_s": t_ours,
            "gtpyhop_s": t_gtpyhop,
            "gtpyhop_actions": len(theirs),
            "gtpyhop_same": theirs == ours,
            "gtpyhop_same_less_no_ops": theirs == without_no_ops(domain, state, ours),
            "aries_s": None,
            "aries_same": None,
            "aries_status": None,
        }
        if n in aries_counts and not isinstance(aries, str) and not aries_over:
            reader, planner = aries
            repeats = 3 if len(ours) <= 40 else 1
            runs = [
                aries_plan(reader, planner, home, services, state, args.aries_timeout) for _ in range(repeats)
            ]
            seconds, plan, status = runs[0][0], runs[0][1], runs[0][2]
            row["aries_s"] = statistics.median(r[0] for r in runs) if plan is not None else None
            row["aries_same"] = None if plan is None else plan == ours
            row["aries_status"] = status
            if plan is None or seconds > args.aries_timeout / 4:
                aries_over = True  # larger requests would only take longer
        elif n in aries_counts and aries_over:
            row["aries_status"] = "not tried"
        rows.append(row)
        console.print(
            f"  {n:>3} services, {len(ours):>3} actions: ours {t_ours * 1e3:.3f} ms, "
            f"GTPyhop {t_gtpyhop * 1e3:.3f} ms"
            + (f", Aries {row['aries_s']:.2f} s" if row["aries_s"] is not None else ""),
            style="dim",
        )
    return rows


def ms(seconds: float | None) -> str:
    if seconds is None:
        return "-"
    return f"{seconds * 1e6:.0f} µs" if seconds < 1e-3 else f"{seconds * 1e3:.2f} ms"


def same(row: dict[str, Any]) -> str:
    if row["gtpyhop_same"]:
        return "same"
    dropped = row["actions"] - row["gtpyhop_actions"]
    if row["gtpyhop_same_less_no_ops"]:
        return f"ours less {dropped} no-op{'s' if dropped > 1 else ''}"
    return "DIFFERENT"


def table(title: str, rows: list[dict[str, Any]]) -> Table:
    t = Table(title=title, title_justify="left")
    for name, justify in (
        ("services", "right"),
        ("actions", "right"),
        ("ours", "right"),
        ("GTPyhop", "right"),
        ("GTPyhop / ours", "right"),
        ("GTPyhop plan", "left"),
        ("Aries (UP)", "right"),
        ("Aries plan", "left"),
    ):
        t.add_column(name, justify=justify)  # type: ignore[arg-type]
    for r in rows:
        aries = "-" if r["aries_status"] is None else ("same" if r["aries_same"] else r["aries_status"])
        if r["aries_same"] is False:
            aries = "DIFFERENT"
        t.add_row(
            str(r["services"]),
            str(r["actions"]),
            ms(r["ours_s"]),
            ms(r["gtpyhop_s"]),
            f"{r['gtpyhop_s'] / r['ours_s']:.1f} ×",
            same(r),
            "-" if r["aries_s"] is None else f"{r['aries_s']:.2f} s",
            aries,
        )
    return t


def plot(by_services: list[dict[str, Any]], by_length: list[dict[str, Any]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    for ax, rows, key, label in (
        (axes[0], by_services, "services", "services in the request"),
        (axes[1], by_length, "actions", "actions in the plan"),
    ):
        x = [r[key] for r in rows]
        ax.plot(x, [r["ours_s"] * 1e3 for r in rows], "o-", label="ours", color="tab:blue")
        ax.plot(x, [r["gtpyhop_s"] * 1e3 for r in rows], "s-", label="GTPyhop 2.0.2", color="tab:orange")
        aries = [(r[key], r["aries_s"] * 1e3) for r in rows if r["aries_s"] is not None]
        if aries:
            ax.plot(*zip(*aries, strict=True), "^--", label="Aries via unified-planning", color="tab:green")
        ax.set_yscale("log")
        ax.set_xlabel(label)
        ax.set_ylabel("planning time (ms, median)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].xaxis.set_major_locator(MaxNLocator(integer=True))
    axes[0].axhline(1.0, color="grey", linestyle=":", label="1 ms target (5 services)")
    axes[1].axhline(50.0, color="grey", linestyle=":", label="50 ms target (300 actions)")
    for ax in axes:
        ax.legend(fontsize=8)
    axes[0].set_title("Planning time against the number of services")
    axes[1].set_title("Planning time against the plan length")
    fig.suptitle("HTN planning on the paper home (the paper's Fig. 10)", fontsize=11)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer sizes, Aries at 1 and 5 services only")
    parser.add_argument("--json", type=Path, help="also write the figures to this JSON file")
    parser.add_argument(
        "--png",
        type=Path,
        default=ROOT / "docs" / "planning_benchmark.png",
        help="the plot (default: %(default)s)",
    )
    parser.add_argument("--no-png", action="store_true", help="do not plot")
    parser.add_argument("--aries-timeout", type=float, default=60.0, help="seconds per Aries solve")
    args = parser.parse_args()
    console = Console(width=130)
    home = load_home("paper")
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 20_000))  # GTPyhop recurses per plan step

    service_counts = [1, 2, 5, 10, 20] if args.quick else SERVICE_COUNTS
    lengths = [25, 100, 300] if args.quick else PLAN_LENGTHS
    domain, state = make_domain(home), initial_state(home, user="table")
    order = request_order(home, 1000)
    length_counts = [services_for_length(home, domain, state, order, n) for n in lengths]
    aries_at = {1, 5} if args.quick else set(ARIES_SERVICE_COUNTS)
    aries = aries_solver()
    if isinstance(aries, str):
        console.print(f"Aries skipped: {aries}", style="yellow")

    console.print("measuring against the number of services ...", style="dim")
    by_services = measure(home, service_counts, aries_at, aries, args, console)
    console.print("measuring against the plan length ...", style="dim")
    by_length = measure(
        home, length_counts, set() if args.quick else set(length_counts), aries, args, console
    )
    if not isinstance(aries, str):
        aries[1].destroy()

    console.print(
        table(f"Planning time against the number of services (paper home, seed {SEED})", by_services)
    )
    console.print(table("Planning time against the plan length (requests of growing length)", by_length))
    five = next(r for r in by_services if r["services"] == 5)
    longest = by_length[-1]
    ratio = statistics.median(r["gtpyhop_s"] / r["ours_s"] for r in by_services + by_length)
    summary = Table(title="Figures", title_justify="left")
    summary.add_column("figure")
    summary.add_column("value", justify="right")
    summary.add_column("target / note")
    summary.add_row("ours, 5 services", ms(five["ours_s"]), f"≤ 1 ms; {five['actions']} actions")
    summary.add_row(
        f"ours, {longest['actions']}-action plan",
        ms(longest["ours_s"]),
        f"≤ 50 ms; {longest['services']} services",
    )
    if five["aries_s"] is not None:
        summary.add_row(
            "Aries (UP), 5 services",
            f"{five['aries_s']:.2f} s",
            f"{five['aries_s'] / five['ours_s']:,.0f} × ours",
        )
    summary.add_row("GTPyhop / ours, median over all sizes", f"{ratio:.1f} ×", "same domain functions")
    summary.add_row(
        "make_domain(paper)", ms(median_seconds(lambda: make_domain(home))), "once per home, not in the times"
    )
    console.print(summary)

    if args.json:
        args.json.write_text(
            json.dumps({"seed": SEED, "by_services": by_services, "by_length": by_length}, indent=2) + "\n"
        )
    if not args.no_png:
        plot(by_services, by_length, args.png)
        console.print(f"plot: {args.png}", style="dim")


if __name__ == "__main__":
    main()
