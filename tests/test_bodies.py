"""The robot's body as one interface, and what needs no pyrobosim: the world written for it, the
commands' checks, what a user without the ``[pyrobosim]`` extra is told, and Home Assistant's
discovery configs as they are published (tests/test_pyrobosim.py and tests/test_ha_discovery.py
run them against pyrobosim and a real Home Assistant)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from homecog.cli.main import main
from homecog.context.ha_discovery import discovery_configs, services_state
from homecog.home import Home
from homecog.planning import act, initial_state
from homecog.simulation.body import SimulatedRobot
from homecog.simulation.interface import ACTIONS, Body, Outcome
from homecog.simulation.pyrobosim_world import pyrobosim_world


def test_every_action_of_the_domain_is_a_method_of_the_body(paper: Home) -> None:
    body = SimulatedRobot(paper)
    assert set(body.domain.actions) == set(ACTIONS) == set(body.commands())
    assert all(callable(getattr(Body, name)) for name in ACTIONS)
    assert "_act" in Body.__abstractmethods__  # which every action's method calls


def test_the_builtin_body_answers_and_never_raises(paper: Home) -> None:
    body = SimulatedRobot(paper, initial_state(paper, user="sofa"))
    assert body.speak("hello") == Outcome(True, "")
    assert body.hand_over("cup", "user") == Outcome(False, "the robot holds None, not 'cup'")
    assert body.switch_iot("lamp", "on") == Outcome(False, "'lamp' has no IoT switch")
    assert body.switch_by_hand("sofa", "on").message.startswith("unknown device 'sofa'")
    assert body.carry_out(()) == Outcome(False, "no such action (); a body does " + ", ".join(ACTIONS))
    assert [a[0] for a in body.result().actions] == ["speak"]  # only what was done is in the run


def test_a_switch_the_home_refuses_fails_the_action_and_acting_replans(paper: Home) -> None:
    calls = []

    def switch(device: str, on: bool) -> None:
        calls.append((device, on))
        if len(calls) == 1:
            raise ConnectionError("the broker is gone")

    body = SimulatedRobot(paper, initial_state(paper, user="sofa"), switch=switch)
    result = act(body.domain, initial_state(paper, user="sofa"), [("TurnOnLamp",)], body.commands())
    assert [str(f) for f in result.failures] == [
        "plan 1: ('switch_by_hand', 'lamp', 'on') failed: ConnectionError: the broker is gone"
    ]
    assert result.achieved and calls == [("lamp", True), ("lamp", True)]
    assert body.result().actions == [
        ("move", "charger", "lamp"),
        ("switch_by_hand", "lamp", "on"),  # replanned at the lamp: no move from the lamp to itself
    ]


def test_the_world_for_pyrobosim_is_the_floor_plan(paper: Home, tmp_path: Path) -> None:
    world = pyrobosim_world(paper)
    files = world.write(tmp_path / "w.yaml")
    data = yaml.safe_load(files[0].read_text())
    assert data["metadata"] == {"locations": "$PWD/w_locations.yaml", "objects": "$PWD/w_objects.yaml"}
    assert yaml.safe_load(files[1].read_text()) == world.locations
    rooms = {r["name"]: r["footprint"]["coords"] for r in data["rooms"]}
    assert rooms["kitchen"] == [[5.05, 5.05], [9.95, 5.05], [9.95, 7.95], [5.05, 7.95]]
    hall = data["hallways"][0]
    assert (hall["width"], hall["conn_points"]) == (
        1.0,
        [[5.45, 4.1], [6.55, 4.1]],
    )  # through [6, 3.6, 6, 4.6]
    assert [loc["name"] for loc in data["locations"] if loc["is_charger"]] == ["charger"]
    robot = data["robots"][0]
    assert robot["pose"]["position"] == {"x": 0.95, "y": 4.4}  # beside the charger at (0.5, 4.4)
    assert robot["path_planner"] == {
        "type": "astar",
        "grid_resolution": 0.05,
        "compress_path": True,
        "grid_inflation_radius": 0.2,
    }


def test_a_place_in_no_room_is_refused() -> None:
    from homecog.errors import PlanningError
    from homecog.home import load_home_text

    text = (Path(__file__).parent / "homes" / "studio.yaml").read_text() + (
        "layout:\n  size: [8, 4]\n  rooms: {studio: [0, 0, 4, 4]}\n  places: {desk: [1, 1], shed: [6, 2]}\n"
    )
    with pytest.raises(
        PlanningError, match=r"^place 'shed' \(6, 2\) lies in no room; pyrobosim needs a room$"
    ):
        pyrobosim_world(load_home_text(text, "studio.yaml"))


def test_export_refuses_a_home_without_a_floor_plan_and_an_unknown_planner(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    studio = str(Path(__file__).parent / "homes" / "studio.yaml")
    assert main(["export", "pyrobosim", "--home", studio, "--out", str(tmp_path / "w.yaml")]) == 2
    assert capsys.readouterr().err == (
        "homecog: error: home 'studio' has no layout; a pyrobosim world needs the floor plan\n"
    )
    assert main(["export", "pyrobosim", "--out", str(tmp_path / "w.yaml"), "--planner", "dijkstra"]) == 2
    assert capsys.readouterr().err == (
        "homecog: error: --planner: unknown path planner 'dijkstra'; "
        "expected one of astar, rrt, prm, world_graph\n"
    )
    assert not (tmp_path / "w.yaml").exists()


def test_without_the_extra_one_line_says_how_to_install_it() -> None:
    """pyrobosim made unimportable, as where the extra is not installed: simulate and up say so
    in one line, exit 2, and up says it before any training."""
    script = (
        "import sys; sys.modules['pyrobosim'] = None\n"  # import pyrobosim now raises ImportError
        "from homecog.cli.main import main\n"
        "sys.exit(main(sys.argv[1:]))\n"
    )
    hint = (
        "homecog: error: the pyrobosim body needs the [pyrobosim] extra, and pyrobosim cannot be imported: "
        "pip install 'homecog[pyrobosim]'\n"
    )
    for args in (
        ["simulate", "--services", "ChargeItSelf", "--robot", "pyrobosim"],
        ["up", "--robot", "pyrobosim", "--port", "1"],
    ):
        done = subprocess.run(
            [sys.executable, "-c", script, *args], capture_output=True, text=True, timeout=60
        )
        assert (done.returncode, done.stderr, done.stdout) == (2, hint, "")


def test_robot_options_are_checked_before_any_work(capsys: pytest.CaptureFixture[str]) -> None:
    for args, error in [
        (
            ["simulate", "--services", "ChargeItSelf", "--robot", "roomba"],
            "--robot: unknown body 'roomba'; expected one of builtin, pyrobosim",
        ),
        (
            ["simulate", "--services", "ChargeItSelf", "--planner", "rrt"],
            "--planner chooses pyrobosim's path planner; it goes with --robot pyrobosim",
        ),
        (["up", "--robot", "roomba"], "--robot: unknown body 'roomba'; expected one of builtin, pyrobosim"),
        (
            ["up", "--robot", "pyrobosim", "--mqtt", "mqtt://127.0.0.1:1"],
            "--robot pyrobosim is the simulated home's robot; in a home on a broker or Home Assistant "
            "the robot switches by IoT",
        ),
    ]:
        assert main(args) == 2
        assert capsys.readouterr().err == f"homecog: error: {error}\n"


def test_every_discovery_config_has_a_unique_id_a_device_and_availability(paper: Home) -> None:
    configs = discovery_configs(paper, prefix="lab")
    assert len(configs) == 3 + len(paper.devices)
    ids = [c["unique_id"] for c in configs.values()]
    assert len(set(ids)) == len(ids) and all(i.startswith("lab_paper_") for i in ids)
    for topic, config in configs.items():
        component, node, key = topic.split("/")[1:4]
        assert topic == f"homeassistant/{component}/{node}/{key}/config" and node == "lab_paper"
        assert config["unique_id"] == config["object_id"] == f"lab_paper_{key}"
        assert config["device"]["identifiers"] in (["lab_paper_robot"], ["lab_paper_home"])
        assert config["availability_topic"] == "lab/paper/robot/availability"
    lamp = configs["homeassistant/switch/lab_paper/lamp/config"]
    assert (lamp["state_topic"], lamp["command_topic"]) == ("lab/paper/state/lamp", "lab/paper/command/lamp")
    assert lamp["device"]["via_device"] == "lab_paper_robot"


def test_the_services_state_fits_home_assistant() -> None:
    assert services_state(["A" * 300]) == "A" * 254 + "…"


def test_the_main_job_never_imports_pyrobosim() -> None:
    """``homecog up`` and the running robot with homecog's own body start as they did before the
    extra: nothing of pyrobosim (nor what only it brings) is imported."""
    script = (
        "import sys\n"
        "import homecog.cli.main, homecog.robot.runtime, homecog.web.main, homecog.simulation.bodies\n"
        "from homecog.home import load_home\n"
        "from homecog.simulation.bodies import make_body\n"
        "make_body('builtin', load_home('paper'))\n"
        "print(sorted(m for m in ('pyrobosim', 'shapely', 'dash', 'trimesh') if m in sys.modules))\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert (done.returncode, done.stdout) == (0, "[]\n"), done.stderr
