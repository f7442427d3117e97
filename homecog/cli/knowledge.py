"""``homecog cognize`` and ``homecog correct``: the services a user needs in a context, and a
user's corrections."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import typer

from homecog.cli.context_args import AtOption, DoingOption, PairsArgument, WhereOption, given_context
from homecog.cli.options import (
    ContextOption,
    DbOption,
    HomeOption,
    JsonOption,
    UserOption,
    check_readable,
)
from homecog.cli.output import emit_json, stdout
from homecog.cli.progress import CommandProgress
from homecog.errors import UsageProblemError
from homecog.home import Home, load_home

#: What ``correct`` is told the user wants: the whole set, or services to add or reject.
WantOption = Annotated[
    str | None, typer.Option(help="The services the user wants, comma-separated (empty: none).")
]
AddOption = Annotated[
    str | None,
    typer.Option(help="Instead: services the user wants too, comma-separated; the rest keep theirs."),
]
RejectOption = Annotated[
    str | None, typer.Option(help="Instead: services the user does not want, comma-separated.")
]


@contextmanager
def _knowledge(h: Home, db: str | None, progress: CommandProgress) -> Iterator[tuple[Any, Any]]:
    """The home's store and its tree (built first if the database has none), closed after."""
    from homecog.knowledge.pipeline import open_tree
    from homecog.knowledge.store import Store

    store = Store.open(db, h)
    try:
        yield store, open_tree(h, store, progress=progress)
    finally:
        store.close()


def cognize(
    pairs: PairsArgument = None,
    context: ContextOption = None,
    at: AtOption = None,
    where: WhereOption = None,
    doing: DoingOption = None,
    home: HomeOption = "paper",
    user: UserOption = None,
    db: DbOption = None,
    json: JsonOption = False,
) -> None:
    """The services the user needs in a context, in priority order, and why."""
    h = load_home(home)
    user = _member(h, user)
    given = given_context(h, context, at, where, doing, pairs)
    with CommandProgress("cognize") as progress, _knowledge(h, db, progress) as (_, tree):
        result = tree.explain_one(given.point, user=user)
    if json:
        emit_json(result.as_dict())
        return
    if given.assumed:
        stdout.print(f"assumed: {_assumed(h, given.assumed)}", style="dim", markup=False)
    if result.unknown:
        stdout.print("unknown context: no experience answers it; tell the robot with homecog correct")
        return
    if not result.services:
        stdout.print("nothing to do: the home is as the user likes it")
        return
    for i, e in enumerate(result.explanations, 1):
        why = "; ".join(f"{k} {v}" for k, v in e.conditions.items()) or "always"
        if e.evidence is not None:
            n = e.evidence["agreed"] + e.evidence["disagreed"]
            numbers = ", ".join(f"#{c}" for c in e.evidence["corrections"])
            source = f"{e.evidence['agreed']} of {n} of {e.user}'s corrections agree ({numbers})"
        else:
            source = f"{e.user}'s correction" if e.user else f"cluster {e.cluster}"
        stdout.print(f"{i}. {e.service}  [dim]({e.category}; {source}: {why})[/dim]")


def correct(
    pairs: PairsArgument = None,
    context: ContextOption = None,
    at: AtOption = None,
    where: WhereOption = None,
    doing: DoingOption = None,
    want: WantOption = None,
    add: AddOption = None,
    reject: RejectOption = None,
    events: Annotated[
        Path | None,
        typer.Option(
            "--events",
            help="An event CSV file (timestamp, every feature and device, services; optionally user) "
            "to learn, row by row, as corrections.",
        ),
    ] = None,
    batch: Annotated[int, typer.Option(min=1, help="Corrections of --events to a transaction.")] = 100,
    home: HomeOption = "paper",
    user: UserOption = None,
    db: DbOption = None,
    json: JsonOption = False,
) -> None:
    """Tell the robot which services the user wants in a context, or learn an event file; it
    learns at once."""
    from homecog.home.codec import parse_services
    from homecog.knowledge import core
    from homecog.knowledge.correction import Correction

    partial = add is not None or reject is not None
    short = pairs or at is not None or where is not None or doing is not None
    if events is not None:
        if context is not None or short or want is not None or partial:
            raise UsageProblemError(
                "--events learns a file: give it without a context, --want, --add or --reject"
            )
        _correct_events(events, home=home, user=user, db=db, batch=batch, json=json)
        return
    if (context is None and not short) or (want is None) == (not partial):
        raise UsageProblemError(
            "give a context (--context, or --at, --where, --doing, NAME=VALUE) and --want (the whole "
            "set) or --add/--reject, or --events FILE"
        )
    h = load_home(home)
    user = _member(h, user)
    point = given_context(h, context, at, where, doing, pairs).point
    if partial:
        adds, rejects = parse_services(add or "", h), parse_services(reject or "", h)
        both = sorted(set(adds) & set(rejects))
        if both:
            raise UsageProblemError(f"--add and --reject both name {both[0]}")
        if not adds and not rejects:
            raise UsageProblemError("--add and --reject name no service")
        c = Correction.change(user, point, add=adds, reject=rejects)
    else:
        c = Correction.whole(user, point, parse_services(want, h))  # type: ignore[arg-type]
    with CommandProgress("correct") as progress, _knowledge(h, db, progress) as (store, tree):
        outcome = core.correct(store, tree, c)
        experiences = store.experience_count()
    if json:
        emit_json({**outcome.as_dict(), "experiences": experiences})
        return
    changed = [f"now adds {', '.join(outcome.added)}"] if outcome.added else []
    changed += [f"no longer proposes {', '.join(outcome.rejected)}"] if outcome.rejected else []
    stdout.print(
        f"stored {user}'s correction #{outcome.number}: {c.says()}; "
        f"{'the robot ' + ' and '.join(changed) if changed else 'the robot already answered so'} "
        f"({experiences:,} experiences)"
    )


def _assumed(h: Home, names: tuple[str, ...]) -> str:
    """What a short context left out, as filled in: ``temperature, posture unknown; every
    other device off``."""
    features = [n for n in names if n in h.feature_names]
    devices = [n for n in names if n in h.device_names]
    said = [f"{', '.join(features)} unknown"] if features else []
    if devices:
        said.append("every device off" if len(devices) == len(h.devices) else "every other device off")
    return "; ".join(said)


def _member(h: Home, user: str | None) -> str:
    """``--user``, or the home's default user; one of the household's users where it names them."""
    if user is None:
        return h.household.default_user
    if not h.household.knows(user):
        raise UsageProblemError(f"--user {user}: not one of the household ({h.household.names()})")
    return user


def _correct_events(
    events: Path, *, home: str, user: str | None, db: str | None, batch: int, json: bool
) -> None:
    """``correct --events``: the whole file checked, then learned in batches of transactions."""
    check_readable(events, "--events", "an event file")
    from homecog.knowledge.event_file import learn_corrections, read_corrections

    h = load_home(home)
    with CommandProgress("correct --events") as progress:
        progress(f"reading {events.name}")
        # every row checked before the first write
        corrections = read_corrections(events, h, _member(h, user))
        with _knowledge(h, db, progress) as (store, tree):
            progress("learning corrections")
            result = learn_corrections(store, tree, corrections, batch=batch, progress=progress.update)
    if json:
        emit_json(result.as_dict())
        return
    stdout.print(
        f"learned {result.events:,} events of {events.name} as corrections in {result.batches:,} "
        f"transaction(s), {result.seconds:.1f} s: {result.changed:,} changed what the robot does "
        f"(added {result.added:,} services, rejected {result.rejected:,}); {result.experiences:,} experiences"
    )
    for name, n in sorted(result.users.items()):
        stdout.print(f"  {name}: {n:,} corrections")
