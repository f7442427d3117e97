"""The running robot and the household: whose change, what it teaches, never fight,
the journal and its undo, partial evidence, the log's kinds through a rebuild."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from homecog.context import DeviceChange
from homecog.context.manual import ManualSource
from homecog.errors import HomeFileError
from homecog.home import load_home_text
from homecog.knowledge import core
from homecog.knowledge.correction import Correction
from homecog.knowledge.evidence import ServiceLearner
from homecog.knowledge.history import correction_history
from homecog.knowledge.pipeline import build
from homecog.knowledge.store import Store
from homecog.robot.attribution import Attribution
from homecog.robot.guidance import QUIET_SECONDS
from homecog.robot.journal import Journal
from homecog.robot.runtime import Runtime
from homecog.robot.settling import Settling
from homecog.web.main import create_app

HOMES = Path(__file__).parent / "homes"
STUDIO = (HOMES / "studio.yaml").read_text()
WORK = {
    "time": "10:00",
    "light": "50",
    "activity": "work",
    "blind": "off",
    "desk_lamp": "off",
    "radio": "off",
}
RELAX = {**WORK, "activity": "relax", "light": "300"}


@pytest.fixture(scope="module")
def stored(tmp_path_factory, studio_build):
    home = load_home_text(STUDIO, "studio.yaml")
    url = f"sqlite:///{tmp_path_factory.mktemp('robot') / 'knowledge.sqlite'}"
    store = Store.open(url, home)
    build(home, store, q_path=studio_build)
    store.close()
    return home, url


def make_runtime(stored, tmp_path, home=None):
    """A runtime on its own copy of the built database, the context set by hand to WORK."""
    base, url = stored
    home = home or base
    copy = tmp_path / "k.sqlite"
    copy.write_bytes(Path(url.removeprefix("sqlite:///")).read_bytes())
    store = Store.open(f"sqlite:///{copy}", home, replace=home is not base)
    source = ManualSource(home)
    source.set_context(WORK)
    return Runtime(home=home, store=store, tree=store.load_tree(), source=source)


def kinds(runtime):
    return [(c.kind, c.want, c.concerns, c.user) for c in correction_history(runtime.store).corrections]


# -- attribution, holds, settling, the journal -------------------------------------------------
def test_a_command_reported_back_is_the_robots_once_and_only_in_its_state_and_time():
    who = Attribution(expect_seconds=60)
    who.expect("radio", True, at=0.0)
    assert who.whose(DeviceChange("radio", False, {}, 1.0)) == "person"  # the other state
    assert who.whose(DeviceChange("radio", True, {}, 2.0)) == "robot"
    assert who.whose(DeviceChange("radio", True, {}, 3.0)) == "person"  # used up
    who.expect("blind", True, at=0.0)
    assert who.whose(DeviceChange("blind", True, {}, 61.0)) == "person"  # expired
    who.expect("blind", True, at=100.0)
    who.forget("blind", True)  # the command failed
    assert who.whose(DeviceChange("blind", True, {}, 101.0)) == "person"
    assert who.whose(DeviceChange("blind", True, {}, 102.0, origin="manual")) == "manual"


def test_the_robot_does_not_switch_back_its_own_switch_until_the_home_moves(paper):
    settling = Settling(paper)
    after = {"time": "19:00", "temperature": "29.8", "illumination": "300", "location": "sofa"}
    after |= {"posture": "sit", "behavior": "watch_tv", "window": "on", "curtain": "off"}
    settling.switched("window", True)
    assert settling.settled("window", {**after, "window": "off"})  # its report has not come yet
    assert settling.settled("window", after)  # the home as the switch left it
    assert settling.settled("window", {**after, "temperature": "30.2"})  # at the edge: hovering
    assert settling.settled("window", {**after, "time": "20:30"})  # the same evening bin
    assert not settling.settled("window", {**after, "behavior": "eat"})  # the situation moved
    assert not settling.settled("window", after)  # and the device is given back for good
    settling.switched("curtain", False)
    assert settling.settled("curtain", after)
    assert not settling.settled("curtain", {**after, "time": "21:00"})  # another clock bin
    settling.switched("curtain", False)
    assert settling.settled("curtain", after)
    assert not settling.settled("curtain", {**after, "curtain": "on"})  # someone switched it since


def test_the_journal_finds_the_latest_switch_of_a_device_within_the_window():
    journal = Journal(keep=3)
    first = journal.add(at=0.0, services=["RadioOn"], switches=[("radio", True)], context={}, user="u")
    assert journal.undoable("radio", False, at=100.0, window=900) == (first, "radio")
    journal.add(at=200.0, services=["RadioOff"], switches=[("radio", False)], context={}, user="u")
    assert journal.undoable("radio", False, at=300.0, window=900) is None  # its latest: off already
    assert journal.undoable("radio", True, at=300.0, window=900)[0].services == ["RadioOff"]
    assert journal.undoable("radio", True, at=1200.0, window=900) is None
    for t in (400.0, 500.0):
        journal.add(at=t, services=[], switches=[], context={}, user="u")
    assert journal.get(first.id) is None and [a.at for a in journal.recent(5)] == [500.0, 400.0, 200.0]


# -- partial evidence -----------------------------------------------------------------------------
@pytest.mark.parametrize("partial", [False, True])
def test_corrections_refine_the_shared_answer_on_its_side_and_as_far_as_they_reach(partial):
    learner = ServiceLearner(n_atoms=3, numeric={}, order=2)
    for code in range(5):  # five times wanted where the shared knowledge did not propose it
        learner.add([None, None, None], [code, 0, 0], True, shared=False, partial=partial)
    assert learner.decide([None, None, None], [9, 0, 0], shared=False).sign == 1  # 0 varied: free
    assert learner.decide([None, None, None], [9, 1, 0], shared=False).sign == 0  # 1 never did
    # a correction says nothing where the shared answer is already yes
    assert learner.decide([None, None, None], [9, 0, 0], shared=True).sign == 0
    assert all(2 in k for k in learner.backoff())


# -- what the household teaches ---------------------------------------------------------------
def test_a_persons_switch_is_learned_for_the_next_cognition(stored, tmp_path):
    runtime = make_runtime(stored, tmp_path)
    before = runtime.context()
    runtime.set_context({"activity": "relax", "light": 300})
    relax = runtime.context()
    assert "RadioOn" in runtime.cognize(relax, "default")["services"]
    runtime.source.switch("radio", False)  # nobody commanded it: a person; it was off already
    runtime.source.switch("radio", True)
    runtime.source.switch("desk_lamp", True)  # a person switches the lamp on while relaxing
    assert runtime.guidance.counts["observed"] == 2
    assert kinds(runtime)[-1] == ("observed", ["LampOn"], ["LampOn"], "default")
    assert "LampOn" not in runtime.cognize(relax, "kim")["services"]  # the shared knowledge
    answer = runtime.cognize({**relax, "desk_lamp": "off"}, "default")
    assert "LampOn" in answer["services"]
    lamp = next(e for e in answer["explanations"] if e["service"] == "LampOn")
    assert lamp["user"] == "default" and lamp["evidence"]["agreed"] == 5  # a switch: five corrections' worth
    assert runtime.holds.held("desk_lamp", runtime.context(), at=runtime.source.clock())
    assert before["activity"] == "work"


def test_the_robots_own_switch_teaches_nothing_and_a_person_undoing_it_rejects_it(stored, tmp_path):
    runtime = make_runtime(stored, tmp_path)
    now = runtime.context()
    assert "RaiseBlind" in runtime.cognize(now, "default")["services"]
    done = runtime.act(now, ["RaiseBlind"])
    assert done.done == [("switch_iot", "blind", "on")] and kinds(runtime) == []
    action = runtime.journal.recent(1)[0]
    assert action.switches == [("blind", True)] and action.why[0]["service"] == "RaiseBlind"
    runtime.source.switch("blind", False)  # a person switches it back at once
    assert kinds(runtime) == [("undo", [], ["RaiseBlind"], "default")]
    assert action.undone == {"blind": "person"}
    assert "RaiseBlind" not in runtime.cognize(now, "default")["services"]
    assert "RaiseBlind" in runtime.cognize(now, "kim")["services"]  # for that user only
    # never fight: the robot leaves the blind alone while the situation is the same
    live = replace(runtime.space.point(now), recent=runtime.moments.recent(runtime.context()))
    runtime.tree.correct_one(live, ["RaiseBlind"], "default", concerns=["RaiseBlind"], weight=5)
    assert "RaiseBlind" in runtime.cognize(runtime.context(), "default")["services"]
    assert runtime.act_now("default") is None and runtime.context()["blind"] == "off"
    assert runtime.status()["left_alone"] >= 1 and runtime.status()["fights"] == 0


def test_what_teaches_nothing_is_counted_and_never_learned(stored, tmp_path):
    runtime = make_runtime(stored, tmp_path)
    context, at = runtime.context(), runtime.source.clock()
    tell = runtime._changed
    tell(DeviceChange("radio", True, context, at, automation=True))
    tell(DeviceChange("blind", True, context, at - 3600))  # a clock that went back an hour
    tell(DeviceChange("desk_lamp", True, None, at))  # the context not complete yet
    for k in range(5):  # a state that flaps several times a second: only the first switch counts
        tell(DeviceChange("radio", k % 2 == 0, {**context, "radio": "on" if k % 2 else "off"}, at + k * 0.2))
    tell(DeviceChange("radio", False, context, at + 0.8 + QUIET_SECONDS - 1))  # not still long enough
    counts = runtime.guidance.counts
    assert counts == {
        "automation": 1,
        "clock_back": 1,
        "incomplete_context": 1,
        "observed": 1,
        "flapping": 5,
    }
    assert [k for k, *_ in kinds(runtime)] == ["observed"]
    assert runtime.household_switches == 9


def test_people_are_learned_for_their_own_users_and_strangers_not(stored, tmp_path):
    home = load_home_text(STUDIO + "household: {users: {ha-ann: ann}, hold: 1}\n", "studio.yaml")
    runtime = make_runtime(stored, tmp_path, home)
    context, at = runtime.context(), runtime.source.clock()
    runtime._changed(DeviceChange("radio", True, context, at, user="ha-ann"))
    runtime._changed(DeviceChange("blind", True, context, at + 10, user="ha-someone"))
    assert [(k, u) for k, _, _, u in kinds(runtime)] == [("observed", "ann")]
    assert runtime.guidance.counts["unknown_person"] == 1
    assert runtime.holds.held("blind", context, at=at + 30)  # not learned, but left alone
    moved = {**context, "activity": "sleep"}
    assert not runtime.holds.held("blind", moved, at=at + 80)  # a one-minute hold, and it moved


def test_a_situation_lived_through_teaches_what_was_left_alone(stored, tmp_path):
    runtime = make_runtime(stored, tmp_path)
    runtime.source.clock = lambda: 0.0  # type: ignore[method-assign]
    runtime.act_now("default")  # the robot raises the blind and so on while the user works
    runtime.source.clock = lambda: 1000.0  # type: ignore[method-assign]
    runtime.act_now("default")
    left = runtime.context()  # the home as the work situation leaves it
    runtime.source.set_context({"activity": "relax"})
    runtime.source.clock = lambda: 1700.0  # type: ignore[method-assign]
    runtime.act_now("default")  # the work situation lasted 700 s and ended
    quiet = [c for c in correction_history(runtime.store).corrections if c.note and c.note.get("quiet")]
    assert len(quiet) == 1 and quiet[0].want == [] and quiet[0].kind == "observed"
    assert (
        set(quiet[0].concerns)
        == {
            s.name
            for s in runtime.home.services
            if len(s.sets) == 1 and (left[s.sets[0][0]] == "on") != s.sets[0][1]
        }
        - set()
    )  # every switch service that would change a device as the work situation left it


def test_the_log_keeps_the_kinds_through_a_reload_and_a_rebuild(stored, tmp_path):
    runtime = make_runtime(stored, tmp_path)
    now = runtime.context()
    runtime.act(now, ["RaiseBlind"])
    runtime.source.switch("blind", False)  # undo
    runtime.source.switch("radio", True)  # observed
    runtime.correct(Correction.whole("kim", runtime.space.point(now), ["BringTea"]))  # explicit
    assert [k for k, *_ in kinds(runtime)] == ["undo", "observed", "explicit"]
    for tree in (runtime.store.load_tree(), core.rebuild(runtime.store)):
        for user in ("default", "kim"):
            for ctx in (now, {**now, "activity": "relax"}, {**now, "radio": "on", "blind": "on"}):
                assert tree.predict_one(runtime.space.point(ctx), user) == runtime.tree.predict_one(
                    runtime.space.point(ctx), user
                )


# -- the HTTP API ---------------------------------------------------------------------------------
def test_the_actions_and_their_undo_over_http(stored, tmp_path):
    runtime = make_runtime(stored, tmp_path)
    client = TestClient(create_app(runtime))
    assert client.get("/api/actions").json()["actions"] == []
    runtime.act(runtime.context(), ["RaiseBlind"])
    answer = client.get("/api/actions", params={"limit": 5}).json()
    (action,) = answer["actions"]
    assert action["services"] == ["RaiseBlind"]
    assert action["switches"] == [{"device": "blind", "state": "on"}] and not action["undone_here"]
    assert answer["household"]["household_switches"] == 0
    undone = client.post(f"/api/actions/{action['id']}/undo", json={"user": "kim"})
    assert undone.status_code == 200, undone.text
    assert undone.json() == {
        "action": action["id"],
        "switched": [{"device": "blind", "state": "off"}],
        "rejected": ["RaiseBlind"],
        "user": "kim",
    }
    assert runtime.context()["blind"] == "off" and runtime.household_switches == 0  # the robot's switch
    history = client.get("/api/history").json()["corrections"]
    assert [(c["kind"], c["user"], c["concerns"]) for c in history] == [("undo", "kim", ["RaiseBlind"])]
    assert client.get("/api/actions").json()["actions"][0]["undone_here"] is True
    again = client.post(f"/api/actions/{action['id']}/undo")
    assert again.status_code == 409 and again.json() == {"detail": f"action {action['id']} is undone already"}
    missing = client.post("/api/actions/999/undo")
    assert missing.status_code == 404 and missing.json()["detail"] == "no action 999 among the robot's latest"
    assert client.post(f"/api/actions/{action['id']}/undo", json={"user": ""}).status_code == 422
    assert client.get("/api/actions", params={"limit": 0}).status_code == 422


# -- home files ------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("section", "message"),
    [
        ("household: {hold: -5}", "household.hold: -5 minutes; expected 0 to 1440"),
        (
            "household: {weights: {observed: 0}}",
            "household.weights.observed: 0; expected a whole number from 1 to 100",
        ),
        (
            "household: {weights: {told: 2}}",
            "household.weights.told: unknown kind; expected one of explicit, observed, undo",
        ),
        (
            "household: {often: 1}",
            "household.often: unknown key; expected one of undo_window, hold, weights, users, default_user",
        ),
        (
            "household: {users: [ann]}",
            "household.users: expected a mapping of people's ids to homecog user names",
        ),
    ],
)
def test_a_bad_household_section_names_the_key(section, message):
    with pytest.raises(HomeFileError) as e:
        load_home_text(STUDIO + section + "\n", "studio.yaml")
    assert str(e.value) == f"studio.yaml: {message}"


def test_eval_days_is_one_json_object_and_refuses_two_evaluations(capsys):
    from homecog.cli.main import main

    studio, kim = str(HOMES / "studio.yaml"), str(HOMES / "studio_kim.yaml")
    assert main(["eval", "--home", studio, "--truth", kim, "--days", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [d["day"] for d in out["days"]] == [1, 2] and out["summary"]["fights"] == 0
    assert set(out["days"][0]) == {"day", "robot_switches", "reversed", "household_switches", "fights"}
    assert out["robot"]["household_switches"] == sum(d["household_switches"] for d in out["days"])
    assert main(["eval", "--home", studio, "--days", "1", "--corrections", "3"]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        "homecog: error: --days and --corrections are two evaluations; give one"
    ]


def test_up_takes_the_household_flags_over_the_home_file(capsys):
    from homecog.cli.main import main
    from homecog.cli.up import household_settings

    home = load_home_text(STUDIO + "household: {hold: 5, weights: {undo: 4}}\n", "studio.yaml")
    settings = household_settings(home.household, 20, None, 3, None)
    assert (settings.undo_window, settings.hold) == (1200.0, 300.0)
    assert settings.weights == {"explicit": 1, "observed": 3, "undo": 4}
    assert main(["up", "--household", "paper_ann", "--mqtt", "mqtt://127.0.0.1:1"]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        "homecog: error: --household lives in the simulated home; it needs --speed > 0, no broker"
    ]
    assert main(["up", "--household", str(HOMES / "studio.yaml")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("homecog: error: --household ") and "not compatible" in err[0]


def test_eval_days_refuses_a_start_that_is_no_date_before_learning(capsys):
    from homecog.cli.main import main

    studio, kim = str(HOMES / "studio.yaml"), str(HOMES / "studio_kim.yaml")
    assert main(["eval", "--home", studio, "--truth", kim, "--days", "1", "--start", "soon"]) == 2
    captured = capsys.readouterr()
    assert captured.err.strip().splitlines() == [
        "homecog: error: start: not a date and time: 'soon'; expected e.g. '2021-06-21 06:00'"
    ]
    assert "training" not in captured.out + captured.err
    assert main(["eval", "--home", studio, "--start", "2021-03-01 06:00"]) == 2
    assert (
        capsys.readouterr().err.strip() == "homecog: error: --start is the closed loop's; give it with --days"
    )


def test_a_switch_never_reported_is_given_up(paper):
    settling = Settling(paper)
    after = {"time": "19:00", "temperature": "29.8", "illumination": "300", "location": "sofa"}
    after |= {"posture": "sit", "behavior": "watch_tv", "lamp": "off"}
    settling.switched("lamp", True, at=0.0)
    assert settling.settled("lamp", after, at=30.0)  # its report may still come
    assert not settling.settled("lamp", after, at=61.0)  # it never came: the lamp is free again
    assert not settling.settled("lamp", after, at=62.0)


def test_a_home_without_categorical_features_holds_by_the_clock_and_the_hold():
    home = load_home_text(
        """
name: clocked
context:
  time: {kind: clock, bins: {day: ["06:00", "18:00"], night: ["18:00", "06:00"]}}
  light: {kind: numeric, unit: lx, bins: {dim: [0, 200], bright: [200, .inf]}}
devices: {lamp: {}}
services:
  LampOn: {category: on, set: {lamp: on}}
  LampOff: {category: off, set: {lamp: off}}
comfort:
  lamp: [{when: {light: [dim]}, want: on}, {want: off}]
""",
        "clocked.yaml",
    )
    from homecog.robot.holds import Holds

    holds = Holds(home, hold=1800)
    holds.hold("lamp", {"time": "10:00", "light": "50"}, at=0.0)
    assert holds.held("lamp", {"time": "17:00", "light": "50"}, at=25200.0)  # the same day bin
    assert not holds.held("lamp", {"time": "19:00", "light": "50"}, at=32400.0)  # night: given back


def test_a_database_that_fails_stops_neither_the_robot_nor_an_undo_for_good(stored, tmp_path, monkeypatch):
    from homecog.errors import StoreError

    runtime = make_runtime(stored, tmp_path)
    client = TestClient(create_app(runtime))
    runtime.source.clock = lambda: 0.0  # type: ignore[method-assign]
    runtime.act_now("default")
    action = runtime.journal.recent(1)[0]
    real = runtime.store.transaction

    def down(*args, **kwargs):
        raise StoreError("database sqlite:///k.sqlite: cannot use the database: disk I/O error")

    monkeypatch.setattr(runtime.store, "transaction", down)
    runtime.source.set_context({"activity": "relax"})
    runtime.source.clock = lambda: 1000.0  # type: ignore[method-assign]
    assert runtime.tick(0) is not None  # the work situation ended: not learned, the robot goes on
    failed = client.post(f"/api/actions/{action.id}/undo")
    assert failed.status_code == 503 and not action.undone_here and action.undone == {}
    monkeypatch.setattr(runtime.store, "transaction", real)
    done = client.post(f"/api/actions/{action.id}/undo")
    assert done.status_code == 200 and done.json()["rejected"] == action.services
    assert action.undone_here and set(action.undone) == {d for d, _ in action.switches}


def test_the_robot_lives_a_stream_of_moments_and_learns_with_their_recent_past(stored, tmp_path):
    """A person's switch and the robot's own are moments of the stream; what the robot learns
    from the household's hands keeps the recent past of its moment, through a rebuild."""
    runtime = make_runtime(stored, tmp_path)
    runtime.act_now("default")  # the robot's own switches: moments with what it carried out
    acted = runtime.journal.recent(1)[0]
    assert acted.switches
    assert set(acted.services) <= runtime.moments.recent(runtime.context()).previous
    runtime.set_context({"activity": "relax", "light": 300})
    runtime.source.switch("desk_lamp", runtime.context()["desk_lamp"] != "on")  # a person
    wanted = kinds(runtime)[-1][1]
    recent = runtime.moments.recent(runtime.context())
    assert recent.previous == frozenset(wanted)
    assert recent.since_switched("desk_lamp") == "<5"
    assert recent.value("previous activity") == "work"  # the situation before relaxing
    examples = core.rebuild(runtime.store).user_examples("default")
    assert examples[-1].recent is not None
    assert examples[-1].recent.value("weekday") == runtime.moments.now().strftime("%a").lower()
    assert examples[-1].recent.value("minutes in activity") == "<5"
