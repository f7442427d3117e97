"""``eval --days`` says what went wrong, per device and per service, in its JSON, its text
and its report; and how far the days have come, as it lives them."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import pytest

from homecog.cli.main import main
from homecog.cli.render import faults_tables
from homecog.evaluation.closed_loop import closed_loop
from homecog.evaluation.closed_loop_report import write_days_report
from homecog.home import load_home
from homecog.knowledge.pipeline import open_tree
from homecog.knowledge.store import Store
from homecog.robot.guidance import switch_services

HOMES = Path(__file__).parent / "homes"
FAMILY, BEN = str(HOMES / "family.yaml"), str(HOMES / "family_ben.yaml")
STUDIO, KIM = str(HOMES / "studio.yaml"), str(HOMES / "studio_kim.yaml")


@pytest.fixture(scope="module")
def lived() -> dict:
    """A day of the family flat with a household of Ben's wishes, as ``--json`` prints it."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["eval", "--home", FAMILY, "--truth", BEN, "--days", "1", "--json"]) == 0
    return json.loads(out.getvalue())


def test_per_device_every_switch_is_counted_once_by_what_it_was(lived):
    devices = lived["devices"]
    assert list(devices) == list(load_home(FAMILY).device_names)
    assert all(set(d) == {"robot_switches", "undone", "missed", "fights"} for d in devices.values())
    days = lived["days"]
    total = {
        k: sum(d[k] for d in days) for k in ("robot_switches", "reversed", "household_switches", "fights")
    }
    assert sum(d["robot_switches"] for d in devices.values()) == total["robot_switches"]
    assert sum(d["undone"] for d in devices.values()) == total["reversed"] > 0
    # every switch of the household either undid the robot's or did what the robot missed
    assert sum(d["undone"] + d["missed"] for d in devices.values()) == total["household_switches"]
    assert sum(d["fights"] for d in devices.values()) == total["fights"]
    for name, d in devices.items():  # as the list of every switch says
        by = [s["by"] for s in lived["switches"] if s["device"] == name]
        assert (by.count("robot"), by.count("household")) == (d["robot_switches"], d["undone"] + d["missed"])


def test_per_service_the_switches_count_for_the_service_that_makes_them(lived):
    services = lived["services"]
    own = switch_services(load_home(FAMILY))
    assert set(services) == set(own.values())
    assert all(set(s) == {"done", "wrong", "missed", "fights"} for s in services.values())
    # the robot's switches of a device to a state count for the one service that makes it
    for (device, on), service in own.items():
        robot = sum(
            1
            for s in lived["switches"]
            if (s["device"], s["state"], s["by"]) == (device, "on" if on else "off", "robot")
        )
        assert services[service]["done"] == robot, service
    counted = {k: sum(s[k] for s in services.values()) for k in ("wrong", "missed")}
    devices = lived["devices"].values()
    assert counted == {
        "wrong": sum(d["undone"] for d in devices),
        "missed": sum(d["missed"] for d in devices),
    }


def test_the_text_and_the_report_name_what_went_wrong(lived, tmp_path, capsys):
    report = write_days_report(lived, tmp_path)
    text = report.read_text()
    wrong = [(n, d) for n, d in lived["devices"].items() if d["undone"] or d["missed"]]
    assert wrong
    worst_name, worst = max(wrong, key=lambda item: item[1]["undone"] + item[1]["missed"] + item[1]["fights"])
    assert "## What went wrong, per device" in text and "## What went wrong, per service" in text
    cells = (worst["robot_switches"], worst["undone"], worst["missed"], worst["fights"])
    assert f"| {worst_name} | {' | '.join(map(str, cells))} |" in text
    # the text: the studio's household switches by hand what the robot does not know of Kim
    assert main(["eval", "--home", STUDIO, "--truth", KIM, "--days", "1"]) == 0
    out = capsys.readouterr().out
    assert "What went wrong, per device" in out and "What went wrong, per service" in out
    assert "by hand: the household's switches the robot should have made" in out
    rows = [line.split("│")[1:-1] for line in out.splitlines() if line.startswith("│ desk_lamp ")]
    assert [[c.strip() for c in row] for row in rows] == [["desk_lamp", "0", "0", "1", "0"]]


def test_the_days_say_how_far_they_have_come():
    home, truth = load_home(STUDIO), load_home(KIM)
    said: list = []
    store = Store.open("sqlite://", home)
    try:
        closed_loop(home, truth, store, open_tree(home, store), days=2, progress=said.append)
    finally:
        store.close()
    assert len(said) == 48  # every simulated hour
    assert [(m.done, m.total) for m in said[:2]] == [(0, 2880), (60, 2880)]
    assert str(said[0]) == "day 1 of 2, 06:00"
    assert str(said[24]).startswith("day 2 of 2, 06:00 (day 1: robot ")


def test_where_nothing_went_wrong_no_table_is_drawn(lived):
    quiet = {
        key: {name: dict.fromkeys(row, 0) for name, row in lived[key].items()}
        for key in ("devices", "services")
    }
    assert faults_tables(quiet) == []
    assert [t.title for t in faults_tables(lived)] == [
        "What went wrong, per device",
        "What went wrong, per service",
    ]
