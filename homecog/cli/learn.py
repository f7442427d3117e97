"""``homecog train`` and ``homecog build``: Sarsa, group by group or joint, and the knowledge tree
built from its samples into the database."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from homecog.cli.options import (
    DbOption,
    HomeOption,
    JsonOption,
    UsageProblemError,
    check_readable,
    check_writable,
)
from homecog.cli.output import emit, emit_json, stdout
from homecog.cli.progress import CommandProgress
from homecog.home import load_home
from homecog.learning.size import big_number


class Mode(StrEnum):
    """The tree's two modes."""

    multi = "multi"
    paper = "paper"


def train(
    home: HomeOption = "paper",
    episodes: Annotated[
        int | None,
        typer.Option(
            help="Episodes: in all, split over the groups by size (default: sweeps until every "
            "group's policy is stable); with --joint, 3,000,000 by default."
        ),
    ] = None,
    seed: Annotated[int, typer.Option(min=0, help="Seed; a run is reproducible from it.")] = 0,
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
    h = load_home(home)  # before the imports below: a bad file is refused at once
    from dataclasses import replace

    from homecog.learning.grouped import train_policy
    from homecog.learning.sarsa import INT64_MAX, SarsaConfig
    from homecog.learning.size import check_size
    from homecog.paths import q_table_path

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
    if episodes is not None and episodes > INT64_MAX:
        raise UsageProblemError(f"episodes must be at most {INT64_MAX}, got {episodes}")
    size = check_size(h, joint=joint)
    path = out if out is not None else q_table_path(h, joint=joint)
    check_writable(path, inputs={"--home": home}, private=True)
    starts = h.context_count << len(h.devices)
    with CommandProgress("train") as progress:
        progress(f"Sarsa on {h.name}, {'episodes' if joint else 'start states'}")
        result = train_policy(
            h, config, joint=joint, episodes=None if joint else episodes, progress=progress.update
        )
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
        f"greedy-optimal rate {result.greedy_optimal_rate:.6f} over {big_number(starts)} start states (exact)"
    )
    stdout.print(f"Q table: {path}")


def build(
    home: HomeOption = "paper",
    q: Annotated[
        Path | None, typer.Option("--q", help="The Q table (default: the cached one, trained if missing).")
    ] = None,
    db: DbOption = None,
    mode: Annotated[
        Mode,
        typer.Option(help="multi (several clusters per service) or paper (Algorithms 2 and 3 as published)."),
    ] = Mode.multi,
    seed: Annotated[int, typer.Option(min=0, help="Seed of the random readings inside bins.")] = 0,
    joint: Annotated[
        bool, typer.Option("--joint", help="Use the joint Q table (train --joint) instead of the groups'.")
    ] = False,
    json: JsonOption = False,
) -> None:
    """Build the knowledge tree from the Q table's samples and store it."""
    from homecog.knowledge.database import redact
    from homecog.knowledge.pipeline import build as run_build
    from homecog.knowledge.store import Store

    h = load_home(home)
    if q is not None:
        check_readable(q, "--q", "a Q table", limit=2**40)
    store = Store.open(db, h)
    try:
        with CommandProgress("build") as progress:
            result = run_build(h, store, q_path=q, mode=mode.value, seed=seed, joint=joint, progress=progress)
        counts = store.counts()
    finally:
        store.close()
    data = {
        "samples": result.samples,
        "nodes": counts["nodes"],
        "clusters": counts["clusters"],
        "seconds": round(result.seconds, 3),
        "db": redact(store.url),
        "mode": mode.value,
    }
    emit(
        data,
        json,
        f"built the {mode.value} tree of {h.name} from {result.samples:,} samples in {result.seconds:.1f} s: "
        f"{counts['nodes']} nodes, {counts['clusters']:,} clusters",
        f"database: {data['db']}",
    )
