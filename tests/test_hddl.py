"""The HDDL export: unified-planning reads the domain and problems, and Aries, where
it runs, finds the plans our planner finds."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from unified_planning.io import PDDLReader
from unified_planning.model.htn import HierarchicalProblem

from homecog.errors import PlanningError
from homecog.home import load_home, load_home_text
from homecog.planning import State, initial_state, plan_services
from homecog.planning.hddl import actions_from_hddl, domain_hddl, hddl_name, problem_hddl

STUDIO = Path(__file__).parent / "homes" / "studio.yaml"
STUDIO_LAYOUT = """
layout:
  size: [6, 4]
  rooms: {studio: [0, 0, 4, 4], bath: [4, 0, 6, 4]}
  walls: [[4, 0, 4, 4]]
  doors: [[4, 1, 4, 2]]
  places: {desk: [1, 1], couch: [3, 3], kettle: [5, 3], dock: [0.5, 3.5]}
  objects: {tea: kettle}
"""

ACTIONS = {
    "move", "stay", "pick", "pour", "hand-over", "speak", "switch-iot-on", "switch-iot-off",
    "switch-by-hand-on", "switch-by-hand-off", "dock",
}  # fmt: skip
TASKS = {"goto", "switch", "fetch", "fill", "deliver"}
#: The domain's methods: each one's task and subtasks (every home's; one more per service).
DOMAIN_METHODS = {
    "already-there": ("goto", []),
    "goto-move": ("goto", ["move"]),
    "goto-stay": ("goto", ["stay"]),
    "by-iot-on": ("switch", ["switch-iot-on"]),
    "by-iot-off": ("switch", ["switch-iot-off"]),
    "by-hand-on": ("switch", ["goto", "switch-by-hand-on"]),
    "by-hand-off": ("switch", ["goto", "switch-by-hand-off"]),
    "fetch-held": ("fetch", []),
    "fetch-from-place": ("fetch", ["goto", "pick"]),
    "fill-here": ("fill", ["pour"]),
    "fill-at-source": ("fill", ["goto", "pour"]),
    "deliver-to-user": ("deliver", ["goto", "hand-over"]),
}

REQUESTS = [
    ["SendDrinks"],
    ["SendDrinks", "TurnOnLamp", "CloseWindow"],
    ["ChargeItSelf", "RemindToSleep", "SendDrinks", "SendDrinks", "TurnOffLamp", "CallToWakeup"],
    ["TurnOnTVL", "TurnOnACL", "TurnOnLight", "OpenCurtain", "OpenWindow", "ChargeItSelf", "ChargeItSelf"],
]
#: Requests to the studio of the format reference (tests/homes/studio.yaml with STUDIO_LAYOUT).
STUDIO_REQUESTS = [
    ["BringTea"],
    ["LampOn", "RaiseBlind", "RadioOn"],
    ["SayGoodnight", "LampOff", "LowerBlind", "RadioOff", "BringTea"],
]
IDENTIFIER = re.compile(r"^[a-z][a-z0-9_-]*$")


@pytest.fixture(scope="module")
def home():
    return load_home("paper")


@pytest.fixture(scope="module")
def reader() -> PDDLReader:
    return PDDLReader()


@pytest.fixture(scope="module")
def studio():
    return load_home_text(STUDIO.read_text() + STUDIO_LAYOUT, "studio.yaml")


def parse(reader: PDDLReader, home, services: list[str], state: State) -> HierarchicalProblem:
    problem = reader.parse_problem_string(domain_hddl(home), problem_hddl(home, services, state))
    assert isinstance(problem, HierarchicalProblem)
    return problem


@pytest.mark.parametrize("services", REQUESTS, ids=lambda s: "-".join(s))
def test_unified_planning_reads_the_domain_and_problem(home, reader, services):
    state = initial_state(home, user="table")
    problem = parse(reader, home, services, state)
    assert {a.name for a in problem.actions} == ACTIONS
    tasks = {t.name for t in problem.tasks}
    assert len(tasks) == len(TASKS) + len(home.services)
    assert tasks >= TASKS | {hddl_name(home, "task", s) for s in home.service_names}
    check_methods(problem, home)
    network = problem.task_network.subtasks
    assert [s.task.name for s in network] == [hddl_name(home, "task", s) for s in services]
    for name in [*tasks, *(a.name for a in problem.actions), *(o.name for o in problem.all_objects)]:
        assert IDENTIFIER.match(name), name


def test_initial_state_follows_the_planning_state(home, reader):
    state = initial_state(home, {"window": "on", "lamp": "on"}, user="sofa")
    state.holding, state.objects["cup"], state.docked = "cup", "robot", True
    problem = parse(reader, home, ["CloseWindow"], state)
    facts = {str(f) for f, v in problem.explicit_initial_values.items() if v.is_true()}
    assert {"robot-at(charger)", "user-at(user, sofa)", "holding(cup)", "docked"} <= facts
    assert {"is-on(window)", "is-on(lamp)"} <= facts and "is-on(tv_living)" not in facts
    assert "hand-empty" not in facts and not any(f.startswith("at(cup") for f in facts)
    assert "iot(lamp)" not in facts and "device-at(lamp, lamp-place)" in facts


def check_methods(problem: HierarchicalProblem, home) -> None:
    """The problem's methods are the domain's (each achieving its task by its subtasks) and one
    a service, ``do-<its task>``, achieving the service's task by the domain's tasks and actions."""
    methods = {
        m.name: (m.achieved_task.task.name, [s.task.name for s in m.subtasks]) for m in problem.methods
    }
    assert {k: v for k, v in methods.items() if k in DOMAIN_METHODS} == DOMAIN_METHODS
    steps = TASKS | ACTIONS
    for service in home.service_names:
        task = hddl_name(home, "task", service)
        achieved, subtasks = methods.pop(f"do-{task}")
        assert achieved == task and subtasks and set(subtasks) <= steps, (service, subtasks)
    assert methods.keys() == DOMAIN_METHODS.keys()  # nothing else


def test_a_home_written_from_the_spec_exports_too(reader, studio):
    services = studio.service_names
    problem = parse(reader, studio, list(services), initial_state(studio))
    check_methods(problem, studio)
    assert [s.task.name for s in problem.task_network.subtasks] == [
        hddl_name(studio, "task", s) for s in services
    ]


def test_unknown_services_and_actions_are_refused(home):
    with pytest.raises(PlanningError, match="unknown service 'Dance'"):
        problem_hddl(home, ["Dance"])
    with pytest.raises(PlanningError, match="unknown HDDL action"):
        actions_from_hddl(home, [("fly", ["charger"])])


def test_actions_map_back_to_ours(home):
    steps = [
        ("stay", ["charger"]),
        ("dock", ["charger"]),
        ("move", ["charger", "lamp-place"]),
        ("switch-by-hand-off", ["lamp", "lamp-place"]),
        ("switch-iot-on", ["tv_living"]),
        ("speak", ["call-to-wakeup-msg"]),
    ]
    assert actions_from_hddl(home, steps) == [
        ("move", "charger", "charger"),
        ("dock", "charger"),
        ("move", "charger", "lamp"),
        ("switch_by_hand", "lamp", "off"),
        ("switch_iot", "tv_living", "on"),
        ("speak", "Good morning, it is time to get up."),
    ]


@pytest.fixture(scope="module")
def aries():
    pytest.importorskip("up_aries", reason="up-aries is not installed")
    import unified_planning.shortcuts as up

    up.get_environment().credits_stream = None
    try:
        planner = up.OneshotPlanner(name="aries")
    except Exception as e:
        pytest.skip(f"Aries does not start here: {e}")
    yield planner
    planner.destroy()


def aries_plan(aries, reader: PDDLReader, home, services: list[str], state: State) -> list:
    """Aries' plan of the exported problem, mapped back to our actions."""
    problem = parse(reader, home, services, state)
    try:
        result = aries.solve(problem, timeout=60)
    except Exception as e:  # the shipped binary may not run on this machine
        pytest.skip(f"Aries does not run here: {type(e).__name__}: {e}")
    assert result.plan is not None, result.status
    steps = [(a.action.name, [str(p) for p in a.actual_parameters]) for a in result.plan.action_plan.actions]
    return actions_from_hddl(home, steps)


@pytest.mark.parametrize("services", REQUESTS, ids=lambda s: "-".join(s))
def test_aries_finds_our_plan(home, reader, aries, services):
    state = initial_state(home, user="table")
    assert (
        aries_plan(aries, reader, home, services, state) == plan_services(home, services, state=state).actions
    )


@pytest.mark.parametrize("services", STUDIO_REQUESTS, ids=lambda s: "-".join(s))
def test_aries_finds_our_plan_in_the_studio(studio, reader, aries, services):
    state = initial_state(studio)
    ours = plan_services(studio, services, state=state).actions
    assert ours and aries_plan(aries, reader, studio, services, state) == ours
