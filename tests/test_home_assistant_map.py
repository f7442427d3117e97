"""The ``home_assistant`` section of a home file: defaults per domain, value maps,
clock states, and one exact message per mistake naming the file and the key path.
No Home Assistant is needed here (tests/test_home_assistant.py talks to a real one)."""

from __future__ import annotations

from pathlib import Path

import pytest

from homecog.errors import ContextError, HomeFileError
from homecog.home import load_home, load_home_text
from homecog.home.home_assistant import DOMAIN_DEFAULTS, DeviceEntity, feature_value, unknown_entities

HOMES = Path(__file__).parent / "homes"
STUDIO = (HOMES / "studio.yaml").read_text()
SECTION = """
home_assistant:
  features:
    light: {entity: input_number.light}
    activity:
      entity: input_select.activity
      values: {working: work, relaxing: relax}
  devices:
    blind: {entity: cover.blind}
    desk_lamp: light.desk_lamp
    radio: {entity: media_player.radio}
"""


def home_with(section: str = SECTION, **replace: str):
    text = STUDIO + section
    for old, new in replace.items():
        assert old.replace("_", " ") in text or old in text
        text = text.replace(old, new)
    return load_home_text(text, "studio.yaml")


def error(section: str) -> str:
    with pytest.raises(HomeFileError) as e:
        load_home_text(STUDIO + section, "studio.yaml")
    return str(e.value)


def test_defaults_per_domain() -> None:
    m = home_with().home_assistant
    assert [d.device for d in m.devices] == ["blind", "desk_lamp", "radio"]
    blind, lamp, radio = m.devices
    assert (blind.on, blind.off, blind.turn_on, blind.turn_off) == (
        ("open", "opening"),
        ("closed", "closing"),
        "cover.open_cover",
        "cover.close_cover",
    )
    assert (lamp.on, lamp.off, lamp.service(True), lamp.service(False)) == (
        ("on",),
        ("off",),
        ("light", "turn_on"),
        ("light", "turn_off"),
    )
    assert radio.state("playing") is True and radio.state("standby") is False
    for domain in ("light", "switch", "fan", "input_boolean"):
        assert DOMAIN_DEFAULTS[domain] == (("on",), ("off",), f"{domain}.turn_on", f"{domain}.turn_off")
    assert m.entities == (
        "input_number.light",
        "input_select.activity",
        "cover.blind",
        "light.desk_lamp",
        "media_player.radio",
    )


def test_climate_is_on_in_every_mode_but_off() -> None:
    ac = home_with(**{"media_player.radio": "climate.living_room"}).home_assistant.device("radio")
    assert [ac.state(s) for s in ("cool", "heat", "heat_cool", "dry", "off")] == [True] * 4 + [False]
    assert ac.service(True) == ("climate", "turn_on")
    with pytest.raises(ContextError, match=r"^radio: climate.living_room is unavailable$"):
        ac.state("unavailable")


def test_explicit_states_and_services_override_the_defaults() -> None:
    section = SECTION.replace(
        "radio: {entity: media_player.radio}",
        "radio: {entity: climate.radio, on: [cool, heat_cool], off: off, turn_on: script.radio_on, "
        "turn_off: script.radio_off}",
    )
    radio = home_with(section).home_assistant.device("radio")
    assert (radio.on, radio.off, radio.turn_on) == (("cool", "heat_cool"), ("off",), "script.radio_on")
    with pytest.raises(ContextError) as e:
        radio.state("heat")
    assert str(e.value) == "radio: climate.radio state 'heat' is neither on (cool, heat_cool) nor off (off)"


def test_the_section_does_not_change_what_is_learned() -> None:
    assert home_with().content_hash == load_home(HOMES / "studio.yaml").content_hash
    assert load_home(HOMES / "studio.yaml").home_assistant is None


def test_values_map_home_assistant_words_and_keep_the_home_s_own() -> None:
    h = home_with()
    activity = h.home_assistant.feature("activity")
    f = h.feature("activity")
    assert [feature_value(f, activity, s) for s in ("working", "relaxing", "sleep")] == [
        "work",
        "relax",
        "sleep",
    ]
    with pytest.raises(ContextError) as e:
        feature_value(f, activity, "away")
    assert str(e.value) == (
        "activity: input_select.activity: state 'away' is not mapped; expected one of working, relaxing, "
        "work, relax, sleep"
    )


def test_numbers_and_clock_states() -> None:
    h = load_home(HOMES / "studio_ha.yaml")
    light, clock = h.home_assistant.feature("light"), h.home_assistant.feature("time")
    assert feature_value(h.feature("light"), light, "199.5") == "199.5"
    assert feature_value(h.feature("time"), clock, "07:05:59") == "07:06"
    assert feature_value(h.feature("time"), clock, "23:59") == "23:59"
    for state, message in [
        ("unavailable", "light: input_number.light is unavailable"),
        ("unknown", "light: input_number.light is unknown"),
        ("-0.5", "light: input_number.light: -0.5 lx is outside every bin; valid range [0, inf)"),
        ("bright", "light: input_number.light: state 'bright' is not a number in lx"),
        ("nan", "light: input_number.light: state 'nan' is not a number in lx"),
    ]:
        with pytest.raises(ContextError) as e:
            feature_value(h.feature("light"), light, state)
        assert str(e.value) == message
    with pytest.raises(
        ContextError, match=r"^time: input_datetime.clock: state '25:00' is not HH:MM\[:SS\]$"
    ):
        feature_value(h.feature("time"), clock, "25:00")


def test_unknown_entities_are_named_with_the_nearest_existing_ones() -> None:
    m = load_home(HOMES / "studio_ha.yaml").home_assistant
    known = ["input_datetime.clock", "input_number.light_level", "input_select.activity", "cover.blinds"]
    known += ["light.desk_lamp", "input_boolean.radio", "input_number.lights"]
    assert unknown_entities(m, known) == [
        "light: unknown entity 'input_number.light'; nearest: input_number.lights, input_number.light_level",
        "blind: unknown entity 'cover.blind'; nearest: cover.blinds",
    ]
    assert unknown_entities(m, [*known, "input_number.light", "cover.blind"]) == []


@pytest.mark.parametrize(
    ("section", "message"),
    [
        ("home_assistant: [light.x]", "studio.yaml: home_assistant: expected a mapping, got a list"),
        (
            "home_assistant: {sensors: {}}",
            "studio.yaml: home_assistant.sensors: unknown key; expected one of features, devices",
        ),
        (
            SECTION.replace("    light: {entity: input_number.light}\n", ""),
            "studio.yaml: home_assistant.features: no entity for light; every feature but the clock "
            "needs one",
        ),
        (
            SECTION.replace("    desk_lamp: light.desk_lamp\n", "").replace(
                "    radio: {entity: media_player.radio}\n", ""
            ),
            "studio.yaml: home_assistant.devices: no entity for desk_lamp, radio; every device needs one",
        ),
        (
            SECTION + "    fridge: {entity: switch.fridge}\n",
            "studio.yaml: home_assistant.devices.fridge: unknown device 'fridge'; expected one of blind, "
            "desk_lamp, radio",
        ),
        (
            SECTION.replace("light: {entity: input_number.light}", "lux: {entity: sensor.lux}"),
            "studio.yaml: home_assistant.features.lux: unknown feature 'lux'; expected one of time, light, "
            "activity",
        ),
        (
            SECTION.replace("{entity: input_number.light}", "{entity: Light Sensor}"),
            "studio.yaml: home_assistant.features.light.entity: expected an entity id such as "
            "sensor.outdoor_temperature, got the text 'Light Sensor'",
        ),
        (
            SECTION.replace("{entity: input_number.light}", "{sensor: input_number.light}"),
            "studio.yaml: home_assistant.features.light.sensor: unknown key; expected one of entity, "
            "attribute, values",
        ),
        (
            SECTION.replace("{entity: input_number.light}", "{entity: input_number.light, values: {a: dim}}"),
            "studio.yaml: home_assistant.features.light.values: only categorical features map values; "
            "light is numeric",
        ),
        (
            SECTION.replace("relaxing: relax", "relaxing: nap"),
            "studio.yaml: home_assistant.features.activity.values.relaxing: unknown value 'nap'; "
            "expected one of work, relax, sleep",
        ),
        (
            SECTION.replace("{entity: cover.blind}", "{entity: lock.blind}"),
            "studio.yaml: home_assistant.devices.blind: domain 'lock' has no default states; give on and off "
            "(defaults exist for light, switch, fan, input_boolean, media_player, cover, climate)",
        ),
        (
            SECTION.replace("{entity: cover.blind}", "{entity: lock.blind, on: unlocked, off: locked}"),
            "studio.yaml: home_assistant.devices.blind: the robot switches blind (iot: true) but domain "
            "'lock' has no default services; give turn_on and turn_off",
        ),
        (
            SECTION.replace("{entity: cover.blind}", "{entity: cover.blind, on: [open, closed]}"),
            "studio.yaml: home_assistant.devices.blind: state 'closed' is both on and off",
        ),
        (
            SECTION.replace("{entity: cover.blind}", "{entity: cover.blind, off: [closed, unavailable]}"),
            "studio.yaml: home_assistant.devices.blind: state 'unavailable' says nothing about the device; "
            "it is always skipped",
        ),
        (
            SECTION.replace("{entity: cover.blind}", "{entity: cover.blind, turn_on: open the blind}"),
            "studio.yaml: home_assistant.devices.blind.turn_on: expected a service such as light.turn_on, "
            "got the text 'open the blind'",
        ),
        (
            SECTION.replace("{entity: cover.blind}", "{entity: cover.blind, on: []}"),
            "studio.yaml: home_assistant.devices.blind.on: empty list; expected at least one state",
        ),
    ],
)
def test_mistakes_name_the_file_the_key_path_and_what_was_expected(section: str, message: str) -> None:
    assert error(section) == message


def test_a_device_the_robot_does_not_switch_needs_states_only() -> None:
    # desk_lamp has iot: false in the studio: a binary sensor's on/off is enough
    section = SECTION.replace(
        "desk_lamp: light.desk_lamp", "desk_lamp: {entity: binary_sensor.lamp, on: on, off: off}"
    )
    lamp = home_with(section).home_assistant.device("desk_lamp")
    assert lamp == DeviceEntity("desk_lamp", "binary_sensor.lamp", ("on",), ("off",), None, None)
    with pytest.raises(ContextError, match=r"no service switches binary_sensor\.lamp"):
        lamp.service(True)


def test_the_ha_commands_say_what_is_wrong_in_one_line(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """No instance is needed to get these wrong (tests/test_home_assistant.py has the rest)."""
    from homecog.cli.main import main

    monkeypatch.delenv("HOMECOG_HA_TOKEN", raising=False)
    closed = "http://127.0.0.1:9"  # discard: nothing listens there
    studio_ha = str(HOMES / "studio_ha.yaml")
    out = str(tmp_path / "out.yaml")
    cases = [
        (
            ["ha", "scaffold", "--home-assistant", closed, "--out", out],
            "no token for Home Assistant at " + closed,
        ),
        (
            ["ha", "scaffold", "--home-assistant", closed, "--ha-token", "t", "--out", out],
            "Home Assistant at ws://127.0.0.1:9/api/websocket cannot be reached: Cannot connect to host",
        ),
        (
            ["ha", "scaffold", "--home-assistant", "homeassistant.local", "--ha-token", "t", "--out", out],
            "Home Assistant URL 'homeassistant.local': expected http(s)://host:port",
        ),
        (
            ["ha", "scaffold", "--home-assistant", closed, "--out", str(tmp_path)],
            f"--out {tmp_path}: is a directory",
        ),
        (
            ["ha", "history", "--recorder", str(tmp_path / "no.db"), "--home", studio_ha, "--out", out],
            f"recorder {tmp_path / 'no.db'}: no such file",
        ),
        (
            ["ha", "history", "--recorder", "bogus://x", "--home", studio_ha, "--out", out],
            "recorder bogus://x: not a database URL (Can't load plugin: sqlalchemy.dialects:bogus)\n",
        ),
        (
            ["ha", "history", "--recorder", "/dev/zero", "--home", studio_ha, "--out", out],
            "recorder /dev/zero: is a device, not a file\n",
        ),
        (
            ["ha", "history", "--recorder", "x.db", "--home", "paper", "--out", out],
            "paper.yaml: no home_assistant section; see homecog ha scaffold",
        ),
        (
            [
                "ha",
                "history",
                "--recorder",
                "x.db",
                "--home",
                studio_ha,
                "--out",
                out,
                "--since",
                "yesterday",
            ],
            "since 'yesterday': expected an ISO 8601 date or time, e.g. 2024-03-01T07:00",
        ),
    ]
    for argv, message in cases:
        code = main(argv)
        captured = capsys.readouterr()
        assert (code, captured.out) == (2, ""), argv
        assert captured.err.startswith("homecog: error: ") and message in captured.err, captured.err
        assert captured.err.count("\n") == 1, captured.err


def _json() -> object:
    from hypothesis import strategies as st

    scalars = st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=12)
    return st.recursive(
        scalars,
        lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
        max_leaves=12,
    )


def test_scaffold_takes_any_answer_of_an_instance_and_writes_a_home_that_loads():
    """Whatever an instance answers for its states (odd types, odd attributes, numbers too big),
    scaffolding leaves out what it cannot read and writes a file that loads; never a traceback."""
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    from homecog.home.ha_scaffold import scaffold

    odd_attrs = st.dictionaries(
        st.sampled_from(["device_class", "unit_of_measurement", "min", "max", "options"]), _json(), max_size=5
    )
    entity = st.fixed_dictionaries(
        {
            "entity_id": st.sampled_from(
                ["light.a", "sensor.t", "input_number.n", "select.s", "person.p", "x"]
            )
            | _json(),
            "state": _json(),
            "attributes": odd_attrs | _json(),
        }
    )

    @settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(st.lists(entity | _json(), max_size=6) | _json())
    def check(states):
        text, summary = scaffold(states, name="odd")
        load_home_text(text, "odd.yaml")
        assert summary["odd"] <= (len(states) if isinstance(states, list) else 0)

    check()
    _, summary = scaffold(
        [
            {"entity_id": "input_number.n", "attributes": {"min": 0, "max": "9"}},  # max not a number
            {"entity_id": "select.s", "attributes": {"options": "abc"}},  # options not a list
            {"entity_id": "sensor.t", "attributes": {"device_class": ["temperature"]}},
            {"entity_id": "light.hall", "attributes": [1, 2]},  # attributes not a mapping
            {"entity_id": 7},
        ],
        name="odd",
    )
    assert (summary["features"], summary["devices"], summary["odd"]) == (["time"], ["robot_light"], 2)
