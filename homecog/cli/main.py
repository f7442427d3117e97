"""The ``homecog`` command (SPEC §11).

Every command takes ``--home`` (a built-in name or a path) and ``--json``. Bad input
prints one line on stderr and exits with status 2; nothing is overwritten.
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.table import Table

# Typer 0.29 carries its own copy of click; its exceptions live there (typer is pinned).
from typer._click import exceptions as click_errors

from homecog.cli.ha import ha_app
from homecog.cli.output import emit_json, progress_bar, stdout
from homecog.errors import HomecogError
from homecog.home import Home, load_home
from homecog.home.loader import canonical
from homecog.home.model import format_number

app = typer.Typer(
    name="homecog",
    help="Service cognition for home service robots: learn which services a user needs.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
home_app = typer.Typer(help="Show or check home definitions.", no_args_is_help=True)
app.add_typer(home_app, name="home")
app.add_typer(ha_app, name="ha")

HomeOption = Annotated[str, typer.Option("--home", help="A built-in home name or the path of a YAML file.")]
JsonOption = Annotated[bool, typer.Option("--json", help="Print one JSON object on stdout.")]


class UsageProblemError(HomecogError):
    """A bad command-line argument."""


# -- homecog home ------------------------------------------------------------------------------
def _when(home: Home, cond: Any) -> str:
    parts = [
        f"{home.features[f].name}∈{{{', '.join(home.features[f].values[k] for k in sorted(codes))}}}"
        for f, codes in cond.features
    ]
    parts += [
        f"{home.devices[d].name}={'/'.join('on' if s else 'off' for s in sorted(states))}"
        for d, states in cond.devices
    ]
    return " and ".join(parts) if parts else "always"


def home_summary(home: Home) -> dict[str, Any]:
    """Sizes of a home's spaces (used by ``home show`` and ``home check``): the joint space, and
    the independent groups the learner splits it into (SPEC §4.1)."""
    from homecog.learning.size import sizes

    return {
        "name": home.name,
        "source": home.source,
        "hash": home.content_hash,
        "features": len(home.features),
        "contexts": home.context_count,
        "devices": len(home.devices),
        "services": len(home.services),
        **sizes(home),
    }


def _big(n: int) -> str:
    """A count as people read it: ``663,552``, or ``1.3e+62`` past a trillion."""
    return f"{n:,}" if n < 10**12 else f"{n:.2g}"


@home_app.command("show")
def home_show(home: HomeOption = "paper", json: JsonOption = False) -> None:
    """Print a home readably: features and bins, devices, services and rules."""
    h = load_home(home)
    if json:
        emit_json({"summary": home_summary(h), "definition": canonical(h)})
        return
    s = home_summary(h)
    stdout.print(f"[bold]{h.name}[/bold] ({h.source}) — {h.description or ''}")
    stdout.print(
        f"{s['contexts']:,} contexts × 2^{s['devices']} device states = {_big(s['start_states'])} start "
        f"states; {_big(s['states'])} states with pending needs; hash {h.content_hash[:12]}"
    )
    stdout.print(
        f"learned in {s['groups']} independent groups, {s['group_states']:,} states in all; the largest, "
        f"{s['largest_group']}, has {s['largest_group_states']:,}"
    )

    t = Table(title="Context features (code / normalized, as Table 1)", title_justify="left")
    for col in ("feature", "kind", "values"):
        t.add_column(col, no_wrap=col in ("feature", "device", "service"), overflow="fold")
    from homecog.home.encoding import coded

    for f in h.features:
        values = []
        for k, v in enumerate(f.values):
            code, norm = coded(f, k)
            rng = f" {f.describe_bin(k)}" if f.bins else ""
            values.append(f"{v}{rng} ({code}/{norm:.2g})")
        t.add_row(f.name + (f" [{f.unit}]" if f.unit else ""), f.kind, "\n".join(values))
    stdout.print(t)

    t = Table(title="Devices (hardware code order)", title_justify="left")
    for col in ("#", "device", "room", "switched", "comfort rules (first match wins)"):
        t.add_column(col, no_wrap=col in ("feature", "device", "service"), overflow="fold")
    for i, (d, rules) in enumerate(zip(h.devices, h.comfort, strict=True)):
        shown = "\n".join(f"{'on ' if r.want else 'off'} when {_when(h, r.when)}" for r in rules)
        t.add_row(str(i + 1), d.name, d.room or "", "IoT" if d.iot else "by hand", shown or "don't care")
    stdout.print(t)

    t = Table(title="Services", title_justify="left")
    for col in ("#", "service", "category", "effect", "needed when", "prohibited when"):
        t.add_column(col, no_wrap=col in ("feature", "device", "service"), overflow="fold")
    for i, (sv, needs, prohibited) in enumerate(zip(h.services, h.needs, h.prohibited, strict=True)):
        effect = ", ".join(f"{d}→{'on' if v else 'off'}" for d, v in sv.sets) or "interaction"
        t.add_row(
            str(i + 1),
            sv.name,
            sv.category,
            effect,
            "\n".join(_when(h, c) for c in needs) or "-",
            "\n".join(_when(h, c) for c in prohibited) or "-",
        )
    stdout.print(t)
    r = h.rewards
    stdout.print(
        f"Rewards: {format_number(r.terminal)}·terminal + {format_number(r.progress)}·progress "
        f"+ {format_number(r.prohibited)}·prohibited, each ±{format_number(r.magnitude)}"
    )


@home_app.command("check")
def home_check(
    file: Annotated[str, typer.Argument(help="The home file to validate.")], json: JsonOption = False
) -> None:
    """Validate a home file; report its size and any start state that cannot reach its optimum."""
    from homecog.environment.conflicts import find_conflicts
    from homecog.learning.size import check_size, describe

    h = load_home(file)
    size = check_size(h)
    if h.layout is not None:  # every place the robot may be sent to must be reachable
        from homecog.simulation import plan_path

        targets = dict.fromkeys(h.layout.places)
        for d in h.devices:
            if not d.iot:
                targets[h.layout.device_place(d.name)] = None
        for target in targets:
            plan_path(h.layout, h.layout.robot, target)
    summary = home_summary(h)
    report = find_conflicts(h)
    summary["unsolvable_start_states"] = report.stuck
    summary["conflicts"] = [
        {"group": c.group.label, "stuck": c.stuck, "start_states": c.start_states, "example": c.example}
        for c in report.groups
    ]
    if json:
        emit_json({"ok": True, **summary})
        return
    stdout.print(
        f"ok: {h.source}: home '{h.name}': {summary['features']} features, "
        f"{summary['contexts']:,} contexts, {summary['devices']} devices, "
        f"{summary['services']} services; {describe(size)}"
    )
    if report.stuck:
        stdout.print(
            f"warning: {_big(report.stuck)} of {_big(report.start_states)} start states cannot reach the "
            "optimum without a prohibited or useless service (conflicting rules):"
        )
        for c in report.groups:
            example = ", ".join(f"{k}={v}" for k, v in c.example.items())
            stdout.print(
                f"  {c.group.label}: {c.stuck:,} of its {c.start_states:,} start states, e.g. {example}"
            )


# -- homecog train -----------------------------------------------------------------------------
def _check_writable(path: Path) -> None:
    """Fail before the work, not after it, when ``path`` cannot be written."""
    if path.is_dir():
        raise UsageProblemError(f"--out {path}: is a directory")
    blocker = next((p for p in path.parents if p.exists() and not p.is_dir()), None)
    if blocker is not None:
        raise UsageProblemError(f"--out {path}: cannot write there: {blocker} is not a directory")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path.parent, prefix=".homecog-check-"):
            pass
    except OSError as e:
        raise UsageProblemError(f"--out {path}: cannot write there: {e.strerror}") from None


@app.command()
def train(
    home: HomeOption = "paper",
    episodes: Annotated[
        int | None,
        typer.Option(
            help="Episodes: in all, split over the groups by size (default: sweeps until every "
            "group's policy is stable); with --joint, 3,000,000 by default."
        ),
    ] = None,
    seed: Annotated[int, typer.Option(help="Seed; a run is reproducible from it.")] = 0,
    alpha: Annotated[float | None, typer.Option(help="Learning rate α (default 1.0).")] = None,
    gamma: Annotated[float | None, typer.Option(help="Discount γ (default 0.2).")] = None,
    epsilon_c: Annotated[float | None, typer.Option(help="ε_t = √(c/t); the paper's c = 2.")] = None,
    max_steps: Annotated[int | None, typer.Option(help="Step limit of an episode (default 30).")] = None,
    out: Annotated[Path | None, typer.Option(help="Where to save the Q table (default: the cache).")] = None,
    joint: Annotated[
        bool, typer.Option("--joint", help="One table over the joint state, as the paper (small homes only).")
    ] = False,
    json: JsonOption = False,
) -> None:
    """Learn the home's services by Sarsa, group by group, and save the Q tables."""
    from dataclasses import replace

    from homecog.learning.grouped import train_policy
    from homecog.learning.sarsa import SarsaConfig
    from homecog.learning.size import check_size
    from homecog.paths import q_table_path

    h = load_home(home)
    given = {
        "episodes": episodes if joint else None,
        "seed": seed,
        "alpha": alpha,
        "gamma": gamma,
        "epsilon_c": epsilon_c,
        "max_steps": max_steps,
    }
    config = replace(SarsaConfig(), **{k: v for k, v in given.items() if v is not None})
    try:
        config.validate()
    except ValueError as e:
        raise UsageProblemError(str(e)) from None
    if episodes is not None and episodes < 0:
        raise UsageProblemError(f"episodes must be 0 or more, got {episodes}")
    size = check_size(h, joint=joint)
    path = out if out is not None else q_table_path(h, joint=joint)
    _check_writable(path)
    starts = h.context_count << len(h.devices)
    with progress_bar(f"Sarsa on {h.name}", config.episodes if joint else 1) as update:
        result = train_policy(h, config, joint=joint, episodes=None if joint else episodes, progress=update)
    result.policy.save(path)
    data = {
        "episodes": result.episodes,
        "steps": result.steps,
        "seconds": round(result.seconds, 3),
        "steps_per_second": round(result.steps_per_second),
        "greedy_optimal_rate": result.greedy_optimal_rate,
        "q_path": str(path),
        "home": h.name,
        "home_hash": h.content_hash,
        "joint": joint,
        "groups": size.groups,
    }
    if json:
        emit_json(data)
        return
    how = "one joint table" if joint else f"{size.groups} groups"
    stdout.print(
        f"trained {h.name} ({how}): {result.episodes:,} episodes, {result.steps:,} steps in "
        f"{result.seconds:.1f} s ({result.steps_per_second / 1e6:.2f} M steps/s)"
    )
    stdout.print(
        f"greedy-optimal rate {result.greedy_optimal_rate:.6f} over {_big(starts)} start states (exact)"
    )
    stdout.print(f"Q table: {path}")


# -- homecog build / cognize / correct ---------------------------------------------------------
DbOption = Annotated[
    str | None,
    typer.Option(
        "--db", help="Database URL (default: $HOMECOG_DB or a SQLite file under the data directory)."
    ),
]
ContextOption = Annotated[
    str, typer.Option("--context", help="name=value for every feature and device, comma-separated.")
]
UserOption = Annotated[str, typer.Option("--user", help="The household member.")]


def _status(message: str) -> None:
    from homecog.cli.output import stderr

    if stderr.is_terminal:
        stderr.print(message, style="dim")


@app.command()
def build(
    home: HomeOption = "paper",
    q: Annotated[
        Path | None, typer.Option("--q", help="The Q table (default: the cached one, trained if missing).")
    ] = None,
    db: DbOption = None,
    mode: Annotated[
        str,
        typer.Option(help="multi (several clusters per service) or paper (Algorithms 2 and 3 as published)."),
    ] = "multi",
    seed: Annotated[int, typer.Option(help="Seed of the random readings inside bins.")] = 0,
    joint: Annotated[
        bool, typer.Option("--joint", help="Use the joint Q table (train --joint) instead of the groups'.")
    ] = False,
    json: JsonOption = False,
) -> None:
    """Build the knowledge tree from the Q table's samples and store it."""
    from homecog.knowledge.ihdr import MODES
    from homecog.knowledge.pipeline import build as run_build
    from homecog.knowledge.store import Store, redact

    if mode not in MODES:
        raise UsageProblemError(f"--mode must be one of {', '.join(MODES)}, got {mode!r}")
    if seed < 0:
        raise UsageProblemError(f"--seed must be 0 or more, got {seed}")
    h = load_home(home)
    if q is not None and not q.exists():
        raise UsageProblemError(f"--q {q}: no such file")
    store = Store(db, h)
    try:
        result = run_build(h, store, q_path=q, mode=mode, seed=seed, joint=joint, progress=_status)
        counts = store.counts()
    finally:
        store.close()
    data = {
        "samples": result.samples,
        "nodes": counts["nodes"],
        "clusters": counts["clusters"],
        "seconds": round(result.seconds, 3),
        "db": redact(store.url),
        "mode": mode,
    }
    if json:
        emit_json(data)
        return
    stdout.print(
        f"built the {mode} tree of {h.name} from {result.samples:,} samples in {result.seconds:.1f} s: "
        f"{counts['nodes']} nodes, {counts['clusters']:,} clusters"
    )
    stdout.print(f"database: {data['db']}")


@contextmanager
def _knowledge(h: Home, db: str | None) -> Iterator[tuple[Any, Any]]:
    """The home's store and its tree (built first if the database has none), closed after."""
    from homecog.knowledge.pipeline import open_tree
    from homecog.knowledge.store import Store

    store = Store(db, h)
    try:
        yield store, open_tree(h, store, progress=_status)
    finally:
        store.close()


@app.command()
def cognize(
    context: ContextOption,
    home: HomeOption = "paper",
    user: UserOption = "default",
    db: DbOption = None,
    json: JsonOption = False,
) -> None:
    """The services the user needs in a context, in priority order, and why."""
    from homecog.knowledge.space import Space, parse_context

    h = load_home(home)
    point = parse_context(context, Space(h))
    with _knowledge(h, db) as (_, tree):
        result = tree.explain_one(point, user=user)
    if json:
        emit_json(result.as_dict())
        return
    if result.unknown:
        stdout.print("unknown context: no experience answers it; tell the robot with homecog correct")
        return
    if not result.services:
        stdout.print("nothing to do: the home is as the user likes it")
        return
    for i, e in enumerate(result.explanations, 1):
        why = "; ".join(f"{k} {v}" for k, v in e.conditions.items()) or "always"
        source = f"{e.user}'s correction" if e.user else f"cluster {e.cluster}"
        stdout.print(f"{i}. {e.service}  [dim]({e.category}; {source}: {why})[/dim]")


@app.command()
def correct(
    context: ContextOption,
    want: Annotated[
        str, typer.Option("--want", help="The services the user wants, comma-separated (empty: none).")
    ],
    home: HomeOption = "paper",
    user: UserOption = "default",
    db: DbOption = None,
    json: JsonOption = False,
) -> None:
    """Tell the robot which services the user wants in a context; it learns at once."""
    from homecog.knowledge.space import Space, parse_context, parse_services

    h = load_home(home)
    point = parse_context(context, Space(h))
    wanted = parse_services(want, h)
    with _knowledge(h, db) as (store, tree):
        added, rejected = store.correct(tree, point, wanted, user)
        experiences = store.experience_count()
    if json:
        emit_json({"added": added, "rejected": rejected, "experiences": experiences, "user": user})
        return
    stdout.print(
        f"learned for {user}: added {', '.join(added) or 'nothing'}; "
        f"rejected {', '.join(rejected) or 'nothing'} ({experiences:,} experiences)"
    )


def _method_names(text: str) -> list[str]:
    """The --methods list, validated."""
    from homecog.evaluation.methods import METHODS

    names = [m.strip() for m in text.split(",") if m.strip()]
    bad = [m for m in names if m not in METHODS]
    if bad or not names:
        raise UsageProblemError(
            f"--methods: unknown method {bad[0] if bad else '(none)'!r}; "
            f"expected some of {', '.join(METHODS)}"
        )
    return names


# -- homecog eval -------------------------------------------------------------------------------
@app.command("eval")
def eval_command(
    home: HomeOption = "paper",
    truth: Annotated[
        str | None, typer.Option(help="The home whose wishes are the ground truth (default: the same home).")
    ] = None,
    scenarios: Annotated[
        str, typer.Option(help="A number of random scenarios, or a scenario CSV file.")
    ] = "2000",
    corrections: Annotated[
        int, typer.Option(help="Corrections by a simulated user (the truth home), with a learning curve.")
    ] = 0,
    seed: Annotated[int, typer.Option(help="Seed of the scenarios and samples.")] = 0,
    methods: Annotated[str, typer.Option(help="Methods, comma-separated.")] = "multi,paper,kmeans,hoeffding",
    report: Annotated[
        Path | None, typer.Option(help="Write a Markdown report with charts into this folder.")
    ] = None,
    db: DbOption = None,
    joint: Annotated[
        bool, typer.Option("--joint", help="Learn from the paper's joint Q table (small homes only).")
    ] = False,
    json: JsonOption = False,
) -> None:
    """Precision, recall and F1 of every method on scenarios; with --corrections, how the robot develops."""
    from homecog.evaluation.evaluate import run as run_eval

    h = load_home(home)
    t = load_home(truth) if truth else h
    names = _method_names(methods)
    if corrections < 0:
        raise UsageProblemError(f"--corrections must be 0 or more, got {corrections}")
    if seed < 0:
        raise UsageProblemError(f"--seed must be 0 or more, got {seed}")
    if scenarios.strip().isdigit():
        cases: int | Path = int(scenarios)
        if cases < 1:
            raise UsageProblemError(f"--scenarios must be at least 1, got {cases}")
    else:
        cases = Path(scenarios)
        if not cases.is_file():
            raise UsageProblemError(f"--scenarios {scenarios}: no such file (give a number or a CSV file)")
    if report is not None:
        _check_writable(report / "report.md")
    result = run_eval(
        h,
        t,
        scenarios=cases,
        seed=seed,
        methods=names,
        corrections=corrections,
        db=db,
        joint=joint,
        progress=_status,
    )
    data = result.as_dict()
    if report is not None:
        from homecog.evaluation.report import write_report

        data["report"] = str(write_report(data, report))
    if json:
        emit_json(data)
        return
    table = Table(title=f"{h.name}: {result.scenarios:,} scenarios, truth {t.name}", title_justify="left")
    for col in ("method", "precision", "recall", "F1", "exact", "seconds"):
        table.add_column(col, justify="right" if col != "method" else "left")
    for name, m in result.methods.items():
        table.add_row(
            name, *(f"{m.micro[k]:.4f}" for k in ("precision", "recall", "f1", "exact")), f"{m.seconds:.2f}"
        )
    table.add_row("paper's Sarsa+IHDR", "0.9821", "0.9026", "0.9407", "", "")
    table.add_row("paper's K-means", "0.8866", "0.8457", "0.8657", "", "")
    stdout.print(table)
    for name, why in result.skipped.items():
        stdout.print(f"{name}: {why}")
    if result.curve:
        stdout.print(
            "corrections → F1: " + ", ".join(f"{c['corrections']}: {c['f1']:.3f}" for c in result.curve)
        )
    if report is not None:
        stdout.print(f"report: {data['report']}")


@app.command()
def replay(
    events: Annotated[
        Path,
        typer.Option(
            "--events",
            help="An event CSV file: timestamp, then every feature and device, and optionally services.",
        ),
    ],
    home: HomeOption = "paper",
    methods: Annotated[str, typer.Option(help="Methods, comma-separated.")] = "multi,paper,kmeans,hoeffding",
    seed: Annotated[int, typer.Option(help="Seed of the samples the methods start from.")] = 0,
    report: Annotated[
        Path | None, typer.Option(help="Write a Markdown report with the running figures into this folder.")
    ] = None,
    joint: Annotated[
        bool, typer.Option("--joint", help="Start from the paper's joint Q table (small homes only).")
    ] = False,
    json: JsonOption = False,
) -> None:
    """Prequential evaluation: every method predicts each event, then learns it."""
    from homecog.evaluation.replay import replay as run_replay
    from homecog.evaluation.report import write_replay_report

    h = load_home(home)
    names = _method_names(methods)
    if not events.is_file():
        raise UsageProblemError(f"--events {events}: no such file")
    if report is not None:
        _check_writable(report / "replay.md")
    result = run_replay(h, events, methods=names, seed=seed, joint=joint, progress=_status)
    data = result.as_dict()
    if report is not None:
        data["report"] = str(write_replay_report(data, report, f"{events.name} on {h.name}"))
    if json:
        data.pop("running")
        emit_json(data)
        return
    table = Table(
        title=f"{result.events:,} events of {events.name}, predicted then learned", title_justify="left"
    )
    for col in ("method", "precision", "recall", "F1"):
        table.add_column(col, justify="right" if col != "method" else "left")
    for name, m in result.methods.items():
        table.add_row(name, *(f"{m[k]:.4f}" for k in ("precision", "recall", "f1")))
    stdout.print(table)
    for name, why in result.skipped.items():
        stdout.print(f"{name}: {why}")
    if report is not None:
        stdout.print(f"report: {data['report']}")


@app.command("adapt-mit")
def adapt_mit(
    folder: Annotated[Path, typer.Argument(help="A subject's folder of the MIT home-activity data.")],
    out: Annotated[Path, typer.Option(help="Where to write the home file and the event file.")] = Path("."),
    name: Annotated[str | None, typer.Option(help="The home's name (default mit_<folder>).")] = None,
    json: JsonOption = False,
) -> None:
    """Turn the MIT home-activity data of one subject into a home file and an event file."""
    from homecog.evaluation.mit import convert

    if not folder.is_dir():
        raise UsageProblemError(f"{folder}: not a folder")
    _check_writable(out / ".probe")
    home_path, events_path, n = convert(folder, out, name)
    h = load_home(home_path)  # what it wrote must load
    data = {
        "home": str(home_path),
        "events": str(events_path),
        "rows": n,
        "name": h.name,
        "devices": len(h.devices),
        "contexts": h.context_count,
    }
    if json:
        emit_json(data)
        return
    stdout.print(
        f"wrote {home_path} ({len(h.devices)} devices, {h.context_count} contexts) and "
        f"{events_path} ({n} events)"
    )
    stdout.print(f"next: homecog replay --home {home_path} --events {events_path}")


# -- homecog plan / simulate ------------------------------------------------------------------
ServicesOption = Annotated[
    str, typer.Option("--services", help="Services in priority order, comma-separated.")
]
PlanContextOption = Annotated[
    str | None,
    typer.Option(
        "--context", help="The context (as for cognize): the user's location and the device states."
    ),
]


def _plan(h: Home, services: str, context: str | None) -> Any:
    from homecog.knowledge.space import Space, parse_context
    from homecog.planning import plan_services

    names = [s.strip() for s in services.split(",") if s.strip()]
    if not names:
        raise UsageProblemError("--services: expected at least one service")
    values = None
    if context is not None:
        space = Space(h)
        values = space.context(parse_context(context, space))
    return plan_services(h, names, context=values)


@app.command()
def plan(
    services: ServicesOption,
    home: HomeOption = "paper",
    context: PlanContextOption = None,
    json: JsonOption = False,
) -> None:
    """Decompose services into robot actions (HTN), in the given order, with the task tree."""
    h = load_home(home)
    result = _plan(h, services, context)
    if json:
        emit_json({"actions": [list(a) for a in result.actions], "tree": [n.as_dict() for n in result.tree]})
        return
    stdout.print(result.outline(), highlight=False, markup=False)
    stdout.print(f"{len(result.actions)} actions", style="dim")


@app.command()
def simulate(
    services: ServicesOption,
    home: HomeOption = "paper",
    context: PlanContextOption = None,
    png: Annotated[Path | None, typer.Option("--png", help="Draw the trajectory into this PNG file.")] = None,
    bag: Annotated[
        Path | None,
        typer.Option("--bag", help="Also write the run as a ROS 2 bag (MCAP) into this new folder."),
    ] = None,
    json: JsonOption = False,
) -> None:
    """Plan the services and carry the plan out with a simulated robot on the floor plan."""
    from homecog.simulation import draw_trajectory
    from homecog.simulation import simulate as run_simulation
    from homecog.simulation.bag import check_bag_folder, write_bag

    h = load_home(home)
    if png is not None:
        _check_writable(png)
    if bag is not None:
        check_bag_folder(bag)
    result = _plan(h, services, context)
    sim = run_simulation(h, result.actions, state=result.start)
    data = sim.as_dict()
    data["png"] = None
    if png is not None:
        draw_trajectory(h.layout, sim, png)
        data["png"] = str(png)
    data["bag"] = str(write_bag(h, sim, bag)) if bag is not None else None
    if json:
        emit_json(data)
        return
    for step in sim.timeline:
        stdout.print(
            f"{step['start']:7.1f} s  {' '.join(step['action'])}"
            + (f"  ({step['distance_m']:.2f} m)" if step["distance_m"] else ""),
            highlight=False,
            markup=False,
        )
    stdout.print(f"{len(sim.timeline)} actions in {sim.seconds:.1f} s, {sim.distance_m:.2f} m driven")
    if png is not None:
        stdout.print(f"trajectory: {png}")
    if bag is not None:
        stdout.print(f"ROS 2 bag: {bag}")


# -- homecog up ---------------------------------------------------------------------------------
LOCAL_HOSTS = ("127.0.0.1", "localhost", "::1")


@app.command()
def up(
    home: HomeOption = "paper",
    db: DbOption = None,
    host: Annotated[
        str, typer.Option(help="Address to serve on; any but 127.0.0.1 needs a token.")
    ] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="Port to serve on.")] = 8000,
    token: Annotated[
        str | None,
        typer.Option(help="Token for writes (default: none on 127.0.0.1, else generated and printed once)."),
    ] = None,
    speed: Annotated[
        float, typer.Option(help="Simulated seconds per real second of the simulated home (0: manual).")
    ] = 60.0,
    mqtt: Annotated[
        str | None,
        typer.Option(
            help="Take the context from this MQTT broker (mqtt://host:1883) instead of the simulator."
        ),
    ] = None,
    publish: Annotated[
        str | None,
        typer.Option(
            help="Mirror the simulated home on this MQTT broker: its states go out, commands come in."
        ),
    ] = None,
    home_assistant: Annotated[
        str | None,
        typer.Option(
            "--home-assistant", help="Take the context from this Home Assistant (http://host:8123) instead."
        ),
    ] = None,
    ha_token: Annotated[
        str | None, typer.Option("--ha-token", help="Its access token (default: $HOMECOG_HA_TOKEN).")
    ] = None,
) -> None:
    """Start the robot: train or reuse the Q table, build or reuse the tree, serve the HMI."""
    import gc
    import secrets

    import uvicorn

    from homecog.context.simulated import SimulatedHome
    from homecog.knowledge.pipeline import open_tree
    from homecog.knowledge.store import Store, redact
    from homecog.web.app import create_app
    from homecog.web.runtime import ManualSource, Runtime

    if not 0 < port < 65536:
        raise UsageProblemError(f"--port must be 1 to 65535, got {port}")
    if not 0 <= speed <= 100_000:
        raise UsageProblemError(f"--speed must be 0 to 100000, got {speed:g}")
    if token is not None and len(token) < 8:
        raise UsageProblemError("--token must be at least 8 characters")
    if publish is not None and (mqtt is not None or speed == 0):
        raise UsageProblemError("--publish mirrors the simulated home; it needs --speed > 0 and no --mqtt")
    if home_assistant is not None and (mqtt is not None or publish is not None):
        raise UsageProblemError(
            "--home-assistant is the home's context; it goes with neither --mqtt nor --publish"
        )
    h = load_home(home)
    if host not in LOCAL_HOSTS and token is None:
        token = secrets.token_urlsafe(24)
        stdout.print(f"token for writes (shown once): {token}")
    say = stdout.print
    with contextlib.ExitStack() as stack:
        if home_assistant is not None:  # first: a wrong URL, token or entity fails before any training
            from homecog.context.home_assistant import HomeAssistantSource

            token_ha = ha_token or os.environ.get("HOMECOG_HA_TOKEN")
            ha_source = HomeAssistantSource(h, home_assistant, token=token_ha).start()
            stack.callback(ha_source.stop)
            say(f"context from Home Assistant {ha_source.version} at {home_assistant}")
        store = Store(db, h)
        stack.callback(store.close)
        tree = open_tree(h, store, progress=lambda m: say(m, style="dim"))
        source: Any = SimulatedHome(h, speed=speed) if speed > 0 else ManualSource(h)
        if mqtt is not None:
            from homecog.context.mqtt import MqttSource

            source = MqttSource(h, mqtt, on_change=lambda snapshot: runtime.publish("context", snapshot))
            source.start()
            stack.callback(source.stop)
            say(
                f"context from {mqtt}: topics homecog/{h.name}/state/<name>, "
                f"commands to homecog/{h.name}/command/<device>"
            )
        if home_assistant is not None:
            source = ha_source
            ha_source.on_change = lambda snapshot: runtime.publish("context", snapshot)
        runtime = Runtime(home=h, store=store, tree=tree, source=source, token=token)
        if publish is not None:
            from homecog.context.mqtt import MqttPublisher

            mirror = MqttPublisher(h, publish, on_command=runtime.switch).start()
            stack.callback(mirror.stop)
            mirror.publish(source.snapshot(), everything=True)
            runtime.watchers.append(mirror.publish)
            say(
                f"the simulated home on {publish}: states to homecog/{h.name}/state/<name>, "
                f"commands from homecog/{h.name}/command/<device>"
            )
        say(f"knowledge: {redact(store.url)} ({store.experience_count():,} experiences)", style="dim")
        say(f"homecog is up: http://{host if ':' not in host else f'[{host}]'}:{port}")
        live = (speed or None) if mqtt is None and home_assistant is None else 1.0  # a real home's own clock
        gc.freeze()  # the tree lives as long as the server: keep the collector from walking it
        uvicorn.run(
            create_app(runtime, speed=live),
            host=host,
            port=port,
            log_level="warning",
            access_log=False,
            proxy_headers=False,  # no proxy is trusted: X-Forwarded-For is not the client
        )


# -- entry point -------------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> int:
    """Run the command line; errors become one line on stderr and exit status 2."""
    args = sys.argv[1:] if argv is None else argv
    try:
        result = app(args=args, prog_name="homecog", standalone_mode=False)
    except HomecogError as e:
        print(f"homecog: error: {e}", file=sys.stderr)
        return 2
    except click_errors.NoArgsIsHelpError:
        return 2  # the help was printed
    except click_errors.UsageError as e:
        where = f"{e.ctx.command_path}: " if e.ctx else ""
        print(f"homecog: error: {where}{e.format_message()}".replace("\n", " "), file=sys.stderr)
        return 2
    except typer.Abort:
        print("homecog: aborted", file=sys.stderr)
        return 130
    except KeyboardInterrupt:
        print("homecog: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 1
    return result if isinstance(result, int) else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
