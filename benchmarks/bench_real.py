"""Real households: every method replayed on every real home's stream, multi's lead with its
interval, and a learning curve per home.

The homes are the MIT home-activity subjects (``homecog adapt-mit``) and van Kasteren's houses
A, B and C (``homecog adapt-kasteren``), each made into an event file of switch rows and quiet
rows by ``homecog log events``. Each stream is replayed prequentially with every method (each
event predicted, then learned); the table gives every method's F1, multi's lead over the best
baseline (of every method but homecog's own modes, multi and paper) and over ``ha_usage`` and
``markov``, with 95 % paired bootstrap intervals over the events. Writes
``docs/eval/real/<home>.png`` (the running F1 of every method), ``real.json`` beside them
the table between the ``real`` markers of docs/figures.md and a short one between those of
README.md (when every home was replayed):

    bin/bench real
    .venv/bin/python benchmarks/bench_real.py [--homes mit_subject1,kasteren_a] [--no-readme]
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from rich.console import Console

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from homecog.evaluation import kasteren, mit  # noqa: E402
from homecog.evaluation.registry import METHOD_NAMES  # noqa: E402
from homecog.evaluation.replay import ReplayResult, replay  # noqa: E402
from homecog.evaluation.report import running_chart  # noqa: E402
from homecog.home import load_home  # noqa: E402

DATA = ROOT.parent / "shared" / "realdata"
HOMES = ("mit_subject1", "mit_subject2", "kasteren_a", "kasteren_b", "kasteren_c")
OUT = ROOT / "docs" / "eval" / "real"
README = ROOT / "docs" / "figures.md"  # where the whole table is (README.md: a short one)
BEGIN, END = "<!-- real:begin -->", "<!-- real:end -->"
console = Console(stderr=True)


def convert(name: str, data: Path, tmp: Path) -> tuple[Path, Path]:
    """The home file and event file of one real home, made from its raw data."""
    if name.startswith("mit_"):
        home, events, _ = mit.convert(data / "mit-home-activity" / name.removeprefix("mit_"), tmp, name)
        return home, events
    house = kasteren.convert(data / "kasteren", name.removeprefix("kasteren_"), tmp, name)
    return house.home, house.events


def run(name: str, data: Path, tmp: Path) -> ReplayResult:
    home_path, events = convert(name, data, tmp)
    return replay(load_home(home_path), events, methods=METHOD_NAMES, points=100)


def _lead(result: ReplayResult, other: str) -> str:
    d = result.versus()[other]
    return f"{d.difference:+.3f} [{d.low:+.3f}, {d.high:+.3f}]"


def table_markdown(results: dict[str, ReplayResult], switches: dict[str, int]) -> str:
    methods = list(METHOD_NAMES)
    head = "| home | events (switch + quiet) | " + " | ".join(methods)
    head += " | multi − best baseline [95 %] | multi − ha_usage | multi − markov |"
    lines = [head, "|---|---|" + "---|" * len(methods) + "---|---|---|"]
    for name, r in results.items():
        f1 = {m: r.methods[m]["f1"] for m in methods if m in r.methods}
        best = max(f1.values())
        cells = [
            (f"**{f1[m]:.3f}**" if f1[m] == best else f"{f1[m]:.3f}") if m in f1 else "–" for m in methods
        ]
        other = max((m for m in f1 if m not in ("multi", "paper")), key=f1.__getitem__)
        events = f"{r.events:,} ({switches[name]:,} + {r.events - switches[name]:,})"
        lines.append(
            f"| [{name}](eval/real/{name}.png) | {events} | "
            + " | ".join(cells)
            + f" | {_lead(r, other)} ({other}) | {_lead(r, 'ha_usage')} | {_lead(r, 'markov')} |"
        )
    return "\n".join(lines)


def summary_markdown(results: dict[str, ReplayResult]) -> str:
    """The README's short table: per home, multi's F1, the best baseline's and multi's leads."""
    lines = [
        "| home | multi | best baseline | multi − best baseline [95 %] | multi − ha_usage | multi − markov |",
        "|---|---|---|---|---|---|",
    ]
    for name, r in results.items():
        f1 = {m: v["f1"] for m, v in r.methods.items()}
        other = max((m for m in f1 if m not in ("multi", "paper")), key=f1.__getitem__)
        lines.append(
            f"| [{name}](docs/eval/real/{name}.png) | {f1['multi']:.3f} | {other} {f1[other]:.3f} | "
            f"{_lead(r, other)} | {_lead(r, 'ha_usage')} | {_lead(r, 'markov')} |"
        )
    return "\n".join(lines)


def update_readme(markdown: str, path: Path = README) -> bool:
    """Put ``markdown`` between the real markers of a file; False where it has none."""
    text = path.read_text(encoding="utf-8")
    pattern = re.compile(re.escape(BEGIN) + ".*?" + re.escape(END), re.S)
    if not pattern.search(text):
        return False
    path.write_text(pattern.sub(lambda _: f"{BEGIN}\n{markdown}\n{END}", text), encoding="utf-8")
    return True


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--homes", default=",".join(HOMES))
    parser.add_argument("--data", type=Path, default=DATA, help="the real-data folder")
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument(
        "--no-readme", action="store_true", help="leave the tables of docs/figures.md and README.md alone"
    )
    args = parser.parse_args()
    names = [h.strip() for h in args.homes.split(",") if h.strip()]
    bad = [h for h in names if h not in HOMES]
    if bad:
        parser.error(f"unknown home {bad[0]!r}; expected some of {', '.join(HOMES)}")
    if not args.data.is_dir():
        parser.error(f"--data {args.data}: no such folder")
    args.out.mkdir(parents=True, exist_ok=True)
    results: dict[str, ReplayResult] = {}
    switches: dict[str, int] = {}
    summary: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            start = time.perf_counter()
            console.log(f"{name} ...")
            r = results[name] = run(name, args.data, Path(tmp))
            switches[name] = int((r.counts["multi"][:, 2] > 0).sum())
            data = r.as_dict()
            running_chart(data, args.out / f"{name}.png")
            data.pop("running")
            summary[name] = {**data, "wall_seconds": round(time.perf_counter() - start, 1)}
            console.log(f"{name}: " + ", ".join(f"{m} {v['f1']:.3f}" for m, v in r.methods.items()))
    (args.out / "real.json").write_text(json.dumps(summary, indent=1) + "\n", encoding="utf-8")
    markdown = table_markdown(results, switches)
    print(markdown)
    if args.no_readme:
        return
    if not update_readme(markdown):
        console.log("docs/figures.md has no real markers: table printed only")
    if set(names) == set(HOMES) and not update_readme(summary_markdown(results), ROOT / "README.md"):
        console.log("README.md has no real markers: its table left alone")


if __name__ == "__main__":
    main()
