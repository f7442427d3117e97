"""What learning depends on in a home: its canonical form as plain data, the content hash of it,
and whether a truth home is compatible with a home.

The hash leaves out the name, descriptions, rooms, the ``iot`` flags, layout and routine, so
editing a floor plan does not throw a trained Q table away.

>>> from homecog.home import load_home
>>> home = load_home("paper")
>>> content_hash(home) == home.content_hash, len(home.content_hash)
(True, 64)
>>> is_compatible(home, home)
[]
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

from homecog.home.model import Condition, Home
from homecog.home.states import state_word


def _condition_json(home: Home, cond: Condition) -> dict[str, list[str]]:
    out = {
        home.features[f].name: sorted(home.features[f].values[k] for k in codes) for f, codes in cond.features
    }
    out.update({home.devices[d].name: sorted(state_word(s) for s in states) for d, states in cond.devices})
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
        "rewards": home.rewards.as_list(),
    }


def content_hash(home: Home) -> str:
    """SHA-256 of :func:`canonical`: equal for homes that learn the same, whatever their layout."""
    text = json.dumps(canonical(home), sort_keys=False, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def is_compatible(truth: Home, home: Home) -> list[str]:
    """What differs between a truth home and a home where the two must be equal ([] = compatible)."""
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
