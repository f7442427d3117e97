"""A household's long history: how learning it and living with it scale with its rows.

On the family flat of the test homes (27 devices, 61 services), one user's history of random,
inconsistent wishes (the worst case: every row a whole set of up to three services drawn at
random) of N rows, for several N:

- ``correct --events FILE`` (a process of its own, SQLite): its wall time, rows a second and
  peak memory;
- after a restart (a new process): loading the tree, and the first cognition for the user,
  whose layer starts from the one ``correct --events`` kept (and, beside it, learned from every
  correction, as where nothing was kept);
- the next cognition on a second server for that user after one more correction through the
  first (it learns the one correction on top).

    bin/bench load                  # or: .venv/bin/python benchmarks/bench_load.py [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rich.console import Console
from rich.table import Table

ROOT = Path(__file__).resolve().parent.parent
HOME = ROOT / "tests" / "homes" / "family.yaml"

#: run in a process of its own: the first cognition after a restart, and a second server's next
PROBE = """
import json, sys, time
from homecog.home import load_home
from homecog.knowledge import core
from homecog.knowledge.correction import Correction
from homecog.knowledge.store import Store
from homecog.evaluation.scenarios import random_scenarios
home = load_home(sys.argv[1]); url = sys.argv[2]
points = [s.point for s in random_scenarios(home, 3, seed=99)]
other, one = Store.open(url, home), Store.open(url, home)
cold = other.load_tree(); cold.layers.snapshots = None  # nothing kept: learned from the first
t = time.perf_counter(); cold.predict_one(points[0], "kim"); unkept = time.perf_counter() - t
t = time.perf_counter(); tree = other.load_tree(); load = time.perf_counter() - t
t = time.perf_counter(); tree.predict_one(points[0], "kim"); first = time.perf_counter() - t
writer = one.load_tree()
core.correct(one, writer, Correction.whole("kim", points[1], []))
t = time.perf_counter(); tree = core.refresh(other, tree); tree.predict_one(points[2], "kim")
print(json.dumps({"load": load, "first": first, "unkept": unkept, "next": time.perf_counter() - t}))
"""


def event_file(path: Path, rows: int, seed: int = 0) -> Path:
    """``rows`` random whole-set wishes of one user (kim) on the family flat, a minute apart."""
    from homecog.evaluation.scenarios import random_scenarios
    from homecog.home import load_home
    from homecog.home.codec import Space

    home = load_home(HOME)
    space, rng = Space(home), random.Random(seed)
    singles = [s.name for s in home.services if len(s.sets) <= 1]  # never a scene with its device
    names = [*space.names]
    lines = [",".join(["timestamp", *names, "services", "user"])]
    for i, s in enumerate(random_scenarios(home, rows, seed=seed)):
        context = space.context(s.point)
        day, minute = divmod(i, 24 * 60)
        stamp = f"2026-01-{1 + day % 28:02d}T{minute // 60:02d}:{minute % 60:02d}:{i // (28 * 1440):02d}"
        wants = ";".join(rng.sample(singles, rng.randint(0, 3)))
        lines.append(",".join([stamp, *(context[n] for n in names), wants, "kim"]))
    path.write_text("\n".join(lines) + "\n")
    return path


def run(args: list[str], env_dir: Path) -> tuple[float, float, str]:
    """Seconds and peak MB of a homecog command, and its output."""
    env = {**os.environ, "HOMECOG_DATA": str(env_dir)}
    code = (
        "import resource, sys\nfrom homecog.cli.main import main\ntry:\n    code = main(sys.argv[1:])\n"
        "finally:\n    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss\n"
        "    print('PEAK', peak, file=sys.stderr)\nsys.exit(code)\n"
    )
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", code, *args], capture_output=True, text=True, env=env, check=False
    )
    seconds = time.perf_counter() - start
    peak = next((int(line.split()[1]) for line in done.stderr.splitlines() if line.startswith("PEAK")), 0)
    if done.returncode:
        raise SystemExit(f"{' '.join(args)} failed: {done.stderr.strip().splitlines()[-2:]}")
    return seconds, peak / 1024, done.stdout


def measure(rows: int, tmp: Path) -> dict[str, float]:
    db = f"sqlite:///{tmp / f'load{rows}.sqlite'}"
    events = event_file(tmp / f"events{rows}.csv", rows)
    run(["build", "--home", str(HOME), "--db", db], tmp)
    seconds, peak, _ = run(
        ["correct", "--home", str(HOME), "--db", db, "--events", str(events), "--json"], tmp
    )
    probe = subprocess.run(
        [sys.executable, "-c", PROBE, str(HOME), db],
        capture_output=True,
        text=True,
        check=True,
        env={**__import__("os").environ, "HOMECOG_DATA": str(tmp)},
    )
    after = json.loads(probe.stdout.strip().splitlines()[-1])
    return {"rows": rows, "seconds": seconds, "peak": peak, **after}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1,000 and 2,000 rows only")
    sizes = [1000, 2000] if parser.parse_args().quick else [1000, 3000, 10000]
    console = Console()
    with tempfile.TemporaryDirectory() as folder:
        results = []
        for n in sizes:
            console.print(f"[dim]{n:,} rows ...[/dim]")
            results.append(measure(n, Path(folder)))
    table = Table(title="One user's history of random wishes, family flat, SQLite")
    for name in (
        "rows",
        "correct --events",
        "rows/s",
        "peak",
        "restart: load",
        "first cognition (layer kept)",
        "(nothing kept)",
        "next on 2nd server",
    ):
        table.add_column(name, justify="right")
    for r in results:
        table.add_row(
            f"{r['rows']:,}",
            f"{r['seconds']:.1f} s",
            f"{r['rows'] / r['seconds']:.0f}",
            f"{r['peak']:.0f} MB",
            f"{r['load'] * 1e3:,.0f} ms",
            f"{r['first'] * 1e3:,.0f} ms",
            f"{r['unkept']:,.1f} s",
            f"{r['next'] * 1e3:.1f} ms",
        )
    console.print(table)


if __name__ == "__main__":
    main()
