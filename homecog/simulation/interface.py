"""The robot's body: one small interface that carries a plan's atomic actions out,
whatever simulates (or is) the robot.

A body has one method per atomic action of the planning domain — ``move``, ``pick``, ``pour``,
``hand_over``, ``speak``, ``switch_iot``, ``switch_by_hand`` and ``dock`` — and each answers with
an :class:`Outcome`: done, or failed and why. It never raises for the world's reasons (a path
that cannot be driven, a cup that is not where the plan thought, a switch whose broker is
gone), as pyrobosim's robot answers with an ``ExecutionResult``; :meth:`Body.commands` turns the
methods into commands for :func:`~homecog.planning.acting.act`, which observes the world again
(:meth:`Body.observe`) and plans anew when one fails.

Two bodies implement it: homecog's own 2D simulator
(:class:`~homecog.simulation.body.SimulatedRobot`) and pyrobosim
(:class:`~homecog.simulation.pyrobosim_body.PyRoboSimBody`). Each records its run the same way
(:meth:`Body.result`: the timeline, the trajectory, the devices), so the run is reported, drawn
and written as a ROS 2 bag alike.

>>> from homecog.home import load_home
>>> from homecog.planning import act, initial_state
>>> from homecog.simulation.body import SimulatedRobot
>>> home = load_home("paper")
>>> body = SimulatedRobot(home, initial_state(home, user="sofa"))
>>> body.pick("cup", "dispenser")                       # it is at the charger
Outcome(success=False, message="the robot is at 'charger', not at 'dispenser'")
>>> body.move("charger", "dispenser").success, body.pick("cup", "dispenser")
(True, Outcome(success=True, message=''))
"""

from __future__ import annotations

import abc
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypedDict

from homecog.errors import CommandError
from homecog.home.model import Home
from homecog.planning import Domain, State, make_domain
from homecog.planning.acting import Command
from homecog.simulation.robot import DiffDrive

if TYPE_CHECKING:
    from homecog.simulation.simulate import SimulationResult

#: the atomic actions of the planning domain, each a method of :class:`Body`
ACTIONS = ("move", "pick", "pour", "hand_over", "speak", "switch_iot", "switch_by_hand", "dock")


@dataclass(frozen=True)
class Outcome:
    """What a body answers for an action: whether it was done and, if not, why."""

    success: bool
    message: str = ""

    @classmethod
    def done(cls) -> Outcome:
        return cls(True)

    @classmethod
    def failed(cls, message: str) -> Outcome:
        return cls(False, message)


class BodyOptions(TypedDict, total=False):
    """What a body is made with beside the home and the world: :class:`Body`'s keywords."""

    switch: Callable[[str, bool], object] | None
    robot: DiffDrive | None
    domain: Domain | None


class Body(abc.ABC):
    """A robot that carries atomic actions out. Subclasses implement :meth:`_act`, which every
    action's method of :data:`ACTIONS` calls (a body may override a method of its own),
    :meth:`start`, :meth:`observe` and :meth:`result`; ``name`` says which body it is
    (``builtin``, ``pyrobosim``) and ``planner`` its path planner's name.

    Parameters
    ----------
    home
        The home; it needs a layout.
    world
        Where the robot and the objects are at the start (default: the home's initial state).
    switch
        ``switch(device, on)``: how a switch reaches the home (a context source's
        :meth:`switch`); a body calls it for ``switch_iot`` and, once at the device, for
        ``switch_by_hand``. Without it, the devices live in the simulation alone.
    robot
        The robot's size and speeds (homecog's own by default, so that runs compare).
    domain
        The planning domain it acts in (default: made from the home).
    """

    name: str
    planner: str

    def __init__(
        self,
        home: Home,
        world: State | None = None,
        *,
        switch: Callable[[str, bool], object] | None = None,
        robot: DiffDrive | None = None,
        domain: Domain | None = None,
    ) -> None:
        self.home, self.switch = home, switch
        self.domain = domain or make_domain(home)
        self.diffdrive = robot or DiffDrive()
        self._prepare()
        self.start(world)

    def _prepare(self) -> None:  # noqa: B027  a hook: most bodies need nothing
        """What the body needs before its first run (nothing here)."""

    # -- the run ------------------------------------------------------------------------------
    @abc.abstractmethod
    def start(self, world: State | None = None) -> None:
        """Begin a new run (a new timeline and trajectory) from ``world`` (default: the home's
        initial state): the robot, the objects and the devices put where it says."""

    @abc.abstractmethod
    def observe(self) -> State:
        """The world as the robot sees it now, as a planning state."""

    @abc.abstractmethod
    def result(self) -> SimulationResult:
        """The run so far: the actions done, their timeline, the trajectory and the devices."""

    # -- the actions: each carried out by _act ------------------------------------------------
    def move(self, origin: str, target: str) -> Outcome:
        """Go from the place ``origin`` to the place (or room) ``target``."""
        return self._act(("move", origin, target))

    def pick(self, obj: str, place: str) -> Outcome:
        """Take ``obj`` from ``place``, where the robot is, with empty hands."""
        return self._act(("pick", obj, place))

    def pour(self, obj: str, place: str) -> Outcome:
        """Fill the held ``obj`` at ``place`` (its source, where the robot is)."""
        return self._act(("pour", obj, place))

    def hand_over(self, obj: str, who: str) -> Outcome:
        """Give the held ``obj`` to ``who``, at whose place the robot is."""
        return self._act(("hand_over", obj, who))

    def speak(self, text: str) -> Outcome:
        """Say ``text`` to the user."""
        return self._act(("speak", text))

    def switch_iot(self, device: str, setting: str) -> Outcome:
        """Switch ``device`` ``on`` or ``off`` by an IoT command."""
        return self._act(("switch_iot", device, setting))

    def switch_by_hand(self, device: str, setting: str) -> Outcome:
        """Switch ``device`` ``on`` or ``off`` by hand, at the device."""
        return self._act(("switch_by_hand", device, setting))

    def dock(self, place: str) -> Outcome:
        """Dock at the charger ``place``, where the robot is."""
        return self._act(("dock", place))

    @abc.abstractmethod
    def _act(self, action: tuple[str, ...]) -> Outcome:
        """Carry ``action`` (its name and arguments) out in the world: checked against it, then
        done, or failed and why."""

    # -- for acting -------------------------------------------------------------------------------
    def carry_out(self, action: tuple[str, ...]) -> Outcome:
        """One action by its name and arguments; an unknown one fails, naming it."""
        if not action or action[0] not in ACTIONS:
            return Outcome.failed(f"no such action {action!r}; a body does {', '.join(ACTIONS)}")
        return getattr(self, action[0])(*action[1:])

    def commands(self) -> dict[str, Command]:
        """A command for every action of the domain (GTPyhop's ``c_move``...): it carries the
        action out through this body and returns the state the action leads to, or raises
        :class:`CommandError` with the body's message, so that acting replans."""
        return {kind: self._command(kind) for kind in self.domain.actions if kind in ACTIONS}

    def _command(self, kind: str) -> Command:
        def command(state: State, *args: str) -> Any:
            expected = self.domain.apply(state, (kind, *args))  # PlanningError: not the robot's plan
            outcome = self.carry_out((kind, *args))
            if not outcome.success:
                raise CommandError(outcome.message)
            return expected

        command.__name__ = command.__qualname__ = f"c_{kind}"
        return command

    def _switch(self, device: str, setting: str) -> Outcome:
        """The home's switch, when there is one; whatever it raises fails the action (a broker
        gone is the world's, not a bug of ours)."""
        if self.switch is None:
            return Outcome.done()
        try:
            self.switch(device, setting == "on")
        except Exception as e:
            return Outcome.failed(f"{type(e).__name__}: {e}")
        return Outcome.done()
