"""The planning domain as data: the notation is checked where it is written, and the
Python functions generated from it are the ones a person would write."""

from __future__ import annotations

import re

import pytest

from homecog.home import Home
from homecog.planning import initial_state, make_domain
from homecog.planning.compile import action_source, compile_domain, method_source, reason_source
from homecog.planning.domain import ACTIONS, METHOD_SCHEMAS, TASKS, tables
from homecog.planning.schema import TaskSchema, action, method

PICK = next(a for a in ACTIONS if a.name == "pick")
BY_HAND = next(m for m in METHOD_SCHEMAS if m.name == "by_hand")


def test_the_generated_action_is_plain_python():
    assert action_source(PICK) == "\n".join(
        [
            "def pick(s, obj, place):",
            "    if not (s.robot == place and s.holding is None and s.objects.get(obj) == place):",
            "        return None",
            "    s.holding = obj",
            "    s.objects[obj] = HELD",
            "    return s",
        ]
    )
    assert method_source(BY_HAND, TASKS[1]) == "\n".join(
        [
            "def by_hand(s, device, setting):",
            "    where = DEVICE_PLACE.get(device)",
            "    if where is None:",
            "        return None",
            "    return [('goto', where), ('switch_by_hand', device, setting)]",
        ]
    )
    assert "return 'the robot already holds {s.holding!r}'.format(" in reason_source(PICK)


def test_reasons_check_shape_types_then_preconditions_in_order(paper: Home):
    domain = make_domain(paper)
    state = initial_state(paper, user="sofa")
    assert domain.reasons["move"](state, "charger") == "expected 3 strings for move"
    assert domain.reasons["move"](state, "charger", 3) == "expected 3 strings for move"
    assert domain.reasons["move"](state, "attic", "sofa").startswith("unknown place 'attic'; the layout has")
    assert domain.why_not(state, ("switch_by_hand", "window", "up")) == "expected 'on' or 'off', got 'up'"
    state.robot, state.holding = "sofa", "cup"
    assert domain.why_not(state, ("pick", "cup", "dispenser")) == "the robot is at 'sofa', not at 'dispenser'"
    state.robot = "dispenser"
    assert domain.why_not(state, ("pick", "cup", "dispenser")) == "the robot already holds 'cup'"
    assert domain.why_not(state, ("hand_over", "cup", "user")) == (
        "the robot is at 'dispenser', not with the user at 'sofa'"
    )
    for name, act in domain.actions.items():  # the function GTPyhop would declare by its name
        assert act.__name__ == name


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: action("fly", "?p - place", pre=[("(flying ?p)", "")]), "unknown predicate 'flying'"),
        (lambda: action("go", "?from - place"), "variable ?from: expected a lowercase Python name"),
        (lambda: action("go", "?p - room"), "unknown type 'room' of ?p"),
        (lambda: action("go", "?p place"), "expected parameters like"),
        (lambda: action("go", "?p - place", pre=[("(robot-at ?p ?q)", "")]), "robot-at takes 1 arguments"),
        (lambda: action("leave", "?p - place", effects=["(not (robot-at ?p))"]), "needs one of"),
        (lambda: action("wire", "?d - device", effects=["(iot ?d)"]), "no action may change iot"),
        (lambda: action("x", "?d - device", effects=["(when (?d) (is-on ?d))"]), "expected (when (= ?p"),
        (lambda: method("m", "goto", lets=["(iot ?d)"]), "a let binds the last argument of a functional"),
        (lambda: method("m", "goto", lets=["(robot-at here)"]), "a let binds a variable"),
        (lambda: action("go", "?p - place", pre=[("((robot-at ?p)", "")]), "expected one expression in"),
    ],
)
def test_the_notation_is_checked_where_it_is_written(make, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        make()


def test_a_variable_must_be_bound_before_it_is_used(paper: Home):
    lost = method("lost", "goto", subtasks=[("move", "?there", "?place")])
    with pytest.raises(ValueError, match=r"method lost of goto: \?there is neither a parameter nor bound"):
        compile_domain("d", ACTIONS, TASKS, (*METHOD_SCHEMAS, lost), tables(paper))
    stray = method("stray", "Nowhere")
    with pytest.raises(ValueError, match="method stray: unknown task 'Nowhere'"):
        compile_domain("d", ACTIONS, TASKS, (stray,), tables(paper))


def test_methods_of_one_name_keep_it_and_are_tried_in_order(paper: Home):
    first = method("either", "Task", subtasks=[("speak", "one")])
    second = method("either", "Task", pre=["(docked)"], subtasks=[("speak", "two")])
    domain = compile_domain("d", ACTIONS, (TaskSchema("Task"),), (second, first), tables(paper))
    assert [m.__name__ for m in domain.methods["Task"]] == ["either", "either"]
    state = initial_state(paper)
    assert domain.methods["Task"][0](state) is None and domain.methods["Task"][1](state) == [("speak", "one")]
