"""Benchmark of learning from people: households with wishes of their own.

For each home — the built-in ``paper``, the test homes ``studio`` and ``flat``, and a generated
home of several rooms (benchmarks/homes.py) — households written at random from the home's
features (homecog/evaluation/households.py), not from its comfort rules:

- ``wishes``: their own rules over the home's values and bins, every switch made;
- ``wishes, noisy``: the same, but 15 % of their switches not made and a whim now and then;
- ``thresholds, noisy``: rules with thresholds on readings inside the home's bins, noisy.

Every method learns the home first (the same samples), then lives through a stream of the
household's events: it predicts each event, then learns it (the trees as a correction of the
household, the online baselines by ``learn_one``; K-means stays as trained). Printed per
household: the prequential F1 over the stream (against what the household did), and the F1 on
held-out contexts after the stream (against what its rules ask for). The oracle answers with
the household's rules. Beside the stream's figures: multi's F1 minus the best other learner's and
minus the oracle's, each with a 95 % paired bootstrap interval over the events.

    bin/bench corrections            # or: python benchmarks/bench_corrections.py --quick
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

sys.path.insert(0, str(Path(__file__).parent))
from homes import home_text

from homecog.evaluation.households import Household, make_household, oracle_predict
from homecog.evaluation.leads import leads
from homecog.evaluation.learn import learn_methods
from homecog.evaluation.methods import TreeMethod
from homecog.evaluation.metrics import prf
from homecog.evaluation.registry import METHOD_NAMES
from homecog.home import load_home
from homecog.home.model import Home
from homecog.knowledge.pipeline import ensure_policy

ROOT = Path(__file__).resolve().parent.parent
USER = "household"
HOUSEHOLDS = (("wishes", False), ("wishes", True), ("thresholds", True))


def homes(rooms: int) -> list[Home]:
    out = [
        load_home("paper"),
        load_home(ROOT / "tests/homes/studio.yaml"),
        load_home(ROOT / "tests/homes/flat.yaml"),
    ]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"rooms{rooms}.yaml"
        path.write_text(home_text(rooms))
        out.append(load_home(path))
    return out


def run_household(
    learned: dict[str, Any], household: Household, *, noisy: bool, events: int, held_out: int, seed: int
) -> dict[str, dict[str, float]]:
    """Prequential F1 over the household's stream and F1 on held-out contexts, per method."""
    methods = {name: copy.deepcopy(m) for name, m in learned.items()}
    for m in methods.values():
        if isinstance(m, TreeMethod):
            m.user = USER
    stream = household.stream(events, seed=seed, noisy=noisy)
    test = household.stream(held_out, seed=seed + 1000, noisy=False)
    totals = {name: [0, 0, 0] for name in [*methods, "oracle"]}
    counts: dict[str, list[tuple[int, int, int]]] = {name: [] for name in totals}  # per event
    seconds = dict.fromkeys(methods, 0.0)
    for e in stream:
        for name, m in methods.items():
            t0 = time.perf_counter()
            predicted = set(m.predict_one(e.point))
            m.learn_one(e.point, sorted(e.wanted))
            seconds[name] += time.perf_counter() - t0
            counts[name].append(_tally(totals[name], predicted, e.wanted))
        counts["oracle"].append(_tally(totals["oracle"], set(e.clean), e.wanted))
    out: dict[str, dict[str, float]] = {}
    for name in totals:
        held = [0, 0, 0]
        for e in test:
            predicted = set(
                oracle_predict(household, e.point) if name == "oracle" else methods[name].predict_one(e.point)
            )
            _tally(held, predicted, e.clean)
        out[name] = {
            "stream_f1": round(prf(*totals[name])[2], 4),
            "held_out_f1": round(prf(*held)[2], 4),
            "seconds": round(seconds.get(name, 0.0), 2),
        }
    if "multi" in counts:  # multi's lead over the best other learner, and over the oracle
        versus = leads(counts)
        others = [n for n in versus if n != "oracle"]
        best = max(others, key=lambda n: out[n]["stream_f1"]) if others else None
        out["multi"]["lead"] = {"over": best, **versus[best].as_dict()} if best else {}
        out["multi"]["oracle"] = versus["oracle"].as_dict()
    return out


def _tally(t: list[int], predicted: set[str], truth: frozenset[str]) -> tuple[int, int, int]:
    event = (len(predicted & truth), len(predicted), len(truth))
    for k in range(3):
        t[k] += event[k]
    return event


def _arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="300 events, 300 held-out contexts")
    parser.add_argument("--events", type=int, default=1000)
    parser.add_argument("--held-out", type=int, default=500)
    parser.add_argument("--seeds", type=int, default=1, help="households of each kind per home")
    parser.add_argument("--rooms", type=int, default=8, help="rooms of the generated home (8: 48 devices)")
    parser.add_argument("--homes", default="", help="comma-separated home names to run (default all)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.quick:
        args.events, args.held_out, args.seeds = 300, 300, 1
    return args


def run_all(args: argparse.Namespace, names: list[str]) -> list[dict[str, Any]]:
    """Every household of every home asked for: its label and every method's figures."""
    rows = []
    for home in homes(args.rooms):
        if args.homes and home.name not in args.homes.split(","):
            continue
        learned = learn_methods(home, ensure_policy(home), names, seed=0)
        for kind, noisy in HOUSEHOLDS:
            for seed in range(args.seeds):
                household = make_household(home, kind, seed=seed)
                figures = run_household(
                    learned.methods,
                    household,
                    noisy=noisy,
                    events=args.events,
                    held_out=args.held_out,
                    seed=seed,
                )
                label = f"{home.name}: {kind}{', noisy' if noisy else ''} #{seed}"
                rows.append({"household": label, "methods": figures})
                print(label, json.dumps({k: v["stream_f1"] for k, v in figures.items()}), file=sys.stderr)
    return rows


def print_tables(rows: list[dict[str, Any]], names: list[str], events: int) -> None:
    """The stream's and the held-out contexts' F1, a table each; the stream's with intervals."""
    columns = [*names, "oracle"]
    for measure, title in (
        ("stream_f1", "prequential F1 over the stream"),
        ("held_out_f1", "F1 on held-out contexts"),
    ):
        table = Table(title=f"Corrections: {title} ({events} events)")
        table.add_column("household")
        for c in columns:
            table.add_column(c, justify="right")
        stream = measure == "stream_f1"
        if stream:  # 95 % paired bootstrap intervals over the stream's events
            table.add_column("multi − best other [95 %]", justify="right")
            table.add_column("multi − oracle [95 %]", justify="right")
        for row in rows:
            present = row["methods"]
            cells = [f"{present[c][measure]:.4f}" if c in present else "-" for c in columns]
            if stream and "multi" in present:
                lead, oracle = present["multi"]["lead"], present["multi"]["oracle"]
                cells += [f"{_interval(lead)} ({lead['over']})" if lead else "-", _interval(oracle)]
            table.add_row(row["household"], *cells)
        Console().print(table)


def main() -> None:
    args = _arguments()
    names = [m for m in METHOD_NAMES if m != "paper"]
    rows = run_all(args, names)
    if args.json:
        print(json.dumps(rows))
    else:
        print_tables(rows, names, args.events)


def _interval(d: dict[str, Any]) -> str:
    if d["low"] is None:
        return f"{d['difference']:+.3f} [too few events]"
    return f"{d['difference']:+.3f} [{d['low']:+.3f}, {d['high']:+.3f}]"


if __name__ == "__main__":
    main()
