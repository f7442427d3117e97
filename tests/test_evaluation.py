"""homecog eval: metrics, truth homes, scenario files, the learning curve and the report."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from homecog.cli.main import main
from homecog.errors import EvaluationError
from homecog.evaluation.evaluate import check_truth, evaluate, load_scenarios
from homecog.evaluation.scenarios import random_scenarios
from homecog.home import load_home
from homecog.home.codec import Space
from homecog.home.scenario_file import Scenario

HOMES = Path(__file__).parent / "homes"
STUDIO = str(HOMES / "studio.yaml")
KIM = str(HOMES / "studio_kim.yaml")


class Fixed:
    """A method that answers from a table (to check the metrics by hand)."""

    name = "fixed"

    def __init__(self, answers):
        self.answers = answers

    def predict_one(self, point):
        return self.answers[point]


def test_metrics_by_hand():
    home = load_home(STUDIO)
    space = Space(home)
    base = random_scenarios(home, 3, seed=0)
    cases = [
        Scenario(s.context, s.point, t)
        for s, t in zip(
            base, [frozenset({"LampOn", "BringTea"}), frozenset({"RaiseBlind"}), frozenset()], strict=True
        )
    ]
    method = Fixed(
        {cases[0].point: ["LampOn"], cases[1].point: ["RaiseBlind", "RadioOn"], cases[2].point: []}
    )
    r = evaluate(method, cases, home.service_names)
    # micro: hits 1 + 1 = 2; predicted 1 + 2 = 3; true 2 + 1 = 3
    assert r.micro == pytest.approx({"precision": 2 / 3, "recall": 2 / 3, "f1": 2 / 3, "exact": 1 / 3})
    # averaged over scenarios: precision (1 + 1/2 + 1) / 3, recall (1/2 + 1 + 1) / 3
    assert r.averaged["precision"] == pytest.approx(2.5 / 3)
    assert r.averaged["recall"] == pytest.approx(2.5 / 3)
    # an empty ratio is 1 only where both sides are empty: said but never wanted, and wanted
    # but never said, are both 0 (a method that never answers does not get precision 1)
    assert r.per_service["RadioOn"] == {"support": 0, "precision": 0.0, "recall": 0.0, "f1": 0.0}
    assert r.per_service["BringTea"] == {"support": 1, "precision": 0.0, "recall": 0.0, "f1": 0.0}
    assert r.per_service["LampOn"] == {"support": 1, "precision": 1.0, "recall": 1.0, "f1": 1.0}
    assert space.names[0] == "time"


def test_incompatible_truth_names_what_differs():
    with pytest.raises(EvaluationError) as e:
        check_truth(load_home("paper"), load_home(STUDIO))
    assert "not compatible with home 'paper'" in str(e.value)
    assert "context features, values or bins differ" in str(e.value)
    assert "devices differ" in str(e.value)
    check_truth(load_home(STUDIO), load_home(KIM))  # compatible: no error


HEADER = "time,light,activity,blind,desk_lamp,radio"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("time,light,activity\n08:00,5,work\n", "line 1: missing column(s) blind, desk_lamp, radio"),
        (f"{HEADER},mood\n08:00,5,work,on,off,off,calm\n", "line 1: unknown column(s) mood"),
        (f"{HEADER},radio\n08:00,5,work,on,off,off,on\n", "line 1: column(s) named twice: radio"),
        (
            f"{HEADER}\n08:00,5,work,on,off,off\n08:00,5,dance,on,off,off\n",
            "line 3, column activity: activity: unknown value 'dance'; expected one of work, relax, sleep",
        ),
        (f"{HEADER}\n8 o'clock,5,work,on,off,off\n", "line 2, column time:"),
        (f"{HEADER}\n08:00,dim,work,on,off,off\n", "line 2, column light: light: not a number: 'dim'"),
        (f"{HEADER}\n08:00,5,work,on,off\n", "line 2: expected 6 fields"),
        (
            f"{HEADER},services\n08:00,5,work,on,off,off,LampOn;Dance\n",
            "line 2, column services: unknown service 'Dance'",
        ),
        ("", "empty file"),
        (f"{HEADER}\n", "no rows after the header"),
    ],
)
def test_scenario_file_errors(tmp_path, text, message):
    path = tmp_path / "s.csv"
    path.write_text(text)
    with pytest.raises(EvaluationError) as e:
        load_scenarios(path, load_home(STUDIO), load_home(STUDIO))
    assert str(e.value).startswith(str(path))
    assert message in str(e.value)


def test_scenario_file_with_and_without_services(tmp_path):
    path = tmp_path / "s.csv"
    path.write_text(
        f"{HEADER},services\n08:00,150,work,off,off,on,LampOn;RaiseBlind\n22:00,5,sleep,off,off,off,\n"
    )
    home = load_home(STUDIO)
    cases = load_scenarios(path, home, home)
    assert [c.truth for c in cases] == [frozenset({"LampOn", "RaiseBlind"}), frozenset()]
    path.write_text(f"{HEADER}\n08:00,150,work,off,off,on\n")
    (case,) = load_scenarios(path, home, home)
    assert case.truth == frozenset({"LampOn", "RaiseBlind", "BringTea"})  # from the home's rules
    (kim,) = load_scenarios(path, home, load_home(KIM))
    assert kim.truth == frozenset({"LampOn", "RaiseBlind", "BringTea"})  # the lamp is on: no radio for Kim


def test_eval_json_and_learning_curve(tmp_path, capsys):
    code = main(
        [
            "eval",
            "--home",
            STUDIO,
            "--truth",
            KIM,
            "--scenarios",
            "400",
            "--corrections",
            "60",
            "--seed",
            "1",
            "--report",
            str(tmp_path / "rep"),
            "--json",
        ]
    )
    out, err = capsys.readouterr()
    assert code == 0, err
    data = json.loads(out)
    assert data["scenarios"] == 400
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
        assert set(m) >= {"precision", "recall", "f1", "exact"}
        assert 0 <= m["precision"] <= 1
    # multi's lead over every other method on the same scenarios, with its interval
    versus = data["multi_minus"]
    assert set(versus) == set(data["methods"]) - {"multi"}
    for name, d in versus.items():
        lead = data["methods"]["multi"]["f1"] - data["methods"][name]["f1"]
        assert d["difference"] == pytest.approx(lead, abs=2e-6) and d["low"] <= d["high"]
    curve = data["curve"]
    assert [c["corrections"] for c in curve] == list(range(0, 61, 6))
    assert curve[0]["f1"] < 0.95  # Kim's wishes differ from what the robot learned
    assert curve[-1]["f1"] > curve[0]["f1"] + 0.03  # and it learns them from her corrections
    assert curve[-1]["f1"] >= 0.95
    report = tmp_path / "rep" / "report.md"
    assert data["report"] == str(report)
    text = report.read_text()
    assert "| multi |" in text and "![curve](curve.png)" in text
    assert "Table 9" not in text and "paper_table9" not in data  # the paper measured its own home
    k = versus["kmeans"]
    assert f"| {k['difference']:+.3f} [{k['low']:+.3f}, {k['high']:+.3f}] |" in text
    for png in ("methods.png", "per_service.png", "curve.png"):
        assert (tmp_path / "rep" / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--truth", "paper"], "not compatible with home 'studio'"),
        (["--scenarios", "0"], "--scenarios must be at least 1"),
        (["--scenarios", "nothere.csv"], "--scenarios nothere.csv: no such file"),
        (
            ["--scenarios", "1" + "0" * 23],
            f"the number of scenarios must be from 1 to 1,000,000, got 1{'0' * 23}",
        ),
        (["--corrections", "1000001"], "the number of corrections must be from 0 to 1,000,000, got 1000001"),
        (["--methods", "multi,svm"], "--methods: unknown method 'svm'"),
        (
            ["--corrections", "-2"],
            "Invalid value for '--corrections': Input should be greater than or equal to 0",
        ),
    ],
)
def test_eval_bad_input(capsys, args, message):
    code = main(["eval", "--home", STUDIO, *args])
    out, err = capsys.readouterr()
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1 and message in err, err


def test_the_papers_table_9_stands_beside_its_own_home_only(tmp_path, capsys):
    """Its rows in the text, the JSON and the report with the built-in paper home measured
    against its own rules; never with another home or another truth."""
    base = ["eval", "--scenarios", "40", "--methods", "multi"]
    assert main([*base, "--report", str(tmp_path), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["paper_table9"] == {
        "Kmeans (paper)": {"precision": 0.8866, "recall": 0.8457, "f1": 0.8657},
        "Sarsa+IHDR (paper)": {"precision": 0.9821, "recall": 0.9026, "f1": 0.9407},
    }
    report = (tmp_path / "report.md").read_text()
    assert "| Sarsa+IHDR (paper), Table 9 | 0.9821 | 0.9026 | 0.9407 |" in report
    assert main(base) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if "(paper)" in line]
    assert [row.split("│")[1].strip() for row in rows] == ["Kmeans (paper)", "Sarsa+IHDR (paper)"]
    assert "0.9821" in rows[1] and "0.9407" in rows[1]
    for other in (["--truth", "paper_ann"], ["--home", STUDIO]):
        assert main([*base, *other]) == 0
        out = capsys.readouterr().out
        assert "multi" in out and "(paper)" not in out and "0.9821" not in out
