"""``drempower bridge``'s ros2_control faces: TopicBasedSystem's topics and the FollowJointTrajectory action.

Their settings come from the options, over the robot file's ``[ros2_control]`` table.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from typing import Any

from ._usage import UsageError

__all__ = ["add_ros2_control_args", "start_ros2_control", "Ros2Control"]


def _interfaces(text: str) -> tuple[str, ...]:
    from ..bridge.joint_topics import check_interfaces

    try:
        return check_interfaces(text.split(","))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("command_interfaces: ")) from exc


def add_ros2_control_args(p: argparse.ArgumentParser) -> None:
    """The ros2_control faces' options (defaults: the robot file's ``[ros2_control]``, else TopicBasedSystem's)."""
    g = p.add_argument_group("ros2_control (TopicBasedSystem and FollowJointTrajectory)")
    g.add_argument(
        "--joint-commands",
        metavar="TOPIC",
        help="TopicBasedSystem's joint_commands_topic, sensor_msgs/JointState (default /robot_joint_commands)",
    )
    g.add_argument(
        "--joint-states",
        metavar="TOPIC",
        help="TopicBasedSystem's joint_states_topic, published at --rate (default /robot_joint_states)",
    )
    g.add_argument(
        "--command-interfaces",
        type=_interfaces,
        metavar="LIST",
        help="the joints' command interfaces in the URDF: position, velocity, effort, or a combination such as "
        "position,velocity (default position)",
    )
    g.add_argument(
        "--action",
        metavar="NAME",
        help="the FollowJointTrajectory action's name (default follow_joint_trajectory)",
    )
    g.add_argument(
        "--no-ros2-control",
        action="store_true",
        help="serve neither TopicBasedSystem's topics nor the action",
    )


@dataclass
class Ros2Control:
    """The faces started on a bridge; :meth:`close` before the bridge's."""

    parts: list[Any] = field(default_factory=list)

    def keys(self) -> dict[str, str]:
        """Zenoh keys of what is served, for ``--json``."""
        out: dict[str, str] = {}
        for part in self.parts:
            if hasattr(part, "commands_key"):
                out.update(joint_commands=part.commands_key, robot_joint_states=part.states_key)
            else:
                out.update({f"action_{role}": key for role, key in part.keys.items()})
        return out

    def close(self) -> None:
        for part in reversed(self.parts):
            part.close()


def start_ros2_control(bridge: Any, args: argparse.Namespace, spec: Any) -> Ros2Control:
    """Start the faces on ``bridge`` as the options and the robot file ``spec`` (or None) say."""
    from ..bridge.joint_topics import DEFAULT_COMMANDS_TOPIC, DEFAULT_STATES_TOPIC, JointTopics
    from ..bridge.trajectory_action import DEFAULT_ACTION, TrajectoryAction

    out = Ros2Control()
    if args.no_ros2_control:
        return out
    conf = dict(getattr(spec, "ros2_control", None) or {})
    try:
        out.parts.append(
            JointTopics(
                bridge,
                args.joint_commands or conf.get("joint_commands_topic", DEFAULT_COMMANDS_TOPIC),
                args.joint_states or conf.get("joint_states_topic", DEFAULT_STATES_TOPIC),
                interfaces=args.command_interfaces or conf.get("command_interfaces", ("position",)),
                kp=conf.get("kp", 20.0),
                kd=conf.get("kd", 1.0),
            )
        )
        action = TrajectoryAction(bridge, args.action or conf.get("action", DEFAULT_ACTION))
        out.parts.append(action)
        out.parts[0].busy = action.running  # JointState commands wait while a goal runs
    except ValueError as exc:
        out.close()
        raise UsageError(f"ros2_control: {exc}") from exc
    return out
