"""Homes of any size for the scale benchmark: ``rooms`` rooms of 6 devices each.

Written from the home file reference alone, in the paper's spirit: every room has a ceiling light, a desk
lamp (switched by hand), a curtain, a window, an air conditioner and a TV, each with a service
each way; the user is in one of the rooms (``location`` has one value per room), and the
comfort rules of a room's devices ask where the user is, what they do, the time, the
temperature and the daylight. Prohibited rules tie each room's window and AC (never cool
through an open window, never open it while the AC runs), so a room has five independent
groups. A floor plan lays the rooms out in a grid with doors between neighbours.

    python benchmarks/homes.py 8 > rooms8.yaml     # 48 devices
"""

from __future__ import annotations

import math
import sys

DEVICES = ("light", "lamp", "curtain", "window", "ac", "tv")
ROOM_W, ROOM_H = 5.0, 4.0


def _room(i: int) -> str:
    return f"room{i + 1}"


def home_text(rooms: int, name: str | None = None) -> str:
    """The YAML of a home with ``rooms`` rooms (6 devices each)."""
    if rooms < 1:
        raise ValueError("at least one room")
    names = [_room(i) for i in range(rooms)]
    out = [
        f"name: {name or f'rooms{rooms}'}",
        f"description: {rooms} rooms of 6 devices ({6 * rooms} devices), generated for the scale benchmark.",
        "context:",
        "  time: {kind: clock, bins: {early_morning: [7, 8], morning: [8, 11.5], noon: [11.5, 13.5],"
        " afternoon: [13.5, 18], evening: [18, 21], night: [21, 7]}}",
        '  temperature: {kind: numeric, unit: "°C", bins: {cold: [-.inf, 25], suitable: [25, 30],'
        " hot: [30, .inf]}}",
        "  illumination: {kind: numeric, unit: lx, bins: {light: [550, .inf], suitable: [100, 550],"
        " dark: [0, 100]}}",
        f"  location: {{kind: categorical, values: [{', '.join(names)}]}}",
        "  posture: {kind: categorical, values: [sit, lie, walk]}",
        "  behavior: {kind: categorical, values: [read, watch_tv, sleep, eat]}",
        "devices:",
    ]
    for r in names:
        for d in DEVICES:
            out.append(f"  {d}_{r}: {{room: {r}, iot: {'false' if d == 'lamp' else 'true'}}}")
    out.append("services:")
    verbs = {
        "light": ("TurnOnLight", "TurnOffLight"),
        "lamp": ("TurnOnLamp", "TurnOffLamp"),
        "curtain": ("OpenCurtain", "CloseCurtain"),
        "window": ("OpenWindow", "CloseWindow"),
        "ac": ("TurnOnAC", "TurnOffAC"),
        "tv": ("TurnOnTV", "TurnOffTV"),
    }
    for r in names:
        for d in DEVICES:
            on, off = verbs[d]
            out.append(f"  {on}_{r}: {{category: switch_on, set: {{{d}_{r}: on}}}}")
            out.append(f"  {off}_{r}: {{category: switch_off, set: {{{d}_{r}: off}}}}")
    out += [
        "  SendDrinks: {category: interaction}",
        "  CallToWakeup: {category: interaction}",
        "  RemindToSleep: {category: interaction}",
        "  ChargeItSelf: {category: maintenance}",
        "comfort:",
    ]
    for r in names:
        out += [
            f"  light_{r}:",
            "    - {when: {behavior: [sleep]}, want: off}",
            f"    - {{when: {{location: [{r}], time: [evening, night]}}, want: on}}",
            f"    - {{when: {{location: [{r}], illumination: [dark]}}, want: on}}",
            "    - {want: off}",
            f"  lamp_{r}:",
            f"    - {{when: {{location: [{r}], behavior: [read]}}, want: on}}",
            "    - {want: off}",
            f"  curtain_{r}:",
            "    - {when: {time: [night]}, want: off}",
            f"    - {{when: {{location: [{r}], behavior: [sleep]}}, want: off}}",
            f"    - {{when: {{location: [{r}], behavior: [watch_tv], illumination: [light]}}, want: off}}",
            "    - {want: on}",
            f"  window_{r}:",
            "    - {when: {time: [night]}, want: off}",
            "    - {when: {temperature: [hot]}, want: off}",
            f"    - {{when: {{location: [{r}], behavior: [sleep]}}, want: off}}",
            "    - {want: on}",
            f"  ac_{r}:",
            f"    - {{when: {{location: [{r}], temperature: [hot]}}, want: on}}",
            "    - {want: off}",
            f"  tv_{r}:",
            f"    - {{when: {{location: [{r}], behavior: [watch_tv]}}, want: on}}",
            "    - {want: off}",
        ]
    out += [
        "needs:",
        "  SendDrinks:",
        "    - {when: {behavior: [read, watch_tv, eat]}}",
        "    - {when: {time: [early_morning], behavior: [sleep]}}",
        "  CallToWakeup:",
        "    - {when: {time: [early_morning], behavior: [sleep]}}",
        "  RemindToSleep:",
        "    - {when: {time: [night], behavior: [read, watch_tv, eat]}}",
        "prohibited:",
        "  CallToWakeup: [{when: {time: [night]}}]",
        "  RemindToSleep: [{when: {behavior: [sleep]}}]",
    ]
    for r in names:
        out += [
            f"  OpenCurtain_{r}: [{{when: {{time: [night]}}}}]",
            f"  OpenWindow_{r}: [{{when: {{ac_{r}: [on]}}}}]",
            f"  TurnOnAC_{r}: [{{when: {{window_{r}: [on]}}}}]",
            f"  TurnOnTV_{r}: [{{when: {{behavior: [sleep]}}}}]",
        ]
    out += _layout(names)
    return "\n".join(out) + "\n"


def _layout(names: list[str]) -> list[str]:
    cols = math.ceil(math.sqrt(len(names)))
    rows = math.ceil(len(names) / cols)
    width, height = cols * ROOM_W, rows * ROOM_H
    out = ["layout:", f"  size: [{width:g}, {height:g}]", "  rooms:"]
    cell = {}
    for i, r in enumerate(names):
        x, y = (i % cols) * ROOM_W, (i // cols) * ROOM_H
        cell[i] = (x, y)
        out.append(f"    {r}: [{x:g}, {y:g}, {x + ROOM_W:g}, {y + ROOM_H:g}]")
    walls, doors = [], []
    for c in range(1, cols):  # vertical walls, a door in every room-to-room stretch
        x = c * ROOM_W
        walls.append(f"    - [{x:g}, 0, {x:g}, {height:g}]")
        for row in range(rows):
            left, right = row * cols + c - 1, row * cols + c
            if right < len(names):
                y = row * ROOM_H
                doors.append(f"    - [{x:g}, {y + 1.5:g}, {x:g}, {y + 2.5:g}]")
            elif left < len(names):  # no room to the right: the wall still closes the row
                pass
    for row in range(1, rows):  # horizontal walls, a door to the room below
        y = row * ROOM_H
        walls.append(f"    - [0, {y:g}, {width:g}, {y:g}]")
        for c in range(cols):
            if row * cols + c < len(names):
                x = c * ROOM_W
                doors.append(f"    - [{x + 2:g}, {y:g}, {x + 3:g}, {y:g}]")
    out += ["  walls:", *walls] if walls else []
    out += ["  doors:", *doors] if doors else []
    out.append("  places:")
    x0, y0 = cell[0]
    out.append(f"    dispenser: [{x0 + 4.4:g}, {y0 + 0.6:g}]")
    out.append(f"    charger: [{x0 + 0.6:g}, {y0 + 0.6:g}]")
    out += [
        "  objects: {cup: dispenser}",
        "  robot: charger",
        "  errands:",
        "    SendDrinks: {bring: cup, pour: true}",
        "    ChargeItSelf: {dock: charger}",
    ]
    return out


if __name__ == "__main__":
    sys.stdout.write(home_text(int(sys.argv[1]) if len(sys.argv) > 1 else 8))


def coupled_home_text(n: int) -> str:
    """A home whose one service ties ``n`` devices into one group (2^n device states)."""
    devices = ", ".join(f"d{i}: {{}}" for i in range(n))
    every = ", ".join(f"d{i}: off" for i in range(n))
    comfort = "\n".join(f"  d{i}: [{{want: off}}]" for i in range(n))
    services = "\n".join(f"  On{i}: {{category: on, set: {{d{i}: on}}}}" for i in range(n))
    return (
        f"name: coupled\ncontext: {{who: {{kind: categorical, values: [a, b]}}}}\ndevices: {{{devices}}}\n"
        f"services:\n  AllOff: {{category: off, set: {{{every}}}}}\n{services}\ncomfort:\n{comfort}\n"
    )
