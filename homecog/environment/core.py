"""The vectorized core of the smart-home environment.

A state is ``(c, h, n)``: the context index ``c`` (fixed within an episode), the device
states ``h`` as bits (bit ``i`` set = device ``i`` on) and the pending needs ``n`` as
bits over the needs of ``c`` (bit ``j`` = the ``j``-th interaction service ``c`` needs).
:class:`~homecog.environment.tables.Tables` holds the rules of a home as arrays
(:mod:`homecog.environment.tables`); the kernels of :mod:`homecog.environment.kernels` step
through them, and :mod:`homecog.environment.reachability` asks which start states reach their
optimum. :class:`Core` puts them together for one home.

States are numbered without collisions by a mixed-radix code: the context digits
(radix = number of values of each feature), then one binary digit per device, then one
binary digit per need *of that context*. Contexts with fewer needs take fewer rows, so
the numbering is dense: every index in ``range(n_states)`` is a state.

The kernels are plain Python over NumPy arrays, compiled by numba. Run with
``NUMBA_DISABLE_JIT=1`` they are the same algorithm as a plain-Python loop (the
benchmark and the equivalence test do that).

>>> from homecog.home import load_home
>>> core = Core(load_home("paper"))
>>> core.n_contexts, core.n_devices, core.n_services, core.n_states
(2592, 8, 20, 1410048)
"""

from __future__ import annotations

import numpy as np

from homecog.environment.kernels import distance, progressed, step, step_many
from homecog.environment.tables import build_tables
from homecog.errors import HomeTooLargeError
from homecog.home.encoding import context_codes, context_index
from homecog.home.model import Home

#: Largest Q table (states × services) the core builds: 2**31 entries (8 GiB of float32).
MAX_TABLE_ENTRIES = 2**31


class Core:
    """The environment of a home as arrays: sizes, state numbering and batched steps.

    >>> from homecog.home import load_home
    >>> core = Core(load_home("paper"))
    >>> c = core.context_of({"time": "night", "temperature": "suitable", "illumination":
    ...     "dark", "location": "bed", "posture": "lie", "behavior": "sleep"})
    >>> core.distance(c, core.bits([False, True, False, False, True, False, False, False]))
    2
    """

    def __init__(self, home: Home) -> None:
        self.home = home
        self.n_contexts = home.context_count
        self.n_devices = len(home.devices)
        self.n_services = len(home.services)
        if self.n_devices > 30:
            raise HomeTooLargeError(
                f"{home.name}: {self.n_devices} devices; a tabular Q table handles at most 30"
            )
        self.tables = build_tables(home)
        self.n_states = int(self.tables.offsets[-1])
        if self.n_states * self.n_services > MAX_TABLE_ENTRIES:
            raise HomeTooLargeError(
                f"{home.name}: {self.n_states:,} states × {self.n_services} services is too large "
                f"for a tabular Q table (at most {MAX_TABLE_ENTRIES:,} entries); "
                "use fewer features, values, devices or needs"
            )

    # -- numbering ---------------------------------------------------------------------
    def context_of(self, values: dict[str, str]) -> int:
        """Context index from value names (bin names or categories) per feature."""
        codes = [f.index(values[f.name]) for f in self.home.features]
        return context_index(self.home, codes)

    def codes(self, c: int) -> tuple[int, ...]:
        """Feature codes of context c."""
        return context_codes(self.home, c)

    @staticmethod
    def bits(states: list[bool] | tuple[bool, ...]) -> int:
        """Device states as bits (device 0 = bit 0)."""
        return sum(1 << d for d, on in enumerate(states) if on)

    def states(self, h: int) -> tuple[bool, ...]:
        """Bits as device states."""
        return tuple(bool(h >> d & 1) for d in range(self.n_devices))

    def full_needs(self, c: int) -> int:
        """Pending-needs bits at the start of an episode in context c."""
        return (1 << int(self.tables.need_count[c])) - 1

    def need_services(self, c: int) -> list[int]:
        """Services needed in context c, in need-bit order."""
        row = self.tables.need_pos[c]
        return [int(a) for a in np.argsort(row) if row[a] >= 0]

    def index(self, c: int, h: int, n: int) -> int:
        """Q-table row of state (c, h, n)."""
        return int(self.tables.offsets[c]) + (h << int(self.tables.need_count[c])) + n

    def decode(self, s: int) -> tuple[int, int, int]:
        """Inverse of :meth:`index`."""
        if not 0 <= s < self.n_states:
            raise ValueError(f"state {s} out of range 0..{self.n_states - 1}")
        c = int(np.searchsorted(self.tables.offsets, s, side="right") - 1)
        rest = s - int(self.tables.offsets[c])
        k = int(self.tables.need_count[c])
        return c, rest >> k, rest & ((1 << k) - 1)

    # -- dynamics ----------------------------------------------------------------------
    def distance(self, c: int, h: int, n: int | None = None) -> int:
        """Distance to the optimum (pending needs default to all needs of c)."""
        n = self.full_needs(c) if n is None else n
        return int(distance(self.tables.care[c], self.tables.want[c], h, n))

    def progressed(self, c: int, h: int, n: int, h2: int, n2: int) -> bool:
        """Whether a step from (c, h, n) to (c, h2, n2) is progress (:func:`progressed`)."""
        care, want = int(self.tables.care[c]), int(self.tables.want[c])
        return bool(progressed(care, want, h, h2, self.distance(c, h, n), self.distance(c, h2, n2)))

    def wanted(self, c: int) -> tuple[bool | None, ...]:
        """Per device, the wanted state in context c (None: don't care)."""
        care, want = int(self.tables.care[c]), int(self.tables.want[c])
        return tuple(bool(want >> d & 1) if care >> d & 1 else None for d in range(self.n_devices))

    def step(self, c: int, h: int, n: int, a: int) -> tuple[int, int, float, bool, bool]:
        """(h', n', reward, terminated, prohibited) of service a in state (c, h, n)."""
        h2, n2, r, done, forbidden = step(self.tables, c, h, n, a)
        return int(h2), int(n2), float(r), bool(done), bool(forbidden)

    def step_many(self, c: np.ndarray, h: np.ndarray, n: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, ...]:
        """:meth:`step` over arrays (int64) of states and services."""
        args = (np.asarray(x, dtype=np.int64) for x in (c, h, n, a))
        return step_many(self.tables, *args)

    def n_start_states(self) -> int:
        """Number of start states: every context and device state, all needs pending."""
        return self.n_contexts * (1 << self.n_devices)

    def table_bytes(self) -> int:
        """Bytes of a Q table (float32) plus its tried marks."""
        return self.n_states * self.n_services * 5
