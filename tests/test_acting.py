"""Acting: plans carried out through commands, replanning when one fails, as
GTPyhop's run_lazy_lookahead. The world is real: the simulated home (its devices) and the
simulated robot on the floor plan; the failing switch is a wrapper of the home's that fails on
purpose."""

from __future__ import annotations

import logging

import pytest

from homecog.context.simulated import SimulatedHome
from homecog.errors import CommandError, PlanningError
from homecog.home import Home
from homecog.planning import Domain, State, act, initial_state, make_domain
from homecog.planning.acting import Failure, iot_commands
from homecog.planning.state import observed_state
from homecog.simulation.body import SimulatedRobot

BROKER_GONE = "ConnectionError: the broker is gone"


class FailingSwitch:
    """The simulated home's switch behind a broker that is gone for the first ``failures``
    commands to ``device`` (every one, when ``failures`` is None)."""

    def __init__(self, home: SimulatedHome, device: str, failures: int | None) -> None:
        self.home, self.device, self.failures = home, device, failures
        self.calls: list[tuple[str, bool]] = []

    def __call__(self, device: str, on: bool) -> None:
        self.calls.append((device, on))
        if device == self.device and (self.failures is None or self.failures > 0):
            if self.failures is not None:
                self.failures -= 1
            raise ConnectionError("the broker is gone")
        self.home.switch(device, on)


@pytest.fixture
def home(paper: Home) -> SimulatedHome:
    source = SimulatedHome(paper, start="2021-06-21 09:00")
    source.switch("window", True)
    return source


@pytest.fixture(scope="module")
def domain(paper: Home) -> Domain:
    return make_domain(paper)


def seen(home: SimulatedHome) -> State:
    return observed_state(home.home, home.snapshot())


def test_a_command_that_fails_once_is_carried_out_after_one_replan(home, domain):
    switch = FailingSwitch(home, "window", failures=1)
    result = act(domain, seen(home), [("CloseWindow",), ("TurnOnLight",)], iot_commands(domain, switch))
    assert result.achieved and result.reason is None
    assert result.replans == 1
    assert result.failures == [Failure(("switch_iot", "window", "off"), BROKER_GONE, 1)]
    assert result.done == [("switch_iot", "window", "off"), ("switch_iot", "ceiling_light", "on")]
    assert switch.calls == [("window", False), ("window", False), ("ceiling_light", True)]
    assert home.snapshot()["window"] == "off" and home.snapshot()["ceiling_light"] == "on"
    assert result.state.devices["window"] is False and result.state.devices["ceiling_light"] is True


def test_only_the_remaining_tasks_are_planned_again(home, domain):
    switch = FailingSwitch(home, "window", failures=1)
    request = [("TurnOnLight",), ("CloseWindow",), ("TurnOnTVL",)]
    result = act(domain, seen(home), request, iot_commands(domain, switch))
    assert [plan.actions for plan in result.plans] == [
        [
            ("switch_iot", "ceiling_light", "on"),
            ("switch_iot", "window", "off"),
            ("switch_iot", "tv_living", "on"),
        ],
        [("switch_iot", "window", "off"), ("switch_iot", "tv_living", "on")],
    ]
    assert [plan.tree[0].task for plan in result.plans] == [("TurnOnLight",), ("CloseWindow",)]
    assert result.done == [
        ("switch_iot", "ceiling_light", "on"),
        ("switch_iot", "window", "off"),
        ("switch_iot", "tv_living", "on"),
    ]
    assert result.achieved and result.replans == 1


def test_a_command_that_always_fails_gives_up_after_max_tries(home, domain, caplog):
    switch = FailingSwitch(home, "window", failures=None)
    with caplog.at_level(logging.INFO, logger="homecog.planning.acting"):
        result = act(
            domain,
            seen(home),
            [("TurnOnLight",), ("CloseWindow",)],
            iot_commands(domain, switch),
            max_tries=3,
        )
    assert not result.achieved
    assert result.done == [("switch_iot", "ceiling_light", "on")]
    assert result.failures == [Failure(("switch_iot", "window", "off"), BROKER_GONE, n) for n in (1, 2, 3)]
    assert len(result.plans) == 3 and result.replans == 2
    assert result.reason == (
        "gave up after 3 plans; the last: plan 3: ('switch_iot', 'window', 'off') failed: " + BROKER_GONE
    )
    assert home.snapshot()["window"] == "on"  # never switched
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert warnings == [
        f"plan {n}: ('switch_iot', 'window', 'off') failed: {BROKER_GONE}" for n in (1, 2, 3)
    ] + [f"acting: {result.reason}"]
    assert "plan 1 for TurnOnLight, CloseWindow: 2 actions" in caplog.messages
    assert result.as_dict()["replans"] == 2 and result.as_dict()["failures"][0]["plan"] == 1


def test_the_world_changed_under_the_plan(paper, domain):
    belief = initial_state(paper, user="sofa")
    body = SimulatedRobot(paper, belief)
    body.world.objects["cup"] = "table"  # someone put the cup on the table
    result = act(domain, belief, [("SendDrinks",)], body.commands(), observe=body.observe)
    assert result.failures == [Failure(("pick", "cup", "dispenser"), "'cup' is not at 'dispenser'", 1)]
    assert result.plans[1].actions == [
        ("move", "dispenser", "table"),  # the replan fetches it from its new place
        ("pick", "cup", "table"),
        ("move", "table", "dispenser"),
        ("pour", "cup", "dispenser"),
        ("move", "dispenser", "sofa"),
        ("hand_over", "cup", "user"),
    ]
    assert result.done == [("move", "charger", "dispenser"), *result.plans[1].actions]
    assert result.achieved and result.replans == 1
    assert body.world.objects == {"cup": "sofa"} and body.world.holding is None
    ran = body.simulation.result()
    assert ran.actions == result.done and ran.distance_m > 0 and ran.seconds > 4 + 6 + 3


def test_what_was_done_of_a_task_is_not_done_again(paper, domain):
    """The user moved to the bed while the robot brought the cup to the sofa: it keeps the cup,
    fills it again at the dispenser (fill does not know it is full) and goes to the bed."""
    belief = initial_state(paper, user="sofa")
    body = SimulatedRobot(paper, belief)
    body.world.user = "bed"
    result = act(domain, belief, [("SendDrinks",), ("ChargeItSelf",)], body.commands(), observe=body.observe)
    failed = ("hand_over", "cup", "user")
    assert result.failures == [Failure(failed, "the robot is at 'sofa', not with the user at 'bed'", 1)]
    assert result.plans[1].actions == [
        ("move", "sofa", "dispenser"),
        ("pour", "cup", "dispenser"),
        ("move", "dispenser", "bed"),
        ("hand_over", "cup", "user"),
        ("move", "bed", "charger"),
        ("dock", "charger"),
    ]
    assert result.achieved and body.world.objects["cup"] == "bed" and body.world.docked


def test_a_request_that_cannot_be_planned_from_what_was_observed(paper, domain, caplog):
    belief = initial_state(paper)
    body = SimulatedRobot(paper, belief)
    del body.world.objects["cup"]  # broken: there is no cup any more
    result = act(domain, belief, [("SendDrinks",)], body.commands(), observe=body.observe)
    assert not result.achieved and result.replans == 0 and len(result.plans) == 1
    assert result.failures == [Failure(("pick", "cup", "dispenser"), "'cup' is not at 'dispenser'", 1)]
    assert result.reason == "no plan for SendDrinks in domain paper"
    assert result.state.robot == "dispenser"  # where the robot saw the world last


def test_actions_without_a_command_are_carried_out_on_the_model(paper, domain):
    result = act(domain, initial_state(paper, user="bed"), [("CallToWakeup",)])
    assert result.achieved and result.replans == 0 and result.failures == []
    assert result.done == [("move", "charger", "bed"), ("speak", "Good morning, it is time to get up.")]
    assert result.state.robot == "bed"


def test_a_command_that_returns_nothing_or_raises_its_own_error(paper, domain):
    def refuse(state, text):
        return None

    def closed(state, origin, target):
        raise CommandError(f"the door to {target} is closed")

    state = initial_state(paper, user="bed")
    result = act(domain, state, [("CallToWakeup",)], {"speak": refuse}, max_tries=1)
    assert result.failures == [
        Failure(("speak", "Good morning, it is time to get up."), "the command failed", 1)
    ]
    assert result.done == [("move", "charger", "bed")] and not result.achieved
    result = act(domain, state, [("CallToWakeup",)], {"move": closed}, max_tries=2)
    assert [f.reason for f in result.failures] == ["the door to bed is closed"] * 2 and result.done == []


def test_bad_requests_are_errors(paper, domain):
    with pytest.raises(PlanningError, match="unknown task 'Dance' in domain paper"):
        act(domain, initial_state(paper), [("Dance",)])
    with pytest.raises(ValueError, match="max_tries must be at least 1"):
        act(domain, initial_state(paper), [("CloseWindow",)], max_tries=0)


def test_a_switch_by_hand_reaches_the_simulated_home(paper, home, domain):
    body = SimulatedRobot(paper, seen(home), switch=home.switch)
    result = act(domain, seen(home), [("TurnOnLamp",), ("CloseWindow",)], body.commands())
    assert result.done == [
        ("move", "charger", "lamp"),
        ("switch_by_hand", "lamp", "on"),
        ("switch_iot", "window", "off"),
    ]
    assert home.snapshot()["lamp"] == "on" and home.snapshot()["window"] == "off"
    assert body.world.devices["lamp"] is True
