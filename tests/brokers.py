"""An MQTT broker for the tests: a real Mosquitto.

:func:`mqtt_broker` gives the URL of the broker at ``$HOMECOG_TEST_MQTT_URL`` or 127.0.0.1:1883
(``.ci/servers.sh`` starts one on CI); when nothing answers there and ``mosquitto`` is installed,
it starts one, and stops it at the end; otherwise the calling tests skip, saying why.
:func:`start_mosquitto` starts a broker of a test's own, on a port of its choosing.
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from homecog.context.mqtt_broker import parse_url

START_TIMEOUT = 10.0  # seconds for a started mosquitto to answer


def port_open(host: str, port: int) -> bool:
    """Whether something accepts connections at ``host:port``."""
    try:
        with socket.create_connection((host, port), timeout=1):
            return True
    except OSError:
        return False


def mosquitto() -> str | None:
    """The ``mosquitto`` program, or None where it is not installed."""
    return shutil.which("mosquitto") or next(
        (p for p in ("/usr/sbin/mosquitto", "/usr/local/sbin/mosquitto") if Path(p).exists()), None
    )


def start_mosquitto(port: int, tmp: Path, timeout: float = START_TIMEOUT) -> subprocess.Popen[bytes]:
    """A mosquitto on 127.0.0.1:``port`` (its configuration in ``tmp``), once it answers."""
    binary = mosquitto()
    assert binary is not None
    conf = tmp / f"mosquitto-{port}.conf"
    conf.write_text(f"listener {port} 127.0.0.1\nallow_anonymous true\npersistence false\n")
    proc = subprocess.Popen([binary, "-c", str(conf)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + timeout
    while not port_open("127.0.0.1", port):
        if proc.poll() is not None:
            raise AssertionError(f"mosquitto on port {port} exited with {proc.returncode}")
        if time.monotonic() > deadline:
            proc.kill()
            proc.wait(10)
            raise AssertionError(f"timed out after {timeout:g} s waiting for mosquitto on port {port}")
        time.sleep(0.02)
    return proc


@contextmanager
def mqtt_broker(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """The URL of a running broker: the one configured, or one started for the while; skips
    (printing why) where there is none and none can be started."""
    url = os.environ.get("HOMECOG_TEST_MQTT_URL", "mqtt://127.0.0.1:1883")
    address = parse_url(url)
    if port_open(address.host, address.port):
        yield url
        return
    if address.host != "127.0.0.1" or mosquitto() is None:
        reason = f"no MQTT broker at {url} and no mosquitto binary to start one"
        print(reason)
        pytest.skip(reason)
    proc = start_mosquitto(address.port, tmp_path_factory.mktemp("mosquitto"))
    try:
        yield url
    finally:
        proc.terminate()
        proc.wait(10)
