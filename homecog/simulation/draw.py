"""The robot's trajectory on the floor plan as a PNG, like the paper's Fig. 15.

Drawn with matplotlib's object interface and the Agg canvas, never pyplot, so it needs no
display and leaves the process's matplotlib backend alone.

>>> import tempfile, pathlib
>>> from homecog.home import load_home
>>> from homecog.simulation import simulate
>>> home = load_home("paper")
>>> result = simulate(home, [("move", "charger", "bed"), ("speak", "Good morning")])
>>> path = pathlib.Path(tempfile.mkdtemp()) / "run.png"
>>> draw_trajectory(home.layout, result, path) == path and path.read_bytes()[:4] == b"\\x89PNG"
True
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle
from matplotlib.transforms import ScaledTranslation

from homecog.home.layout import WALL_THICKNESS, Layout
from homecog.simulation.simulate import SimulationResult

_ROOM_COLOURS = ["#e8f1fa", "#fbeee0", "#e9f5e6", "#f3e8f5", "#fdf7dc", "#e6f4f4"]
_WALL = "#2b2b2b"
_PLACE = "#555555"
_ACTION = "#c0392b"
#: Inches of margin around what is drawn, in the PNG.
PAD = 0.15
_LABEL_BOX = {"boxstyle": "round,pad=0.15", "facecolor": "white", "edgecolor": "none", "alpha": 0.75}


def draw_trajectory(layout: Layout, result: SimulationResult, path: str | Path, *, dpi: int = 150) -> Path:
    """Write the floor plan, the places, the robot's path coloured by time and the numbered
    spots where it worked to the PNG file ``path`` (folders made as needed), cropped to what
    is drawn and :data:`PAD` inches around it; returns the path."""
    path = Path(path)
    fig = trajectory_figure(layout, result)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi, bbox_inches="tight", pad_inches=PAD)
    return path


def trajectory_figure(layout: Layout, result: SimulationResult) -> Figure:
    """The figure :func:`draw_trajectory` writes (its one axes in metres, the colour bar's after it)."""
    w, h = layout.size
    fig = Figure(figsize=(min(16.0, 0.9 * w + 2.5), min(14.0, 0.9 * h)))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()

    for i, (name, (x0, y0, x1, y1)) in enumerate(layout.rooms.items()):
        colour = _ROOM_COLOURS[i % len(_ROOM_COLOURS)]
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, facecolor=colour, edgecolor="none", zorder=0))
        room = {"ha": "left", "va": "top", "fontsize": 9, "style": "italic", "color": "#55606b"}
        ax.text(x0 + 0.15, y1 - 0.15, name.replace("_", " "), zorder=1, **room)

    half = WALL_THICKNESS / 2
    for x0, y0, x1, y1 in layout.solid_walls():
        corner = (min(x0, x1) - half, min(y0, y1) - half)
        width, height = abs(x1 - x0) + 2 * half, abs(y1 - y0) + 2 * half
        ax.add_patch(Rectangle(corner, width, height, facecolor=_WALL, edgecolor="none", zorder=2))
    for x0, y0, x1, y1 in layout.doors:  # a thin dotted threshold, so a door reads as a door
        ax.plot([x0, x1], [y0, y1], color="#8a96a3", linestyle=(0, (1, 2)), linewidth=1, zorder=2)

    for name, (x, y) in layout.places.items():
        ax.plot(x, y, marker="D", markersize=4.5, color=_PLACE, zorder=5)
        label = {"ha": "center", "va": "top", "fontsize": 8, "color": _PLACE, "bbox": _LABEL_BOX}
        ax.annotate(
            name.replace("_", " "), (x, y), xytext=(0, -7), textcoords="offset points", zorder=5, **label
        )

    t, xy = result.trajectory[:, 0], result.trajectory[:, 1:3]
    segments = np.stack([xy[:-1], xy[1:]], axis=1)
    moving = np.hypot(*(segments[:, 1] - segments[:, 0]).T) > 0
    lines = LineCollection(segments[moving], cmap="viridis", linewidths=2.5, capstyle="round", zorder=3)
    lines.set_array(t[1:][moving])
    lines.set_clim(0.0, max(result.seconds, 1e-9))
    ax.add_collection(lines)
    fig.colorbar(lines, ax=ax, shrink=0.8, pad=0.02).set_label("time (s)")

    # numbered spots where the robot worked, one label per spot ("2–3" for pick and pour)
    spots: dict[tuple[float, float], list[int]] = {}
    caption = []
    for row in result.timeline:
        if row["action"][0] == "move":
            continue
        k = int(np.searchsorted(t, row["start"], side="right")) - 1
        spots.setdefault((round(float(xy[k, 0]), 3), round(float(xy[k, 1]), 3)), []).append(row["index"])
        caption.append(f"{row['index']} {' '.join(row['action'])}")
    for (x, y), numbers in spots.items():
        ax.plot(x, y, marker="o", markersize=10, color=_ACTION, markeredgecolor="white", zorder=7)
        label = {"fontsize": 9, "fontweight": "bold", "color": _ACTION, "bbox": _LABEL_BOX}
        ax.annotate(_numbers(numbers), (x, y), xytext=(8, 6), textcoords="offset points", zorder=8, **label)

    # start and end above the spots: a run often ends where it began (back on the charger)
    ax.plot(
        *xy[0],
        marker="o",
        markersize=17,
        markerfacecolor="none",
        markeredgecolor="#27ae60",
        markeredgewidth=2.5,
        linestyle="none",
        zorder=9,
        label="start",
    )
    ax.plot(*xy[-1], marker="s", markersize=6, color="#1f2d3a", linestyle="none", zorder=10, label="end")
    if spots:
        ax.plot([], [], marker="o", markersize=8, color=_ACTION, linestyle="none", label="action (plan step)")

    ax.set_xlim(-0.3, w + 0.3)
    ax.set_ylim(-0.3, h + 0.3)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    # below the tick labels and the x label, whatever the figure's size: offsets in points
    below = ax.transAxes + ScaledTranslation(0, -34 / 72, fig.dpi_scale_trans)
    legend = {"ncol": 3, "frameon": False, "fontsize": 9, "borderaxespad": 0}
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, 0), bbox_transform=below, **legend)
    ax.set_title(
        f"{len(result.actions)} actions in {result.seconds:.1f} s, {result.distance_m:.1f} m driven",
        fontsize=11,
    )
    if caption:
        text = {"ha": "center", "va": "top", "fontsize": 8, "color": "#444444"}
        ax.annotate(
            _lines(caption, 110),
            (0.5, 0),
            xycoords="axes fraction",
            xytext=(0, -58),
            textcoords="offset points",
            **text,
        )
    return fig


def _numbers(numbers: list[int]) -> str:
    """``[2, 3, 4, 7]`` -> ``2–4, 7``."""
    runs: list[list[int]] = []
    for n in numbers:
        if runs and n == runs[-1][-1] + 1:
            runs[-1].append(n)
        else:
            runs.append([n])
    return ", ".join(str(r[0]) if len(r) == 1 else f"{r[0]}–{r[-1]}" for r in runs)


def _lines(items: list[str], width: int) -> str:
    """Items side by side, a new line where the next would pass ``width`` characters."""
    lines = [""]
    for item in items:
        if lines[-1] and len(lines[-1]) + 3 + len(item) > width:
            lines.append("")
        lines[-1] += ("   " if lines[-1] else "") + item
    return "\n".join(lines)
