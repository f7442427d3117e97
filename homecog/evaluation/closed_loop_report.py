"""The closed loop's report (``homecog eval --days N --report DIR``): a chart of the robot's and
the household's switches per day, a Markdown table of the days, and what went wrong per device
and per service."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from homecog.evaluation.closed_loop_faults import worst
from homecog.evaluation.report import pyplot, save_chart

COLUMNS = (
    ("robot_switches", "robot's switches", "#4C72B0"),
    ("reversed", "undone by the household", "#C44E52"),
    ("household_switches", "household's own switches", "#55A868"),
    ("fights", "fights", "#000000"),
)


def days_chart(result: dict[str, Any], path: Path) -> Path:
    """Per day: the robot's switches, those undone, the household's own switches, fights."""
    plt = pyplot()
    days = [d["day"] for d in result["days"]]
    fig, ax = plt.subplots(figsize=(8, 3.8))
    for key, label, color in COLUMNS:
        ax.plot(days, [d[key] for d in result["days"]], marker="o", ms=3, label=label, color=color)
    ax.set_xlabel("day")
    ax.set_ylabel("switches a day")
    ax.set_xticks(days)
    ax.set_ylim(bottom=0)
    ax.set_title(f"{result['home']} living with a household of {result['truth']}'s wishes")
    ax.legend(fontsize=8, frameon=False)
    return save_chart(fig, path)


def write_days_report(result: dict[str, Any], folder: Path) -> Path:
    """``household.md`` and ``household.png`` in ``folder``; the Markdown file's path."""
    folder.mkdir(parents=True, exist_ok=True)
    chart = days_chart(result, folder / "household.png")
    s = result["summary"]
    share = s["last3_household_share"]
    lines = [
        f"# {result['home']} and a household of {result['truth']}'s wishes, {len(result['days'])} days",
        "",
        f"![switches per day]({chart.name})",
        "",
        "| day | robot's switches | undone | household's own | fights |",
        "|---:|---:|---:|---:|---:|",
        *(_row(d) for d in result["days"]),
        "",
        "Over the last three days the household switched "
        + (f"{share:.0%} a day of what it switched on day 1" if share is not None else "nothing on day 1")
        + f"; {s['last3_undone_share']:.1%} of the robot's switches were undone; {s['fights']} fights.",
        "",
        *_faults(result),
    ]
    path = folder / "household.md"
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


#: what went wrong, per device and per service: (key, heading, columns as (key, heading))
FAULTS = (
    (
        "devices",
        "device",
        (
            ("robot_switches", "robot's switches"),
            ("undone", "undone by the household"),
            ("missed", "switched by hand instead"),
            ("fights", "fights"),
        ),
    ),
    (
        "services",
        "service",
        (
            ("done", "done by the robot"),
            ("wrong", "wrong (undone)"),
            ("missed", "missed (done by hand)"),
            ("fights", "fights"),
        ),
    ),
)


def _faults(result: dict[str, Any]) -> list[str]:
    """The Markdown tables of what went wrong, per device and per service, the most first."""
    lines = []
    for key, name, columns in FAULTS:
        rows = worst(result[key], [k for k, _ in columns[1:]])
        if not rows:
            continue
        lines += [f"## What went wrong, per {name}", ""]
        lines += ["| " + " | ".join([name, *(h for _, h in columns)]) + " |"]
        lines += ["|---|" + "---:|" * len(columns)]
        lines += ["| " + " | ".join([n, *(str(row[k]) for k, _ in columns)]) + " |" for n, row in rows]
        lines.append("")
    return lines


def _row(d: dict[str, Any]) -> str:
    cells = (d["day"], d["robot_switches"], d["reversed"], d["household_switches"], d["fights"])
    return "| " + " | ".join(str(c) for c in cells) + " |"
