"""A floor plan the robot can live in, checked when a home is loaded: where the user can be, the
devices' rooms, places clear of the walls, and everywhere the user or an errand can be reachable
from the robot's start; each refusal one line with the file, the key path and what to change, at
``home check`` and at every command."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from homecog.errors import HomeFileError
from homecog.home import load_home
from homecog.home.floor import free_floor
from homecog.home.homes import __file__ as homes_init
from homecog.simulation.grid import occupancy_grid

PAPER = (Path(homes_init).parent / "paper.yaml").read_text()


def _home(tmp_path: Path, old: str, new: str) -> Path:
    assert old in PAPER
    path = tmp_path / "flat.yaml"
    path.write_text(PAPER.replace(old, new))
    return path


CASES = {
    "a location that is no place": (
        "values: [table, sofa, bed, dining_table]",
        "values: [table, sofa, bed, dining_table, balcony]",
        "context.location.values[4]: 'balcony' is neither a place nor a room of the layout; add it to "
        "layout.places or layout.rooms, or rename the value",
    ),
    "a device in a room the layout lacks": (
        "tv_bedroom: {room: bedroom, iot: true}",
        "tv_bedroom: {room: attic, iot: true}",
        "devices.tv_bedroom.room: room 'attic' is not a room of the layout (layout.rooms: living_room, "
        "bedroom, dining_area, kitchen); add it there or change the device's room",
    ),
    "a room without a door": (
        "    - [6, 3.6, 6, 4.6]          # living room <-> bedroom\n",
        "",
        "context.location.values[2]: 'bed' (the user can be there) cannot be reached from the robot's "
        "start 'charger'; room 'bedroom' has no door: add one to layout.doors on a wall of it",
    ),
    "a place walled off inside its room": (
        "    - [5, 5, 5, 8]              # dining area | kitchen\n",
        "    - [5, 5, 5, 8]              # dining area | kitchen\n    - [8.8, 6.8, 10, 6.8]\n"
        "    - [8.8, 6.8, 8.8, 8]\n",
        "layout.objects.cup: 'dispenser' (the cup is fetched from there) cannot be reached from the "
        "robot's start 'charger'; walls close it off: add a door to layout.doors on the way there",
    ),
    "a place too close to a wall": (
        "charger: [0.5, 4.4]",
        "charger: [0.5, 4.85]",
        "layout.places.charger: (0.5, 4.85) is 0.15 m from a wall; the robot (radius 0.2 m) needs 0.25 m: "
        "move the place away from the wall",
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_floor_plan_the_robot_cannot_live_in_is_refused_at_load(tmp_path, case):
    old, new, message = CASES[case]
    path = _home(tmp_path, old, new)
    with pytest.raises(HomeFileError) as e:
        load_home(path)
    assert str(e.value) == f"{path}: {message}"


@pytest.mark.parametrize("command", [["home", "check"], ["plan", "--services", "SendDrinks", "--home"]])
def test_the_refusal_is_one_line_at_home_check_and_every_command(tmp_path, command):
    old, new, message = CASES["a room without a door"]
    path = _home(tmp_path, old, new)
    proc = subprocess.run(
        [sys.executable, "-m", "homecog.cli.main", *command, str(path)], capture_output=True, text=True
    )
    assert proc.returncode == 2
    assert proc.stderr == f"homecog: error: {path}: {message}\n"


def test_the_simulator_plans_on_the_floor_the_check_read():
    layout = load_home("paper").layout
    assert (occupancy_grid(layout).occupied == ~free_floor(layout)).all()
    # every place of the paper home keeps the robot's clearance, and the free floor is one piece
    free = free_floor(layout)
    assert 0.6 < free.mean() < 0.95
