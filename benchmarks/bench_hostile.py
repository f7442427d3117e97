"""Hostile input (docs/design.md, "Hostile input"): a legitimate client's cognition alone and
beside ten hostile clients, and what each hostile input costs.

The server is ``homecog serve`` on a database of two learned homes (SQLite by default, or
``--db URL``), without a token on 127.0.0.1, in a process of its own; every client is a process
of its own too. On Linux with two or more cores the server runs on core 0, and the clients (as
machines of their own would) and the server's planner (niced, in a process of its own) on
core 1 (taskset). The legitimate client asks
``POST /api/homes/home0/cognize`` with random valid contexts, 50 a second, and records each
latency: alone; beside ten hostile clients of 20 requests a second each ("paced"); and, for
scale, flooding (every client sends its next request as soon as the answer comes) beside ten
hostile clients and beside ten ordinary ones asking for cognition. The hostile clients:

- three that spell the home otherwise (``HOME0``, ``home0%20``, ``%00``, ``home0%2e``) on the
  schema and on cognition, each request a 404 that used to reload the home;
- three that open connections and send half a request, twenty at a time, each closed by the
  server after its request deadline (5 s) with 408;
- three that ask for plans: 500 services (refused, 422) and the most a plan may have, 32
  (carried out, or 429 while the planner is busy);
- one that sends JSON nested 1,000 deep (422).

Then a household's heavy use and bodies made to cost, ten clients of each kind at the paced
rate in turn, then the three kinds mixed: the history's biggest page (1,000 corrections),
corrections of fifty users (each stored and learned), and 64 KiB of brackets sent as a
correction (422).

Then the command line against hostile files: each run of ``homecog`` timed, with its peak memory.

    .venv/bin/python benchmarks/bench_hostile.py [--seconds 15] [--db URL]
"""

from __future__ import annotations

import argparse
import http.client
import json
import os
import random
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rich.console import Console
from rich.table import Table

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
from homes import home_text  # noqa: E402

# the server on core 0; the clients, as machines of their own would be, and the planner on core 1
PIN = (
    (["taskset", "-c", "0"], ["taskset", "-c", "1"])
    if shutil.which("taskset") and (os.cpu_count() or 1) >= 2
    else ([], [])
)
CONTEXT = "time=10:00,light=50,activity=work,blind=off,desk_lamp=off,radio=off"
BAD_NAMES = ("HOME0", "Home0", "home0%20", "%00", "home0%2e", "home0%09")
HOSTILE = (("names", 3), ("slow", 3), ("plans", 3), ("deep", 1))
#: the clients of a household's heavy use and of bodies made to cost: ten of each kind in turn,
#: then all of them mixed
HEAVY = ("history", "corrects", "bigdeep")
DEEP = {"deep": ("[" * 1000 + "]" * 1000).encode(), "bigdeep": ("[" * 32768 + "]" * 32768).encode()}


# -- the clients (each run as `bench_hostile.py --client KIND PORT SECONDS`) ---------------------
def _context(rng: random.Random, devices: list[str]) -> dict[str, object]:
    return {
        "time": f"{rng.randrange(24)}:{rng.choice(['00', '30'])}",
        "temperature": rng.choice([18, 22, 27, 33]),
        "illumination": rng.choice([50, 300, 800]),
        "location": "room1",
        "posture": rng.choice(["sit", "lie", "walk"]),
        "behavior": rng.choice(["read", "watch_tv", "sleep", "eat"]),
    } | {d: rng.choice(["on", "off"]) for d in devices}


def _ask(
    conn: http.client.HTTPConnection, method: str, path: str, body: bytes | None = None
) -> tuple[int, float]:
    start = time.perf_counter()
    conn.request(method, path, body=body, headers={"Content-Type": "application/json"} if body else {})
    answer = conn.getresponse()
    answer.read()
    return answer.status, time.perf_counter() - start


def _request(
    kind: str, rng: random.Random, devices: list[str], services: list[str]
) -> tuple[str, str, bytes | None]:
    """A client's next request of its kind: method, path and body."""
    if kind in ("legit", "ordinary"):
        method, path, body = "POST", "/api/homes/home0/cognize", {"context": _context(rng, devices)}
    elif kind == "names":
        name, rest = rng.choice(BAD_NAMES), rng.choice(["openapi.json", "cognize"])
        method, path, body = ("GET", f"/api/homes/{name}/{rest}", None)
        if rest == "cognize":
            method, body = "POST", {"context": _context(rng, devices)}
    elif kind == "history":
        method, path, body = "GET", "/api/homes/home0/history?limit=1000", None
    elif kind == "corrects":
        want = rng.sample(services, rng.randint(0, 2))
        body = {"context": _context(rng, devices), "want": want, "user": f"u{rng.randrange(50)}"}
        method, path = "POST", "/api/homes/home0/corrections"
    elif kind == "plans":
        n = rng.choice([500, 32])
        method, path, body = "POST", "/api/homes/home0/plan", {"services": (services * 125)[:n]}
    elif kind == "bigdeep":  # 64 KiB of brackets, to the corrections
        method, path, body = "POST", "/api/homes/home0/corrections", None
    else:  # deep
        method, path, body = "POST", "/api/homes/home0/cognize", None
    data = DEEP.get(kind) or (json.dumps(body).encode() if body else None)
    return method, path, data


def client(kind: str, port: int, seconds: float, rate: float) -> dict[str, object]:
    """Run one client for ``seconds``, ``rate`` requests a second at most (0: as fast as it
    can): its answers' statuses and latencies."""
    rng = random.Random(kind)
    end = time.monotonic() + seconds
    statuses: dict[int, int] = {}
    latencies: list[float] = []
    devices = [f"{d}_room1" for d in ("light", "lamp", "curtain", "window", "ac", "tv")]
    services = ["TurnOnLight_room1", "TurnOffLight_room1", "OpenCurtain_room1", "SendDrinks"]
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    while time.monotonic() < end:
        if kind == "slow":
            status, took = _half_sent(port)
        else:
            method, path, data = _request(kind, rng, devices, services)
            try:
                status, took = _ask(conn, method, path, data)
            except (OSError, http.client.HTTPException):
                conn.close()
                conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
                status, took = -1, 0.0
        statuses[status] = statuses.get(status, 0) + 1
        latencies.append(took)
        if rate and kind != "slow":
            time.sleep(max(0.0, 1 / rate - took))
    return {"kind": kind, "statuses": statuses, "latencies": latencies}


def _half_sent(port: int, at_once: int = 20) -> tuple[int, float]:
    """Twenty connections sending half a request each; the status the first one got and the
    seconds until the server closed the last."""
    start = time.perf_counter()
    socks = []
    for _ in range(at_once):
        s = socket.create_connection(("127.0.0.1", port), timeout=30)
        head = f"POST /api/homes/home0/cognize HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Length: 99\r\n"
        s.sendall(head.encode() + b"\r\n{")
        socks.append(s)
    answers = []
    for s in socks:
        out = b""
        try:
            while chunk := s.recv(4096):
                out += chunk
        except OSError:
            pass
        s.close()
        answers.append(int(out.split(b" ", 2)[1]) if out.startswith(b"HTTP/1.1 ") else -1)
    return answers[0], time.perf_counter() - start


# -- the server ------------------------------------------------------------------------------------
def learn(folder: Path, url: str) -> None:
    for i in range(2):
        (folder / f"home{i}.yaml").write_text(home_text(1, name=f"home{i}"))
    subprocess.run(
        [sys.executable, "-m", "homecog.cli.main", "fleet", "train", str(folder), "--db", url, "--serial"],
        check=True,
        cwd=ROOT,
        capture_output=True,
    )


def serve(url: str, port: int) -> subprocess.Popen[bytes]:
    args = [*PIN[0], sys.executable, "-m", "homecog.cli.main", "serve", "--db", url, "--port", str(port)]
    proc = subprocess.Popen(args, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    for _ in range(600):
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=1):
                break
        except OSError:
            time.sleep(0.1)
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    _ask(conn, "GET", "/api/homes/home0/home")  # loaded before the measures
    _ask(conn, "POST", "/api/homes/home0/plan", b'{"services": ["SendDrinks"]}')  # the planner started
    if PIN[0]:  # the planner on the other core: on a machine of two, the server's core is its own
        for child in _children(proc.pid):
            for pid in [child, *_children(child)]:
                os.sched_setaffinity(pid, {1})
    return proc


def peak_mb(pid: int) -> float:
    """A process's peak resident memory and its children's (the planner), MB."""
    total = 0.0
    for p in [pid, *_children(pid)]:
        try:
            status = Path(f"/proc/{p}/status").read_text()
        except OSError:
            continue
        total += next(int(line.split()[1]) for line in status.splitlines() if line.startswith("VmHWM")) / 1024
    return total


def _children(pid: int) -> list[int]:
    try:
        return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        return []


def run_clients(kinds: list[tuple[str, float]], port: int, seconds: float) -> list[dict[str, object]]:
    """Clients of these kinds and rates, each a process, at once: what each saw."""
    procs = [
        subprocess.Popen(
            [*PIN[1], sys.executable, __file__, "--client", kind, str(port), str(seconds), str(rate)],
            stdout=subprocess.PIPE,
            cwd=ROOT,
        )
        for kind, rate in kinds
    ]
    return [json.loads(p.communicate(timeout=seconds + 120)[0]) for p in procs]


def percentile(values: list[float], q: float) -> float:
    return statistics.quantiles(values, n=100)[q - 1] if len(values) > 1 else values[0]


# -- the command line against hostile files --------------------------------------------------------
def file_cases(folder: Path) -> list[tuple[str, list[str]]]:
    studio = (ROOT / "tests" / "homes" / "studio.yaml").read_text()
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, 10)]
    (folder / "bomb.yaml").write_text(
        studio.replace("unit: lx", "unit: *a9").replace("context:", "\n".join(lines) + "\ncontext:", 1)
    )
    (folder / "nested.yaml").write_text("[" * 100_000)
    (folder / "big.yaml").write_text("#" * (4 << 20))
    (folder / "escape.yaml").write_text(studio.replace("name: studio", 'name: "../../x"'))
    (folder / "nul.csv").write_text(
        "timestamp,time,light,activity,blind,desk_lamp,radio,services,user\n"
        + "2024-03-01T08:00,10:00,50,work,off,off,off,,a\x00b\n"
    )
    devices = ", ".join(f"d{i}: {{}}" for i in range(10_000))
    (folder / "many.yaml").write_text(
        f"name: many\ncontext: {{m: {{kind: categorical, values: [a, b]}}}}\ndevices: {{{devices}}}\n"
        "services: {S: {category: c, set: {d0: on}}}\ncomfort: {d0: [{want: on}]}\n"
    )
    os.mkfifo(folder / "fifo.yaml")
    _big_events(folder / "big.csv", 200_000_000)
    home = str(ROOT / "tests" / "homes" / "studio.yaml")
    return [
        ("alias bomb, 9 levels", ["home", "check", str(folder / "bomb.yaml")]),
        ("100,000 nested lists", ["home", "check", str(folder / "nested.yaml")]),
        ("a 4 MiB home file", ["home", "check", str(folder / "big.yaml")]),
        ("a name that is a path", ["train", "--home", str(folder / "escape.yaml")]),
        ("/dev/zero as a home", ["home", "show", "--home", "/dev/zero"]),
        ("a FIFO as a home", ["home", "show", "--home", str(folder / "fifo.yaml")]),
        ("/dev/zero as events", ["correct", "--events", "/dev/zero", "--home", home]),
        ("a folder as events", ["correct", "--events", str(folder), "--home", home]),
        ("NUL in an event's user", ["correct", "--events", str(folder / "nul.csv"), "--home", home]),
        ("200 MB of events, last line bad", ["correct", "--events", str(folder / "big.csv"), "--home", home]),
        ("10,000 devices, joint", ["train", "--joint", "--home", str(folder / "many.yaml")]),
        ("--context ,,,==,", ["cognize", "--context", ",,,==,"]),
        (
            "--db in a missing folder",
            ["cognize", "--home", home, "--context", CONTEXT, "--db", "sqlite:////nonexist/x.sqlite"],
        ),
    ]


def _big_events(path: Path, size: int) -> None:
    """An event file of the studio of about ``size`` bytes, good but for its last line."""
    rng = random.Random(0)
    rows = [
        f"2024-03-01T{i // 60:02d}:{i % 60:02d}:00,{rng.randrange(24):02d}:{rng.choice(['00', '30'])},"
        f"{rng.choice([5, 50, 300, 812.5])},{rng.choice(['work', 'relax', 'sleep'])},"
        + ",".join(rng.choice(["on", "off"]) for _ in range(3))
        + f",{rng.choice(['LampOn', '', 'RadioOn;BringTea'])},{rng.choice(['', 'ann'])}\n"
        for i in range(1440)
    ]
    block = "".join(rows)
    with path.open("w") as f:
        f.write("timestamp,time,light,activity,blind,desk_lamp,radio,services,user\n")
        for _ in range(size // len(block)):
            f.write(block)
        f.write("2024-03-02T00:00:00,10:00,50,dance,off,off,off,,\n")


class _Measured(subprocess.Popen):  # type: ignore[type-arg]
    """A Popen that reaps its child with ``wait4``, keeping the child's own peak memory (MB)."""

    peak_mb = 0.0

    def _try_wait(self, wait_flags: int) -> tuple[int, int]:
        pid, status, usage = os.wait4(self.pid, wait_flags)
        if pid:
            self.peak_mb = usage.ru_maxrss / 1024
        return pid, status


def run_file_case(args: list[str], env: dict[str, str]) -> tuple[int, float, float, str]:
    """A run of homecog: its status, seconds, peak memory (MB) and first line."""
    start = time.perf_counter()
    command = [sys.executable, "-m", "homecog.cli.main", *args]
    proc = _Measured(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    out, err = proc.communicate(timeout=120)
    lines = (err or out).decode().strip().splitlines()
    said = (lines[0] if lines else "").removeprefix("homecog: error: ")
    return proc.returncode, time.perf_counter() - start, proc.peak_mb, said[:100]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=15.0, help="each phase's length")
    parser.add_argument("--db", help="the fleet's database URL (default: a SQLite file)")
    parser.add_argument("--rate", type=float, default=20, help="requests a second of each paced client")
    parser.add_argument("--client", nargs=4, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.client:
        kind, port, seconds, rate = args.client
        print(json.dumps(client(kind, int(port), float(seconds), float(rate))))
        return
    console = Console(width=200)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        url = args.db or f"sqlite:///{folder / 'fleet.sqlite'}"
        (folder / "homes").mkdir()
        console.print("learning two homes ...", style="dim")
        learn(folder / "homes", url)
        port = _free_port()
        server = serve(url, port)
        legit = ("legit", 2.5 * args.rate)
        hostile = [(k, r) for k, n in HOSTILE for _ in range(n) for r in (args.rate,)]
        phases = {
            "paced": [legit, *hostile],
            "ordinary flood": [legit, *[("ordinary", 0.0)] * 10],
            "hostile flood": [legit, *[(k, 0.0) for k, _ in hostile]],
            **{f"{kind} ×10": [legit, *[(kind, args.rate)] * 10] for kind in HEAVY},
            "heavy, mixed": [legit, *[(kind, args.rate) for kind in HEAVY for _ in range(4)][:10]],
        }
        try:
            results = {"alone": run_clients([legit], port, args.seconds)}
            for phase, kinds in phases.items():
                console.print(f"{phase} ...", style="dim")
                results[phase] = run_clients(kinds, port, args.seconds)
            memory = peak_mb(server.pid)
        finally:
            server.terminate()
            server.wait(timeout=30)
        _server_table(console, results, memory, url, args.rate)
        env = {**os.environ, "HOMECOG_DATA": str(folder / "data")}
        table = Table(title="The command line against hostile files (each a run of homecog)")
        for col in ("input", "status", "seconds", "peak MB", "what it says"):
            table.add_column(col, justify="left" if col in ("input", "what it says") else "right")
        for label, cli in file_cases(folder):
            status, seconds, peak, said = run_file_case(cli, env)
            table.add_row(label, str(status), f"{seconds:.2f}", f"{peak:.0f}", said.replace(str(folder), "…"))
        console.print(table)
        outside = Path("/nonexist").exists() or (folder.parent / "x").exists()
        console.print(f"anything made outside the data directory: {outside}")


def _server_table(
    console: Console, results: dict[str, list[dict]], memory: float, url: str, rate: float
) -> None:
    table = Table(title=f"homecog serve ({url.split(':')[0]}): a client's cognition, and ten other clients")
    for col in ("phase", "client", "requests", "p50 ms", "p95 ms", "max s", "answers"):
        table.add_column(col, justify="left" if col in ("phase", "client", "answers") else "right")
    for phase, rows in results.items():
        for i, row in enumerate(_merged(rows)):
            lat = row["latencies"]
            answers = ", ".join(f"{k}: {v}" for k, v in sorted(row["statuses"].items()))
            table.add_row(
                phase if i == 0 else "",
                row["kind"],
                str(len(lat)),
                f"{percentile(lat, 50) * 1000:.1f}",
                f"{percentile(lat, 95) * 1000:.1f}",
                f"{max(lat):.2f}",
                answers,
            )
    console.print(table)
    p95 = {phase: percentile(rows[0]["latencies"], 95) * 1000 for phase, rows in results.items()}
    hostile = [r for phase in ("paced", "hostile flood") for r in results[phase][1:]]
    five = sum(n for r in hostile for code, n in r["statuses"].items() if int(code) >= 500)
    worst = max(max(r["latencies"]) for r in hostile if r["kind"] != "slow")
    console.print(
        f"cognition p95: {p95['alone']:.1f} ms alone; {p95['paced']:.1f} ms beside ten hostile clients of "
        f"{rate:g} requests/s ({p95['paced'] / p95['alone']:.2f} ×); flooding, {p95['hostile flood']:.1f} ms "
        f"beside ten hostile clients, {p95['ordinary flood']:.1f} ms beside ten ordinary ones. 5xx: {five}; "
        f"slowest hostile answer {worst:.2f} s (a half-sent request: closed at its 5 s deadline); "
        f"server peak memory {memory:.0f} MB (with its planner)"
    )
    heavy = [phase for phase in p95 if phase.endswith("×10") or phase == "heavy, mixed"]
    console.print(
        "cognition p95 beside ten clients of "
        + "; ".join(
            f"{phase.removesuffix(' ×10')}: {p95[phase]:.1f} ms ({p95[phase] / p95['alone']:.2f} ×)"
            for phase in heavy
        )
    )


def _merged(rows: list[dict]) -> list[dict]:
    """The clients of one kind as one row, the legitimate client first."""
    out: dict[str, dict] = {}
    for row in rows:
        kept = out.setdefault(row["kind"], {"kind": row["kind"], "statuses": {}, "latencies": []})
        kept["latencies"] += row["latencies"]
        for code, n in row["statuses"].items():
            kept["statuses"][code] = kept["statuses"].get(code, 0) + n
    return list(out.values())


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


if __name__ == "__main__":
    main()
