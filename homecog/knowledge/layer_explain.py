"""What a user's answer matched and its evidence, as the explanation of a cognition says it.

>>> _interval(type("F", (), {"kind": "number", "unit": "°C"})(), 23.0, math.inf)
'≥ 23 °C'
"""

from __future__ import annotations

import math
from typing import Any

from homecog.home.clock import format_clock
from homecog.home.model import format_number
from homecog.knowledge.corrections import UserLayers
from homecog.knowledge.keys import Decision


def layer_evidence(
    layers: UserLayers, user: str | None, a: int, decision: Decision
) -> tuple[dict[str, str], dict[str, Any]]:
    """What a user's answer matched — per feature of its key, the value or the learned
    interval — and its evidence: the corrections (the user's 1st, 2nd, …) in that cell that
    agree, how many agreed and how many did not."""
    assert user is not None
    learner = layers.learners(user)[a]
    conditions: dict[str, str] = {}
    for pos, j in enumerate(decision.key):
        if j == layers.n_features + layers.n_recent:
            conditions["shared knowledge"] = "proposes it" if decision.cell[pos] else "does not propose it"
            continue
        if j >= layers.n_features:
            names = [
                *layers.recent_names,
                "wanted just before",
                "services just before",
                "since its device switched",
            ]
            conditions[names[j - layers.n_features]] = str(decision.cell[pos])
            continue
        feature = layers.home.features[j]
        atom = decision.cell[pos]
        if feature.bins is None:
            conditions[feature.name] = feature.values[atom]  # type: ignore[index]
        elif isinstance(atom, tuple):
            conditions[feature.name] = f"{feature.values[atom[1]]} {feature.describe_bin(atom[1])}"  # type: ignore[index]
        else:
            conditions[feature.name] = _interval(feature, *learner.interval(decision, j))
    agree = decision.sign > 0
    members = [i for i, wanted in learner.members(decision) if wanted == agree]
    evidence = {
        "agreed": decision.wanted if agree else decision.unwanted,
        "disagreed": decision.unwanted if agree else decision.wanted,
        "corrections": members[-10:],
    }
    return conditions, evidence


def _interval(feature: Any, low: float, high: float) -> str:
    """A learned interval as people read it: ``≥ 23 °C``, ``[16, 25) °C``, ``18:30-07:00``."""
    if feature.kind == "clock":
        start, end = (0.0 if math.isinf(low) else low), (24.0 if math.isinf(high) else high)
        return f"{format_clock(start)}-{format_clock(end)}"
    unit = f" {feature.unit}" if feature.unit else ""
    if math.isinf(low) and math.isinf(high):
        return "any"
    if math.isinf(low):
        return f"< {format_number(high)}{unit}"
    if math.isinf(high):
        return f"≥ {format_number(low)}{unit}"
    return f"[{format_number(low)}, {format_number(high)}){unit}"
