"""homecog replay: prequential evaluation of an event stream."""

from __future__ import annotations

import json
from datetime import datetime, timedelta
from pathlib import Path

import pytest

from homecog.cli.main import main
from homecog.evaluation.scenarios import random_scenarios
from homecog.home import load_home

HOMES = Path(__file__).parent / "homes"
STUDIO = str(HOMES / "studio.yaml")
KIM = str(HOMES / "studio_kim.yaml")


def write_events(path: Path, n: int) -> None:
    """Events of the studio whose household wants what studio_kim.yaml says."""
    home = load_home(STUDIO)
    names = list(home.feature_names + home.device_names)
    start = datetime(2026, 3, 1, 7, 0)
    lines = ["timestamp," + ",".join(names) + ",services"]
    for i, s in enumerate(random_scenarios(home, n, seed=3, truth=load_home(KIM))):
        when = (start + timedelta(minutes=17 * i)).isoformat()
        lines.append(when + "," + ",".join(s.context[k] for k in names) + "," + ";".join(sorted(s.truth)))
    path.write_text("\n".join(lines) + "\n")


def test_replay_learns_the_household(tmp_path, capsys):
    events = tmp_path / "events.csv"
    write_events(events, 300)
    code = main(
        ["replay", "--home", STUDIO, "--events", str(events), "--report", str(tmp_path / "r"), "--json"]
    )
    out, err = capsys.readouterr()
    assert code == 0, err
    data = json.loads(out)
    assert data["events"] == 300
    assert set(data["methods"]) == {
        *(
            "multi",
            "paper",
            "kmeans",
            "hoeffding",
            "frequency",
            "naive_bayes",
            "ha_usage",
            "markov",
            "boosted",
        )
    }
    for m in data["methods"].values():
        assert set(m) == {"precision", "recall", "f1"}
    # the trees learn every correction at once; K-means only moves its clusters slowly
    assert data["methods"]["multi"]["f1"] > data["methods"]["kmeans"]["f1"]
    assert data["methods"]["multi"]["f1"] >= 0.95
    # multi's lead over every other method, with its interval over the events
    versus = data["multi_minus"]
    assert set(versus) == set(data["methods"]) - {"multi"}
    for name, d in versus.items():
        lead = data["methods"]["multi"]["f1"] - data["methods"][name]["f1"]
        assert d["difference"] == pytest.approx(lead, abs=2e-6)
        assert d["low"] <= d["high"]
    assert versus["kmeans"]["low"] > 0  # 300 events tell the two apart
    text = (tmp_path / "r" / "replay.md").read_text()
    assert "| multi |" in text
    k = versus["kmeans"]
    assert f"| {k['difference']:+.3f} [{k['low']:+.3f}, {k['high']:+.3f}] |" in text
    assert (tmp_path / "r" / "running.png").read_bytes()[:4] == b"\x89PNG"


def test_replay_bad_events(tmp_path, capsys):
    events = tmp_path / "e.csv"
    write_events(events, 5)
    lines = events.read_text().splitlines()
    lines[3] = "yesterday" + lines[3][lines[3].index(",") :]
    events.write_text("\n".join(lines) + "\n")
    code = main(["replay", "--home", STUDIO, "--events", str(events)])
    _, err = capsys.readouterr()
    assert code == 2
    assert f"{events}: line 4, column timestamp: 'yesterday' is not an ISO 8601 time" in err
    no_ts = tmp_path / "n.csv"
    no_ts.write_text("\n".join(line.split(",", 1)[1] for line in lines) + "\n")
    code = main(["replay", "--home", STUDIO, "--events", str(no_ts)])
    _, err = capsys.readouterr()
    assert code == 2 and "line 1: missing column(s) timestamp" in err


def test_replay_rows_of_the_simple_learners_alone():
    """The online baselines need no policy: they learn the stream alone, from nothing."""
    from homecog.evaluation.replay import replay_rows

    home = load_home(STUDIO)
    rows = random_scenarios(home, 400, seed=3, truth=load_home(KIM))
    result = replay_rows(home, rows, methods=["frequency", "naive_bayes"], points=40)
    assert result.events == 400 and set(result.methods) == {"frequency", "naive_bayes"}
    assert result.versus() == {} and "multi_minus" not in result.as_dict()  # no multi to compare
    assert result.versus("frequency")["naive_bayes"].difference == pytest.approx(
        result.methods["frequency"]["f1"] - result.methods["naive_bayes"]["f1"], abs=2e-6
    )
    for name, series in result.running.items():
        assert [r[0] for r in series] == list(range(10, 401, 10))
        assert series[-1][3] == pytest.approx(result.methods[name]["f1"], abs=1e-6)
        # a household's wishes repeat: over the whole stream it does better than over its first half
        assert series[-1][3] > series[19][3] > 0


def test_a_slow_stream_reports_progress_by_the_clock(monkeypatch):
    """Every 1,000 events, and on a stream slow enough (a large home) every PROGRESS_SECONDS."""
    from homecog.evaluation import replay as replay_module

    home = load_home(STUDIO)
    rows = random_scenarios(home, 30, seed=4, truth=load_home(KIM))
    said: list[str] = []
    replay_module.replay_rows(home, rows, methods=["frequency"], progress=said.append)
    assert said == []  # 30 quick events: nothing to say
    monkeypatch.setattr(replay_module, "PROGRESS_SECONDS", 0.0)
    replay_module.replay_rows(home, rows, methods=["frequency"], progress=said.append)
    assert said == [f"{i:,} of 30 events" for i in range(1, 31)]


def test_the_paper_mode_learns_a_correction_as_the_paper_does():
    """In a replay ``paper`` learns each event as its Algorithm 2 learns a sample: into its
    one-cluster-per-node tree, for everyone; ``multi`` through the user's own layer."""
    from homecog.evaluation.methods import TreeMethod
    from homecog.knowledge.ihdr import IHDRTree

    home = load_home(STUDIO)
    s = next(x for x in random_scenarios(home, 50, seed=3, truth=load_home(KIM)) if x.truth)
    for mode in ("paper", "multi"):
        method = TreeMethod(IHDRTree(home, mode=mode), user="household")
        method.learn_one(s.point, sorted(s.truth))
        learned_shared = method.tree.n_samples == 1 and method.tree.users == []
        assert learned_shared == (mode == "paper")
        assert (method.tree.n_clusters("household") == 1) == (mode == "multi")
        assert set(method.predict_one(s.point)) == set(s.truth)  # what it learned, it says
