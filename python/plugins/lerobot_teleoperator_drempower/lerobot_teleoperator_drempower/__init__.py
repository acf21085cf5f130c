"""LeRobot's ``drempower_leader`` teleoperator: a DrEmpower arm in teach mode, its joint positions the actions.

LeRobot finds this package by its name (``lerobot_teleoperator_*``) and imports it, which registers the
teleoperator type: ``lerobot-teleoperate --teleop.type=drempower_leader --teleop.robot_file=leader.toml ...``.
"""

from .config_drempower_leader import DrEmpowerLeaderConfig
from .drempower_leader import DrEmpowerLeader

__all__ = ["DrEmpowerLeader", "DrEmpowerLeaderConfig"]
