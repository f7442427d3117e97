"""Every stage on a home of real size: 48 devices in 8 rooms, learned group by group,
built into a store, rebuilt from its compact log, asked, corrected, evaluated, planned and
simulated."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from homecog.evaluation.evaluate import run as run_eval
from homecog.evaluation.metrics import scores
from homecog.evaluation.scenarios import random_scenarios
from homecog.home import Home
from homecog.home.classes import group_classes
from homecog.home.groups import device_groups
from homecog.knowledge import core
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.pipeline import build
from homecog.knowledge.store import Store

ROOT = Path(__file__).parent.parent


@pytest.fixture(scope="module")
def rooms8_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from homes import home_text

    path = tmp_path_factory.mktemp("rooms8") / "rooms8.yaml"
    path.write_text(home_text(8))
    return path


@pytest.fixture(scope="module")
def built(rooms8: Home, tmp_path_factory: pytest.TempPathFactory) -> tuple[Store, IHDRTree]:
    db = tmp_path_factory.mktemp("rooms8db") / "k.sqlite"
    store = Store.open(f"sqlite:///{db}", rooms8)
    result = build(rooms8, store)
    assert result.samples == _samples(rooms8)  # every start state of every group, over its classes
    return store, result.tree


def _samples(home: Home) -> int:
    """A sample per start state of each group: its classes of contexts × its device states — far
    fewer than the 518,400 start states of the groups over every context."""
    groups = [g for g in device_groups(home) if g.services]
    count = sum(group_classes(home, g).count << len(g.devices) for g in groups)
    assert count * 100 < sum(home.context_count << len(g.devices) for g in groups) == 518_400
    return count


def test_multi_reaches_its_precision_and_recall_on_48_devices(rooms8: Home, built: tuple[Store, IHDRTree]):
    _, tree = built
    cases = random_scenarios(rooms8, 2000, seed=3)
    figures = scores([tree.predict_one(s.point) for s in cases], [sorted(s.truth) for s in cases])
    assert figures["precision"] >= 0.995 and figures["recall"] >= 0.995
    assert sum(len(s.truth) for s in cases) > 2000 * 10  # the scenarios ask much of the robot


def test_the_compact_log_rebuilds_the_same_tree(built: tuple[Store, IHDRTree], rooms8: Home):
    store, tree = built
    assert store.load_tree().signature() == tree.signature()
    assert core.rebuild(store).signature() == tree.signature()
    with store.engine.connect() as conn:
        size = conn.exec_driver_sql("SELECT SUM(LENGTH(data)) FROM experiences").scalar_one()
    assert size < 518_400  # less than a byte a sample: positions and mask indices, compressed


def test_group_tables_answer_as_the_clusters_do(built: tuple[Store, IHDRTree], rooms8: Home):
    _, tree = built
    cases = random_scenarios(rooms8, 300, seed=8)
    for s in cases[:30]:
        tree.correct_one(s.point, sorted(s.truth)[:3], user="kim")  # a user layer on top
    fast = [tree.explain_one(s.point, user=u).as_dict() for s in cases for u in (None, "kim")]
    assert tree.data.gindex  # the group tables were used
    tree.data.gindex = False  # force the lookup of every cluster of every service
    try:
        slow = [tree.explain_one(s.point, user=u).as_dict() for s in cases for u in (None, "kim")]
    finally:
        tree.data.gindex = None
    assert fast == slow


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "homecog.cli.main", *args], capture_output=True, text=True, timeout=600
    )


def _json(*args: str) -> dict:
    return json.loads(_cli(*args, "--json").stdout)


def test_the_command_line_on_48_devices(rooms8_file: Path, rooms8: Home, tmp_path: Path):
    db = f"sqlite:///{tmp_path / 'k.sqlite'}"
    trained = json.loads(_cli("train", "--home", str(rooms8_file), "--json").stdout)
    assert trained["groups"] == 44 and trained["greedy_optimal_rate"] >= 0.999
    built = json.loads(_cli("build", "--home", str(rooms8_file), "--db", db, "--json").stdout)
    assert built["samples"] == _samples(rooms8)
    case = random_scenarios(rooms8, 1, seed=4)[0]
    context = ",".join(f"{k}={v}" for k, v in case.context.items())
    answer = json.loads(
        _cli("cognize", "--home", str(rooms8_file), "--db", db, "--context", context, "--json").stdout
    )
    assert set(answer["services"]) == case.truth
    wanted = sorted(case.truth)[:1]
    corrected = _cli(
        "correct",
        "--home",
        str(rooms8_file),
        "--db",
        db,
        "--context",
        context,
        "--want",
        ",".join(wanted),
        "--json",
    )
    assert set(json.loads(corrected.stdout)["rejected"]) == case.truth - set(wanted)
    again = _cli("cognize", "--home", str(rooms8_file), "--db", db, "--context", context, "--json")
    assert json.loads(again.stdout)["services"] == wanted  # at once, for that user
    planned = json.loads(
        _cli("plan", "--home", str(rooms8_file), "--services", "SendDrinks,TurnOnLamp_room8", "--json").stdout
    )
    assert [a[0] for a in planned["actions"]][-2:] == ["move", "switch_by_hand"]  # the lamp: by hand
    out = tmp_path / "run.png"
    simulated = _cli(
        "simulate",
        "--home",
        str(rooms8_file),
        "--services",
        "SendDrinks,TurnOnLamp_room8",
        "--png",
        str(out),
        "--json",
    )
    assert json.loads(simulated.stdout)["distance_m"] > 10 and out.stat().st_size > 10_000


def test_eval_on_a_large_home_says_which_baseline_it_left_out(rooms8: Home, monkeypatch: pytest.MonkeyPatch):
    from homecog.evaluation import registry

    monkeypatch.setattr(registry, "HOEFFDING_BUDGET", 1_000_000)
    report = run_eval(rooms8, rooms8, scenarios=200, methods=["multi", "kmeans", "hoeffding"])
    assert set(report.methods) == {"multi", "kmeans"}
    assert report.skipped["hoeffding"].startswith(
        "not run: its 100 river trees (one per service) learning 8,000"
    )
    assert report.methods["multi"].micro["f1"] >= 0.995
    assert "skipped" in report.as_dict()


def test_the_running_robot_serves_48_devices(rooms8: Home, built: tuple[Store, IHDRTree]):
    from fastapi.testclient import TestClient

    from homecog.context.manual import ManualSource
    from homecog.home.codec import json_context
    from homecog.robot.runtime import Runtime
    from homecog.web.main import create_app

    store, _ = built
    runtime = Runtime(home=rooms8, store=store, tree=store.load_tree(), source=ManualSource(rooms8))
    client = TestClient(create_app(runtime))
    assert len(client.get("/api/home").json()["devices"]) == 48
    for case in random_scenarios(rooms8, 20, seed=12):
        answer = client.post("/api/cognize", json={"context": json_context(rooms8, case.context)})
        assert answer.status_code == 200
        assert set(answer.json()["services"]) == case.truth
    plan = client.post(
        "/api/plan", json={"services": ["TurnOnLamp_room8"], "context": json_context(rooms8, case.context)}
    )
    assert plan.status_code == 200 and plan.json()["actions"][-1] == ["switch_by_hand", "lamp_room8", "on"]
