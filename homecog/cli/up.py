"""``homecog up``: the running robot, its HMI and HTTP API."""

from __future__ import annotations

import contextlib
import dataclasses
import os
from typing import Annotated, Any

import typer

from homecog.cli.options import (
    DbOption,
    HomeOption,
    HostOption,
    PortOption,
    UsageProblemError,
)
from homecog.cli.output import stdout
from homecog.home import load_home
from homecog.home.household import Household

LOCAL_HOSTS = ("127.0.0.1", "localhost", "::1")


def up(
    home: HomeOption = "paper",
    db: DbOption = None,
    host: HostOption = "127.0.0.1",
    port: PortOption = 8000,
    token: Annotated[
        str | None,
        typer.Option(
            help="Token every /api request needs (default: $HOMECOG_TOKEN; none on 127.0.0.1, "
            "else generated and printed once)."
        ),
    ] = None,
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
    import secrets

    from homecog.context.manual import ManualSource
    from homecog.context.simulated import SimulatedHome
    from homecog.knowledge.database import redact
    from homecog.knowledge.pipeline import open_tree
    from homecog.knowledge.store import Store
    from homecog.robot.runtime import Runtime
    from homecog.web.main import create_app
    from homecog.web.serving import run
    from homecog.web.settings import Settings

    if publish is not None and (mqtt is not None or speed == 0):
        raise UsageProblemError("--publish mirrors the simulated home; it needs --speed > 0 and no --mqtt")
    if home_assistant is not None and (mqtt is not None or publish is not None):
        raise UsageProblemError(
            "--home-assistant is the home's context; it goes with neither --mqtt nor --publish"
        )
    if household is not None and (mqtt is not None or home_assistant is not None or speed == 0):
        raise UsageProblemError("--household lives in the simulated home; it needs --speed > 0, no broker")
    from homecog.simulation.bodies import BODIES

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
    h = load_home(home)
    people = household_settings(h.household, undo_window, hold, observed_weight, undo_weight)
    truth = load_home(household) if household is not None else None
    if truth is not None:
        from homecog.home.content import is_compatible

        problems = is_compatible(truth, h)
        if problems:
            raise UsageProblemError(
                f"--household {truth.source}: not compatible with home '{h.name}': {'; '.join(problems)}"
            )
    settings = Settings.of(token=token)  # or $HOMECOG_TOKEN; refused unless 8 or more ASCII characters
    if host not in LOCAL_HOSTS and settings.token is None:
        settings = settings.model_copy(update={"token": secrets.token_urlsafe(24)})
        stdout.print(f"token for every /api request (shown once): {settings.token}")
    say = stdout.print
    with contextlib.ExitStack() as stack:
        if home_assistant is not None:  # first: a wrong URL, token or entity fails before any training
            from homecog.context.home_assistant import HomeAssistantSource

            token_ha = ha_token or os.environ.get("HOMECOG_HA_TOKEN")
            ha_source = HomeAssistantSource(h, home_assistant, token=token_ha).start()
            stack.callback(ha_source.stop)
            say(f"context from Home Assistant {ha_source.version} at {home_assistant}")
        store = Store.open(db, h)
        stack.callback(store.close)
        tree = open_tree(h, store, progress=lambda m: say(m, style="dim"))
        source: Any = (
            SimulatedHome(h, speed=speed, routine_switches=truth is None) if speed > 0 else ManualSource(h)
        )
        if mqtt is not None:
            from homecog.context.mqtt import MqttSource

            source = MqttSource(h, mqtt)
        if home_assistant is not None:
            source = ha_source
        runtime = Runtime(home=h, store=store, tree=tree, source=source, household=people, robot=robot)
        if runtime.actor.body is not None:
            say(
                f"the robot's body: {runtime.actor.body.name} ({runtime.actor.body.planner} paths)",
                style="dim",
            )
        if truth is not None:
            from homecog.evaluation.closed_loop import SimulatedHousehold

            living = SimulatedHousehold(truth, source, undo_window=people.undo_window)
            runtime.after_tick.append(living.step)
            say(f"a household of {truth.name}'s wishes lives in the simulated home")
        if mqtt is not None:  # started once the runtime exists: a retained state comes at once
            source.on_change = functools.partial(runtime.publish, "context")
            source.start()
            stack.callback(source.stop)
            say(
                f"context from {mqtt}: topics homecog/{h.name}/state/<name>, "
                f"commands to homecog/{h.name}/command/<device>"
            )
        if home_assistant is not None:  # running since before the training: its changes go on from here
            ha_source.on_change = functools.partial(runtime.publish, "context")
        if publish is not None:
            from homecog.context.mqtt import MqttPublisher

            mirror = MqttPublisher(h, publish, on_command=runtime.switch).start()
            stack.callback(mirror.stop)
            mirror.publish(source.snapshot(), everything=True)
            runtime.watchers.append(mirror.publish)
            say(
                f"the simulated home on {publish}: states to homecog/{h.name}/state/<name>, "
                f"commands from homecog/{h.name}/command/<device>"
            )
        broker = mqtt or publish
        if broker is not None:  # the robot and the home in Home Assistant, gone when it stops
            from homecog.robot.announce import announce

            stack.callback(announce(runtime, broker).start(wait=False).stop)
            say(f"in Home Assistant by MQTT discovery on {broker}: the robot's services, last action, undo")
        say(f"knowledge: {redact(store.url)} ({store.experience_count():,} experiences)", style="dim")
        say(f"homecog is up: http://{host if ':' not in host else f'[{host}]'}:{port}")
        live = speed if mqtt is None and home_assistant is None else 1.0  # a real home's own clock
        gc.freeze()  # the tree lives as long as the server: keep the collector from walking it
        settings = settings.model_copy(update={"live": live})
        run(create_app(runtime, settings), settings, host=host, port=port)


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
