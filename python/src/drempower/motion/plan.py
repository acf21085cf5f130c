"""A trajectory made ready to follow (no I/O): checked against the joints' limits and the bus's
capacity before anything moves, each cycle's commands made from it as the cycle comes (the memory a
plan takes does not grow with its duration; :data:`MAX_DURATION` bounds the time its checks take).

:mod:`drempower.motion.follow_async` (and the generated ``follow_sync``) streams a :class:`FollowPlan`.
"""

from __future__ import annotations

import math
from collections.abc import Awaitable, Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

from ..client.engine.commands import AxisMode, PositionMode, make_angle, make_impedance
from ..client.engine.effects import Batch, Op, read_states
from ..client.engine.ops import set_mode
from ..client.engine.state import MotorState
from ..errors import FollowError, ValidationError
from ..protocol.messages import Message, StartImpedance
from ..sim.timing import frame_bits
from .trajectory import Rows, Trajectory

if TYPE_CHECKING:
    from ..robotfile import RobotSpec

_States = dict[int, MotorState]
AsyncEach = Callable[[Mapping[str, Callable[[], Awaitable[_States]]]], Awaitable[dict[str, _States]]]
"""How the asyncio follower runs each bus's part of a cycle (the robot's ``_each``, or inline for a bus)."""
SyncEach = Callable[[Mapping[str, Callable[[], _States]]], dict[str, _States]]
"""The same for the threaded follower."""

__all__ = [
    "MAX_DURATION",
    "MODES",
    "AsyncEach",
    "SyncEach",
    "FollowError",
    "FollowPlan",
    "FollowReport",
    "Lane",
    "Units",
    "bus_rate_limit",
    "model_ranges",
    "robot_lanes",
    "robot_limits",
    "make_plan",
    "as_trajectory",
]

Mode = Literal["position", "impedance", "p"]
MODES: tuple[str, ...] = ("position", "impedance", "p")
"""``position``: filtered position (T); ``impedance``: position, velocity and torque feed-forward with
``kp``/``kd``; ``p``: position with speed and torque feed-forward (P)."""
_STATE_BITS = 135
"""Most bits a state reply (8 data bytes) takes on the wire, stuffing included."""
_RPM_PER_RAD_S = 60 / (2 * math.pi)


class Units:
    """A joint seen in the trajectory's units (rad at a robot's joint, or deg for a bare motor) and in
    wire units: ``gear``/``offset`` as a robot file's (deg units: gear 1 and the identity)."""

    __slots__ = ("deg", "gear", "offset", "unit")

    def __init__(self, gear: float = 1.0, offset: float = 0.0, *, deg: bool = False) -> None:
        self.gear, self.offset, self.deg = gear, offset, deg
        self.unit = "deg" if deg else "rad"

    def angle(self, x: float) -> float:
        """Motor angle (deg) of position ``x``."""
        return x if self.deg else math.degrees((x - self.offset) * self.gear)

    def speed(self, v: float) -> float:
        """Motor speed (r/min) of velocity ``v`` (unit/s)."""
        return v / 6.0 if self.deg else v * self.gear * _RPM_PER_RAD_S

    def torque(self, tau: float) -> float:
        """Motor torque (Nm) of a joint torque ``tau`` (Nm)."""
        return tau if self.deg else tau / self.gear

    def position(self, st: MotorState) -> float:
        """The measured position of state ``st`` in the trajectory's units."""
        return st.angle if self.deg else math.radians(st.angle) / self.gear + self.offset


@dataclass
class Lane:
    """The joints of one bus: ``names``, motor ``ids`` and their :class:`Units`, in trajectory order
    (``index``: each joint's column in the trajectory)."""

    bus: str
    names: list[str]
    ids: list[int]
    units: list[Units]
    index: list[int]
    on_timeout: list[str]
    bitrate: int | None = None
    reply_state: Mapping[int, bool] = field(default_factory=dict)


@dataclass
class FollowReport:
    """How a trajectory was followed: ``max_error`` (joint -> largest tracking error, rad at a joint,
    deg for a motor), ``late`` (cycles that ended after the next was due), ``rate`` (achieved Hz),
    ``duration`` (s), ``cycles`` sent, and ``stopped`` (why it stopped early, or None)."""

    max_error: dict[str, float]
    late: int = 0
    rate: float = 0.0
    duration: float = 0.0
    cycles: int = 0
    stopped: str | None = None
    trace: list[tuple[float, list[float], list[float]]] | None = None
    """With ``trace=True``: (time s, reference, measured) per state read, joints in trajectory order."""

    def as_dict(self) -> dict[str, Any]:
        """The report as JSON-ready data (no trace)."""
        return {
            "max_error": self.max_error,
            "late": self.late,
            "rate": self.rate,
            "duration": self.duration,
            "cycles": self.cycles,
            "stopped": self.stopped,
        }


MAX_DURATION = 600.0
"""The longest trajectory (s) a plan follows: its checks sample every cycle before anything moves, so
a longer one is refused (split it) rather than keeping its caller (a goal, an enable) waiting."""


class CycleTimes(Sequence[float]):
    """The time (s) of each cycle of a plan: ``k / rate``, the last at the trajectory's end (no list)."""

    def __init__(self, count: int, rate: float, duration: float) -> None:
        self._count, self._rate, self._duration = count, rate, duration

    def __len__(self) -> int:
        return self._count + 1

    def __getitem__(self, k: Any) -> Any:
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(self)))]
        if not -len(self) <= k < len(self):
            raise IndexError(k)
        k %= len(self)
        return min(k / self._rate, self._duration)


class CycleCommands(Sequence[dict[str, list[Message]]]):
    """Each cycle's commands per bus, made from the trajectory when asked for (no list of them all)."""

    def __init__(self, times: CycleTimes, make: Callable[[float], dict[str, list[Message]]]) -> None:
        self._times, self._make = times, make

    def __len__(self) -> int:
        return len(self._times)

    def __getitem__(self, k: Any) -> Any:
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(self)))]
        return self._make(self._times[k])


@dataclass
class FollowPlan:
    """A checked trajectory: each cycle's commands per bus, made as the cycle comes."""

    trajectory: Trajectory
    lanes: list[Lane]
    rate: float
    mode: str
    times: Sequence[float]
    commands: Sequence[dict[str, list[Message]]]
    max_error: list[float]
    timeout: float | None
    bandwidth: float
    unit: str

    def cycle_op(self, k: int, lane: Lane) -> Op[dict[int, MotorState]]:
        """The operation of cycle ``k`` on ``lane`` for an impedance cycle (presets, one start, reads)."""
        return _impedance_cycle(self.commands[k][lane.bus], lane.ids, self.timeout)

    def hold_messages(self, lane: Lane, states: Mapping[int, MotorState]) -> list[Message]:
        """What stops ``lane``'s joints: hold where each is (T mode), or idle where the joint says so."""
        out: list[Message] = []
        for i, how in zip(lane.ids, lane.on_timeout, strict=True):
            st = states.get(i)
            if how == "idle":
                out.append(set_mode(i, AxisMode.IDLE))
            elif st is not None:  # no state yet: the last command stands
                out.append(make_angle(i, st.angle, 0.0, self.bandwidth, PositionMode.T))
        return out


def _impedance_cycle(msgs: list[Message], ids: list[int], timeout: float | None) -> Op[dict[int, MotorState]]:
    start = msgs[-1]
    assert isinstance(start, StartImpedance)
    yield Batch(msgs[:-1], start)
    states = yield from read_states(ids, timeout)
    return {i: st for i, st in zip(ids, states, strict=True) if st is not None}


def as_trajectory(
    times: Sequence[float] | Trajectory,
    positions: Rows | None,
    velocities: Rows | None,
    joints: Iterable[str] | None,
    default: Sequence[str],
) -> Trajectory:
    """``follow``'s arguments as a :class:`Trajectory` (its joints ``joints``, else a mapping's, else ``default``)."""
    if isinstance(times, Trajectory):
        if positions is not None or velocities is not None:
            raise ValidationError("follow: give a Trajectory, or times and positions, not both")
        return times if joints is None else times.select(list(joints))
    if positions is None:
        raise ValidationError("follow: positions missing: one row per time, or joint -> positions")
    names = joints if joints is not None or isinstance(positions, Mapping) else default
    return Trajectory(times, positions, velocities, joints=names)


def robot_lanes(
    spec: RobotSpec,
    joints: Sequence[str],
    bitrate: Callable[[str], int | None],
    reply_state: Callable[[str], Mapping[int, bool]],
) -> list[Lane]:
    """The lanes (one per bus, in the order met) of the robot joints ``joints`` (trajectory order);
    ``bitrate(bus)`` and ``reply_state(bus)`` say what is known of each bus."""
    lanes: dict[str, Lane] = {}
    for j, name in enumerate(joints):
        js = spec.joints.get(name)
        if js is None:
            raise ValidationError(f"joint {name!r}: no such joint (joints: {', '.join(spec.joints)})")
        lane = lanes.get(js.bus)
        if lane is None:
            lane = lanes[js.bus] = Lane(js.bus, [], [], [], [], [], bitrate(js.bus), reply_state(js.bus))
        lane.names.append(name)
        lane.ids.append(js.id)
        lane.units.append(Units(js.gear, js.offset))
        lane.index.append(j)
        lane.on_timeout.append(str(getattr(js, "on_timeout", "hold")))
    return list(lanes.values())


def robot_limits(
    spec: RobotSpec, joints: Sequence[str], model_range: Callable[[str], tuple[float, float] | None] | None
) -> dict[str, dict[str, Any]]:
    """What is known of each joint's limits: the robot file's ``limits``, else the model's joint range
    (``model_range(model_joint)``)."""
    out: dict[str, dict[str, Any]] = {}
    for name in joints:
        js = spec.joints[name]
        own = dict(getattr(js, "limits", None) or {})
        if own:
            out[name] = {**own, "source": f"{spec.source} [joints.{name}] limits"}
        elif model_range is not None:
            rng = model_range(js.model_joint or name)
            if rng is not None:
                out[name] = {"position": rng, "source": f"the range of model joint {js.model_joint or name!r}"}
    return out


def model_ranges(model: Any) -> Callable[[str], tuple[float, float] | None]:
    """``range(joint)`` of a MuJoCo model (``mujoco.MjModel``): the joint's (low, high) rad, None when unlimited."""
    import mujoco

    def joint_range(joint: str) -> tuple[float, float] | None:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint)
        if jid < 0 or not model.jnt_limited[jid]:
            return None
        return float(model.jnt_range[jid][0]), float(model.jnt_range[jid][1])

    return joint_range


def bus_rate_limit(lane: Lane, mode: str) -> tuple[float | None, int]:
    """The highest cycle rate (Hz) ``lane``'s bus carries for its motors in ``mode`` (None: bit rate
    unknown), and the bits one cycle takes."""
    bits = 0
    for i in lane.ids:
        if mode == "impedance":
            bits += frame_bits(i << 5, bytes(8)) + frame_bits(i << 5, bytes(8)) + _STATE_BITS  # preset, read
        else:
            bits += frame_bits(i << 5, bytes(8)) + _STATE_BITS
            if not lane.reply_state.get(i, False):
                bits += frame_bits(i << 5, bytes(8))  # a fast read follows the command
    if mode == "impedance":
        bits += frame_bits(0, bytes(8))  # the one start
    return (None if lane.bitrate is None else lane.bitrate / bits), bits


def _check_limits(tr: Trajectory, times: Iterable[float], limits: Mapping[str, Mapping[str, Any]], unit: str) -> None:
    """Refuse a trajectory that leaves a joint's position range or exceeds its speed or acceleration."""
    for t in times:
        s = tr.sample(t)
        for j, name in enumerate(tr.joints):
            lim = limits.get(name)
            if not lim:
                continue
            where = f"follow: joint {name!r} at t={t:.3f} s"
            rng = lim.get("position")
            if rng is not None and not rng[0] <= s.positions[j] <= rng[1]:
                raise ValidationError(
                    f"{where}: position {s.positions[j]:.4g} {unit} is outside its limits "
                    f"{rng[0]:g}..{rng[1]:g} {unit} ({lim.get('source', 'limits')}); nothing was sent"
                )
            rates = (("speed", s.velocities[j], f"{unit}/s"), ("accel", s.accelerations[j], f"{unit}/s^2"))
            for key, value, u in rates:
                top = lim.get(key)
                if top is not None and abs(value) > top * (1 + 1e-9):
                    raise ValidationError(
                        f"{where}: {key} {value:.4g} {u} is beyond its limit +-{top:g} {u} "
                        f"({lim.get('source', 'limits')}); slow it down (e.g. --speed); nothing was sent"
                    )


def make_plan(
    tr: Trajectory,
    lanes: list[Lane],
    *,
    rate: float,
    mode: str,
    max_error: float | Mapping[str, float] | None,
    limits: Mapping[str, Mapping[str, Any]],
    kp: float,
    kd: float,
    bandwidth: float | None,
    torques: Callable[[float], Sequence[float]] | None,
    timeout: float | None,
) -> FollowPlan:
    """Check ``tr`` and build every cycle's commands per lane; raises :class:`ValidationError` naming
    the field, value and allowed range before anything is sent."""
    if mode not in MODES:
        raise ValidationError(f"mode={mode!r}: one of {', '.join(map(repr, MODES))}")
    if isinstance(rate, bool) or not isinstance(rate, int | float) or not math.isfinite(rate) or rate <= 0:
        raise ValidationError(f"rate={rate!r}: expected a number of Hz > 0")
    unit = lanes[0].units[0].unit
    for lane in lanes:
        top, bits = bus_rate_limit(lane, mode)
        if top is not None and rate > top:
            raise ValidationError(
                f"rate={rate:g} Hz: above what bus {lane.bus!r} carries for {len(lane.ids)} motors in {mode} mode at "
                f"{lane.bitrate} bit/s ({bits} bits a cycle): at most {math.floor(top)} Hz"
            )
    bw = min(300.0, rate / 2) if bandwidth is None else bandwidth
    errs: list[float] = []
    for name in tr.joints:
        e = max_error.get(name, math.inf) if isinstance(max_error, Mapping) else max_error
        if e is None:
            e = math.inf
        if isinstance(e, bool) or not isinstance(e, int | float) or math.isnan(e) or e <= 0:
            raise ValidationError(f"max_error[{name!r}]={e!r}: expected a tracking error > 0 {unit}")
        errs.append(float(e))
    if tr.duration > MAX_DURATION:
        raise ValidationError(
            f"follow: the trajectory lasts {tr.duration:g} s, beyond the longest a plan follows "
            f"({MAX_DURATION:g} s); split it; nothing was sent"
        )
    count = max(1, math.ceil(tr.duration * rate - 1e-9))
    times = CycleTimes(count, float(rate), tr.duration)
    _check_limits(tr, times, limits, unit)

    def cycle(t: float) -> dict[str, list[Message]]:
        s = tr.sample(t)
        ff = [0.0] * len(tr.joints) if torques is None else list(torques(t))
        cyc: dict[str, list[Message]] = {}
        for lane in lanes:
            msgs: list[Message] = []
            for i, u, j in zip(lane.ids, lane.units, lane.index, strict=True):
                deg = u.angle(s.positions[j])
                if mode == "position":
                    msgs.append(make_angle(i, deg, 0.0, bw, PositionMode.T))
                elif mode == "p":
                    msgs.append(make_angle(i, deg, u.speed(s.velocities[j]), u.torque(ff[j]), PositionMode.P))
                else:
                    preset, _ = make_impedance(i, deg, u.speed(s.velocities[j]), u.torque(ff[j]), kp, kd)
                    msgs.append(preset)
            if mode == "impedance":
                msgs.append(StartImpedance(0, float(kp), float(kd)))
            cyc[lane.bus] = msgs
        return cyc

    return FollowPlan(tr, lanes, float(rate), mode, times, CycleCommands(times, cycle), errs, timeout, bw, unit)
