"""ROS 2 actions over rmw_zenoh: the types rosidl generates for an action, and where they travel.

An action ``NAME`` of type ``pkg/action/Act`` is three services and two topics
(rmw_zenoh maps them as any service and topic, names under ``NAME/_action/``):

================  ===========================================  =============================
``send_goal``     service ``pkg/action/Act_SendGoal``          goal id + goal -> accepted
``cancel_goal``   service ``action_msgs/srv/CancelGoal``       goal info -> goals canceling
``get_result``    service ``pkg/action/Act_GetResult``         goal id -> status + result
``feedback``      topic ``pkg/action/Act_FeedbackMessage``     goal id + feedback
``status``        topic ``action_msgs/msg/GoalStatusArray``    every goal's status
================  ===========================================  =============================

:func:`register_action` adds an action's types to a ``rosbags`` type store from
its ``.action`` text, so their CDR and RIHS01 hashes come from the definitions.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING, Any

from . import rosmsg

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

__all__ = [
    "FOLLOW_JOINT_TRAJECTORY",
    "CANCEL_GOAL",
    "GOAL_STATUS_ARRAY",
    "ROLES",
    "STATUS",
    "ERROR",
    "register_action",
    "role_type",
    "typestore",
]

FOLLOW_JOINT_TRAJECTORY = "control_msgs/action/FollowJointTrajectory"
CANCEL_GOAL = "action_msgs/srv/CancelGoal"
GOAL_STATUS_ARRAY = "action_msgs/msg/GoalStatusArray"
ROLES = ("send_goal", "cancel_goal", "get_result", "feedback", "status")
STATUS = {"UNKNOWN": 0, "ACCEPTED": 1, "EXECUTING": 2, "CANCELING": 3, "SUCCEEDED": 4, "CANCELED": 5, "ABORTED": 6}
"""``action_msgs/msg/GoalStatus`` values."""
ERROR = {
    "SUCCESSFUL": 0,
    "INVALID_GOAL": -1,
    "INVALID_JOINTS": -2,
    "OLD_HEADER_TIMESTAMP": -3,
    "PATH_TOLERANCE_VIOLATED": -4,
    "GOAL_TOLERANCE_VIOLATED": -5,
}
"""``FollowJointTrajectory`` result error codes."""

MESSAGES: dict[str, str] = {
    "control_msgs/msg/JointTolerance": "string name\nfloat64 position\nfloat64 velocity\nfloat64 acceleration\n",
    "control_msgs/msg/JointComponentTolerance": (
        "uint16 X_AXIS=1\nuint16 Y_AXIS=2\nuint16 Z_AXIS=3\nuint16 TRANSLATION=4\nuint16 ROTATION=5\n"
        "string joint_name\nuint16 component\nfloat64 position\nfloat64 velocity\nfloat64 acceleration\n"
    ),
}
"""Messages of the actions' definitions that the Jazzy store lacks (control_msgs, ros2_control's Jazzy release)."""
ACTIONS: dict[str, str] = {
    FOLLOW_JOINT_TRAJECTORY: """\
trajectory_msgs/JointTrajectory trajectory
trajectory_msgs/MultiDOFJointTrajectory multi_dof_trajectory
JointTolerance[] path_tolerance
JointComponentTolerance[] component_path_tolerance
JointTolerance[] goal_tolerance
JointComponentTolerance[] component_goal_tolerance
builtin_interfaces/Duration goal_time_tolerance
---
int32 error_code
int32 SUCCESSFUL = 0
int32 INVALID_GOAL = -1
int32 INVALID_JOINTS = -2
int32 OLD_HEADER_TIMESTAMP = -3
int32 PATH_TOLERANCE_VIOLATED = -4
int32 GOAL_TOLERANCE_VIOLATED = -5
string error_string
---
std_msgs/Header header
string[] joint_names
trajectory_msgs/JointTrajectoryPoint desired
trajectory_msgs/JointTrajectoryPoint actual
trajectory_msgs/JointTrajectoryPoint error
string[] multi_dof_joint_names
trajectory_msgs/MultiDOFJointTrajectoryPoint multi_dof_desired
trajectory_msgs/MultiDOFJointTrajectoryPoint multi_dof_actual
trajectory_msgs/MultiDOFJointTrajectoryPoint multi_dof_error
""",
}
"""Definitions (``.action`` text) of the actions the bridge serves."""
_CANCEL = """\
GoalInfo goal_info
---
int8 ERROR_NONE=0
int8 ERROR_REJECTED=1
int8 ERROR_UNKNOWN_GOAL_ID=2
int8 ERROR_GOAL_TERMINATED=3
int8 return_code
GoalInfo[] goals_canceling
"""


def register_action(store: Typestore, name: str, definition: str) -> None:
    """Add action ``name`` (``pkg/action/Act``) given by its ``.action`` text to ``store``, as rosidl does:
    ``Act_Goal``, ``Act_Result``, ``Act_Feedback``, the services ``Act_SendGoal`` and ``Act_GetResult``
    (with their request, response and event types) and ``Act_FeedbackMessage``."""
    from rosbags.typesys import get_types_from_msg

    parts = _split(definition, name)
    pkg, _, short = name.split("/")
    uuid = "unique_identifier_msgs/UUID goal_id\n"
    texts = {
        f"{short}_Goal": parts[0],
        f"{short}_Result": parts[1],
        f"{short}_Feedback": parts[2],
        f"{short}_FeedbackMessage": f"{uuid}{short}_Feedback feedback\n",
    }
    services = {
        f"{short}_SendGoal": (f"{uuid}{short}_Goal goal\n", "bool accepted\nbuiltin_interfaces/Time stamp\n"),
        f"{short}_GetResult": (uuid, f"int8 status\n{short}_Result result\n"),
    }
    for service, (request, response) in services.items():
        texts.update(rosmsg.service_texts(service, request, response))
    # rosbags files every parsed type under msg/: parse there, then move the action's types to action/.
    moved = {f"{pkg}/msg/{n}": f"{pkg}/action/{n}" for n in texts}
    types: dict[str, Any] = {}
    for typename, text in texts.items():
        for key, (consts, fields) in get_types_from_msg(text, f"{pkg}/msg/{typename}").items():
            types[moved.get(key, key)] = (consts, [(n, rosmsg._rename(d, moved)) for n, d in fields])
    store.register(types)


def _split(definition: str, name: str) -> list[str]:
    parts: list[list[str]] = [[]]
    for line in definition.splitlines():
        if line.strip() == "---":
            parts.append([])
        else:
            parts[-1].append(line)
    if len(parts) != 3:
        raise ValueError(f"action {name}: its definition has {len(parts) - 1} '---' lines, an action has 2")
    return ["\n".join(p) + "\n" if any(line.strip() for line in p) else rosmsg._PLACEHOLDER for p in parts]


def role_type(action_type: str, role: str) -> str:
    """The service or message type of ``role`` (one of :data:`ROLES`) of an action of type ``action_type``."""
    return {
        "send_goal": f"{action_type}_SendGoal",
        "cancel_goal": CANCEL_GOAL,
        "get_result": f"{action_type}_GetResult",
        "feedback": f"{action_type}_FeedbackMessage",
        "status": GOAL_STATUS_ARRAY,
    }[role]


@functools.lru_cache(maxsize=1)
def typestore() -> Typestore:
    """The bridge's type store (:func:`drempower.bridge.rosmsg.typestore`) with the actions' types added."""
    store = rosmsg.typestore()
    if FOLLOW_JOINT_TRAJECTORY + "_Goal" not in store.fielddefs:
        from rosbags.typesys import get_types_from_msg

        for name, text in MESSAGES.items():
            store.register(get_types_from_msg(text, name))
        rosmsg.register_service(store, CANCEL_GOAL, _CANCEL)
        for name, definition in ACTIONS.items():
            register_action(store, name, definition)
    return store
