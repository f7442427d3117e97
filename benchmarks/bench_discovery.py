"""homecog in a local Home Assistant 2024.3.3 by MQTT discovery: how fast the robot's entities
appear, how fast its decision becomes the services sensor's state there, and how fast a press
of the undo button there is learned as a rejection.

Home Assistant runs from ``.ha-venv`` (``bash .ci/home_assistant.sh``) with the tests'
configuration (tests/home_assistant.py) and its MQTT integration on the broker at
``$HOMECOG_TEST_MQTT_URL`` or 127.0.0.1:1883 (a Mosquitto); the robot follows the studio (a
context set by hand) as ``homecog up --publish`` does, announced by
:func:`homecog.robot.announce.announce`.

- *Configs → entities*: from the discovery's start (configs published) to every entity of the
  robot and the home available in Home Assistant (polled every 10 ms over REST).
- *Decision → state*: the robot decides (``Runtime.act_now``: relaxing with the radio off, tea
  and the radio; once it has switched the radio on, tea) until the services sensor's new state
  reaches this process as Home Assistant's ``state_changed`` event. This process's clock.
- *Undo → learned*: a person presses "Undo last action" in Home Assistant (``button.press``
  over REST, as the app does) until the robot has switched the radio back and learned the
  rejection (its guidance counts the undo).

    .venv/bin/python benchmarks/bench_discovery.py [--decisions 100] [--presses 100]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import secrets
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from rich.console import Console
from rich.table import Table

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from home_assistant import VERSION, HomeAssistant, StateChanges, enable_mqtt, hass_binary  # noqa: E402

from homecog.context.manual import ManualSource  # noqa: E402
from homecog.context.mqtt_publisher import MqttPublisher  # noqa: E402
from homecog.home import load_home  # noqa: E402
from homecog.knowledge.pipeline import build  # noqa: E402
from homecog.knowledge.store import Store  # noqa: E402
from homecog.robot.announce import announce  # noqa: E402
from homecog.robot.runtime import Runtime  # noqa: E402

WORK = {
    "time": "10:00",
    "light": "300",
    "activity": "work",
    "blind": "on",
    "desk_lamp": "off",
    "radio": "off",
}


def wait(condition: Callable[[], object], what: str, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise SystemExit(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(0.001)


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q / 100 * (len(ordered) - 1)))]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--decisions", type=int, default=100)
    parser.add_argument("--presses", type=int, default=100)
    args = parser.parse_args(argv)
    hass, why = hass_binary()
    if hass is None:
        print(f"discovery: {why}", file=sys.stderr)
        return 1
    broker = os.environ.get("HOMECOG_TEST_MQTT_URL", "mqtt://127.0.0.1:1883")
    home = load_home(ROOT / "tests" / "homes" / "studio.yaml")
    with tempfile.TemporaryDirectory(prefix="homecog-bench-discovery-") as folder:
        server = HomeAssistant(hass, Path(folder) / "ha")
        server.start()
        try:
            server.onboard()
            enable_mqtt(server, broker)
            with StateChanges(server, server.owner_token) as changes:
                rows = measure(server, changes, broker, home, Path(folder), args)
        finally:
            server.stop()
    table = Table(title=f"homecog in Home Assistant {VERSION} by MQTT discovery (the studio)")
    for column in ("from → to", "n", "median ms", "p95 ms", "max ms"):
        table.add_column(column, justify="left" if column == "from → to" else "right")
    for name, ms in rows:
        table.add_row(
            name, str(len(ms)), f"{statistics.median(ms):.1f}", f"{percentile(ms, 95):.1f}", f"{max(ms):.1f}"
        )
    Console(width=120).print(table)
    return 0


def measure(
    server: HomeAssistant, changes: StateChanges, broker: str, home, folder: Path, args: argparse.Namespace
) -> list[tuple[str, list[float]]]:
    prefix = f"homecog_b{secrets.token_hex(4)}"
    store = Store.open(f"sqlite:///{folder / 'k.sqlite'}", home)
    source = ManualSource(home)
    source.set_context(WORK)
    household = dataclasses.replace(home.household, hold=0.0)
    runtime = Runtime(
        home=home, store=store, tree=build(home, store).tree, source=source, household=household
    )
    decided: list[tuple[float, list[str]]] = []
    runtime.announcers.append(
        lambda kind, data: (
            decided.append((time.perf_counter(), data["services"])) if kind == "decision" else None
        )
    )
    mirror = MqttPublisher(home, broker, prefix=prefix, on_command=runtime.switch).start()
    mirror.publish(source.snapshot(), everything=True)
    runtime.watchers.append(mirror.publish)
    keys = [("sensor", "services"), ("sensor", "last_action"), ("button", "undo")]
    keys += [("switch", d) for d in home.device_names]
    entities = [f"{c}.{prefix}_studio_{k}" for c, k in keys]

    def available(entity: str) -> bool:
        try:
            return server.state(server.owner_token, entity)["state"] != "unavailable"
        except Exception:
            return False

    begin = time.perf_counter()
    discovery = announce(runtime, broker, prefix=prefix).start()
    try:
        wait(lambda: all(available(e) for e in entities), "every entity available")
        appeared = [1000 * (time.perf_counter() - begin)]
        sensor, to_state = entities[0], []
        for n in range(args.decisions):
            since, first = changes.count(), len(decided)
            source.set_context({"activity": "relax", "light": str(300 + n % 50), "radio": "off"})
            runtime.act_now("default")
            for at, services in decided[first:]:
                text = ", ".join(services)
                wait(
                    lambda s=since, t=text: any(st and st["state"] == t for _, st in changes.of(sensor, s)),
                    text,
                )
                seen = next(t for t, st in changes.of(sensor, since) if st and st["state"] == text)
                to_state.append(1000 * (seen - at))
        to_learned = []
        for n in range(1, args.presses + 1):
            source.set_context({"activity": ["relax", "work"][n % 2], "radio": "off"})
            if runtime.act(source.snapshot(), ["RadioOn"]) is None:
                raise SystemExit(f"the robot did not switch the radio on before press {n}")
            runtime.act(source.snapshot(), [])  # the robot looks at the home, as every tick does
            undos = runtime.guidance.counts["undo"]
            began = time.perf_counter()
            server.call(server.owner_token, "button.press", entities[2])
            wait(lambda u=undos: runtime.guidance.counts["undo"] == u + 1, f"undo {n} learned")
            to_learned.append(1000 * (time.perf_counter() - began))
    finally:
        discovery.stop()
        mirror.stop()
        store.close()
    return [
        ("configs published → every entity available", appeared),
        ("robot's decision → services sensor's state", to_state),
        ("undo pressed → rejection learned", to_learned),
    ]


if __name__ == "__main__":
    sys.exit(main())
