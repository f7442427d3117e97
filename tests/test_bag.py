"""A simulated run as a ROS 2 bag, read back as ROS tools read it: with rosbags (as
``ros2 bag`` does, through metadata.yaml) and with Foxglove's mcap-ros2-support (the MCAP file
alone)."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader

from homecog.errors import PlanningError
from homecog.home import Home, load_home
from homecog.planning import plan_services
from homecog.simulation import occupancy_grid, simulate
from homecog.simulation.bag import TOPICS, write_bag

START = 1_700_000_000_123_456_789
SERVICES = ["SendDrinks", "TurnOnLamp", "CloseWindow", "ChargeItSelf"]


@pytest.fixture(scope="module")
def run(paper: Home):
    plan = plan_services(paper, SERVICES, user="sofa")
    return simulate(paper, plan.actions, state=plan.start)


@pytest.fixture(scope="module")
def bag(paper: Home, run, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_bag(paper, run, tmp_path_factory.mktemp("bags") / "run", start_ns=START)


def ns(seconds: float) -> int:
    return START + round(seconds * 1e9)


def test_rosbags_reads_every_topic_back(paper: Home, run, bag: Path) -> None:
    with AnyReader([bag]) as reader:
        assert {c.topic: c.msgtype for c in reader.connections} == TOPICS
        got: dict[str, list[tuple[int, object]]] = {t: [] for t in TOPICS}
        for connection, timestamp, raw in reader.messages():
            got[connection.topic].append((timestamp, reader.deserialize(raw, connection.msgtype)))
    trajectory = run.trajectory
    assert len(got["/robot/pose"]) == len(got["/tf"]) == len(trajectory) == 1333
    # every pose where the simulation had the robot, at the simulation's time
    for (stamp, pose), (t, x, y, theta) in zip(got["/robot/pose"], trajectory, strict=True):
        assert stamp == ns(t) == pose.header.stamp.sec * 10**9 + pose.header.stamp.nanosec
        q = pose.pose.orientation
        assert (pose.header.frame_id, pose.pose.position.x, pose.pose.position.y) == ("map", x, y)
        assert math.isclose(2 * math.atan2(q.z, q.w), theta, abs_tol=1e-9) or math.isclose(
            abs(theta), math.pi, abs_tol=1e-9
        )
    last = got["/tf"][-1][1].transforms[0]
    assert (last.header.frame_id, last.child_frame_id) == ("map", "base_link")
    assert (last.transform.translation.x, last.transform.translation.y) == tuple(trajectory[-1, 1:3])
    # one String per action, as it starts
    assert [(s, m.data) for s, m in got["/robot/action"]] == [
        (ns(row["start"]), " ".join(row["action"])) for row in run.timeline
    ]
    assert got["/robot/action"][0][1].data == "move charger dispenser"
    # the path, once, with every pose
    ((stamp, path),) = got["/robot/path"]
    assert stamp == START and len(path.poses) == len(trajectory)
    assert (path.poses[-1].pose.position.x, path.poses[-1].pose.position.y) == tuple(trajectory[-1, 1:3])


def test_the_map_is_the_floor_plan(paper: Home, bag: Path) -> None:
    with AnyReader([bag]) as reader:
        ((connection, stamp, raw),) = list(
            reader.messages(connections=[c for c in reader.connections if c.topic == "/map"])
        )
        grid = reader.deserialize(raw, connection.msgtype)
    walls = occupancy_grid(paper.layout, radius=0.0).occupied
    assert (grid.info.width, grid.info.height, grid.info.resolution) == (
        200,
        160,
        np.float32(0.05),
    )  # 10 m by 8 m
    assert (grid.header.frame_id, stamp) == ("map", START)
    data = np.asarray(grid.data).reshape(grid.info.height, grid.info.width)
    assert np.array_equal(data == 100, walls) and set(np.unique(data)) == {0, 100}
    col, row = (int(c / 0.05) for c in paper.layout.place("sofa"))
    assert data[row, col] == 0  # the sofa is free; the outer wall is not
    assert data[0, 100] == 100


def test_the_map_and_path_are_latched(bag: Path) -> None:
    text = (bag / "metadata.yaml").read_text()
    assert "storage_identifier: mcap" in text and "version: 9" in text
    with AnyReader([bag]) as reader:
        durability = {c.topic: c.ext.offered_qos_profiles[0].durability.name for c in reader.connections}
    assert durability == {
        "/map": "TRANSIENT_LOCAL",
        "/robot/path": "TRANSIENT_LOCAL",
        "/robot/pose": "VOLATILE",
        "/tf": "VOLATILE",
        "/robot/action": "VOLATILE",
    }


def test_foxglove_s_reader_reads_the_mcap_file_alone(run, bag: Path) -> None:
    (mcap,) = bag.glob("*.mcap")
    counts: dict[str, int] = {}
    actions, times = [], []
    with mcap.open("rb") as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False):
            assert schema.encoding == "ros2msg" and channel.message_encoding == "cdr"
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            times.append(message.log_time)
            if channel.topic == "/robot/action":
                actions.append(decoded.data)
            elif channel.topic == "/map":
                assert (decoded.info.width, decoded.info.height) == (200, 160)
    assert counts == {"/map": 1, "/robot/path": 1, "/robot/pose": 1333, "/tf": 1333, "/robot/action": 10}
    assert actions == [" ".join(row["action"]) for row in run.timeline]
    assert times == sorted(times) and times[-1] == ns(run.seconds)  # written in time order


def test_simulate_writes_the_bag_and_never_overwrites_one(tmp_path: Path) -> None:
    out = tmp_path / "bag"
    args = [
        sys.executable,
        "-m",
        "homecog.cli.main",
        "simulate",
        "--services",
        "TurnOnLamp",
        "--bag",
        str(out),
    ]
    done = subprocess.run([*args, "--json"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert f'"bag": "{out}"' in done.stdout
    with AnyReader([out]) as reader:
        assert sum(c.msgcount for c in reader.connections if c.topic == "/robot/action") == 2  # move, switch
    again = subprocess.run(args, capture_output=True, text=True, timeout=120)
    assert (again.returncode, again.stderr) == (
        2,
        f"homecog: error: bag {out}: exists; a bag is written into a new folder\n",
    )


def test_a_home_without_a_floor_plan_has_no_bag(studio: Home, run, tmp_path: Path) -> None:
    with pytest.raises(PlanningError, match=r"^home 'studio' has no layout; a bag needs the floor plan$"):
        write_bag(studio, run, tmp_path / "bag")
    (tmp_path / "file").write_text("")
    with pytest.raises(PlanningError, match=r"is not a directory$"):
        write_bag(load_home("paper"), run, tmp_path / "file" / "bag")
