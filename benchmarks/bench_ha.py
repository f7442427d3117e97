"""homecog and a local Home Assistant 2024.3.3: how fast a change reaches the robot's context,
how fast the robot's switch becomes Home Assistant's state, how fast the robot is back after
Home Assistant restarts.

Home Assistant runs from ``.ha-venv`` (``bash .ci/home_assistant.sh``) with the tests'
configuration (tests/home_assistant.py) on this machine; homecog follows it as ``homecog up
--home-assistant`` does, through :class:`HomeAssistantSource` and the ``studio_ha`` home.

- *State change → context*: a person's app sets ``input_number.light`` (one change at a time);
  from the change's ``last_updated`` in Home Assistant to the moment homecog's context holds
  the new value (``on_change``). Both clocks are this machine's.
- *Decision → entity's state*: the robot's switch (``HomeAssistantSource.switch``, a service call)
  from the call to the ``last_updated`` of the entity's new state, for an ``input_boolean`` and
  for a template cover (a cover whose opening switches another entity, as real covers report
  back); and on to the moment homecog sees that state.
- *Back after a restart*: Home Assistant stopped and started again; from the moment its API
  answers again to homecog connected, subscribed and holding a new snapshot.

    .venv/bin/python benchmarks/bench_ha.py [--changes 200] [--switches 100] [--restarts 3] [--install]
"""

from __future__ import annotations

import argparse
import asyncio
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from datetime import datetime
from pathlib import Path

import aiohttp
from rich.console import Console
from rich.table import Table

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from home_assistant import VERSION, HomeAssistant, hass_binary  # noqa: E402

from homecog.context.home_assistant import HomeAssistantSource  # noqa: E402
from homecog.home import load_home  # noqa: E402


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, round(q / 100 * len(ordered) + 0.5) - 1))]


def ha_time(state: dict) -> float:
    return datetime.fromisoformat(state["last_updated"]).timestamp()


class Person:
    """A household member's app: one WebSocket connection, service calls one at a time."""

    def __init__(self, url: str, token: str) -> None:
        self.url, self.token = url, token
        self.loop = asyncio.new_event_loop()
        threading.Thread(target=self.loop.run_forever, daemon=True).start()
        self.ws = self.run(self._connect())
        self.id = 0

    def run(self, coro):
        return asyncio.run_coroutine_threadsafe(coro, self.loop).result(30)

    async def _connect(self):
        self.session = aiohttp.ClientSession()
        ws = await self.session.ws_connect(f"{self.url}/api/websocket")
        await ws.receive_json()
        await ws.send_json({"type": "auth", "access_token": self.token})
        assert (await ws.receive_json())["type"] == "auth_ok"
        return ws

    def call(self, domain: str, service: str, entity: str, **data: object) -> None:
        async def go() -> None:
            self.id += 1
            await self.ws.send_json(
                {"id": self.id, "type": "call_service", "domain": domain, "service": service,
                 "target": {"entity_id": entity}, "service_data": data}
            )  # fmt: skip
            while (await self.ws.receive_json()).get("id") != self.id:
                pass

        self.run(go())

    def close(self) -> None:
        async def go() -> None:
            await self.ws.close()
            await self.session.close()

        self.run(go())
        self.loop.call_soon_threadsafe(self.loop.stop)


def measure_changes(source: HomeAssistantSource, person: Person, n: int) -> tuple[list[float], list[float]]:
    """(last_updated → context, the person's call → context) per change, in seconds."""
    changed: dict[str, float] = {}  # light value -> Home Assistant's last_updated
    seen: dict[str, float] = {}  # light value -> when homecog's context held it
    done = threading.Condition()

    def on_state(entity: str, state: dict, received: float) -> None:
        if entity == "input_number.light":
            changed[state["state"]] = ha_time(state)

    def on_change(snapshot: dict[str, str]) -> None:
        with done:
            seen.setdefault(snapshot["light"], time.time())
            done.notify_all()

    source.on_state, source.on_change = on_state, on_change
    to_context, end_to_end = [], []
    for i in range(n):
        value = 1000 + i  # each a new value, all in the `bright` bin
        began = time.time()
        person.call("input_number", "set_value", "input_number.light", value=value)
        with done:
            done.wait_for(lambda v=str(value): v in seen, timeout=10)
        key = f"{value}.0"
        to_context.append(seen[str(value)] - changed[key])
        end_to_end.append(seen[str(value)] - began)
        time.sleep(0.02)
    source.on_state = source.on_change = None
    return to_context, end_to_end


def measure_switches(
    source: HomeAssistantSource, device: str, entity: str, n: int
) -> tuple[list[float], list[float]]:
    """(the switch call → the entity's new state in Home Assistant, → homecog sees it) per switch."""
    arrived: dict[tuple[str, str], tuple[float, float]] = {}  # (entity, state) -> (last_updated, received)
    lock = threading.Condition()

    def on_state(e: str, state: dict, received: float) -> None:
        if e == entity:
            with lock:
                arrived[(e, state["state"])] = (ha_time(state), received)
                lock.notify_all()

    source.on_state = on_state
    mapping = source.mapping.device(device)
    to_state, round_trip = [], []
    for i in range(n):
        on = source.snapshot()[device] == "off"
        target = mapping.on[0] if on else mapping.off[0]
        with lock:
            arrived.pop((entity, target), None)
        began = time.time()
        source.switch(device, on)
        with lock:
            lock.wait_for(lambda t=target: (entity, t) in arrived, timeout=10)
        changed, received = arrived[(entity, target)]
        to_state.append(changed - began)
        round_trip.append(received - began)
        deadline = time.monotonic() + 5
        while source.snapshot()[device] != ("on" if on else "off") and time.monotonic() < deadline:
            time.sleep(0.005)
        time.sleep(0.02 if i % 2 else 0.05)
    source.on_state = None
    return to_state, round_trip


def measure_restarts(
    server: HomeAssistant, source: HomeAssistantSource, k: int
) -> tuple[list[float], list[float]]:
    """(API answers again → homecog connected and subscribed, Home Assistant's start) per restart."""
    back, starts = [], []
    for _ in range(k):
        server.stop()
        deadline = time.monotonic() + 30
        while source.connected and time.monotonic() < deadline:
            time.sleep(0.01)
        starts.append(server.start())
        answered = time.monotonic()
        while not source.connected and time.monotonic() - answered < 60:
            time.sleep(0.005)
        back.append(time.monotonic() - answered)
        source.wait_ready(10)
    return back, starts


def install_seconds() -> float | None:
    """A fresh install of Home Assistant into a new venv with .ci/home_assistant.sh (uv's cache
    as this machine has it)."""
    folder = Path(tempfile.mkdtemp()) / "ha-venv"
    began = time.monotonic()
    done = subprocess.run(
        ["bash", str(ROOT / ".ci" / "home_assistant.sh")],
        env={**os.environ, "HOMECOG_TEST_HA_VENV": str(folder)},
        capture_output=True,
        text=True,
    )
    seconds = time.monotonic() - began
    ok = (folder / "bin" / "hass").exists()
    shutil.rmtree(folder.parent, ignore_errors=True)
    print(done.stdout.strip())
    return seconds if ok else None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--changes", type=int, default=200)
    parser.add_argument("--switches", type=int, default=100)
    parser.add_argument("--restarts", type=int, default=3)
    parser.add_argument("--install", action="store_true", help="also time a fresh install into a new venv")
    args = parser.parse_args()
    console = Console(width=130)
    hass, why = hass_binary()
    if hass is None:  # bin/bench runs every benchmark: say why this one cannot, and go on
        console.print(f"bench_ha: skipped: {why}")
        return
    installed = install_seconds() if args.install else None
    config = Path(tempfile.mkdtemp()) / "home-assistant"
    server = HomeAssistant(hass, config)
    first_start = server.start()
    try:
        person_token = server.onboard()
        _, robot_token = server.add_user("homecog", "homecog", "homecog-password-1")
        home = load_home(ROOT / "tests" / "homes" / "studio_ha.yaml")
        source = HomeAssistantSource(home, server.url, token=robot_token).start()
        source.wait_ready(10)
        person = Person(server.url, person_token)
        try:
            to_context, end_to_end = measure_changes(source, person, args.changes)
        finally:
            person.close()
        radio = measure_switches(source, "radio", "input_boolean.radio", args.switches)
        blind = measure_switches(source, "blind", "cover.blind", args.switches)
        back, restarts = measure_restarts(server, source, args.restarts)
        source.stop()
    finally:
        server.stop()
        shutil.rmtree(config.parent, ignore_errors=True)

    ms = 1000.0
    table = Table(title=f"homecog and Home Assistant {VERSION} on this machine", title_justify="left")
    for col in ("figure", "n", "p50", "p95", "max", "target"):
        table.add_column(col, justify="left" if col in ("figure", "target") else "right")

    def row(name: str, values: list[float], target: str = "", unit: float = ms, suffix: str = " ms") -> None:
        table.add_row(
            name,
            str(len(values)),
            *(
                f"{x * unit:.1f}{suffix}"
                for x in (statistics.median(values), percentile(values, 95), max(values))
            ),
            target,
        )

    row("state change → homecog's context", to_context, "p95 ≤ 100 ms")
    row("  (a person's service call → context)", end_to_end)
    row("robot's switch → entity's new state (input_boolean)", radio[0], "p95 ≤ 200 ms")
    row("robot's switch → entity's new state (template cover)", blind[0], "p95 ≤ 200 ms")
    row("  (robot's switch → homecog sees the new state, cover)", blind[1])
    row("API answers again → reconnected and resubscribed", back, "≤ 5 s", unit=1, suffix=" s")
    row("Home Assistant restart: start → API answers", restarts, unit=1, suffix=" s")
    console.print(table)
    console.print(
        f"Home Assistant's first start (fresh configuration) → API answers: {first_start:.1f} s"
        + (f"; a fresh install into a new venv: {installed:.1f} s" if installed else "")
    )


if __name__ == "__main__":
    main()
