"""The running system under load: ``homecog up`` in its own process, 20 concurrent clients.

The load tool is wrk (Debian's and Ubuntu's package ``wrk``, Homebrew's ``wrk``), one thread
holding one connection per client. Saturated: each client sends its next request as soon as
the answer arrives, so the latencies include the wait behind the other clients' requests.
Paced: each client waits ``--pause`` ms after each answer, a busy but not saturated server.
The cognition requests cycle through 2,000 random valid contexts of the home, for two users.
On Linux with two or more cores, the server runs on core 0 and wrk on core 1 (taskset), so
that neither steals the other's core. Measured: ``POST /api/cognize`` and the page
(``GET /``), latency p50/p95/p99 and throughput, and how long ``homecog up`` takes to be
ready when the Q table and the tree already exist.

    .venv/bin/python benchmarks/bench_web.py [--home paper] [--clients 20] [--seconds 10]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import socket
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
PIN = (
    (["taskset", "-c", "0"], ["taskset", "-c", "1"])
    if shutil.which("taskset") and (os.cpu_count() or 1) >= 2
    else ([], [])
)

# wrk's Lua: send the bodies in turn; at the end print one JSON line of figures (microseconds)
LUA = """
local bodies = {%s}
local i = 0
delay = function() return %d end
request = function()
  i = i + 1
  if #bodies == 0 then return wrk.format("GET") end
  return wrk.format("POST", nil, {["Content-Type"] = "application/json"}, bodies[i %% #bodies + 1])
end
done = function(summary, latency, requests)
  local e = summary.errors
  io.write(string.format(
    '\\n{"requests": %%d, "seconds": %%f, "p50": %%d, "p95": %%d, "p99": %%d, "errors": %%d}\\n',
    summary.requests, summary.duration / 1e6, latency:percentile(50), latency:percentile(95),
    latency:percentile(99), e.connect + e.read + e.write + e.status + e.timeout))
end
"""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def get(url: str) -> bytes:
    with urllib.request.urlopen(url, timeout=2) as r:
        return r.read()


def start(home: str, port: int, db: str | None) -> tuple[subprocess.Popen[bytes], float]:
    """``homecog up`` in a process of its own; returns it and the seconds until it answered."""
    args = [sys.executable, "-m", "homecog.cli.main", "up", "--home", home, "--port", str(port)]
    args = [*PIN[0], *args]
    if db:
        args += ["--db", db]
    t0 = time.perf_counter()
    proc = subprocess.Popen(args, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    while True:
        try:
            get(f"http://127.0.0.1:{port}/api/home")
            return proc, time.perf_counter() - t0
        except (urllib.error.URLError, OSError):
            pass
        if proc.poll() is not None:
            raise SystemExit(f"homecog up exited with {proc.returncode}")
        time.sleep(0.05)


def contexts(home: str, n: int, seed: int = 0) -> list[dict[str, str | float]]:
    """``n`` random valid contexts of the home, as a client would send them (numbers as numbers)."""
    from homecog.evaluation.scenarios import random_scenarios
    from homecog.home import load_home
    from homecog.home.codec import Space, json_context

    h = load_home(home)
    space = Space(h)
    return [json_context(h, space.context(s.point)) for s in random_scenarios(h, n, seed=seed)]


def wrk(url: str, bodies: list[str], clients: int, seconds: int, pause: int = 0) -> dict[str, float]:
    """One wrk run, each client waiting ``pause`` ms after each answer."""
    script = LUA % (", ".join(f"[==[{b}]==]" for b in bodies), pause)
    with tempfile.NamedTemporaryFile("w", suffix=".lua", delete=False) as f:
        f.write(script)
    try:
        out = subprocess.run(
            [*PIN[1], "wrk", "-t1", f"-c{clients}", f"-d{seconds}s", "-s", f.name, url],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
    finally:
        os.unlink(f.name)
    figures = json.loads(out.strip().splitlines()[-1])
    if figures["errors"]:
        raise SystemExit(f"{figures['errors']} requests to {url} failed")
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--home", default="paper")
    parser.add_argument("--db", default=None)
    parser.add_argument("--clients", type=int, default=20)
    parser.add_argument("--seconds", type=int, default=10)
    parser.add_argument("--pause", type=int, default=10, help="ms each paced client waits")
    parser.add_argument("--runs", type=int, default=3, help="runs of each; the median run is shown")
    args = parser.parse_args()
    if shutil.which("wrk") is None:
        raise SystemExit("bench_web needs the load tool wrk: apt-get install wrk (or brew install wrk)")
    port = free_port()
    proc, _ = start(args.home, port, args.db)  # the first start makes what is missing
    proc.terminate()
    proc.wait()
    proc, ready = start(args.home, port, args.db)  # the figure: a start with everything made
    try:
        base = f"http://127.0.0.1:{port}"
        bodies = [
            json.dumps({"context": c, "user": ("ann", "kim")[i % 2]}, separators=(",", ":"))
            for i, c in enumerate(contexts(args.home, 2000))
        ]
        wrk(f"{base}/api/cognize", bodies, args.clients, 2)  # warm up
        rows = []
        paced = f"paced, {args.pause} ms pause"
        for name, load, url, pause in (
            ("POST /api/cognize", "saturated", f"{base}/api/cognize", 0),
            ("POST /api/cognize", paced, f"{base}/api/cognize", args.pause),
            ("GET / (the page)", "saturated", f"{base}/", 0),
            ("GET / (the page)", paced, f"{base}/", args.pause),
        ):
            sent = bodies if "cognize" in url else []
            runs = sorted(
                (wrk(url, sent, args.clients, args.seconds, pause) for _ in range(args.runs)),
                key=lambda r: r["p95"],
            )
            rows.append((name, load, runs[len(runs) // 2]))
    finally:
        proc.terminate()
        proc.wait()
    pinned = ", server and wrk on cores of their own" if PIN[0] else ""
    title = (
        f"homecog up on {args.home}: wrk, {args.clients} concurrent clients{pinned}, "
        f"the median of {args.runs} runs of {args.seconds} s"
    )
    table = Table(title=title, title_justify="left")
    for col in ("", "load", "requests", "p50 ms", "p95 ms", "p99 ms", "per second"):
        table.add_column(col, justify="right" if col not in ("", "load") else "left")
    for name, load, r in rows:
        table.add_row(
            name,
            load,
            f"{r['requests']:,}",
            *(f"{r[p] / 1000:.2f}" for p in ("p50", "p95", "p99")),
            f"{r['requests'] / r['seconds']:,.0f}",
        )
    Console().print(table)
    Console().print(f"homecog up ready (Q table and tree already made): {ready:.2f} s")


if __name__ == "__main__":
    main()
