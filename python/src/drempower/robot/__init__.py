"""Several buses as one robot: joints by name, synchronised moves and stops across buses.

>>> import drempower
>>> with drempower.open_robot("robot.toml") as robot:          # doctest: +SKIP
...     move = robot.move_joints({"shoulder": 0.5, "elbow": -0.2}, speed=1.0, accel=5.0)
...     robot.positions_done()
...     print(f"{move.move_time} s, start skew {move.skew * 1e6:.0f} us")

The file format is described in :mod:`drempower.robotfile` and docs/robot.md.
"""

from typing import TYPE_CHECKING

from .._lazy import lazy_names

if TYPE_CHECKING:
    from .config import BusSpec, JointSpec, RobotSpec, load_robot, parse_robot
    from .joint import Gearing, JointState
    from .plan import SyncMove
    from .robot_async import AsyncJoint, AsyncRobot, open_robot_async
    from .robot_sync import Joint, Robot, open_robot

__all__ = [
    "AsyncJoint",
    "AsyncRobot",
    "BusSpec",
    "Gearing",
    "Joint",
    "JointSpec",
    "JointState",
    "Robot",
    "RobotSpec",
    "SyncMove",
    "load_robot",
    "open_robot",
    "open_robot_async",
    "parse_robot",
]

_HOMES = {
    "config": (
        "BusSpec",
        "JointSpec",
        "RobotSpec",
        "load_robot",
        "parse_robot",
    ),
    "joint": (
        "Gearing",
        "JointState",
    ),
    "plan": ("SyncMove",),
    "robot_async": (
        "AsyncJoint",
        "AsyncRobot",
        "open_robot_async",
    ),
    "robot_sync": (
        "Joint",
        "Robot",
        "open_robot",
    ),
}
__getattr__ = lazy_names(__name__, _HOMES)
