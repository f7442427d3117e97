"""A user's learned layer kept on disk, so that a restart need not learn it again.

A user's layer is a pure function of their corrections in order and of the shared tree
(:mod:`homecog.knowledge.corrections`): after a restart the first answer for the user learned it
again from every correction, some 35 ms a correction of a stream (a year's history: hours). A
snapshot keeps what the layer learned — the user's learners, additive model and threshold — with
the build of the shared tree it was learned over and a digest of the corrections it holds. A
layer made again starts from the snapshot where both match the corrections' first ones, and
learns only the corrections after them.

Snapshots live in the data directory (private, ``0700``; each file ``0600``), one folder per
database and build, a file per user named by a digest of the user's name. They are this
process's own cache, written and read by homecog alone (pickle): a file that cannot be read, or
that belongs to another build, is ignored, and the layer is learned from the corrections.

>>> import tempfile
>>> from homecog.knowledge.corrections import Example
>>> snaps = LayerSnapshots(Path(tempfile.mkdtemp()), build="b1")
>>> examples = [Example((1, 0), (None, None), frozenset({2}))]
>>> snaps.save("ann", examples, {"learned": 1})
>>> snaps.load("ann", examples + [Example((0, 0), (None, None), frozenset())])
(1, {'learned': 1})
>>> snaps.load("ann", [Example((0, 0), (None, None), frozenset())]) is None  # other corrections
True
>>> LayerSnapshots(snaps.folder, build="b2").load("ann", examples) is None  # another build
True
"""

from __future__ import annotations

import hashlib
import logging
import pickle
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from homecog.errors import StoreError
from homecog.paths import atomic_write

if TYPE_CHECKING:
    from homecog.knowledge.corrections import Example

log = logging.getLogger(__name__)

#: a layer learned again in at least this many seconds is kept (a quicker one is not worth it)
KEEP_AFTER = 1.0
#: what a snapshot holds changes with this (another's is ignored)
FORMAT = 2


class LayerSnapshots:
    """The snapshots of one database's users' layers, for one build of its shared tree."""

    def __init__(self, folder: Path, build: str) -> None:
        self.folder = folder
        self.build = build

    def _path(self, user: str) -> Path:
        return self.folder / f"{hashlib.sha256(user.encode()).hexdigest()[:24]}.pickle"

    def save(self, user: str, examples: Sequence[Example], learned: Any) -> None:
        """Keep what a user's layer learned from ``examples`` (every one of their corrections so
        far); a snapshot that cannot be written is logged and left out."""
        kept = {
            "format": FORMAT,
            "build": self.build,
            "n": len(examples),
            "digest": digest(examples),
            "learned": learned,
        }
        try:
            with atomic_write(self._path(user), StoreError) as f:
                pickle.dump(kept, f, protocol=pickle.HIGHEST_PROTOCOL)
        except (StoreError, pickle.PicklingError) as e:
            log.warning("the layer of %r could not be kept: %s", user, e)

    def load(self, user: str, examples: Sequence[Example]) -> tuple[int, Any] | None:
        """What a user's layer learned from the first of ``examples`` (how many, and it), or None
        where no snapshot of this build holds a prefix of them."""
        path = self._path(user)
        try:
            with path.open("rb") as f:
                kept = pickle.load(f)
            n = kept["n"]
            if (
                kept.get("format") != FORMAT
                or kept["build"] != self.build
                or n > len(examples)
                or kept["digest"] != digest(examples[:n])
            ):
                return None
            return n, kept["learned"]
        except FileNotFoundError:
            return None
        except Exception as e:
            log.warning("the kept layer %s is not used: %s", path, e)
            return None


def digest(examples: Sequence[Example]) -> str:
    """A digest of corrections, the same in every process (sets written in order)."""
    h = hashlib.sha256()
    for e in examples:
        concerns = None if e.concerns is None else sorted(e.concerns)
        recent = None if e.recent is None else sorted(e.recent.as_dict().items(), key=lambda kv: kv[0])
        h.update(
            repr(
                (e.codes, e.readings, sorted(e.want), concerns, e.weight, recent, sorted(e.missing))
            ).encode()
        )
    return h.hexdigest()
