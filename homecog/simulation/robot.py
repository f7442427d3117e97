"""A differential-drive robot that follows waypoints.

It turns on the spot towards the next waypoint, then drives straight to it, never faster than
its linear and angular limits, integrated with a fixed time step. Turning and driving never
happen together, so the robot stays exactly on the straight segments the path planner
checked for clearance.

>>> robot = DiffDrive()
>>> poses = robot.follow([(0.0, 0.0), (1.0, 0.0)], theta=0.0)
>>> poses[-1].tolist()                                # t, x, y, theta: 1 m at 0.5 m/s
[2.0, 1.0, 0.0, 0.0]
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from homecog.home.layout import Point2


@dataclass(frozen=True)
class DiffDrive:
    """A differential-drive robot's limits and its control step."""

    max_linear: float = 0.5
    """Top linear speed, m/s."""
    max_angular: float = 1.2
    """Top angular speed, rad/s."""
    dt: float = 0.05
    """Integration and control step, seconds."""
    radius: float = 0.2
    """Radius of the robot's round footprint, metres; the path planner keeps it off walls."""

    def __post_init__(self) -> None:
        for name in ("max_linear", "max_angular", "dt", "radius"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"DiffDrive.{name} must be a positive number, got {value!r}")

    def follow(self, waypoints: Sequence[Point2], *, theta: float, t: float = 0.0) -> np.ndarray:
        """The poses ``(t, x, y, theta)`` after each step of driving through ``waypoints``,
        starting at the first waypoint with heading ``theta`` at time ``t``; shape (steps, 4),
        empty when there is nowhere to go. The last pose is exactly at the last waypoint.

        >>> poses = DiffDrive().follow([(0.0, 0.0), (0.0, 1.0)], theta=0.0)
        >>> len(poses), poses[-1].round(4).tolist()   # turn 90° (27 steps), drive 1 m (40 steps)
        (67, [3.35, 0.0, 1.0, 1.5708])
        """
        x, y = map(float, waypoints[0]) if waypoints else (0.0, 0.0)
        poses: list[tuple[float, float, float, float]] = []
        step = 0
        turn, drive = self.max_angular * self.dt, self.max_linear * self.dt
        for wx, wy in waypoints[1:]:
            length = math.hypot(wx - x, wy - y)
            if length < 1e-9:
                continue
            heading = math.atan2(wy - y, wx - x)
            while (left := _wrap(heading - theta)) != 0.0:
                theta = heading if abs(left) <= turn else _wrap(theta + math.copysign(turn, left))
                step += 1
                poses.append((t + step * self.dt, x, y, theta))
            x0, y0, travelled = x, y, 0.0
            while travelled < length:
                travelled = min(length, travelled + drive)
                if travelled == length:
                    x, y = float(wx), float(wy)  # land exactly on the waypoint
                else:
                    x, y = x0 + travelled * math.cos(heading), y0 + travelled * math.sin(heading)
                step += 1
                poses.append((t + step * self.dt, x, y, theta))
        return np.array(poses, dtype=float).reshape(-1, 4)


def _wrap(angle: float) -> float:
    """An angle in (-π, π]."""
    wrapped = math.remainder(angle, math.tau)
    return math.pi if wrapped == -math.pi else wrapped
