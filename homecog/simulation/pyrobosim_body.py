"""pyrobosim as the robot's body: the plan's actions carried out in a pyrobosim world
made from the home's floor plan (:mod:`homecog.simulation.pyrobosim_world`), with pyrobosim's own
path planners, navigation, picking and placing.

========================  ===========================================================
action                    in pyrobosim
========================  ===========================================================
``move a b``              ``Robot.navigate`` to the location ``b`` (or the room): its
                          path planner plans, its executor drives the path
``pick obj place``        ``Robot.pick_object``: the object must be at the robot's
                          location
``pour obj place``        held and at its source: the robot's own check; it takes its time
``hand_over obj user``    ``Robot.place_object`` at the user's place
``speak text``            takes its time
``switch_iot dev on``     the home's switch (an IoT command)
``switch_by_hand dev on`` at the device's location, then the home's switch
``dock place``            at a location that is a charger: its battery full
========================  ===========================================================

Every action first checks the planning domain's preconditions against the world as pyrobosim
has it (where the robot stands, what it holds, where the objects are), then asks pyrobosim,
and answers with pyrobosim's own message when it fails (``Failed to plan a path.``); an
exception inside pyrobosim is a failure too, never raised. Times and the trajectory are
recorded as the built-in body records them (:meth:`~homecog.simulation.Simulation.record`):
a move by pyrobosim's trajectory, every other action by its duration.

pyrobosim is an optional extra (``pip install 'homecog[pyrobosim]'``); without it the body says
so in one line (:class:`~homecog.errors.DependencyNotInstalledError`).
"""

from __future__ import annotations

import contextlib
import logging
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, Unpack

import numpy as np

from homecog.errors import DependencyNotInstalledError, PlanningError
from homecog.home.model import Home
from homecog.planning import State, initial_state
from homecog.planning.state import HELD
from homecog.simulation.interface import Body, BodyOptions, Outcome
from homecog.simulation.pyrobosim_world import _rooms, place_pose, pyrobosim_world
from homecog.simulation.simulate import Simulation, SimulationResult

INSTALL = "pip install 'homecog[pyrobosim]'"
_QUIET = logging.ERROR  # pyrobosim logs every action at INFO; its failures come back as messages


def require_pyrobosim() -> Any:
    """pyrobosim's world loader, its planners registered; :class:`DependencyNotInstalledError`
    with the install hint where the extra is not installed."""
    try:
        import pyrobosim.navigation  # noqa: F401  registers the path planners by name
        from pyrobosim.core import WorldYamlLoader
    except ImportError as e:
        missing = (e.name or "pyrobosim").split(".")[0]
        raise DependencyNotInstalledError(
            f"the pyrobosim body needs the [pyrobosim] extra, and {missing} cannot be imported: {INSTALL}"
        ) from None
    return WorldYamlLoader


class PyRoboSimBody(Body):
    """The robot in a pyrobosim world made from ``home``'s floor plan.

    Parameters
    ----------
    home, world, switch, robot, domain
        As for every :class:`~homecog.simulation.interface.Body`.
    planner
        pyrobosim's path planner: ``astar`` (default), ``rrt``, ``prm`` or ``world_graph``.
    seed
        Seeds numpy's global generator, which pyrobosim's sampling planners draw from, at
        every :meth:`start` (``None``: left alone).
    """

    name = "pyrobosim"

    def __init__(
        self,
        home: Home,
        world: State | None = None,
        *,
        planner: str = "astar",
        seed: int | None = 0,
        **options: Unpack[BodyOptions],
    ) -> None:
        self._loader = require_pyrobosim()
        self.planner, self.seed = planner, seed
        self.planning_seconds = 0.0  # the wall time pyrobosim's path planner took, all runs
        self.simulation: Simulation
        super().__init__(home, world, **options)

    def _prepare(self) -> None:
        """The pyrobosim world made from the home's floor plan, its loggers quiet."""
        self.layout = self.home.layout  # PlanningError just below when there is none
        spec = pyrobosim_world(self.home, robot=self.diffdrive, planner=self.planner)
        self._rooms = _rooms(self.layout)  # type: ignore[arg-type]
        with tempfile.TemporaryDirectory(prefix="homecog-pyrobosim-") as folder, _quiet():
            self.world = self._loader().from_file(spec.write(Path(folder) / "world.yaml")[0])
        for logger in (
            logging.getLogger("pyrobosim"),
            self.world.logger,
            *(r.logger for r in self.world.robots),
        ):
            logger.setLevel(_QUIET)
        self.robot = self.world.robots[0]

    # -- the run ------------------------------------------------------------------------------
    def start(self, world: State | None = None) -> None:
        from pyrobosim.core.types import set_parent
        from pyrobosim.utils.pose import Pose

        world = world if world is not None else initial_state(self.home)
        if self.seed is not None:
            np.random.seed(self.seed)
        x, y, yaw = place_pose(self.layout, self._rooms, world.robot, self.diffdrive.radius)  # type: ignore[arg-type]
        held = self.robot.manipulated_object
        if held is not None and world.holding != held.name:
            self.robot.manipulated_object = None
        self.robot.set_pose(Pose(x=x, y=y, yaw=yaw))
        for obj in self.world.objects:
            where = world.objects.get(obj.name)
            if where == HELD:
                self.robot._attach_object(obj)
            elif where is not None:
                spawn = self.world.get_entity_by_name(where).children[0]
                set_parent(obj, spawn)
                obj.set_pose(Pose(x=spawn.pose.x, y=spawn.pose.y))
                obj.create_polygons()
        self.robot.battery_level = 100.0
        self.simulation = Simulation(
            self.home, world, robot=self.diffdrive, domain=self.domain, pose=(x, y, yaw)
        )

    def observe(self) -> State:
        """The planning state with the robot's place, what it holds and where the objects are
        as pyrobosim has them; the devices and the user as the run left them."""
        state = self.simulation.state.copy()
        place = self._place()
        if place is not None:
            state.robot = place
        held = self.robot.manipulated_object
        state.holding = held.name if held is not None else None
        for obj in self.world.objects:
            parent = obj.parent
            if obj.name in state.objects and parent is not None:
                state.objects[obj.name] = HELD if parent is self.robot else parent.parent.name
        return state

    def result(self) -> SimulationResult:
        return self.simulation.result()

    # -- the actions (pour and speak, with no physical part, are Body's own) ---------------------
    def move(self, origin: str, target: str) -> Outcome:
        def navigate() -> tuple[Outcome, np.ndarray | None]:
            if self._place() == target:
                return Outcome.done(), None  # there already: nothing to drive
            try:  # planned apart from following: some planners raise where they find no path
                path = self.robot.plan_path(goal=target)
            except Exception:
                path = None
            if path is None or path.num_poses < 2:
                return Outcome.failed(f"pyrobosim: Failed to plan a path to {target!r}."), None
            self.planning_seconds += path.planning_time
            answer = self.robot.navigate(path=path, realtime_factor=-1.0)
            if not answer.is_success():
                return Outcome.failed(f"pyrobosim: {answer.message or answer.status.name}"), None
            return Outcome.done(), self._poses()

        return self._act(("move", origin, target), navigate)

    def pick(self, obj: str, place: str) -> Outcome:
        return self._act(("pick", obj, place), lambda: (_answer(self.robot.pick_object(obj)), None))

    def hand_over(self, obj: str, who: str) -> Outcome:
        return self._act(("hand_over", obj, who), lambda: (_answer(self.robot.place_object()), None))

    def switch_iot(self, device: str, setting: str) -> Outcome:
        return self._act(("switch_iot", device, setting), lambda: (self._switch(device, setting), None))

    def switch_by_hand(self, device: str, setting: str) -> Outcome:
        return self._act(("switch_by_hand", device, setting), lambda: (self._switch(device, setting), None))

    def dock(self, place: str) -> Outcome:
        def charge() -> tuple[Outcome, None]:
            where = self.robot.location
            location = getattr(where, "parent", None)
            if location is None or not getattr(location, "is_charger", False):
                return Outcome.failed(f"pyrobosim: {place!r} is no charger"), None
            return (
                Outcome.done() if self.robot.battery_level >= 100.0 else Outcome.failed("not charging")
            ), None

        return self._act(("dock", place), charge)

    # -- helpers ----------------------------------------------------------------------------------
    def _act(
        self, action: tuple[str, ...], physical: Callable[[], tuple[Outcome, np.ndarray | None]] | None = None
    ) -> Outcome:
        """Check ``action`` against the world as pyrobosim has it, let pyrobosim carry its
        physical part out, and record it; whatever pyrobosim raises is a failure."""
        before = self.observe()
        why = self.domain.why_not(before, action)
        if why is not None:
            return Outcome.failed(why)
        poses = None
        if physical is not None:
            try:
                outcome, poses = physical()
            except Exception as e:  # pyrobosim's own errors are the world's, not ours
                return Outcome.failed(f"pyrobosim: {type(e).__name__}: {e}")
            if not outcome.success:
                return outcome
        self.simulation.state = before  # the run goes on from the world as pyrobosim had it
        try:
            self.simulation.record(action, poses)
        except PlanningError as e:
            return Outcome.failed(str(e))
        return Outcome.done()

    def _place(self) -> str | None:
        """The place (or room) the robot stands at in pyrobosim: a location's spot, or a room's
        navigation pose; ``None`` on the way."""
        where = self.robot.location
        if where is None:
            return None
        parent = getattr(where, "parent", None)
        if parent is not None and parent.name in self.layout.places:  # a location's spot
            return parent.name
        pose = self.robot.get_pose()
        if where.name in self.layout.rooms and any(pose.is_approx(p) for p in where.nav_poses):
            return where.name
        return None

    def _poses(self) -> np.ndarray:
        """The path pyrobosim's executor just drove, as rows ``t, x, y, theta`` after the
        run's clock, one every control step of the robot."""
        traj = self.robot.path_executor.traj
        t = np.asarray(traj.t_pts, dtype=float)
        xs = np.array([p.x for p in traj.poses])
        ys = np.array([p.y for p in traj.poses])
        yaws = np.unwrap(np.array([p.get_yaw() for p in traj.poses]))
        steps = np.arange(self.diffdrive.dt, t[-1], self.diffdrive.dt) if t[-1] > 0 else np.array([])
        steps = np.append(steps, t[-1])
        theta = np.remainder(np.interp(steps, t, yaws) + np.pi, 2 * np.pi) - np.pi
        rows = np.column_stack(
            [steps + self.simulation.clock, np.interp(steps, t, xs), np.interp(steps, t, ys), theta]
        )
        return rows


def _answer(result: Any) -> Outcome:
    """pyrobosim's ``ExecutionResult`` as an :class:`Outcome`."""
    if result.is_success():
        return Outcome.done()
    return Outcome.failed(f"pyrobosim: {result.message or result.status.name}")


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    """pyrobosim's loggers (one per world and robot, made as it loads) held at :data:`_QUIET`
    while it loads: it announces every entity it creates."""
    previous = logging.root.manager.disable
    logging.disable(logging.INFO)
    try:
        yield
    finally:
        logging.disable(previous)
