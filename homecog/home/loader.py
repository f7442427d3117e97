"""Load and validate home definitions (SPEC §2).

Every error names the file, the key path and what was expected::

    paper.yaml: comfort.lamp[2].when.behavior: unknown value 'nap'; expected one of read, ...

YAML 1.1 readers turn a bare ``on``/``off``/``yes``/``no`` into booleans; this loader
reads YAML with YAML 1.2 booleans (only true/false), so category names such as
``yes`` stay strings, and device states accept on/off, true/false and yes/no.

>>> home = load_home("paper")
>>> home.name, len(home.services), home.context_count
('paper', 20, 2592)
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import re
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import Any

import yaml

from homecog.errors import HomeFileError
from homecog.home.clock import clock_hours
from homecog.home.home_assistant import parse_home_assistant
from homecog.home.layout import parse_layout
from homecog.home.model import (
    ComfortRule,
    Condition,
    Device,
    Feature,
    Home,
    Rewards,
    Service,
    format_number,
)
from homecog.home.routine import parse_routine
from homecog.home.states import STATE_WORDS

BUILTIN_PACKAGE = "homecog.home.homes"
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_SECTIONS = (
    "name",
    "description",
    "context",
    "devices",
    "services",
    "comfort",
    "needs",
    "prohibited",
    "rewards",
    "layout",
    "routine",
    "home_assistant",
)
_REQUIRED = ("name", "context", "devices", "services", "comfort")
_KINDS = ("clock", "numeric", "categorical")


class _Loader(yaml.SafeLoader):
    """SafeLoader with YAML 1.2 booleans and an error on duplicate keys."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: set[Any] = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"duplicate key {key!r}", key_node.start_mark
                )
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


# YAML 1.2 has no base-60 numbers: keep an unquoted clock time (19:00) a string, not 1140.
_NUMBER_TAGS = ("tag:yaml.org,2002:int", "tag:yaml.org,2002:float")
_Loader.yaml_implicit_resolvers = {
    first: [
        (tag, re.compile(r"(?!.*:)" + rx.pattern, rx.flags) if tag in _NUMBER_TAGS else rx)
        for tag, rx in resolvers
        if tag != "tag:yaml.org,2002:bool"
    ]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:bool", re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"), list("tTfF")
)


def builtin_homes() -> list[str]:
    """Names of the homes shipped with homecog."""
    files = resources.files(BUILTIN_PACKAGE).iterdir()
    return sorted(f.name[:-5] for f in files if f.name.endswith(".yaml"))


def resolve_home(name_or_path: str | Path) -> tuple[str, str]:
    """``(source name, YAML text)`` of a built-in home name or a path."""
    text = str(name_or_path)
    if text in builtin_homes():
        res = resources.files(BUILTIN_PACKAGE).joinpath(f"{text}.yaml")
        return f"{text}.yaml", res.read_text(encoding="utf-8")
    path = Path(name_or_path)
    looks_like_path = path.suffix in (".yaml", ".yml") or "/" in text or path.exists()
    if not looks_like_path:
        raise HomeFileError(
            f"unknown home {text!r}; built-in homes: {', '.join(builtin_homes())}, "
            "or give the path of a YAML file"
        )
    try:
        return str(name_or_path), path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise HomeFileError(f"{text}: no such file") from None
    except IsADirectoryError:
        raise HomeFileError(f"{text}: is a directory, not a home file") from None
    except (OSError, UnicodeDecodeError) as e:
        reason = e.strerror if isinstance(e, OSError) and e.strerror else str(e)
        raise HomeFileError(f"{text}: cannot read: {reason}") from None


def load_home(name_or_path: str | Path) -> Home:
    """Load a home by built-in name (``paper``) or path, validated."""
    source, text = resolve_home(name_or_path)
    return load_home_text(text, source)


def load_home_text(text: str, source: str = "<home>") -> Home:
    """Parse and validate the YAML text of a home; ``source`` names it in errors."""
    try:
        data = yaml.load(text, Loader=_Loader)  # _Loader is a SafeLoader
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None) or getattr(e, "context_mark", None)
        where = f"line {mark.line + 1}: " if mark is not None else ""
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise HomeFileError(f"{source}: {where}not valid YAML: {problem}") from None
    return _Validator(source).home(data)


def parse_device_state(value: object) -> bool | None:
    """A state in the one vocabulary (:mod:`homecog.home.states`); None when it is none of it."""
    if isinstance(value, bool):
        return value
    if isinstance(value, str):
        return STATE_WORDS.get(value.strip().lower())
    return None


def _join(path: str, key: object) -> str:
    if isinstance(key, int):
        return f"{path}[{key}]"
    return f"{path}.{key}" if path else str(key)


class _Validator:
    """Walks the parsed YAML, building the model and failing with key paths."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, path: str, message: str) -> HomeFileError:
        where = f"{path}: " if path else ""
        return HomeFileError(f"{self.source}: {where}{message}")

    # -- shapes --------------------------------------------------------------------------
    def mapping(self, value: object, path: str, *, allow_empty: bool = False) -> dict[Any, Any]:
        if value is None and allow_empty:
            return {}
        if not isinstance(value, dict):
            raise self.fail(path, f"expected a mapping, got {_kind(value)}")
        if not value and not allow_empty:
            raise self.fail(path, "is empty; expected at least one entry")
        for key in value:
            if not isinstance(key, str):
                raise self.fail(path, f"key {key!r} is not a name")
        return value

    def keys(
        self, value: dict[Any, Any], path: str, allowed: tuple[str, ...], required: tuple[str, ...] = ()
    ) -> None:
        for key in value:
            if key not in allowed:
                raise self.fail(_join(path, key), f"unknown key; expected one of {', '.join(allowed)}")
        for key in required:
            if key not in value:
                raise self.fail(path, f"missing key '{key}'")

    def name(self, value: object, path: str, what: str) -> str:
        if not isinstance(value, str) or not _NAME.match(value):
            raise self.fail(
                path, f"{what} name {value!r} must be letters, digits and _ and not start with a digit"
            )
        return value

    def number(self, value: object, path: str) -> float:
        if isinstance(value, bool):
            raise self.fail(path, f"expected a number, got {value!r}")
        if isinstance(value, str):
            try:
                value = float(value.strip().replace(".inf", "inf").replace(".Inf", "inf"))
            except ValueError:
                raise self.fail(path, f"expected a number, got {value!r}") from None
        if not isinstance(value, (int, float)) or math.isnan(value):
            raise self.fail(path, f"expected a number, got {value!r}")
        return float(value)

    def hours(self, value: object, path: str) -> float:
        if isinstance(value, str) and ":" in value:
            try:
                value = clock_hours(value)
            except ValueError:
                raise self.fail(path, f'expected hours (7.5 or "07:30"), got {value!r}') from None
        x = self.number(value, path)
        if not 0 <= x <= 24:
            raise self.fail(path, f"hour {format_number(x)} out of range; expected 0 to 24")
        return x

    def state(self, value: object, path: str) -> bool:
        state = parse_device_state(value)
        if state is None:
            raise self.fail(path, f"unknown state {value!r}; expected on or off")
        return state

    # -- the sections --------------------------------------------------------------------
    def home(self, data: object) -> Home:
        if data is None:
            raise self.fail("", "is empty; expected a home definition")
        data = self.mapping(data, "")
        self.keys(data, "", _SECTIONS)
        for key in _REQUIRED:
            if key not in data:
                raise self.fail("", f"missing section '{key}'")
        name = data["name"]
        if not isinstance(name, str) or not name.strip():
            raise self.fail("name", f"expected a non-empty string, got {name!r}")
        description = data.get("description")
        if description is not None and not isinstance(description, str):
            raise self.fail("description", "expected a string")

        features = self.features(data["context"])
        devices = self.devices(data["devices"])
        clash = {f.name for f in features} & {d.name for d in devices}
        if clash:
            raise self.fail(
                f"devices.{sorted(clash)[0]}", "a device may not share a name with a context feature"
            )
        services = self.services(data["services"], devices)
        comfort = self.comfort(data["comfort"], features, devices)
        needs = self.service_rules(data.get("needs"), "needs", features, devices, services)
        prohibited = self.service_rules(data.get("prohibited"), "prohibited", features, devices, services)
        rewards = self.rewards(data.get("rewards"))
        layout = None
        if data.get("layout") is not None:
            layout = parse_layout(
                data["layout"],
                self.fail,
                devices={d.name: (d.room, d.iot) for d in devices},
                interaction={s.name for s in services if not s.sets},
                services={s.name for s in services},
            )

        home = Home(
            name=name.strip(),
            features=features,
            devices=devices,
            services=services,
            comfort=comfort,
            needs=needs,
            prohibited=prohibited,
            rewards=rewards,
            layout=layout,
            routine=parse_routine(data.get("routine"), features, devices, self.fail),
            home_assistant=parse_home_assistant(data.get("home_assistant"), features, devices, self.fail),
            description=description,
            source=self.source,
        )
        object.__setattr__(home, "content_hash", content_hash(home))
        return home

    def features(self, section: object) -> tuple[Feature, ...]:
        section = self.mapping(section, "context")
        return tuple(self.feature(name, spec, f"context.{name}") for name, spec in section.items())

    def feature(self, name: str, spec: object, path: str) -> Feature:
        self.name(name, path, "feature")
        spec = self.mapping(spec, path)
        self.keys(spec, path, ("kind", "unit", "bins", "values", "description"), ("kind",))
        kind = spec["kind"]
        if kind not in _KINDS:
            raise self.fail(f"{path}.kind", f"unknown kind {kind!r}; expected one of {', '.join(_KINDS)}")
        unit = spec.get("unit")
        if unit is not None:
            unit = str(unit)
        if kind == "categorical":
            if "bins" in spec:
                raise self.fail(f"{path}.bins", "a categorical feature has values, not bins")
            if "values" not in spec:
                raise self.fail(path, "missing key 'values'")
            values = spec["values"]
            if not isinstance(values, list):
                raise self.fail(f"{path}.values", f"expected a list, got {_kind(values)}")
            if not values:
                raise self.fail(f"{path}.values", "empty value list")
            names = []
            for i, v in enumerate(values):
                if isinstance(v, (dict, list)) or v is None:
                    raise self.fail(f"{path}.values[{i}]", f"expected a value name, got {_kind(v)}")
                text = str(v).strip()
                if not text or any(c in text for c in ",=;\n"):
                    raise self.fail(
                        f"{path}.values[{i}]", f"value {text!r} may not be empty or contain , = ;"
                    )
                if text in names:
                    raise self.fail(f"{path}.values[{i}]", f"duplicate value {text!r}")
                names.append(text)
            return Feature(name=name, kind="categorical", values=tuple(names), unit=unit)

        if "values" in spec:
            raise self.fail(f"{path}.values", f"a {kind} feature has bins, not values")
        if "bins" not in spec:
            raise self.fail(path, "missing key 'bins'")
        bins_spec = self.mapping(spec["bins"], f"{path}.bins")
        names, bins = [], []
        for bin_name, bounds in bins_spec.items():
            bpath = f"{path}.bins.{bin_name}"
            self.name(bin_name, bpath, "bin")
            if not isinstance(bounds, list) or len(bounds) != 2:
                raise self.fail(bpath, f"expected [low, high], got {bounds!r}")
            if kind == "clock":
                low, high = (self.hours(b, f"{bpath}[{i}]") for i, b in enumerate(bounds))
                if low == high:  # [0, 24] and [24, 0] are the whole day, not empty
                    raise self.fail(bpath, f"empty bin [{format_number(low)}, {format_number(high)}]")
            else:
                low, high = (self.number(b, f"{bpath}[{i}]") for i, b in enumerate(bounds))
                if low >= high:
                    raise self.fail(
                        bpath,
                        f"bins reversed: low {format_number(low)} is not below high {format_number(high)}",
                    )
            names.append(bin_name)
            bins.append((low % 24, high % 24) if kind == "clock" else (low, high))
        if kind == "clock":
            self.check_clock_cover(names, bins, f"{path}.bins")
        else:
            self.check_numeric_cover(names, bins, f"{path}.bins")
        return Feature(name=name, kind=kind, values=tuple(names), bins=tuple(bins), unit=unit)

    def check_numeric_cover(self, names: list[str], bins: list[tuple[float, float]], path: str) -> None:
        order = sorted(range(len(bins)), key=lambda k: bins[k])
        for a, b in itertools.pairwise(order):
            (_, a_high), (b_low, _) = bins[a], bins[b]
            if a_high > b_low:
                raise self.fail(
                    path,
                    f"bins '{names[a]}' and '{names[b]}' overlap "
                    f"({format_number(b_low)} to {format_number(a_high)})",
                )
            if a_high < b_low:
                raise self.fail(
                    path,
                    f"gap between bins '{names[a]}' and '{names[b]}' "
                    f"({format_number(a_high)} to {format_number(b_low)})",
                )

    def check_clock_cover(self, names: list[str], bins: list[tuple[float, float]], path: str) -> None:
        # Cut wrapping bins at midnight, then the pieces must tile [0, 24) exactly.
        pieces: list[tuple[float, float, int]] = []
        for k, (low, high) in enumerate(bins):
            if low < high:
                pieces.append((low, high, k))
            else:
                pieces.append((low, 24.0, k))
                if high > 0:
                    pieces.append((0.0, high, k))
        pieces.sort()
        hhmm = _hhmm
        if pieces[0][0] > 0:
            raise self.fail(path, f"the clock bins leave a gap from 00:00 to {hhmm(pieces[0][0])}")
        for (_, a_high, a), (b_low, _, b) in itertools.pairwise(pieces):
            if a_high > b_low:
                raise self.fail(
                    path,
                    f"bins '{names[a]}' and '{names[b]}' overlap "
                    f"({hhmm(b_low)} to {hhmm(min(a_high, 24.0))})",
                )
            if a_high < b_low:
                raise self.fail(
                    path, f"gap between bins '{names[a]}' and '{names[b]}' ({hhmm(a_high)} to {hhmm(b_low)})"
                )
        if pieces[-1][1] < 24:
            raise self.fail(path, f"the clock bins leave a gap from {hhmm(pieces[-1][1])} to 24:00")

    def devices(self, section: object) -> tuple[Device, ...]:
        section = self.mapping(section, "devices")
        out = []
        for name, spec in section.items():
            path = f"devices.{name}"
            self.name(name, path, "device")
            spec = self.mapping(spec, path, allow_empty=True)
            self.keys(spec, path, ("room", "iot", "place", "description"))
            iot = parse_device_state(spec.get("iot", True))
            if iot is None:
                raise self.fail(f"{path}.iot", f"expected true or false, got {spec['iot']!r}")
            room = spec.get("room")
            out.append(Device(name=name, room=None if room is None else str(room), iot=iot))
        return tuple(out)

    def services(self, section: object, devices: tuple[Device, ...]) -> tuple[Service, ...]:
        section = self.mapping(section, "services")
        device_names = [d.name for d in devices]
        out = []
        for name, spec in section.items():
            path = f"services.{name}"
            self.name(name, path, "service")
            spec = self.mapping(spec, path)
            self.keys(spec, path, ("category", "set", "description"), ("category",))
            category = spec["category"]
            if not isinstance(category, str) or not category.strip():
                raise self.fail(f"{path}.category", f"expected a category name, got {category!r}")
            sets = []
            for device, state in self.mapping(spec.get("set"), f"{path}.set", allow_empty=True).items():
                if device not in device_names:
                    raise self.fail(
                        f"{path}.set.{device}",
                        f"unknown device {device!r}; expected one of {', '.join(device_names)}",
                    )
                sets.append((device, self.state(state, f"{path}.set.{device}")))
            description = spec.get("description")
            out.append(
                Service(
                    name=name,
                    category=category.strip(),
                    sets=tuple(sets),
                    description=None if description is None else str(description),
                )
            )
        return tuple(out)

    def condition(
        self,
        spec: object,
        path: str,
        features: tuple[Feature, ...],
        devices: tuple[Device, ...],
        context_only: bool,
    ) -> Condition:
        spec = self.mapping(spec, path, allow_empty=True)
        fnames = [f.name for f in features]
        dnames = [d.name for d in devices]
        fconds, dconds = [], []
        for key, allowed in spec.items():
            kpath = f"{path}.{key}"
            values = allowed if isinstance(allowed, list) else [allowed]
            if not values:
                raise self.fail(kpath, "empty value list")
            if key in fnames:
                feature = features[fnames.index(key)]
                codes = set()
                for v in values:
                    text = str(v).strip() if not isinstance(v, (dict, list)) else None
                    if text not in feature.values:
                        raise self.fail(
                            kpath, f"unknown value {v!r}; expected one of {', '.join(feature.values)}"
                        )
                    codes.add(feature.values.index(text))
                fconds.append((fnames.index(key), frozenset(codes)))
            elif key in dnames and not context_only:
                dconds.append((dnames.index(key), frozenset(self.state(v, kpath) for v in values)))
            elif key in dnames:
                raise self.fail(
                    kpath, f"'{key}' is a device; these rules use context features only ({', '.join(fnames)})"
                )
            else:
                expected = fnames + ([] if context_only else dnames)
                raise self.fail(kpath, f"unknown feature {key!r}; expected one of {', '.join(expected)}")
        return Condition(features=tuple(sorted(fconds)), devices=tuple(sorted(dconds)))

    def rules(self, spec: object, path: str, parse: Callable[[dict[str, Any], str], Any]) -> tuple[Any, ...]:
        if not isinstance(spec, list):
            raise self.fail(path, f"expected a list of rules, got {_kind(spec)}")
        out = []
        for i, rule in enumerate(spec):
            rpath = f"{path}[{i}]"
            out.append(parse(self.mapping(rule, rpath, allow_empty=True), rpath))
        return tuple(out)

    def comfort(
        self, section: object, features: tuple[Feature, ...], devices: tuple[Device, ...]
    ) -> tuple[tuple[ComfortRule, ...], ...]:
        section = self.mapping(section, "comfort", allow_empty=True)
        dnames = [d.name for d in devices]
        by_device: dict[str, tuple[ComfortRule, ...]] = {}
        for device, rules in section.items():
            path = f"comfort.{device}"
            if device not in dnames:
                raise self.fail(path, f"unknown device {device!r}; expected one of {', '.join(dnames)}")

            def parse(rule: dict[str, Any], rpath: str) -> ComfortRule:
                self.keys(rule, rpath, ("when", "want"), ("want",))
                when = self.condition(rule.get("when"), f"{rpath}.when", features, devices, True)
                want = parse_device_state(rule["want"])
                if want is None:
                    raise self.fail(f"{rpath}.want", f"expected on or off, got {rule['want']!r}")
                return ComfortRule(when=when, want=want)

            by_device[device] = self.rules(rules, path, parse)
        return tuple(by_device.get(name, ()) for name in dnames)

    def service_rules(
        self,
        section: object,
        key: str,
        features: tuple[Feature, ...],
        devices: tuple[Device, ...],
        services: tuple[Service, ...],
    ) -> tuple[tuple[Condition, ...], ...]:
        section = self.mapping(section, key, allow_empty=True)
        snames = [s.name for s in services]
        by_service: dict[str, tuple[Condition, ...]] = {}
        for service, rules in section.items():
            path = f"{key}.{service}"
            if service not in snames:
                raise self.fail(path, f"unknown service {service!r}; expected one of {', '.join(snames)}")
            if key == "needs" and not services[snames.index(service)].is_interaction:
                raise self.fail(
                    path,
                    f"needs are for interaction services; {service} sets devices "
                    "(its wanted states come from the comfort rules)",
                )

            def parse(rule: dict[str, Any], rpath: str) -> Condition:
                self.keys(rule, rpath, ("when",))
                return self.condition(
                    rule.get("when"), f"{rpath}.when", features, devices, context_only=key == "needs"
                )

            by_service[service] = self.rules(rules, path, parse)
        return tuple(by_service.get(name, ()) for name in snames)

    def rewards(self, section: object) -> Rewards:
        if section is None:
            return Rewards()
        section = self.mapping(section, "rewards", allow_empty=True)
        self.keys(section, "rewards", ("weights", "magnitude"))
        weights = self.mapping(section.get("weights"), "rewards.weights", allow_empty=True)
        self.keys(weights, "rewards.weights", ("terminal", "progress", "prohibited"))
        default = Rewards()
        values = {
            k: self.number(weights.get(k, getattr(default, k)), f"rewards.weights.{k}")
            for k in ("terminal", "progress", "prohibited")
        }
        magnitude = self.number(section.get("magnitude", default.magnitude), "rewards.magnitude")
        if magnitude <= 0:
            raise self.fail(
                "rewards.magnitude", f"expected a positive number, got {format_number(magnitude)}"
            )
        return Rewards(magnitude=magnitude, **values)


def _hhmm(hours: float) -> str:
    minutes = round(hours * 60)
    return f"{minutes // 60:02d}:{minutes % 60:02d}"


def _kind(value: object) -> str:
    if value is None:
        return "nothing"
    return {dict: "a mapping", list: "a list", str: f"the text {value!r}", bool: f"{value}"}.get(
        type(value), f"{value!r}"
    )


def _condition_json(home: Home, cond: Condition) -> dict[str, list[str]]:
    out = {
        home.features[f].name: sorted(home.features[f].values[k] for k in codes) for f, codes in cond.features
    }
    out.update(
        {home.devices[d].name: sorted("on" if s else "off" for s in states) for d, states in cond.devices}
    )
    return out


def canonical(home: Home) -> dict[str, Any]:
    """What learning depends on, as plain data (order kept where it carries meaning)."""
    return {
        "context": [[f.name, f.kind, list(f.values), [list(b) for b in f.bins or ()]] for f in home.features],
        "devices": list(home.device_names),
        "services": [[s.name, s.category, [[d, v] for d, v in s.sets]] for s in home.services],
        "comfort": [[[_condition_json(home, r.when), r.want] for r in rules] for rules in home.comfort],
        "needs": [[_condition_json(home, c) for c in rules] for rules in home.needs],
        "prohibited": [[_condition_json(home, c) for c in rules] for rules in home.prohibited],
        "rewards": [
            home.rewards.terminal,
            home.rewards.progress,
            home.rewards.prohibited,
            home.rewards.magnitude,
        ],
    }


def content_hash(home: Home) -> str:
    """SHA-256 of :func:`canonical`: equal for homes that learn the same, whatever their layout."""
    text = json.dumps(canonical(home), sort_keys=False, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def is_compatible(truth: Home, home: Home) -> list[str]:
    """What differs between a truth home and a home where SPEC §2 requires equality ([] = compatible)."""
    problems = []
    a, b = canonical(truth), canonical(home)
    if a["context"] != b["context"]:
        problems.append("context features, values or bins differ")
    if a["devices"] != b["devices"]:
        problems.append("devices differ")
    effects_a = {s.name: s.sets for s in truth.services}
    effects_b = {s.name: s.sets for s in home.services}
    if effects_a != effects_b:
        problems.append("service names or effects differ")
    return problems
