"""Benchmark of homes of real size: the cost of learning against the number of devices.

    bin/bench scale                  # or: .venv/bin/python benchmarks/bench_scale.py [options]
    bin/bench scale -- --rooms 1,2,4,8,16,32,167 --scenes 8,32,167 --repeats 3

Homes of 1 to 32 rooms of 6 devices and a building of 167 rooms (1,002 devices;
benchmarks/homes.py), and homes of 8, 32 and 167 rooms with a scene per room (its light, its
desk lamp switched by hand and its TV off) and three whole-home scenes
(benchmarks/scene_homes.py), each learned from nothing by the command line in a fresh data
directory: ``homecog train`` and ``homecog build`` (wall and peak memory of each process), the
greedy-optimal rate, the multi tree's precision and recall on 2,000 random scenarios
(``homecog eval --methods multi``) and its cognition p50 with explanations. Where the paper's
joint table fits (``train --joint``), the same beside it. Homes of more than 100 rooms are
learned once. The log-log plot of cost against devices goes to docs/scale.png.
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
from typing import Any

from rich.console import Console
from rich.table import Table

sys.path.insert(0, str(Path(__file__).parent))
from homes import coupled_home_text, home_text
from scene_homes import scene_home_text

ROOT = Path(__file__).resolve().parent.parent


def peak_of(args: list[str], env: dict[str, str]) -> tuple[dict[str, Any], float, int]:
    """A homecog command with --json: its answer, wall seconds and the peak memory (bytes) of that
    process alone (a fresh interpreter waits for it and reads its children's peak)."""
    code = (
        "import json, resource, subprocess, sys, time\n"
        "t = time.perf_counter()\n"
        "p = subprocess.run(sys.argv[1:], capture_output=True, text=True)\n"
        "w = time.perf_counter() - t\n"
        "print(json.dumps({'rc': p.returncode, 'out': p.stdout, 'err': p.stderr[-800:], 'wall': w,\n"
        "    'peak': resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024}))\n"
    )
    cmd = [sys.executable, "-c", code, sys.executable, "-m", "homecog.cli.main", *args, "--json"]
    res = json.loads(subprocess.run(cmd, capture_output=True, text=True, env=env, check=True).stdout)
    if res["rc"] != 0:
        raise RuntimeError(f"homecog {' '.join(args)} failed: {res['err'].strip()}")
    return json.loads(res["out"]), res["wall"], res["peak"]


def cognition_p50(home_file: Path, env: dict[str, str], n: int = 2000) -> float:
    """Median seconds of one cognition with explanations, from a context dict, on the built tree."""
    code = (
        "import json, statistics, sys, time\n"
        "from homecog.home import load_home\n"
        "from homecog.knowledge.store import Store\n"
        "from homecog.evaluation.scenarios import random_scenarios\n"
        "home = load_home(sys.argv[1]); store = Store.open(None, home); tree = store.load_tree()\n"
        "xs = [s.context for s in random_scenarios(home, int(sys.argv[2]), seed=11)]\n"
        "tree.explain_one(xs[0]); ts = []\n"
        "for x in xs:\n"
        "    t = time.perf_counter(); tree.explain_one(x); ts.append(time.perf_counter() - t)\n"
        "print(statistics.median(ts))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, str(home_file), str(n)],
        capture_output=True,
        text=True,
        env=env,
        check=True,
    )
    return float(out.stdout.strip())


def measure(home_file: Path, *, joint: bool, repeats: int, scenarios: int) -> dict[str, Any]:
    """Train, build, evaluate one home (``repeats`` times from nothing); medians."""
    flag = ["--joint"] if joint else []
    runs = []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory() as data:
            env = {**os.environ, "HOMECOG_DATA": data}
            env.pop("HOMECOG_DB", None)
            trained, train_wall, train_peak = peak_of(["train", "--home", str(home_file), *flag], env)
            built, build_wall, build_peak = peak_of(["build", "--home", str(home_file), *flag], env)
            runs.append(
                {
                    "train": train_wall,
                    "build": build_wall,
                    "peak": max(train_peak, build_peak),
                    "rate": trained["greedy_optimal_rate"],
                    "samples": built["samples"],
                    "clusters": built["clusters"],
                    "env": env,
                }
            )
            if len(runs) == repeats:  # quality and speed of the last run's tree
                evaluated, _, _ = peak_of(
                    [
                        "eval",
                        "--home",
                        str(home_file),
                        "--methods",
                        "multi",
                        "--scenarios",
                        str(scenarios),
                        *flag,
                    ],
                    env,
                )
                multi = evaluated["methods"]["multi"]
                p50 = cognition_p50(home_file, env)
    med = {k: statistics.median(r[k] for r in runs) for k in ("train", "build", "peak")}
    return {
        **med,
        "total": statistics.median(r["train"] + r["build"] for r in runs),
        "rate": runs[-1]["rate"],
        "samples": runs[-1]["samples"],
        "clusters": runs[-1]["clusters"],
        "precision": multi["precision"],
        "recall": multi["recall"],
        "p50": p50,
        "repeats": repeats,
    }


def plot(rows: list[dict[str, Any]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    grouped = [r for r in rows if not r["joint"] and r["shape"] == "rooms"]
    scenes = [r for r in rows if r["shape"] == "scenes"]
    joint = [r for r in rows if r["joint"]]
    fig, ax = plt.subplots(1, 2, figsize=(10, 4.2))
    xs = [r["devices"] for r in grouped]
    ax[0].loglog(xs, [r["total"] for r in grouped], "o-", label="grouped: train + build (wall)")
    ax[0].loglog(xs, [r["train"] for r in grouped], "s--", label="grouped: train", alpha=0.7)
    if scenes:
        ax[0].loglog(
            [r["devices"] for r in scenes],
            [r["total"] for r in scenes],
            "d-",
            label="with scenes: train + build",
        )
    if joint:
        ax[0].loglog(
            [r["devices"] for r in joint], [r["total"] for r in joint], "x", ms=10, label="joint table"
        )
    base = grouped[0]
    for slope, style in ((1, ":"), (2, "-.")):
        ax[0].loglog(
            xs, [base["total"] * (x / base["devices"]) ** slope for x in xs], style, color="grey", lw=0.8
        )
        ax[0].annotate(
            f"∝ devices^{slope}", (xs[-1], base["total"] * (xs[-1] / base["devices"]) ** slope), fontsize=7
        )
    ax[0].set_xlabel("devices")
    ax[0].set_ylabel("seconds")
    ax[0].set_title("Learning a home from nothing")
    ax[0].legend(fontsize=7)
    ax[1].loglog(xs, [r["peak"] / 2**20 for r in grouped], "o-", label="grouped")
    if scenes:
        ax[1].loglog(
            [r["devices"] for r in scenes], [r["peak"] / 2**20 for r in scenes], "d-", label="with scenes"
        )
    if joint:
        ax[1].loglog(
            [r["devices"] for r in joint], [r["peak"] / 2**20 for r in joint], "x", ms=10, label="joint"
        )
    ax[1].set_xlabel("devices")
    ax[1].set_ylabel("peak memory (MB)")
    ax[1].set_title("Peak memory of train / build")
    ax[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def refusal_seconds(folder: Path, n: int = 34, repeats: int = 5) -> float:
    """Median seconds to refuse a home too large to learn (a group of 2^n states): the size
    check counts the states, it never enumerates them."""
    from homecog.errors import HomeTooLargeError
    from homecog.home import load_home
    from homecog.learning.size import check_size

    path = folder / f"coupled{n}.yaml"
    path.write_text(coupled_home_text(n))
    home = load_home(path)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        try:
            check_size(home)
        except HomeTooLargeError:
            times.append(time.perf_counter() - start)
    assert len(times) == repeats, "the coupled home was not refused"
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rooms", default="1,2,4,8,16,32,167", help="room counts, comma-separated")
    parser.add_argument("--scenes", default="8,32,167", help="room counts of the homes with scenes")
    parser.add_argument("--repeats", type=int, default=3, help="runs from nothing per home (medians)")
    parser.add_argument("--scenarios", type=int, default=2000)
    parser.add_argument("--plot", type=Path, default=ROOT / "docs" / "scale.png")
    args = parser.parse_args()
    console = Console(width=160)
    counts = lambda text: [int(r) for r in text.split(",") if r]  # noqa: E731
    homes = [("rooms", r, False) for r in counts(args.rooms)] + [("rooms", 1, True)]
    homes += [("scenes", r, False) for r in counts(args.scenes)]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for shape, r, joint in homes:
            path = Path(tmp) / f"{shape}{r}.yaml"
            path.write_text(home_text(r) if shape == "rooms" else scene_home_text(r))
            console.print(f"{shape}{r} ({6 * r} devices){' joint' if joint else ''} ...", style="dim")
            repeats = 1 if r > 100 else args.repeats
            row = measure(path, joint=joint, repeats=repeats, scenarios=args.scenarios)
            rows.append({"shape": shape, "rooms": r, "devices": 6 * r, "joint": joint, **row})
    table = Table(title="Homes of real size (medians; a fresh data directory each run)", title_justify="left")
    cols = (
        "home",
        "devices",
        "train s",
        "build s",
        "train+build s",
        "peak MB",
        "rate",
        "samples",
        "clusters",
    )
    for col in (*cols, "precision", "recall", "cognition p50"):
        table.add_column(col, justify="left" if col == "home" else "right")
    for r in rows:
        table.add_row(
            f"{r['shape']}{r['rooms']}{' joint' if r['joint'] else ''}",
            str(r["devices"]),
            f"{r['train']:.1f}",
            f"{r['build']:.1f}",
            f"{r['total']:.1f}",
            f"{r['peak'] / 2**20:,.0f}",
            f"{r['rate']:.6f}",
            f"{r['samples']:,}",
            f"{r['clusters']:,}",
            f"{r['precision']:.4f}",
            f"{r['recall']:.4f}",
            f"{r['p50'] * 1e6:,.0f} µs",
        )
    console.print(table)
    by_devices = {r["devices"]: r for r in rows if not r["joint"] and r["shape"] == "rooms"}
    if 48 in by_devices and 192 in by_devices:
        console.print(
            f"cost of 192 devices / cost of 48: {by_devices[192]['total'] / by_devices[48]['total']:.2f}"
        )
    with tempfile.TemporaryDirectory() as tmp:
        refused = refusal_seconds(Path(tmp))
    console.print(f"a home too large to learn (a group of 2^34 states) refused in {refused * 1e3:.1f} ms")
    plot(rows, args.plot)
    console.print(f"plot: {args.plot}")


if __name__ == "__main__":
    main()
