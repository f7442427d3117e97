"""The closed loop's report (``homecog eval --days N --report DIR``): a chart of the robot's and
the household's switches per day, and a Markdown table of the days."""

from __future__ import annotations

from pathlib import Path
from typing import Any

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
    ]
    path = folder / "household.md"
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


def _row(d: dict[str, Any]) -> str:
    cells = (d["day"], d["robot_switches"], d["reversed"], d["household_switches"], d["fights"])
    return "| " + " | ".join(str(c) for c in cells) + " |"
