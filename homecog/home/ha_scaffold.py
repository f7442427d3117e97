"""``homecog ha scaffold``: a first home file from a Home Assistant instance's entities,
for the user to edit.

- Context features: the clock (``time``, the local clock); numeric sensors by device class
  (temperature, illuminance, humidity, CO₂) with default bins in their unit; ``input_number``
  helpers cut into three bins over their range; ``input_select``/``select`` entities as
  categories (their options, with names made safe where needed); people (``person``, where
  something tracks them) at home or away; occupancy, motion and presence sensors, and door and window sensors.
- Devices: every entity of a domain with defaults (light, switch, fan, input_boolean,
  media_player, cover, climate), each with a service each way (``TurnOnHallLight``,
  ``OpenBlind``, …).
- Rules: a light is off at night and when nobody is home, on when it is dark (or in the evening
  without a light sensor); a cover is open by day and closed at night; a climate device is on
  when it is too hot or too cold. Everything else is "don't care" until the user says more.

>>> states = [
...     {"entity_id": "sensor.hall_lux", "state": "120", "attributes": {"device_class": "illuminance",
...      "unit_of_measurement": "lx"}},
...     {"entity_id": "input_select.mode", "state": "Movie time", "attributes": {"options": ["Day",
...      "Movie time"]}},
...     {"entity_id": "light.hall", "state": "off", "attributes": {}},
...     {"entity_id": "cover.blind", "state": "open", "attributes": {}},
... ]
>>> text, summary = scaffold(states, name="flat")
>>> summary["features"], summary["services"]
(['time', 'mode', 'hall_lux'], ['OpenBlind', 'CloseBlind', 'TurnOnHall', 'TurnOffHall'])
>>> from homecog.home import load_home_text
>>> load_home_text(text).home_assistant.feature("mode").values
(('Day', 'day'), ('Movie time', 'movie_time'))
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import Any

import yaml

from homecog.home.home_assistant import DOMAIN_DEFAULTS, NO_READING
from homecog.home.validator import load_home_text

INF = math.inf
CLOCK_BINS = {"night": ["22:00", "06:00"], "morning": ["06:00", "12:00"], "afternoon": ["12:00", "18:00"],
              "evening": ["18:00", "22:00"]}  # fmt: skip
# device class -> (unit, bins) in that unit; temperatures are converted for °F sensors
SENSOR_BINS: dict[str, tuple[str, dict[str, list[float]]]] = {
    "temperature": ("°C", {"cold": [-INF, 18], "comfortable": [18, 26], "hot": [26, INF]}),
    "illuminance": ("lx", {"dark": [-INF, 100], "dim": [100, 550], "bright": [550, INF]}),
    "humidity": ("%", {"dry": [-INF, 30], "comfortable": [30, 60], "humid": [60, INF]}),
    "carbon_dioxide": ("ppm", {"fresh": [-INF, 800], "stale": [800, 1200], "bad": [1200, INF]}),
}
# binary sensor device class -> (off value, on value)
BINARY_VALUES = {
    "occupancy": ("absent", "present"),
    "presence": ("absent", "present"),
    "motion": ("still", "moving"),
    "door": ("closed", "open"),
    "window": ("closed", "open"),
}
SWITCH_WORDS = {"cover": ("Open", "Close")}  # others: TurnOn / TurnOff


def _name(text: str) -> str:
    """A name the home file accepts: letters, digits and _, not starting with a digit.

    >>> _name("Movie time!"), _name("2nd floor")
    ('movie_time', '_2nd_floor')
    """
    name = re.sub(r"[^a-z0-9]+", "_", text.lower()).strip("_") or "x"
    return f"_{name}" if name[0].isdigit() else name


def _camel(name: str) -> str:
    return "".join(part.capitalize() for part in name.split("_") if part) or "Device"


def _unique(name: str, taken: set[str]) -> str:
    out, n = name, 2
    while out in taken:
        out, n = f"{name}_{n}", n + 1
    taken.add(out)
    return out


def _fahrenheit(bins: dict[str, list[float]]) -> dict[str, list[float]]:
    return {k: [v if math.isinf(v) else round(v * 9 / 5 + 32, 1) for v in b] for k, b in bins.items()}


#: what of an instance's answer is read: its first entities, each option and unit this long
MAX_ENTITIES, MAX_OPTIONS, MAX_TEXT = 10_000, 100, 100
ENTITY_ID = re.compile(r"[a-z_]{1,64}\.[a-z0-9_]{1,190}")


def entities(states: object) -> tuple[list[dict[str, Any]], int]:
    """The entity states as scaffolding reads them, and how many it left out as odd: an entity
    id that is not ``domain.object_id``, attributes that are not a mapping; of the attributes
    only a text ``device_class`` and ``unit_of_measurement``, finite numbers ``min`` and
    ``max``, and ``options`` of a few texts or numbers (beyond :data:`MAX_ENTITIES`, none).

    >>> entities([{"entity_id": "light.hall", "attributes": {"min": "3", "options": "ab"}}, 7, {}])
    ([{'entity_id': 'light.hall', 'state': None, 'attributes': {}}], 2)
    """
    if not isinstance(states, list):
        return [], 0
    kept, odd = [], 0
    for s in states[:MAX_ENTITIES]:
        entity = s.get("entity_id") if isinstance(s, Mapping) else None
        attrs = s.get("attributes") or {} if isinstance(s, Mapping) else None
        if not isinstance(entity, str) or not ENTITY_ID.fullmatch(entity) or not isinstance(attrs, Mapping):
            odd += 1
            continue
        state = s.get("state")
        kept.append(
            {
                "entity_id": entity,
                "state": state if isinstance(state, str) else None,
                "attributes": _attrs(attrs),
            }
        )
    return kept, odd + max(0, len(states) - MAX_ENTITIES)


def _attrs(attrs: Mapping[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key in ("device_class", "unit_of_measurement"):
        if isinstance(attrs.get(key), str) and len(attrs[key]) <= MAX_TEXT:
            out[key] = attrs[key]
    for key in ("min", "max"):
        value = attrs.get(key)
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        if number and math.isfinite(value) and abs(value) < 1e15:
            out[key] = value
    options = attrs.get("options")
    few = isinstance(options, list) and 0 < len(options) <= MAX_OPTIONS
    if few and all(_option(o) for o in options):
        out["options"] = list(options)
    return out


def _option(o: object) -> bool:
    return isinstance(o, (str, int, float)) and not isinstance(o, bool) and len(str(o)) <= MAX_TEXT


def _feature_of(state: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any], str | None] | None:
    """The context feature an entity's state makes, if any: its spec in ``context``, its mapping
    in ``home_assistant.features`` and what it is for the rules (``None``: nothing to them)."""
    entity = state["entity_id"]
    domain = entity.partition(".")[0]
    attrs = state.get("attributes") or {}
    device_class = attrs.get("device_class")
    if domain == "sensor" and device_class in SENSOR_BINS:
        return _sensor(attrs, device_class), {"entity": entity}, device_class
    if domain == "input_number" and "min" in attrs and "max" in attrs and attrs["max"] > attrs["min"]:
        return _input_number(attrs), {"entity": entity}, None
    if domain in ("input_select", "select") and attrs.get("options"):
        return _select(entity, attrs)
    if domain == "person" and state.get("state") not in NO_READING:  # a person without trackers
        return (
            {"kind": "categorical", "values": ["home", "away"]},
            {"entity": entity, "values": {"not_home": "away"}},
            "person",
        )
    if domain == "binary_sensor" and device_class in BINARY_VALUES:
        off, on = BINARY_VALUES[device_class]
        return (
            {"kind": "categorical", "values": [off, on]},
            {"entity": entity, "values": {"off": off, "on": on}},
            None,
        )
    return None


def _sensor(attrs: Mapping[str, Any], device_class: str) -> dict[str, Any]:
    unit, bins = SENSOR_BINS[device_class]
    given = attrs.get("unit_of_measurement")
    if device_class == "temperature" and given == "°F":
        unit, bins = "°F", _fahrenheit(bins)
    return {"kind": "numeric", "unit": given or unit, "bins": bins}


def _input_number(attrs: Mapping[str, Any]) -> dict[str, Any]:
    low, high = float(attrs["min"]), float(attrs["max"])
    a, b = (round(low + (high - low) * k / 3, 3) for k in (1, 2))
    spec: dict[str, Any] = {"kind": "numeric", "bins": {"low": [-INF, a], "medium": [a, b], "high": [b, INF]}}
    if attrs.get("unit_of_measurement"):
        spec["unit"] = attrs["unit_of_measurement"]
    return spec


def _select(entity: str, attrs: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any], None]:
    options = [str(o) for o in attrs["options"]]
    values = list(dict.fromkeys(_name(o) for o in options))
    fmap: dict[str, Any] = {"entity": entity}
    words = {o: _name(o) for o in options if _name(o) != o}
    if words:
        fmap["values"] = words
    return {"kind": "categorical", "values": values}, fmap, None


def scaffold(states: object, *, name: str = "my_home") -> tuple[str, dict[str, Any]]:
    """The YAML text of a home file for these entity states, and what it holds
    (``features``, ``devices``, ``services``: lists of names; ``odd``: entities left out, as
    :func:`entities` reads them). The text always loads."""
    states, odd = entities(states)
    taken: set[str] = {"time"}
    context: dict[str, Any] = {"time": {"kind": "clock", "bins": CLOCK_BINS}}
    fmaps: dict[str, Any] = {}
    devices: dict[str, Any] = {}
    dmaps: dict[str, Any] = {}
    services: dict[str, Any] = {}
    kinds: dict[str, str] = {}  # feature -> what it is, for the rules
    for state in sorted(states, key=lambda s: s["entity_id"]):
        entity = state["entity_id"]
        domain, _, object_id = entity.partition(".")
        made = _feature_of(state)
        if made is not None:
            feature = _unique(_name(object_id), taken)
            context[feature], fmaps[feature], kind = made
            if kind is not None:
                kinds[feature] = kind
        elif domain in DOMAIN_DEFAULTS:
            device = _unique(_name(object_id), taken)
            devices[device] = {"iot": True}
            dmaps[device] = {"entity": entity}
            kinds[device] = domain
            on_word, off_word = SWITCH_WORDS.get(domain, ("TurnOn", "TurnOff"))
            camel = _camel(device)
            services[f"{on_word}{camel}"] = {"category": "switch_on", "set": {device: "on"}}
            services[f"{off_word}{camel}"] = {"category": "switch_off", "set": {device: "off"}}
    if not devices:
        # a home needs a device to learn; the user replaces this one
        devices["robot_light"] = {"iot": False}
        dmaps["robot_light"] = {"entity": "input_boolean.robot_light", "on": "on", "off": "off"}
        services["TurnOnRobotLight"] = {"category": "switch_on", "set": {"robot_light": "on"}}
        services["TurnOffRobotLight"] = {"category": "switch_off", "set": {"robot_light": "off"}}
    home = {
        "name": _name(name),
        "description": "Written by homecog ha scaffold from a Home Assistant instance; edit it.",
        "context": context,
        "devices": devices,
        "services": services,
        "comfort": _comfort(devices, kinds),
        "home_assistant": {"features": fmaps, "devices": dmaps},
    }
    text = HEADER + yaml.safe_dump(
        home, sort_keys=False, allow_unicode=True, width=110, default_flow_style=None
    )
    load_home_text(text, f"{name}.yaml")  # what it writes must load
    return text, {"features": list(context), "devices": list(devices), "services": list(services), "odd": odd}


def _comfort(devices: Mapping[str, Any], kinds: Mapping[str, str]) -> dict[str, list[dict[str, Any]]]:
    """Starting rules: see the module docstring."""
    first = {
        k: next((f for f, v in kinds.items() if v == k), None)
        for k in ("illuminance", "temperature", "person")
    }
    comfort: dict[str, list[dict[str, Any]]] = {}
    for device in devices:
        kind = kinds.get(device)
        rules: list[dict[str, Any]] = []
        if kind == "light":
            rules.append({"when": {"time": ["night"]}, "want": "off"})
            if first["person"]:
                rules.append({"when": {first["person"]: ["away"]}, "want": "off"})
            dark = {first["illuminance"]: ["dark"]} if first["illuminance"] else {"time": ["evening"]}
            rules += [{"when": dark, "want": "on"}, {"want": "off"}]
        elif kind == "cover":
            rules = [
                {"when": {"time": ["night"]}, "want": "off"},
                {"when": {"time": ["morning", "afternoon"]}, "want": "on"},
            ]
        elif kind == "climate" and first["temperature"]:
            rules = [{"when": {first["temperature"]: ["cold", "hot"]}, "want": "on"}, {"want": "off"}]
        if rules:
            comfort[device] = rules
    return comfort


HEADER = """\
# A first home file from a Home Assistant instance (homecog ha scaffold). Edit it before the robot
# learns from it: remove what does not matter, name the rooms, set the bins, and write the rules
# (comfort: the state each device should be in; needs: the services the user wants; prohibited:
# what the robot must never do). docs/home-file.md says what each key means; check it with homecog home check.
"""
