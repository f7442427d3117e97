"""How much a stream's context says about its services: the best F1 that simple online learners
reach on it, chosen after the fact.

For every key of at most ``--order`` context features and devices (every feature of the home
as its value or bin, every device on/off), a frequency learner keyed on it — per service, how
often the service was wanted among the past events of the same key and the same state of the
devices it sets, proposed above a threshold chosen online from past events only, as the
``frequency`` baseline does on (location, behavior) — replays the stream prequentially. The
table shows the best keys and ``multi`` beside them, all in the same run.

The best key is chosen knowing the whole stream, so its F1 is *above* what any online learner
choosing among these keys could reach: where it is low, the context lacks what the household's
switches depend on, and no learner over these features can do much better.

    bin/bench ceiling                      # both MIT subjects (adapted as homecog adapt-mit does)
    .venv/bin/python benchmarks/bench_ceiling.py [--order 2] [--top 8] [HOME EVENTS ...]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from itertools import combinations
from pathlib import Path

from rich.console import Console
from rich.table import Table

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from homecog.evaluation.baselines import ServiceFrequency, features_of  # noqa: E402
from homecog.evaluation.evaluate import load_scenarios  # noqa: E402
from homecog.evaluation.metrics import prf  # noqa: E402
from homecog.evaluation.mit import convert  # noqa: E402
from homecog.evaluation.replay import replay_rows  # noqa: E402
from homecog.home import load_home  # noqa: E402
from homecog.home.codec import Space  # noqa: E402
from homecog.home.model import Home  # noqa: E402

MIT = ROOT.parent / "shared" / "realdata" / "mit-home-activity"


def key_f1(home: Home, xs: list[dict[str, str]], wants: list[set[str]], key: tuple[str, ...]) -> float:
    """Prequential micro F1 of the frequency learner keyed on ``key`` (plus each service's devices)."""
    learner = ServiceFrequency({s.name: [*key, *(d for d, _ in s.sets)] for s in home.services})
    hits = predicted = true = 0
    for x, want in zip(xs, wants, strict=True):
        answer = learner.predict_one(x)
        hits += len(answer & want)
        predicted += len(answer)
        true += len(want)
        learner.learn_one(x, want)
    return prf(hits, predicted, true)[2]


def ceiling(home: Home, events: Path, order: int) -> tuple[list[tuple[float, tuple[str, ...]]], float, int]:
    """Every key's F1 (best first), multi's F1 in the same replay, and the events."""
    rows = load_scenarios(events, home, home, events=True)
    space = Space(home)
    xs = [features_of(space, r.point) for r in rows]
    wants = [set(r.truth) for r in rows]
    names = [d.name for d in space.dims]
    keys = [k for r in range(order + 1) for k in combinations(names, r)]
    scored = sorted(((key_f1(home, xs, wants, k), k) for k in keys), key=lambda t: -t[0])
    multi = replay_rows(home, rows, methods=["multi", "frequency"]).methods
    return scored, multi["multi"]["f1"], len(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("streams", nargs="*", type=Path, help="pairs HOME EVENTS (default: the MIT subjects)")
    parser.add_argument("--order", type=int, default=2, help="the most features a key has")
    parser.add_argument("--top", type=int, default=5, help="best keys shown per stream")
    parser.add_argument("--mit", type=Path, default=MIT, help="the MIT home-activity folder")
    args = parser.parse_args()
    if len(args.streams) % 2:
        parser.error("streams come in pairs: HOME EVENTS")
    console = Console()
    table = Table(title=f"The best frequency keys of up to {args.order} features, chosen after the fact")
    for col in ("stream", "events", "key", "F1"):
        table.add_column(col)
    with tempfile.TemporaryDirectory() as tmp:
        pairs = list(zip(args.streams[::2], args.streams[1::2], strict=True))
        if not pairs:
            for subject in ("subject1", "subject2"):
                if not (args.mit / subject).is_dir():
                    sys.exit(f"no MIT data at {args.mit}; give HOME EVENTS pairs instead")
                home_path, events, _ = convert(args.mit / subject, Path(tmp), f"mit_{subject}")
                pairs.append((home_path, events))
        for home_path, events in pairs:
            home = load_home(home_path)
            start = time.perf_counter()
            scored, multi, n = ceiling(home, events, args.order)
            label = f"{home.name} ({time.perf_counter() - start:.0f} s)"
            for i, (f1, key) in enumerate(scored[: args.top]):
                stream, events = (label, f"{n}") if i == 0 else ("", "")
                table.add_row(stream, events, ", ".join(key) or "()", f"{f1:.4f}")
            tried = f"multi (same run); {len(scored)} keys tried"
            table.add_row("", "", tried, f"{multi:.4f}", end_section=True)
    console.print(table)


if __name__ == "__main__":
    main()
