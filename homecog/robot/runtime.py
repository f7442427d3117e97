"""The running robot: the home, its knowledge and a context source, put together for the HTTP
routes and the closed loop. What happened (corrections, agreement) is read from the store's
experience log (:mod:`homecog.knowledge.history`), so it outlives the process; what the robot
did lately is in its journal.

>>> from homecog.context.manual import ManualSource
>>> from homecog.home import load_home
>>> from homecog.knowledge.ihdr import IHDRTree
>>> from homecog.knowledge.store import Store
>>> home = load_home("paper")
>>> runtime = Runtime(home=home, store=Store.open("sqlite://", home), tree=IHDRTree(home),
...                   source=ManualSource(home))
>>> runtime.source.switch("lamp", True)        # nobody commanded it: a person's switch
>>> now = runtime.source.clock()
>>> runtime.guidance.counts["observed"], runtime.holds.held("lamp", runtime.context(), at=now)
(1, True)
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import orjson

from homecog.context import ContextSource, DeviceChange, LivingSource, SettableSource
from homecog.context.simulated import SimulatedHome
from homecog.errors import ContextError, FixedContextError, StoreError
from homecog.home.codec import Point, Space, json_context
from homecog.home.household import Household
from homecog.home.model import Home, format_number
from homecog.home.states import state_word
from homecog.knowledge import core
from homecog.knowledge.correction import Correction
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.store import Store
from homecog.planning import Acting
from homecog.robot.actor import Actor
from homecog.robot.attribution import Attribution
from homecog.robot.events import EventBus, correction_event, tell_all
from homecog.robot.guidance import QUIET_SITUATION, Guidance
from homecog.robot.holds import Holds, situation
from homecog.robot.journal import Journal
from homecog.robot.moments import Moments
from homecog.robot.pacing import Pacing
from homecog.robot.plans import plan_request
from homecog.robot.review import Pending

log = logging.getLogger("homecog.robot")
#: what the household's hands taught: switches, undos, situations lived with the devices as left
LEARNED = ("observed", "undo", "quiet")


@dataclass
class Runtime:
    """Everything the routes share. Cognition and corrections hold ``lock`` while they read or
    change the tree (a correction not while its transaction writes and commits): the tree is not
    thread-safe, FastAPI runs plain route functions (corrections) in a thread pool, a source
    tells its changes on its own thread, and cognition runs on the event loop unless ``lock`` is
    held (:mod:`homecog.web.routes.cognize`). ``household``: the home's own settings unless given."""

    home: Home
    store: Store
    tree: IHDRTree
    source: ContextSource
    household: Household | None = None
    lock: threading.Lock = field(default_factory=threading.Lock)
    watchers: list[Callable[[dict[str, str]], object]] = field(default_factory=list)
    after_tick: list[Callable[[], object]] = field(default_factory=list)
    """Called after every :meth:`tick` (a simulated household taking its turn)."""
    robot: str = "builtin"
    """The robot's body in the simulated home (:data:`homecog.simulation.bodies.BODIES`)."""
    fresh: float | None = None
    """Seconds at most between two looks at the database for another process's corrections or
    build (``homecog up``; ``None``: this process alone writes, as in the closed loop)."""
    announcers: list[Callable[[str, object], object]] = field(default_factory=list)
    """Told every event ``(kind, data)`` as the live stream is, and the robot's decisions
    (``decision``: the services it proposes, their explanations, the user) when they change:
    Home Assistant's entities (:mod:`homecog.robot.announce`)."""

    def __post_init__(self) -> None:
        self.household = self.household or self.home.household
        self.space = Space(self.home)
        self.bus = EventBus()
        self.attribution = Attribution()
        self.holds = Holds(self.home, hold=self.household.hold)
        self.pacing = Pacing(self.home)
        self.journal = Journal()
        self.pending = Pending()
        self.guidance = Guidance(self.home, self.household, self.journal, self._learn, self._point_now)
        body = self.robot if isinstance(self.source, SimulatedHome) and self.home.layout is not None else None
        self.actor = Actor(
            self.home,
            self.source,
            attribution=self.attribution,
            holds=self.holds,
            journal=self.journal,
            body=body,
            pacing=self.pacing,
        )
        self._checked, self._version = time.monotonic(), self.store.home_version()
        self.household_switches = 0  # device changes by people (and automations) seen
        self._situation: tuple[float, dict[str, str] | None] = (0.0, None)  # since, latest context
        self._acting = threading.RLock()  # the robot acts, or an action is undone: one at a time
        self._decision: tuple[list[str], list[Any]] | None = None  # the latest announced
        self.moments = Moments(self.home, self.source.clock, simulated=isinstance(self.source, SimulatedHome))
        self.source.listen(self._changed)

    @property
    def acted(self) -> Acting | None:
        """What the robot did last."""
        return self.actor.acted

    # -- context ------------------------------------------------------------------------------
    def context(self) -> dict[str, str]:
        """The context as the source has it, as text; :class:`ContextError` while a broker has not
        sent every state yet."""
        return self.source.snapshot()

    def json_context(self) -> dict[str, str | float]:
        """The context as the HTTP contract writes it (numbers as numbers)."""
        return json_context(self.home, self.context())

    def set_context(self, values: Mapping[str, object]) -> dict[str, str | float]:
        """Manual mode: change some features or devices (valid values, as the contract checks
        them); :class:`FixedContextError` when the source cannot be set by hand."""
        if not isinstance(self.source, SettableSource):
            raise FixedContextError("the context comes from a broker; it cannot be set by hand")
        unknown = [k for k in values if k not in self.space.names]
        if unknown:
            raise ContextError(f"unknown feature or device {unknown[0]!r}")
        typed = json_context(self.home, values)  # raises naming a value that does not fit
        text = {k: format_number(v) if isinstance(v, float) else v for k, v in typed.items()}
        self.space.point({**self.source.snapshot(), **text})  # the whole result must be valid
        self.source.set_context(text)
        self.publish("context", self.context())
        return self.json_context()

    # -- cognition, corrections, plans ---------------------------------------------------------
    def cognize(self, context: Mapping[str, object], user: str) -> dict[str, Any]:
        point = self.space.point(context)
        self.keep_fresh()
        with core.reading(self.tree, self.lock, user) as tree:
            return tree.explain_one(point, user=user).as_dict()

    def cognize_json(self, context: Mapping[str, object], user: str, *, wait: bool = True) -> bytes | None:
        """:meth:`cognize` as JSON, the same object (orjson writes the dataclasses directly); its
        services become the user's pending proposals. With ``wait`` false (the event loop's),
        None where the answer would wait: the user's layer not learned yet, or a lock held."""
        point = self.space.point(context)
        self.keep_fresh()
        if wait:
            with core.reading(self.tree, self.lock, user) as tree:
                answer = tree.explain_one(point, user=user)
        elif (answer := core.answer_now(self.tree, self.lock, point, user)) is None:
            return None
        self.pending.shown(user, point, answer.services)  # what the user may answer yes or no to
        return orjson.dumps(answer)

    def keep_fresh(self) -> None:
        """Where another process shares the database (``fresh`` seconds apart at most): the
        tree brought up to its corrections and builds when the home's version moved."""
        if self.fresh is None or time.monotonic() - self._checked < self.fresh:
            return
        self._checked = time.monotonic()
        version = self.store.home_version()  # one primary-key lookup
        if version != self._version:
            tree = core.refresh(self.store, self.tree, self.lock)
            with self.lock:
                self.tree = tree
            self._version = version

    def correct(self, c: Correction) -> dict[str, Any]:
        """Learn and store an explicit correction (the knowledge core commits it, then learns
        it); the store's log keeps it (and the history). Returns what it stored and changed."""
        self.household.member(c.user)
        outcome = core.correct(self.store, self.tree, c, self.lock)  # the lock only off the database
        experiences = self.store.experience_count()  # outside the lock: cognition need not wait
        self.publish("correction", correction_event(outcome))
        return {**outcome.as_dict(), "experiences": experiences}

    def _learn(self, c: Correction) -> None:
        """A correction the household's hands made (observed, undo): learned and logged; a
        person's switch is a moment of the stream."""
        if c.kind == "observed" and c.want:
            self.moments.lived(self.space.context(c.point), list(c.want))
        outcome = core.correct(self.store, self.tree, c, self.lock)
        log.info("learned %s for %s: %s", c.kind, c.user, c.says())
        self.publish("correction", correction_event(outcome))

    def _point_now(self, context: Mapping[str, str]) -> Point:
        """A context of the household's stream as a point, with the recent past of its moment."""
        return replace(self.space.point(context), recent=self.moments.recent(context))

    def plan(self, services: list[str], context: Mapping[str, object] | None) -> dict[str, Any]:
        """The services decomposed into robot actions, in the given order, and the plan carried
        out by a robot of the runtime's body on the floor plan: its timeline, time, distance and
        trajectory (``[t, x, y]`` rows, at most 400). :class:`PlanningError` when it cannot be."""
        return plan_request(self.home, services, context, self.robot)

    # -- the living home ------------------------------------------------------------------------
    def tick(self, seconds: float, *, act: bool = True, user: str | None = None) -> bool:
        """Let a simulated source live ``seconds`` of simulated time; then, if ``act``, the robot
        carries out the services it proposes there for ``user`` (the household's default user).
        True if the context changed."""
        if not self.source.ready:  # a broker has not sent every state yet
            return False
        before = self.source.snapshot()
        if isinstance(self.source, LivingSource):
            self.source.advance(seconds)
        if act:
            self.act_now(user or self.household.default_user)
        for turn in self.after_tick:
            turn()
        after = self.source.snapshot()
        if after != before:
            self.publish("context", after)
        return after != before

    def act_now(self, user: str) -> Acting | None:
        """The robot acts on what it proposes for ``user`` in the context now, one switch at a
        time: after each it looks at the home again and decides anew (a curtain it opened makes
        the room light, and the ceiling light it also proposed in the dark is wanted no more).
        A situation that ended is learned from first (:meth:`Guidance.quiet`). What was done
        last, or ``None``."""
        with self._acting:
            return self._act_now(user)

    def _act_now(self, user: str) -> Acting | None:
        now = self.source.snapshot()
        self.holds.observe(now)
        self._follow_situation(now, user)
        done = None
        for _ in range(len(self.home.devices) + 1):
            seen = self.pacing.steady(now)  # a reading at a bin's edge does not flap the bin
            point = replace(self.space.point(seen), recent=self.moments.recent(now))
            with core.reading(self.tree, self.lock, user) as tree:
                proposed = tree.predict_one(point, user=user)
            self._decided(now, proposed, user)
            acted = self.act(now, proposed, user=user, one_switch=True)
            if acted is None:
                if self.moments.changed(now):  # a moment where nobody switched
                    self.moments.lived(now, [])
                break
            self.moments.lived(now, [s for s in proposed if self._changes(s, now)])
            done, now = acted, self.source.snapshot()
            self._situation = (self._situation[0], now)  # the situation's latest: as the robot left it
        return done

    def _decided(self, now: Mapping[str, str], proposed: list[str], user: str) -> None:
        """Tell the announcers what the robot proposes now and why, when that changed."""
        if not self.announcers:
            return
        decision = (list(proposed), self._why(now, proposed, user))
        if decision != self._decision:
            self._decision = decision
            data = {"services": decision[0], "explanations": decision[1], "user": user}
            self._announce("decision", data)

    def _announce(self, kind: str, data: object) -> None:
        for announcer in self.announcers:
            try:
                announcer(kind, data)
            except Exception:  # the robot goes on whatever an app does
                log.exception("an announcer failed on %s", kind)

    def _changes(self, service: str, now: Mapping[str, str]) -> bool:
        """Whether a service would change anything in the context (an errand always does)."""
        sets = self.home.services[self.home.service_index(service)].sets
        return not sets or any(now.get(d) != state_word(on) for d, on in sets)

    def act(
        self,
        now: Mapping[str, str],
        proposed: list[str],
        *,
        user: str | None = None,
        one_switch: bool = False,
    ) -> Acting | None:
        """Carry out the proposed services that have something to do (:class:`Actor`; with
        ``one_switch``, the errands and the first switch only); what was done (``None``:
        nothing to do), the action also in the journal."""
        who = user or self.household.default_user
        why = lambda todo: self._why(now, todo, who)  # noqa: E731
        action = self.actor.act(now, proposed, user=who, why=why, one_switch=one_switch)
        if action is None:
            return None
        self.publish("action", action.as_dict())
        if action.switches:
            self.publish("context", self.context())
        return self.actor.acted

    def _follow_situation(self, now: dict[str, str], user: str) -> None:
        """Keep the context of the situation lived now; when it ends after a while, what the
        household left as it was is learned."""
        where, at = situation(self.home, now), self.source.clock()
        began, last = self._situation
        ended = last is not None and situation(self.home, last) != where
        self._situation = (at if ended or last is None else began, now)
        if ended and at - began >= QUIET_SITUATION:
            try:
                self.guidance.quiet(last, user)  # type: ignore[arg-type]
            except (StoreError, ContextError) as e:  # the robot acts on, whatever the database does
                log.warning("what the household left alone could not be learned: %s", e)

    def _why(self, now: Mapping[str, str], services: list[str], user: str) -> list[Any]:
        point = self.space.point(now)
        with core.reading(self.tree, self.lock, user) as tree:
            answer = tree.explain_one(point, user=user).as_dict()
        return [e for e in answer["explanations"] if e.get("service") in services]

    def undo(self, action_id: int, user: str | None = None) -> dict[str, Any]:
        """Undo the robot's action from the HMI: its switches switched back (as the robot's own
        commands, then held for the person) and its services learned as rejections where it
        acted. :class:`LookupError` for an action not in the journal, :class:`FixedContextError`
        for one already undone."""
        with self._acting:
            action = self.journal.get(action_id)
            if action is None:
                raise LookupError(f"no action {action_id} among the robot's latest")
            if action.undone_here or (
                action.switches and set(action.undone) >= {d for d, _ in action.switches}
            ):
                raise FixedContextError(f"action {action_id} is undone already")
            now = self.source.snapshot()
            switched = []
            for device in dict.fromkeys(d for d, _ in reversed(action.switches)):
                back = action.context.get(device) == "on"  # as it was before the robot acted
                if now.get(device) == state_word(back) or device in action.undone:
                    continue
                if self.actor.switch(device, back) is None and getattr(self.source, "skips_switches", False):
                    continue  # Home Assistant away: not switched back
                self.holds.hold(device, now, at=self.source.clock())
                switched.append((device, back))
            rejected = self.guidance.undo(action.id, user or action.user)  # StoreError: nothing marked
            action.undone_here = True
            back_now = self.source.snapshot()
            for device, _ in action.switches:  # those back as they were (now, or by a try before)
                if back_now.get(device) == action.context.get(device):
                    action.undone.setdefault(device, "hmi")
        self.publish("context", self.context())
        switched = [{"device": d, "state": state_word(on)} for d, on in switched]
        return {"action": action.id, "switched": switched, "rejected": rejected, "user": user or action.user}

    def _changed(self, change: DeviceChange) -> None:
        """A device changed in the home: whose, and what it teaches (on the source's thread)."""
        self.pacing.switched(change.device, change.on, at=change.at)
        who = self.attribution.whose(change)
        if who in ("robot", "manual"):
            return
        if change.before is not None:
            self.holds.hold(change.device, change.before, at=change.at)
        self.household_switches += 1
        self.guidance.person(change)

    def status(self) -> dict[str, Any]:
        """What the household did and the robot left alone, for the HMI."""
        counts = dict(self.guidance.counts)
        return {
            "household_switches": self.household_switches,
            "learned": {k: counts.get(k, 0) for k in LEARNED},
            "ignored": {k: v for k, v in counts.items() if k not in LEARNED},
            "fights": self.holds.fights,
            "left_alone": self.actor.skipped_held,
            "undo_window_minutes": self.household.undo_window / 60,
            "hold_minutes": self.household.hold / 60,
        }

    # -- the live event stream -----------------------------------------------------------------
    def subscribe(self) -> Any:
        return self.bus.subscribe()

    def unsubscribe(self, queue: Any) -> None:
        self.bus.unsubscribe(queue)

    def switch(self, device: str, on: bool) -> None:
        """Switch a device of the home, as an IoT command from outside (a broker) does."""
        self.source.switch(device, on)
        self.publish("context", self.context())

    def publish(self, kind: str, data: object) -> None:
        """Send an event to every open stream, from any thread; a new context also goes to every
        watcher."""
        if kind == "context":
            tell_all(self.watchers, data)  # type: ignore[arg-type]
        self._announce(kind, data)
        if not self.bus.listening:
            return
        if kind == "context":
            try:
                data = json_context(self.home, data)  # type: ignore[arg-type]
            except (ContextError, ValueError):
                log.exception("a context that does not fit the home")
                return
        self.bus.send(kind, data)
