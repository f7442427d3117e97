"""Homes with scenes for the scale benchmark: the rooms of ``homes.py``, and what people add.

Every room gets a scene that switches its ceiling light, its desk lamp (switched by hand) and
its TV off together (``Quiet_<room>``), and the home three whole-home scenes: all lights off,
good night (lights and TVs off, curtains closed) and leaving (lights, TVs and air conditioners
off). Each sets its devices as their own services do, so it ties nothing; the robot takes it
where it does the work of two services or more.

    python benchmarks/scene_homes.py 8 > scenes8.yaml     # 48 devices, 11 scenes
"""

from __future__ import annotations

import sys

from homes import home_text


def _rooms(rooms: int) -> list[str]:
    return [f"room{i + 1}" for i in range(rooms)]


def scene_home_text(rooms: int, name: str | None = None) -> str:
    """The YAML of a home of ``rooms`` rooms of 6 devices with a scene per room and three
    whole-home scenes."""
    names = _rooms(rooms)
    scenes = [
        f"  Quiet_{r}: {{category: scene, set: {{light_{r}: off, lamp_{r}: off, tv_{r}: off}}}}"
        for r in names
    ]

    def every(devices: tuple[str, ...], state: str = "off") -> str:
        return ", ".join(f"{d}_{r}: {state}" for r in names for d in devices)

    scenes += [
        f"  AllLightsOff: {{category: scene, set: {{{every(('light', 'lamp'))}}}}}",
        f"  GoodNight: {{category: scene, set: {{{every(('light', 'lamp', 'tv', 'curtain'))}}}}}",
        f"  Leaving: {{category: scene, set: {{{every(('light', 'lamp', 'tv', 'ac'))}}}}}",
    ]
    text = home_text(rooms, name=name or f"scenes{rooms}")
    text = text.replace(
        f"description: {rooms} rooms of 6 devices",
        f"description: {rooms} rooms of 6 devices, a scene per room and three for the whole home,",
        1,
    )
    return text.replace(
        "  SendDrinks: {category: interaction}\n",
        "\n".join(scenes) + "\n  SendDrinks: {category: interaction}\n",
        1,
    )


if __name__ == "__main__":
    sys.stdout.write(scene_home_text(int(sys.argv[1]) if len(sys.argv) > 1 else 8))
