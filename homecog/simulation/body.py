"""The simulated robot's body (SPEC §8, §10): commands that carry a plan's actions out on the
floor plan, for acting (:mod:`homecog.planning.acting`).

The world is a :class:`~homecog.simulation.Simulation`: where the robot and the objects really
are, which may differ from what the robot believes. A command checks the action against the
world (the planning domain's reason when it does not apply: the cup is not where the robot
thought), switches the device in the home through ``switch`` for a switch (a context source's,
so that the simulated home sees it), and runs the action in the simulation, which takes its
time and drives its path.

>>> from homecog.home import load_home
>>> from homecog.planning import act, initial_state
>>> home = load_home("paper")
>>> body = SimulatedRobot(home, initial_state(home, user="sofa"))
>>> body.world.objects["cup"] = "table"          # someone moved the cup
>>> result = act(body.domain, initial_state(home, user="sofa"), [("SendDrinks",)], body.commands(),
...              observe=body.observe)
>>> print(result.failures[0])
plan 1: ('pick', 'cup', 'dispenser') failed: 'cup' is not at 'dispenser'
>>> result.done, result.replans, result.achieved     # planned again from where the cup is
([('move', 'charger', 'dispenser'), ('move', 'dispenser', 'table'), ('pick', 'cup', 'table'), \
('move', 'table', 'dispenser'), ('pour', 'cup', 'dispenser'), ('move', 'dispenser', 'sofa'), \
('hand_over', 'cup', 'user')], 1, True)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from homecog.errors import CommandError, PlanningError
from homecog.home.model import Home
from homecog.planning import Domain, State, make_domain
from homecog.planning.acting import Command
from homecog.simulation.robot import DiffDrive
from homecog.simulation.simulate import Simulation

SWITCHES = ("switch_iot", "switch_by_hand")


class SimulatedRobot:
    """A robot on a home's floor plan that carries actions out as commands.

    Parameters
    ----------
    home
        The home; it needs a layout.
    world
        Where the robot and the objects are (default: the home's initial state).
    switch
        ``switch(device, on)``: how a switch reaches the home (a context source's
        :meth:`switch`); without it, the devices live in the simulation alone.
    robot, domain
        The robot's limits and the planning domain (default: made from the home).
    """

    def __init__(
        self,
        home: Home,
        world: State | None = None,
        *,
        switch: Callable[[str, bool], object] | None = None,
        robot: DiffDrive | None = None,
        domain: Domain | None = None,
    ) -> None:
        self.home = home
        self.switch = switch
        self.domain = domain or make_domain(home)
        self.simulation = Simulation(home, world, robot=robot, domain=self.domain)

    @property
    def world(self) -> State:
        """The state of the world as it is (the simulation's), not as the robot believes it."""
        return self.simulation.state

    def start(self, world: State) -> None:
        """Begin a new run (a new timeline and trajectory) from ``world``."""
        self.simulation = Simulation(self.home, world, robot=self.simulation.robot, domain=self.domain)

    def observe(self) -> State:
        """What the robot sees of the world: all of it."""
        return self.simulation.state.copy()

    def commands(self) -> dict[str, Command]:
        """A command for every action of the domain."""
        return {kind: self._command(kind) for kind in self.domain.actions}

    def _command(self, kind: str) -> Command:
        def command(state: State, *args: str) -> Any:
            action = (kind, *args)
            expected = self.domain.apply(state, action)  # PlanningError: a plan the robot did not make
            why = self.domain.why_not(self.simulation.state, action)
            if why is not None:
                raise CommandError(why)
            if self.switch is not None and kind in SWITCHES:
                try:
                    self.switch(args[0], args[1] == "on")
                except Exception as e:  # the home's switch failing is the world's, not our bug
                    raise CommandError(f"{type(e).__name__}: {e}") from e
            try:
                self.simulation.run(action)
            except PlanningError as e:  # a path that cannot be driven
                raise CommandError(str(e)) from e
            return expected

        command.__name__ = command.__qualname__ = f"c_{kind}"  # GTPyhop's name of a command
        return command
