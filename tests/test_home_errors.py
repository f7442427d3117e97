"""Bad home files fail with one exact message naming the file, the key path and what was expected.

The contract: every error names the file, the key path and what was expected. Each bad case
takes the valid home ``SMALL`` below (or the paper's own text), breaks one thing and checks
the whole message of the :class:`HomeFileError`. The positive cases pin down what must load:
YAML 1.1 booleans as device states, ``yes``/``no`` as category names, ``"HH:MM"`` clock bins,
clock bins wrapping midnight and the half-open bins of the paper home.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml

from homecog.errors import ContextError, HomeFileError
from homecog.home import Home, load_home, load_home_text
from homecog.home.home_file import resolve_home

HOMES = Path(__file__).parent / "homes"

# A compact valid home, modelled on tests/homes/studio.yaml.
SMALL = """\
name: tiny
context:
  time:
    kind: clock
    bins: {day: ["07:00", "19:00"], night: ["19:00", "07:00"]}
  light:
    kind: numeric
    unit: lx
    bins: {dim: [0, 200], bright: [200, .inf]}
  activity: {kind: categorical, values: [work, relax, sleep]}
devices:
  blind: {room: studio}
  lamp: {room: studio, iot: false}
services:
  RaiseBlind: {category: open, set: {blind: on}}
  LowerBlind: {category: close, set: {blind: off}}
  LampOn: {category: open, set: {lamp: on}}
  LampOff: {category: close, set: {lamp: off}}
  BringTea: {category: care}
comfort:
  blind:
    - {when: {time: [night]}, want: off}
    - {want: on}
  lamp:
    - {when: {activity: [work], light: [dim]}, want: on}
    - {want: off}
needs:
  BringTea: [{when: {activity: [work]}}]
prohibited:
  RaiseBlind: [{when: {time: [night]}}]
  LampOn: [{when: {blind: [on]}}]
rewards: {weights: {terminal: 0.5, progress: 0.2, prohibited: 0.3}, magnitude: 10}
"""

SERVICES = "RaiseBlind, LowerBlind, LampOn, LampOff, BringTea"


def _tokens(path: str) -> list[str | int]:
    """``"comfort.lamp[0].when"`` → ``["comfort", "lamp", 0, "when"]``."""
    return [int(t[1:-1]) if t.startswith("[") else t for t in re.findall(r"\[\d+\]|[^.\[\]]+", path)]


def _parent(data: Any, path: str) -> tuple[Any, str | int]:
    *head, last = _tokens(path)
    for key in head:
        data = data[key]
    return data, last


def put(path: str, value: object) -> Callable[[dict[str, Any]], None]:
    """A mutation that sets (or adds) the entry at a key path."""

    def mutate(data: dict[str, Any]) -> None:
        parent, last = _parent(data, path)
        parent[last] = value

    return mutate


def drop(path: str) -> Callable[[dict[str, Any]], None]:
    """A mutation that removes the entry at a key path."""

    def mutate(data: dict[str, Any]) -> None:
        parent, last = _parent(data, path)
        del parent[last]

    return mutate


def broken(mutate: Callable[[dict[str, Any]], None]) -> str:
    """The text of SMALL with one thing broken."""
    data = yaml.safe_load(SMALL)
    mutate(data)
    return yaml.safe_dump(data, sort_keys=False, allow_unicode=True)


def load_error(text: str, source: str = "bad.yaml") -> str:
    with pytest.raises(HomeFileError) as caught:
        load_home_text(text, source=source)
    return str(caught.value)


def test_small_home_is_valid() -> None:
    """The base of every bad case loads, both as written and after a YAML round trip."""
    home = load_home_text(SMALL, source="tiny.yaml")
    assert home.name == "tiny"
    assert home.context_count == 2 * 2 * 3
    assert home.device_names == ("blind", "lamp")
    assert load_home_text(broken(lambda d: None)).content_hash == home.content_hash


# -- text that is not a home at all --------------------------------------------------------------
TEXT_CASES = [
    pytest.param(
        "name: [unclosed",
        "bad.yaml: line 2: not valid YAML: did not find expected ',' or ']'",
        id="not-yaml",
    ),
    pytest.param("", "bad.yaml: is empty; expected a home definition", id="empty-file"),
    pytest.param(
        "# only a comment\n\n", "bad.yaml: is empty; expected a home definition", id="only-comments"
    ),
    pytest.param("- name\n- context\n", "bad.yaml: expected a mapping, got a list", id="top-level-list"),
    pytest.param("paper", "bad.yaml: expected a mapping, got the text 'paper'", id="top-level-text"),
]


@pytest.mark.parametrize(("text", "message"), TEXT_CASES)
def test_not_a_home(text: str, message: str) -> None:
    assert load_error(text) == message


def test_duplicate_key_names_its_line() -> None:
    lines = SMALL.splitlines()
    at = lines.index("  lamp: {room: studio, iot: false}")
    lines.insert(at + 1, "  lamp: {room: hall}")
    assert load_error("\n".join(lines)) == (f"bad.yaml: line {at + 2}: not valid YAML: duplicate key 'lamp'")


# -- one thing broken in a valid home ------------------------------------------------------------
BAD_CASES = [
    *(
        pytest.param(drop(section), f"bad.yaml: missing section '{section}'", id=f"missing-{section}")
        for section in ("name", "context", "devices", "services", "comfort")
    ),
    pytest.param(
        put("extras", {"a": 1}),
        "bad.yaml: extras: unknown key; expected one of name, description, context, devices, "
        "services, comfort, needs, prohibited, rewards, layout, routine, home_assistant, household, log",
        id="unknown-section",
    ),
    pytest.param(
        put("name", ""),
        "bad.yaml: name: '' is not a home name: 1 to 64 letters, digits, _ or -, "
        "beginning with a letter or digit",
        id="empty-name",
    ),
    pytest.param(
        put("context", {}), "bad.yaml: context: is empty; expected at least one entry", id="empty-context"
    ),
    pytest.param(
        put("devices", ["blind", "lamp"]),
        "bad.yaml: devices: expected a mapping, got a list",
        id="devices-as-list",
    ),
    # features
    pytest.param(
        put("context.activity.kind", "boolean"),
        "bad.yaml: context.activity.kind: unknown kind 'boolean'; "
        "expected one of clock, numeric, categorical",
        id="bad-feature-kind",
    ),
    pytest.param(
        drop("context.light.kind"), "bad.yaml: context.light: missing key 'kind'", id="missing-feature-kind"
    ),
    pytest.param(
        put("context.activity.values", []),
        "bad.yaml: context.activity.values: empty value list",
        id="empty-categorical-values",
    ),
    pytest.param(
        put("context.activity.values", ["work", "relax", "work"]),
        "bad.yaml: context.activity.values[2]: duplicate value 'work'",
        id="duplicate-categorical-value",
    ),
    pytest.param(
        put("context.light.bins.dim", [200, 0]),
        "bad.yaml: context.light.bins.dim: bins reversed: low 200 is not below high 0",
        id="numeric-bins-reversed",
    ),
    pytest.param(
        put("context.light.bins.dim", [0, 300]),
        "bad.yaml: context.light.bins: bins 'dim' and 'bright' overlap (200 to 300)",
        id="numeric-bins-overlap",
    ),
    pytest.param(
        put("context.light.bins.dim", [0, 100]),
        "bad.yaml: context.light.bins: gap between bins 'dim' and 'bright' (100 to 200)",
        id="numeric-bins-gap",
    ),
    pytest.param(
        put("context.light.bins.dim", [0, "lots"]),
        "bad.yaml: context.light.bins.dim[1]: expected a number, got 'lots'",
        id="numeric-bound-not-a-number",
    ),
    pytest.param(
        put("context.light.bins.dim", [0, 100, 200]),
        "bad.yaml: context.light.bins.dim: expected [low, high], got [0, 100, 200]",
        id="numeric-bin-not-a-pair",
    ),
    pytest.param(
        put("context.time.bins.day", ["07:00", "20:00"]),
        "bad.yaml: context.time.bins: bins 'day' and 'night' overlap (19:00 to 20:00)",
        id="clock-bins-overlap",
    ),
    pytest.param(
        put("context.time.bins.day", ["08:00", "19:00"]),
        "bad.yaml: context.time.bins: gap between bins 'night' and 'day' (07:00 to 08:00)",
        id="clock-bins-gap",
    ),
    pytest.param(
        put("context.time.bins.night", ["19:00", "24:00"]),
        "bad.yaml: context.time.bins: the clock bins leave a gap from 00:00 to 07:00",
        id="clock-bins-miss-early-hours",
    ),
    pytest.param(
        put("context.time.bins.night", ["00:00", "07:00"]),
        "bad.yaml: context.time.bins: the clock bins leave a gap from 19:00 to 24:00",
        id="clock-bins-miss-late-hours",
    ),
    pytest.param(
        put("context.time.bins.day", [7, 7]),
        "bad.yaml: context.time.bins.day: empty bin [7, 7]",
        id="clock-bin-empty",
    ),
    pytest.param(
        put("context.time.bins.day", ["7:75", "19:00"]),
        "bad.yaml: context.time.bins.day[0]: expected hours (7.5 or \"07:30\"), got '7:75'",
        id="clock-bound-bad-minutes",
    ),
    pytest.param(
        put("context.time.bins.day", [7, 25]),
        "bad.yaml: context.time.bins.day[1]: hour 25 out of range; expected 0 to 24",
        id="clock-bound-past-24",
    ),
    # devices and services
    pytest.param(
        put("devices.light", {"room": "studio"}),
        "bad.yaml: devices.light: a device may not share a name with a context feature",
        id="device-named-like-feature",
    ),
    pytest.param(
        put("devices.lamp.iot", "maybe"),
        "bad.yaml: devices.lamp.iot: expected true or false, got 'maybe'",
        id="device-iot-not-bool",
    ),
    pytest.param(
        put("services.LampOn.set.tv", "on"),
        "bad.yaml: services.LampOn.set.tv: unknown device 'tv'; expected one of blind, lamp",
        id="service-sets-unknown-device",
    ),
    pytest.param(
        put("services.LampOn.set.lamp", "dim"),
        "bad.yaml: services.LampOn.set.lamp: unknown state 'dim'; expected on or off",
        id="service-sets-bad-state",
    ),
    pytest.param(
        drop("services.LampOn.category"),
        "bad.yaml: services.LampOn: missing key 'category'",
        id="service-without-category",
    ),
    # comfort
    pytest.param(
        put("comfort.tv", [{"want": "on"}]),
        "bad.yaml: comfort.tv: unknown device 'tv'; expected one of blind, lamp",
        id="comfort-unknown-device",
    ),
    pytest.param(
        put("comfort.lamp[0].when.mood", ["happy"]),
        "bad.yaml: comfort.lamp[0].when.mood: unknown feature 'mood'; expected one of time, light, activity",
        id="comfort-unknown-feature",
    ),
    pytest.param(
        put("comfort.lamp[0].when.activity", ["nap"]),
        "bad.yaml: comfort.lamp[0].when.activity: unknown value 'nap'; expected one of work, relax, sleep",
        id="comfort-unknown-value",
    ),
    pytest.param(
        put("comfort.lamp[0].when.light", ["dark"]),
        "bad.yaml: comfort.lamp[0].when.light: unknown value 'dark'; expected one of dim, bright",
        id="comfort-unknown-bin",
    ),
    pytest.param(
        put("comfort.lamp[0].when.blind", ["on"]),
        "bad.yaml: comfort.lamp[0].when.blind: 'blind' is a device; "
        "these rules use context features only (time, light, activity)",
        id="comfort-names-device",
    ),
    pytest.param(
        put("comfort.lamp[0].when.activity", []),
        "bad.yaml: comfort.lamp[0].when.activity: empty value list",
        id="comfort-empty-value-list",
    ),
    pytest.param(
        put("comfort.lamp[0].want", "maybe"),
        "bad.yaml: comfort.lamp[0].want: expected on or off, got 'maybe'",
        id="want-maybe",
    ),
    pytest.param(
        drop("comfort.lamp[0].want"), "bad.yaml: comfort.lamp[0]: missing key 'want'", id="want-missing"
    ),
    pytest.param(
        put("comfort.lamp[0].unless", {}),
        "bad.yaml: comfort.lamp[0].unless: unknown key; expected one of when, want",
        id="comfort-rule-unknown-key",
    ),
    pytest.param(
        put("comfort.lamp", {"want": "on"}),
        "bad.yaml: comfort.lamp: expected a list of rules, got a mapping",
        id="comfort-rules-not-a-list",
    ),
    # needs
    pytest.param(
        put("needs.Dance", [{"when": {"activity": ["relax"]}}]),
        f"bad.yaml: needs.Dance: unknown service 'Dance'; expected one of {SERVICES}",
        id="needs-unknown-service",
    ),
    pytest.param(
        put("needs.BringTea[0].when.mood", ["happy"]),
        "bad.yaml: needs.BringTea[0].when.mood: unknown feature 'mood'; "
        "expected one of time, light, activity",
        id="needs-unknown-feature",
    ),
    pytest.param(
        put("needs.BringTea[0].when.blind", ["on"]),
        "bad.yaml: needs.BringTea[0].when.blind: 'blind' is a device; "
        "these rules use context features only (time, light, activity)",
        id="needs-names-device",
    ),
    pytest.param(
        put("needs.LampOn", [{"when": {"activity": ["work"]}}]),
        "bad.yaml: needs.LampOn: needs are for interaction services; LampOn sets devices "
        "(its wanted states come from the comfort rules)",
        id="needs-on-device-service",
    ),
    # prohibited
    pytest.param(
        put("prohibited.Dance", [{"when": {"activity": ["relax"]}}]),
        f"bad.yaml: prohibited.Dance: unknown service 'Dance'; expected one of {SERVICES}",
        id="prohibited-unknown-service",
    ),
    pytest.param(
        put("prohibited.RaiseBlind[0].when.mood", ["happy"]),
        "bad.yaml: prohibited.RaiseBlind[0].when.mood: unknown feature 'mood'; "
        "expected one of time, light, activity, blind, lamp",
        id="prohibited-unknown-feature",
    ),
    pytest.param(
        put("prohibited.LampOn[0].when.blind", ["half"]),
        "bad.yaml: prohibited.LampOn[0].when.blind: unknown state 'half'; expected on or off",
        id="prohibited-bad-device-state",
    ),
    # rewards
    pytest.param(
        put("rewards.magnitude", -10),
        "bad.yaml: rewards.magnitude: expected a positive number, got -10",
        id="negative-reward-magnitude",
    ),
    pytest.param(
        put("rewards.magnitude", 0),
        "bad.yaml: rewards.magnitude: expected a positive number, got 0",
        id="zero-reward-magnitude",
    ),
    pytest.param(
        put("rewards.weights.bonus", 1),
        "bad.yaml: rewards.weights.bonus: unknown key; expected one of terminal, progress, prohibited",
        id="unknown-reward-weight",
    ),
    pytest.param(
        put("rewards.weights.terminal", "lots"),
        "bad.yaml: rewards.weights.terminal: expected a number, got 'lots'",
        id="reward-weight-not-a-number",
    ),
]


@pytest.mark.parametrize(("mutate", "message"), BAD_CASES)
def test_broken_home(mutate: Callable[[dict[str, Any]], None], message: str) -> None:
    assert load_error(broken(mutate)) == message


def test_spec_example_message_on_the_paper_home() -> None:
    """The reference's own example: a third lamp rule asking for a behaviour 'nap'."""
    _, text = resolve_home("paper")
    lamp_end = "    - {want: off}\n  ceiling_light:\n"
    assert text.count(lamp_end) == 1
    text = text.replace(
        lamp_end,
        "    - {when: {behavior: [eat]}, want: off}\n    - {when: {behavior: [nap]}, want: off}\n" + lamp_end,
    )
    assert load_error(text, source="paper.yaml") == (
        "paper.yaml: comfort.lamp[2].when.behavior: unknown value 'nap'; "
        "expected one of read, watch_tv, sleep, eat"
    )


# -- files: the path is the source ---------------------------------------------------------------
def test_error_of_a_file_names_its_path(tmp_path: Path) -> None:
    path = tmp_path / "mine.yaml"
    path.write_text(broken(put("comfort.tv", [{"want": "on"}])), encoding="utf-8")
    with pytest.raises(HomeFileError) as caught:
        load_home(path)
    assert str(caught.value) == f"{path}: comfort.tv: unknown device 'tv'; expected one of blind, lamp"


@pytest.mark.parametrize(
    ("name", "message"),
    [
        pytest.param("none.yaml", "{tmp}/none.yaml: no such file", id="no-such-file"),
        pytest.param("", "{tmp}: is a directory, not a home file", id="directory"),
        pytest.param("latin1.yaml", "{tmp}/latin1.yaml: line 1: not UTF-8 text", id="not-utf8"),
    ],
)
def test_unreadable_file(tmp_path: Path, name: str, message: str) -> None:
    (tmp_path / "latin1.yaml").write_bytes("# unit: \xb0C\n".encode("latin-1"))
    with pytest.raises(HomeFileError) as caught:
        load_home(tmp_path / name if name else tmp_path)
    assert str(caught.value) == message.format(tmp=tmp_path)


def test_unknown_home_name() -> None:
    with pytest.raises(HomeFileError) as caught:
        load_home("nope")
    assert str(caught.value) == (
        "unknown home 'nope'; built-in homes: paper, paper_ann, or give the path of a YAML file"
    )


# -- what must load -------------------------------------------------------------------------------
def _with_lamp_rule(want: str) -> str:
    return SMALL.replace("- {when: {activity: [work], light: [dim]}, want: on}", f"- {{want: {want}}}")


@pytest.mark.parametrize(
    ("word", "state"),
    [
        pytest.param("on", True, id="on"),
        pytest.param("off", False, id="off"),
        pytest.param("true", True, id="true"),
        pytest.param("false", False, id="false"),
        pytest.param("yes", True, id="yes"),
        pytest.param("no", False, id="no"),
        pytest.param("On", True, id="On"),
        pytest.param("OFF", False, id="OFF"),
        pytest.param('"on"', True, id="quoted-on"),
    ],
)
def test_want_accepts_yaml_booleans(word: str, state: bool) -> None:
    home = load_home_text(_with_lamp_rule(word), source="tiny.yaml")
    assert home.comfort[home.device_index("lamp")][0].want is state


@pytest.mark.parametrize(
    ("word", "state"),
    [
        pytest.param("off", False, id="off"),
        pytest.param("on", True, id="on"),
        pytest.param("no", False, id="no"),
        pytest.param("yes", True, id="yes"),
        pytest.param("false", False, id="false"),
    ],
)
def test_service_set_accepts_yaml_booleans(word: str, state: bool) -> None:
    text = SMALL.replace(
        "LampOff: {category: close, set: {lamp: off}}", f"Lamp: {{category: x, set: {{lamp: {word}}}}}"
    )
    home = load_home_text(text, source="tiny.yaml")
    assert home.services[home.service_index("Lamp")].sets == (("lamp", state),)


def test_yes_and_no_stay_category_names() -> None:
    text = SMALL.replace(
        "  activity: {kind: categorical, values: [work, relax, sleep]}\n",
        "  activity: {kind: categorical, values: [work, relax, sleep]}\n"
        "  guests: {kind: categorical, values: [yes, no]}\n",
    ).replace("BringTea: [{when: {activity: [work]}}]", "BringTea: [{when: {guests: [yes]}}]")
    home = load_home_text(text, source="tiny.yaml")
    guests = home.feature("guests")
    assert guests.values == ("yes", "no")
    assert guests.discretize("no") == 1
    assert home.needs[home.service_index("BringTea")][0].features == (
        (home.feature_index("guests"), frozenset({0})),
    )


def test_clock_bins_as_quoted_hhmm() -> None:
    studio = load_home(HOMES / "studio.yaml")
    assert studio.feature("time").bins == ((6.5, 19.0), (19.0, 6.5))


def test_clock_bins_as_unquoted_hhmm() -> None:
    """YAML 1.1 would read 19:00 as the base-60 number 1140; a home file means 19:00."""
    text = SMALL.replace('["07:00", "19:00"]', "[07:00, 19:00]").replace(
        '["19:00", "07:00"]', "[19:00, 07:00]"
    )
    assert "19:00]" in text
    home = load_home_text(text, source="tiny.yaml")
    assert home.feature("time").bins == ((7.0, 19.0), (19.0, 7.0))


SPLIT_AT_MIDNIGHT = """\
    bins: {day: ["07:00", "19:00"], evening: ["19:00", "24:00"], night: ["00:00", "07:00"]}
"""


@pytest.mark.parametrize(
    ("reading", "value"),
    [
        pytest.param("07:00", "day", id="07:00"),
        pytest.param("18:59", "day", id="18:59"),
        pytest.param("19:00", "evening", id="19:00"),
        pytest.param("23:59", "evening", id="23:59"),
        pytest.param("24:00", "night", id="24:00"),
        pytest.param("00:00", "night", id="00:00"),
        pytest.param("06:59", "night", id="06:59"),
    ],
)
def test_clock_bins_ending_at_24_and_starting_at_00(reading: str, value: str) -> None:
    text = SMALL.replace(
        '    bins: {day: ["07:00", "19:00"], night: ["19:00", "07:00"]}\n', SPLIT_AT_MIDNIGHT
    )
    time = load_home_text(text, source="tiny.yaml").feature("time")
    assert time.bins == ((7.0, 19.0), (19.0, 0.0), (0.0, 7.0))
    assert time.values[time.discretize(reading)] == value


def test_one_clock_bin_for_the_whole_day() -> None:
    text = (
        SMALL.replace(
            '    bins: {day: ["07:00", "19:00"], night: ["19:00", "07:00"]}\n',
            "    bins: {always: [0, 24]}\n",
        )
        .replace("    - {when: {time: [night]}, want: off}\n", "")
        .replace("RaiseBlind: [{when: {time: [night]}}]", "RaiseBlind: [{when: {time: [always]}}]")
    )
    time = load_home_text(text, source="tiny.yaml").feature("time")
    assert [time.discretize(t) for t in ("00:00", "12:00", "23:59", "24:00")] == [0, 0, 0, 0]


@pytest.fixture(scope="module")
def paper() -> Home:
    return load_home("paper")


@pytest.mark.parametrize(
    ("feature", "reading", "value"),
    [
        pytest.param("time", "21:00", "night", id="21:00-night"),
        pytest.param("time", "20:59", "evening", id="20:59-evening"),
        pytest.param("time", "00:00", "night", id="00:00-night"),
        pytest.param("time", "24:00", "night", id="24:00-night"),
        pytest.param("time", "06:59", "night", id="06:59-night"),
        pytest.param("time", "07:00", "early_morning", id="07:00-early_morning"),
        pytest.param("time", 7, "early_morning", id="7-early_morning"),
        pytest.param("time", "11:30", "noon", id="11:30-noon"),
        pytest.param("temperature", 24.99, "cold", id="24.99C-cold"),
        pytest.param("temperature", 25, "suitable", id="25C-suitable"),
        pytest.param("temperature", "30", "hot", id="30C-hot"),
        pytest.param("temperature", -40, "cold", id="-40C-cold"),
        pytest.param("illumination", 0, "dark", id="0lx-dark"),
        pytest.param("illumination", 99.9, "dark", id="99.9lx-dark"),
        pytest.param("illumination", 100, "suitable", id="100lx-suitable"),
        pytest.param("illumination", 550, "light", id="550lx-light"),
    ],
)
def test_paper_bins_are_half_open(paper: Home, feature: str, reading: object, value: str) -> None:
    f = paper.feature(feature)
    assert f.values[f.discretize(reading)] == value


@pytest.mark.parametrize(
    ("feature", "reading", "message"),
    [
        pytest.param(
            "illumination",
            -5,
            "illumination: -5 lx is outside every bin; valid range [0, inf)",
            id="illumination-below-every-bin",
        ),
        pytest.param(
            "time", "25:00", "time: time '25:00' out of range; expected 00:00 to 24:00", id="time-25:00"
        ),
        pytest.param("temperature", "warm", "temperature: not a number: 'warm'", id="temperature-text"),
        pytest.param(
            "location",
            "kitchen",
            "location: unknown value 'kitchen'; expected one of table, sofa, bed, dining_table",
            id="unknown-location",
        ),
    ],
)
def test_reading_outside_the_feature(paper: Home, feature: str, reading: object, message: str) -> None:
    with pytest.raises(ContextError) as caught:
        paper.feature(feature).discretize(reading)
    assert str(caught.value) == message
