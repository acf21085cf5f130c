"""LeRobot's ``drempower`` follower robot: a DrEmpower arm from its robot file.

LeRobot finds this package by its name (``lerobot_robot_*``) and imports it, which registers the
robot type: ``lerobot-teleoperate --robot.type=drempower --robot.robot_file=arm.toml ...``.
"""

from .config_drempower_follower import DrEmpowerFollowerConfig
from .drempower_follower import DrEmpowerFollower

__all__ = ["DrEmpowerFollower", "DrEmpowerFollowerConfig"]
