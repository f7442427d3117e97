"""The running system under load: ``homecog up`` in its own process, 20 concurrent clients.

Measures ``POST /api/cognize`` and the page (``GET /``) latency (p50, p95, p99) and throughput,
and how long ``homecog up`` takes to be ready with the Q table and the tree already made.

    .venv/bin/python benchmarks/bench_web.py [--home paper] [--clients 20] [--requests 2000]
"""

from __future__ import annotations

import argparse
import asyncio
import os
import random
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import numpy as np
from rich.console import Console
from rich.table import Table

ROOT = Path(__file__).resolve().parent.parent


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start(home: str, port: int, db: str | None) -> tuple[subprocess.Popen[bytes], float]:
    args = [sys.executable, "-m", "homecog.cli.main", "up", "--home", home, "--port", str(port)]
    if db:
        args += ["--db", db]
    t0 = time.perf_counter()
    proc = subprocess.Popen(args, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    while True:
        try:
            if httpx.get(f"http://127.0.0.1:{port}/api/home", timeout=0.5).status_code == 200:
                return proc, time.perf_counter() - t0
        except httpx.HTTPError:
            pass
        if proc.poll() is not None:
            raise SystemExit(f"homecog up exited with {proc.returncode}")
        time.sleep(0.05)


def contexts(home: dict, n: int, seed: int = 0) -> list[dict[str, str]]:
    """Random valid contexts from the home's values (numbers from /api/context's style)."""
    from homecog.evaluation.scenarios import random_scenarios
    from homecog.home import load_home
    from homecog.knowledge.space import Space

    h = load_home(home["source"])
    space = Space(h)
    return [space.context(s.point) for s in random_scenarios(h, n, seed=seed)]


async def load(url: str, method: str, bodies: list[object], clients: int) -> tuple[np.ndarray, float]:
    latencies: list[float] = []
    queue: asyncio.Queue[object] = asyncio.Queue()
    for b in bodies:
        queue.put_nowait(b)
    limits = httpx.Limits(max_connections=clients, max_keepalive_connections=clients)
    async with httpx.AsyncClient(limits=limits, timeout=10) as client:

        async def worker() -> None:
            while not queue.empty():
                body = queue.get_nowait()
                t = time.perf_counter()
                r = await (client.post(url, json=body) if method == "POST" else client.get(url))
                latencies.append(time.perf_counter() - t)
                assert r.status_code == 200, r.text

        t0 = time.perf_counter()
        await asyncio.gather(*(worker() for _ in range(clients)))
        wall = time.perf_counter() - t0
    return np.array(latencies) * 1000, wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--home", default="paper")
    parser.add_argument("--db", default=None)
    parser.add_argument("--clients", type=int, default=20)
    parser.add_argument("--requests", type=int, default=2000)
    args = parser.parse_args()
    os.environ.setdefault("PYTHONWARNINGS", "ignore")
    port = free_port()
    proc, ready = start(args.home, port, args.db)  # the first start makes what is missing
    proc.terminate()
    proc.wait()
    proc, ready = start(args.home, port, args.db)  # the figure: a start with everything made
    try:
        base = f"http://127.0.0.1:{port}"
        home = httpx.get(f"{base}/api/home").json()
        home["source"] = args.home
        users = ["ann", "kim"]
        bodies = [{"context": c, "user": random.choice(users)} for c in contexts(home, args.requests)]
        asyncio.run(load(f"{base}/api/cognize", "POST", bodies[:100], args.clients))  # warm up
        cog, cog_wall = asyncio.run(load(f"{base}/api/cognize", "POST", bodies, args.clients))
        page, page_wall = asyncio.run(load(f"{base}/", "GET", [None] * 500, args.clients))
    finally:
        proc.terminate()
        proc.wait()
    table = Table(title=f"homecog up on {args.home}: {args.clients} concurrent clients", title_justify="left")
    for col in ("", "requests", "p50 ms", "p95 ms", "p99 ms", "per second"):
        table.add_column(col, justify="right" if col else "left")
    for name, lat, wall in (("POST /api/cognize", cog, cog_wall), ("GET / (the page)", page, page_wall)):
        p50, p95, p99 = np.percentile(lat, [50, 95, 99])
        rate = f"{len(lat) / wall:,.0f}"
        table.add_row(name, f"{len(lat):,}", f"{p50:.2f}", f"{p95:.2f}", f"{p99:.2f}", rate)
    Console().print(table)
    Console().print(f"homecog up ready (Q table and tree already made): {ready:.2f} s")


if __name__ == "__main__":
    main()
