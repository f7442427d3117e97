"""A real Home Assistant 2024.3.3 for the tests and the benchmark, started from its own venv.

``.ci/home_assistant.sh`` installs it into ``.ha-venv/`` (``$HOMECOG_TEST_HA_VENV`` names another
venv); where it is not there, :func:`hass_binary` says why and the tests skip. Each instance gets
a fresh configuration folder with the entities of ``tests/homes/studio_ha.yaml``: helpers
(``input_*``) stand in for sensors, a template cover and a template light switch helpers the way
real devices switch, and an automation switches the radio when ``input_boolean.trigger`` turns
on (a change with a parent context). :meth:`HomeAssistant.onboard` makes the owner, a person of
the household, and :meth:`HomeAssistant.add_user` another user, the robot, each with a
long-lived token, without a browser; :class:`ServiceCalls` records every service call the
instance carries out, and as whom; :class:`StateChanges` every state change, as it arrives;
:func:`enable_mqtt` sets its MQTT integration up on a broker (it needs paho-mqtt 1.6.1 in its
venv, which ``.ci/home_assistant.sh`` installs).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import aiohttp

if TYPE_CHECKING:
    import pytest

ROOT = Path(__file__).resolve().parent.parent
VERSION = "2024.3.3"
CLIENT_ID = "http://127.0.0.1/"  # any URL will do as an OAuth client id
START_TIMEOUT = 180.0  # seconds; about 30 s on an idle 2-core machine

CONFIGURATION = """\
homeassistant:
  name: homecog test home
  latitude: 52.52
  longitude: 13.40
  elevation: 34
  unit_system: metric
  time_zone: UTC
  currency: EUR
  country: DE
http:
  server_host: 127.0.0.1
  server_port: {port}
api:
websocket_api:
onboarding:
auth:
config:
recorder:
  commit_interval: 0
  purge_keep_days: 30
history:
input_datetime:
  clock: {{name: Clock, has_date: false, has_time: true, initial: "10:00"}}
input_number:
  light: {{name: Light, min: -100, max: 2000, step: 1, initial: 300, mode: box, unit_of_measurement: lx}}
input_select:
  activity: {{name: Activity, options: [working, relaxing, sleeping, away], initial: working}}
input_boolean:
  radio: {{name: Radio}}
  blind_motor: {{name: Blind motor}}
  desk_lamp_power: {{name: Desk lamp power}}
  trigger: {{name: Trigger}}
cover:
  - platform: template
    covers:
      blind:
        friendly_name: Blind
        value_template: "{{{{ is_state('input_boolean.blind_motor', 'on') }}}}"
        open_cover: {{service: input_boolean.turn_on, target: {{entity_id: input_boolean.blind_motor}}}}
        close_cover: {{service: input_boolean.turn_off, target: {{entity_id: input_boolean.blind_motor}}}}
light:
  - platform: template
    lights:
      desk_lamp:
        friendly_name: Desk lamp
        value_template: "{{{{ is_state('input_boolean.desk_lamp_power', 'on') }}}}"
        turn_on: {{service: input_boolean.turn_on, target: {{entity_id: input_boolean.desk_lamp_power}}}}
        turn_off: {{service: input_boolean.turn_off, target: {{entity_id: input_boolean.desk_lamp_power}}}}
automation:
  - id: radio_with_the_trigger
    alias: Radio with the trigger
    trigger: {{platform: state, entity_id: input_boolean.trigger, to: "on"}}
    action: {{service: input_boolean.toggle, target: {{entity_id: input_boolean.radio}}}}
"""


def ha_venv() -> Path:
    """Where Home Assistant's own venv is looked for."""
    return Path(os.environ.get("HOMECOG_TEST_HA_VENV") or ROOT / ".ha-venv")


def hass_binary() -> tuple[Path | None, str]:
    """The ``hass`` program of Home Assistant 2024.3.3, or None and why it cannot be had."""
    venv = ha_venv()
    hass = venv / "bin" / "hass"
    if not hass.exists():
        return None, f"no Home Assistant at {venv} (bash .ci/home_assistant.sh installs it there)"
    stamp = venv / ".homecog-ha"
    if stamp.exists() and VERSION not in stamp.read_text():
        return None, f"{venv} holds another Home Assistant than {VERSION}: {stamp.read_text().strip()}"
    return hass, ""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def running_home_assistant(tmp_path_factory: pytest.TempPathFactory) -> Iterator[HomeAssistant]:
    """A Home Assistant started in a fresh folder and onboarded (its owner's token in
    :attr:`HomeAssistant.owner_token`), stopped at the end; skips the calling tests, printing
    why, where there is none to start or it does not start."""
    import pytest  # here, not above: the benchmark uses this module without pytest

    hass, why = hass_binary()
    if hass is None:
        print(f"\nSKIP Home Assistant tests: {why}", file=sys.stderr)
        pytest.skip(why)
    server = HomeAssistant(hass, tmp_path_factory.mktemp("home-assistant"))
    try:
        seconds = server.start()
    except RuntimeError as e:
        reason = f"Home Assistant {VERSION} did not start: {e}"
        print(f"\nSKIP {reason}", file=sys.stderr)
        pytest.skip(reason)
    print(f"\nHome Assistant {VERSION} answered after {seconds:.1f} s at {server.url}", file=sys.stderr)
    try:
        server.onboard()
        yield server
    finally:
        server.stop()


class HomeAssistant:
    """One Home Assistant process on 127.0.0.1 with a configuration folder of its own."""

    def __init__(self, hass: Path, config: Path, port: int | None = None) -> None:
        self.hass = hass
        self.config = config
        self.port = port or free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.proc: subprocess.Popen[bytes] | None = None
        self.owner_token = ""
        self.owner_id = ""
        config.mkdir(parents=True, exist_ok=True)
        (config / "configuration.yaml").write_text(CONFIGURATION.format(port=self.port, config=config))

    @property
    def recorder(self) -> Path:
        return self.config / "home-assistant_v2.db"

    # -- the process ---------------------------------------------------------------------------
    def start(self, timeout: float = START_TIMEOUT) -> float:
        """Start it and wait until its API answers; the seconds that took."""
        begin = time.monotonic()
        log = (self.config / "hass.out").open("ab")
        # --skip-pip: everything it needs is in its venv, and it must not install at run time
        self.proc = subprocess.Popen(
            [str(self.hass), "-c", str(self.config), "--skip-pip", "--log-no-color"],
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        log.close()
        while not self.answers():
            if self.proc.poll() is not None:
                raise RuntimeError(f"Home Assistant exited with {self.proc.returncode}: {self.log_tail()}")
            if time.monotonic() - begin > timeout:
                self.stop()
                raise RuntimeError(f"Home Assistant did not answer within {timeout:g} s: {self.log_tail()}")
            time.sleep(0.05)
        return time.monotonic() - begin

    def answers(self) -> bool:
        """Whether the HTTP API answers (401 without a token is an answer)."""
        try:
            with urllib.request.urlopen(f"{self.url}/api/", timeout=1):
                return True
        except urllib.error.HTTPError:
            return True
        except OSError:
            return False

    def stop(self) -> None:
        """Stop it as a service manager would (SIGTERM, then SIGKILL after 30 s)."""
        proc, self.proc = self.proc, None
        if proc is None or proc.poll() is not None:
            return
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)

    def kill(self) -> None:
        """End it at once, as a crash or a power cut does (SIGKILL): no goodbye on its connections."""
        proc, self.proc = self.proc, None
        if proc is not None and proc.poll() is None:
            proc.kill()
            proc.wait(10)

    def log_tail(self, lines: int = 5) -> str:
        path = self.config / "hass.out"
        text = path.read_text(errors="replace") if path.exists() else ""
        return " | ".join(text.strip().splitlines()[-lines:])

    # -- users and tokens ------------------------------------------------------------------------
    def onboard(self, name: str = "Kim", username: str = "kim", password: str = "kim-password-1") -> str:
        """Make the owner (a person of the household) and return a long-lived token of theirs."""
        code = self.post("/api/onboarding/users", {
            "client_id": CLIENT_ID, "name": name, "username": username,
            "password": password, "language": "en",
        })["auth_code"]  # fmt: skip
        access = self._token_for(code)
        self.owner_token = self.ws(access, "auth/long_lived_access_token", client_name="tests", lifespan=30)
        self.owner_id = self.ws(self.owner_token, "auth/current_user")["id"]
        return self.owner_token

    def add_user(self, name: str, username: str, password: str) -> tuple[str, str]:
        """Another user (not an administrator) and a long-lived token of theirs: (user id, token)."""
        user = self.ws(self.owner_token, "config/auth/create", name=name, group_ids=["system-users"])["user"]
        self.ws(
            self.owner_token,
            "config/auth_provider/homeassistant/create",
            user_id=user["id"],
            username=username,
            password=password,
        )
        flow = self.post(
            "/auth/login_flow",
            {"client_id": CLIENT_ID, "handler": ["homeassistant", None], "redirect_uri": CLIENT_ID},
        )
        done = self.post(
            f"/auth/login_flow/{flow['flow_id']}",
            {"client_id": CLIENT_ID, "username": username, "password": password},
        )
        access = self._token_for(done["result"])
        return user["id"], self.ws(access, "auth/long_lived_access_token", client_name="homecog", lifespan=30)

    def _token_for(self, code: str) -> str:
        body = urllib.parse.urlencode(
            {"grant_type": "authorization_code", "code": code, "client_id": CLIENT_ID}
        ).encode()
        with urllib.request.urlopen(f"{self.url}/auth/token", data=body, timeout=10) as r:
            return json.load(r)["access_token"]

    # -- talking to it ---------------------------------------------------------------------------
    def post(self, path: str, body: dict[str, Any], token: str | None = None) -> Any:
        request = urllib.request.Request(
            f"{self.url}{path}",
            data=json.dumps(body).encode(),
            headers={
                "Content-Type": "application/json",
                **({"Authorization": f"Bearer {token}"} if token else {}),
            },
        )
        with urllib.request.urlopen(request, timeout=10) as r:
            return json.load(r)

    def call(self, token: str, service: str, entity: str, **data: Any) -> Any:
        """A service call over REST as a person's app makes it (``input_boolean.turn_on``)."""
        domain, _, name = service.partition(".")
        return self.post(f"/api/services/{domain}/{name}", {"entity_id": entity, **data}, token)

    def state(self, token: str, entity: str) -> dict[str, Any]:
        request = urllib.request.Request(
            f"{self.url}/api/states/{entity}", headers={"Authorization": f"Bearer {token}"}
        )
        with urllib.request.urlopen(request, timeout=10) as r:
            return json.load(r)

    def ws(self, token: str, command: str, **kwargs: Any) -> Any:
        """One WebSocket command's result."""

        async def run() -> Any:
            async with (
                aiohttp.ClientSession() as session,
                session.ws_connect(f"{self.url}/api/websocket") as ws,
            ):
                await ws.receive_json()  # auth_required
                await ws.send_json({"type": "auth", "access_token": token})
                answer = await ws.receive_json()
                if answer["type"] != "auth_ok":
                    raise RuntimeError(f"Home Assistant refused the token: {answer}")
                await ws.send_json({"id": 1, "type": command, **kwargs})
                while True:
                    message = await ws.receive_json()
                    if message.get("id") == 1 and message["type"] == "result":
                        if not message["success"]:
                            raise RuntimeError(f"{command}: {message['error']}")
                        return message["result"]

        return asyncio.run(run())


class ServiceCalls:
    """Every service call Home Assistant carries out, as its ``call_service`` events tell them,
    recorded on a thread of its own (over a WebSocket of ``token``, an administrator's): each as
    ``(domain.service, entity ids, the user id of the call's context)``.

    ``with ServiceCalls(server, token) as calls: ...``; :meth:`by`: the calls of one user.
    """

    def __init__(self, server: HomeAssistant, token: str) -> None:
        self.server = server
        self.token = token
        self.calls: list[tuple[str, tuple[str, ...], str | None]] = []
        self._lock = threading.Lock()
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._task: asyncio.Task[None] | None = None
        self._thread = threading.Thread(target=self._run, name="ha-service-calls", daemon=True)

    def __enter__(self) -> ServiceCalls:
        self._thread.start()
        if not self._ready.wait(10) or self._error is not None:
            self.close()
            raise RuntimeError(f"could not follow Home Assistant's service calls: {self._error}")
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        loop, task = self._loop, self._task
        if loop is not None and task is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):
                loop.call_soon_threadsafe(task.cancel)
        self._thread.join(10)

    def count(self) -> int:
        """How many calls have been recorded."""
        with self._lock:
            return len(self.calls)

    def by(self, user_id: str, *, since: int = 0) -> list[tuple[str, tuple[str, ...]]]:
        """The calls made as ``user_id`` (of those after the first ``since``), in order:
        ``(domain.service, entity ids)``."""
        with self._lock:
            return [(s, e) for s, e, u in self.calls[since:] if u == user_id]

    def _run(self) -> None:
        with contextlib.suppress(asyncio.CancelledError):
            asyncio.run(self._follow())

    async def _follow(self) -> None:
        self._loop, self._task = asyncio.get_running_loop(), asyncio.current_task()
        try:
            async with (
                aiohttp.ClientSession() as session,
                session.ws_connect(f"{self.server.url}/api/websocket") as ws,
            ):
                await ws.receive_json()  # auth_required
                await ws.send_json({"type": "auth", "access_token": self.token})
                if (answer := await ws.receive_json())["type"] != "auth_ok":
                    raise RuntimeError(f"Home Assistant refused the token: {answer}")
                await ws.send_json({"id": 1, "type": "subscribe_events", "event_type": "call_service"})
                if not (await ws.receive_json()).get("success"):
                    raise RuntimeError("Home Assistant refused the subscription to call_service")
                self._ready.set()
                async for message in ws:
                    event = json.loads(message.data).get("event") or {}
                    data = event.get("data") or {}
                    entities = (data.get("service_data") or {}).get("entity_id") or []
                    entities = [entities] if isinstance(entities, str) else entities
                    call = f"{data.get('domain')}.{data.get('service')}"
                    with self._lock:
                        self.calls.append(
                            (call, tuple(entities), (event.get("context") or {}).get("user_id"))
                        )
        except Exception as e:
            self._error = e
            self._ready.set()


class StateChanges:
    """Home Assistant's ``state_changed`` events, as they reach this process, each with the
    moment it arrived (``time.perf_counter``): over a WebSocket of an administrator's token."""

    def __init__(self, server: HomeAssistant, token: str) -> None:
        self.server, self.token = server, token
        self.events: list[tuple[float, str, dict[str, Any] | None]] = []
        self._lock = threading.Lock()
        self._ready = threading.Event()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._task: asyncio.Task[None] | None = None
        self._thread = threading.Thread(target=lambda: asyncio.run(self._follow()), daemon=True)

    def __enter__(self) -> StateChanges:
        self._thread.start()
        if not self._ready.wait(10):
            raise RuntimeError("could not follow Home Assistant's state changes")
        return self

    def __exit__(self, *exc: object) -> None:
        if self._loop is not None and self._task is not None and not self._loop.is_closed():
            self._loop.call_soon_threadsafe(self._task.cancel)
        self._thread.join(10)

    def of(self, entity: str, since: int = 0) -> list[tuple[float, dict[str, Any] | None]]:
        with self._lock:
            return [(t, s) for t, e, s in self.events[since:] if e == entity]

    def count(self) -> int:
        with self._lock:
            return len(self.events)

    async def _follow(self) -> None:
        self._loop, self._task = asyncio.get_running_loop(), asyncio.current_task()
        try:
            async with (
                aiohttp.ClientSession() as session,
                session.ws_connect(f"{self.server.url}/api/websocket") as ws,
            ):
                await ws.receive_json()
                await ws.send_json({"type": "auth", "access_token": self.token})
                if (answer := await ws.receive_json())["type"] != "auth_ok":
                    raise RuntimeError(f"Home Assistant refused the token: {answer}")
                await ws.send_json({"id": 1, "type": "subscribe_events", "event_type": "state_changed"})
                if not (await ws.receive_json()).get("success"):
                    raise RuntimeError("Home Assistant refused the subscription to state_changed")
                self._ready.set()
                async for message in ws:
                    data = (json.loads(message.data).get("event") or {}).get("data") or {}
                    with self._lock:
                        self.events.append(
                            (time.perf_counter(), data.get("entity_id"), data.get("new_state"))
                        )
        except asyncio.CancelledError:
            pass


def enable_mqtt(server: HomeAssistant, url: str) -> None:
    """Home Assistant's MQTT integration on the broker, set up as a person does in its app."""
    from homecog.context.mqtt_broker import parse_url

    address = parse_url(url)
    flow = server.post("/api/config/config_entries/flow", {"handler": "mqtt"}, server.owner_token)
    if flow.get("step_id") != "broker":
        raise RuntimeError(f"Home Assistant's MQTT integration did not ask for the broker: {flow}")
    done = server.post(
        f"/api/config/config_entries/flow/{flow['flow_id']}",
        {"broker": address.host, "port": address.port},
        server.owner_token,
    )
    if done.get("type") != "create_entry":
        raise RuntimeError(f"Home Assistant's MQTT integration could not be set up: {done}")
