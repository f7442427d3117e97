"""Benchmark of the environment core and Sarsa on the paper home (issue: the foundation).

Prints one table. Figures are medians over repeated runs in this one process, so their
ratios are fair; the machine is noisy, so compare runs, not single numbers.

    bin/bench train            # or: .venv/bin/python benchmarks/bench_train.py [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from homecog.environment.core import Core
from homecog.environment.reachability import greedy_outcomes
from homecog.home import load_home
from homecog.learning.grouped import train_policy
from homecog.learning.qtable import QTable
from homecog.learning.sarsa import NO_STARTS, SarsaConfig, run_episodes, seed_rng, train

ROOT = Path(__file__).resolve().parent.parent

PLAIN = """
import sys, time
from homecog.environment.core import Core
from homecog.home import load_home
from homecog.learning.qtable import QTable
from homecog.learning.sarsa import NO_STARTS, run_episodes, seed_rng
core = Core(load_home("paper"))
table = QTable.empty(core)
start = time.perf_counter()
steps = run_episodes(core.tables, table.q, table.tried, int(sys.argv[1]), 0, 1.0, 0.2, 2.0, 0.0, 30,
                     seed_rng(0), NO_STARTS, NO_STARTS)
print(steps, time.perf_counter() - start)
"""


def ceiling(n_rows: int, n_cols: int, repeats: int) -> float:
    """Random read-modify-writes per second of a Q-table-sized float32 array (NumPy)."""
    q = np.zeros(n_rows * n_cols, dtype=np.float32)
    idx = np.random.default_rng(0).integers(0, q.size, 10_000_000)
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        q[idx] += 1.0
        rates.append(idx.size / (time.perf_counter() - start))
    return statistics.median(rates)


def kernel_rate(core: Core, episodes: int, repeats: int) -> tuple[float, int]:
    """Steps per second of the compiled kernel on the first ``episodes`` episodes from scratch."""
    rates, steps = [], 0
    for _ in range(repeats):
        table = QTable.empty(core)
        start = time.perf_counter()
        steps = run_episodes(
            core.tables,
            table.q,
            table.tried,
            episodes,
            0,
            1.0,
            0.2,
            2.0,
            0.0,
            30,
            seed_rng(0),
            NO_STARTS,
            NO_STARTS,
        )
        rates.append(steps / (time.perf_counter() - start))
    return statistics.median(rates), steps


def plain_rate(episodes: int) -> tuple[float, int]:
    """The same kernel interpreted (NUMBA_DISABLE_JIT=1): a plain-Python loop of the algorithm."""
    env = {**os.environ, "NUMBA_DISABLE_JIT": "1"}
    out = subprocess.run(
        [sys.executable, "-c", PLAIN, str(episodes)], capture_output=True, text=True, env=env, check=True
    ).stdout.split()
    steps, seconds = int(out[0]), float(out[1])
    return steps / seconds, steps


def batched_rate(core: Core, repeats: int) -> float:
    """Steps per second of ``Core.step_many`` on a million random (state, service) pairs."""
    rng = np.random.default_rng(1)
    s = rng.integers(0, core.n_states, 1_000_000)
    c = np.searchsorted(core.tables.offsets, s, side="right") - 1
    k = core.tables.need_count[c]
    rest = s - core.tables.offsets[c]
    h, n = rest >> k, rest & ((1 << k) - 1)
    a = rng.integers(0, core.n_services, s.size)
    core.step_many(c[:10], h[:10], n[:10], a[:10])
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        core.step_many(c, h, n, a)
        rates.append(s.size / (time.perf_counter() - start))
    return statistics.median(rates)


def time_to_rate(core: Core, seed: int, chunk: int, limit: int) -> dict[str, float | None]:
    """Training seconds (evaluation excluded) and episodes until the rate reaches 0.999 and 1.0."""
    home = core.home
    table = QTable.empty(core)
    seconds, found = 0.0, {}
    while table.episodes < limit and "1.0" not in found:
        result = train(home, SarsaConfig(episodes=chunk, seed=seed), core=core, q_table=table)
        seconds += result.seconds
        rate = float(greedy_outcomes(core.tables, table.q).mean())
        for key, threshold in (("0.999", 0.999), ("1.0", 1.0)):
            if key not in found and rate >= threshold:
                found[key] = (seconds, table.episodes)
    return {
        "seconds_0999": found.get("0.999", (None,))[0],
        "episodes_0999": found.get("0.999", (0, None))[1],
        "seconds_1": found.get("1.0", (None,))[0],
        "episodes_1": found.get("1.0", (0, None))[1],
    }


def cli_wall(repeats: int, *flags: str) -> tuple[float, float]:
    """Wall seconds of ``homecog train --home paper`` with default settings, and its rate."""
    walls, rate = [], 0.0
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "HOMECOG_DATA": tmp}
        for _ in range(repeats):
            start = time.perf_counter()
            out = subprocess.run(
                [sys.executable, "-m", "homecog.cli.main", "train", "--home", "paper", "--json", *flags],
                capture_output=True,
                text=True,
                env=env,
                check=True,
            ).stdout
            walls.append(time.perf_counter() - start)
            rate = json.loads(out)["greedy_optimal_rate"]
    return statistics.median(walls), rate


def median(values: list[float | None]) -> float | None:
    got = [v for v in values if v is not None]
    return statistics.median(got) if len(got) == len(values) else None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats and seeds")
    args = parser.parse_args()
    repeats, seeds = (1, [0]) if args.quick else (3, [0, 1, 2])
    console = Console(width=130)
    home = load_home("paper")
    core = Core(home)
    train(home, SarsaConfig(episodes=10), core=core)  # compile (or load the compiled cache)

    console.print("measuring ...", style="dim")
    ceil = ceiling(core.n_states, core.n_services, repeats)
    episodes = 5_000
    compiled_small, steps_small = kernel_rate(core, episodes, repeats)
    plain, plain_steps = plain_rate(episodes)
    batched = batched_rate(core, repeats)
    runs = [train(home, SarsaConfig(seed=s), core=core) for s in seeds]
    full_rate = statistics.median(r.steps_per_second for r in runs)
    reach = [time_to_rate(core, s, 100_000, 20_000_000) for s in seeds]
    wall, wall_rate = cli_wall(repeats, "--joint")
    grouped = [train_policy(home, SarsaConfig(seed=s)) for s in seeds]
    grouped_wall, grouped_rate = cli_wall(repeats)

    table = Table(
        title=f"Sarsa on the paper home ({core.n_states:,} states × {core.n_services} services; "
        f"medians of {len(seeds)} seeds / {repeats} repeats)",
        title_justify="left",
    )
    table.add_column("figure")
    table.add_column("value", justify="right")
    table.add_column("note")
    table.add_row("random RMW of a Q-sized array (NumPy)", f"{ceil / 1e6:.1f} M/s", "the ceiling")
    table.add_row(
        "compiled kernel, full default run",
        f"{full_rate / 1e6:.2f} M steps/s",
        f"{SarsaConfig().episodes:,} episodes, {runs[0].steps:,} steps",
    )
    table.add_row(
        f"compiled kernel, first {episodes:,} episodes",
        f"{compiled_small / 1e6:.2f} M steps/s",
        f"{steps_small:,} steps",
    )
    table.add_row(
        f"plain-Python loop, first {episodes:,} episodes",
        f"{plain / 1e3:.1f} k steps/s",
        f"same code, NUMBA_DISABLE_JIT=1; {plain_steps:,} steps",
    )
    table.add_row("compiled / plain-Python", f"{compiled_small / plain:,.0f} ×", "same episodes")
    table.add_row("Core.step_many (batched env step)", f"{batched / 1e6:.1f} M steps/s", "1 M random pairs")
    for key, label in (("0999", "0.999"), ("1", "1.0")):
        secs = median([r[f"seconds_{key}"] for r in reach])
        eps = median([r[f"episodes_{key}"] for r in reach])
        table.add_row(
            f"training seconds to rate {label}",
            "not reached" if secs is None else f"{secs:.1f} s",
            ""
            if eps is None
            else f"{eps / 1e6:.2f} M episodes; per seed "
            + ", ".join(f"{r[f'seconds_{key}']:.1f}" if r[f"seconds_{key}"] else "-" for r in reach),
        )
    table.add_row(
        "`homecog train --home paper --joint` wall",
        f"{wall:.1f} s",
        f"default settings, rate {wall_rate:.6f}; includes start-up and saving",
    )
    table.add_row(
        "grouped (10 groups): training seconds to the end",
        f"{statistics.median(r.seconds for r in grouped):.2f} s",
        f"rate per seed {', '.join(f'{r.greedy_optimal_rate:.6f}' for r in grouped)}; "
        f"{statistics.median(r.episodes for r in grouped):,.0f} episodes, "
        f"{statistics.median(r.steps for r in grouped):,.0f} steps",
    )
    table.add_row(
        "`homecog train --home paper` wall (grouped, the default)",
        f"{grouped_wall:.1f} s",
        f"rate {grouped_rate:.6f}; includes start-up and saving",
    )
    console.print(table)


if __name__ == "__main__":
    main()
