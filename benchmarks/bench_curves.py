"""Learning curves: how fast each method learns a household from its corrections or events.

Three streams, each replayed prequentially (every method predicts a row, then learns it; the
running micro F1 after every row), ``multi`` beside every baseline:

- ``paper_ann``: the paper home, whose household (``paper_ann``) wants otherwise than the robot
  learned; a simulated Ann corrects it after each of ``--corrections`` random scenarios (those
  of ``homecog eval --truth paper_ann --corrections N``, seed and all);
- ``mit_subject1``, ``mit_subject2``: the MIT home-activity data as ``homecog adapt-mit`` makes
  it, replayed as ``homecog replay`` does.

The trees and the Hoeffding trees start from the home's samples; K-means answers from its
training clusters throughout; ``frequency`` and ``naive_bayes`` start from nothing and learn the
stream alone. Writes ``docs/curves/<stream>.png``, ``docs/curves/curves.json`` and the table
between the ``curves`` markers of docs/figures.md:

    bin/bench curves
    .venv/bin/python benchmarks/bench_curves.py [--corrections 1000] [--seed 0] [--streams a,b] [--no-readme]
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
from rich.table import Table

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from homecog.evaluation.evaluate import load_scenarios  # noqa: E402
from homecog.evaluation.mit import convert  # noqa: E402
from homecog.evaluation.registry import METHOD_NAMES  # noqa: E402
from homecog.evaluation.replay import ReplayResult, replay_rows  # noqa: E402
from homecog.evaluation.scenarios import random_scenarios  # noqa: E402
from homecog.home import load_home  # noqa: E402

STREAMS = ("paper_ann", "mit_subject1", "mit_subject2")
MIT = ROOT.parent / "shared" / "realdata" / "mit-home-activity"
OUT = ROOT / "docs" / "curves"
README = ROOT / "docs" / "figures.md"  # where the table is
BEGIN, END = "<!-- curves:begin -->", "<!-- curves:end -->"
COLORS = {
    "multi": "#C44E52",
    "paper": "#DD8452",
    "kmeans": "#8C8C8C",
    "hoeffding": "#4C72B0",
    "frequency": "#55A868",
    "naive_bayes": "#8172B3",
}
console = Console(stderr=True)


def run_stream(name: str, corrections: int, seed: int, mit: Path, tmp: Path) -> tuple[str, ReplayResult]:
    """Replay one stream; returns what a row is (for the axis) and the result."""
    if name == "paper_ann":
        home = load_home("paper")
        # the stream of eval's correction curve (evaluate.correction_curve)
        rows = random_scenarios(home, corrections, seed=seed + 7919, truth=load_home("paper_ann"))
        what = "corrections by Ann"
    else:
        subject = name.removeprefix("mit_")
        home_path, events, _ = convert(mit / subject, tmp, name)
        home = load_home(home_path)
        rows = load_scenarios(events, home, home, events=True)
        what = "events of the subject (switches and quiet moments)"
    result = replay_rows(home, rows, methods=METHOD_NAMES, seed=seed, points=100, progress=console.log)
    return what, result


def plot(name: str, what: str, result: ReplayResult, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8.5, 3.8))
    for method, series in result.running.items():
        if series:
            ax.plot(
                [r[0] for r in series],
                [r[3] for r in series],
                label=f"{method} ({series[-1][3]:.3f})",
                color=COLORS.get(method),
                linewidth=2.4 if method == "multi" else 1.3,
            )
    ax.set_xlabel(what)
    ax.set_ylabel("running F1 (prequential)")
    ax.set_ylim(0, 1)
    ax.set_title(f"{name}: {result.events:,} rows, each predicted before it is learned")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.01, 0.5), frameon=False)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def table_markdown(results: dict[str, dict[str, Any]]) -> str:
    methods = [m for m in METHOD_NAMES if any(m in r["methods"] for r in results.values())]
    lines = [
        "| stream | rows | " + " | ".join(methods) + " | wall |",
        "|---|---|" + "---|" * len(methods) + "---|",
    ]
    for name, r in results.items():
        f1 = {m: r["methods"][m]["f1"] for m in methods if m in r["methods"]}
        best = max(f1.values())
        cells = [
            f"**{f1[m]:.3f}**" if f1.get(m) == best else (f"{f1[m]:.3f}" if m in f1 else "-") for m in methods
        ]
        lines.append(
            f"| [{name}](curves/{name}.png) | {r['events']:,} | "
            + " | ".join(cells)
            + f" | {r['seconds']:.0f} s |"
        )
    return "\n".join(lines)


def update_readme(markdown: str) -> bool:
    text = README.read_text(encoding="utf-8")
    pattern = re.compile(re.escape(BEGIN) + ".*?" + re.escape(END), re.S)
    if not pattern.search(text):
        return False
    README.write_text(pattern.sub(lambda _: f"{BEGIN}\n{markdown}\n{END}", text), encoding="utf-8")
    return True


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--corrections", type=int, default=1000, help="length of the paper_ann stream")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--streams", default=",".join(STREAMS))
    parser.add_argument("--mit", type=Path, default=MIT, help="the MIT home-activity folder")
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument("--no-readme", action="store_true", help="leave the table of docs/figures.md alone")
    args = parser.parse_args()
    names = [s.strip() for s in args.streams.split(",") if s.strip()]
    bad = [s for s in names if s not in STREAMS]
    if bad:
        parser.error(f"unknown stream {bad[0]!r}; expected some of {', '.join(STREAMS)}")
    args.out.mkdir(parents=True, exist_ok=True)
    summary_path = args.out / "curves.json"
    summary: dict[str, dict[str, Any]] = (
        json.loads(summary_path.read_text()) if summary_path.is_file() else {}
    )
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            console.log(f"{name} ...")
            what, result = run_stream(name, args.corrections, args.seed, args.mit, Path(tmp))
            plot(name, what, result, args.out / f"{name}.png")
            summary[name] = {
                "events": result.events,
                "methods": result.methods,
                "seconds": round(result.seconds, 1),
                "seed": args.seed,
                "skipped": result.skipped,
            }
    summary = {k: summary[k] for k in STREAMS if k in summary}
    summary_path.write_text(json.dumps(summary, indent=1) + "\n", encoding="utf-8")
    table = Table(title=f"Final running F1 ({time.perf_counter() - start:.0f} s)", title_justify="left")
    methods = [m for m in METHOD_NAMES if any(m in r["methods"] for r in summary.values())]
    for col in ("stream", "rows", *methods):
        table.add_column(col, justify="left" if col == "stream" else "right")
    for name, r in summary.items():
        table.add_row(
            name,
            f"{r['events']:,}",
            *(f"{r['methods'][m]['f1']:.3f}" if m in r["methods"] else "-" for m in methods),
        )
    Console().print(table)
    if not args.no_readme and update_readme(table_markdown(summary)):
        console.log("docs/figures.md: the learning curves' table updated")


if __name__ == "__main__":
    main()
