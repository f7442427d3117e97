"""A build's samples as the experience log keeps them, compactly.

A home of 48 or 1,000 devices has millions of samples; storing each one's codes and readings
would make the log gigabytes. What the policy decided is stored — per sample the step at
which each service is performed (int8) and what matters to it (an index into the few distinct
masks) — and what is a function of the home and the seed is made again when the tree is
rebuilt: the codes, which are every start state of the group in order (over the group's
classes of contexts since format 3, over every context before), and the readings, drawn from
the build's seed exactly as the build drew them.

Rows hold at most :data:`ROWS_PER_PART` samples, so no database row grows past a few
megabytes; a rebuild joins a group's parts before it learns them, in the build's order.
"""

from __future__ import annotations

import io
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from homecog.home.codec import Space
from homecog.home.groups import device_groups, project
from homecog.home.model import Home
from homecog.knowledge.samples import SampleSet, code_dtype, draw_readings, placed, start_codes

FORMAT = 3
ROWS_PER_PART = 1 << 17


def pack(arrays: dict[str, np.ndarray]) -> bytes:
    """Arrays as one compressed blob (``np.savez`` in zlib)."""
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return zlib.compress(buf.getvalue(), 1)  # fast: a build logs millions of samples


def unpack(data: bytes) -> dict[str, np.ndarray]:
    """Inverse of :func:`pack`."""
    with np.load(io.BytesIO(zlib.decompress(data)), allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


@dataclass
class SampleLog:
    """What a build writes to the log: ``parts`` of (payload, blob), in learning order."""

    seed: int
    joint: bool
    parts: list[tuple[dict[str, Any], bytes]] = field(default_factory=list)
    count: int = 0

    def __len__(self) -> int:
        return self.count

    def add(self, samples: SampleSet, group: int) -> None:
        """Log the samples of one group (or, joint, of the home)."""
        masks, index = np.unique(samples.masks, return_inverse=True)
        index = index.reshape(samples.masks.shape).astype(np.uint16 if len(masks) < 2**16 else np.uint32)
        n = len(samples)
        for start in range(0, max(n, 1), ROWS_PER_PART):
            rows = slice(start, start + ROWS_PER_PART)
            payload = {
                "format": FORMAT,
                "group": group,
                "start": start,
                "count": len(samples.positions[rows]),
                "total": n,
                "seed": self.seed,
                "joint": self.joint,
            }
            blob = pack({"positions": samples.positions[rows], "masks": masks, "index": index[rows]})
            self.parts.append((payload, blob))
        self.count += n


def regenerate(home: Home, rows: list[tuple[dict[str, Any], bytes]]) -> Iterator[SampleSet]:
    """The sample sets of a logged build, one per group in learning order (see the module)."""
    by_group: dict[int, list[tuple[dict[str, Any], bytes]]] = {}
    for payload, blob in rows:
        by_group.setdefault(payload["group"], []).append((payload, blob))
    groups = device_groups(home)
    for g, parts in by_group.items():
        parts.sort(key=lambda p: p[0]["start"])
        meta = parts[0][0]
        arrays = [unpack(blob) for _, blob in parts]
        positions = np.concatenate([a["positions"] for a in arrays])
        masks = np.concatenate([a["masks"][a["index"]] for a in arrays])
        classes = meta.get("format") != 2  # format 2 logged every context of a group
        if meta["joint"]:
            seen, rng = home, np.random.default_rng(meta["seed"])
        else:
            seen = project(home, groups[g], classes=classes)
            rng = np.random.default_rng([meta["seed"], groups[g].index])
        space = Space(seen)
        codes = start_codes(seen)
        if len(codes) != meta["total"] or len(positions) != meta["total"]:
            raise ValueError(f"logged samples of group {g} do not fit the home")
        samples = SampleSet(
            space=space,
            codes=codes.astype(code_dtype(space)),
            readings=draw_readings(space, codes, rng),
            positions=positions,
            masks=masks,
        )
        if not meta["joint"]:
            placed(samples, home, groups[g], meta["seed"])
            if not classes:
                samples.classes = samples.origin = None
        yield samples
