"""A simulated home that lives through days at an accelerated clock.

The user follows the home's routine (:mod:`homecog.home.routine`): where they are and what
they do comes from the step that holds, and the devices a step ``set`` s are switched when it
starts. Temperature and illumination come from a typical year of real weather and the devices
(:mod:`homecog.context.weather`). Devices keep their state until the robot (:meth:`switch`) or
the user switches them; every device change is told to the listeners (:meth:`listen`) with
the context just before it. Nothing runs by itself: the caller moves the clock with
:meth:`SimulatedHome.advance` (the web server calls ``advance(real_elapsed * speed)``), so a
test can step through a day deterministically.

>>> from homecog.home import load_home
>>> sim = SimulatedHome(load_home("paper"), start="2021-06-17 07:00")
>>> s = sim.snapshot()
>>> s["time"], s["location"], s["posture"], s["behavior"], s["temperature"]   # file: 19.4 °C
('07:00', 'bed', 'lie', 'sleep', '19.3')
>>> sim.advance(40 * 60)                 # 40 simulated minutes: breakfast
>>> sim.snapshot()["behavior"], sim.snapshot()["ceiling_light"]
('eat', 'on')
>>> sim.switch("ceiling_light", False)   # the robot's IoT command
>>> sim.snapshot()["ceiling_light"]
'off'
>>> sim.set_context({"behavior": "read"}); sim.snapshot()["behavior"]
'read'
>>> sim.resume(); sim.snapshot()["behavior"]
'eat'
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import KW_ONLY, dataclass
from datetime import datetime, timedelta

import numpy as np

from homecog.context import ChangeNotifier, DeviceChange, Origin
from homecog.context.weather import Weather, clamp, numeric_readings
from homecog.errors import ContextError
from homecog.home.codec import normalize
from homecog.home.model import Home, format_number
from homecog.home.routine import Routine, Step, default_routine
from homecog.home.states import state_word

_EPOCH = datetime(1970, 1, 1)
DEFAULT_START = "2021-06-21 06:00"  # midsummer: warm days, cool nights, long daylight
TEMPERATURE_NOISE = 0.2  # °C, standard deviation of the thermometer
ILLUMINATION_NOISE = 0.02  # relative standard deviation of the light sensor


def parse_start(start: datetime | str) -> datetime:
    """A simulated date and time; :class:`ContextError` naming what is not one."""
    if isinstance(start, datetime):
        return start.replace(tzinfo=None)
    try:
        return datetime.fromisoformat(str(start).strip())
    except ValueError:
        raise ContextError(
            f"start: not a date and time: {start!r}; expected e.g. {DEFAULT_START!r}"
        ) from None


@dataclass(eq=False)
class SimulatedHome(ChangeNotifier):
    """A home whose user lives the routine under typical-year weather.

    Parameters
    ----------
    home
        The home; its ``routine`` (or :func:`default_routine`) drives the user.
    speed
        Simulated seconds per real second, for callers that follow a wall clock.
    start
        The simulated date and time to start at (local standard time of the weather file).
    seed
        Seeds the sensor noise on temperature and illumination; same seed, same snapshots.
    routine_switches
        Whether the routine's steps switch the devices they ``set`` (a simulated household
        that switches by its own wishes instead sets this false).
    """

    ready = True

    home: Home
    _: KW_ONLY
    speed: float = 60.0
    start: datetime | str = DEFAULT_START
    seed: int = 0
    routine_switches: bool = True

    def __post_init__(self) -> None:
        home, routine = self.home, self.home.routine
        self._routine: Routine = routine if isinstance(routine, Routine) else default_routine(home.features)
        self._now = parse_start(self.start)
        self._weather = Weather()
        self._overrides: dict[str, str] = {}
        self._states = dict.fromkeys(home.device_names, False)
        # the devices as the user left them over the day before the start
        steps = self._routine.steps
        current = self._routine.index_at(self._hours)
        for k in range(current + 1, current + 1 + len(steps)):
            self._apply(steps[k % len(steps)], tell=False)

    # -- the clock -------------------------------------------------------------------
    @property
    def now(self) -> datetime:
        """The simulated date and time."""
        return self._now

    @property
    def _hours(self) -> float:
        t = self._now
        return t.hour + t.minute / 60 + (t.second + t.microsecond / 1e6) / 3600

    @property
    def step(self) -> Step:
        """The routine step that holds now."""
        return self._routine.step_at(self._hours)

    def advance(self, seconds: float) -> None:
        """Move the clock ``seconds`` simulated seconds on; steps that start on the way switch
        their devices, in order."""
        if seconds < 0:
            raise ValueError(f"cannot advance by {seconds} seconds; time only moves forward")
        end = self._now + timedelta(seconds=seconds)
        steps = self._routine.steps
        while True:
            k = (self._routine.index_at(self._hours) + 1) % len(steps)
            midnight = self._now.replace(hour=0, minute=0, second=0, microsecond=0)
            boundary = midnight + timedelta(seconds=round(steps[k].at * 3600))
            if boundary <= self._now:  # the next step starts tomorrow
                boundary += timedelta(days=1)
            if boundary > end:
                break
            self._now = boundary
            self._apply(steps[k])
        self._now = end

    def clock(self) -> float:
        """The simulated clock as seconds since 1970 (the clock as if it were UTC)."""
        return (self._now - _EPOCH).total_seconds()

    def _apply(self, step: Step, *, tell: bool = True) -> None:
        if not self.routine_switches:
            return
        for device, on in step.sets.items():
            self._set(device, on, "home" if tell else None)

    def _set(self, device: str, on: bool, origin: Origin | None) -> None:
        """Switch a device; tell the listeners (``origin`` None: nobody is told)."""
        if self._states[device] == on:
            return
        before = self.snapshot() if origin is not None and getattr(self, "_listeners", None) else None
        self._states[device] = on
        if before is not None:
            self._tell(DeviceChange(device, on, before, self.clock(), origin=origin))  # type: ignore[arg-type]

    # -- the protocol ----------------------------------------------------------------
    def snapshot(self) -> dict[str, str]:
        """Every feature and device as text, as a scenario file or ``--context`` takes them."""
        return self._snapshot(self._states)

    def actual(self) -> dict[str, str]:
        """The home as it is, not as its sensors read it (no sensor noise): what the people who
        live there feel."""
        return self._snapshot(self._states, noisy=False)

    def preview(self, device: str, on: bool) -> dict[str, str]:
        """The home as it would be now with ``device`` switched (the readings it moves moved too,
        without sensor noise): what a person who knows their home expects of a switch."""
        return self._snapshot({**self._states, device: on}, noisy=False)

    def _snapshot(self, states: Mapping[str, bool], *, noisy: bool = True) -> dict[str, str]:
        values = self._routine.values_at(self._hours)
        numbers = numeric_readings(self.home, self._now, states, self._weather)
        minute = self._now.toordinal() * 1440 + self._now.hour * 60 + self._now.minute
        noise = np.random.default_rng([self.seed, minute]).standard_normal(len(self.home.features))
        noise *= noisy
        out: dict[str, str] = {}
        for i, f in enumerate(self.home.features):
            if f.name in self._overrides:
                out[f.name] = self._overrides[f.name]
            elif f.kind == "clock":
                out[f.name] = f"{self._now.hour:02d}:{self._now.minute:02d}"
            elif f.kind == "categorical":
                out[f.name] = values[f.name]
            else:
                x = numbers[f.name]
                if (f.unit or "").strip().lower() in ("lx", "lux") or f.name in ("illumination", "light"):
                    x = round(clamp(f, x * (1 + ILLUMINATION_NOISE * noise[i])))
                else:
                    x = round(clamp(f, x + TEMPERATURE_NOISE * noise[i]), 1)
                out[f.name] = format_number(clamp(f, x))
        for device, on in states.items():
            out[device] = state_word(on)
        return out

    def switch(self, device: str, on: bool) -> None:
        """Switch ``device`` on or off: the robot's IoT command, or a hand in the simulated home
        (the running robot tells which by what it commanded)."""
        if device not in self._states:
            raise ContextError(
                f"unknown device {device!r}; expected one of {', '.join(self.home.device_names)}"
            )
        self._set(device, bool(on), "home")

    def status(self) -> dict[str, object]:
        return {"kind": "simulated", "connected": True}

    # -- manual mode -----------------------------------------------------------------
    @property
    def manual(self) -> bool:
        """True while :meth:`set_context` overrides some feature."""
        return bool(self._overrides)

    def set_context(self, values: Mapping[str, object]) -> None:
        """Set features and devices by hand: features hold the given value until
        :meth:`resume`; devices are switched (and then keep their state as usual).

        Checks everything before changing anything; raises :class:`ContextError` naming an
        unknown name or a value that fits no bin.
        """
        overrides: dict[str, str] = {}
        states: dict[str, bool] = {}
        for name, value in values.items():
            written = normalize(self.home, name, value)  # ContextError naming what does not fit
            if name in self._states:
                states[name] = written == "on"
            else:
                overrides[name] = written
        self._overrides.update(overrides)
        for device, on in states.items():
            self._set(device, on, "manual")

    def resume(self) -> None:
        """Leave manual mode: the features follow the routine, the clock and the weather again."""
        self._overrides.clear()

    def __repr__(self) -> str:
        return f"SimulatedHome({self.home.name!r}, now={self._now.isoformat(sep=' ')}, speed={self.speed})"
