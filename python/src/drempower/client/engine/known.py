"""What the session knows about each motor: its latest state, whether it answered, the parameters the
client relies on, whether this bus commanded it, and the last position move it was sent."""

from __future__ import annotations

import dataclasses

from ...protocol.addresses import (
    AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE,
    AXIS0_REQUESTED_STATE,
    AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE,
)
from ...protocol.ids import Frame, SysCmd
from ...protocol.limits import MOTION_CMDS
from ...protocol.messages import Message, PositionP, PositionQ, PositionT, WriteParam
from .state import MotorState

__all__ = ["Known", "MoveRecord"]

_POSITION_CMDS = (PositionT, PositionQ, PositionP)
_RESETS = frozenset((SysCmd.INIT_CONFIG, SysCmd.ERASE_CONFIG, SysCmd.REBOOT))


@dataclasses.dataclass(slots=True)
class MoveRecord:
    """The last position move this bus commanded to one motor (what a wait for it checks).

    ``target`` deg (None when unknown), ``sent`` the session time its command
    or start was sent, ``move_time`` the planned duration (s, Q-mode
    synchronised moves) and ``took`` the arrival time of the first state with
    T = 0 after ``sent`` (the motor showed it took the move; None until then).
    ``resend`` holds the node-addressed messages that started it (the motor's
    preset and a start to that motor only, or the direct position command),
    sent again when a wait finds the move lost (see
    :func:`~drempower.client.engine.ops.wait_done`); empty when unknown.
    """

    target: float | None
    sent: float
    move_time: float | None = None
    took: float | None = None
    resend: tuple[Message, ...] = ()


class Known:
    """Facts about the motors, per node id; filled by what the bus sends and receives (no I/O)."""

    __slots__ = ("commanded", "frame_times", "heard", "moves", "reply_state", "states", "traj_mode")

    def __init__(self) -> None:
        self.states: dict[int, MotorState] = {}
        """The latest state of every motor heard from."""
        self.frame_times: dict[int, float] = {}
        """When each latest state was on the wire by its transport's own clock (see
        :class:`~drempower.protocol.ids.TimedFrame`), else when it arrived (s, monotonic scale)."""
        self.heard: set[int] = set()
        """Motors that answered a request."""
        self.traj_mode: dict[int, int] = {}
        """Known ``traj_mode`` (35104) per motor: read from it or set through this bus."""
        self.reply_state: dict[int, bool] = {}
        """Known ``enable_reply_state`` (31214) per motor."""
        self.moves: dict[int, MoveRecord] = {}
        """The last position move per motor (see :class:`MoveRecord`); other motion commands drop it."""
        self.commanded: set[int] = set()
        """Motors this bus has sent motion commands or a requested state to (0 = broadcast)."""

    def forget(self, node: int) -> None:
        """Drop the learned parameters of ``node`` (every motor for 0): after a reboot, id change or config reset."""
        if node == 0:
            self.traj_mode.clear()
            self.reply_state.clear()
        else:
            self.traj_mode.pop(node, None)
            self.reply_state.pop(node, None)

    def learn(self, node: int, address: int, value: float) -> None:
        """Record a parameter value this bus read or wrote when the client relies on it.

        A broadcast write (node 0) makes the value of every motor unknown until read.
        """
        if address == AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE:
            if node == 0:
                self.traj_mode.clear()
            elif value in (1, 2):
                self.traj_mode[node] = int(value)
            else:  # not a mode a move can be timed with: read it again (and refuse it) when needed
                self.traj_mode.pop(node, None)
        elif address == AXIS0_CONFIG_EXTRA_SETTING_ENABLE_REPLY_STATE:
            if node == 0:
                self.reply_state.clear()
            else:
                self.reply_state[node] = bool(value)

    def note(self, msg: Message, frame: Frame, now: float) -> None:
        """Track what ``msg`` (encoded as ``frame``, sent at ``now`` s) changes: commanded motors, moves,
        remembered parameters."""
        cmd = msg.cmd
        if cmd in MOTION_CMDS:
            self.commanded.add(msg.node)
            if cmd != 0x0C:  # a preset changes nothing until its start
                self.new_move(msg, now)
        elif isinstance(msg, WriteParam):
            if msg.address == AXIS0_REQUESTED_STATE:
                self.commanded.add(msg.node)
            else:
                self.learn(msg.node, msg.address, msg.value)
        elif cmd == 0x08 and frame[1][0] in _RESETS:
            self.forget(msg.node)

    def new_move(self, msg: Message, now: float) -> None:
        """Record the position move a direct command sent at ``now`` (s) starts; any other motion command
        ends the record (a broadcast one, every motor's)."""
        node = msg.node
        if node == 0:
            self.moves.clear()
        elif isinstance(msg, _POSITION_CMDS):
            self.moves[node] = MoveRecord(msg.position, now, resend=(msg,))
        else:
            self.moves.pop(node, None)
