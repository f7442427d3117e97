"""Benchmark of the robot's bodies on the same plans: homecog's own 2D simulator beside pyrobosim
with each of its path planners, on the paper home.

    bin/bench bodies           # or: .venv/bin/python benchmarks/bench_bodies.py [--quick] [--json F]

The plans: for each place where the user can be (sofa, table, bed, dining table), the paper's
evening request (SendDrinks, TurnOnLamp, CloseWindow, ChargeItSelf) and every service of the
home the robot's body does alone (bring, speak, dock, switch by hand), each from the home's
initial state (the robot on its charger, the lamp off). Each body carries every plan out with
acting (:func:`homecog.simulation.bodies.carry_out`), so a failed action is planned again.

Per body: how long it takes to make (pyrobosim loads the world and builds its planner), the plans
achieved, the actions that failed, the wall time per plan (median and 95th percentile: planning
paths and driving them at full speed, pyrobosim's executor resting 0.1 s after each path), the
path driven per plan and the robot's own time per plan (driving at 0.5 m/s and the actions'
durations). The sampling planners (RRT, PRM) draw from numpy's generator, seeded once per body.
"""

from __future__ import annotations

import argparse
import json
import logging
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from homecog.home import load_home
from homecog.home.model import Home
from homecog.planning import Plan, initial_state, plan_services
from homecog.simulation.bodies import carry_out, make_body

ROOT = Path(__file__).resolve().parent.parent
EVENING = ["SendDrinks", "TurnOnLamp", "CloseWindow", "ChargeItSelf"]
BODIES = [
    ("builtin", None),
    ("pyrobosim", "astar"),
    ("pyrobosim", "rrt"),
    ("pyrobosim", "prm"),
    ("pyrobosim", "world_graph"),
]


def body_services(home: Home) -> list[str]:
    """The services the body carries out itself: errands and switches by hand."""
    iot = {d.name for d in home.devices if d.iot}
    return [s.name for s in home.services if not s.sets or any(d not in iot for d, _ in s.sets)]


def plans(home: Home, *, quick: bool) -> list[Plan]:
    """The same plans for every body (see the module's docstring)."""
    places = ["sofa", "table", "bed", "dining_table"][: 2 if quick else 4]
    requests = [EVENING, *([s] for s in body_services(home))]
    return [plan_services(home, r, state=initial_state(home, user=p)) for p in places for r in requests]


def run_body(home: Home, kind: str, planner: str | None, todo: list[Plan]) -> dict[str, Any]:
    begin = time.perf_counter()
    body = make_body(kind, home, planner=planner)
    made = time.perf_counter() - begin
    walls, paths, seconds, achieved, failed, replans = [], [], [], 0, 0, 0
    for plan in todo:
        t = time.perf_counter()
        acting, run = carry_out(body, plan)
        walls.append(time.perf_counter() - t)
        achieved += acting.achieved
        failed += len(acting.failures)
        replans += acting.replans
        if acting.achieved:
            paths.append(run.distance_m)
            seconds.append(run.seconds)
    walls.sort()
    return {
        "body": kind,
        "planner": body.planner,
        "setup_s": round(made, 3),
        "plans": len(todo),
        "achieved": achieved,
        "failed_actions": failed,
        "replans": replans,
        "wall_ms_median": round(1000 * statistics.median(walls), 1),
        "wall_ms_p95": round(1000 * walls[min(len(walls) - 1, round(0.95 * (len(walls) - 1)))], 1),
        "path_m_mean": round(statistics.fmean(paths), 2) if paths else None,
        "robot_s_mean": round(statistics.fmean(seconds), 1) if seconds else None,
        "path_planning_s": round(getattr(body, "planning_seconds", 0.0), 2),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="half the user's places")
    parser.add_argument("--json", type=Path, help="also write the rows as JSON here")
    args = parser.parse_args(argv)
    logging.getLogger("homecog.planning.acting").setLevel(logging.ERROR)  # failures are counted
    home = load_home("paper")
    todo = plans(home, quick=args.quick)
    rows = []
    for kind, planner in BODIES:
        try:
            rows.append(run_body(home, kind, planner, todo))
        except Exception as e:  # pyrobosim not installed: said, the others still measured
            print(f"{kind} ({planner}): {e}", file=sys.stderr)
    table = Table(title=f"The robot's bodies on {len(todo)} plans of the paper home")
    for column in (
        "body", "path planner", "made in s", "plans achieved", "failed actions", "replans",
        "wall ms per plan (median)", "(p95)", "path m per plan", "robot s per plan",
    ):  # fmt: skip
        table.add_column(column, justify="left" if column in ("body", "path planner") else "right")
    for r in rows:
        table.add_row(
            r["body"], r["planner"], f"{r['setup_s']:.2f}", f"{r['achieved']}/{r['plans']}",
            str(r["failed_actions"]), str(r["replans"]),
            f"{r['wall_ms_median']:.1f}", f"{r['wall_ms_p95']:.1f}",
            f"{r['path_m_mean']:.2f}" if r["path_m_mean"] is not None else "-",
            f"{r['robot_s_mean']:.1f}" if r["robot_s_mean"] is not None else "-",
        )  # fmt: skip
    Console(width=160).print(table)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
