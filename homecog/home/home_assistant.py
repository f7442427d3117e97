"""The ``home_assistant:`` section of a home file: where each feature and device lives in a Home
Assistant instance, and how its states read as the home's values.

.. code-block:: yaml

    home_assistant:
      features:
        time: {entity: input_datetime.clock}          # optional: HH:MM[:SS]; else the local clock
        temperature: {entity: sensor.outdoor_temperature}   # a number in the feature's unit
        behavior:
          entity: input_select.activity
          values: {reading: read, watching TV: watch_tv}      # Home Assistant's words → values
      devices:
        ceiling_light: {entity: light.living_room}    # the domain's defaults: on/off, light.turn_on/off
        ac_living: {entity: climate.living_room, on: [cool, heat_cool]}

Every feature but the clock ones, and every device, must be mapped. A feature may read an
``attribute`` of its entity instead of the state. A device takes its ``on`` and ``off`` states
and its ``turn_on`` and ``turn_off`` services from the defaults of its entity's domain
(:data:`DOMAIN_DEFAULTS`), or from the section; a domain without defaults needs the states,
and the services too when the robot switches the device (``iot: true``). Mapping entities does
not change what the robot learns, so the section is not part of the home's content hash.

>>> from homecog.home import load_home
>>> home = load_home("tests/homes/studio_ha.yaml")
>>> blind = home.home_assistant.device("blind")
>>> blind.entity, blind.on, blind.turn_on
('cover.blind', ('open', 'opening'), 'cover.open_cover')
>>> blind.state("closing"), feature_value(home.feature("activity"),
...     home.home_assistant.feature("activity"), "relaxing")
(False, 'relax')
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from homecog.errors import ContextError
from homecog.home.model import Device, Feature, find_named, reading_text
from homecog.home.shapes import Fail, check_keys, kind_of, mapped_names, mapping_of, mapping_with_keys
from homecog.home.states import state_word

ENTITY_ID = re.compile(r"^[a-z0-9_]+\.[a-z0-9_]+$")
SERVICE = re.compile(r"^[a-z0-9_]+\.[a-z0-9_]+$")
# States every entity may take that say nothing about it: reported and skipped, never read.
NO_READING = ("unavailable", "unknown")

# Per domain: the states that read as on (None: any state but the off ones), the off states,
# and the services that switch it on and off.
DOMAIN_DEFAULTS: dict[str, tuple[tuple[str, ...] | None, tuple[str, ...], str, str]] = {
    "light": (("on",), ("off",), "light.turn_on", "light.turn_off"),
    "switch": (("on",), ("off",), "switch.turn_on", "switch.turn_off"),
    "fan": (("on",), ("off",), "fan.turn_on", "fan.turn_off"),
    "input_boolean": (("on",), ("off",), "input_boolean.turn_on", "input_boolean.turn_off"),
    "media_player": (
        ("on", "idle", "playing", "paused", "buffering"),
        ("off", "standby"),
        "media_player.turn_on",
        "media_player.turn_off",
    ),
    "cover": (("open", "opening"), ("closed", "closing"), "cover.open_cover", "cover.close_cover"),
    "climate": (None, ("off",), "climate.turn_on", "climate.turn_off"),
}


@dataclass(frozen=True)
class FeatureEntity:
    """A context feature read from an entity's state (or one of its attributes); ``values``
    maps Home Assistant's words to the feature's values (categorical features only)."""

    feature: str
    entity: str
    attribute: str | None = None
    values: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class DeviceEntity:
    """A device as an entity: which states read as on and off, and the services that switch it
    (``None`` for a device the robot does not switch and whose domain has none)."""

    device: str
    entity: str
    on: tuple[str, ...] | None  # None: every state but the off ones (and unavailable, unknown)
    off: tuple[str, ...]
    turn_on: str | None
    turn_off: str | None

    def state(self, state: str) -> bool:
        """Whether an entity state reads as on; :class:`ContextError` when it is neither.

        >>> DeviceEntity("ac", "climate.ac", None, ("off",), None, None).state("cool")
        True
        """
        if state in NO_READING:
            raise ContextError(f"{self.device}: {self.entity} is {state}")
        if state in self.off:
            return False
        if self.on is None or state in self.on:
            return True
        raise ContextError(
            f"{self.device}: {self.entity} state {state!r} is neither on ({', '.join(self.on)}) "
            f"nor off ({', '.join(self.off)})"
        )

    def service(self, on: bool) -> tuple[str, str]:
        """``(domain, service)`` of the call that switches the device on or off."""
        name = self.turn_on if on else self.turn_off
        if name is None:
            raise ContextError(f"{self.device}: no service switches {self.entity}; give turn_on and turn_off")
        domain, _, service = name.partition(".")
        return domain, service


@dataclass(frozen=True)
class HomeAssistantMap:
    """The validated ``home_assistant`` section of a home."""

    features: tuple[FeatureEntity, ...]
    devices: tuple[DeviceEntity, ...]

    def feature(self, name: str) -> FeatureEntity:
        """The mapping of a feature (:class:`KeyError` for an unmapped one)."""
        return find_named(self.features, name, "feature")

    def device(self, name: str) -> DeviceEntity:
        """The mapping of a device."""
        return find_named(self.devices, name, "device")

    @property
    def entities(self) -> tuple[str, ...]:
        """Every entity the home reads, in the home's order, each once."""
        return tuple(dict.fromkeys([f.entity for f in self.features] + [d.entity for d in self.devices]))


def feature_value(feature: Feature, mapping: FeatureEntity, state: object) -> str:
    """An entity's state (or attribute value) as the feature's value, written as in a scenario
    file; :class:`ContextError` naming the entity when it cannot be read or fits no bin.

    >>> from homecog.home import load_home
    >>> home = load_home("tests/homes/studio_ha.yaml")
    >>> light = home.home_assistant.feature("light")
    >>> feature_value(home.feature("light"), light, "150.0")
    '150'
    >>> feature_value(home.feature("light"), light, "-5")
    Traceback (most recent call last):
    ...
    homecog.errors.ContextError: light: input_number.light: -5 lx is outside every bin; valid range [0, inf)
    """
    where = f"{feature.name}: {mapping.entity}"
    if state is None or (isinstance(state, str) and state in NO_READING):
        raise ContextError(f"{where} is {'without ' + mapping.attribute if state is None else state}")
    text = str(state).strip()
    if feature.kind == "categorical":
        words = dict(mapping.values)
        value = words.get(text, text)
        if value not in feature.values:
            known = list(dict.fromkeys([*words, *feature.values]))  # its words first
            raise ContextError(f"{where}: state {text!r} is not mapped; expected one of {', '.join(known)}")
        return value
    expected = "HH:MM[:SS]" if feature.kind == "clock" else f"a number in {feature.unit or 'its unit'}"
    try:
        value = reading_text(feature.kind, text)
    except ValueError:
        raise ContextError(f"{where}: state {text!r} is not {expected}") from None
    try:
        feature.discretize(value)
    except ContextError as e:  # its message starts with the feature's name, already in `where`
        raise ContextError(f"{where}: {str(e).removeprefix(feature.name + ': ')}") from None
    return value


def nearest(entity: str, known: Iterable[str], n: int = 3) -> list[str]:
    """The existing entity ids most like ``entity`` (same domain first).

    >>> nearest("light.livng_room", ["light.living_room", "switch.living_room", "light.hall"])
    ['light.living_room', 'switch.living_room']
    """
    known = list(known)
    domain = entity.partition(".")[0]
    same = difflib.get_close_matches(entity, [k for k in known if k.startswith(domain + ".")], n, 0.6)
    other = difflib.get_close_matches(entity, known, n, 0.6)
    return list(dict.fromkeys(same + other))[:n]


def unknown_entities(mapping: HomeAssistantMap, known: Iterable[str]) -> list[str]:
    """One line per mapped entity the instance does not have, with the nearest existing ones.

    >>> from homecog.home import load_home
    >>> mapping = load_home("tests/homes/studio_ha.yaml").home_assistant
    >>> unknown_entities(mapping, [e for e in mapping.entities if e != "cover.blind"] + ["cover.blinds"])
    ["blind: unknown entity 'cover.blind'; nearest: cover.blinds"]
    """
    known = set(known)
    out = []
    for name, entity in [(f.feature, f.entity) for f in mapping.features] + [
        (d.device, d.entity) for d in mapping.devices
    ]:
        if entity not in known:
            close = nearest(entity, sorted(known))
            out.append(
                f"{name}: unknown entity {entity!r}; "
                + (f"nearest: {', '.join(close)}" if close else "no entity of that name or like it")
            )
    return out


# -- validation ------------------------------------------------------------------------------------
def parse_home_assistant(
    section: object, features: Sequence[Feature], devices: Sequence[Device], fail: Fail
) -> HomeAssistantMap | None:
    """The validated ``home_assistant`` section (``None`` where the home has none): the entity of
    every feature and device, how its states read, and the services that switch a device; errors
    through ``fail(key path, message)`` as the loader words them."""
    if section is None:
        return None
    path = "home_assistant"
    section = mapping_with_keys(section, path, ("features", "devices"), fail)
    fmaps, dmaps = mapped_names(section, path, features, devices, fail)
    return HomeAssistantMap(
        features=tuple(
            _feature(f, fmaps[f.name], f"{path}.features.{f.name}", fail) for f in features if f.name in fmaps
        ),
        devices=tuple(_device(d, dmaps[d.name], f"{path}.devices.{d.name}", fail) for d in devices),
    )


def _spec(value: object, path: str, fail: Fail) -> dict[str, Any]:
    """The mapping of a feature or device, or its short form ``lamp: light.desk_lamp``."""
    if isinstance(value, str) and ENTITY_ID.match(value.strip()):
        return {"entity": value}
    return mapping_of(value, path, fail)


def _entity(spec: dict[str, Any], path: str, fail: Fail) -> str:
    if "entity" not in spec:
        raise fail(path, "missing key 'entity'")
    entity = spec["entity"]
    if not isinstance(entity, str) or not ENTITY_ID.match(entity.strip()):
        raise fail(
            f"{path}.entity",
            f"expected an entity id such as sensor.outdoor_temperature, got {kind_of(entity)}",
        )
    return entity.strip()


def _feature(feature: Feature, spec: object, path: str, fail: Fail) -> FeatureEntity:
    spec = _spec(spec, path, fail)
    check_keys(spec, path, ("entity", "attribute", "values"), fail)
    entity = _entity(spec, path, fail)
    attribute = spec.get("attribute")
    if attribute is not None and (not isinstance(attribute, str) or not attribute.strip()):
        raise fail(f"{path}.attribute", f"expected an attribute name, got {kind_of(attribute)}")
    words: list[tuple[str, str]] = []
    if "values" in spec:
        if feature.kind != "categorical":
            raise fail(
                f"{path}.values", f"only categorical features map values; {feature.name} is {feature.kind}"
            )
        values = mapping_of(spec["values"], f"{path}.values", fail)
        for word, value in values.items():
            text = str(value).strip() if isinstance(value, (str, int, float)) else None
            if text not in feature.values:
                raise fail(
                    f"{path}.values.{word}",
                    f"unknown value {value!r}; expected one of {', '.join(feature.values)}",
                )
            words.append((str(word), text))
    return FeatureEntity(
        feature=feature.name,
        entity=entity,
        attribute=attribute.strip() if attribute else None,
        values=tuple(words),
    )


def _states(value: object, path: str, fail: Fail) -> tuple[str, ...]:
    items = value if isinstance(value, list) else [value]
    out = []
    for item in items:
        if isinstance(item, bool):  # YAML's true/false: Home Assistant writes states in lowercase words
            item = state_word(item)
        if not isinstance(item, (str, int, float)) or not str(item).strip():
            raise fail(path, f"expected a state or a list of states, got {kind_of(value)}")
        out.append(str(item).strip())
    if not out:
        raise fail(path, "empty list; expected at least one state")
    return tuple(out)


def _service(value: object, path: str, fail: Fail) -> str:
    if not isinstance(value, str) or not SERVICE.match(value.strip()):
        raise fail(path, f"expected a service such as light.turn_on, got {kind_of(value)}")
    return value.strip()


def _device(device: Device, spec: object, path: str, fail: Fail) -> DeviceEntity:
    spec = _spec(spec, path, fail)
    check_keys(spec, path, ("entity", "on", "off", "turn_on", "turn_off"), fail)
    entity = _entity(spec, path, fail)
    domain = entity.partition(".")[0]
    default_on, default_off, default_turn_on, default_turn_off = DOMAIN_DEFAULTS.get(
        domain, (None, None, None, None)
    )
    on = _states(spec["on"], f"{path}.on", fail) if "on" in spec else default_on
    off = _states(spec["off"], f"{path}.off", fail) if "off" in spec else default_off
    if off is None or (on is None and domain not in DOMAIN_DEFAULTS):
        raise fail(
            path,
            f"domain {domain!r} has no default states; give on and off "
            f"(defaults exist for {', '.join(DOMAIN_DEFAULTS)})",
        )
    both = sorted(set(on or ()) & set(off))
    if both:
        raise fail(path, f"state {both[0]!r} is both on and off")
    for word in (*(on or ()), *off):
        if word in NO_READING:
            raise fail(path, f"state {word!r} says nothing about the device; it is always skipped")
    turn_on = _service(spec["turn_on"], f"{path}.turn_on", fail) if "turn_on" in spec else default_turn_on
    turn_off = (
        _service(spec["turn_off"], f"{path}.turn_off", fail) if "turn_off" in spec else default_turn_off
    )
    if device.iot and (turn_on is None or turn_off is None):
        raise fail(
            path,
            f"the robot switches {device.name} (iot: true) but domain {domain!r} has no default "
            "services; give turn_on and turn_off",
        )
    return DeviceEntity(device=device.name, entity=entity, on=on, off=off, turn_on=turn_on, turn_off=turn_off)
