"""What the commands print for people (``--json`` prints data instead): tables and lines made
apart from the commands that compute them."""

from __future__ import annotations

from typing import Any

from rich.table import Table

from homecog.evaluation.closed_loop_faults import worst
from homecog.evaluation.report import PAPER_TABLE9, VERSUS
from homecog.home import Home


def when_text(home: Home, cond: Any) -> str:
    parts = [
        f"{home.features[f].name}∈{{{', '.join(home.features[f].values[k] for k in sorted(codes))}}}"
        for f, codes in cond.features
    ]
    parts += [
        f"{home.devices[d].name}={'/'.join('on' if s else 'off' for s in sorted(states))}"
        for d, states in cond.devices
    ]
    return " and ".join(parts) if parts else "always"


def home_tables(h: Home) -> list[Table]:
    """A home's features (with Table 1 codes), devices with their comfort rules, and services."""
    from homecog.home.encoding import coded

    out = []
    t = Table(title="Context features (code / normalized, as Table 1)", title_justify="left")
    for col in ("feature", "kind", "values"):
        t.add_column(col, no_wrap=col in ("feature", "device", "service"), overflow="fold")
    for f in h.features:
        values = []
        for k, v in enumerate(f.values):
            code, norm = coded(f, k)
            rng = f" {f.describe_bin(k)}" if f.bins else ""
            values.append(f"{v}{rng} ({code}/{norm:.2g})")
        t.add_row(f.name + (f" [{f.unit}]" if f.unit else ""), f.kind, "\n".join(values))
    out.append(t)

    t = Table(title="Devices (hardware code order)", title_justify="left")
    for col in ("#", "device", "room", "switched", "comfort rules (first match wins)"):
        t.add_column(col, no_wrap=col in ("feature", "device", "service"), overflow="fold")
    for i, (d, rules) in enumerate(zip(h.devices, h.comfort, strict=True)):
        shown = "\n".join(f"{'on ' if r.want else 'off'} when {when_text(h, r.when)}" for r in rules)
        t.add_row(str(i + 1), d.name, d.room or "", "IoT" if d.iot else "by hand", shown or "don't care")
    out.append(t)

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
            "\n".join(when_text(h, c) for c in needs) or "-",
            "\n".join(when_text(h, c) for c in prohibited) or "-",
        )
    out.append(t)
    return out


def eval_table(result: Any, home: str, truth: str) -> Table:
    """Each method's micro figures, beside the paper's Table 9 on the paper's own home."""
    table = Table(title=f"{home}: {result.scenarios:,} scenarios, truth {truth}", title_justify="left")
    versus = result.versus()
    columns = ["method", "precision", "recall", "F1", "exact", "ECE", "seconds"] + (
        [VERSUS] if versus else []
    )
    for col in columns:
        table.add_column(col, justify="right" if col != "method" else "left")
    for name, m in result.methods.items():
        figures = (f"{m.micro[k]:.4f}" for k in ("precision", "recall", "f1", "exact"))
        against = [str(versus[name]) if name in versus else ""] if versus else []
        ece = f"{m.calibration['ece']:.4f}" if m.calibration else ""
        table.add_row(name, *figures, ece, f"{m.seconds:.2f}", *against)
    for name, (p, r, f) in PAPER_TABLE9.items() if result.paper else ():
        table.add_row(
            name, f"{p / 100:.4f}", f"{r / 100:.4f}", f"{f / 100:.4f}", "", "", "", *([""] if versus else [])
        )
    return table


def replay_table(result: Any, events: str) -> Table:
    """Each method's running figures at the end of an event stream."""
    table = Table(title=f"{result.events:,} events of {events}, predicted then learned", title_justify="left")
    versus = result.versus()
    columns = ["method", "precision", "recall", "F1", "ECE"] + ([VERSUS] if versus else [])
    for col in columns:
        table.add_column(col, justify="right" if col != "method" else "left")
    for name, m in result.methods.items():
        against = [str(versus[name]) if name in versus else ""] if versus else []
        ece = result.calibration[name]["ece"] if name in result.calibration else None
        figures = (f"{m[k]:.4f}" for k in ("precision", "recall", "f1"))
        table.add_row(name, *figures, "" if ece is None else f"{ece:.4f}", *against)
    if result.calibration:
        table.caption = "ECE: expected calibration error of the methods' probabilities (p ≥ 0.1, ten bins)"
    return table


def days_table(result: dict[str, Any]) -> Table:
    """The closed loop per day: the robot's switches, those undone, the household's, fights."""
    table = Table(
        title=f"{result['home']} with a household of {result['truth']}'s wishes", title_justify="left"
    )
    for col in ("day", "robot's switches", "undone", "household's own", "fights"):
        table.add_column(col, justify="right")
    for d in result["days"]:
        table.add_row(
            *(str(d[k]) for k in ("day", "robot_switches", "reversed", "household_switches", "fights"))
        )
    return table


#: the columns of what went wrong: per device, and per service (key, heading)
DEVICE_FAULTS = (
    ("robot_switches", "robot's"),
    ("undone", "undone"),
    ("missed", "by hand"),
    ("fights", "fights"),
)
SERVICE_FAULTS = (("done", "done"), ("wrong", "wrong"), ("missed", "missed"), ("fights", "fights"))
#: what the columns say, under each table
FAULTS_NOTES = {
    "device": "robot's: its switches; undone: of those, switched back by the household; "
    "by hand: the household's switches the robot should have made",
    "service": "done: by the robot; wrong: done and undone by the household; "
    "missed: done by the household by hand instead",
}


def faults_tables(result: dict[str, Any]) -> list[Table]:
    """What went wrong in the closed loop: the devices, then the services, with a switch undone,
    missed or fought over, the most first (none where nothing went wrong)."""
    tables = []
    for key, first, columns, wrong in (
        ("devices", "device", DEVICE_FAULTS, ("undone", "missed", "fights")),
        ("services", "service", SERVICE_FAULTS, ("wrong", "missed", "fights")),
    ):
        rows = worst(result[key], wrong)
        if not rows:
            continue
        table = Table(
            title=f"What went wrong, per {first}",
            title_justify="left",
            caption=FAULTS_NOTES[first],
            caption_justify="left",
        )
        table.add_column(first)
        for _, heading in columns:
            table.add_column(heading, justify="right")
        for name, row in rows:
            table.add_row(name, *(str(row[k]) for k, _ in columns))
        tables.append(table)
    return tables
