"""A fleet of homes: homes learned per minute, serially and on a local Ray with 2
workers; and cognition under 20 concurrent clients spread over 100 homes and 2 ``homecog
serve`` processes sharing one database.

Learning: ``--homes`` generated homes of ``--rooms`` rooms (benchmarks/homes.py), each trained,
sampled, built and stored as ``homecog fleet train`` does, serial and Ray runs alternating
``--rounds`` times (the best of each shown), into PostgreSQL when one answers
at ``$HOMECOG_TEST_POSTGRES_URL`` (default postgresql+psycopg://postgres@127.0.0.1:5432/test),
else SQLite. Both runs are warm: the serial one after a first home has compiled the kernels,
Ray's after it started and each worker learned a home (Ray's start is shown apart); the
figure is the steady throughput a fleet sees.

Serving: 100 one-room homes learned into the same database, two ``homecog serve`` processes,
and ``--clients`` clients (asyncio, keep-alive HTTP/1.1, half on each server), each asking
``POST /api/homes/{home}/cognize`` of a random home with a random valid context: saturated
(the next request as soon as the answer comes) and paced (``--pause`` ms after each answer).
Every request reads the home's version in the database first (the staleness check).

    .venv/bin/python benchmarks/bench_fleet.py [--homes 24] [--rooms 3] [--clients 20]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import secrets
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from pathlib import Path

from rich.console import Console
from rich.table import Table

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
from homes import home_text  # noqa: E402

PG = os.environ.get("HOMECOG_TEST_POSTGRES_URL", "postgresql+psycopg://postgres@127.0.0.1:5432/test")


# -- a database -------------------------------------------------------------------------------------
def database(tmp: Path) -> tuple[str, object]:
    """A fresh PostgreSQL database when the server answers (and a function dropping it), else a
    SQLite file."""
    from sqlalchemy import create_engine, text
    from sqlalchemy.engine import make_url

    admin = make_url(PG)
    name = "homecog_bench_" + secrets.token_hex(4)
    try:
        engine = create_engine(admin, isolation_level="AUTOCOMMIT", connect_args={"connect_timeout": 3})
        with engine.connect() as conn:
            conn.execute(text(f"CREATE DATABASE {name}"))
    except Exception as e:
        print(f"(PostgreSQL not usable, SQLite instead: {str(e).splitlines()[0]})", file=sys.stderr)
        return f"sqlite:///{tmp / 'fleet.sqlite'}", lambda: None

    def drop() -> None:
        with engine.connect() as conn:
            conn.execute(text(f"DROP DATABASE IF EXISTS {name} WITH (FORCE)"))
        engine.dispose()

    return admin.set(database=name).render_as_string(hide_password=False), drop


def write_homes(folder: Path, n: int, rooms: int, prefix: str) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for i in range(n):
        path = folder / f"{prefix}{i:03d}.yaml"
        path.write_text(home_text(rooms, name=f"{prefix}{i:03d}"))
        paths.append(path)
    return paths


# -- learning -------------------------------------------------------------------------------------
def learning(tmp: Path, url: str, homes: int, rooms: int, rounds: int) -> dict[str, float]:
    """Homes per minute, serially and on Ray, the best of ``rounds`` alternating runs (on a
    shared machine the others' load comes and goes), each run on homes of its own."""
    from homecog.fleet.train import import_ray, plan, run_ray, run_serial

    warm = write_homes(tmp / "warm", 3, rooms, "warm")
    plan(warm, url)  # migrates
    list(run_serial(warm[:1], url))  # compiles the kernels in this process
    ray = import_ray()
    t0 = time.perf_counter()
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level="ERROR")
    figures: dict[str, float] = {"ray_start": time.perf_counter() - t0, "serial": 0.0, "ray": 0.0}
    try:
        list(run_ray(warm[1:], url, address=None, workers=2))  # each worker imports and compiles
        for r in range(rounds):
            for mode in ("serial", "ray"):
                paths = write_homes(tmp / f"{mode}{r}", homes, rooms, f"{mode}{r}_")
                t0 = time.perf_counter()
                if mode == "serial":
                    done = list(run_serial(paths, url))
                else:
                    done = list(run_ray(paths, url, address=None, workers=2))
                rate = 60 * sum(d.status == "learned" for d in done) / (time.perf_counter() - t0)
                figures[mode] = max(figures[mode], rate)
    finally:
        ray.shutdown()
    return figures


# -- serving --------------------------------------------------------------------------------------
def serve(url: str, port: int, log: Path) -> subprocess.Popen[bytes]:
    command = [sys.executable, "-m", "homecog.cli.main", "serve", "--db", url, "--port", str(port)]
    proc = subprocess.Popen(command, cwd=ROOT, stdout=log.open("wb"), stderr=subprocess.STDOUT)
    deadline = time.monotonic() + 60
    while True:
        try:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/api/homes", timeout=2).close()
            return proc
        except (urllib.error.URLError, OSError):
            if proc.poll() is not None or time.monotonic() > deadline:
                raise SystemExit(f"homecog serve did not start: {log.read_text()[-2000:]}") from None
            time.sleep(0.1)


def requests_for(names: list[str], per_home: int = 20) -> list[bytes]:
    """Raw HTTP requests of cognition, ``per_home`` random contexts for each home."""
    from homecog.evaluation.scenarios import random_scenarios
    from homecog.home import load_home_text
    from homecog.home.codec import Space
    from homecog.web.models import json_context

    home = load_home_text(home_text(1, name="x"))  # every served home has this one's features
    space = Space(home)
    contexts = [json_context(home, space.context(s.point)) for s in random_scenarios(home, 500, seed=0)]
    rng = random.Random(0)
    out = []
    for name in names:
        for _ in range(per_home):
            body = json.dumps({"context": rng.choice(contexts), "user": rng.choice(["ann", "kim"])}).encode()
            head = (
                f"POST /api/homes/{name}/cognize HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                f"Content-Type: application/json\r\nContent-Length: {len(body)}\r\n\r\n"
            )
            out.append(head.encode() + body)
    rng.shuffle(out)
    return out


def _quantiles(latencies: list[float]) -> tuple[float, float, float]:
    """p50, p95, p99 in ms."""
    q = statistics.quantiles(sorted(latencies), n=100)
    return q[49] * 1000, q[94] * 1000, q[98] * 1000


async def client(
    port: int, requests: list[bytes], until: float, pause: float, out: list[float], *, once: bool = False
) -> None:
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    rng = random.Random(port + len(out))
    try:
        while once or time.perf_counter() < until:
            request = rng.choice(requests)
            t0 = time.perf_counter()
            writer.write(request)
            head = await reader.readuntil(b"\r\n\r\n")
            if not head.startswith(b"HTTP/1.1 200"):
                raise SystemExit(f"an error answer: {head[:200]!r}")
            length = int(head.lower().split(b"content-length:")[1].split(b"\r\n")[0])
            await reader.readexactly(length)
            out.append(time.perf_counter() - t0)
            if once:
                return
            if pause:
                await asyncio.sleep(pause)
    finally:
        writer.close()


async def load(
    ports: list[int], requests: list[bytes], clients: int, seconds: float, pause: float
) -> list[float]:
    latencies: list[float] = []
    until = time.perf_counter() + seconds
    await asyncio.gather(
        *(client(ports[i % len(ports)], requests, until, pause, latencies) for i in range(clients))
    )
    return latencies


def serving(tmp: Path, url: str, homes: int, clients: int, seconds: float, pause: float) -> list[tuple]:
    from homecog.fleet.train import plan, run_serial

    paths = write_homes(tmp / "served", homes, 1, "served")
    todo, _ = plan(paths, url)
    list(run_serial(todo, url))
    ports = [_free_port(), _free_port()]
    procs = [serve(url, p, tmp / f"serve-{p}.log") for p in ports]
    try:
        names = [p.stem for p in paths]
        requests = requests_for(names)
        first = {}  # every home into both caches: the first request of a home loads its tree
        for port in ports:
            for request in requests:
                name = request.split(b"/")[3].decode()
                if (port, name) not in first:
                    lat: list[float] = []
                    asyncio.run(client(port, [request], 0.0, 0.0, lat, once=True))
                    first[(port, name)] = lat[0]
        asyncio.run(load(ports, requests, clients, 3.0, 0))  # warm
        rows = [("first request of a home (loads it)", len(first), *_quantiles(list(first.values())), 0.0)]
        for name, wait in (("saturated", 0.0), (f"paced, {pause * 1000:.0f} ms pause", pause)):
            lat = asyncio.run(load(ports, requests, clients, seconds, wait))
            rows.append((name, len(lat), *_quantiles(lat), len(lat) / seconds))
        return rows
    finally:
        for proc in procs:
            proc.terminate()
            proc.wait()


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def learning_table(console: Console, figures: dict[str, float], args: argparse.Namespace, kind: str) -> None:
    table = Table(
        title=f"homecog fleet train: {args.homes} homes of {args.rooms} rooms ({6 * args.rooms} devices) "
        f"into {kind}, {os.cpu_count()} cores, the best of {args.rounds} alternating runs",
        title_justify="left",
    )
    for col in ("", "homes per minute", "× serial"):
        table.add_column(col, justify="left" if not col else "right")
    ratio = figures["ray"] / figures["serial"]
    table.add_row("serial, one process", f"{figures['serial']:.0f}", "1.00")
    table.add_row("Ray, local, 2 workers", f"{figures['ray']:.0f}", f"{ratio:.2f}")
    console.print(table)
    console.print(f"(a local Ray took {figures['ray_start']:.1f} s to start, not counted above)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--homes", type=int, default=24, help="homes learned in each mode")
    parser.add_argument("--rounds", type=int, default=2, help="alternating runs of each; the best is shown")
    parser.add_argument("--skip-learning", action="store_true", help="only the serving part")
    parser.add_argument("--rooms", type=int, default=3, help="rooms (6 devices each) of the learned homes")
    parser.add_argument("--served", type=int, default=100, help="homes served")
    parser.add_argument("--clients", type=int, default=20)
    parser.add_argument("--seconds", type=float, default=10)
    parser.add_argument("--pause", type=float, default=10, help="ms each paced client waits")
    args = parser.parse_args()
    console = Console()
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        url, drop = database(tmp)
        kind = url.split(":")[0].split("+")[0]
        try:
            figures = {} if args.skip_learning else learning(tmp, url, args.homes, args.rooms, args.rounds)
            rows = serving(tmp, url, args.served, args.clients, args.seconds, args.pause / 1000)
        finally:
            drop()  # type: ignore[operator]
    if figures:
        learning_table(console, figures, args, kind)
    table = Table(
        title=f"homecog serve: POST /api/homes/{{home}}/cognize, {args.clients} clients over "
        f"{args.served} homes and 2 servers on {kind}, {args.seconds:.0f} s",
        title_justify="left",
    )
    for col in ("load", "requests", "p50 ms", "p95 ms", "p99 ms", "per second"):
        table.add_column(col, justify="left" if col == "load" else "right")
    for name, n, p50, p95, p99, rate in rows:
        table.add_row(
            name, f"{n:,}", f"{p50:.2f}", f"{p95:.2f}", f"{p99:.2f}", f"{rate:,.0f}" if rate else ""
        )
    console.print(table)


if __name__ == "__main__":
    main()
