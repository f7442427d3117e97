"""pyrobosim as the robot's body: the home's floor plan exported as a pyrobosim world
and opened by pyrobosim's own loader, the paper's plan carried out there with its path planner,
a failed action planned again, the run reported, drawn and written as a ROS 2 bag as the
built-in body's is, and the same answers from both bodies where an action does not apply.

pyrobosim is the ``[pyrobosim]`` extra (``.ci/pyrobosim.sh`` installs it into the test venv);
where it is missing these tests skip, saying why (what a user without it is told, and what
needs no pyrobosim, is tests/test_bodies.py's).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from rosbags.highlevel import AnyReader

from homecog.cli.main import main
from homecog.home import Home
from homecog.planning import act, initial_state, plan_services
from homecog.robot.plans import plan_request
from homecog.simulation.bag import TOPICS
from homecog.simulation.bodies import carry_out
from homecog.simulation.body import SimulatedRobot
from homecog.simulation.interface import Outcome
from homecog.simulation.pyrobosim_world import nav_poses

pyrobosim = pytest.importorskip(
    "pyrobosim", reason="pyrobosim is not installed (bash .ci/pyrobosim.sh installs the [pyrobosim] extra)"
)
from pyrobosim.core import WorldYamlLoader  # noqa: E402
from pyrobosim.planning.actions import ExecutionOptions  # noqa: E402

from homecog.simulation.pyrobosim_body import PyRoboSimBody  # noqa: E402

SERVICES = ["SendDrinks", "TurnOnLamp", "CloseWindow", "ChargeItSelf"]
EVENING = {"lamp": "off", "window": "on"}  # the devices the plan changes, as they start


@pytest.fixture(scope="module")
def body(paper: Home) -> PyRoboSimBody:
    return PyRoboSimBody(paper)


def evening(paper: Home):
    return initial_state(paper, EVENING, user="sofa")


# -- the world ------------------------------------------------------------------------------------
def test_the_exported_world_has_every_room_place_and_door(paper: Home, tmp_path: Path) -> None:
    assert main(["export", "pyrobosim", "--out", str(tmp_path / "home.yaml"), "--json"]) == 0
    world = WorldYamlLoader().from_file(tmp_path / "home.yaml")  # pyrobosim's own loader
    layout = paper.layout
    assert [r.name for r in world.rooms] == list(layout.rooms)
    assert [loc.name for loc in world.locations] == list(layout.places)
    assert [(o.name, o.parent.name) for o in world.objects] == [("cup", "dispenser_spot")]
    # one hallway per door, joining the rooms on its two sides, as wide as the door
    joined = {(h.room_start.name, h.room_end.name, round(h.width, 6)) for h in world.hallways}
    assert joined == {
        ("living_room", "bedroom", 1.0),
        ("living_room", "dining_area", 1.2),
        ("dining_area", "kitchen", 1.0),
    }
    # each room as the floor plan's rectangle inside half a wall; a place is where the layout has it
    for room in world.rooms:
        x0, y0, x1, y1 = layout.rooms[room.name]
        assert room.polygon.bounds == pytest.approx((x0 + 0.05, y0 + 0.05, x1 - 0.05, y1 - 0.05))
    for loc in world.locations:
        assert (loc.pose.x, loc.pose.y) == layout.places[loc.name]
        assert loc.parent.name == layout.room_at(layout.places[loc.name])
        assert loc.is_charger == (loc.name == "charger")
        assert len(loc.children[0].nav_poses) == len(nav_poses(layout, _rooms(paper), loc.name, 0.2)) > 0
    robot = world.robots[0]
    assert robot.location.name == "charger_spot" and robot.radius == 0.2
    assert type(robot.path_planner).__name__ == "AStarPlanner"


def _rooms(home: Home):
    from homecog.simulation.pyrobosim_world import _rooms

    return _rooms(home.layout)


def test_export_says_what_it_wrote(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "w" / "paper.yaml"
    assert main(["export", "pyrobosim", "--out", str(out), "--planner", "rrt", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["rooms"] == ["living_room", "bedroom", "dining_area", "kitchen"]
    assert data["hallways"] == ["living_room-bedroom", "living_room-dining_area", "dining_area-kitchen"]
    assert data["locations"] == ["sofa", "table", "bed", "dining_table", "dispenser", "charger", "lamp"]
    assert data["objects"] == ["cup"]
    assert data["files"] == [
        str(out),
        str(out.with_name("paper_locations.yaml")),
        str(out.with_name("paper_objects.yaml")),
    ]
    world = WorldYamlLoader().from_file(out)
    assert type(world.robots[0].path_planner).__name__ == "RRTPlanner"


# -- carrying plans out ------------------------------------------------------------------------------
def test_the_paper_plan_is_carried_out_in_pyrobosim(paper: Home, body: PyRoboSimBody) -> None:
    plan = plan_services(paper, SERVICES, state=evening(paper))
    acting, run = carry_out(body, plan)
    assert acting.achieved and acting.failures == [] and acting.replans == 0
    assert acting.done == plan.actions == run.actions  # every action of the plan, done, in order
    assert [a[0] for a in run.actions] == [
        "move", "pick", "pour", "move", "hand_over", "move", "switch_by_hand", "switch_iot", "move", "dock",
    ]  # fmt: skip
    assert run.devices["lamp"] is True and run.devices["window"] is False
    assert run.state.docked and run.held is None and run.state.objects["cup"] == "sofa"
    # pyrobosim's world agrees: the cup on the sofa, the robot charged beside the charger
    cup = body.world.get_object_by_name("cup")
    assert cup.parent.name == "sofa_spot" and body.robot.manipulated_object is None
    assert body.robot.location.name == "charger_spot" and body.robot.battery_level == 100.0
    # every move drove from where the last ended to beside its target, in time
    for row in run.timeline:
        if row["action"][0] == "move" and row["action"][1] != row["action"][2]:
            assert row["distance_m"] > 0.5 and row["end"] > row["start"] + row["distance_m"] / 0.5 - 1e-6
    t = run.trajectory[:, 0]
    assert (t[1:] >= t[:-1]).all() and t[-1] == run.seconds
    x, y = run.trajectory[-1, 1:3].round(6)
    assert (x, y) in {(0.95, 4.4), (0.5, 3.95)}  # beside the charger at (0.5, 4.4), on a clear side


def test_a_cup_that_is_elsewhere_in_pyrobosim_is_fetched_from_there(paper: Home, body: PyRoboSimBody) -> None:
    belief = evening(paper)
    world = belief.copy()
    world.objects["cup"] = "table"  # someone put the cup on the table
    body.start(world)
    result = act(body.domain, belief, [("SendDrinks",)], body.commands(), observe=body.observe)
    assert [str(f) for f in result.failures] == [
        "plan 1: ('pick', 'cup', 'dispenser') failed: 'cup' is not at 'dispenser'"
    ]
    assert result.achieved and result.replans == 1
    assert result.done == [
        ("move", "charger", "dispenser"),
        ("move", "dispenser", "table"),
        ("pick", "cup", "table"),
        ("move", "table", "dispenser"),
        ("pour", "cup", "dispenser"),
        ("move", "dispenser", "sofa"),
        ("hand_over", "cup", "user"),
    ]
    assert body.world.get_object_by_name("cup").parent.name == "sofa_spot"


def test_a_pick_that_pyrobosim_fails_is_tried_again(paper: Home, body: PyRoboSimBody) -> None:
    body.start(evening(paper))
    body.robot.action_execution_options = {"pick": ExecutionOptions(success_probability=0.0)}
    looked = []

    def observe():
        looked.append(True)
        body.robot.action_execution_options = {}  # the gripper works again
        return body.observe()

    try:
        result = act(body.domain, evening(paper), [("SendDrinks",)], body.commands(), observe=observe)
    finally:
        body.robot.action_execution_options = {}
    assert [str(f) for f in result.failures] == [
        "plan 1: ('pick', 'cup', 'dispenser') failed: pyrobosim: Simulated pick failure."
    ]
    assert looked == [True] and result.achieved and result.replans == 1
    assert result.plans[1].actions[:1] == [("pick", "cup", "dispenser")]  # already there: no move
    assert [a[0] for a in body.result().actions] == ["move", "pick", "pour", "move", "hand_over"]


def test_a_room_pyrobosim_cannot_reach_fails_with_its_message_never_an_exception(
    paper: Home, body: PyRoboSimBody
) -> None:
    body.start(evening(paper))
    hallway = next(h for h in body.world.hallways if h.room_end.name == "kitchen")
    assert body.world.close_location(hallway).is_success()
    body.robot.update_polygons()  # the robot and its planner see the door closed
    body.robot.path_planner.reset()
    try:
        result = act(body.domain, evening(paper), [("SendDrinks",)], body.commands(), observe=body.observe)
    finally:
        body.world.open_location(hallway)
        body.robot.update_polygons()
        body.robot.path_planner.reset()
    assert not result.achieved and result.done == []
    assert [str(f) for f in result.failures] == [
        f"plan {n}: ('move', 'charger', 'dispenser') failed: pyrobosim: Failed to plan a path to 'dispenser'."
        for n in (1, 2, 3)
    ]


@pytest.mark.parametrize("kind", ["builtin", "pyrobosim"])
def test_both_bodies_answer_the_same_where_an_action_does_not_apply(
    paper: Home, body: PyRoboSimBody, kind: str
) -> None:
    robot = body if kind == "pyrobosim" else SimulatedRobot(paper)
    robot.start(evening(paper))
    assert robot.pick("cup", "dispenser") == Outcome(False, "the robot is at 'charger', not at 'dispenser'")
    assert robot.move("charger", "attic") == Outcome(
        False,
        "unknown place 'attic'; the layout has sofa, table, bed, dining_table, dispenser, charger, "
        "lamp, living_room, bedroom, dining_area, kitchen",
    )
    assert robot.dock("sofa") == Outcome(False, "the robot is at 'charger', not at 'sofa'")
    assert robot.carry_out(("fly", "bed")).message.startswith("no such action ('fly', 'bed')")
    assert robot.switch_by_hand("lamp", "on") == Outcome(False, "the robot is at 'charger', not at 'lamp'")
    assert robot.move("charger", "bedroom") == Outcome(True)  # a room: its centre
    assert robot.observe().robot == "bedroom" and robot.result().actions == [("move", "charger", "bedroom")]


# -- the command line ----------------------------------------------------------------------------------
def test_simulate_with_pyrobosim_reports_draws_and_writes_the_bag(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    png, bag = tmp_path / "run.png", tmp_path / "bag"
    args = ["simulate", "--services", ",".join(SERVICES), "--robot", "pyrobosim", "--json"]
    assert main([*args, "--png", str(png), "--bag", str(bag)]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["robot"] == {
        "body": "pyrobosim",
        "planner": "astar",
        "achieved": True,
        "replans": 0,
        "failures": [],
    }
    assert len(data["actions"]) == len(data["timeline"]) == 10 and data["devices"]["lamp"] == "on"
    assert png.read_bytes()[:4] == b"\x89PNG" and data["png"] == str(png)
    with AnyReader([bag]) as reader:
        assert {c.topic for c in reader.connections} == set(TOPICS)
        actions = [
            reader.deserialize(raw, c.msgtype).data
            for c, _, raw in reader.messages()
            if c.topic == "/robot/action"
        ]
    assert actions == [" ".join(a) for a in data["actions"]]


def test_the_builtin_body_reports_itself(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "--services", "ChargeItSelf", "--json"]) == 0
    robot = json.loads(capsys.readouterr().out)["robot"]
    assert robot == {"body": "builtin", "planner": "astar", "achieved": True, "replans": 0, "failures": []}


def test_the_running_robot_acts_with_the_pyrobosim_body(paper: Home) -> None:
    from homecog.context.simulated import SimulatedHome
    from homecog.knowledge.ihdr import IHDRTree
    from homecog.knowledge.store import Store
    from homecog.robot.runtime import Runtime

    source = SimulatedHome(paper, speed=0, start="2021-06-21 21:30", routine_switches=False)
    runtime = Runtime(
        home=paper,
        store=Store.open("sqlite://", paper),
        tree=IHDRTree(paper),
        source=source,
        robot="pyrobosim",
    )
    assert isinstance(runtime.actor.body, PyRoboSimBody)
    now = runtime.context()
    assert now["lamp"] == "off"
    runtime.act(now, ["TurnOnLamp", "ChargeItSelf"])
    assert runtime.acted.achieved
    assert runtime.acted.done == [
        ("move", "charger", "lamp"),
        ("switch_by_hand", "lamp", "on"),
        ("move", "lamp", "charger"),
        ("dock", "charger"),
    ]
    assert runtime.context()["lamp"] == "on"  # the simulated home saw the switch by hand
    shown = runtime.plan(["SendDrinks"], None)["simulation"]
    assert [row["action"][0] for row in shown["timeline"]] == ["move", "pick", "pour", "move", "hand_over"]
    # the HMI's plan is carried out by a pyrobosim robot too, not the built-in one
    builtin = plan_request(runtime.home, ["SendDrinks"], None)["simulation"]
    assert shown["distance_m"] != builtin["distance_m"]
