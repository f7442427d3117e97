"""A simulated run as a ROS 2 bag: MCAP storage and standard message types, written
with rosbags (no ROS installation), so that Foxglove or RViz replays it.

=====================  ===========================  ==============================================
topic                  type                         what
=====================  ===========================  ==============================================
``/map``               nav_msgs/msg/OccupancyGrid   the floor plan (walls 100, free 0), once at
                                                    the start, latched (transient local)
``/robot/path``        nav_msgs/msg/Path            the whole path the robot drives, once at the
                                                    start, latched
``/robot/pose``        geometry_msgs/msg/PoseStamped  the robot's pose at every simulation step
``/tf``                tf2_msgs/msg/TFMessage       the same pose as the transform map → base_link
``/robot/action``      std_msgs/msg/String          each action of the plan as it starts
                                                    (``move charger dispenser``)
=====================  ===========================  ==============================================

Every message is in the ``map`` frame (metres, x right, y up, the floor plan's origin at the
grid's corner); the bag's clock starts at ``start_ns`` (the wall clock when not given) and
follows the simulation's. The bag is a folder with ``metadata.yaml`` and one ``.mcap`` file
(rosbag2 format version 9, ROS 2 Jazzy's message definitions).

>>> import tempfile
>>> from pathlib import Path
>>> from homecog.home import load_home
>>> from homecog.planning import plan_services
>>> from homecog.simulation import simulate
>>> home = load_home("paper")
>>> run = simulate(home, plan_services(home, ["TurnOnLamp"], user="sofa").actions)
>>> folder = write_bag(home, run, Path(tempfile.mkdtemp()) / "run", start_ns=0)
>>> sorted(p.suffix for p in folder.iterdir())
['.mcap', '.yaml']
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from homecog.errors import PlanningError
from homecog.home.model import Home
from homecog.simulation.grid import RESOLUTION, occupancy_grid
from homecog.simulation.simulate import SimulationResult

FRAME, ROBOT_FRAME = "map", "base_link"
TOPICS = {
    "/map": "nav_msgs/msg/OccupancyGrid",
    "/robot/path": "nav_msgs/msg/Path",
    "/robot/pose": "geometry_msgs/msg/PoseStamped",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/robot/action": "std_msgs/msg/String",
}
LATCHED = ("/map", "/robot/path")


def check_bag_folder(path: Path) -> None:
    """Fail before the simulation, not after it, when the bag cannot be written there: the folder
    must not exist (a bag is never overwritten) and its parent must be writable."""
    if path.exists():
        raise PlanningError(f"bag {path}: exists; a bag is written into a new folder")
    parent = next((p for p in path.parents if p.exists()), Path("."))
    if not parent.is_dir():
        raise PlanningError(f"bag {path}: cannot write there: {parent} is not a directory")


def _qos(latched: bool) -> list[Any]:
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    never = QosTime(0x7FFFFFFF, 0xFFFFFFFF)  # rosbag2's "infinite" duration
    return [
        Qos(
            QosHistory.KEEP_LAST,
            1 if latched else 10,
            QosReliability.RELIABLE,
            QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE,
            never,
            never,
            QosLiveliness.AUTOMATIC,
            never,
            False,
        )
    ]


def write_bag(home: Home, run: SimulationResult, path: Path, *, start_ns: int | None = None) -> Path:
    """Write ``run`` (of ``home``, which has a layout) as a ROS 2 bag into the new folder ``path``."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    if home.layout is None:
        raise PlanningError(f"home {home.name!r} has no layout; a bag needs the floor plan")
    check_bag_folder(path)
    store = get_typestore(Stores.ROS2_JAZZY)
    t = store.types
    start = time.time_ns() if start_ns is None else int(start_ns)

    def stamp(seconds: float) -> Any:
        ns = start + round(seconds * 1e9)
        return t["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def header(seconds: float, frame: str = FRAME) -> Any:
        return t["std_msgs/msg/Header"](stamp=stamp(seconds), frame_id=frame)

    def pose(x: float, y: float, theta: float) -> Any:
        return t["geometry_msgs/msg/Pose"](
            position=t["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
            orientation=t["geometry_msgs/msg/Quaternion"](
                x=0.0, y=0.0, z=math.sin(theta / 2), w=math.cos(theta / 2)
            ),
        )

    rows = [(float(s), float(x), float(y), float(th)) for s, x, y, th in run.trajectory]
    stamped = [
        t["geometry_msgs/msg/PoseStamped"](header=header(s), pose=pose(x, y, th)) for s, x, y, th in rows
    ]
    messages: list[tuple[float, str, Any]] = [
        (0.0, "/map", _grid(home, t, header(0.0))),
        (0.0, "/robot/path", t["nav_msgs/msg/Path"](header=header(0.0), poses=stamped)),
    ]
    for (s, x, y, _), message in zip(rows, stamped, strict=True):
        messages.append((s, "/robot/pose", message))
        transform = t["geometry_msgs/msg/Transform"](
            translation=t["geometry_msgs/msg/Vector3"](x=x, y=y, z=0.0), rotation=message.pose.orientation
        )
        child = t["geometry_msgs/msg/TransformStamped"](
            header=header(s), child_frame_id=ROBOT_FRAME, transform=transform
        )
        messages.append((s, "/tf", t["tf2_msgs/msg/TFMessage"](transforms=[child])))
    for row in run.timeline:
        messages.append(
            (float(row["start"]), "/robot/action", t["std_msgs/msg/String"](data=" ".join(row["action"])))
        )
    messages.sort(key=lambda m: m[0])  # stable: at one moment the map and path come first

    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = {
            topic: writer.add_connection(
                topic, kind, typestore=store, offered_qos_profiles=_qos(topic in LATCHED)
            )
            for topic, kind in TOPICS.items()
        }
        for seconds, topic, message in messages:
            data = store.serialize_cdr(message, TOPICS[topic])
            writer.write(connections[topic], start + round(seconds * 1e9), data)
    return path


def _grid(home: Home, t: Any, head: Any) -> Any:
    """The floor plan's walls as an occupancy grid: a cell is occupied where a wall covers its
    centre (the robot's radius not added: that is the planner's grid, not the plan's)."""
    grid = occupancy_grid(home.layout, radius=0.0)  # type: ignore[arg-type]
    rows, cols = grid.occupied.shape
    # ROS: row-major from the origin, x along a row, y across rows; ours is [row = y, col = x]
    data = np.where(grid.occupied, 100, 0).astype(np.int8).ravel()
    info = t["nav_msgs/msg/MapMetaData"](
        map_load_time=head.stamp,
        resolution=float(RESOLUTION),
        width=cols,
        height=rows,
        origin=t["geometry_msgs/msg/Pose"](
            position=t["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
            orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
        ),
    )
    return t["nav_msgs/msg/OccupancyGrid"](header=head, info=info, data=data)
