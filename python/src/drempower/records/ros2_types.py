"""ROS 2 message definitions (``ros2msg`` text) of the channels a recording holds.

Raw frames use ``can_msgs/msg/Frame`` (as ``ros2_socketcan`` publishes them),
motor states ``sensor_msgs/msg/JointState`` (SI units: rad, rad/s, Nm), and
parameter values and errors two small ``drempower_msgs`` types whose full text
travels in the file, so any ROS 2 MCAP reader decodes them.
"""

from __future__ import annotations

__all__ = [
    "frame_topic",
    "topic_type",
    "counter_of",
    "is_frame_topic",
    "FRAME",
    "JOINT_STATE",
    "PARAMETER_VALUE",
    "MOTOR_ERROR",
    "DEFINITIONS",
    "TOPICS",
]

_SEP = "=" * 80
_HEADER = (
    """MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
"""
    + _SEP
    + """
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""
)


def _with_header(body: str) -> str:
    return body + _SEP + "\n" + _HEADER


FRAME = "can_msgs/msg/Frame"
JOINT_STATE = "sensor_msgs/msg/JointState"
PARAMETER_VALUE = "drempower_msgs/msg/ParameterValue"
MOTOR_ERROR = "drempower_msgs/msg/MotorError"

DEFINITIONS: dict[str, str] = {
    FRAME: _with_header(
        "std_msgs/Header header\nuint32 id\nbool is_rtr\nbool is_extended\nbool is_error\nuint8 dlc\nuint8[8] data\n"
    ),
    JOINT_STATE: _with_header(
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n"
    ),
    PARAMETER_VALUE: _with_header(
        "std_msgs/Header header\nuint8 node\nuint16 address\nstring name\nstring unit\nfloat64 value\n"
    ),
    MOTOR_ERROR: _with_header("std_msgs/Header header\nuint8 node\nstring source\nuint32 code\nstring text\n"),
}
"""Message type name -> its ``ros2msg`` definition (with the dependencies it embeds)."""

TOPICS: dict[str, str] = {
    "/can/tx": FRAME,
    "/can/rx": FRAME,
    "/joint_states": JOINT_STATE,
    "/drempower/parameters": PARAMETER_VALUE,
    "/drempower/errors": MOTOR_ERROR,
}
"""Topic -> message type: frames the host sent, frames it received, states, parameter replies, errors."""


def frame_topic(tx: bool, bus: str | None = None) -> str:
    """The raw-frame topic: ``/can/tx``/``/can/rx``, or ``/can/<bus>/tx``/``/can/<bus>/rx`` for a robot's bus."""
    return f"/can{'' if bus is None else '/' + bus}/{'tx' if tx else 'rx'}"


def is_frame_topic(topic: str) -> bool:
    """True for ``/can/tx``, ``/can/rx`` and the per-bus ``/can/<bus>/tx``, ``/can/<bus>/rx``."""
    parts = topic.split("/")
    return len(parts) in (3, 4) and parts[1] == "can" and parts[-1] in ("tx", "rx") and all(parts[2:])


def topic_type(topic: str) -> str:
    """The message type of ``topic`` (raw-frame topics of every bus included); KeyError for others."""
    return FRAME if is_frame_topic(topic) else TOPICS[topic]


_COUNTERS = {JOINT_STATE: "states", PARAMETER_VALUE: "parameters", MOTOR_ERROR: "errors", FRAME: "frames_written"}


def counter_of(topic: str) -> str:
    """Which :class:`~drempower.records.sink.SinkStats` counter a message of ``topic`` adds to."""
    return _COUNTERS[topic_type(topic)]
