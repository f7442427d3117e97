"""HTN planning: the domain derived from a home, the plan and its tree, layouts."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import pytest

from homecog.cli.main import main
from homecog.errors import HomeFileError, PlanningError
from homecog.home import load_home, load_home_text
from homecog.planning import initial_state, make_domain, plan_services
from homecog.planning.planner import Domain, find_plan

STUDIO = Path(__file__).parent / "homes" / "studio.yaml"

# The studio written from the home file reference, with a floor plan of its own and no errands: its
# interaction services must plan from the defaults.
STUDIO_LAYOUT = """
layout:
  size: [6, 4]
  rooms: {studio: [0, 0, 4, 4], bath: [4, 0, 6, 4]}
  walls: [[4, 0, 4, 4]]
  doors: [[4, 1, 4, 2]]
  places: {desk: [1, 1], couch: [3, 3], kettle: [5, 3], dock: [0.5, 3.5]}
  objects: {tea: kettle}
"""


def studio(layout: str = STUDIO_LAYOUT):
    return load_home_text(STUDIO.read_text() + layout, "studio.yaml")


def paper_context(**changes: str) -> dict[str, object]:
    context: dict[str, object] = {
        "time": "22:00",
        "temperature": "19",
        "illumination": "200",
        "location": "table",
        "posture": "sit",
        "behavior": "read",
        **dict.fromkeys(load_home("paper").device_names, "off"),
    }
    context.update(changes)
    return context


def test_send_drinks_decomposes_as_in_fig7():
    plan = plan_services(load_home("paper"), ["SendDrinks"], context=paper_context())
    assert plan.actions == [
        ("move", "charger", "dispenser"),
        ("pick", "cup", "dispenser"),
        ("pour", "cup", "dispenser"),
        ("move", "dispenser", "table"),
        ("hand_over", "cup", "user"),
    ]
    assert plan.state.objects["cup"] == "table" and plan.state.holding is None


def test_every_service_of_paper_plans_and_does_what_it_says():
    """Over every service and both states of every device it sets: the plan leaves the
    devices as the service sets them, by IoT where the device has it, by hand otherwise."""
    home = load_home("paper")
    iot = {d.name: d.iot for d in home.devices}
    domain = make_domain(home)
    for service in home.services:
        for before in (False, True):
            context = paper_context(**{d: ("on" if before else "off") for d, _ in service.sets})
            plan = plan_services(home, [service.name], context=context, domain=domain)
            assert plan.actions, service.name
            for device, value in service.sets:
                assert plan.state.devices[device] is value
                kind = "switch_iot" if iot[device] else "switch_by_hand"
                # switching to the state a device is already in changes nothing, and stays
                assert (kind, device, "on" if value else "off") in plan.actions
                if not iot[device]:
                    i = plan.actions.index((kind, device, "on" if value else "off"))
                    assert plan.actions[i - 1][0] == "move"
                    assert plan.actions[i - 1][2] == home.layout.device_place(device)


def test_priority_order_and_the_tree_round_trip():
    home = load_home("paper")
    request = ["CallToWakeup", "OpenCurtain", "TurnOnLamp", "SendDrinks", "ChargeItSelf"]
    plan = plan_services(home, request, context=paper_context(location="bed"))
    assert [root.task[0] for root in plan.tree] == request

    def leaves(node):
        if node.is_action:
            return [node]
        return [leaf for child in node.children for leaf in leaves(child)]

    flat = [leaf for root in plan.tree for leaf in leaves(root)]
    assert [leaf.task for leaf in flat] == plan.actions
    assert [leaf.index for leaf in flat] == list(range(1, len(plan.actions) + 1))
    assert plan.actions[:2] == [("move", "charger", "bed"), ("speak", "Good morning, it is time to get up.")]
    assert plan.actions[-2:] == [("move", "bed", "charger"), ("dock", "charger")]
    assert plan.state.docked is True
    moves = [a for a in plan.actions if a[0] == "move"]
    for earlier, later in itertools.pairwise(moves):
        assert earlier[2] == later[1]  # the robot leaves from where it arrived
    outline = plan.outline().splitlines()
    assert (
        outline[0] == "CallToWakeup" and outline[1] == "  goto bed" and outline[2] == "    1 move charger bed"
    )


def test_two_deliveries_fetch_the_cup_back_from_the_user():
    plan = plan_services(load_home("paper"), ["SendDrinks", "SendDrinks"], user="sofa")
    assert plan.actions[5:] == [
        ("pick", "cup", "sofa"),  # the robot is with the user already: no move from sofa to sofa
        ("move", "sofa", "dispenser"),
        ("pour", "cup", "dispenser"),
        ("move", "dispenser", "sofa"),
        ("hand_over", "cup", "user"),
    ]


def test_no_plan_moves_from_a_place_to_itself():
    """A goto where the robot already is has nothing to do: over every pair of services of the
    paper home, from every place the user can be, no plan has a zero-length move, every move
    leaves from where the robot is, and the robot still ends where the plan sends it."""
    home = load_home("paper")
    domain = make_domain(home)
    requests = [[a.name, b.name] for a, b in itertools.product(home.services, repeat=2)]
    for where in home.feature("location").values:
        for request in requests:
            plan = plan_services(home, request, user=where, domain=domain)
            here = plan.start.robot
            for a in plan.actions:
                if a[0] == "move":
                    assert a[1] == here and a[2] != here, (where, request, plan.actions)
                    here = a[2]
            assert here == plan.state.robot
    plan = plan_services(home, ["ChargeItSelf", "ChargeItSelf"], user="sofa", domain=domain)
    assert plan.actions == [("dock", "charger"), ("dock", "charger")]  # the robot starts at the charger
    assert plan.outline().splitlines()[:3] == ["ChargeItSelf", "  goto charger", "  1 dock charger"]


def test_a_home_written_from_the_spec_plans_with_default_errands():
    home = studio()
    plan = plan_services(home, ["SayGoodnight", "LampOn", "RadioOn"], user="couch")
    assert plan.actions == [
        ("move", "desk", "couch"),
        ("speak", "say goodnight"),
        ("move", "couch", "studio"),  # the desk lamp has no place: the centre of its room
        ("switch_by_hand", "desk_lamp", "on"),
        ("switch_iot", "radio", "on"),
    ]
    assert initial_state(home).robot == "desk"  # the first place when `robot` is not given


def test_backtracking_takes_the_next_method():
    def fail(state):
        return None

    def fine(state):
        return [("noop",)]

    domain = Domain("d", actions={"noop": lambda s: s}, methods={"t": [fail, fine]})

    class S:
        def copy(self):
            return self

    plan = find_plan(domain, S(), [("t",)])
    assert plan.tree[0].method == "fine" and plan.actions == [("noop",)]
    with pytest.raises(PlanningError, match="no plan for t"):
        find_plan(Domain("d", actions={}, methods={"t": [fail]}), S(), [("t",)])
    with pytest.raises(ValueError, match="both an action and a compound task: x"):
        Domain("d", actions={"x": fine}, methods={"x": [fine]})


def test_planning_errors():
    with pytest.raises(PlanningError, match="home 'studio' has no layout"):
        plan_services(load_home(STUDIO), ["LampOn"])
    with pytest.raises(PlanningError, match="unknown service 'Fly'"):
        plan_services(load_home("paper"), ["Fly"])
    with pytest.raises(PlanningError, match="unknown place 'garden' for the user"):
        plan_services(load_home("paper"), ["SendDrinks"], user="garden")


@pytest.mark.parametrize(
    ("layout", "message"),
    [
        (
            STUDIO_LAYOUT.replace("objects: {tea: kettle}", "objects: {tea: pantry}"),
            "layout.objects.tea: unknown place 'pantry'",
        ),
        (
            STUDIO_LAYOUT.replace("doors: [[4, 1, 4, 2]]", "doors: [[3, 1, 3, 2]]"),
            "layout.doors[0]: does not lie on a wall",
        ),
        (
            STUDIO_LAYOUT.replace("desk: [1, 1]", "desk: [4.02, 3]"),
            "layout.places.desk: (4.02, 3) lies inside the wall",
        ),
        (
            STUDIO_LAYOUT.replace("couch: [3, 3]", "couch: [7, 3]"),
            "layout.places.couch: point (7, 3) lies outside",
        ),
        (STUDIO_LAYOUT + "  errands: {Fly: {say: hi}}\n", "layout.errands.Fly: unknown service 'Fly'"),
        (
            STUDIO_LAYOUT + "  errands: {LampOn: {say: hi}}\n",
            "layout.errands.LampOn: LampOn switches devices",
        ),
        (
            STUDIO_LAYOUT + "  errands: {BringTea: {bring: cake}}\n",
            "layout.errands.BringTea.bring: unknown object",
        ),
        (
            STUDIO_LAYOUT + "  errands: {BringTea: {say: a, dock: desk}}\n",
            "expected exactly one of bring, dock or say",
        ),
        (
            STUDIO_LAYOUT.replace(
                "rooms: {studio: [0, 0, 4, 4], bath: [4, 0, 6, 4]}", "rooms: {bath: [4, 0, 6, 4]}"
            ),
            "device 'desk_lamp' is switched by hand but has no place of its name and its room 'studio'",
        ),
        (STUDIO_LAYOUT.replace("size: [6, 4]", "size: [6]"), "layout.size: expected a list of 2 numbers"),
        (
            STUDIO_LAYOUT.replace("walls: [[4, 0, 4, 4]]", "walls: [[0, 0, 4, 4]]"),
            "layout.walls[0]: expected a horizontal or vertical",
        ),
        (STUDIO_LAYOUT + "  robot: garage\n", "layout.robot: unknown place 'garage'"),
        (STUDIO_LAYOUT + "  stairs: []\n", "layout.stairs: unknown key"),
    ],
)
def test_bad_layouts_name_the_key(layout, message):
    with pytest.raises(HomeFileError) as e:
        studio(layout)
    assert str(e.value).startswith("studio.yaml: layout")
    assert message in str(e.value)


def test_cli_plan(capsys):
    context = ",".join(f"{k}={v}" for k, v in paper_context(window="on").items())
    assert main(["plan", "--services", "CloseWindow,SendDrinks", "--context", context, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["actions"][0] == ["switch_iot", "window", "off"]
    assert data["actions"][-1] == ["hand_over", "cup", "user"]
    assert [t["task"] for t in data["tree"]] == [["CloseWindow"], ["SendDrinks"]]
    assert data["tree"][0]["children"][0] == {
        "task": ["switch", "window", "off"],
        "method": "by_iot",
        "children": [{"action": ["switch_iot", "window", "off"], "index": 1}],
    }
    assert main(["plan", "--services", "CloseWindow"]) == 0
    assert "1 switch_iot window off" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--services", "Fly"], "unknown service 'Fly'"),
        (["--services", ""], "--services: expected at least one service"),
        (["--services", "LampOn", "--home", str(STUDIO)], "home 'studio' has no layout"),
        (["--services", "SendDrinks", "--context", "time=7:00"], "missing temperature, illumination"),
    ],
)
def test_cli_plan_errors(capsys, args, message):
    assert main(["plan", *args]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    err = captured.err.strip()
    assert err.startswith("homecog: error:") and message in err and "\n" not in err


def test_cli_simulate(capsys, tmp_path):
    png = tmp_path / "run.png"
    args = ["simulate", "--services", "SendDrinks,TurnOnLamp,ChargeItSelf", "--png", str(png), "--json"]
    assert main(args) == 0
    data = json.loads(capsys.readouterr().out)
    assert {"actions", "seconds", "distance_m", "timeline", "devices", "png"} <= set(data)
    assert data["png"] == str(png) and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert data["actions"] == [t["action"] for t in data["timeline"]]
    assert data["actions"][-1] == ["dock", "charger"]
    assert data["devices"]["lamp"] == "on"
    assert data["seconds"] == pytest.approx(data["timeline"][-1]["end"])
    assert data["distance_m"] == pytest.approx(sum(t["distance_m"] for t in data["timeline"]))
    # the robot drives from the charger to the dispenser and on: at least the straight lines
    places = load_home("paper").layout.places
    straight = sum(
        ((places[a][0] - places[b][0]) ** 2 + (places[a][1] - places[b][1]) ** 2) ** 0.5
        for a, b in [("charger", "dispenser"), ("dispenser", "table")]  # the user: the first location
    )
    assert data["distance_m"] > straight
    assert main(["simulate", "--services", "CloseWindow", "--png", str(tmp_path)]) == 2
    assert "is a directory" in capsys.readouterr().err
    # the simulation starts from the plan's state: the drink goes to the bed the context names
    context = ",".join(f"{k}={v}" for k, v in paper_context(location="bed").items())
    assert main(["simulate", "--services", "SendDrinks", "--context", context, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["actions"][-2] == ["move", "dispenser", "bed"]


def test_home_check_finds_a_place_the_robot_cannot_reach(capsys, tmp_path):
    walled = tmp_path / "walled.yaml"
    walled.write_text(STUDIO.read_text() + STUDIO_LAYOUT.replace("  doors: [[4, 1, 4, 2]]\n", ""))
    assert main(["home", "check", str(walled)]) == 2
    assert capsys.readouterr().err.strip() == (
        f"homecog: error: {walled}: layout.objects.tea: 'kettle' (the tea is fetched from there) cannot "
        "be reached from the robot's start 'desk'; room 'bath' has no door: add one to layout.doors on a "
        "wall of it"
    )
    doored = tmp_path / "doored.yaml"
    doored.write_text(STUDIO.read_text() + STUDIO_LAYOUT)
    assert main(["home", "check", str(doored)]) == 0
