"""The web tests' servers: ``homecog up`` in a process of its own, or an app on uvicorn in a thread,
and the studio home with a floor plan, built once into a SQLite file that tests copy."""

from __future__ import annotations

import os
import socket
import sqlite3
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

HOMES = Path(__file__).parent / "homes"
LAYOUT = """
layout:
  size: [6, 4]
  rooms: {studio: [0, 0, 4, 4], bath: [4, 0, 6, 4]}
  walls: [[4, 0, 4, 4]]
  doors: [[4, 1, 4, 2]]
  places: {desk: [1, 1], couch: [3, 3], kettle: [5, 3]}
  objects: {tea: kettle}
"""
STUDIO_WITH_LAYOUT = (HOMES / "studio.yaml").read_text() + LAYOUT


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def build_studio(directory: Path) -> tuple[Path, Path]:
    """The studio home with a floor plan written to ``directory`` and its knowledge built into a
    SQLite file there: (home file, database file). About ten seconds."""
    from homecog.home import load_home
    from homecog.knowledge.pipeline import build
    from homecog.knowledge.store import Store

    home_path = directory / "studio.yaml"
    home_path.write_text(STUDIO_WITH_LAYOUT)
    db = directory / "knowledge.sqlite"
    store = Store.open(f"sqlite:///{db}", load_home(home_path))
    try:
        build(store.home, store)
    finally:
        store.close()
    return home_path, db


def copy_database(source: Path, target: Path) -> str:
    """A copy of a SQLite database (its log included), as a URL."""
    target.parent.mkdir(parents=True, exist_ok=True)
    with sqlite3.connect(source) as src, sqlite3.connect(target) as dst:
        src.backup(dst)
    return f"sqlite:///{target}"


def get(url: str, token: str | None = None, timeout: float = 5) -> Any:
    """GET and decode JSON (raises ``urllib.error.HTTPError`` for an error status)."""
    import json

    request = urllib.request.Request(url, headers={"Authorization": f"Bearer {token}"} if token else {})
    with urllib.request.urlopen(request, timeout=timeout) as r:
        return json.load(r)


def send(url: str, body: object, token: str | None = None, method: str = "POST") -> tuple[int, Any]:
    """Send JSON; the status and the decoded answer, whatever the status."""
    import json

    headers = {"Content-Type": "application/json", **({"Authorization": f"Bearer {token}"} if token else {})}
    request = urllib.request.Request(url, data=json.dumps(body).encode(), headers=headers, method=method)
    try:
        with urllib.request.urlopen(request, timeout=30) as r:
            return r.status, json.load(r)
    except urllib.error.HTTPError as e:
        return e.code, json.load(e)


@contextmanager
def homecog_up(
    home: Path, db: str, data: Path, *args: str, host: str = "127.0.0.1"
) -> Iterator[tuple[str, subprocess.Popen[bytes]]]:
    """``homecog up --speed 0`` on a free port until the block ends: (base URL, process); what it
    prints goes to ``data/up-<port>.log``."""
    port = free_port()
    command = [sys.executable, "-m", "homecog.cli.main", "up", "--home", str(home), "--db", db]
    command += ["--host", host, "--port", str(port), "--speed", "0", *args]
    env = {**os.environ, "HOMECOG_DATA": str(data)}
    data.mkdir(parents=True, exist_ok=True)
    log = (data / f"up-{port}.log").open("wb")  # a file, not a pipe nobody reads while it serves
    proc = subprocess.Popen(command, env=env, stdout=log, stderr=subprocess.STDOUT)
    base = f"http://{host}:{port}"
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                urllib.request.urlopen(f"{base}/openapi.json", timeout=2).close()
                break
            except (urllib.error.URLError, OSError):
                if proc.poll() is not None:
                    out = (data / f"up-{port}.log").read_text()
                    raise AssertionError(f"homecog up exited: {out}") from None
                assert time.monotonic() < deadline, "homecog up did not answer within 60 s"
                time.sleep(0.1)
        yield base, proc
    finally:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        log.close()


@contextmanager
def serve(app: Any, settings: Any = None) -> Iterator[str]:
    """An ASGI app on uvicorn in a thread, on a free port of 127.0.0.1: its base URL. With
    ``settings``, served as ``homecog up`` serves it (:mod:`homecog.web.serving`)."""
    import uvicorn

    port = free_port()
    if settings is not None:
        from homecog.web.serving import guarded, options

        config = uvicorn.Config(guarded(app, settings), **options(settings, host="127.0.0.1", port=port))
    else:
        config = uvicorn.Config(
            app, host="127.0.0.1", port=port, log_level="warning", timeout_graceful_shutdown=1
        )
    server = uvicorn.Server(config)
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 20
    while not server.started:
        assert time.monotonic() < deadline, "the server did not start"
        time.sleep(0.05)
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        thread.join(timeout=10)
