"""The validation of a parsed home file: every section checked, the model built, and every
error naming the file, the key path and what was expected.

The sections are validated by :class:`~homecog.home.context_section.ContextSection` (features)
and :class:`~homecog.home.rule_sections.RuleSections` (comfort, needs, prohibited), with
``layout``, ``routine``, ``home_assistant`` and ``log`` in modules of their own; this module holds the
rest (devices, services, rewards) and puts the home together. :func:`load_home` and
:func:`load_home_text` are the entry: a home found and read as YAML
(:mod:`~homecog.home.home_file`), then validated.

YAML 1.1 readers turn a bare ``on``/``off``/``yes``/``no`` into booleans; a home file is read
with YAML 1.2 booleans (only true/false), so category names such as ``yes`` stay strings, and
device states accept on/off, true/false and yes/no.

>>> home = load_home("paper")
>>> home.name, len(home.services), home.context_count
('paper', 20, 2592)

>>> HomeValidator("den.yaml").home({"name": "den", "context": {}})
Traceback (most recent call last):
...
homecog.errors.HomeFileError: den.yaml: missing section 'devices'
"""

from __future__ import annotations

from pathlib import Path

from homecog.home.content import content_hash
from homecog.home.context_section import ContextSection
from homecog.home.floor import check_floor
from homecog.home.home_assistant import parse_home_assistant
from homecog.home.home_file import read_yaml, resolve_home
from homecog.home.household import parse_household
from homecog.home.layout import Layout, parse_layout
from homecog.home.log_section import parse_log
from homecog.home.model import Device, Feature, Home, Rewards, RewardWeights, Service, format_number
from homecog.home.pacing import default_minutes
from homecog.home.routine import parse_routine
from homecog.home.rule_sections import RuleSections
from homecog.home.shapes import parse_device_state
from homecog.names import home_name_problem

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
    "household",
    "log",
)
_REQUIRED = ("name", "context", "devices", "services", "comfort")


class HomeValidator(ContextSection):
    """Walks the parsed YAML, building the model and failing with key paths."""

    def home(self, data: object) -> Home:
        if data is None:
            raise self.fail("", "is empty; expected a home definition")
        data = self.mapping(data, "")
        self.keys(data, "", _SECTIONS)
        for key in _REQUIRED:
            if key not in data:
                raise self.fail("", f"missing section '{key}'")
        name = data["name"]
        problem = home_name_problem(name)
        if problem is not None:  # it names files and rows: never a path (homecog.names)
            raise self.fail("name", problem)
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
        rules = RuleSections(self.source, features, devices)
        home = Home(
            name=name,
            features=features,
            devices=devices,
            services=services,
            comfort=rules.comfort(data["comfort"]),
            needs=rules.service_rules(data.get("needs"), "needs", services),
            prohibited=rules.service_rules(data.get("prohibited"), "prohibited", services),
            rewards=self.rewards(data.get("rewards")),
            layout=self.layout(data.get("layout"), features, devices, services),
            routine=parse_routine(data.get("routine"), features, devices, self.fail),
            home_assistant=parse_home_assistant(data.get("home_assistant"), features, devices, self.fail),
            household=parse_household(data.get("household"), self.fail),
            log=parse_log(data.get("log"), features, devices, self.fail),
            description=description,
            source=self.source,
        )
        object.__setattr__(home, "content_hash", content_hash(home))
        return home

    def layout(
        self,
        section: object,
        features: tuple[Feature, ...],
        devices: tuple[Device, ...],
        services: tuple[Service, ...],
    ) -> Layout | None:
        """The floor plan (``None`` where the home has none), its rooms and places checked
        against the home's devices, services and locations."""
        if section is None:
            return None
        layout = parse_layout(
            section,
            self.fail,
            devices={d.name: (d.room, d.iot) for d in devices},
            interaction={s.name for s in services if not s.sets},
            services={s.name for s in services},
        )
        location = next((f for f in features if f.name == "location" and f.is_discrete), None)
        check_floor(
            layout,
            locations=location.values if location is not None else (),
            devices={d.name: (d.room, d.iot) for d in devices},
            fail=self.fail,
        )
        return layout

    def devices(self, section: object) -> tuple[Device, ...]:
        section = self.mapping(section, "devices")
        out = []
        for name, spec in section.items():
            path = f"devices.{name}"
            self.name(name, path, "device")
            spec = self.mapping(spec, path, allow_empty=True)
            self.keys(spec, path, ("room", "iot", "place", "description", "min_on", "min_off"))
            iot = parse_device_state(spec.get("iot", True))
            if iot is None:
                raise self.fail(f"{path}.iot", f"expected true or false, got {spec['iot']!r}")
            room = spec.get("room")
            least = {
                k: 60 * (self.minutes(spec[k], f"{path}.{k}") if k in spec else default_minutes(name))
                for k in ("min_on", "min_off")
            }
            out.append(Device(name=name, room=None if room is None else str(room), iot=iot, **least))
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

    def rewards(self, section: object) -> Rewards:
        if section is None:
            return Rewards()
        section = self.mapping(section, "rewards", allow_empty=True)
        self.keys(section, "rewards", ("weights", "magnitude"))
        weights = self.mapping(section.get("weights"), "rewards.weights", allow_empty=True)
        self.keys(weights, "rewards.weights", ("terminal", "progress", "prohibited"))
        default = Rewards()
        values = {
            k: self.number(weights.get(k, getattr(default.weights, k)), f"rewards.weights.{k}")
            for k in ("terminal", "progress", "prohibited")
        }
        magnitude = self.number(section.get("magnitude", default.magnitude), "rewards.magnitude")
        if magnitude <= 0:
            raise self.fail(
                "rewards.magnitude", f"expected a positive number, got {format_number(magnitude)}"
            )
        return Rewards(RewardWeights(**values), magnitude)


def load_home(name_or_path: str | Path) -> Home:
    """Load a home by built-in name (``paper``) or path, validated."""
    source, text = resolve_home(name_or_path)
    return load_home_text(text, source)


def load_home_text(text: str, source: str = "<home>") -> Home:
    """Parse and validate the YAML text of a home; ``source`` names it in errors."""
    return HomeValidator(source).home(read_yaml(text, source))
