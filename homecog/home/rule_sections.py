"""The rule sections of a home file: ``comfort`` (a device's wanted state where a condition
holds), ``needs`` and ``prohibited`` (a service's conditions), and the conditions they share.

A condition names features (and, outside ``comfort`` and ``needs``, devices) with the values it
allows; a single value may stand for a list of one.

>>> from homecog.home import load_home
>>> home = load_home("paper")
>>> rule = home.comfort[home.device_index("lamp")][0]
>>> rule.want, [home.features[f].name for f, _ in rule.when.features]
(True, ['location', 'behavior'])
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from homecog.home.model import ComfortRule, Condition, Device, Feature, Service
from homecog.home.shapes import ShapeChecks, kind_of, parse_device_state


class RuleSections(ShapeChecks):
    """The validation of ``comfort``, ``needs`` and ``prohibited`` against a home's features
    and devices."""

    def __init__(self, source: str, features: tuple[Feature, ...], devices: tuple[Device, ...]) -> None:
        super().__init__(source)
        self.features = features
        self.devices = devices

    def condition(self, spec: object, path: str, context_only: bool) -> Condition:
        spec = self.mapping(spec, path, allow_empty=True)
        fnames = [f.name for f in self.features]
        dnames = [d.name for d in self.devices]
        fconds, dconds = [], []
        for key, allowed in spec.items():
            kpath = f"{path}.{key}"
            values = allowed if isinstance(allowed, list) else [allowed]
            if not values:
                raise self.fail(kpath, "empty value list")
            if key in fnames:
                feature = self.features[fnames.index(key)]
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
            raise self.fail(path, f"expected a list of rules, got {kind_of(spec)}")
        out = []
        for i, rule in enumerate(spec):
            rpath = f"{path}[{i}]"
            out.append(parse(self.mapping(rule, rpath, allow_empty=True), rpath))
        return tuple(out)

    def by_name(
        self,
        section: object,
        key: str,
        names: list[str],
        what: str,
        parser: Callable[[str, str], Callable[[dict[str, Any], str], Any]],
    ) -> tuple[tuple[Any, ...], ...]:
        """A section of rules per device or service, in the home's order (none where it has
        none); ``parser(name, path)`` checks the name and gives the parse of one of its rules."""
        section = self.mapping(section, key, allow_empty=True)
        found: dict[str, tuple[Any, ...]] = {}
        for name, rules in section.items():
            path = f"{key}.{name}"
            if name not in names:
                raise self.fail(path, f"unknown {what} {name!r}; expected one of {', '.join(names)}")
            found[name] = self.rules(rules, path, parser(name, path))
        return tuple(found.get(name, ()) for name in names)

    def comfort(self, section: object) -> tuple[tuple[ComfortRule, ...], ...]:
        def parse(rule: dict[str, Any], rpath: str) -> ComfortRule:
            self.keys(rule, rpath, ("when", "want"), ("want",))
            when = self.condition(rule.get("when"), f"{rpath}.when", True)
            want = parse_device_state(rule["want"])
            if want is None:
                raise self.fail(f"{rpath}.want", f"expected on or off, got {rule['want']!r}")
            return ComfortRule(when=when, want=want)

        return self.by_name(
            section, "comfort", [d.name for d in self.devices], "device", lambda _n, _p: parse
        )

    def service_rules(
        self, section: object, key: str, services: tuple[Service, ...]
    ) -> tuple[tuple[Condition, ...], ...]:
        snames = [s.name for s in services]

        def parse(rule: dict[str, Any], rpath: str) -> Condition:
            self.keys(rule, rpath, ("when",))
            return self.condition(rule.get("when"), f"{rpath}.when", context_only=key == "needs")

        def parser(service: str, path: str) -> Callable[[dict[str, Any], str], Condition]:
            if key == "needs" and not services[snames.index(service)].is_interaction:
                raise self.fail(
                    path,
                    f"needs are for interaction services; {service} sets devices "
                    "(its wanted states come from the comfort rules)",
                )
            return parse

        return self.by_name(section, key, snames, "service", parser)
