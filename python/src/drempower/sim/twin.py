"""A robot twin: simulated motors that drive the joints of a MuJoCo model.

A :class:`Twin` owns one ``MjModel``/``MjData`` and steps it at the simulator's
1 ms step. Each coupled motor keeps its whole controller (:class:`~drempower.sim.drive.Drive`:
every mode, the limits, the protections); instead of its own mechanics, the twin
is its plant: the motor's torque acts on the model's joint through a MuJoCo
actuator, MuJoCo integrates the whole robot (gravity, inertia, contacts, joint
limits, damping, friction loss, armature), and the model joint's angle and speed
come back to the motor through the joint's ``gear`` and ``offset``::

    motor output turns = (joint rad - offset) * gear / 2 pi   (+ the motor's zero at coupling)
    joint torque Nm    = motor torque Nm * gear

The model's own actuators of a coupled joint are removed (the motor is its
actuator). The motor's own rotor inertia, viscous and Coulomb friction are added to the
model joint's armature, damping and friction loss (reflected through the gear),
unless the joint's ``friction`` is ``"model"``. The speed-proportional part of the
controller's torque goes to the actuator's velocity bias, which MuJoCo's
``implicitfast`` and ``implicit`` integrators treat implicitly, as the plain
mechanics do.

The physics lags the motors' clock by one step: at a bus step at time t the twin
first integrates up to t - 1 ms with the torques of the previous step, then the
motors compute their torques from that state. Buses of one robot share one twin;
the first bus to reach a step integrates it, so on several buses the twin follows
the one furthest ahead; :class:`TwinRunner` advances them in lockstep, 1 ms at a time
(``drempower sim --robot`` runs one).

``twin.push(body="link3", force=(0, 0, -5), duration=1.0)`` and
``twin.push_joint("elbow", torque=2.0, duration=0.5)`` are a hand from outside.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
import weakref
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..errors import ConfigError, ValidationError
from .drive import TAU
from .params import CONFIG

if TYPE_CHECKING:
    from ..robotfile import RobotSpec
    from .bus import SimBus
    from .motor import SimMotor

__all__ = ["PUSH_LIMITS", "Coupling", "Push", "Twin", "TwinRunner", "couple_robot", "twin_of", "require_mujoco"]

_EPS = 1e-9
_ACTUATOR_PREFIX = "drempower:"
"""Name prefix of the actuators the twin adds to the model (one per coupled joint)."""
_TWINS: weakref.WeakKeyDictionary[SimBus, Twin] = weakref.WeakKeyDictionary()


def require_mujoco() -> Any:
    """The ``mujoco`` module, or a :class:`ConfigError` that says how to install it."""
    try:
        import mujoco
    except ImportError:
        raise ConfigError("a robot model needs the physics extra: pip install 'drempower[physics]' (MuJoCo)") from None
    return mujoco


def twin_of(bus: SimBus) -> Twin | None:
    """The twin whose joints the motors of ``bus`` drive, or None."""
    return _TWINS.get(bus)


@dataclass(frozen=True)
class Coupling:
    """A motor coupled to model joint ``model_joint`` (``name``: the robot's joint name)."""

    name: str
    motor: SimMotor
    model_joint: str
    gear: float = 1.0
    offset: float = 0.0
    motor_friction: bool = True
    """Add the motor's rotor inertia and friction to the model joint's (False: ``friction = "model"``)."""
    identified: Mapping[str, float] | None = None
    """The joint's identified ``inertia``, ``viscous``, ``coulomb`` (at the joint): they replace the model's
    armature (less the links' own inertia), damping and friction loss, and the motor's."""


PUSH_LIMITS = {"force": 1000.0, "torque": 200.0, "duration": 10.0}
"""The hand's bounds: force N and torque Nm per component (of one push, and of all pushes acting on one
body or joint together), duration s (0 < d <= this)."""


@dataclass(frozen=True)
class Push:
    """A force (N) and torque (Nm) on a body, world frame, or a torque (Nm) on a joint, until ``end`` (s)."""

    end: float
    body: int | None
    dof: int | None
    force: tuple[float, float, float]
    torque: tuple[float, float, float]
    joint_torque: float


class _Link:
    """The twin's side of one coupling: indices into the model and the conversion constants."""

    __slots__ = ("act", "dof", "drive", "g2", "gear", "k", "name", "offset", "per_rad", "qadr", "zero")

    def __init__(self, c: Coupling, act: int, qadr: int, dof: int) -> None:
        self.name = c.name
        self.drive = c.motor.drive
        self.act, self.qadr, self.dof = act, qadr, dof
        self.gear, self.offset = c.gear, c.offset
        self.per_rad = c.gear / TAU
        """Motor output turns per joint rad."""
        self.g2 = c.gear * c.gear / TAU
        """Joint Nm/(rad/s) per motor Nm/(turn/s)."""
        self.k = 0.0
        self.zero = 0.0
        """Motor output turns when the joint is at ``offset``."""


class Twin:
    """One MuJoCo model driven by simulated motors (see the module docstring).

    ``model_file`` is MJCF or URDF; ``couplings`` name the motors and their joints.
    The physics step is ``step`` s (the simulator's 1 ms). Raises :class:`ConfigError`
    when the model cannot be read or a joint is missing or not a hinge.
    """

    STEP = 0.001

    def __init__(self, model_file: str, couplings: Sequence[Coupling], *, step: float = STEP) -> None:
        mujoco = require_mujoco()
        self._mj = mujoco
        try:
            spec = mujoco.MjSpec.from_file(model_file)
        except Exception as exc:  # MuJoCo's parser errors have no common type
            raise ConfigError(f"model {model_file}: {exc}") from None
        self.source = model_file
        hinge = mujoco.mjtJoint.mjJNT_HINGE
        names = [j.name for j in spec.joints if j.name]
        seen: dict[str, str] = {}
        for c in couplings:
            mj = spec.joint(c.model_joint)
            if mj is None:
                raise ConfigError(
                    f"model {model_file}: joint {c.name!r}: model_joint={c.model_joint!r} is not a joint of the "
                    f"model ({', '.join(names) or 'it has no named joint'})"
                )
            if mj.type != hinge:
                raise ConfigError(f"model {model_file}: joint {c.model_joint!r} is not a hinge: a motor turns a hinge")
            if c.model_joint in seen:
                raise ConfigError(
                    f"model {model_file}: joints {seen[c.model_joint]!r} and {c.name!r} both drive {c.model_joint!r}"
                )
            seen[c.model_joint] = c.name
            if c.identified is not None:
                _identified_terms(mj, c.identified)
            elif c.motor_friction:
                d = c.motor.drive
                g2 = c.gear * c.gear
                mj.armature += d.j / TAU * g2
                extra = d.b / TAU * g2
                if isinstance(mj.damping, float):  # MuJoCo 3: one coefficient
                    mj.damping += extra
                else:  # MuJoCo 4: the polynomial's coefficients, linear first
                    damping = mj.damping.copy()
                    damping[0] += extra
                    mj.damping = damping
                mj.frictionloss += d.fc * abs(c.gear)
            act = spec.add_actuator()
            act.name = _ACTUATOR_PREFIX + c.model_joint
            act.target = c.model_joint
            act.trntype = mujoco.mjtTrn.mjTRN_JOINT
            act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
            act.biastype = mujoco.mjtBias.mjBIAS_AFFINE
            act.gainprm = [1.0] + [0.0] * (len(act.gainprm) - 1)
            act.biasprm = [0.0] * len(act.biasprm)
            act.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
        coupled = set(seen)
        for own in list(spec.actuators):  # the motors replace the model's own actuators of their joints
            if own.target in coupled and not own.name.startswith(_ACTUATOR_PREFIX):
                spec.delete(own)
        spec.option.timestep = step
        try:
            self.model = spec.compile()
        except Exception as exc:
            raise ConfigError(f"model {model_file}: {exc}") from None
        _check_finite(self.model, model_file)
        self.data = mujoco.MjData(self.model)
        self._qpos, self._qvel, self._ctrl = self.data.qpos, self.data.qvel, self.data.ctrl
        self._bias = self.model.actuator_biasprm
        self._mj_step = mujoco.mj_step
        self._v: list[float] = []
        self.step_s = step
        self.time = 0.0
        """Physics time (s): one step behind the motors' clock."""
        self.lock = threading.RLock()
        """Held while the twin steps; hold it to read ``model``/``data`` consistently."""
        self._pushes: list[Push] = []
        self._pushes_dirty = False
        m = self.model
        self._links: list[_Link] = []
        self._by_name: dict[str, _Link] = {}
        for c in couplings:
            jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, c.model_joint)
            act = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, _ACTUATOR_PREFIX + c.model_joint)
            link = _Link(c, act, int(m.jnt_qposadr[jid]), int(m.jnt_dofadr[jid]))
            self._links.append(link)
            self._by_name[c.name] = link
            self._by_name.setdefault(c.model_joint, link)
            if c.identified is not None:  # the armature is what the links' own inertia at qpos0 leaves
                m.dof_armature[link.dof] = max(0.0, c.identified["inertia"] - float(m.dof_M0[link.dof]))
                m.dof_M0[link.dof] += m.dof_armature[link.dof]
        mujoco.mj_forward(m, self.data)
        for link, c in zip(self._links, couplings, strict=True):
            d = link.drive
            link.zero = d.pos - c.motor.position / 360.0  # the turns at which the motor reads 0 deg
            d.plant = self
        self._publish()
        for link in self._links:  # a motor in closed loop since power-up holds where the joint is
            d = link.drive
            if d.active:
                d.hold(d.pos)
                d.integ = 0.0

    # ------------------------------------------------------------------ stepping

    def sync(self, now: float) -> None:
        """Integrate up to ``now`` - 1 step, with the torques the motors last computed (their plant's part)."""
        if self.time >= now - 1.5 * self.step_s:
            return
        with self.lock:
            while self.time < now - 1.5 * self.step_s:
                self._step()

    def _step(self) -> None:
        ctrl, bias, v = self._ctrl, self._bias, self._v
        for link in self._links:
            drv = link.drive
            k = drv.gain * link.g2
            if k != link.k:
                bias[link.act, 2] = -k
                link.k = k
            ctrl[link.act] = link.gear * (drv.torque + drv.ext) + k * v[link.dof]
        if (self._pushes and self._pushes[0].end <= self.time + _EPS) or self._pushes_dirty:
            self._apply_pushes()
        self._mj_step(self.model, self.data)
        self.time += self.step_s
        self._publish()

    def _publish(self) -> None:
        """The model joints' angle and speed to the motors."""
        q = self._qpos.tolist()
        self._v = v = self._qvel.tolist()
        for link in self._links:
            drv = link.drive
            drv.pos = (q[link.qadr] - link.offset) * link.per_rad + link.zero
            drv.vel = v[link.dof] * link.per_rad

    # ------------------------------------------------------------------ the hand

    def push(
        self,
        body: str,
        force: Iterable[float] = (0.0, 0.0, 0.0),
        torque: Iterable[float] = (0.0, 0.0, 0.0),
        duration: float = 1.0,
    ) -> None:
        """Apply ``force`` (N) and ``torque`` (Nm), world frame, at the centre of mass of ``body``
        for ``duration`` s of simulated time, from now (on top of other pushes)."""
        f = _vector(force, "force")
        t = _vector(torque, "torque")
        with self.lock:
            bid = self._mj.mj_name2id(self.model, self._mj.mjtObj.mjOBJ_BODY, body)
            if bid <= 0:
                bodies = [self.model.body(i).name for i in range(1, self.model.nbody)]
                raise ValidationError(f"body={body!r}: not a body of the model ({', '.join(bodies)})")
            self._add(Push(self.time + _duration(duration), bid, None, f, t, 0.0))

    def push_joint(self, joint: str, torque: float, duration: float = 1.0) -> None:
        """Apply ``torque`` Nm to joint ``joint`` (the robot's name or the model's) for ``duration`` s
        of simulated time, from now (on top of the motor's torque and other pushes)."""
        if isinstance(torque, bool) or not isinstance(torque, int | float) or not math.isfinite(torque):
            raise ValidationError(f"torque={torque!r}: expected a finite number of Nm")
        with self.lock:
            dof = self._dof(joint)
            self._add(Push(self.time + _duration(duration), None, dof, (0.0,) * 3, (0.0,) * 3, float(torque)))

    def release(self) -> None:
        """End every push now."""
        with self.lock:
            self._pushes.clear()
            self._pushes_dirty = True

    @property
    def pushes(self) -> list[Push]:
        """The pushes acting now (ends in simulated s)."""
        with self.lock:
            return [p for p in self._pushes if p.end > self.time + _EPS]

    def _add(self, push: Push) -> None:
        """Add ``push`` when it, and the pushes acting on its body or joint with it, stay within
        :data:`PUSH_LIMITS`; a ValidationError naming the limit otherwise (the lock held)."""
        if push.end - self.time > PUSH_LIMITS["duration"] + _EPS:
            raise ValidationError(
                f"duration={push.end - self.time:g}: a push lasts at most {PUSH_LIMITS['duration']:g} s"
            )
        same = [p for p in self._pushes if p.end > self.time + _EPS and (p.body, p.dof) == (push.body, push.dof)]
        for what, unit, parts in (
            ("force", "N", [q.force for q in (*same, push)]),
            ("torque", "Nm", [q.torque if push.dof is None else (q.joint_torque, 0.0, 0.0) for q in (*same, push)]),
        ):
            top = PUSH_LIMITS[what]
            total = [sum(v[i] for v in parts) for i in range(3)]
            if any(abs(x) > top for x in total):
                together = " with the pushes acting on it" if same else ""
                raise ValidationError(
                    f"{what} {tuple(round(x, 6) for x in total)} {unit}{together}: beyond +-{top:g} {unit} "
                    "per component (the hand's bound)"
                )
        self._pushes.append(push)
        self._pushes.sort(key=lambda p: p.end)
        self._pushes_dirty = True

    def _apply_pushes(self) -> None:
        d = self.data
        now = self.time + _EPS
        self._pushes = [p for p in self._pushes if p.end > now]
        self._pushes_dirty = False
        d.xfrc_applied[:] = 0.0
        d.qfrc_applied[:] = 0.0
        for p in self._pushes:
            if p.body is not None:
                d.xfrc_applied[p.body, :3] += p.force
                d.xfrc_applied[p.body, 3:] += p.torque
            if p.dof is not None:
                d.qfrc_applied[p.dof] += p.joint_torque

    # ------------------------------------------------------------------ state

    @property
    def joints(self) -> list[str]:
        """The robot joints the motors drive, in coupling order."""
        return [link.name for link in self._links]

    def joint_position(self, joint: str) -> float:
        """The angle (rad) of joint ``joint`` (the robot's name or any hinge of the model)."""
        with self.lock:
            return float(self.data.qpos[self._qadr(joint)])

    def joint_velocity(self, joint: str) -> float:
        """The speed (rad/s) of joint ``joint``."""
        with self.lock:
            return float(self.data.qvel[self._dof(joint)])

    def joint_positions(self) -> dict[str, float]:
        """Every named hinge and slide joint of the model: its position (rad or m), by the model's name."""
        mj = self._mj
        with self.lock:
            m = self.model
            return {
                m.joint(i).name: float(self.data.qpos[m.jnt_qposadr[i]])
                for i in range(m.njnt)
                if m.joint(i).name
                and int(m.jnt_type[i]) in (int(mj.mjtJoint.mjJNT_HINGE), int(mj.mjtJoint.mjJNT_SLIDE))
            }

    def set_joint(self, joint: str, position: float, velocity: float = 0.0) -> None:
        """Put joint ``joint`` at ``position`` rad moving at ``velocity`` rad/s (a starting pose);
        the motors see it at once."""
        for value, what in ((position, "position"), (velocity, "velocity")):
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
                raise ValidationError(f"{what}={value!r}: expected a finite number")
        with self.lock:
            self.data.qpos[self._qadr(joint)] = position
            self.data.qvel[self._dof(joint)] = velocity
            self._mj.mj_forward(self.model, self.data)
            self._publish()

    def energy(self) -> tuple[float, float]:
        """Potential (gravity) and kinetic energy (J) of the model now."""
        mj = self._mj
        with self.lock:
            m, d = self.model, self.data
            mj.mj_energyPos(m, d)
            mj.mj_energyVel(m, d)
            return float(d.energy[0]), float(d.energy[1])

    def _qadr(self, joint: str) -> int:
        link = self._by_name.get(joint)
        if link is not None:
            return link.qadr
        return int(self.model.jnt_qposadr[self._joint_id(joint)])

    def _dof(self, joint: str) -> int:
        link = self._by_name.get(joint)
        if link is not None:
            return link.dof
        return int(self.model.jnt_dofadr[self._joint_id(joint)])

    def _joint_id(self, joint: str) -> int:
        mj = self._mj
        jid = int(mj.mj_name2id(self.model, mj.mjtObj.mjOBJ_JOINT, joint))
        if jid < 0 or int(self.model.jnt_type[jid]) != int(mj.mjtJoint.mjJNT_HINGE):
            hinges = [
                self.model.joint(i).name
                for i in range(self.model.njnt)
                if int(self.model.jnt_type[i]) == int(mj.mjtJoint.mjJNT_HINGE)
            ]
            raise ValidationError(f"joint={joint!r}: not a hinge of the model ({', '.join(hinges)})")
        return jid

    def __repr__(self) -> str:
        return f"<Twin {self.source}: joints {', '.join(self.joints)}; t={self.time:.3f} s>"


_FINITE = {
    "body_pos": "body",
    "body_quat": "body",
    "body_ipos": "body",
    "body_iquat": "body",
    "body_mass": "body",
    "body_inertia": "body",
    "jnt_pos": "joint",
    "jnt_axis": "joint",
    "jnt_range": "joint",
    "dof_damping": "dof",
    "dof_armature": "dof",
    "dof_frictionloss": "dof",
    "geom_pos": "geom",
    "geom_quat": "geom",
    "geom_size": "geom",
    "qpos0": "",
}
"""The compiled model's arrays that must hold finite numbers, and what each row is."""


def _check_finite(model: Any, model_file: object) -> None:
    """Refuse a model with NaN or infinity where physics needs numbers (an MJCF axis, a URDF origin): MuJoCo
    would reset every step and the joints read 0. A ConfigError naming the file, the field and the element."""
    import numpy as np

    for field, kind in _FINITE.items():
        values = np.asarray(getattr(model, field, ()), dtype=float)
        bad = np.argwhere(~np.isfinite(values))
        if bad.size:
            row = int(bad[0][0])
            name = ""
            if kind in ("body", "joint", "geom"):
                name = getattr(model, kind)(row).name or str(row)
            elif kind == "dof":
                name = model.joint(int(model.dof_jntid[row])).name or str(row)
            what = f" ({kind} {name!r})" if name else ""
            raise ConfigError(
                f"model {model_file}: {field}{what} holds {float(values[tuple(bad[0])])!r}: expected finite numbers"
            )


def _vector(value: Iterable[float], what: str) -> tuple[float, float, float]:
    try:
        v = tuple(float(x) for x in value)
    except (TypeError, ValueError):
        v = ()
    if len(v) != 3 or not all(math.isfinite(x) for x in v):
        raise ValidationError(f"{what}={value!r}: expected 3 finite numbers (x, y, z), world frame")
    return v[0], v[1], v[2]


def _duration(seconds: float) -> float:
    if isinstance(seconds, bool) or not isinstance(seconds, int | float) or not 0 < seconds < math.inf:
        raise ValidationError(f"duration={seconds!r}: expected a positive finite number of seconds")
    return float(seconds)


def _identified_terms(mj: Any, identified: Mapping[str, float]) -> None:
    """Set a model joint's (an ``MjSpec`` joint's) damping and friction loss to the identified ones, its
    armature to 0 (the compiled model's is set from its inertia)."""
    mj.armature = 0.0
    if isinstance(mj.damping, float):  # MuJoCo 3: one coefficient
        mj.damping = identified["viscous"]
    else:  # MuJoCo 4: the polynomial's coefficients, linear first
        damping = mj.damping.copy()
        damping[:] = 0.0
        damping[0] = identified["viscous"]
        mj.damping = damping
    mj.frictionloss = identified["coulomb"]


def couple_robot(spec: RobotSpec, buses: Mapping[str, SimBus]) -> Twin | None:
    """Couple the motors of the simulated ``buses`` (by the robot's bus names) to the model of ``spec``.

    Returns the twin they share, or None when ``spec`` names no model. Joints on
    buses not in ``buses`` are not driven (their model joints move freely).
    """
    if spec.model is None:
        return None
    for j in spec.joints.values():
        bus = buses.get(j.bus)
        if bus is not None and j.sim_params:
            configure(bus.motors[j.id], j.sim_params)
    couplings = [
        Coupling(
            j.name,
            buses[j.bus].motors[j.id],
            j.model_joint or j.name,
            j.gear,
            j.offset,
            j.friction != "model",
            j.identified,
        )
        for j in spec.joints.values()
        if j.bus in buses
    ]
    twin = Twin(spec.model.file, couplings)
    for bus in buses.values():
        _TWINS[bus] = twin
    return twin


def configure(motor: SimMotor, params: Mapping[str, float]) -> None:
    """Start ``motor`` with ``params`` (by name) as its saved configuration, unless it has one."""
    store = motor.params
    if store.saved is not None:
        return
    for name, value in params.items():
        motor.set_param(name, value)
    store.saved = {a: store.ram[a] for a in CONFIG}


class TwinRunner:
    """A thread that advances several buses in lockstep in real time (scaled by ``time_scale``).

    Every bus reaches each 1 ms step before any goes on to the next, so the twin
    they share always integrates the torques every motor computed at the step
    before. Host frames wake it (each bus's ``on_activity``). ``start()``/``stop()``,
    or use it as a context manager; with ``while_attached`` it also ends once the
    in-process clients of every bus have closed (``open_robot`` runs one so).
    """

    IDLE = 0.02
    """Longest sleep (wall s) when nothing is due."""
    MAX_CATCH_UP = 0.05
    """Most wall time one round makes up for (s); beyond it the simulation falls behind."""

    ATTACH_GRACE = 10.0
    """With ``while_attached``: how long (wall s) the buses may wait for their first listener."""

    def __init__(self, buses: Iterable[SimBus], time_scale: float = 1.0, *, while_attached: bool = False) -> None:
        if not time_scale > 0:
            raise ValidationError(f"time_scale={time_scale!r}: must be > 0 simulated seconds per second")
        self.buses = list(buses)
        self.time_scale = time_scale
        self.while_attached = while_attached
        """End by itself once every bus has lost its listeners (its clients closed)."""
        self._stop = False
        self._wake = threading.Event()
        self._thread: threading.Thread | None = None
        self._goal = 0.0
        """Simulated time (s) the buses are brought up to."""
        self._last = 0.0
        """Wall time (monotonic s) of the latest round."""

    def start(self) -> TwinRunner:
        """Start advancing the buses (no-op when already running).

        With one bus, a host frame first brings the twin up to wall time (the bus's ``clock_sync``), as
        the plain simulator's runner does: every answer carries the state of the moment, not that of the
        last round (up to :attr:`IDLE` old)."""
        if self._thread is None:
            self._stop = False
            self._goal = max(b.now for b in self.buses)
            self._last = time.monotonic()
            for bus in self.buses:
                with bus.lock:
                    bus.on_activity = self._wake.set
                    if len(self.buses) == 1:
                        bus.clock_sync = self._sync
            self._thread = threading.Thread(target=self._run, name="drempower-twin", daemon=True)
            self._thread.start()
        return self

    def stop(self) -> None:
        """Stop advancing and wait for the thread to end."""
        self._stop = True
        self._wake.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        self._detach()

    def _detach(self) -> None:
        for bus in self.buses:
            with bus.lock:
                if bus.on_activity == self._wake.set:
                    bus.on_activity = None
                if bus.clock_sync == self._sync:
                    bus.clock_sync = None

    def _sync(self) -> None:
        """A one-bus twin's ``clock_sync``: up to wall time before a host frame enters (the bus lock held)."""
        self._catch_up()

    def _catch_up(self) -> float:
        """Advance every bus in lockstep up to wall time (a round of :meth:`_run`; with one bus, also
        called under its lock before a host frame enters); returns the simulated time reached."""
        buses, step = self.buses, Twin.STEP
        now = time.monotonic()
        self._goal += min(now - self._last, self.MAX_CATCH_UP) * self.time_scale
        self._last = now
        goal = self._goal
        while True:
            t = min(b.now for b in buses)
            if t >= goal - _EPS:
                break
            nxt = min(goal, (math.floor(t / step + _EPS) + 1) * step)
            for bus in buses:
                if bus.now < nxt:
                    bus.advance(nxt - bus.now)
        return goal

    def _run(self) -> None:
        buses, wake, scale = self.buses, self._wake, self.time_scale
        start = time.monotonic()
        one = buses[0].lock if len(buses) == 1 else contextlib.nullcontext()
        seen = False
        while not self._stop:
            if self.while_attached:
                attached = any(b._listeners for b in buses)  # SimTransport.close removes its listener
                seen = seen or attached
                if not attached and (seen or time.monotonic() - start > self.ATTACH_GRACE):
                    break
            wake.clear()
            with one:  # one bus: its clock_sync may catch up from a host's thread too
                goal = self._catch_up()
            due = min(b.next_due() for b in buses)
            wake.wait(min(self.IDLE, max((due - goal) / scale, 0.0)))
        self._detach()

    def __enter__(self) -> TwinRunner:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
