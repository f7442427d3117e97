"""Random homes, written as a user writes a home file, for property tests (hypothesis).

A home has a clock whose bins may wrap midnight, a numeric feature, a ``location`` with up to six
values and sometimes an activity; up to seven devices in up to three rooms, some switched by hand,
each with a service each way; scenes that set several devices across rooms; sometimes a service
that sets two devices and is forbidden by a third's state (so it ties them, as no scene does);
interaction services with needs; comfort rules over one or two features; prohibited rules over the
context and over device states. Homes stay small (a few hundred contexts) so that each is learned,
built and judged in well under a second.

>>> from hypothesis import given, settings
>>> from homecog.home import load_home_text
>>> @settings(max_examples=3, deadline=None, derandomize=True)
... @given(homes())
... def loads(text):
...     assert load_home_text(text, "random.yaml").devices
>>> loads()
"""

from __future__ import annotations

import itertools

from hypothesis import strategies as st

ROOMS = ("hall", "den", "loft")
KINDS = ("lamp", "fan", "blind", "heater", "radio", "vent", "light")


def _yaml_list(values: list[str]) -> str:
    return "[" + ", ".join(values) + "]"


@st.composite
def _clock(draw: st.DrawFn) -> tuple[str, list[str]]:
    """2 to 4 bins over the whole day (the text, the bin names); the last wraps midnight unless
    the first starts at 0."""
    cuts = sorted(draw(st.sets(st.integers(1, 23), min_size=2, max_size=4)))
    if draw(st.booleans()):
        cuts[0] = 0
    bins = [f"b{i}: [{a}, {b}]" for i, (a, b) in enumerate(itertools.pairwise(cuts))]
    bins.append(f"b{len(cuts) - 1}: [{cuts[-1]}, {cuts[0] if cuts[0] else 24}]")
    return "{kind: clock, bins: {" + ", ".join(bins) + "}}", [f"b{i}" for i in range(len(cuts))]


@st.composite
def _when(draw: st.DrawFn, features: dict[str, list[str]], devices: list[str] | None = None) -> str:
    """A condition over one or two features (and, given ``devices``, maybe one device's state)."""
    names = draw(st.lists(st.sampled_from(sorted(features)), min_size=1, max_size=2, unique=True))
    parts = []
    for name in names:
        values = features[name]
        most = max(1, len(values) - 1)
        chosen = draw(st.lists(st.sampled_from(values), min_size=1, max_size=most, unique=True))
        parts.append(f"{name}: {_yaml_list(chosen)}")
    if devices:
        parts.append(f"{draw(st.sampled_from(devices))}: [{draw(st.sampled_from(['on', 'off']))}]")
    return "{" + ", ".join(parts) + "}"


def _context(draw: st.DrawFn) -> tuple[list[str], dict[str, list[str]]]:
    """The ``context:`` lines and each feature's values (its bins' or its own)."""
    clock, bins = draw(_clock())
    features = {
        "clock": bins,
        "warmth": ["cool", "mild", "hot"],
        "location": [f"spot{i}" for i in range(draw(st.integers(2, 6)))],
    }
    lines = [
        "name: random",
        "context:",
        f"  clock: {clock}",
        '  warmth: {kind: numeric, unit: "°C", bins: {cool: [-.inf, 18], mild: [18, 26], hot: [26, .inf]}}',
        f"  location: {{kind: categorical, values: {_yaml_list(features['location'])}}}",
    ]
    if draw(st.booleans()):
        features["doing"] = ["rest", "work"]
        lines.append("  doing: {kind: categorical, values: [rest, work]}")
    return lines, features


def _services(draw: st.DrawFn, devices: list[str], lines: list[str], prohibited: list[str]) -> list[str]:
    """The ``services:`` lines but the interactions (one on and one off per device, scenes, a
    pair prohibited by a device state) and their names."""
    lines.append("services:")
    services: list[str] = []
    for d in devices:
        lines.append(f"  On_{d}: {{category: on, set: {{{d}: on}}}}")
        lines.append(f"  Off_{d}: {{category: off, set: {{{d}: off}}}}")
        services += [f"On_{d}", f"Off_{d}"]
    for k in range(draw(st.integers(0, 3))):
        members = draw(
            st.lists(st.sampled_from(devices), min_size=2, max_size=min(4, len(devices)), unique=True)
        )
        sets = ", ".join(f"{d}: {draw(st.sampled_from(['on', 'off']))}" for d in members)
        lines.append(f"  Scene{k}: {{category: scene, set: {{{sets}}}}}")
        services.append(f"Scene{k}")
    if len(devices) >= 3 and draw(st.booleans()):
        a, b, c = draw(st.lists(st.sampled_from(devices), min_size=3, max_size=3, unique=True))
        lines.append(f"  Pair: {{category: pair, set: {{{a}: off, {b}: off}}}}")
        prohibited.append(f"  Pair: [{{when: {{{c}: [on]}}}}]")
        services.append("Pair")
    return services


def _comfort(draw: st.DrawFn, devices: list[str], features: dict[str, list[str]], lines: list[str]) -> None:
    """The ``comfort:`` lines: one to three rules a device, sometimes a default."""
    lines.append("comfort:")
    for d in devices:
        rules = [
            f"{{when: {draw(_when(features))}, want: {draw(st.sampled_from(['on', 'off']))}}}"
            for _ in range(draw(st.integers(1, 3)))
        ]
        if draw(st.booleans()):
            rules.append(f"{{want: {draw(st.sampled_from(['on', 'off']))}}}")
        lines.append(f"  {d}: [{', '.join(rules)}]")


@st.composite
def homes(draw: st.DrawFn) -> str:
    """The text of a random home file."""
    lines, features = _context(draw)
    n_dev = draw(st.integers(2, 7))
    devices = [f"{KINDS[i]}{i}" for i in range(n_dev)]
    rooms = {d: draw(st.sampled_from(ROOMS)) for d in devices}
    lines.append("devices:")
    for d in devices:
        lines.append(f"  {d}: {{room: {rooms[d]}, iot: {str(draw(st.booleans())).lower()}}}")
    prohibited: list[str] = []
    services = _services(draw, devices, lines, prohibited)
    interactions = [f"Talk{k}" for k in range(draw(st.integers(0, 2)))]
    lines += [f"  {t}: {{category: talk}}" for t in interactions]
    _comfort(draw, devices, features, lines)
    if interactions:
        lines.append("needs:")
        lines += [f"  {t}: [{{when: {draw(_when(features))}}}]" for t in interactions]
    for name in draw(st.lists(st.sampled_from(services + interactions), max_size=3, unique=True)):
        if name == "Pair":
            continue
        with_device = draw(st.booleans()) and not name.startswith("Scene")
        prohibited.append(f"  {name}: [{{when: {draw(_when(features, devices if with_device else None))}}}]")
    if prohibited:
        lines += ["prohibited:", *prohibited]
    return "\n".join(lines) + "\n"
