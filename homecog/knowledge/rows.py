"""The tree's state and a build's samples as rows of the store's tables, and back.

The learner never touches SQL; :mod:`homecog.knowledge.store` runs the statements, this module
says what goes into them.

>>> from homecog.knowledge.model import Numeric
>>> text = encode_conditions({2: frozenset({1, 0}), 0: Numeric(count=2, total=3.0, low=1.0, high=2.0)})
>>> text
'{"0":{"n":2,"sum":3.0,"low":1.0,"high":2.0},"2":[0,1]}'
>>> decode_conditions(text)[2]
frozenset({0, 1})
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from datetime import datetime
from typing import Any

import numpy as np

from homecog.home.codec import Space
from homecog.home.model import Home
from homecog.home.recent import Recent
from homecog.knowledge import sample_log
from homecog.knowledge.corrections import Example
from homecog.knowledge.model import Cluster, Numeric
from homecog.knowledge.sample_log import SampleLog
from homecog.knowledge.samples import SampleSet
from homecog.knowledge.state import TreeState

SAMPLES_PER_ROW = 32768  # samples per row in the format that keeps codes and readings


def encode_conditions(conditions: dict[int, Any]) -> str:
    out = {}
    for j, cond in sorted(conditions.items()):
        if isinstance(cond, Numeric):
            out[str(j)] = {"n": cond.count, "sum": cond.total, "low": cond.low, "high": cond.high}
        else:
            out[str(j)] = sorted(cond)
    return json.dumps(out, separators=(",", ":"))


def decode_conditions(text_: str) -> dict[int, Any]:
    out: dict[int, Any] = {}
    for j, cond in json.loads(text_).items():
        if isinstance(cond, dict):
            out[int(j)] = Numeric(count=cond["n"], total=cond["sum"], low=cond["low"], high=cond["high"])
        else:
            out[int(j)] = frozenset(cond)
    return out


def cluster_from_row(row: Any) -> Cluster:
    """A cluster from a ``clusters`` row."""
    return Cluster(
        id=row.tree_id,
        conditions=decode_conditions(row.conditions),
        count=row.count,
        position_sum=row.position_sum,
        user=row.user,
        polarity=row.polarity,
        seed=None if row.seed is None else tuple(json.loads(row.seed)),
        seq=row.seq,
    )


def example_from_payload(home: Home, payload: dict[str, Any]) -> Example:
    """A user's correction as their layer keeps it, from its ``experiences`` row."""
    concerns = payload.get("concerns")
    return Example(
        codes=tuple(payload["codes"]),
        readings=tuple(payload["readings"]),
        want=frozenset(home.service_index(s) for s in payload["want"]),
        concerns=None if concerns is None else frozenset(home.service_index(s) for s in concerns),
        weight=int(payload.get("weight", 1)),
        recent=None if payload.get("recent") is None else Recent.from_dict(payload["recent"]),
        missing=frozenset(payload.get("missing", ())),
    )


def node_rows(state: TreeState) -> list[dict[str, Any]]:
    """The ``nodes`` rows of a tree."""
    return [
        {
            "id": n.id,
            "parent_id": n.parent,
            "name": n.name,
            "kind": n.kind,
            "service": n.service,
            "count": n.count,
            "position_sum": n.position_sum,
        }
        for n in state.nodes
    ]


def cluster_rows(pairs: Iterable[tuple[int, Cluster]], user: str | None) -> list[dict[str, Any]]:
    """The ``clusters`` rows of (node id, cluster) pairs, shared (``user`` None) or a user's."""
    return [
        {
            "node_id": node_id,
            "user": user,
            "tree_id": c.id,
            "polarity": c.polarity,
            "conditions": encode_conditions(c.conditions),
            "count": c.count,
            "position_sum": c.position_sum,
            "seq": c.seq,
            "seed": None if c.seed is None else json.dumps(list(c.seed)),
        }
        for node_id, c in pairs
    ]


def log_rows(
    log: SampleLog, build_id: int, mode: str, seconds: float | None, now: datetime
) -> list[dict[str, Any]]:
    return [
        {
            "kind": "samples",
            "user": None,
            "created_at": now,
            "payload": json.dumps(
                {
                    **payload,
                    "build": build_id,
                    "part": i,
                    "parts": len(log.parts),
                    "mode": mode,
                    "seconds": seconds,
                }
            ),
            "data": blob,
        }
        for i, (payload, blob) in enumerate(log.parts)
    ]


def sample_rows(
    samples: SampleSet, build_id: int, mode: str, seconds: float | None, now: datetime
) -> list[dict[str, Any]]:
    parts = max(1, -(-len(samples) // SAMPLES_PER_ROW))
    numeric = [j for j, d in enumerate(samples.space.dims) if d.numeric]
    rows = []
    for part in range(parts):
        chunk = slice(part * SAMPLES_PER_ROW, (part + 1) * SAMPLES_PER_ROW)
        rows.append(
            {
                "kind": "samples",
                "user": None,
                "created_at": now,
                "payload": json.dumps(
                    {
                        "build": build_id,
                        "part": part,
                        "parts": parts,
                        "mode": mode,
                        "seconds": seconds,
                        "count": len(samples.codes[chunk]),
                    }
                ),
                "data": sample_log.pack(
                    {
                        "codes": samples.codes[chunk],
                        "readings": samples.readings[chunk][:, numeric],
                        "numeric": np.array(numeric, dtype=np.int64),
                        "positions": samples.positions[chunk],
                        "masks": samples.masks[chunk],
                    }
                ),
            }
        )
    return rows


def samples_from(home: Home, arrays: list[dict[str, np.ndarray]]) -> SampleSet:
    space = Space(home)
    codes = np.concatenate([a["codes"] for a in arrays])
    readings = np.full((len(codes), len(space.dims)), np.nan)
    numeric = arrays[0]["numeric"]
    readings[:, numeric] = np.concatenate([a["readings"] for a in arrays])
    return SampleSet(
        space=space,
        codes=codes,
        readings=readings,
        positions=np.concatenate([a["positions"] for a in arrays]),
        masks=np.concatenate([a["masks"] for a in arrays]),
    )
