"""``homecog up``: the running robot, its HMI and HTTP API."""

from __future__ import annotations

import contextlib
import dataclasses
import os
from collections.abc import Callable
from dataclasses import dataclass
from typing import Annotated, Any, cast

import typer

from homecog.cli.options import (
    DbOption,
    HomeOption,
    HostOption,
    PortOption,
    TokenOption,
    server_settings,
    url_host,
)
from homecog.cli.output import stdout
from homecog.errors import UsageProblemError
from homecog.home import load_home
from homecog.home.household import Household
from homecog.home.model import Home

#: seconds at most between two looks at the database for another server's corrections
FRESH = 0.05


def up(
    home: HomeOption = "paper",
    db: DbOption = None,
    host: HostOption = "127.0.0.1",
    port: PortOption = 8000,
    token: TokenOption = None,
    speed: Annotated[
        float,
        typer.Option(
            min=0, max=100_000, help="Simulated seconds per real second of the simulated home (0: manual)."
        ),
    ] = 60.0,
    mqtt: Annotated[
        str | None,
        typer.Option(
            help="Take the context from this MQTT broker (mqtt://host:1883) instead of the simulator."
        ),
    ] = None,
    publish: Annotated[
        str | None,
        typer.Option(
            help="Mirror the simulated home on this MQTT broker: its states go out, commands come in."
        ),
    ] = None,
    home_assistant: Annotated[
        str | None,
        typer.Option(
            "--home-assistant", help="Take the context from this Home Assistant (http://host:8123) instead."
        ),
    ] = None,
    ha_token: Annotated[
        str | None, typer.Option("--ha-token", help="Its access token (default: $HOMECOG_HA_TOKEN).")
    ] = None,
    household: Annotated[
        str | None,
        typer.Option(
            help="A simulated household of this home's wishes lives in the simulated home and "
            "switches by hand what is not as it wants (the robot learns from it)."
        ),
    ] = None,
    undo_window: Annotated[
        float | None,
        typer.Option(min=0, max=1440, help="Minutes within which a person switching back is an undo (15)."),
    ] = None,
    hold: Annotated[
        float | None,
        typer.Option(min=0, max=1440, help="Minutes the robot leaves a device a person switched (30)."),
    ] = None,
    observed_weight: Annotated[
        int | None, typer.Option(min=1, max=100, help="Corrections' worth of a person's switch (5).")
    ] = None,
    undo_weight: Annotated[
        int | None, typer.Option(min=1, max=100, help="Corrections' worth of an undo (5).")
    ] = None,
    robot: Annotated[
        str,
        typer.Option(
            "--robot",
            help="The robot's body in the simulated home: builtin (homecog's own simulator) or pyrobosim.",
        ),
    ] = "builtin",
) -> None:
    """Start the robot: train or reuse the Q table, build or reuse the tree, serve the HMI."""
    import functools
    import gc

    from homecog.knowledge.database import redact
    from homecog.robot.assemble import Wiring, assemble
    from homecog.web.main import create_app
    from homecog.web.serving import run

    _check_flags(
        mqtt=mqtt,
        home_assistant=home_assistant,
        publish=publish,
        household=household,
        speed=speed,
        robot=robot,
    )
    outside = _outside(home_assistant=home_assistant, mqtt=mqtt)
    h = load_home(home)
    people = household_settings(h.household, undo_window, hold, observed_weight, undo_weight)
    truth = _household(household, h)
    settings = server_settings(token, host)
    say = stdout.print
    with contextlib.ExitStack() as stack:
        early = outside is not None and outside.source.early
        # made once the tree is (a simulated home's clock starts then), or started at once
        made: Any = functools.partial(_source, outside, speed=speed, truth=truth, ha_token=ha_token)
        if early:  # a wrong URL, token or entity fails before any training
            made = _start(outside, outside.source.make(h, outside.url, ha_token), h, stack)
        wiring = Wiring(h, db=db, fresh=FRESH, household=people, robot=robot, truth=truth)
        runtime = assemble(wiring, source=made, progress=lambda m: say(m, style="dim")).runtime
        stack.callback(runtime.store.close)
        store, source = runtime.store, cast(Any, runtime.source)
        if runtime.actor.body is not None:
            say(
                f"the robot's body: {runtime.actor.body.name} ({runtime.actor.body.planner} paths)",
                style="dim",
            )
        if truth is not None:
            say(f"a household of {truth.name}'s wishes lives in the simulated home")
        if outside is not None:  # once the runtime exists: a retained state comes at once
            source.on_change = functools.partial(runtime.publish, "context")
            if not early:
                _start(outside, source, h, stack)
        if publish is not None:
            _mirror(h, publish, source, runtime, stack)
        broker = mqtt or publish
        if broker is not None:  # the robot and the home in Home Assistant, gone when it stops
            from homecog.robot.announce import announce

            stack.callback(announce(runtime, broker).start(wait=False).stop)
            say(
                f"in Home Assistant by MQTT discovery on {_shown(broker)}: the robot's services, "
                "last action, undo"
            )
        say(f"knowledge: {redact(store.url)} ({store.experience_count():,} experiences)", style="dim")
        say(f"homecog is up: http://{url_host(host)}:{port}")
        live = speed if outside is None else 1.0  # a real home's own clock
        gc.freeze()  # the tree lives as long as the server: keep the collector from walking it
        settings = settings.model_copy(update={"live": live})
        run(create_app(runtime, settings), settings, host=host, port=port)


@dataclass(frozen=True)
class OutsideSource:
    """A home's context from outside the simulator, as a flag of ``homecog up`` names it."""

    make: Callable[[Home, str, str | None], Any]  # (home, URL, Home Assistant token) → the source
    early: bool  # started before the training (else once the runtime exists)
    said: Callable[[Home, str, Any], str]  # what is printed once it is started


@dataclass(frozen=True)
class Outside:
    """The outside source chosen, and its URL."""

    source: OutsideSource
    url: str


def _home_assistant(home: Home, url: str, ha_token: str | None) -> Any:
    from homecog.context.ha_client import TOKEN_HELP
    from homecog.context.home_assistant import HomeAssistantSource
    from homecog.errors import HomeAssistantError

    token = ha_token or os.environ.get("HOMECOG_HA_TOKEN")
    if not token and home.home_assistant is not None:  # the flag's words; the source's say no flag
        raise HomeAssistantError(
            f"no token for Home Assistant at {url}: set $HOMECOG_HA_TOKEN or give --ha-token, " + TOKEN_HELP
        )
    return HomeAssistantSource(home, url, token=token)


def _mqtt(home: Home, url: str, ha_token: str | None) -> Any:
    from homecog.context.mqtt_source import MqttSource

    return MqttSource(home, url)


def _shown(url: str) -> str:
    """A broker's (or any) URL as it is printed: never with its password."""
    from homecog.context.mqtt_broker import redact_url

    return redact_url(url)


#: The option naming each outside source → how it is made, started and said.
OUTSIDE = {
    "home_assistant": OutsideSource(
        _home_assistant,
        early=True,
        said=lambda home, url, source: f"context from Home Assistant {source.version} at {_shown(url)}",
    ),
    "mqtt": OutsideSource(
        _mqtt,
        early=False,
        said=lambda home, url, source: (
            f"context from {_shown(url)}: topics homecog/{home.name}/state/<name>, "
            f"commands to homecog/{home.name}/command/<device>"
        ),
    ),
}


def _outside(**urls: str | None) -> Outside | None:
    """The outside source an option names (at most one: :func:`_check_flags`), or None: the
    simulated home."""
    return next((Outside(OUTSIDE[option], url) for option, url in urls.items() if url is not None), None)


def _check_flags(
    *,
    mqtt: str | None,
    home_assistant: str | None,
    publish: str | None,
    household: str | None,
    speed: float,
    robot: str,
) -> None:
    """The flags that go together, checked before any work."""
    from homecog.simulation.bodies import BODIES

    if publish is not None and (mqtt is not None or speed == 0):
        raise UsageProblemError("--publish mirrors the simulated home; it needs --speed > 0 and no --mqtt")
    if home_assistant is not None and (mqtt is not None or publish is not None):
        raise UsageProblemError(
            "--home-assistant is the home's context; it goes with neither --mqtt nor --publish"
        )
    if household is not None and (mqtt is not None or home_assistant is not None or speed == 0):
        raise UsageProblemError("--household lives in the simulated home; it needs --speed > 0, no broker")
    if robot not in BODIES:
        raise UsageProblemError(f"--robot: unknown body {robot!r}; expected one of {', '.join(BODIES)}")
    if robot != "builtin" and (mqtt is not None or home_assistant is not None):
        raise UsageProblemError(
            f"--robot {robot} is the simulated home's robot; in a home on a broker or Home Assistant "
            "the robot switches by IoT"
        )
    if robot == "pyrobosim":  # before any training: the extra missing is said at once
        from homecog.simulation.pyrobosim_body import require_pyrobosim

        require_pyrobosim()


def _household(household: str | None, home: Home) -> Home | None:
    """The home of ``--household``'s wishes, checked against the served ``home``."""
    if household is None:
        return None
    from homecog.home.content import is_compatible

    truth = load_home(household)
    problems = is_compatible(truth, home)
    if problems:
        raise UsageProblemError(
            f"--household {truth.source}: not compatible with home '{home.name}': {'; '.join(problems)}"
        )
    return truth


def _simulated(home: Home, speed: float, truth: Home | None) -> Any:
    """The simulated home (its routine switching devices unless a household lives there), or
    the manual source at ``--speed 0``."""
    from homecog.context.manual import ManualSource
    from homecog.context.simulated import SimulatedHome

    return (
        SimulatedHome(home, speed=speed, routine_switches=truth is None) if speed > 0 else ManualSource(home)
    )


def _source(
    outside: Outside | None, home: Home, *, speed: float, truth: Home | None, ha_token: str | None
) -> Any:
    """The context source made once the tree is: the simulated home (or the manual source), or
    an outside source started only once the runtime exists (:attr:`OutsideSource.early`)."""
    if outside is None:
        return _simulated(home, speed, truth)
    return outside.source.make(home, outside.url, ha_token)


def _start(outside: Outside, source: Any, home: Home, stack: contextlib.ExitStack) -> Any:
    """Start an outside source, to be stopped with the server; said once it is."""
    source.start()
    stack.callback(source.stop)
    stdout.print(outside.source.said(home, outside.url, source))
    return source


def _mirror(home: Home, url: str, source: Any, runtime: Any, stack: contextlib.ExitStack) -> None:
    """``--publish``: the simulated home on a broker, its states out and commands in."""
    from homecog.context.mqtt_publisher import MqttPublisher

    mirror = MqttPublisher(home, url, on_command=runtime.switch).start()
    stack.callback(mirror.stop)
    mirror.publish(source.snapshot(), everything=True)
    runtime.watchers.append(mirror.publish)
    stdout.print(
        f"the simulated home on {_shown(url)}: states to homecog/{home.name}/state/<name>, "
        f"commands from homecog/{home.name}/command/<device>"
    )


def household_settings(
    base: Household, undo_window: float | None, hold: float | None, observed: int | None, undo: int | None
) -> Household:
    """The home file's ``household`` settings with the flags given over them (minutes → s)."""
    weights = dict(base.weights)
    weights.update({k: w for k, w in (("observed", observed), ("undo", undo)) if w is not None})
    return dataclasses.replace(
        base,
        undo_window=base.undo_window if undo_window is None else undo_window * 60,
        hold=base.hold if hold is None else hold * 60,
        weights=weights,
    )


# -- entry point -------------------------------------------------------------------------------
