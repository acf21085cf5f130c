"""The robot file: buses and the joints on them, read from a TOML file (the robot layer, the simulator
and the transports read it; :mod:`drempower.robot.config` names the same objects).

::

    [buses.left]
    interface = "sim"          # any interface open_bus takes, with its options
    [buses.right]
    interface = "socketcan"
    channel = "can1"
    [joints.shoulder]
    bus = "left"
    id = 1
    [joints.elbow]
    bus = "right"
    id = 1
    gear = -1.0                # motor output turns per joint turn (sign: direction)
    offset = 0.5               # joint position (rad) when the motor reads 0 deg
    limits = { position = [-1.5, 1.5], speed = 2.0, torque = 5.0, accel = 10.0, max_step = 0.2 }
    on_timeout = "hold"        # when its controller is gone: "hold" (default) or "idle"

``limits`` are soft limits at the joint (rad, rad/s, Nm, rad/s^2, rad; each optional):
a command beyond one is refused before any frame, naming the file and the joint
(see :mod:`drempower.client.engine.gate`). ``on_timeout`` is what the command watchdog
(:mod:`drempower.client.engine.watchdog`) does to the joint when its controller is gone.

Every key of a bus entry but ``interface`` goes to :func:`drempower.open_bus`
(``channel``, ``bitrate``, ``host``, ``port``, ``timeout``, ``time_scale``...;
``profile``, a firmware profile of ``drempower doctor --write-profile``, relative
to the robot file; a sim bus's firmware knobs such as ``status_bits = "kept"``).
A ``"sim"`` bus simulates the motors of its joints.

A robot file may name a physics model (MJCF, or URDF through MuJoCo's import;
the path is relative to the robot file): its simulated motors then drive the
model's joints (see :mod:`drempower.sim.twin`)::

    [model]
    file = "arm.xml"
    [joints.shoulder]
    bus = "left"
    id = 1
    model_joint = "shoulder"   # the model's joint (default: the joint's name)
    friction = "model"         # only the model's damping and friction act (default "motor": both)
    [joints.shoulder.sim_params]   # a simulated motor's configuration (its gains tuned for the arm)
    "axis0.controller.config.pos_gain" = 20.0

A simulated joint's heat (:mod:`drempower.sim.thermal`) takes its constants from ``[joints.NAME.thermal]``
(:data:`THERMAL_KEYS`), over a sim bus's ``thermal = {...}`` for all its motors, over the estimates::

    [joints.shoulder.thermal]
    winding_tau = 600.0        # s
    winding_r_th = 8.0         # K/W
"""

from __future__ import annotations

import math
import os
import re
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from .errors import ConfigError
from .protocol.limits import MAX_NODE, is_motor
from .protocol.parameters import parameter

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib  # type: ignore[import-not-found, no-redef, unused-ignore]

__all__ = [
    "bus_options",
    "BusSpec",
    "JointSpec",
    "ModelSpec",
    "RobotSpec",
    "load_robot",
    "parse_robot",
    "JOINT_NAME",
    "FRICTIONS",
    "THERMAL_KEYS",
    "thermal_table",
    "JointLimit",
    "ModelRange",
    "joint_limits",
    "model_range_of",
]

JOINT_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_.-]*$")
"""What a joint or bus name looks like: it starts with a letter or ``_``, so it never reads as a motor id."""
_JOINT_KEYS = frozenset(("bus", "id", "gear", "offset"))
# the safety keys of a joint: soft limits and the watchdog's action
_SAFETY_KEYS = frozenset(("limits", "on_timeout", "on_overheat", "on_stall", "on_divergence"))
JOINT_LIMITS = {"position": "rad", "speed": "rad/s", "torque": "Nm", "accel": "rad/s^2", "max_step": "rad"}
"""The soft limits a joint can have, in joint units."""
ON_TIMEOUT = ("hold", "idle")
"""What the watchdog may do to a joint whose controller is gone; the first is a joint's default."""
ON_OVERHEAT = ("warn", "hold", "idle")
"""What the health supervisor may do to a joint that overheats or stalls."""
ON_DIVERGENCE = ("warn", "hold", "idle")
"""What the shadow twin (:mod:`drempower.robot.shadow`) may do when a joint diverges from its twin: report
it, hold every joint where it is, or stop every motor (the emergency stop)."""
HEALTH_KEYS: dict[str, tuple[float, float] | tuple[str, ...]] = {
    "period": (0.05, 60.0),
    "warn_c": (0.0, 150.0),
    "warn_margin_c": (0.0, 100.0),
    "act_margin_c": (0.0, 100.0),
    "stall_s": (0.0, 600.0),
    "stall_fraction": (0.1, 1.0),
    "on_overheat": ON_OVERHEAT,
    "on_stall": ON_OVERHEAT,
}
"""The ``[health]`` keys (the supervisor's policy, :class:`~drempower.client.engine.supervisor.HealthPolicy`):
a number's range, or a choice's values."""


THERMAL_KEYS: dict[str, tuple[float, float, str]] = {
    "ambient_c": (-40.0, 80.0, "degC"),
    "winding_r_th": (0.1, 100.0, "K/W"),
    "winding_tau": (1.0, 36000.0, "s"),
    "board_r_th": (0.1, 100.0, "K/W"),
    "board_tau": (1.0, 36000.0, "s"),
    "board_idle_w": (0.0, 50.0, "W"),
    "fet_resistance": (0.0, 1.0, "ohm"),
}
"""A simulated motor's thermal constants (:class:`~drempower.sim.thermal.ThermalModel`'s fields): each key's
(low, high, unit)."""


def thermal_table(value: object, where: str) -> dict[str, float]:
    """A ``thermal`` table, checked: known keys (:data:`THERMAL_KEYS`), finite numbers in their range;
    a :class:`ConfigError` naming ``where``, the key, the value and the range otherwise."""
    out: dict[str, float] = {}
    for key, v in _table(value, where).items():
        rng = THERMAL_KEYS.get(key)
        if rng is None:
            raise ConfigError(f"{where}: unknown key {key!r}: the keys are {', '.join(THERMAL_KEYS)}")
        lo, hi, unit = rng
        x = _number(v, f"{where}: {key}")
        if not lo <= x <= hi:
            raise ConfigError(f"{where}: {key}={v!r}: expected {lo:g}..{hi:g} {unit}")
        out[key] = x
    return out


@dataclass(frozen=True)
class BusSpec:
    """One bus: its name, ``interface`` and the other :func:`~drempower.open_bus` options."""

    name: str
    interface: str
    options: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class JointSpec:
    """One joint: motor ``id`` on bus ``bus``; ``gear`` motor turns per joint turn, ``offset`` rad."""

    name: str
    bus: str
    id: int
    gear: float = 1.0
    offset: float = 0.0
    model_joint: str | None = None
    """The physics model's joint this joint is (None: the joint's own name)."""
    friction: str = "motor"
    """``"motor"``: the motor's friction and rotor inertia act besides the model's; ``"model"``: only the model's."""
    sim_params: Mapping[str, float] = field(default_factory=dict)
    """Parameters (by name) a simulated motor of this joint starts with when it has no saved configuration."""
    limits: Mapping[str, Any] = field(default_factory=dict)
    """Soft limits in joint units (:data:`JOINT_LIMITS`): ``position`` (low, high) rad, the others magnitudes."""
    on_timeout: str = ON_TIMEOUT[0]
    """What the command watchdog does when the joint's controller is gone: ``hold`` or ``idle``."""
    on_overheat: str | None = None
    """What the health supervisor does when the joint overheats (None: ``[health]``'s ``on_overheat``)."""
    on_stall: str | None = None
    """What the health supervisor does when the joint stalls (None: ``[health]``'s ``on_stall``)."""
    on_divergence: str | None = None
    """What the shadow twin does when the joint diverges from its twin (:data:`ON_DIVERGENCE`; None:
    ``[model]``'s ``on_divergence``)."""
    identified: Mapping[str, float] | None = None
    """The joint's identified ``inertia`` kg m^2, ``viscous`` Nm s/rad, ``coulomb`` Nm (``drempower identify
    --write``): the twin's joint has them in place of the model's and the motor's."""
    thermal: Mapping[str, float] | None = None
    """A simulated joint's thermal constants (``[joints.NAME.thermal]``, :data:`THERMAL_KEYS`) over its bus's
    and the estimates; None: those."""


@dataclass(frozen=True)
class RobotSpec:
    """Buses and joints, in the order of the file; ``source`` names where they came from;
    ``model`` the physics model of the robot, if the file names one."""

    buses: Mapping[str, BusSpec]
    joints: Mapping[str, JointSpec]
    source: str = "robot"
    model: ModelSpec | None = None
    ros2_control: Mapping[str, Any] = field(default_factory=dict)
    """The bridge's ros2_control settings (``[ros2_control]``: :data:`ROS2_CONTROL_KEYS`)."""
    health: Mapping[str, Any] | None = None
    """The health supervisor's policy (``[health]``: :data:`HEALTH_KEYS`); None: the file does not ask for it."""

    def joints_on(self, bus: str) -> list[JointSpec]:
        """The joints of bus ``bus``, in file order."""
        return [j for j in self.joints.values() if j.bus == bus]

    def on_divergence(self, joint: str) -> str:
        """What the shadow twin does when joint ``joint`` diverges: the joint's ``on_divergence``, else
        ``[model]``'s, else ``"warn"``."""
        own = self.joints[joint].on_divergence
        if own is not None:
            return own
        if self.model is not None and self.model.on_divergence is not None:
            return self.model.on_divergence
        return ON_DIVERGENCE[0]

    def on_timeout(self, bus: str) -> dict[int, str]:
        """``{motor id: "hold"|"idle"}`` of bus ``bus``'s joints, for its command watchdog
        (:class:`~drempower.client.engine.watchdog.Watchdog`)."""
        return {j.id: j.on_timeout for j in self.joints_on(bus)}

    def open_options(self, bus: str) -> dict[str, Any]:
        """The :func:`~drempower.open_bus` keyword arguments of bus ``bus`` (a sim bus gets its joints' ids;
        with a model, the robot and the bus's name, to simulate its joints on the model)."""
        spec = self.buses[bus]
        kw: dict[str, Any] = {"interface": spec.interface, **spec.options}
        if spec.interface == "sim" and self.model is not None:
            kw.update(robot=self, robot_bus=bus)
        elif spec.interface == "sim":
            kw["motors"] = sorted(j.id for j in self.joints_on(bus))
        if spec.interface == "sim":
            kw.update(self.sim_thermal(bus))
        return kw

    def sim_thermal(self, bus: str) -> dict[str, Any]:
        """The simulated bus ``bus``'s per-motor thermal constants (``motor_thermal``, a SimBus argument) of
        its joints' ``thermal`` tables (empty: none has one)."""
        per = {j.id: dict(j.thermal) for j in self.joints_on(bus) if j.thermal}
        return {"motor_thermal": per} if per else {}


def _name(kind: str, name: str, where: str) -> str:
    if not JOINT_NAME.match(name):
        raise ConfigError(
            f"{where}: {kind} name {name!r}: use letters, digits, '_', '.' or '-', starting with a letter or '_'"
        )
    return name


def _table(value: object, where: str) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise ConfigError(f"{where}: expected a table, got {value!r}")
    return value


def _number(value: object, where: str, *, nonzero: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ConfigError(f"{where}={value!r}: expected a finite number")
    if nonzero and value == 0:
        raise ConfigError(f"{where}=0: a gear of 0 would make every joint position the same; use e.g. 1.0 or -1.0")
    return float(value)


def _limits(value: object, where: str) -> dict[str, Any]:
    """A joint's ``limits`` table, checked: known names, numbers, position low <= high, magnitudes > 0."""
    table = _table(value, where)
    out: dict[str, Any] = {}
    for name, v in table.items():
        unit = JOINT_LIMITS.get(name)
        if unit is None:
            raise ConfigError(f"{where}: unknown limit {name!r}: the limits are {', '.join(JOINT_LIMITS)}")
        if name == "position":
            if not isinstance(v, list) or len(v) != 2:
                raise ConfigError(f"{where}.position={v!r}: expected [low, high] in rad")
            low, high = _number(v[0], f"{where}.position"), _number(v[1], f"{where}.position")
            if low > high:
                raise ConfigError(f"{where}.position={v!r}: low is above high")
            out[name] = (low, high)
        else:
            x = _number(v, f"{where}.{name}")
            if x <= 0:
                raise ConfigError(f"{where}.{name}={v!r}: a limit is > 0 ({unit}, by magnitude)")
            out[name] = x
    return out


def parse_robot(data: Mapping[str, Any], source: str = "robot", base: str | None = None) -> RobotSpec:
    """Check a robot description (the TOML file as a dict); raises :class:`ConfigError` naming the entry and key.

    ``base``: the folder a model's relative path starts from (default: the current one)."""
    unknown = sorted(set(data) - {"buses", "joints", "model", "ros2_control", "health"})
    if unknown:
        raise ConfigError(
            f"{source}: unknown section {unknown[0]!r}: "
            "a robot file has [buses.NAME], [joints.NAME], [model], [ros2_control] and [health]"
        )
    buses: dict[str, BusSpec] = {}
    for name, entry in _table(data.get("buses", {}), f"{source}: buses").items():
        where = f"{source}: [buses.{name}]"
        _name("bus", name, where)
        opts = dict(_table(entry, where))
        interface = opts.pop("interface", None)
        if not isinstance(interface, str) or not interface:
            raise ConfigError(f"{where}: interface={interface!r}: give the interface, e.g. 'sim', 'socketcan'")
        if interface == "sim" and "motors" in opts:
            raise ConfigError(f"{where}: motors: a sim bus simulates the motors of its joints; leave motors out")
        if "thermal" in opts:
            if interface != "sim":
                raise ConfigError(f"{where}: thermal: only a sim bus simulates heat (its motors' constants)")
            opts["thermal"] = thermal_table(opts["thermal"], f"{where}: thermal")
        profile = opts.get("profile")
        if isinstance(profile, str) and profile:  # a firmware profile file, relative to the robot file
            opts["profile"] = os.path.normpath(os.path.join(base or os.getcwd(), os.path.expanduser(profile)))
        buses[name] = BusSpec(name, interface, opts)
    if not buses:
        raise ConfigError(f"{source}: no [buses.NAME] entry: a robot needs at least one bus")
    joints: dict[str, JointSpec] = {}
    taken: dict[tuple[str, int], str] = {}
    for name, entry in _table(data.get("joints", {}), f"{source}: joints").items():
        where = f"{source}: [joints.{name}]"
        _name("joint", name, where)
        j = _table(entry, where)
        extra = sorted(set(j) - _JOINT_KEYS - _MODEL_JOINT_KEYS - _SAFETY_KEYS)
        if extra:
            raise ConfigError(
                f"{where}: unknown key {extra[0]!r}: a joint has bus, id, gear, offset, limits, on_timeout, "
                "on_overheat, on_stall, on_divergence, model_joint, friction, sim_params, identified and thermal"
            )
        bus = j.get("bus")
        if bus not in buses:
            raise ConfigError(f"{where}: bus={bus!r}: not one of the buses ({', '.join(buses)})")
        ident = j.get("id")
        if not is_motor(ident):
            raise ConfigError(f"{where}: id={ident!r}: motor ids are 1..{MAX_NODE}")
        other = taken.get((bus, ident))
        if other is not None:
            raise ConfigError(f"{where}: id={ident}: joint {other!r} already is motor {ident} on bus {bus!r}")
        taken[(bus, ident)] = name
        gear = _number(j.get("gear", 1.0), f"{where}: gear", nonzero=True)
        offset = _number(j.get("offset", 0.0), f"{where}: offset")
        limits = _limits(j.get("limits", {}), f"{where}: limits")
        on_timeout = j.get("on_timeout", ON_TIMEOUT[0])
        if on_timeout not in ON_TIMEOUT:
            raise ConfigError(f"{where}: on_timeout={on_timeout!r}: expected 'hold' or 'idle'")
        on_overheat = j.get("on_overheat")
        if on_overheat is not None and on_overheat not in ON_OVERHEAT:
            raise ConfigError(f"{where}: on_overheat={on_overheat!r}: expected 'warn', 'hold' or 'idle'")
        on_stall = j.get("on_stall")
        if on_stall is not None and on_stall not in ON_OVERHEAT:
            raise ConfigError(f"{where}: on_stall={on_stall!r}: expected 'warn', 'hold' or 'idle'")
        on_divergence = _on_divergence(j, where)
        joints[name] = JointSpec(
            name,
            bus,
            ident,
            gear,
            offset,
            limits=limits,
            on_timeout=on_timeout,
            on_overheat=on_overheat,
            on_stall=on_stall,
            on_divergence=on_divergence,
            **_model_joint(j, where),
        )
    if not joints:
        raise ConfigError(f"{source}: no [joints.NAME] entry: a robot needs at least one joint")
    empty = [b for b in buses if not any(j.bus == b for j in joints.values())]
    if empty:
        raise ConfigError(f"{source}: [buses.{empty[0]}] carries no joint: give it one or remove it")
    model = _model(data["model"], source, base) if "model" in data else None
    if model is None:
        named = next((n for n, j in joints.items() if j.on_divergence is not None), None)
        if named is not None:
            raise ConfigError(
                f"{source}: [joints.{named}]: on_divergence: the shadow twin needs a [model]; give one or leave it out"
            )
    ros2 = _ros2_control(data.get("ros2_control", {}), f"{source}: [ros2_control]")
    health = _health(data["health"], f"{source}: [health]") if "health" in data else None
    return RobotSpec(buses, joints, source, model, ros2, health)


def _health(value: object, where: str) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, v in _table(value, where).items():
        allowed = HEALTH_KEYS.get(key)
        if allowed is None:
            raise ConfigError(f"{where}: unknown key {key!r}: the keys are {', '.join(HEALTH_KEYS)}")
        if isinstance(allowed[0], str):
            if v not in allowed:
                raise ConfigError(f"{where}: {key}={v!r}: expected one of {', '.join(repr(a) for a in allowed)}")
            out[key] = v
            continue
        lo, hi = allowed
        x = _number(v, f"{where}: {key}")
        if not lo <= x <= hi:
            raise ConfigError(f"{where}: {key}={v!r}: expected {lo}..{hi}")
        out[key] = x
    return out


ROS2_CONTROL_KEYS = {
    "joint_commands_topic": str,
    "joint_states_topic": str,
    "command_interfaces": list,
    "action": str,
    "kp": float,
    "kd": float,
}
"""The ``[ros2_control]`` keys: TopicBasedSystem's topics, the joints' command interfaces, the
FollowJointTrajectory action's name, impedance gains (see ``drempower bridge``)."""


def _ros2_control(value: object, where: str) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, v in _table(value, where).items():
        kind = ROS2_CONTROL_KEYS.get(key)
        if kind is None:
            raise ConfigError(f"{where}: unknown key {key!r}: the keys are {', '.join(ROS2_CONTROL_KEYS)}")
        if kind is float:
            out[key] = _number(v, f"{where}: {key}")
        elif kind is list and not (isinstance(v, list) and all(isinstance(x, str) for x in v)):
            raise ConfigError(f'{where}: {key}={v!r}: expected a list of names, e.g. ["position", "velocity"]')
        elif kind is str and not (isinstance(v, str) and v.strip()):
            raise ConfigError(f"{where}: {key}={v!r}: expected a ROS 2 name")
        else:
            out[key] = v
    return out


def load_robot(path: str | os.PathLike[str]) -> RobotSpec:
    """Read and check the robot file ``path``; raises :class:`ConfigError` naming the file and what is wrong."""
    where = os.fspath(path)
    try:
        with open(where, "rb") as f:
            data = tomllib.load(f)
    except OSError as exc:
        raise ConfigError(f"cannot read robot file {where}: {exc.strerror or exc}") from exc
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{where}: not valid TOML: {exc}") from exc
    return parse_robot(data, where, os.path.dirname(os.path.abspath(where)))


def bus_options(spec: RobotSpec, bus: str, overrides: Mapping[str, Any]) -> dict[str, Any]:
    """``open_bus`` arguments of ``bus``: the file's, then ``overrides`` (None values skipped);
    ``sim`` options go to sim buses only."""
    kw = spec.open_options(bus)
    for key, value in overrides.items():
        if key == "sim":
            if kw["interface"] == "sim" and value:
                kw.update(value)
        elif value is not None:
            kw[key] = value
    return kw


# ---------------------------------------------------------------------- the physics model

FRICTIONS = ("motor", "model")
"""A joint's ``friction``: the motor's own friction and rotor inertia act too, or only the model's."""
_MODEL_JOINT_KEYS = frozenset(("model_joint", "friction", "sim_params", "identified", "thermal"))
IDENTIFIED_KEYS = ("inertia", "viscous", "coulomb")
"""The keys of a joint's ``identified`` table."""
_MODEL_KEYS = frozenset(("file", "on_divergence"))


@dataclass(frozen=True)
class ModelSpec:
    """The robot's physics model: ``file`` (absolute path) of an MJCF or URDF model; ``on_divergence``
    what the shadow twin does when a joint without its own ``on_divergence`` diverges (None: ``"warn"``)."""

    file: str
    on_divergence: str | None = None


def _on_divergence(entry: Mapping[str, Any], where: str) -> str | None:
    """An entry's ``on_divergence`` (one of :data:`ON_DIVERGENCE`), or None when it has none."""
    value = entry.get("on_divergence")
    if value is not None and value not in ON_DIVERGENCE:
        raise ConfigError(f"{where}: on_divergence={value!r}: expected one of {', '.join(map(repr, ON_DIVERGENCE))}")
    return value


def _model(value: object, source: str, base: str | None) -> ModelSpec:
    where = f"{source}: [model]"
    entry = _table(value, where)
    extra = sorted(set(entry) - _MODEL_KEYS)
    if extra:
        raise ConfigError(f"{where}: unknown key {extra[0]!r}: [model] has file and on_divergence")
    file = entry.get("file")
    if not isinstance(file, str) or not file:
        raise ConfigError(f"{where}: file={file!r}: give the model's MJCF or URDF file, e.g. 'arm.xml'")
    path = os.path.normpath(os.path.join(base or os.getcwd(), os.path.expanduser(file)))
    if not os.path.isfile(path):
        raise ConfigError(f"{where}: file={file!r}: no such file ({path})")
    return ModelSpec(path, _on_divergence(entry, where))


def _model_joint(j: Mapping[str, Any], where: str) -> dict[str, Any]:
    """A joint entry's ``model_joint``, ``friction`` and ``sim_params`` (JointSpec's keyword arguments)."""
    model_joint = j.get("model_joint")
    if model_joint is not None and (not isinstance(model_joint, str) or not model_joint):
        raise ConfigError(f"{where}: model_joint={model_joint!r}: give the name of a joint of the model")
    friction = j.get("friction", "motor")
    if friction not in FRICTIONS:
        raise ConfigError(f"{where}: friction={friction!r}: one of {', '.join(map(repr, FRICTIONS))}")
    params: dict[str, float] = {}
    for key, value in _table(j.get("sim_params", {}), f"{where}: sim_params").items():
        try:
            p = parameter(key)
        except ValueError:
            raise ConfigError(f"{where}: sim_params: {key!r} is not a parameter name (see drempower params)") from None
        if not p.writable:
            raise ConfigError(f"{where}: sim_params: {key!r} is read-only")
        params[p.name] = _number(value, f"{where}: sim_params: {key}")
    thermal = thermal_table(j["thermal"], f"{where}: thermal") if "thermal" in j else None
    return {
        "model_joint": model_joint,
        "friction": friction,
        "sim_params": params,
        "identified": _identified(j, where),
        "thermal": thermal,
    }


def _identified(j: Mapping[str, Any], where: str) -> dict[str, float] | None:
    """A joint entry's ``identified`` table (inertia, viscous, coulomb: each a number >= 0), or None."""
    if "identified" not in j:
        return None
    entry = _table(j["identified"], f"{where}: identified")
    extra = sorted(set(entry) - set(IDENTIFIED_KEYS))
    if extra:
        raise ConfigError(f"{where}: identified: unknown key {extra[0]!r}: it has {', '.join(IDENTIFIED_KEYS)}")
    out: dict[str, float] = {}
    for key in IDENTIFIED_KEYS:
        if key not in entry:
            raise ConfigError(f"{where}: identified: {key} missing (it has {', '.join(IDENTIFIED_KEYS)})")
        value = _number(entry[key], f"{where}: identified: {key}")
        if not 0 <= value < math.inf:
            raise ConfigError(f"{where}: identified: {key}={value!r}: expected a finite number >= 0")
        out[key] = value
    return out


# ---------------------------------------------------------------------- a joint's limits, from one place

ModelRange = Callable[[str], "tuple[float, float] | None"]
"""``range(model_joint)``: the model joint's (low, high) rad, None when it has no range."""


class JointLimit(dict[str, Any]):
    """Limits at one joint (joint units: rad, rad/s, Nm, rad/s^2, rad) with ``where`` each was set."""

    def __init__(self, values: dict[str, Any], where: dict[str, str]) -> None:
        super().__init__(values)
        self.where = where


def model_range_of(spec: RobotSpec, model: Any = None) -> ModelRange | None:
    """The joint ranges of the robot's model (``model``: a ``mujoco.MjModel`` already loaded, e.g. the
    twin's); None when the file names no model or MuJoCo is not installed."""
    if model is None:
        if spec.model is None:
            return None
        try:
            import mujoco
        except ImportError:
            return None
        model = mujoco.MjModel.from_xml_path(spec.model.file)
    import mujoco

    def joint_range(joint: str) -> tuple[float, float] | None:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint)
        if jid < 0 or not model.jnt_limited[jid]:
            return None
        return float(model.jnt_range[jid][0]), float(model.jnt_range[jid][1])

    return joint_range


def joint_limits(spec: RobotSpec, name: str, model_range: ModelRange | None) -> JointLimit:
    """Joint ``name``'s limits (joint units): the file's ``limits``, with the model joint's range as its
    position limit where the file gives none or a wider one; ``.where`` names the source of each."""
    js = spec.joints[name]
    own = dict(js.limits)
    file_where = f"{spec.source}: [joints.{name}] limits"
    where = dict.fromkeys(own, file_where)
    rng = None if model_range is None else model_range(js.model_joint or name)
    if rng is not None:
        model_where = f"the range of model joint {js.model_joint or name!r}"
        mine = own.get("position")
        if mine is None:
            own["position"], where["position"] = (float(rng[0]), float(rng[1])), model_where
        else:
            low, high = max(mine[0], rng[0]), min(mine[1], rng[1])
            if low > high:  # no position both allow: the file's own range is refused entirely
                low, high = mine
            own["position"] = (low, high)
            if (low, high) != tuple(mine):
                where["position"] = model_where if (low, high) == tuple(rng) else f"{file_where} and {model_where}"
    return JointLimit(own, where)
