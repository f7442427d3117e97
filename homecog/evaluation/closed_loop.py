"""A simulated household, and the robot and the household living days together.

The household acts by the wishes of a *truth* home (compatible with the robot's): whenever a
device is not as the truth's comfort rules want it in the context now, a person switches it by
hand once it has been so for :data:`DELAY` seconds. A person does not switch back their own
switch while their situation is the same (a curtain opened because the room was dark is not
closed again because the daylight it let in makes the room light), nor switch one where the
switch would make them want it switched back (it knows its home: the readings the switch
moves, as the simulated home computes them). It feels the home as it is, not as the sensors
read it (their noise is the robot's alone). It never touches the HMI:
the robot learns from its switches alone.

The closed loop (:func:`closed_loop`) lets both live ``days`` simulated days in the home (its
routine moves the user, typical-year weather the readings; the routine's own device switches
are the household's, so they are left out) and counts, per day, the robot's switches, those the
household switched back within the undo window, the household's own switches and the fights —
the robot switching a device again that the household switched, in the same situation; and, in
all, what went wrong per device and per service (:mod:`homecog.evaluation.closed_loop_faults`).
Both counts are the household's own, not the robot's bookkeeping.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any

from homecog.context import DeviceChange
from homecog.context.simulated import DEFAULT_START, SimulatedHome
from homecog.evaluation.closed_loop_faults import Faults, per_device, per_service
from homecog.home.codec import Space
from homecog.home.household import Household
from homecog.home.model import Home
from homecog.home.states import state_word
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.store import Store
from homecog.progress import Counted, Progress
from homecog.robot.holds import situation

if TYPE_CHECKING:
    from homecog.robot.runtime import Runtime

#: how long a device stays other than the household wants before a person switches it (s)
DELAY = 120.0
#: the closed loop's tick (simulated seconds)
STEP = 60.0


@dataclass
class Day:
    """One simulated day of the closed loop."""

    day: int
    robot_switches: int = 0
    reversed: int = 0
    household_switches: int = 0
    fights: int = 0


@dataclass
class SimulatedHousehold:
    """People who switch by hand what is not as the truth home wants, after ``delay`` seconds.
    It watches the home's changes (:meth:`seen`, a source listener) to count, on its own, what
    the robot switched, what it switched back and any fight."""

    truth: Home
    source: SimulatedHome
    undo_window: float = 900.0
    delay: float = DELAY
    today: Day = field(default_factory=lambda: Day(1))

    def __post_init__(self) -> None:
        self.switches: list[dict[str, object]] = []  # every switch: day, time, device, state, by
        self.faults = Faults()  # every switch by what it was, per device and state
        self._space = Space(self.truth)
        self._n = len(self.truth.features)
        self._since: dict[str, float] = {}  # device -> not as wanted since
        self._mine: tuple[str, bool] | None = None
        self._robot: dict[str, tuple[bool, float]] = {}  # device -> the robot's last switch
        # device -> the situation of our last switch of it and the state we set
        self._ours: dict[str, tuple[tuple[object, ...], bool]] = {}
        self.source.listen(self.seen)

    def wishes(self, context: dict[str, str]) -> dict[str, bool]:
        """The devices the household cares about now, and how it wants them."""
        codes = self._space.point(context).codes[: self._n]
        return {
            d.name: w
            for d, w in zip(self.truth.devices, self.truth.wanted(codes), strict=True)
            if w is not None
        }

    def step(self) -> list[tuple[str, bool]]:
        """Switch by hand what has not been as wanted for ``delay`` seconds; what was switched."""
        now, context = self.source.clock(), self.source.actual()  # what they feel, not the sensors
        wished = self.wishes(context)
        where = situation(self.truth, context)
        for device in [d for d, (w, _) in self._ours.items() if w != where]:
            del self._ours[device]  # the situation moved on: that switch is in the past
        done = []
        for device in self.truth.device_names:
            want = wished.get(device)
            ours = self._ours.get(device)
            if ours is not None and ours[1] == (context[device] == "on"):
                want = None  # as we set it in this situation: we do not switch it back ourselves
            if want is None or (context[device] == "on") == want or not self._stable(device, want):
                self._since.pop(device, None)
                continue
            since = self._since.setdefault(device, now)
            if now - since >= self.delay:
                self._switch(device, want, context)
                done.append((device, want))
                self._since.pop(device, None)
        return done

    def _stable(self, device: str, on: bool) -> bool:
        """Whether the household would still want ``device`` so once switched (a curtain opened
        to a dark room that makes it light enough to want it closed is no wish to act on)."""
        after = self.wishes(self.source.preview(device, on)).get(device)
        return after is None or after == on

    def _switch(self, device: str, on: bool, context: dict[str, str]) -> None:
        self._mine = (device, on)
        try:
            self.source.switch(device, on)
        finally:
            self._mine = None
        self.today.household_switches += 1
        self._record(device, on, "household")
        self._ours[device] = (situation(self.truth, context), on)
        robot = self._robot.pop(device, None)
        if robot is not None and robot[0] != on and self.source.clock() - robot[1] <= self.undo_window:
            self.today.reversed += 1
            self.faults.undone[(device, robot[0])] += 1
        else:
            self.faults.missed[(device, on)] += 1

    def _record(self, device: str, on: bool, by: str) -> None:
        time = self.source.now.strftime("%H:%M:%S")
        self.switches.append(
            {"day": self.today.day, "time": time, "device": device, "state": state_word(on), "by": by}
        )

    def seen(self, change: DeviceChange) -> None:
        """A change in the home: ours, or else the robot's (nobody else lives here)."""
        if self._mine == (change.device, change.on):
            return
        self.today.robot_switches += 1
        self.faults.robot[(change.device, change.on)] += 1
        self._record(change.device, change.on, "robot")
        self._robot[change.device] = (change.on, change.at)
        ours = self._ours.get(change.device)
        if change.before is not None and ours is not None and ours[0] == situation(self.truth, change.before):
            self.today.fights += 1
            self.faults.fights[(change.device, change.on)] += 1


def closed_loop(
    home: Home,
    truth: Home,
    store: Store,
    tree: IHDRTree,
    *,
    days: int,
    household: Household | None = None,
    start: str = DEFAULT_START,
    seed: int = 0,
    progress: Progress | None = None,
) -> dict[str, Any]:
    """The robot (learning in ``tree``, logging to ``store``) and a household of ``truth``'s
    wishes live ``days`` days in ``home``; per day what each did (:class:`Day`), per device and
    service what went wrong, and the robot's own view of it at the end."""
    from homecog.robot.assemble import Wiring, assemble

    source = SimulatedHome(home, start=start, seed=seed, routine_switches=False)  # ContextError: a bad start
    wiring = Wiring(home, household=household or home.household, truth=truth)
    robot = assemble(wiring, store=store, tree=tree, source=source)
    runtime, people = robot.runtime, robot.living
    assert people is not None  # the wiring's truth lives in the home
    out: list[Day] = []
    began = time.perf_counter()
    for day in range(1, days + 1):
        people.today = Day(day)
        _live_day(runtime, source, day, days, out[-1] if out else None, progress)
        out.append(people.today)
    days_out = [asdict(d) for d in out]
    return {
        "home": home.name,
        "truth": truth.name,
        "days": days_out,
        "summary": summary(days_out, people.switches),
        "devices": per_device(home, people.faults),
        "services": per_service(home, people.faults),
        "switches": people.switches,
        "robot": runtime.status(),
        "experiences": store.experience_count(),
        "seconds": round(time.perf_counter() - began, 2),
    }


def _live_day(
    runtime: Runtime, source: SimulatedHome, day: int, days: int, last: Day | None, progress: Progress | None
) -> None:
    """One simulated day of the closed loop, its progress said every simulated hour."""
    ticks = round(86400 / STEP)
    hourly = max(1, round(3600 / STEP))
    before = (
        ""
        if last is None
        else f" (day {last.day}: robot {last.robot_switches} switches, {last.reversed} undone; "
        f"household {last.household_switches}; {last.fights} fights)"
    )
    for tick in range(ticks):
        if progress is not None and tick % hourly == 0:
            done = (day - 1) * ticks + tick
            clock = source.now.strftime("%H:%M")
            progress(Counted(f"day {day} of {days}, {clock}{before}", done, days * ticks))
        runtime.tick(STEP)


def summary(days: list[dict[str, Any]], switches: Sequence[Mapping[str, Any]] = ()) -> dict[str, Any]:
    """The figures of a closed loop: the household's switches a day over the last three days
    as a share of day 1's, the share of the robot's switches undone over them, fights in all,
    and the robot's switches of one device within an hour at most (:func:`busiest_hour`).

    >>> d = [{"household_switches": 20, "robot_switches": 5, "reversed": 2, "fights": 0}] + [
    ...     {"household_switches": 1, "robot_switches": 50, "reversed": 0, "fights": 0}] * 3
    >>> summary(d)
    {'last3_household_share': 0.05, 'last3_undone_share': 0.0, 'fights': 0, 'robot_most_in_an_hour': 0}
    """
    last = days[-3:]
    first = days[0]["household_switches"]
    robot = sum(d["robot_switches"] for d in last)
    per_day = sum(d["household_switches"] for d in last) / len(last)
    return {
        "last3_household_share": round(per_day / first, 4) if first else None,
        "last3_undone_share": round(sum(d["reversed"] for d in last) / robot, 4) if robot else 0.0,
        "fights": sum(d["fights"] for d in days),
        "robot_most_in_an_hour": busiest_hour(switches),
    }


def busiest_hour(switches: Sequence[Mapping[str, Any]], by: str = "robot") -> int:
    """The most switches of one device by ``by`` within any 60 minutes.

    >>> times = ("06:04:00", "06:09:00", "06:18:00")
    >>> s = [{"day": 1, "time": t, "device": "ac", "by": "robot"} for t in times]
    >>> busiest_hour(s), busiest_hour(s[:2] + [{**s[2], "time": "07:05:00"}])
    (3, 2)
    """
    times: dict[str, list[float]] = {}
    for s in switches:
        if s["by"] == by:
            h, m, sec = (int(x) for x in str(s["time"]).split(":"))
            times.setdefault(str(s["device"]), []).append(
                (int(s["day"]) - 1) * 86400 + h * 3600 + m * 60 + sec
            )
    most = 0
    for ts in times.values():
        ts.sort()
        start = 0
        for end, t in enumerate(ts):
            while t - ts[start] >= 3600:
                start += 1
            most = max(most, end - start + 1)
    return most
