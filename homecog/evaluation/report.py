"""The evaluation report: a Markdown file with charts (methods, beside the paper's Table 9 on
the paper's own home; a per-service heat map; the learning curve under corrections)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from homecog.home.model import Home

#: The paper's Table 9 (%): precision, recall, F.
PAPER_TABLE9 = {"Kmeans (paper)": (88.66, 84.57, 86.57), "Sarsa+IHDR (paper)": (98.21, 90.26, 94.07)}


def is_paper_experiment(home: Home, truth: Home) -> bool:
    """Whether figures of ``home`` against ``truth`` stand beside the paper's Table 9: the robot
    learns the built-in ``paper`` home (its content, whatever the file's name or floor plan) and
    is measured against that home's own rules, as the paper measured its robot.

    >>> from homecog.home import load_home
    >>> paper, ann = load_home("paper"), load_home("paper_ann")
    >>> is_paper_experiment(paper, paper), is_paper_experiment(paper, ann), is_paper_experiment(ann, ann)
    (True, False, False)
    """
    from homecog.home import load_home

    paper = load_home("paper").content_hash
    return home.content_hash == paper and truth.content_hash == paper


def paper_table9() -> dict[str, dict[str, float]]:
    """The paper's Table 9 as fractions, as the JSON of ``eval`` gives it."""
    return {
        name: {"precision": round(p / 100, 6), "recall": round(r / 100, 6), "f1": round(f / 100, 6)}
        for name, (p, r, f) in PAPER_TABLE9.items()
    }


#: The heading of multi's lead over a method, and what it means.
VERSUS = "multi − it [95 %]"
VERSUS_NOTE = (
    "multi − it: multi's F1 minus the method's, with a 95 % paired bootstrap interval over the "
    "{over}; an interval that holds 0 cannot tell the two apart (none under 20 {over})."
)


def _lead(result: dict[str, Any], name: str) -> str:
    """A method's cell of the VERSUS column: `` +0.021 [-0.010, +0.052] |``, or empty."""
    d = result.get("multi_minus", {}).get(name)
    if not d:
        return " |"
    if d["low"] is None:
        return f" {d['difference']:+.3f} [too few events] |"
    return f" {d['difference']:+.3f} [{d['low']:+.3f}, {d['high']:+.3f}] |"


def _methods_table(
    result: dict[str, Any], columns: list[str], cells: Callable[[dict[str, Any]], str]
) -> list[str]:
    """The Markdown table of every method's ``cells`` under ``columns``, and multi's lead over
    it where the result has one."""
    versus = "multi_minus" in result
    head = ["method", *columns, *([VERSUS] if versus else [])]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, m in result["methods"].items():
        lines.append(f"| {name} | {cells(m)} |" + (_lead(result, name) if versus else ""))
    return lines


def pyplot() -> Any:
    """matplotlib's pyplot, drawing off screen."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_chart(fig: Any, path: Path) -> Path:
    """Lay a figure out, write it as a PNG and close it; the path."""
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    pyplot().close(fig)
    return path


def methods_chart(report: dict[str, Any], path: Path) -> Path:
    """Grouped bars of precision, recall and F1 per method (beside the paper's Table 9 where the
    report has it)."""
    plt = pyplot()
    rows = {
        name: (m["precision"] * 100, m["recall"] * 100, m["f1"] * 100)
        for name, m in report["methods"].items()
    }
    if "paper_table9" in report:
        rows |= PAPER_TABLE9
    fig, ax = plt.subplots(figsize=(9, 4.2))
    width = 0.26
    for i, (label, color) in enumerate([("precision", "#4C72B0"), ("recall", "#55A868"), ("F1", "#C44E52")]):
        xs = [k + (i - 1) * width for k in range(len(rows))]
        bars = ax.bar(xs, [v[i] for v in rows.values()], width, label=label, color=color)
        ax.bar_label(bars, fmt="%.1f", fontsize=7, padding=1)
    ax.set_xticks(range(len(rows)), list(rows), rotation=15)
    ax.set_ylim(min(50, min(min(v) for v in rows.values()) - 5), 112)
    ax.set_ylabel("%")
    ax.set_title(f"{report['home']}: {report['scenarios']:,} scenarios, truth {report['truth']}")
    ax.legend(loc="upper center", ncol=3, fontsize=8, frameon=False)
    return save_chart(fig, path)


def heatmap(report: dict[str, Any], path: Path) -> Path:
    """F1 per service (rows) and method (columns)."""
    plt = pyplot()
    methods = list(report["methods"])
    services = list(next(iter(report["methods"].values()))["per_service"])
    values = [[report["methods"][m]["per_service"][s]["f1"] for m in methods] for s in services]
    fig, ax = plt.subplots(figsize=(1.6 + 1.1 * len(methods), 0.32 * len(services) + 1.2))
    im = ax.imshow(values, cmap="RdYlGn", vmin=0, vmax=1, aspect="auto")
    ax.set_xticks(range(len(methods)), methods)
    ax.set_yticks(range(len(services)), services, fontsize=8)
    for i, row in enumerate(values):
        for j, v in enumerate(row):
            ax.text(j, i, f"{v:.2f}", ha="center", va="center", fontsize=7)
    fig.colorbar(im, ax=ax, label="F1")
    ax.set_title("F1 per service")
    return save_chart(fig, path)


def curve_chart(curve: list[dict[str, float]], path: Path) -> Path:
    plt = pyplot()
    xs = [c["corrections"] for c in curve]
    fig, ax = plt.subplots(figsize=(7, 3.6))
    for key, color in (("precision", "#4C72B0"), ("recall", "#55A868"), ("f1", "#C44E52")):
        ax.plot(xs, [c[key] * 100 for c in curve], marker="o", markersize=3, label=key, color=color)
    ax.set_xlabel("corrections by the user")
    ax.set_ylabel("% on held-out scenarios")
    ax.set_title("The robot's development with use")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return save_chart(fig, path)


def write_report(report: dict[str, Any], folder: Path) -> Path:
    """``folder/report.md`` with its PNG charts; returns the Markdown path."""
    folder.mkdir(parents=True, exist_ok=True)
    methods_chart(report, folder / "methods.png")
    heatmap(report, folder / "per_service.png")
    lines = [
        f"# Evaluation of `{report['home']}`",
        "",
        f"{report['scenarios']:,} scenarios; ground truth from the home `{report['truth']}`. "
        "Micro precision Σ|p∩t|/Σ|p|, recall Σ|p∩t|/Σ|t|, F1, and the exact-match rate; "
        "then the same averaged over scenarios.",
        "",
        *_methods_table(
            report,
            ["precision", "recall", "F1", "exact", "averaged P", "averaged R", "seconds"],
            lambda m: (
                f"{m['precision']:.4f} | {m['recall']:.4f} | {m['f1']:.4f} | {m['exact']:.4f} | "
                f"{m['averaged']['precision']:.4f} | {m['averaged']['recall']:.4f} | {m['seconds']:.2f}"
            ),
        ),
    ]
    versus = "multi_minus" in report
    for name, (p, r, f) in PAPER_TABLE9.items() if "paper_table9" in report else ():
        lines.append(
            f"| {name}, Table 9 | {p / 100:.4f} | {r / 100:.4f} | {f / 100:.4f} | | | | |"
            + (" |" if versus else "")
        )
    if versus:
        lines += ["", VERSUS_NOTE.format(over="scenarios")]
    lines += ["", "![methods](methods.png)", "", "## Per service", "", "![per service](per_service.png)", ""]
    if "curve" in report:
        curve_chart(report["curve"], folder / "curve.png")
        lines += [
            "## Development with use",
            "",
            "A simulated user whose wishes are the truth home corrects the robot after each fresh "
            "scenario; figures are on the held-out scenarios above.",
            "",
            "| corrections | precision | recall | F1 |",
            "|---|---|---|---|",
        ]
        lines += [
            f"| {c['corrections']} | {c['precision']:.4f} | {c['recall']:.4f} | {c['f1']:.4f} |"
            for c in report["curve"]
        ]
        lines += ["", "![curve](curve.png)", ""]
    path = folder / "report.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def running_chart(result: dict[str, Any], path: Path) -> Path:
    """The running F1 of every method over the stream."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 3.6))
    for name, series in result["running"].items():
        if series:
            ax.plot([r[0] for r in series], [r[3] * 100 for r in series], label=name)
    ax.set_xlabel("events")
    ax.set_ylabel("running F1 (%)")
    ax.set_title(f"Prequential replay of {result['events']:,} events")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return save_chart(fig, path)


def write_replay_report(result: dict[str, Any], folder: Path, title: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    running_chart(result, folder / "running.png")
    lines = [
        f"# Replay of {title}",
        "",
        f"{result['events']:,} events, each predicted before it was learned.",
        "",
        *_methods_table(
            result,
            ["precision", "recall", "F1"],
            lambda m: f"{m['precision']:.4f} | {m['recall']:.4f} | {m['f1']:.4f}",
        ),
    ]
    if "multi_minus" in result:
        lines += ["", VERSUS_NOTE.format(over="events")]
    lines += ["", "![running](running.png)", ""]
    path = folder / "replay.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
