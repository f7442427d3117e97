"""Benchmark of the robot living with a household: the closed loop, and how fast a person's
switch is learned.

    bin/bench household            # or: .venv/bin/python benchmarks/bench_household.py [--days N]

1. The closed loop (``homecog eval --truth T --days N``) for homes and households of other
   wishes: the household's own switches on day 1 and a day over the last three, the share of the
   robot's switches it undid over them, fights.
2. A person's switch seen (the source tells the runtime) → learned, logged in SQLite, and in the
   next cognition: its latency over many switches in random contexts, beside an explicit
   correction's commit.
"""

from __future__ import annotations

import argparse
import random
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from homecog.context.manual import ManualSource
from homecog.evaluation.closed_loop import closed_loop
from homecog.evaluation.scenarios import random_scenarios
from homecog.home import load_home
from homecog.knowledge import core
from homecog.knowledge.correction import Correction
from homecog.knowledge.pipeline import open_tree
from homecog.knowledge.store import Store
from homecog.robot.runtime import Runtime

TESTS = Path(__file__).parent.parent / "tests" / "homes"
JUNE, MARCH = "2021-06-21 06:00", "2021-03-15 06:00"  # warm days about 25 °C at noon; cool ones
PAIRS = [
    ("paper", "paper_ann", JUNE),
    ("paper", "paper_ann", MARCH),
    ("paper", "paper", JUNE),
    (str(TESTS / "studio.yaml"), str(TESTS / "studio_kim.yaml"), JUNE),
]


def loops(days: int, console: Console) -> None:
    table = Table(title=f"The closed loop, {days} simulated days", title_justify="left")
    for col in ("home", "household", "from", "day 1", "last 3 a day", "share of day 1", "undone (last 3)"):
        table.add_column(col, justify="right")
    table.add_column("fights", justify="right")
    table.add_column("seconds", justify="right")
    first = None
    for home_name, truth_name, start in PAIRS:
        home, truth = load_home(home_name), load_home(truth_name)
        store = Store.open("sqlite://", home)
        result = closed_loop(home, truth, store, open_tree(home, store), days=days, start=start)
        store.close()
        first = first or result
        d, s = result["days"], result["summary"]
        last = statistics.fmean(x["household_switches"] for x in d[-3:])
        share = "—" if s["last3_household_share"] is None else f"{s['last3_household_share']:.0%}"
        table.add_row(
            home.name,
            truth.name,
            start[:10],
            str(d[0]["household_switches"]),
            f"{last:.1f}",
            share,
            f"{s['last3_undone_share']:.1%}",
            str(s["fights"]),
            f"{result['seconds']:.0f}",
        )
    console.print(table)
    assert first is not None
    per_day = Table(title=f"{first['home']} with {first['truth']}, per day", title_justify="left")
    for col in ("day", "robot's switches", "undone", "household's own", "fights"):
        per_day.add_column(col, justify="right")
    for x in first["days"]:
        per_day.add_row(
            *(str(x[k]) for k in ("day", "robot_switches", "reversed", "household_switches", "fights"))
        )
    console.print(per_day)


def latency(switches: int, console: Console) -> None:
    home = load_home("paper")
    with tempfile.TemporaryDirectory() as folder:
        store = Store.open(f"sqlite:///{folder}/k.sqlite", home)
        source = ManualSource(home)
        runtime = Runtime(home=home, store=store, tree=open_tree(home, store), source=source)
        rng = random.Random(0)
        scenarios = random_scenarios(home, switches * 2, seed=1)
        runtime.cognize(scenarios[0].context, "default")  # the lookup table, made once
        observed, explicit = [], []
        clock = [0.0]
        source.clock = lambda: clock[0]  # type: ignore[method-assign]  # two minutes between switches
        for k in range(switches):
            clock[0] += 120.0
            source.set_context(scenarios[k].context)
            device = rng.choice(home.device_names)
            on = source.snapshot()[device] == "off"
            t = time.perf_counter()
            source.switch(device, on)  # a person: told to the runtime, learned, logged
            runtime.cognize(source.snapshot(), "default")
            observed.append(time.perf_counter() - t)
            point = runtime.space.point(scenarios[switches + k].context)
            t = time.perf_counter()
            with runtime.lock:
                core.correct(runtime.store, runtime.tree, Correction.whole("kim", point, []))
            explicit.append(time.perf_counter() - t)
        learned = runtime.guidance.counts
        store.close()
    assert learned["observed"] + learned["undo"] + learned["no_service"] == switches, learned
    table = Table(
        title=f"A person's switch to the next cognition, {switches} switches, SQLite", title_justify="left"
    )
    for col in ("", "p50 ms", "p95 ms", "max ms"):
        table.add_column(col, justify="right")
    for name, xs in (
        ("observed switch → learned → cognition", observed),
        ("explicit correction committed", explicit),
    ):
        arr = np.array(xs) * 1000
        table.add_row(
            name, f"{np.percentile(arr, 50):.2f}", f"{np.percentile(arr, 95):.2f}", f"{arr.max():.2f}"
        )
    console.print(table)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--days", type=int, default=14)
    parser.add_argument("--switches", type=int, default=300)
    args = parser.parse_args()
    console = Console(width=120)
    latency(args.switches, console)
    loops(args.days, console)


if __name__ == "__main__":
    main()
