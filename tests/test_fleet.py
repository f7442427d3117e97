"""homecog fleet train: many homes into one database, serially and as tasks on a
local Ray; a home learned for the same content is skipped, a bad home file is reported and the
others learned, a training killed with SIGKILL leaves every home complete or absent; and the
migration of one-home databases (schema 0002) to the keyed form, on every database."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from fleet_homes import home_rows, home_text, write_homes
from sqlalchemy import insert, select
from sqlalchemy.exc import OperationalError
from webserver import free_port

from homecog.cli.main import main
from homecog.home import Home, load_home_text
from homecog.knowledge import core
from homecog.knowledge.correction import Correction
from homecog.knowledge.database import make_engine
from homecog.knowledge.pipeline import build
from homecog.knowledge.schema import ClusterRow, ExperienceRow, HomeRow, NodeRow, UserRow
from homecog.knowledge.store import Store
from homecog.learning.policy import Policy

BAD = "name: [oops\n"
# no usage reports; no token authentication on the test's own cluster (Ray 2.60 turns it on for
# ray start, and the driver would need the token of the cluster)
RAY_ENV = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0", "RAY_AUTH_MODE": "disabled"}


def run(capsys, *args) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def fleet_command(*args: object) -> list[str]:
    return [sys.executable, "-m", "homecog.cli.main", "fleet", "train", *map(str, args)]


def _have_ray() -> None:
    try:
        import ray  # noqa: F401
    except ImportError:
        reason = "Ray is not installed (pip install 'homecog[fleet]'); the Ray tests skip"
        print(f"\nSKIP {reason}", file=sys.stderr)
        pytest.skip(reason)


# -- serially -------------------------------------------------------------------------------------
def test_serial_learns_every_home_reports_a_bad_one_and_skips_what_it_has(tmp_path, capsys):
    homes = write_homes(tmp_path / "homes", 2)
    (tmp_path / "homes" / "broken.yaml").write_text(BAD)
    url = f"sqlite:///{tmp_path / 'fleet.sqlite'}"
    code, out, err = run(capsys, "fleet", "train", tmp_path / "homes", "--db", url, "--serial", "--json")
    assert code == 1, err  # a home failed; the others are learned
    report = json.loads(out)
    by_file = {h["file"]: h for h in report["homes"]}
    assert by_file["broken.yaml"]["status"] == "failed"
    assert "broken.yaml: line 2: not valid YAML" in by_file["broken.yaml"]["error"]
    for home in homes:
        r = by_file[f"{home.name}.yaml"]
        assert r["status"] == "learned" and r["greedy_optimal_rate"] == 1.0 and r["samples"] > 0
    assert report["workers"] == 1 and report["ray"] is None
    rows = home_rows(url)
    assert set(rows) == {h.name for h in homes}
    assert all(r["built"] and r["nodes"] and r["clusters"] and r["build"] == 1 for r in rows.values())
    # the home file and the Q tables are stored with the build
    engine = make_engine(url)
    with engine.connect() as conn:
        source, policy = conn.execute(
            select(HomeRow.source, HomeRow.policy).where(HomeRow.name == homes[0].name)
        ).one()
    engine.dispose()
    assert load_home_text(source).content_hash == homes[0].content_hash
    (tmp_path / "q.npz").write_bytes(policy)
    assert Policy.load(tmp_path / "q.npz", homes[0]).greedy_optimal_rate == 1.0
    # again: nothing learned twice
    code, out, _ = run(capsys, "fleet", "train", tmp_path / "homes", "--db", url, "--serial", "--json")
    assert code == 1
    statuses = {h["file"]: h["status"] for h in json.loads(out)["homes"]}
    assert statuses == {"broken.yaml": "failed", "home0.yaml": "skipped", "home1.yaml": "skipped"}
    assert home_rows(url) == rows


def test_a_changed_home_file_is_learned_again_replacing_the_old(tmp_path, capsys):
    write_homes(tmp_path / "homes", 1)
    url = f"sqlite:///{tmp_path / 'fleet.sqlite'}"
    assert run(capsys, "fleet", "train", tmp_path / "homes", "--db", url, "--serial")[0] == 0
    first = home_rows(url)["home0"]
    path = tmp_path / "homes" / "home0.yaml"
    path.write_text(path.read_text() + "\nrewards: {magnitude: 5}\n")
    code, out, _ = run(capsys, "fleet", "train", tmp_path / "homes", "--db", url, "--serial", "--json")
    assert code == 0 and json.loads(out)["homes"][0]["status"] == "learned"
    rows = home_rows(url)["home0"]
    assert rows["build"] == 2 and rows["version"] == 2
    assert rows["experiences"] == first["experiences"]  # the old log went with it


@pytest.mark.parametrize(
    ("setup", "message"),
    [
        (lambda d: d / "none", "none: not a folder of home files"),
        (lambda d: d, "no home files (*.yaml) in it"),
    ],
)
def test_bad_folders_are_one_line(tmp_path, capsys, setup, message):
    code, out, err = run(capsys, "fleet", "train", setup(tmp_path), "--db", "sqlite://", "--serial")
    assert code == 2 and out == "" and message in err and err.count("\n") == 1, err


def test_a_database_that_cannot_be_used_is_one_line(tmp_path, capsys):
    write_homes(tmp_path / "homes", 1)
    bad = "postgresql+psycopg://postgres@127.0.0.1:1/x"
    code, _, err = run(capsys, "fleet", "train", tmp_path / "homes", "--db", bad, "--serial")
    assert code == 2 and "cannot use the database" in err and err.count("\n") == 1, err


# -- on Ray ---------------------------------------------------------------------------------------
def write_too_large(folder: Path, name: str = "huge") -> None:
    """A home file that loads but that learning refuses, in the task, after the driver has
    loaded it: 31 extra devices switched off only all together (a service that is no scene, since
    no service of one device switches any of them off) make one group of 31 devices, over the size
    check's limit of 30 (not a memory estimate: alike on every machine)."""
    extra = [f"x{i}" for i in range(31)]
    text = home_text(1, name=name)
    text = text.replace("devices:\n", "devices:\n" + "".join(f"  {d}: {{room: room1}}\n" for d in extra), 1)
    off = ", ".join(f"{d}: off" for d in extra)
    ons = "".join(f"  On_{d}: {{category: switch_on, set: {{{d}: on}}}}\n" for d in extra)
    text = text.replace(
        "services:\n", f"services:\n  AllOff: {{category: switch_off, set: {{{off}}}}}\n{ons}", 1
    )
    text = text.replace("comfort:\n", "comfort:\n" + "".join(f"  {d}: [{{want: off}}]\n" for d in extra), 1)
    (folder / f"{name}.yaml").write_text(text)


@pytest.mark.slow
@pytest.mark.xdist_group("ray")
def test_a_local_ray_learns_two_homes_as_the_serial_run_does(tmp_path):
    """... and reports a file that does not load and a home that fails in its task."""
    _have_ray()
    homes = write_homes(tmp_path / "homes", 2)
    (tmp_path / "homes" / "broken.yaml").write_text(BAD)
    write_too_large(tmp_path / "homes")
    ray_url, serial_url = (f"sqlite:///{tmp_path / f'{k}.sqlite'}" for k in ("ray", "serial"))
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0"}
    done = subprocess.run(
        fleet_command(tmp_path / "homes", "--db", ray_url, "--workers", 2, "--json"),
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )
    assert done.returncode == 1, done.stderr[-3000:]
    report = json.loads(done.stdout)
    assert report["ray"] == "local" and report["workers"] == 2
    assert {h["file"]: h["status"] for h in report["homes"]} == {
        "broken.yaml": "failed",
        "home0.yaml": "learned",
        "home1.yaml": "learned",
        "huge.yaml": "failed",
    }
    huge = next(h for h in report["homes"] if h["file"] == "huge.yaml")
    assert huge["home"] == "huge"  # loaded: it failed in its task, in training
    assert huge["error"].startswith("huge: too large to learn: its largest group")
    assert set(home_rows(ray_url)) == {"home0", "home1"}
    subprocess.run(fleet_command(tmp_path / "homes", "--db", serial_url, "--serial"), timeout=300, env=env)
    for home in homes:  # the same seed: the same tree wherever it was learned
        trees = []
        for url in (ray_url, serial_url):
            store = Store.open(url, home)
            trees.append(store.load_tree().signature())
            store.close()
        assert trees[0] == trees[1]


@contextlib.contextmanager
def ray_cluster(tmp_path: Path) -> Iterator[str]:
    """A Ray cluster of 2 CPUs started with ``ray start --head`` on free ports, in a session of
    its own, until the block ends: its address. Stopped by signalling that session (not
    ``ray stop``, which stops every Ray of this user on the machine, other runs' too); skips,
    saying why, when it cannot start."""
    ray = Path(sys.executable).parent / "ray"
    ports = [free_port() for _ in range(7)]
    temp = Path(tempfile.mkdtemp(prefix="ray", dir="/tmp"))  # short: Ray's socket paths
    command = [str(ray), "start", "--head", "--block", "--num-cpus", "2", "--include-dashboard=false"]
    command += ["--port", ports[0], "--temp-dir", str(temp), "--ray-client-server-port", ports[1]]
    command += ["--dashboard-agent-listen-port", ports[2], "--dashboard-agent-grpc-port", ports[3]]
    command += ["--metrics-export-port", ports[4], "--runtime-env-agent-port", ports[5]]
    command += ["--node-manager-port", ports[6]]
    log_path = tmp_path / "ray-start.log"
    with log_path.open("wb") as log:
        proc = subprocess.Popen(
            [str(c) for c in command],
            stdout=log,
            stderr=subprocess.STDOUT,
            env=RAY_ENV,
            start_new_session=True,
        )
    try:
        deadline = time.monotonic() + 60
        while "Ray runtime started" not in log_path.read_text(errors="replace"):
            if proc.poll() is not None or time.monotonic() > deadline:
                reason = f"ray start --head did not start a cluster: {log_path.read_text()[-500:]}"
                print(f"\nSKIP {reason}", file=sys.stderr)
                pytest.skip(reason)
            time.sleep(0.2)
        yield f"127.0.0.1:{ports[0]}"
    finally:
        proc.terminate()  # ray start --block stops what it started, then itself
        try:
            proc.wait(timeout=20)
        finally:
            with contextlib.suppress(ProcessLookupError):  # anything of its session left
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        shutil.rmtree(temp, ignore_errors=True)


@pytest.mark.slow
@pytest.mark.xdist_group("ray")
def test_ray_address_learns_on_a_running_cluster(tmp_path):
    """``--ray ADDRESS``: the tasks go to a cluster started apart (``ray start --head``); a home
    that fails in its task is reported, the other learned."""
    _have_ray()
    write_homes(tmp_path / "homes", 1)
    write_too_large(tmp_path / "homes")
    url = f"sqlite:///{tmp_path / 'fleet.sqlite'}"
    with ray_cluster(tmp_path) as address:
        done = subprocess.run(
            fleet_command(tmp_path / "homes", "--db", url, "--ray", address, "--json"),
            capture_output=True,
            text=True,
            timeout=300,
            env=RAY_ENV,
        )
    assert done.returncode == 1, done.stderr[-3000:]
    report = json.loads(done.stdout)
    assert report["ray"] == address
    assert {h["file"]: h["status"] for h in report["homes"]} == {
        "home0.yaml": "learned",
        "huge.yaml": "failed",
    }
    assert "too large to learn" in report["homes"][1]["error"]
    assert list(home_rows(url)) == ["home0"]


# -- killed ---------------------------------------------------------------------------------------
def _assert_complete_or_absent(url: str, homes: list[Home]) -> list[str]:
    """Every home of the database whole: loads, rebuilds from its log to the same tree; the
    names of the homes there."""
    rows = home_rows(url)
    for name, r in rows.items():
        assert r["built"] and r["nodes"] > 0 and r["clusters"] > 0 and r["experiences"] > 0, (name, r)
    for home in homes:
        if home.name in rows:
            store = Store.open(url, home)
            try:
                assert core.rebuild(store).signature() == store.load_tree().signature()
            finally:
                store.close()
    return sorted(rows)


@pytest.mark.slow
@pytest.mark.xdist_group("ray")
@pytest.mark.parametrize("how", ["serial", "ray"])
def test_a_training_killed_with_sigkill_leaves_every_home_complete_or_absent(tmp_path, how):
    if how == "ray":
        _have_ray()
    homes = write_homes(tmp_path / "homes", 6)
    url = f"sqlite:///{tmp_path / 'fleet.sqlite'}"
    args = ["--serial"] if how == "serial" else ["--workers", "2"]
    env = {**os.environ, "RAY_USAGE_STATS_ENABLED": "0"}
    # a session of its own: SIGKILL goes to the command and every process it started (Ray's too)
    proc = subprocess.Popen(
        fleet_command(tmp_path / "homes", "--db", url, *args),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
        env=env,
    )
    deadline = time.monotonic() + 240
    try:
        while time.monotonic() < deadline and proc.poll() is None:
            with contextlib.suppress(OperationalError):  # not yet made
                if len(home_rows(url)) >= 2:
                    break
            time.sleep(0.05)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    first = _assert_complete_or_absent(url, homes)
    assert 2 <= len(first) <= 6
    # the next run learns what is missing and skips what is there
    done = subprocess.run(
        fleet_command(tmp_path / "homes", "--db", url, "--serial", "--json"),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    statuses = {h["home"]: h["status"] for h in json.loads(done.stdout)["homes"]}
    # (a Ray worker in the middle of a task may still commit its home after the kill: whole too)
    assert set(first) <= {n for n, s in statuses.items() if s == "skipped"}
    assert _assert_complete_or_absent(url, homes) == sorted(h.name for h in homes)


# -- migration ------------------------------------------------------------------------------------
def _upgrade_to(engine, revision: str) -> None:
    from alembic import command
    from alembic.config import Config

    import homecog.knowledge.store as store_module

    cfg = Config()
    cfg.set_main_option("script_location", str(Path(store_module.__file__).parent / "migrations"))
    with engine.begin() as conn:
        cfg.attributes["connection"] = conn
        command.upgrade(cfg, revision)


def test_a_one_home_database_of_schema_0002_moves_to_the_keyed_form(
    db_url: str, tmp_path, studio: Home, studio_build: Path
) -> None:
    """The rows of a 0002 database (one home, no home column) get the home's name from its
    ``homes`` row; the tree, its users' layers, the log and the counts are as they were."""
    source = Store.open(f"sqlite:///{tmp_path / 'source.sqlite'}", studio)
    tree = build(studio, source, q_path=studio_build).tree
    context = {
        "time": "10:00",
        "light": 100,
        "activity": "work",
        "blind": "off",
        "desk_lamp": "off",
        "radio": "off",
    }
    core.correct(source, tree, Correction.whole("alice", tree.point(context), ["RadioOn"]))
    before = (source.load_tree().signature(), source.counts(), source.experience_count())
    tables = {}
    with source.engine.connect() as conn:
        for row_type in (HomeRow, NodeRow, ClusterRow, UserRow, ExperienceRow):
            rows = [dict(r._mapping) for r in conn.execute(select(row_type.__table__))]
            tables[row_type.__tablename__] = rows
    source.close()
    # the same rows as schema 0002 held them
    engine = make_engine(db_url)
    _upgrade_to(engine, "0002")
    old = {"homes": ("id", "name", "content_hash", "mode", "built_at", "state")}
    with engine.begin() as conn:
        from sqlalchemy import MetaData, Table

        meta = MetaData()
        for name in ("homes", "nodes", "clusters", "users", "experiences"):
            table = Table(name, meta, autoload_with=conn)
            rows = tables[name]
            if name == "homes":
                rows = [{"id": 1, **{k: r[k] for k in old["homes"][1:]}} for r in rows]
            else:
                rows = [{k: v for k, v in r.items() if k != "home"} for r in rows]
                rows.sort(key=lambda r: r.get("id", 0))
            conn.execute(insert(table), rows)
    engine.dispose()
    store = Store.open(db_url, studio)  # migrates
    try:
        assert (store.load_tree().signature(), store.counts(), store.experience_count()) == before
        assert core.rebuild(store).signature() == before[0]
        assert store.home_version() == (1, 1)
        assert store.load_tree().predict_one(context, "alice") == tree.predict_one(context, "alice")
    finally:
        store.close()


def test_a_database_of_an_unknown_newer_schema_is_one_line(tmp_path, capsys):
    write_homes(tmp_path / "homes", 1)
    url = f"sqlite:///{tmp_path / 'new.sqlite'}"
    engine = make_engine(url)
    with engine.begin() as conn:
        conn.exec_driver_sql("CREATE TABLE alembic_version (version_num VARCHAR(32) PRIMARY KEY)")
        conn.exec_driver_sql("INSERT INTO alembic_version VALUES ('9999')")
    engine.dispose()
    for args in (["fleet", "train", tmp_path / "homes", "--serial"], ["serve"]):
        code, out, err = run(capsys, *args, "--db", url)
        assert code == 2 and out == "" and err.count("\n") == 1, err
        assert "a schema this homecog does not know" in err and "9999" in err, err


def test_without_ray_the_command_says_how_to_have_it(tmp_path, capsys, monkeypatch):
    write_homes(tmp_path / "homes", 1)
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray fails as where it is not installed
    code, _, err = run(capsys, "fleet", "train", tmp_path / "homes", "--db", "sqlite://")
    assert code == 2 and "pip install 'homecog[fleet]'" in err and err.count("\n") == 1, err
