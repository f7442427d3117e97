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

Counting in cells is one kind of learner; an additive one may generalize where cells are thin.
So two logistic regressions (scikit-learn, L2) replay the stream too, refitted on all past
events before each one, each proposing only services that would change something:

- *per service*: one model per service over the one-hot context (every feature's value or bin,
  every device on/off);
- *pooled*: one model over every (event, service) pair, whose features are the context per
  service, the context per direction (switching on, switching off: shared by every device), and
  whether the service's device is in the room the user is in (a categorical feature's value that
  names the device's room) per direction, alone and with each feature's value, so what one light
  teaches counts for the others.

Their regularization (C of 0.3, 1, 3) and threshold are again chosen after the fact.

    bin/bench ceiling                      # both MIT subjects (adapted as homecog adapt-mit does)
    .venv/bin/python benchmarks/bench_ceiling.py [--order 2] [--top 8] [--no-logistic] [HOME EVENTS ...]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from itertools import combinations
from pathlib import Path
from typing import Any

import numpy as np
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


C_GRID = (0.3, 1.0, 3.0)
T_GRID = tuple(np.arange(0.05, 0.601, 0.025))


def _targets(home: Home) -> list[tuple[str, str, str, str | None]]:
    """Per service of one device: its name, the device, the state it sets, the device's room."""
    rooms = {d.name: d.room for d in home.devices}
    return [
        (s.name, s.sets[0][0], "on" if s.sets[0][1] else "off", rooms[s.sets[0][0]])
        for s in home.services
        if len(s.sets) == 1
    ]


def _pair_features(
    x: dict[str, str], service: str, direction: str, room: str | None, pooled: bool
) -> list[str]:
    names = [f"{k}={v}" for k, v in x.items()]
    if not pooled:
        return names
    here = any(v == room for v in x.values()) if room else False
    return [
        f"s={service}",
        *(f"{service}|{n}" for n in names),
        *(f"{direction}|{n}" for n in names),
        f"{direction}|in the device's room={here}",
        *(f"{direction}|in the device's room={here}|{n}" for n in names),
    ]


def logistic_f1(
    home: Home, xs: list[dict[str, str]], wants: list[set[str]], pooled: bool
) -> tuple[float, float, float]:
    """Prequential micro F1 of logistic regression refitted before every event, with C and the
    threshold that were best after the fact: (F1, C, threshold)."""
    import warnings

    from sklearn.feature_extraction import DictVectorizer
    from sklearn.linear_model import LogisticRegression

    targets = _targets(home)
    pairs = [  # (event, service, features, wanted) where the service would change something
        (i, name, _pair_features(x, name, state, room, pooled), name in wants[i])
        for i, x in enumerate(xs)
        for name, device, state, room in targets
        if x.get(device) != state
    ]
    matrix = DictVectorizer().fit_transform([dict.fromkeys(f, 1) for _, _, f, _ in pairs]).tocsr()
    y = np.array([w for *_, w in pairs])
    event = np.array([i for i, *_ in pairs])
    group = np.array([n for _, n, *_ in pairs]) if not pooled else np.zeros(len(pairs), dtype=str)
    true = sum(len(w) for w in wants)
    best = (0.0, 0.0, 0.0)
    for c in C_GRID:
        prob = np.zeros(len(pairs))
        for g in np.unique(group):
            mine = group == g
            for i in range(1, len(xs)):
                past, now = mine & (event < i), mine & (event == i)
                if not now.any() or not y[past].any():
                    continue  # never wanted yet: 0
                if y[past].all():
                    prob[now] = 1.0
                    continue
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    model = LogisticRegression(C=c, max_iter=300).fit(matrix[past], y[past])
                prob[now] = model.predict_proba(matrix[now])[:, 1]
        for t in T_GRID:
            said = prob > t
            f1 = prf(int((said & y).sum()), int(said.sum()), true)[2]
            best = max(best, (f1, c, float(t)))
    return best


def ceiling(
    home: Home, events: Path, order: int, logistic: bool = True
) -> tuple[list[tuple[float, tuple[str, ...]]], dict[str, tuple[float, float, float]], Any, int]:
    """Every key's F1 (best first), the logistic regressions' (F1, C, threshold), the replay of
    multi and the baselines in the same run, and the events."""
    rows = load_scenarios(events, home, home, events=True)
    space = Space(home)
    xs = [features_of(space, r.point) for r in rows]
    wants = [set(r.truth) for r in rows]
    names = [d.name for d in space.dims]
    keys = [k for r in range(order + 1) for k in combinations(names, r)]
    scored = sorted(((key_f1(home, xs, wants, k), k) for k in keys), key=lambda t: -t[0])
    fitted = {}
    if logistic:
        for pooled in (False, True):
            fitted["pooled" if pooled else "per service"] = logistic_f1(home, xs, wants, pooled)
    replayed = replay_rows(home, rows, methods=["multi", "frequency", "naive_bayes"])
    return scored, fitted, replayed, len(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("streams", nargs="*", type=Path, help="pairs HOME EVENTS (default: the MIT subjects)")
    parser.add_argument("--order", type=int, default=2, help="the most features a key has")
    parser.add_argument("--top", type=int, default=5, help="best keys shown per stream")
    parser.add_argument("--mit", type=Path, default=MIT, help="the MIT home-activity folder")
    parser.add_argument("--no-logistic", action="store_true", help="leave out the logistic regressions")
    args = parser.parse_args()
    if len(args.streams) % 2:
        parser.error("streams come in pairs: HOME EVENTS")
    console = Console()
    table = Table(title=f"The best frequency keys of up to {args.order} features, chosen after the fact")
    for col in ("stream", "events", "key", "F1"):
        table.add_column(col, no_wrap=True)
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
            scored, fitted, replayed, n = ceiling(home, events, args.order, not args.no_logistic)
            label = f"{home.name} ({time.perf_counter() - start:.0f} s)"
            for i, (f1, key) in enumerate(scored[: args.top]):
                stream, events = (label, f"{n}") if i == 0 else ("", "")
                table.add_row(stream, events, ", ".join(key) or "()", f"{f1:.4f}")
            for kind, (f1, c, t) in fitted.items():
                table.add_row(
                    "", "", f"logistic regression, {kind} (C {c:g}, threshold {t:.3f})", f"{f1:.4f}"
                )
            versus = replayed.versus()
            for name, m in replayed.methods.items():
                what = (
                    f"{name}, online (same run; {len(scored)} keys tried)"
                    if name == "multi"
                    else f"{name}, online"
                )
                against = f"   multi − it {versus[name]}" if name in versus else ""
                table.add_row("", "", what + against, f"{m['f1']:.4f}", end_section=name == "naive_bayes")
    console.print(table)


if __name__ == "__main__":
    main()
