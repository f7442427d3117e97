"""The ``log:`` section of a home file: which entities of a log of state changes are the home's
features and devices, and how their states read (``homecog log events``).

.. code-block:: yaml

    log:
      quiet: 10                       # minutes: a feature change this far from every switch is a quiet row
      devices:
        lamp: {entity: x10.a1, on: [on, "1"], off: [off, "0"]}   # on/off words; default on and off
      features:
        time: {entity: clock}         # optional: HH:MM[:SS]; else the timestamp's local time
        temperature: {entity: sensor.temp}                       # a number in the feature's unit
        behavior: {entity: activity, values: {"Preparing dinner": cooking}}   # words → values
        location:                     # the room of the latest presence entity that turned on
          presence: {motion.kitchen: kitchen, pir_bath: bathroom}
          hold: 30                    # minutes it holds after the entity turns off
          several: several            # optional: the value while entities of two rooms are live

An entity is any non-empty name the log uses. Every feature but the clock ones, and every
device, must be mapped. A presence entity is on at one of its ``on`` states (default ``on``) and
off at one of ``off`` (default ``off``); from when it turns on until ``hold`` minutes after it
last turned on or off it is *live*, and the feature is the room of the live entity that turned
on last — or, with ``several`` (a value of the feature), that value while live entities are in
more than one room (a household in several rooms at once); with none live it is ``unknown``
where the feature has that value, else the last room.
The entity of a device may not serve as presence: what the robot is to predict must not say
where the user is. Mapping entities does not change what the robot learns, so the section is not part
of the home's content hash.

>>> from homecog.home import load_home_text
>>> home = load_home_text('''
... name: den
... context:
...   behavior: {kind: categorical, values: [read, sleep]}
...   location: {kind: categorical, values: [bed, desk, unknown]}
... devices: {lamp: {}}
... services: {LampOn: {category: on, set: {lamp: on}}}
... comfort: {lamp: [{want: on}]}
... log:
...   devices: {lamp: {entity: x10.a1, on: [on, 1]}}
...   features:
...     behavior: {entity: activity, values: {Reading: read}}
...     location: {presence: {pir_bed: bed, pir_desk: desk}, hold: 5}
... ''', "den.yaml")
>>> home.log.device("lamp").on, home.log.quiet, home.log.presence_of("location").hold
(('on', '1'), 10.0, 5.0)
>>> sorted(home.log.entities)
['activity', 'pir_bed', 'pir_desk', 'x10.a1']
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from homecog.home.model import Device, Feature, find_named, format_number
from homecog.home.shapes import Fail, check_keys, kind_of, mapped_names, mapping_of, mapping_with_keys
from homecog.home.states import state_word

QUIET, HOLD = 10.0, 30.0  # minutes


@dataclass(frozen=True)
class LogDevice:
    """A device as a log entity, and the words of its states."""

    device: str
    entity: str
    on: tuple[str, ...] = ("on",)
    off: tuple[str, ...] = ("off",)


@dataclass(frozen=True)
class LogFeature:
    """A feature read from an entity's states; ``values`` maps the log's words to the feature's
    values (categorical features only)."""

    feature: str
    entity: str
    values: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class LogPresence:
    """A categorical feature made from presence or motion entities, each in a room (a value)."""

    feature: str
    rooms: tuple[tuple[str, str], ...]  # entity, room
    hold: float = HOLD  # minutes
    on: tuple[str, ...] = ("on",)
    off: tuple[str, ...] = ("off",)
    several: str | None = None  # the value while entities of several rooms are live


@dataclass(frozen=True)
class LogMap:
    """The validated ``log`` section of a home."""

    features: tuple[LogFeature, ...]
    presence: tuple[LogPresence, ...]
    devices: tuple[LogDevice, ...]
    quiet: float = QUIET  # minutes

    def device(self, name: str) -> LogDevice:
        """The mapping of a device (:class:`KeyError` for an unmapped one)."""
        return find_named(self.devices, name, "device")

    def presence_of(self, name: str) -> LogPresence:
        """The presence mapping of a feature."""
        return find_named(self.presence, name, "feature")

    @property
    def entities(self) -> frozenset[str]:
        """Every entity the home reads from a log."""
        rooms = {e for p in self.presence for e, _ in p.rooms}
        return frozenset({f.entity for f in self.features} | rooms | {d.entity for d in self.devices})


# -- validation ------------------------------------------------------------------------------------
def parse_log(
    section: object, features: Sequence[Feature], devices: Sequence[Device], fail: Fail
) -> LogMap | None:
    """The validated ``log`` section (``None`` where the home has none): the entity of every
    feature and device and how its states read, the presence entities of a room feature, and the
    quiet minutes; errors through ``fail(key path, message)`` as the loader words them."""
    if section is None:
        return None
    path = "log"
    section = mapping_with_keys(section, path, ("features", "devices", "quiet"), fail, kind=_kind)
    quiet = _minutes(section.get("quiet", QUIET), f"{path}.quiet", fail)
    fmaps, dmaps = mapped_names(section, path, features, devices, fail, kind=_kind)
    mapped = [_device(d.name, dmaps[d.name], f"{path}.devices.{d.name}", fail) for d in devices]
    plain: list[LogFeature] = []
    presence: list[LogPresence] = []
    for feature in features:
        if feature.name not in fmaps:
            continue
        where = f"{path}.features.{feature.name}"
        spec = _spec(fmaps[feature.name], where, fail)
        if "presence" in spec:
            presence.append(_presence(feature, spec, where, {d.entity: d.device for d in mapped}, fail))
        else:
            plain.append(_feature(feature, spec, where, fail))
    return LogMap(features=tuple(plain), presence=tuple(presence), devices=tuple(mapped), quiet=quiet)


def _mapping(value: object, path: str, fail: Fail) -> dict[str, Any]:
    return mapping_of(value, path, fail, kind=_kind)


def _spec(value: object, path: str, fail: Fail) -> dict[str, Any]:
    """The mapping of a feature or device, or its short form ``lamp: x10.a1``."""
    if isinstance(value, (str, int)) and not isinstance(value, bool) and str(value).strip():
        return {"entity": value}
    return _mapping(value, path, fail)


def _name(value: object, path: str, what: str, fail: Fail) -> str:
    """An entity or a word: a non-empty text (a number reads as its text)."""
    if isinstance(value, bool) or not isinstance(value, (str, int, float)) or not str(value).strip():
        raise fail(path, f"expected {what}, got {_kind(value)}")
    return str(value).strip()


def _minutes(value: object, path: str, fail: Fail, *, positive: bool = False) -> float:
    number = value if isinstance(value, (int, float)) and not isinstance(value, bool) else math.nan
    if not math.isfinite(number) or number < 0 or (positive and number == 0):
        raise fail(
            path, f"expected minutes, a number {'above' if positive else 'from'} 0, got {_kind(value)}"
        )
    return float(number)


def _words(value: object, path: str, fail: Fail) -> tuple[str, ...]:
    items = value if isinstance(value, list) else [value]
    out = []
    for item in items:
        if isinstance(item, bool):  # YAML's true/false
            item = state_word(item)
        out.append(_name(item, path, "a state or a list of states", fail))
    if not out:
        raise fail(path, "empty list; expected at least one state")
    return tuple(dict.fromkeys(out))


def _on_off(spec: dict[str, Any], path: str, fail: Fail) -> tuple[tuple[str, ...], tuple[str, ...]]:
    on = _words(spec["on"], f"{path}.on", fail) if "on" in spec else ("on",)
    off = _words(spec["off"], f"{path}.off", fail) if "off" in spec else ("off",)
    both = sorted(set(on) & set(off))
    if both:
        raise fail(path, f"state {both[0]!r} is both on and off")
    return on, off


def _device(name: str, spec: object, path: str, fail: Fail) -> LogDevice:
    spec = _spec(spec, path, fail)
    check_keys(spec, path, ("entity", "on", "off"), fail)
    if "entity" not in spec:
        raise fail(path, "missing key 'entity'")
    entity = _name(spec["entity"], f"{path}.entity", "an entity name", fail)
    on, off = _on_off(spec, path, fail)
    return LogDevice(device=name, entity=entity, on=on, off=off)


def _feature(feature: Feature, spec: dict[str, Any], path: str, fail: Fail) -> LogFeature:
    check_keys(spec, path, ("entity", "values"), fail)
    if "entity" not in spec:
        raise fail(path, "missing key 'entity' (or 'presence')")
    entity = _name(spec["entity"], f"{path}.entity", "an entity name", fail)
    words: list[tuple[str, str]] = []
    if "values" in spec:
        if feature.kind != "categorical":
            raise fail(
                f"{path}.values", f"only categorical features map values; {feature.name} is {feature.kind}"
            )
        for word, value in _mapping(spec["values"], f"{path}.values", fail).items():
            words.append((str(word).strip(), _value(feature, value, f"{path}.values.{word}", fail)))
    return LogFeature(feature=feature.name, entity=entity, values=tuple(words))


def _value(feature: Feature, value: object, path: str, fail: Fail) -> str:
    text = (
        str(value).strip() if isinstance(value, (str, int, float)) and not isinstance(value, bool) else None
    )
    if text not in feature.values:
        raise fail(path, f"unknown value {value!r}; expected one of {', '.join(feature.values)}")
    return text


def _presence(
    feature: Feature, spec: dict[str, Any], path: str, devices: dict[str, str], fail: Fail
) -> LogPresence:
    check_keys(spec, path, ("presence", "hold", "on", "off", "several"), fail)
    if feature.kind != "categorical":
        raise fail(
            f"{path}.presence",
            f"only a categorical feature is made from presence; {feature.name} is {feature.kind}",
        )
    rooms = []
    for entity, room in _mapping(spec["presence"], f"{path}.presence", fail).items():
        where = f"{path}.presence.{entity}"
        name = _name(entity, where, "an entity name", fail)
        if name in devices:
            raise fail(where, f"is the entity of device {devices[name]}; a device the robot predicts "
                              "may not say where the user is")  # fmt: skip
        rooms.append((name, _value(feature, room, where, fail)))
    if not rooms:
        raise fail(f"{path}.presence", "is empty; expected at least one entity and its room")
    hold = _minutes(spec.get("hold", HOLD), f"{path}.hold", fail, positive=True)
    on, off = _on_off(spec, path, fail)
    several = spec.get("several")
    if several is not None:
        several = _value(feature, several, f"{path}.several", fail)
    return LogPresence(feature=feature.name, rooms=tuple(rooms), hold=hold, on=on, off=off, several=several)


def _kind(value: object) -> str:
    """What a value is, a number written as people write it."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return format_number(value)
    return kind_of(value)
