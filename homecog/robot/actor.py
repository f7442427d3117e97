"""The robot acting on what it proposes: the proposed services that have
something to do are planned, in their order, and carried out — IoT switches through the context
source, and in the simulated home everything else by the simulated robot's body; a failed
command is replanned and logged, never raised.

Every switch it commands is announced to the attribution first (so its report is known for the
robot's own), a service that would switch a device a person holds is left out (never fight), and
what it did goes to the journal with the services' explanations. Nor does it switch back a device
it switched itself while the home is as that switch left it, or while the user's situation is
the one it switched in (:mod:`homecog.robot.settling`), nor switch one device more than
:data:`~homecog.robot.pacing.MOST_AN_HOUR` times within an hour: past that the device is the
household's to switch (:mod:`homecog.robot.pacing`).
"""

from __future__ import annotations

import concurrent.futures
import logging
from collections.abc import Callable, Mapping
from typing import Any

from homecog.context import ContextSource
from homecog.errors import PlanningError
from homecog.home.model import Home
from homecog.home.states import state_word
from homecog.planning import Acting, State, acting, make_domain
from homecog.planning.state import device_states, observed_state
from homecog.robot.attribution import Attribution
from homecog.robot.holds import Holds
from homecog.robot.journal import Journal, RobotAction
from homecog.robot.pacing import Pacing
from homecog.robot.settling import Settling
from homecog.simulation.bodies import make_body

log = logging.getLogger("homecog.robot")


class Actor:
    """The robot's hands: IoT switches, and a body on the floor plan where it has one."""

    def __init__(
        self,
        home: Home,
        source: ContextSource,
        *,
        attribution: Attribution,
        holds: Holds,
        journal: Journal,
        body: str | None,
        pacing: Pacing | None = None,
    ) -> None:
        self.home = home
        self.source = source
        self.attribution = attribution
        self.holds = holds
        self.journal = journal
        self.domain = make_domain(home)
        self._iot = {d.name for d in home.devices if d.iot}
        # In the simulated home the robot has a body on the floor plan (``body``: its kind,
        # homecog's own or pyrobosim): it drives, brings, docks and switches by hand there. A
        # real home (MQTT, Home Assistant) gets IoT switches.
        self.body = make_body(body, home, switch=self.switch, domain=self.domain) if body else None
        self.acted: Acting | None = None
        self.skipped_held = 0  # services left out because a person holds one of their devices
        self.pacing = pacing or Pacing(home)  # each device's minimum time between switches
        self.skipped_resting = 0  # services left out: a device of theirs switched too lately
        self.settling = Settling(home)  # its own recent switches: not switched back at once
        self.skipped_settling = 0  # services left out: they would switch back the robot's own
        self.skipped_hourly = 0  # services left out: a device of theirs switched enough this hour
        self._sent: dict[str, dict[str, str]] = {}
        self._proposed: set[str] = set()
        self._switched: list[tuple[str, bool]] | None = None

    def switch(self, device: str, on: bool) -> object:
        """The robot's own switch: announced, then commanded. A command that fails — it raises,
        the source skips it (``None``: Home Assistant away) or its future says it failed — is not
        expected back, nor journaled as switched."""
        self.attribution.expect(device, on, at=self.source.clock())
        try:
            result = self.source.switch(device, on)
        except BaseException:
            self.attribution.forget(device, on)
            raise
        if result is None and getattr(self.source, "skips_switches", False):
            self.attribution.forget(device, on)
            return result
        if isinstance(result, concurrent.futures.Future):
            result.add_done_callback(lambda f: self._settled_call(f, device, on))
        if self._switched is not None:
            self._switched.append((device, on))
        return result

    def _settled_call(self, future: concurrent.futures.Future[Any], device: str, on: bool) -> None:
        failed = future.cancelled() or future.exception() is not None or future.result() is False
        if failed:
            log.warning("the switch of %s %s failed; its report is not awaited", device, state_word(on))
            self.attribution.forget(device, on)
            self.settling.forget(device)

    def todo(self, now: Mapping[str, str], proposed: list[str], *, one_switch: bool = False) -> list[str]:
        """The proposed services to carry out now (``one_switch``: the errands and only the first
        service that switches something, so the robot can look again before the next).

        A service that switches devices is done while one of them is not as it sets it, once
        per change of the home (not once a tick while a device is slow to report), not while a
        person holds one of its devices; without a body only by IoT. An errand (bring, dock,
        say) is done once each time it comes to be proposed, by the body."""
        devices = device_states(self.home, now)
        at = self.source.clock()
        held = self.holds.held_devices(now, at=at)
        settling = self.settling.settled_devices(now, at=at)
        out, switching = [], False
        for name in proposed:
            sets = self.home.services[self.home.service_index(name)].sets
            if sets:
                pending = any(devices[d] != on for d, on in sets)
                reachable = self.body is not None or all(d in self._iot for d, _ in sets)
                if pending and held.intersection(d for d, _ in sets):
                    self.skipped_held += 1
                    continue
                if pending and settling.intersection(d for d, on in sets if devices[d] != on):
                    self.skipped_settling += 1
                    continue
                if pending and any(self.pacing.resting(d, at=at) for d, on in sets if devices[d] != on):
                    self.skipped_resting += 1
                    continue
                if pending and any(self.pacing.spent(d, at=at) for d, on in sets if devices[d] != on):
                    self.skipped_hourly += 1
                    continue
                if pending and reachable and self._sent.get(name) != now:
                    if one_switch and switching:
                        continue
                    self._sent[name] = dict(now)
                    out.append(name)
                    switching = True
            elif self.body is not None and name not in self._proposed:
                out.append(name)
        self._proposed = set(proposed)
        return out

    def act(
        self,
        now: Mapping[str, str],
        proposed: list[str],
        *,
        user: str,
        why: Callable[[list[str]], list[Any]],
        one_switch: bool = False,
    ) -> RobotAction | None:
        """Carry out what is to do of ``proposed`` in ``now``; the action journaled (``why``
        gives the explanations of its services), or ``None`` when there was nothing to do or it
        could not be planned."""
        todo = self.todo(now, proposed, one_switch=one_switch)
        if not todo:
            return None
        self._switched = []
        try:
            state = self._observe()
            commands = acting.iot_commands(self.domain, self.switch)
            if self.body is not None:
                self.body.start(state)  # a new run on the floor plan, from where the robot is
                commands = self.body.commands()
            result = acting.act(self.domain, state, [(n,) for n in todo], commands, observe=self._observe)
        except PlanningError as e:  # the user at no place of the layout, say: the robot waits
            log.warning("the robot cannot plan %s: %s", ", ".join(todo), e)
            return None
        finally:
            switched, self._switched = self._switched or [], None
        log.info("the robot did: %s", "; ".join(" ".join(a) for a in result.done) or "nothing")
        self.acted = result
        at = self.source.clock()
        for device, on in switched:
            self.holds.robot_switched(device, now)
            self.settling.switched(device, on, at=at, context=now)
            self.pacing.robot_switched(device, at=at)
        return self.journal.add(
            at=self.source.clock(),
            services=todo,
            switches=switched,
            context=dict(now),
            user=user,
            why=why(todo),
            done=[" ".join(a) for a in result.done],
        )

    def _observe(self) -> State:
        """The home as the robot sees it: the source's context and, with a body, where it is."""
        world = self.body.observe() if self.body is not None else None
        return observed_state(self.home, self.source.snapshot(), world)
