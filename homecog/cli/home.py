"""``homecog home show`` and ``homecog home check``: a home file read, its sizes and groups, its
conflicting rules."""

from __future__ import annotations

from typing import Annotated, Any

import typer

from homecog.cli.options import (
    HomeOption,
    JsonOption,
)
from homecog.cli.output import emit_json, stdout
from homecog.cli.render import home_tables
from homecog.home import Home, load_home
from homecog.home.content import canonical
from homecog.home.model import format_number
from homecog.learning.size import big_number


def home_summary(home: Home) -> dict[str, Any]:
    """Sizes of a home's spaces (used by ``home show`` and ``home check``): the joint space, and
    the independent groups the learner splits it into."""
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


def home_show(home: HomeOption = "paper", json: JsonOption = False) -> None:
    """Print a home readably: features and bins, devices, services and rules."""
    h = load_home(home)
    if json:
        emit_json({"summary": home_summary(h), "definition": canonical(h)})
        return
    s = home_summary(h)
    stdout.print(f"[bold]{h.name}[/bold] ({h.source}) — {h.description or ''}")
    stdout.print(
        f"{big_number(s['contexts'])} contexts × 2^{s['devices']} device states = "
        f"{big_number(s['start_states'])} start states; {big_number(s['states'])} states with pending "
        f"needs; hash {h.content_hash[:12]}"
    )
    stdout.print(
        f"learned in {s['groups']} independent groups, {big_number(s['group_states'])} states in all; "
        f"the largest, {s['largest_group']}, has {big_number(s['largest_group_states'])}"
        + (
            f"; {s['scenes']} scenes, each taken where it does the work of several services"
            if s["scenes"]
            else ""
        )
    )

    for table in home_tables(h):
        stdout.print(table)
    w, magnitude = h.rewards.weights, h.rewards.magnitude
    stdout.print(
        f"Rewards: {format_number(w.terminal)}·terminal + {format_number(w.progress)}·progress "
        f"+ {format_number(w.prohibited)}·prohibited, each ±{format_number(magnitude)}"
    )


def home_check(
    file: Annotated[str, typer.Argument(help="The home file to validate.")], json: JsonOption = False
) -> None:
    """Validate a home file; report its size and any start state that cannot reach its optimum."""
    h = load_home(file)  # before the imports below: a bad file is refused at once
    from homecog.environment.conflicts import find_conflicts
    from homecog.learning.size import check_size, describe

    size = check_size(h)
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
        f"{big_number(summary['contexts'])} contexts, {summary['devices']} devices, "
        f"{summary['services']} services"
        + (f" ({summary['scenes']} of them scenes)" if summary["scenes"] else "")
        + f"; {describe(size)}"
    )
    if report.stuck:
        stdout.print(
            f"warning: {big_number(report.stuck)} of {big_number(report.start_states)} start states "
            "cannot reach the optimum without a prohibited or useless service (conflicting rules):"
        )
        for c in report.groups:
            example = ", ".join(f"{k}={v}" for k, v in c.example.items())
            stdout.print(
                f"  {c.group.label}: {big_number(c.stuck)} of its {big_number(c.start_states)} start states, "
                f"e.g. {example}"
            )


# -- homecog train -----------------------------------------------------------------------------
