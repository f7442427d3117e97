"""Real households: every method replayed on every real home at hand, multi's lead over each per
home and pooled over the homes, and a learning curve per home.

The homes are the MIT home-activity subjects (``homecog adapt-mit``), van Kasteren's houses A, B
and C (``homecog adapt-kasteren``) and the UCI occupancy-detection office
(:mod:`homecog.evaluation.uci`), each made into an event file of switch rows and quiet rows by
``homecog log events``, and any event file given with its home file (``--events HOME EVENTS``).
Each stream is replayed prequentially with every method (each event predicted, then learned).
Per home: every method's F1, multi's lead over the best baseline (of every method but homecog's
own modes, multi and paper) and over ``boosted``, ``ha_usage`` and ``markov``, with 95 % paired
bootstrap intervals over the events. Pooled: per method, the mean over the homes of multi's
lead, each home weighing the same, with a 95 % bootstrap interval stratified by home
(:func:`homecog.evaluation.leads.pooled_difference`). Writes ``docs/eval/real/<home>.png`` (the
running F1 of every method) and ``real.json`` beside them, the tables between the ``real``
markers of docs/figures.md and short ones between those of README.md (when every built-in
home was replayed). A home whose raw data is not at hand is left out and said; one that cannot
be read is said, and the others go on:

    bin/bench real [-- --events my_home.yaml my_events.csv]
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

from homecog.errors import HomecogError, one_line  # noqa: E402
from homecog.evaluation import kasteren, mit, uci  # noqa: E402
from homecog.evaluation.leads import Difference, pooled_leads  # noqa: E402
from homecog.evaluation.registry import METHOD_NAMES  # noqa: E402
from homecog.evaluation.replay import ReplayResult, replay  # noqa: E402
from homecog.evaluation.report import running_chart  # noqa: E402
from homecog.home import load_home  # noqa: E402

DATA = ROOT.parent / "shared" / "realdata"
HOMES = ("mit_subject1", "mit_subject2", "kasteren_a", "kasteren_b", "kasteren_c", "uci_office")
#: the folder of each built-in home's raw data, under --data
FOLDERS = {"mit": "mit-home-activity", "kasteren": "kasteren", "uci": "uci-occupancy"}
OUT = ROOT / "docs" / "eval" / "real"
README = ROOT / "docs" / "figures.md"  # where the whole table is (README.md: a short one)
BEGIN, END = "<!-- real:begin -->", "<!-- real:end -->"
#: the methods whose lead over them each home's row shows beside the best baseline's
VERSUS = ("boosted", "ha_usage", "markov")
console = Console(stderr=True)


def raw_folder(name: str, data: Path) -> Path:
    return data / FOLDERS[name.split("_")[0]]


def convert(name: str, data: Path, tmp: Path) -> tuple[Path, Path]:
    """The home file and event file of one built-in real home, made from its raw data."""
    folder = raw_folder(name, data)
    if name.startswith("mit_"):
        home, events, _ = mit.convert(folder / name.removeprefix("mit_"), tmp, name)
        return home, events
    if name.startswith("uci_"):
        office = uci.convert(folder, tmp, name)
        return office.home, office.events
    house = kasteren.convert(folder, name.removeprefix("kasteren_"), tmp, name)
    return house.home, house.events


def run(home_path: Path, events: Path) -> ReplayResult:
    return replay(load_home(home_path), events, methods=METHOD_NAMES, points=100)


def _lead(d: Difference | None) -> str:
    return "–" if d is None else str(d).replace("[too few events]", "[few events]")


def _best_other(result: ReplayResult) -> str:
    f1 = {m: v["f1"] for m, v in result.methods.items() if m not in ("multi", "paper")}
    return max(f1, key=f1.__getitem__)


def _cell(f1: dict[str, float], method: str, best: float) -> str:
    if method not in f1:
        return "–"
    return f"**{f1[method]:.3f}**" if f1[method] == best else f"{f1[method]:.3f}"


def table_markdown(results: dict[str, ReplayResult], switches: dict[str, int]) -> str:
    """docs/figures.md's table: per home, every method's F1 and multi's leads."""
    methods = [m for m in METHOD_NAMES if any(m in r.methods for r in results.values())]
    head = "| home | events (switch + quiet) | " + " | ".join(methods) + " | multi − best baseline [95 %] | "
    head += " | ".join(f"multi − {m}" for m in VERSUS) + " |"
    lines = [head, "|---|---|" + "---|" * (len(methods) + 1 + len(VERSUS))]
    for name, r in results.items():
        f1 = {m: r.methods[m]["f1"] for m in methods if m in r.methods}
        best = max(f1.values())
        cells = [_cell(f1, m, best) for m in methods]
        other, versus = _best_other(r), r.versus()
        events = f"{r.events:,} ({switches[name]:,} + {r.events - switches[name]:,})"
        lines.append(
            f"| [{name}](eval/real/{name}.png) | {events} | "
            + " | ".join(cells)
            + f" | {_lead(versus[other])} ({other}) | "
            + " | ".join(_lead(versus.get(m)) for m in VERSUS)
            + " |"
        )
    return "\n".join(lines)


def summary_markdown(results: dict[str, ReplayResult]) -> str:
    """The README's short table: per home, multi's F1, the best baseline's and multi's leads."""
    lines = [
        "| home | multi | best baseline | multi − best baseline [95 %] | "
        + " | ".join(f"multi − {m}" for m in VERSUS)
        + " |",
        "|---|---|---|---|" + "---|" * len(VERSUS),
    ]
    for name, r in results.items():
        other, versus = _best_other(r), r.versus()
        lines.append(
            f"| [{name}](docs/eval/real/{name}.png) | {r.methods['multi']['f1']:.3f} | "
            f"{other} {r.methods[other]['f1']:.3f} | {_lead(versus[other])} | "
            + " | ".join(_lead(versus.get(m)) for m in VERSUS)
            + " |"
        )
    return "\n".join(lines)


def pooled(results: dict[str, ReplayResult]) -> dict[str, tuple[Difference, int]]:
    """Per method, multi's lead pooled over the homes (each weighing the same) and their number."""
    return pooled_leads({name: dict(r.counts) for name, r in results.items()})


def pooled_markdown(results: dict[str, ReplayResult], leads: dict[str, tuple[Difference, int]]) -> str:
    """Per method: the pooled lead, the homes where multi is ahead or behind (the whole
    interval above or below 0), and multi's smallest lead over it on one home."""
    lines = [
        "| multi − | pooled over the homes [95 %, stratified by home] | homes | ahead / behind "
        "| smallest lead |",
        "|---|---|---|---|---|",
    ]
    for method, (d, homes) in leads.items():
        each = [r.versus()[method] for r in results.values() if method in r.versus()]
        ahead = sum(x.low is not None and x.low > 0 for x in each)
        behind = sum(x.high is not None and x.high < 0 for x in each)
        worst = min(x.difference for x in each)
        lines.append(f"| {method} | {_lead(d)} | {homes} | {ahead} / {behind} | {worst:+.3f} |")
    return "\n".join(lines)


def calibration_markdown(results: dict[str, ReplayResult]) -> str:
    """Per home, every method's expected calibration error (prequential, p ≥ 0.1, ten bins),
    and their mean over the homes."""
    methods = [m for m in METHOD_NAMES if any(m in r.calibration for r in results.values())]
    lines = ["| ECE | " + " | ".join(methods) + " |", "|---|" + "---|" * len(methods)]
    for name, r in results.items():
        cells = (f"{r.calibration[m]['ece']:.3f}" if m in r.calibration else "" for m in methods)
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    means = []
    for m in methods:
        eces = [r.calibration[m]["ece"] for r in results.values() if m in r.calibration]
        means.append(f"{sum(eces) / len(eces):.3f}")
    lines.append("| mean over the homes | " + " | ".join(means) + " |")
    return "\n".join(lines)


def update_readme(markdown: str, path: Path = README) -> bool:
    """Put ``markdown`` between the real markers of a file; False where it has none."""
    text = path.read_text(encoding="utf-8")
    pattern = re.compile(re.escape(BEGIN) + ".*?" + re.escape(END), re.S)
    if not pattern.search(text):
        return False
    path.write_text(pattern.sub(lambda _: f"{BEGIN}\n{markdown}\n{END}", text), encoding="utf-8")
    return True


def arguments() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--homes", default=",".join(HOMES), help="built-in homes, comma-separated")
    parser.add_argument("--data", type=Path, default=DATA, help="the real-data folder")
    parser.add_argument(
        "--events",
        nargs=2,
        action="append",
        default=[],
        metavar=("HOME", "EVENTS"),
        help="a home file and its event file, replayed beside the built-in homes (repeatable)",
    )
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument(
        "--no-readme", action="store_true", help="leave the tables of docs/figures.md and README.md alone"
    )
    args = parser.parse_args()
    args.names = [h.strip() for h in args.homes.split(",") if h.strip()]
    bad = [h for h in args.names if h not in HOMES]
    if bad:
        parser.error(f"unknown home {bad[0]!r}; expected some of {', '.join(HOMES)}")
    for home, events in args.events:
        for path in (home, events):
            if not Path(path).is_file():
                parser.error(f"--events {home} {events}: {path}: no such file")
    return args


def streams(args: argparse.Namespace, tmp: Path) -> dict[str, tuple[Path, Path]]:
    """Every home to replay, by name: the built-in ones whose raw data is at hand, converted, and
    the event files given; what cannot be had is said."""
    out: dict[str, tuple[Path, Path]] = {}
    for name in args.names:
        if not raw_folder(name, args.data).is_dir():
            console.log(f"{name}: left out, no raw data at {raw_folder(name, args.data)}")
            continue
        try:
            out[name] = convert(name, args.data, tmp)
        except HomecogError as e:
            console.log(f"{name}: left out, its data cannot be converted: {one_line(str(e))}")
    for home, events in args.events:
        try:
            name = load_home(Path(home)).name
        except HomecogError as e:
            console.log(f"{home}: left out: {one_line(str(e))}")
            continue
        while name in out:
            name += "_"
        out[name] = (Path(home), Path(events))
    return out


def main() -> None:
    args = arguments()
    args.out.mkdir(parents=True, exist_ok=True)
    results: dict[str, ReplayResult] = {}
    switches: dict[str, int] = {}
    summary: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, (home, events) in streams(args, Path(tmp)).items():
            start = time.perf_counter()
            console.log(f"{name} ...")
            try:
                r = results[name] = run(home, events)
            except HomecogError as e:
                console.log(f"{name}: left out, it cannot be replayed: {one_line(str(e))}")
                continue
            switches[name] = int((r.counts["multi"][:, 2] > 0).sum())
            data = r.as_dict()
            running_chart(data, args.out / f"{name}.png")
            data.pop("running")
            summary[name] = {**data, "wall_seconds": round(time.perf_counter() - start, 1)}
            console.log(f"{name}: " + ", ".join(f"{m} {v['f1']:.3f}" for m, v in r.methods.items()))
    if not results:
        sys.exit("bench real: no home could be replayed")
    leads = pooled(results)
    summary["pooled"] = {m: {**d.as_dict(), "homes": n} for m, (d, n) in leads.items()}
    (args.out / "real.json").write_text(json.dumps(summary, indent=1) + "\n", encoding="utf-8")
    together = pooled_markdown(results, leads)
    calibration = calibration_markdown(results)
    together += "\n\n" + calibration
    markdown = table_markdown(results, switches) + "\n\n" + together
    print(markdown)
    if args.no_readme:
        return
    if not update_readme(markdown):
        console.log("docs/figures.md has no real markers: table printed only")
    short = summary_markdown(results) + "\n\n" + together
    if set(HOMES) <= set(results) and not update_readme(short, ROOT / "README.md"):
        console.log("README.md has no real markers: its table left alone")


if __name__ == "__main__":
    main()
