"""Replaying a recording on the twin: the commands a robot was sent, fed to its simulated motors.

A recording made by ``drempower record --robot FILE`` holds every frame on the robot's buses (the
commands of every host: this one's on ``/can/<bus>/tx``, another host's, such as ``drempower play``'s,
among ``/can/<bus>/rx``) and the joint states the motors reported (``/joint_states``, at the joint).
:func:`load_recording` reads both; :class:`Replay` builds the twin of the robot file with given
``armature``, ``damping`` and ``frictionloss`` per joint (the totals at the joint: the motor's share
included), puts the joints where the recording starts (at the first motion command), sends the
recorded host frames to the simulated motors at their recorded times, steps 1 ms at a time and
returns what the twin did; :func:`compare` gives per joint the RMS and largest difference of
position, speed and torque between the twin and the recording.

The recorded states arrive some transport delay after the motors measured them; the twin's states are
compared ``delay`` s earlier than their recorded time.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..errors import ConfigError, ProtocolError, ValidationError
from ..protocol.describe import CaptureDecoder
from ..protocol.ids import Frame
from ..protocol.messages import PositionP, PositionQ, PositionT, StartImpedance, State, Torque, Velocity

if TYPE_CHECKING:
    import numpy as np

    from ..robotfile import RobotSpec

__all__ = ["PARAMETERS", "Recording", "Replay", "Trace", "compare", "load_recording", "windowed"]

PARAMETERS = ("armature", "damping", "frictionloss")
"""The joint parameters a twin fit sets (kg m^2, Nm s/rad, Nm at the joint)."""
_MOTION = (PositionT, PositionQ, PositionP, Velocity, Torque, StartImpedance)
"""Commands that move a joint: the replay starts at the first."""
STEP = 0.001
_DEG = math.pi / 180.0
_RPM = 2.0 * math.pi / 60.0


@dataclass
class Recording:
    """What a recording holds for a robot: host ``frames`` as (s from ``start``, bus, frame), and per joint
    the reported ``states`` as arrays ``t`` (s from ``start``), ``q`` rad, ``v`` rad/s, ``tau`` Nm."""

    path: str
    start: float
    """Unix time (s) of the first motion command: the replay's time 0."""
    frames: list[tuple[float, str, Frame]]
    states: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)

    @property
    def duration(self) -> float:
        """The time (s) of the last state reported."""
        return max((float(s["t"][-1]) for s in self.states.values() if len(s["t"])), default=0.0)


def _numpy() -> Any:
    try:
        import numpy
    except ImportError:
        raise ConfigError("the twin fit needs numpy: pip install 'drempower[fit]'") from None
    return numpy


SMOOTH = 0
"""Frames each side over which :func:`load_recording` averages the recorded times (0: as recorded; see there)."""


def load_recording(path: str | os.PathLike[str], spec: RobotSpec, *, smooth: int = SMOOTH) -> Recording:
    """The host frames and joint states of the MCAP recording ``path`` of the robot ``spec``.

    The states are the motors' state frames (on ``/can/<bus>/rx``), at the joint (gear and offset as
    the robot file says). ``drempower record`` stamps each received frame with its transport's own
    time where the transport gives one (a socketcand server's stamp, python-can's receive timestamp,
    the simulator's clock), else when the recording host took it, late by a latency that varies (a
    busy host takes a burst of frames at once after a pause); for such a recording, whose frames are in
    the order they were on the bus at a steady rate, each frame's time may be taken as the mean of the
    recorded times of the ``smooth`` frames each side of it (0, the default: as recorded).

    Raises :class:`ValidationError` (naming the file) when it is not a recording of this robot or has
    no motion command."""
    np = _numpy()
    try:
        from mcap.reader import make_reader
        from mcap_ros2.decoder import DecoderFactory
    except ImportError:
        raise ConfigError("reading a recording needs the records extra: pip install 'drempower[records]'") from None
    if isinstance(smooth, bool) or not isinstance(smooth, int) or smooth < 0:
        raise ValidationError(f"smooth={smooth!r}: expected a whole number of frames >= 0")
    name = os.fspath(path)
    buses = list(spec.buses)
    joint_of = {(j.bus, j.id): j for j in spec.joints.values()}
    decoders: dict[str, CaptureDecoder] = {}
    stamps: list[float] = []
    host: list[tuple[int, str, Frame, bool]] = []
    states: list[tuple[int, str, float, float, float]] = []
    try:
        fh = open(name, "rb")  # noqa: SIM115 - closed below
    except OSError as exc:
        raise ValidationError(f"{name}: {exc.strerror}") from None
    with fh:
        try:
            reader = make_reader(fh, decoder_factories=[DecoderFactory()])
            summary = reader.get_summary()
            topics = (
                None if summary is None else [c.topic for c in summary.channels.values() if c.topic.startswith("/can/")]
            )
            for _, channel, message, msg in reader.iter_decoded_messages(topics=topics):
                topic = channel.topic
                tx = topic.endswith("/tx")
                if not topic.startswith("/can/") or not (tx or topic.endswith("/rx")):
                    continue
                parts = topic.split("/")
                bus = parts[2] if len(parts) == 4 else (buses[0] if len(buses) == 1 else "")
                if bus not in spec.buses or msg.is_extended or msg.is_rtr or msg.dlc != 8:
                    continue
                k = len(stamps)
                stamps.append(message.log_time / 1e9)
                frame = Frame(msg.id, bytes(msg.data)[:8], False, False)
                dec = decoders.setdefault(bus, CaptureDecoder())
                try:
                    who, decoded = dec.decode(frame.arbitration_id, frame.data, stamps[-1])
                except ProtocolError:
                    continue
                if tx or who == "host":
                    host.append((k, bus, frame, isinstance(decoded, _MOTION)))
                elif isinstance(decoded, State):
                    j = joint_of.get((bus, frame.arbitration_id >> 5))
                    if j is not None:
                        states.append(
                            (
                                k,
                                j.name,
                                decoded.position * _DEG / j.gear + j.offset,
                                decoded.speed * _RPM / j.gear,
                                decoded.torque * j.gear,
                            )
                        )
        except ValidationError:
            raise
        except Exception as exc:  # the mcap readers' errors have no common type
            raise ValidationError(f"{name}: not an MCAP recording ({type(exc).__name__}: {exc})") from None
    first = next((k for k, _, _, motion in host if motion), None)
    if first is None:
        raise ValidationError(f"{name}: no motion command in the recording: nothing to replay")
    t = np.asarray(stamps, dtype=float)
    if smooth and len(t) > 2 * smooth + 1:
        c = np.concatenate(([0.0], np.cumsum(t)))
        idx = np.arange(len(t))
        lo = np.clip(idx - smooth, 0, len(t) - 1)
        hi = np.clip(idx + smooth, 0, len(t) - 1)
        t = (c[hi + 1] - c[lo]) / (hi - lo + 1)
    start = float(t[first])
    rec = Recording(name, start, [(max(0.0, float(t[k]) - start), b, f) for k, b, f, _ in host])
    rows: dict[str, list[tuple[float, float, float, float]]] = {}
    for k, joint, q, v, tau in states:
        if t[k] >= start:
            rows.setdefault(joint, []).append((float(t[k]) - start, q, v, tau))
    for joint, rs in rows.items():
        a = np.array(rs, dtype=float)
        rec.states[joint] = {"t": a[:, 0], "q": a[:, 1], "v": a[:, 2], "tau": a[:, 3]}
    return rec


@dataclass
class Trace:
    """What the twin did on a 1 ms grid: ``t`` (s), and per joint ``q`` rad, ``v`` rad/s, ``tau`` Nm."""

    t: np.ndarray
    q: dict[str, np.ndarray]
    v: dict[str, np.ndarray]
    tau: dict[str, np.ndarray]


class Replay:
    """Replays ``recording`` on the twin of ``spec`` (see the module docstring).

    :attr:`nominal` holds each joint's ``armature``, ``damping`` and ``frictionloss`` as the robot file's
    twin has them; :meth:`run` takes others for some joints and returns a :class:`Trace`.
    """

    def __init__(self, spec: RobotSpec, recording: Recording) -> None:
        from .twin import require_mujoco

        self._np = _numpy()
        self._mj = require_mujoco()
        if spec.model is None:
            raise ConfigError(f"{spec.source}: no [model]: a twin needs one")
        self.spec = spec
        self.recording = recording
        used = {b for _, b, _ in recording.frames}
        self.buses = [b for b in spec.buses if b in used] or list(spec.buses)
        self.joints = [j.name for j in spec.joints.values() if j.bus in self.buses]
        missing = [j for j in self.joints if j not in recording.states or len(recording.states[j]["t"]) < 2]
        if missing:
            raise ValidationError(
                f"{recording.path}: no joint states of joint {missing[0]!r}: record with --robot and "
                "--heartbeat-ms or --poll"
            )
        self.duration = recording.duration
        twin, _ = self._build()
        m = twin.model
        self.nominal: dict[str, dict[str, float]] = {}
        for j in self.joints:
            dof = self._dof(m, j)
            self.nominal[j] = {
                "armature": float(m.dof_armature[dof]),
                "damping": float(m.dof_damping[dof]),
                "frictionloss": float(m.dof_frictionloss[dof]),
            }

    def _dof(self, m: Any, joint: str) -> int:
        mj = self._mj
        js = self.spec.joints[joint]
        return int(m.jnt_dofadr[mj.mj_name2id(m, mj.mjtObj.mjOBJ_JOINT, js.model_joint or joint)])

    def _build(self) -> tuple[Any, dict[str, Any]]:
        from .bus import SimBus
        from .twin import couple_robot

        buses = {b: SimBus([j.id for j in self.spec.joints_on(b)]) for b in self.buses}
        twin = couple_robot(self.spec, buses)
        assert twin is not None
        return twin, buses

    def run(self, params: Mapping[str, Mapping[str, float]] | None = None, seconds: float | None = None) -> Trace:
        """The twin's run through the recording (or its first ``seconds``), with ``params`` (joint ->
        ``armature``/``damping``/``frictionloss``, totals at the joint) in place of the nominal ones."""
        np, mj = self._np, self._mj
        twin, buses = self._build()
        m, d = twin.model, twin.data
        for joint, values in (params or {}).items():
            dof = self._dof(m, joint)
            for key, value in values.items():
                if key not in PARAMETERS:
                    raise ValidationError(f"{key!r}: not a twin parameter ({', '.join(PARAMETERS)})")
                getattr(m, f"dof_{key}")[dof] = value
        mj.mj_setConst(m, d)
        for joint in self.joints:  # where the recording starts
            st = self.recording.states[joint]
            twin.set_joint(joint, float(np.interp(0.0, st["t"], st["q"])), float(np.interp(0.0, st["t"], st["v"])))
        end = self.duration if seconds is None else min(seconds, self.duration)
        n = math.floor(end / STEP + 1e-9) + 1
        qadr = [
            int(m.jnt_qposadr[mj.mj_name2id(m, mj.mjtObj.mjOBJ_JOINT, self.spec.joints[j].model_joint or j)])
            for j in self.joints
        ]
        dofs = [self._dof(m, j) for j in self.joints]
        drives = [buses[self.spec.joints[j].bus].motors[self.spec.joints[j].id].drive for j in self.joints]
        gears = [self.spec.joints[j].gear for j in self.joints]
        q = np.empty((n, len(self.joints)))
        v = np.empty_like(q)
        tau = np.empty_like(q)
        frames = self.recording.frames
        k_frame, nf = 0, len(frames)
        order = list(buses.values())
        qpos, qvel = d.qpos, d.qvel
        for k in range(n):
            t = k * STEP
            while k_frame < nf and frames[k_frame][0] <= t + 1e-9:
                _, b, frame = frames[k_frame]
                buses[b].send(frame)
                k_frame += 1
            for bus in order:
                bus.advance(STEP)
            q[k] = qpos[qadr]
            v[k] = qvel[dofs]
            tau[k] = [dr.torque * g for dr, g in zip(drives, gears, strict=True)]
        return Trace(
            np.arange(n) * STEP,
            {j: q[:, i] for i, j in enumerate(self.joints)},
            {j: v[:, i] for i, j in enumerate(self.joints)},
            {j: tau[:, i] for i, j in enumerate(self.joints)},
        )


WINDOW = 0.02
"""s: the twin and the recording are compared as means over windows this long (see :func:`windowed`)."""


def windowed(
    recording: Recording, trace: Trace, joint: str, key: str, delay: float = 0.0, window: float = WINDOW
) -> tuple[np.ndarray, np.ndarray]:
    """The recorded and the twin's ``key`` (``q``, ``v`` or ``tau``) of ``joint`` as means over windows of
    ``window`` s: the recorded samples stamped in the window (``delay`` s earlier) and the twin's 1 ms
    states in it. The means, not the samples, are compared: a recording's time stamps are only as good
    as its host's latency, and a motor's torque chatters from one millisecond to the next; what a
    joint's armature, damping and friction change is slower."""
    np = _numpy()
    st = recording.states[joint]
    ts = st["t"]
    n = math.floor(min(float(ts[-1]), float(trace.t[-1])) / window + 1e-9) if len(ts) else 0
    keep = ts < n * window
    rb = np.floor(ts[keep] / window).astype(int)
    count = np.bincount(rb, minlength=n)[:n]
    rsum = np.bincount(rb, weights=st[key][keep], minlength=n)[:n]
    ok = count > 0
    # the twin's mean over each window, ``delay`` s earlier: differences of its running integral
    sim = getattr(trace, key)[joint]
    integral = np.concatenate(([0.0], np.cumsum((sim[1:] + sim[:-1]) * 0.5 * np.diff(trace.t))))
    end = float(trace.t[-1])
    a = np.clip(np.arange(n)[ok] * window - delay, 0.0, end - 1e-6)
    b = np.clip(a + window, a + 1e-6, end)
    means = (np.interp(b, trace.t, integral) - np.interp(a, trace.t, integral)) / (b - a)
    return rsum[ok] / count[ok], means


def compare(
    recording: Recording, trace: Trace, joints: Sequence[str] | None = None, delay: float = 0.0
) -> dict[str, dict[str, float]]:
    """Per joint: RMS and largest difference twin - robot of position (``rms_deg``, ``max_deg``), speed
    (``rms_deg_s``, ``max_deg_s``) and torque (``rms_nm``, ``max_nm``), over the time the trace covers,
    as means over :data:`WINDOW` (see :func:`windowed`), the twin's taken ``delay`` s before the
    recorded time; ``windows`` compared."""
    np = _numpy()
    out: dict[str, dict[str, float]] = {}
    for j in joints or list(trace.q):
        row: dict[str, float] = {}
        for key, unit, scale in (("q", "deg", 180 / math.pi), ("v", "deg_s", 180 / math.pi), ("tau", "nm", 1.0)):
            rec, sim = windowed(recording, trace, j, key, delay)
            e = (sim - rec) * scale
            row[f"rms_{unit}"] = float(np.sqrt(np.mean(e * e))) if len(e) else math.nan
            row[f"max_{unit}"] = float(np.max(np.abs(e))) if len(e) else math.nan
            row["windows"] = len(e)
        out[j] = row
    return out
