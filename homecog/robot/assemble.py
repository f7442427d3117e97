"""The composition root: the one place where a running robot (:class:`Runtime`) is put together
from its parts — the knowledge store, the tree (loaded, or built when the database has none),
the context source, the household's settings, the robot's body and how fresh the tree is kept
— for ``homecog up`` (:mod:`homecog.cli.up`), each home of ``homecog serve``
(:mod:`homecog.fleet.serve`) and the closed loop (:mod:`homecog.evaluation.closed_loop`).

A caller says what it wants in a :class:`Wiring` and hands over the parts it already holds (a
store another one owns, a source it started); :func:`assemble` makes the rest in a fixed
order: the store, the tree, the source, the runtime, then a simulated household living in the
home. The store it opens is the caller's to close (``runtime.store.close()``), unless the
assembly fails, when it is closed here.

>>> from homecog.home import load_home
>>> home = load_home("paper")
>>> runtime = assemble(Wiring(home, db="sqlite://"), tree=IHDRTree(home)).runtime  # an empty tree
>>> type(runtime.source).__name__, runtime.fresh, runtime.household == home.household
('ManualSource', None, True)
>>> runtime.store.close()
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

from homecog.context import ContextSource
from homecog.home.household import Household
from homecog.home.model import Home
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.store import Store
from homecog.robot.runtime import Runtime

if TYPE_CHECKING:
    from homecog.context.simulated import SimulatedHome
    from homecog.evaluation.closed_loop import SimulatedHousehold

#: a source given ready, or made from the home once the store and the tree are (a simulated
#: home's clock starts when it is made: not before a long training)
SourceSpec = ContextSource | Callable[[Home], ContextSource] | None


@dataclass(frozen=True)
class Wiring:
    """What a running robot is made of, as its caller chooses it.

    ``db``: the knowledge database's URL (None: the default file of the home), used when no
    store is given. ``build``: the tree built (and the Q table trained) when the database has
    none; else the stored one is loaded. ``fresh``: seconds at most between two looks at the
    database for another process's writes (None: this process alone writes). ``household``:
    the household's settings (None: the home file's). ``robot``: the robot's body in a
    simulated home. ``truth``: a simulated household of this home's wishes lives in the
    (simulated) home and switches by hand what is not as it wants.
    """

    home: Home
    db: str | None = None
    build: bool = True
    fresh: float | None = None
    household: Household | None = None
    robot: str = "builtin"
    truth: Home | None = None


@dataclass
class Assembled:
    """A running robot, and the simulated household living with it (if :class:`Wiring` has a
    ``truth``): the closed loop reads what it did."""

    runtime: Runtime
    living: SimulatedHousehold | None = None


def assemble(
    wiring: Wiring,
    *,
    store: Store | None = None,
    tree: IHDRTree | None = None,
    source: SourceSpec = None,
    progress: Callable[[str], Any] | None = None,
) -> Assembled:
    """The running robot of ``wiring``, from the parts given and those it makes: the store
    (opened from ``wiring.db``), the tree (:func:`~homecog.knowledge.pipeline.open_tree` with
    ``progress`` if ``wiring.build``, else the stored one), the source (a ready one, one made
    from the home, or by hand: :class:`~homecog.context.manual.ManualSource`)."""
    home = wiring.home
    opened = store is None
    if store is None:
        store = Store.open(wiring.db, home)
    try:
        if tree is None:
            tree = _tree(home, store, build=wiring.build, progress=progress)
        runtime = Runtime(
            home=home,
            store=store,
            tree=tree,
            source=_source(home, source),
            household=wiring.household,
            robot=wiring.robot,
            fresh=wiring.fresh,
        )
    except BaseException:
        if opened:
            store.close()
        raise
    living = None
    if wiring.truth is not None:  # after the runtime: the robot hears the home's changes first
        from homecog.evaluation.closed_loop import SimulatedHousehold

        assert runtime.household is not None  # the home's own settings unless given
        simulated = cast("SimulatedHome", runtime.source)  # a household lives in a simulated home
        living = SimulatedHousehold(wiring.truth, simulated, undo_window=runtime.household.undo_window)
        runtime.after_tick.append(living.step)
    return Assembled(runtime, living)


def _tree(home: Home, store: Store, *, build: bool, progress: Callable[[str], Any] | None) -> IHDRTree:
    if not build:
        return store.load_tree()
    from homecog.knowledge.pipeline import open_tree

    return open_tree(home, store, progress=progress)


def _source(home: Home, source: SourceSpec) -> ContextSource:
    if source is None:
        from homecog.context.manual import ManualSource

        return ManualSource(home)
    if isinstance(source, ContextSource):
        return source
    return source(home)
