"""The short way of giving a context: ``--at``, ``--where``, ``--doing`` and ``NAME=VALUE``
arguments, wherever ``--context`` is taken; the features they find in any home, and one line
naming every name or value that is wrong, with nothing stored."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from homecog.cli.main import main
from homecog.errors import ContextError
from homecog.home import load_home, load_home_text
from homecog.home.roles import clock_feature, role_feature

HOMES = Path(__file__).parent / "homes"
STUDIO = str(HOMES / "studio.yaml")
FULL = "time=08:00,light=500,activity=work,blind=on,desk_lamp=off,radio=off"


def run(capsys: pytest.CaptureFixture[str], argv: list[str]) -> tuple[int, str, str]:
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def one_line_error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    """The one line a refused command prints (its exit status 2, nothing on stdout)."""
    code, out, err = run(capsys, argv)
    assert (code, out) == (2, ""), err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err.removeprefix("homecog: error: ").rstrip("\n")


# -- which feature is which, in any home ----------------------------------------------------------
def test_the_features_are_found_by_their_names_in_any_home():
    paper, studio, flat = load_home("paper"), load_home(STUDIO), load_home(HOMES / "flat.yaml")
    assert [clock_feature(h).name for h in (paper, studio, flat)] == ["time", "time", "clock"]
    assert role_feature(paper, "where", "sofa").name == "location"
    assert role_feature(flat, "where", "kitchen").name == "room"
    assert [role_feature(h, "doing", "x").name for h in (paper, studio, flat)] == [
        "behavior",
        "activity",
        "doing",
    ]


def test_a_feature_of_another_name_is_found_by_its_value_or_refused_by_what_was_looked_for():
    text = (HOMES / "studio.yaml").read_text(encoding="utf-8").replace("activity", "task")
    home = load_home_text(text, "studio.yaml")
    assert role_feature(home, "doing", "relax").name == "task"
    with pytest.raises(ContextError) as e:
        role_feature(home, "where", "sofa")
    assert str(e.value) == (
        "home 'studio' has no feature of where the user is (none is named location, room, place "
        "or where, and none has the value 'sofa')"
    )
    twice = text.replace(
        "light:\n    kind: numeric",
        "mood: {kind: categorical, values: [work, calm]}\n  light:\n    kind: numeric",
    )
    with pytest.raises(ContextError) as e:
        role_feature(load_home_text(twice, "studio.yaml"), "doing", "work")
    assert str(e.value).endswith("and mood, task all have the value 'work')")
    with pytest.raises(ContextError) as e:
        clock_feature(load_home(HOMES / "den.yaml"))
    assert str(e.value) == "home 'den' has no clock feature"


# -- the same answer as --context ------------------------------------------------------------------
def cognize_json(capsys: pytest.CaptureFixture[str], *args: str) -> dict:
    code, out, err = run(capsys, ["cognize", "--home", STUDIO, "--json", *args])
    assert code == 0, err
    return json.loads(out)


def test_the_short_way_answers_as_the_whole_context_it_stands_for(capsys):
    short = cognize_json(capsys, "--at", "08:00", "--doing", "work", "light=500", "blind=on")
    assert short == cognize_json(capsys, "--context", FULL)
    assert short["services"]  # an answer to compare, not two empty ones
    # over --context it changes what it names, and nothing else
    night = cognize_json(capsys, "--context", FULL, "--at", "23:00")
    assert night == cognize_json(capsys, "--context", FULL.replace("08:00", "23:00"))
    assert night != short
    # alone, a feature it leaves out is unknown and a device off; the text says so
    code, out, err = run(capsys, ["cognize", "--home", STUDIO, "--doing", "sleep", "radio=on"])
    assert code == 0, err
    assert out.splitlines()[0] == "assumed: time, light unknown; every other device off"
    assert cognize_json(capsys, "--doing", "sleep", "radio=on") == cognize_json(
        capsys, "--context", "time=unknown,light=unknown,activity=sleep,blind=off,desk_lamp=off,radio=on"
    )


def test_correct_and_plan_take_the_short_way(capsys, tmp_path):
    db = f"sqlite:///{tmp_path / 'k.sqlite'}"
    code, out, err = run(
        capsys,
        [
            "correct",
            "--home",
            STUDIO,
            "--db",
            db,
            "--at",
            "20:00",
            "--doing",
            "sleep",
            "--add",
            "BringTea",
            "--json",
        ],
    )
    assert code == 0, err
    assert json.loads(out)["added"] == ["BringTea"]
    after = cognize_json(capsys, "--db", db, "--at", "20:00", "--doing", "sleep")
    assert "BringTea" in after["services"]
    plans = []
    for where in (
        ["--where", "sofa"],
        [
            "--context",
            "time=22:00,temperature=19,illumination=200,location=sofa,"
            "posture=sit,behavior=read,window=off,curtain=off,tv_living=off,tv_bedroom=off,"
            "ac_living=off,ac_bedroom=off,lamp=off,ceiling_light=off",
        ],
    ):
        code, out, err = run(capsys, ["plan", "--services", "SendDrinks", *where, "--json"])
        assert code == 0, err
        plans.append(json.loads(out)["actions"])
    assert plans[0] == plans[1] and ["move", "dispenser", "sofa"] in plans[0]
    # what a short context leaves out is the plan's default (the user at the first place), not
    # an unknown place
    for args in (["--at", "20:00"], []):
        code, out, err = run(capsys, ["plan", "--services", "SendDrinks", *args, "--json"])
        assert code == 0, err
        plans.append(json.loads(out)["actions"])
    assert plans[2] == plans[3] and ["move", "dispenser", "table"] in plans[2]


# -- bad input: one line naming all that is wrong, nothing stored ----------------------------------
@pytest.mark.parametrize(
    ("args", "message"),
    [
        pytest.param(
            ["mood=happy", "weather=rain", "--at", "08:00"],
            "unknown features 'mood', 'weather' of home 'studio' (features: time, light, activity; "
            "devices: blind, desk_lamp, radio)",
            id="unknown-features",
        ),
        pytest.param(
            ["--doing", "dance"],
            "--doing dance: activity: unknown value 'dance'; expected one of work, relax, sleep",
            id="unknown-value-of-an-option",
        ),
        pytest.param(
            ["activity=dance", "radio=maybe", "light=dim"],
            "activity: unknown value 'dance'; expected one of work, relax, sleep; radio: unknown state "
            "'maybe'; expected on or off; light: not a number: 'dim'",
            id="unknown-values-of-pairs",
        ),
        pytest.param(
            ["--at", "25:00"],
            "--at 25:00: time: time '25:00' out of range; expected 00:00 to 24:00",
            id="bad-time",
        ),
        pytest.param(["relax"], "'relax' is not NAME=VALUE", id="not-a-pair"),
        pytest.param(
            ["--at", "08:00", "time=09:00"], "time given twice (--at 08:00 and time=09:00)", id="given-twice"
        ),
        pytest.param(
            ["--where", "desk"],
            "--where desk: home 'studio' has no feature of where the user is (none is named location, "
            "room, place or where, and none has the value 'desk'); give it as NAME=VALUE",
            id="no-location-feature",
        ),
        pytest.param(
            [],
            "no context: give --context with every feature and device, or the short way: --at HH:MM, "
            "--where PLACE, --doing ACTIVITY and NAME=VALUE arguments",
            id="no-context",
        ),
    ],
)
def test_bad_short_contexts_are_one_line(capsys, args, message):
    assert one_line_error(capsys, ["cognize", "--home", STUDIO, *args]) == message


def test_a_home_without_the_features_says_so_for_each(capsys):
    den = str(HOMES / "den.yaml")
    assert one_line_error(capsys, ["cognize", "--home", den, "--at", "20:00"]) == (
        "--at 20:00: home 'den' has no clock feature; give it as NAME=VALUE"
    )


def test_a_refused_correction_stores_nothing(capsys, tmp_path):
    db = f"sqlite:///{tmp_path / 'k.sqlite'}"
    base = ["correct", "--home", STUDIO, "--db", db, "--add", "RadioOn", "--json"]
    code, out, err = run(capsys, [*base, "--doing", "relax"])
    assert code == 0, err
    stored = json.loads(out)["experiences"]
    assert one_line_error(capsys, [*base, "--doing", "relax", "mood=calm"]).startswith(
        "unknown feature 'mood'"
    )
    assert one_line_error(capsys, [*base, "--doing", "nap"]).startswith(
        "--doing nap: activity: unknown value"
    )
    code, out, err = run(capsys, [*base, "--doing", "work"])
    assert code == 0, err
    assert json.loads(out)["experiences"] == stored + 1  # the refused ones stored nothing
    assert one_line_error(capsys, ["correct", "--home", STUDIO, "--events", "e.csv", "--at", "08:00"]) == (
        "--events learns a file: give it without a context, --want, --add or --reject"
    )
