"""Benchmark of the knowledge stage on the paper home: cognition, corrections, build, growth.

    bin/bench knowledge            # or: .venv/bin/python benchmarks/bench_knowledge.py [--quick]

Servers: PostgreSQL and MariaDB are measured where reachable (``HOMECOG_BENCH_POSTGRES`` and
``HOMECOG_BENCH_MARIADB`` override the URLs); a fresh database is made and dropped for each.
"""

from __future__ import annotations

import argparse
import os
import pickle
import statistics
import subprocess
import sys
import tempfile
import time
import uuid

import numpy as np
from rich.console import Console
from rich.table import Table
from sqlalchemy import create_engine, text

from homecog.environment.core import Core
from homecog.evaluation.scenarios import random_scenarios
from homecog.home import load_home
from homecog.knowledge import core
from homecog.knowledge.correction import Correction
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.pipeline import ensure_policy, learn_policy
from homecog.knowledge.samples import SampleSet, make_samples
from homecog.knowledge.store import Store

SERVERS = {
    "PostgreSQL": os.environ.get(
        "HOMECOG_BENCH_POSTGRES", "postgresql+psycopg://postgres@127.0.0.1:5432/postgres"
    ),
    "MariaDB": os.environ.get("HOMECOG_BENCH_MARIADB", "mysql+pymysql://root@127.0.0.1:3306/mysql"),
}


def percentiles(seconds: list[float]) -> tuple[float, float]:
    arr = np.array(seconds)
    return float(np.percentile(arr, 50)), float(np.percentile(arr, 99))


def cognition(tree: IHDRTree, contexts: list[dict[str, str]]) -> tuple[float, float, float]:
    """p50 and p99 latency (s) of predict_one from a context dict, and throughput (1/s)."""
    tree.predict_one(contexts[0])  # builds the lookup table
    times = []
    start = time.perf_counter()
    for x in contexts:
        t = time.perf_counter()
        tree.predict_one(x)
        times.append(time.perf_counter() - t)
    total = time.perf_counter() - start
    p50, p99 = percentiles(times)
    return p50, p99, len(contexts) / total


def server_database(admin_url: str) -> tuple[str, str] | None:
    """Make a fresh database on a server: (its URL, its name), or None when unreachable."""
    name = f"homecog_bench_{uuid.uuid4().hex[:8]}"
    try:
        engine = create_engine(admin_url, isolation_level="AUTOCOMMIT", connect_args={"connect_timeout": 3})
        with engine.connect() as conn:
            conn.execute(text(f"CREATE DATABASE {name}"))
        engine.dispose()
    except Exception as e:  # report and skip this server
        print(f"skipping {admin_url}: {str(e).splitlines()[0]}", file=sys.stderr)
        return None
    return admin_url.rsplit("/", 1)[0] + f"/{name}", name


def drop_database(admin_url: str, name: str) -> None:
    engine = create_engine(admin_url, isolation_level="AUTOCOMMIT")
    with engine.connect() as conn:
        conn.execute(text(f"DROP DATABASE {name}"))
    engine.dispose()


def corrections(url: str, tree: IHDRTree, samples: SampleSet, n: int) -> tuple[float, float]:
    """p50, p99 seconds to commit a correction (the store's whole transaction)."""
    store = Store.open(url, tree.home)
    core.save_build(store, tree, samples)
    live = store.load_tree()
    scenarios = random_scenarios(tree.home, n, seed=11)
    times = []
    for i, s in enumerate(scenarios):
        want = sorted(s.truth)[:-1] if i % 2 else [*sorted(s.truth), "ChargeItSelf"]
        t = time.perf_counter()
        core.correct(store, live, Correction.whole(f"user{i % 3}", s.point, want))
        times.append(time.perf_counter() - t)
    store.drop_all()
    store.close()
    return percentiles(times)


def growth(
    home_tree: IHDRTree, samples: SampleSet, more: SampleSet, sizes: list[int], contexts: list[dict[str, str]]
) -> list[tuple[int, int, int, int, float]]:
    """(experiences, nodes, clusters, bytes, p50 cognition s) as the learned samples grow."""
    rng = np.random.default_rng(0)
    both = SampleSet(
        space=samples.space,
        codes=np.concatenate([samples.codes, more.codes]),
        readings=np.concatenate([samples.readings, more.readings]),
        positions=np.concatenate([samples.positions, more.positions]),
        masks=np.concatenate([samples.masks, more.masks]),
    )
    order = rng.permutation(len(both))
    out = []
    for n in sizes:
        pick = order[:n]
        part = SampleSet(
            space=both.space,
            codes=both.codes[pick],
            readings=both.readings[pick],
            positions=both.positions[pick],
            masks=both.masks[pick],
        )
        tree = IHDRTree(home_tree.home)
        tree.learn_many(part)
        p50, _, _ = cognition(tree, contexts)
        out.append((n, tree.root.n_nodes, tree.n_clusters(), len(pickle.dumps(tree)), p50))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repetitions")
    args = parser.parse_args()
    console = Console(width=130)
    home = load_home("paper")
    core = Core(home)
    joint = ensure_policy(home, joint=True)  # the paper's table: the growth and mode rows
    grouped = ensure_policy(home)
    n_ctx = 2000 if args.quick else 20000
    contexts = [s.context for s in random_scenarios(home, n_ctx, seed=7)]

    console.print("measuring ...", style="dim")
    rows: list[tuple[str, str, str]] = []

    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "HOMECOG_DATA": os.environ.get("HOMECOG_DATA", tmp)}
        for flags, what in (([], "grouped, the default"), (["--joint"], "the joint table")):
            walls = []
            for i in range(1 if args.quick else 3):
                db = f"sqlite:///{tmp}/build{i}{len(flags)}.sqlite"
                start = time.perf_counter()
                subprocess.run(
                    [
                        sys.executable,
                        "-m",
                        "homecog.cli.main",
                        "build",
                        "--home",
                        "paper",
                        "--db",
                        db,
                        *flags,
                    ],
                    check=True,
                    capture_output=True,
                    env=env,
                )
                walls.append(time.perf_counter() - start)
            rows.append(
                (
                    f"`homecog build --home paper {' '.join(flags)}` wall ({what}; Q table cached)",
                    f"{statistics.median(walls):.1f} s",
                    f"median of {len(walls)}; samples, tree and the SQLite store",
                )
            )

    samples = make_samples(core, joint.q(0), seed=0)
    for mode, policy in (("multi", grouped), ("multi", joint), ("paper", joint)):
        tree = IHDRTree(home, mode=mode)
        learn_policy(home, policy, tree)
        p50, p99, rate = cognition(tree, contexts)
        what = "joint table" if policy.joint else "groups"
        rows.append(
            (
                f"cognition, {mode} tree of the {what} ({tree.n_clusters()} clusters), from a context dict",
                f"p50 {p50 * 1e6:.0f} µs",
                f"p99 {p99 * 1e6:.0f} µs; {rate:,.0f} cognitions/s; {len(contexts):,} random scenarios",
            )
        )
        if mode == "multi" and policy.joint:
            multi = tree

    n_corr = 100 if args.quick else 300
    with tempfile.TemporaryDirectory() as tmp:
        p50, p99 = corrections(f"sqlite:///{tmp}/c.sqlite", multi, samples, n_corr)
        rows.append(
            ("correction committed, SQLite", f"p50 {p50 * 1e3:.1f} ms", f"p99 {p99 * 1e3:.1f} ms; {n_corr}")
        )
    for name, admin in SERVERS.items():
        made = server_database(admin)
        if made is None:
            rows.append((f"correction committed, {name}", "skipped", "server unreachable"))
            continue
        url, db_name = made
        try:
            p50, p99 = corrections(url, multi, samples, n_corr)
        finally:
            drop_database(admin, db_name)
        rows.append(
            (f"correction committed, {name}", f"p50 {p50 * 1e3:.1f} ms", f"p99 {p99 * 1e3:.1f} ms; {n_corr}")
        )

    more = make_samples(core, joint.q(0), seed=1)  # the same start states with other readings
    sizes = [1_000, 10_000, 100_000, 1_000_000]
    for n, nodes, clusters, size, p50 in growth(multi, samples, more, sizes, contexts[:2000]):
        rows.append(
            (
                f"multi tree after {n:,} experiences",
                f"{clusters:,} clusters",
                f"{nodes} nodes, {size / 1e3:,.0f} kB pickled; cognition p50 {p50 * 1e6:.0f} µs",
            )
        )

    table = Table(title="Knowledge on the paper home", title_justify="left")
    for col in ("figure", "value", "note"):
        table.add_column(col)
    for row in rows:
        table.add_row(*row)
    console.print(table)


if __name__ == "__main__":
    main()
