"""``homecog eval``, ``homecog replay`` and ``homecog adapt-mit``: quality on scenarios, learning
from event streams, real data."""

from __future__ import annotations

from datetime import datetime, timedelta
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from homecog.cli.options import (
    ALL_METHODS,
    DbOption,
    HomeOption,
    JsonOption,
    MethodsOption,
    check_conversion,
    check_not_input,
    check_readable,
    check_writable,
    method_names,
)
from homecog.cli.output import emit, emit_json, stdout
from homecog.cli.progress import CommandProgress
from homecog.cli.render import days_table, eval_table, faults_tables, replay_table
from homecog.errors import UsageProblemError
from homecog.home import load_home

if TYPE_CHECKING:
    from homecog.evaluation.evaluate import EvalReport


# -- homecog eval -------------------------------------------------------------------------------
#: ``eval --days``: the closed loop, the robot living with a simulated household.
DaysOption = Annotated[
    int | None,
    typer.Option(
        min=1,
        max=365,
        help="Instead: the robot and a household of the truth home's wishes live this many "
        "simulated days; the household corrects it only by switching.",
    ),
]
StartOption = Annotated[
    str | None,
    typer.Option(help="With --days: the simulated date and time to start at (default 2021-06-21 06:00)."),
]


def eval_command(
    home: HomeOption = "paper",
    truth: Annotated[
        str | None, typer.Option(help="The home whose wishes are the ground truth (default: the same home).")
    ] = None,
    scenarios: Annotated[
        str, typer.Option(help="A number of random scenarios, or a scenario CSV file.")
    ] = "2000",
    corrections: Annotated[
        int,
        typer.Option(min=0, help="Corrections by a simulated user (the truth home), with a learning curve."),
    ] = 0,
    seed: Annotated[int, typer.Option(min=0, help="Seed of the scenarios and samples.")] = 0,
    methods: MethodsOption = ALL_METHODS,
    report: Annotated[
        Path | None, typer.Option(help="Write a Markdown report with charts into this folder.")
    ] = None,
    db: DbOption = None,
    joint: Annotated[
        bool, typer.Option("--joint", help="Learn from the paper's joint Q table (small homes only).")
    ] = False,
    days: DaysOption = None,
    start: StartOption = None,
    json: JsonOption = False,
) -> None:
    """Precision, recall and F1 of every method on scenarios; with --corrections, how the robot
    develops; with --days, the robot living with a household (the closed loop)."""
    from homecog.evaluation.evaluate import run as run_eval

    h = load_home(home)
    t = load_home(truth) if truth else h
    if days is not None:
        if corrections:
            raise UsageProblemError("--days and --corrections are two evaluations; give one")
        _closed_loop(h, t, days=days, seed=seed, db=db, report=report, json=json, start=start)
        return
    if start is not None:
        raise UsageProblemError("--start is the closed loop's; give it with --days")
    names = method_names(methods)
    cases = _scenarios(scenarios)
    if report is not None:
        check_writable(report / "report.md", "--report", inputs={"--scenarios": scenarios, "--home": home})
    with CommandProgress("eval") as progress:
        result = run_eval(
            h,
            t,
            scenarios=cases,
            seed=seed,
            methods=names,
            corrections=corrections,
            db=db,
            joint=joint,
            progress=progress,
        )
    _show_eval(result, report, json)


def _scenarios(text: str) -> int | Path:
    """--scenarios: a number of random scenarios (at least 1), or a readable scenario file."""
    if text.strip().isdigit():
        if int(text) < 1:
            raise UsageProblemError(f"--scenarios must be at least 1, got {int(text)}")
        return int(text)
    path = Path(text)
    if not path.exists() and not path.is_symlink():
        raise UsageProblemError(f"--scenarios {text}: no such file (give a number or a CSV file)")
    check_readable(path, "--scenarios", "a scenario file")
    return path


def _show_eval(result: EvalReport, report: Path | None, json: bool) -> None:
    """The evaluation's figures: its report written, as JSON or as a table."""
    data = result.as_dict()
    if report is not None:
        from homecog.evaluation.report import write_report

        data["report"] = str(write_report(data, report))
    if json:
        emit_json(data)
        return
    stdout.print(eval_table(result, result.home, result.truth))
    _say_skipped(result.skipped)
    if result.curve:
        stdout.print(
            "corrections → F1: " + ", ".join(f"{c['corrections']}: {c['f1']:.3f}" for c in result.curve)
        )
    if report is not None:
        stdout.print(f"report: {data['report']}")


def _say_skipped(skipped: dict[str, str]) -> None:
    """Every method left out, and why."""
    for name, why in skipped.items():
        stdout.print(f"{name}: {why}")


def _closed_loop(
    h: Any,
    t: Any,
    *,
    days: int,
    seed: int,
    db: str | None,
    report: Path | None,
    json: bool,
    start: str | None,
) -> None:
    """``homecog eval --days``: the robot (knowledge in ``db``, else in memory) and a household of
    ``t``'s wishes live ``days`` days in ``h``."""
    from homecog.evaluation.closed_loop import closed_loop
    from homecog.evaluation.evaluate import check_truth
    from homecog.knowledge.pipeline import open_tree
    from homecog.knowledge.store import Store

    check_truth(h, t)
    if start is not None:
        from homecog.context.simulated import parse_start

        moment = parse_start(start)  # a start that is no date and time fails before any learning
        if datetime.max - moment <= timedelta(days=days + 1):
            raise UsageProblemError(
                f"--start {start}: {days} day{'s' * (days != 1)} from then is past the year 9999"
            )
    if report is not None:
        check_writable(report / "household.md", "--report", inputs={"--home": h.source})
    store = Store.open(db or "sqlite://", h)
    try:
        with CommandProgress("eval --days") as progress:
            tree = open_tree(h, store, progress=progress)
            when = {} if start is None else {"start": start}
            result = closed_loop(h, t, store, tree, days=days, seed=seed, progress=progress, **when)
    finally:
        store.close()
    if report is not None:
        from homecog.evaluation.closed_loop_report import write_days_report

        result["report"] = str(write_days_report(result, report))
    if json:
        emit_json(result)
        return
    stdout.print(days_table(result))
    tables = faults_tables(result)
    for table in tables:
        stdout.print(table)
    if not tables:
        stdout.print("nothing went wrong: no switch of the robot's undone, none made by hand instead")
    s = result["summary"]
    share = s["last3_household_share"]
    stdout.print(
        "last 3 days: the household's own switches "
        + (f"{share:.0%} a day of day 1's" if share is not None else "(none on day 1)")
        + f", {s['last3_undone_share']:.1%} of the robot's switches undone, {s['fights']} fights"
    )
    if report is not None:
        stdout.print(f"report: {result['report']}")


def replay(
    events: Annotated[
        Path,
        typer.Option(
            "--events",
            help="An event CSV file: timestamp, then every feature and device, and optionally services.",
        ),
    ],
    home: HomeOption = "paper",
    methods: MethodsOption = ALL_METHODS,
    seed: Annotated[int, typer.Option(min=0, help="Seed of the samples the methods start from.")] = 0,
    report: Annotated[
        Path | None, typer.Option(help="Write a Markdown report with the running figures into this folder.")
    ] = None,
    joint: Annotated[
        bool, typer.Option("--joint", help="Start from the paper's joint Q table (small homes only).")
    ] = False,
    predictions: Annotated[
        Path | None,
        typer.Option(help="Write every method's answer to every event into this file, a JSON line an event."),
    ] = None,
    json: JsonOption = False,
) -> None:
    """Prequential evaluation: every method predicts each event, then learns it."""
    check_readable(events, "--events", "an event file")  # before the imports: a second or two
    from homecog.evaluation.replay import replay as run_replay
    from homecog.evaluation.report import write_replay_report

    h = load_home(home)
    names = method_names(methods)
    if report is not None:
        check_writable(report / "replay.md", "--report", inputs={"--events": events, "--home": home})
    if predictions is not None:
        check_not_input(predictions, "--predictions", {"--events": events, "--home": home})
        _check_file("--predictions", predictions)
    with CommandProgress("replay") as progress:
        progress(f"reading {events.name}")
        result = run_replay(
            h, events, methods=names, seed=seed, joint=joint, progress=progress, predictions=predictions
        )
    data = result.as_dict()
    if report is not None:
        data["report"] = str(write_replay_report(data, report, f"{events.name} on {h.name}"))
    if json:
        data.pop("running")
        emit_json(data)
        return
    stdout.print(replay_table(result, events.name))
    _say_skipped(result.skipped)
    if report is not None:
        stdout.print(f"report: {data['report']}")


def _check_file(option: str, path: Path) -> None:
    """Fail before the work when a file cannot be written there (one line naming it); a named
    pipe without a reader would hang the command."""
    from homecog.text_files import not_to_write

    problem = not_to_write(path)
    if problem is not None:
        raise UsageProblemError(f"{option} {path}: {problem}")
    if not path.parent.is_dir():
        raise UsageProblemError(f"{option} {path}: cannot write there: no directory {path.parent}")
    existed = path.exists()
    try:
        with path.open("a", encoding="utf-8"):
            pass
    except OSError as e:
        raise UsageProblemError(f"{option} {path}: cannot write there: {e.strerror}") from None
    if not existed:
        path.unlink()  # the replay makes it; a run that fails before leaves nothing behind


def adapt_mit(
    folder: Annotated[Path, typer.Argument(help="A subject's folder of the MIT home-activity data.")],
    out: Annotated[Path, typer.Option(help="Where to write the home file and the event file.")] = Path("."),
    name: Annotated[str | None, typer.Option(help="The home's name (default mit_<folder>).")] = None,
    json: JsonOption = False,
) -> None:
    """Turn the MIT home-activity data of one subject into a home file and an event file."""
    from homecog.evaluation.mit import convert

    check_conversion(folder, out)
    with CommandProgress("adapt-mit") as progress:
        progress(f"converting {folder.name}")
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
    emit(
        data,
        json,
        f"wrote {home_path} ({len(h.devices)} devices, {h.context_count} contexts) and "
        f"{events_path} ({n} events)",
        f"next: homecog replay --home {home_path} --events {events_path}",
    )
