"""``--robot FILE``: joint names where motor ids go, and commands over the robot's buses.

After parsing, :func:`apply_robot` turns the joint names of ``IDS`` into motor
ids and groups them by bus. A command whose motors are all on one bus runs on
that bus as usual. Across several buses, ``stop`` sends the emergency stop to
every bus at once and ``move`` is one synchronised move (it reports the skew
between the buses' start frames); other commands run once per bus, in the
order of the file. A command that sets ``robot_whole`` (``record``, ``bridge``, ``dash``)
opens the robot's buses itself: it gets ``args.robot_spec`` and ``args.robot_groups``.
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import io
import json
import math
import re
import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

from ..errors import FieldRangeError, SoftLimitError
from ..robot.joint import Gearing
from ..robotfile import JOINT_NAME, JointSpec, RobotSpec, load_robot
from ._output import emit, is_terminal, json_line
from ._usage import UsageError

__all__ = [
    "apply_robot",
    "joint_or_ids",
    "joint_record",
    "joint_refusal",
    "with_units",
    "named_joints",
    "rate_scale",
    "rates_at_joint",
    "run_command",
    "to_joint_angle",
    "to_motor",
]

_ONE_BUS = frozenset(("monitor", "speed", "torque", "impedance"))
"""Commands that keep running (one bus at a time would never reach the next): their joints must share a bus."""
_PER_BUS = frozenset(("scan",))
"""Commands without joint names that still make sense once per bus."""
_CONNECTIONS = {"sim": "--sim", "serial": "--serial", "uart": "--uart", "interface": "-i/--interface"}


def joint_or_ids(parse: Callable[[str], list[int]]) -> Callable[[str], list[int | str]]:
    """An IDS argument type that also takes joint names (``elbow``, ``shoulder,elbow``), kept as text."""

    def parse_words(text: str) -> list[int | str]:
        parts = [p for p in text.replace(" ", "").split(",") if p]
        if parts and text.strip().lower() != "all" and all(JOINT_NAME.match(p) for p in parts):
            return list(parts)
        return list(parse(text))

    parse_words.__name__ = getattr(parse, "__name__", "ids")
    return parse_words


def _groups(spec: RobotSpec, words: list[int | str]) -> dict[str, list[int]]:
    """``{bus: [ids]}`` of the joint names and ids given (every bus with all its joints for none or ``all``)."""
    if not words or words == [0]:
        return {b: [0] if words else [j.id for j in spec.joints_on(b)] for b in spec.buses}
    ids = [w for w in words if isinstance(w, int)]
    if ids and len(spec.buses) > 1:
        raise UsageError(
            f"motor ids ({', '.join(map(str, ids))}) are ambiguous with a robot of several buses "
            f"({', '.join(spec.buses)}): name joints ({', '.join(spec.joints)})"
        )
    out: dict[str, list[int]] = {}
    for w in words:
        if isinstance(w, int):
            out.setdefault(next(iter(spec.buses)), []).append(w)
            continue
        j = spec.joints.get(w)
        if j is None:
            raise UsageError(f"joint {w!r}: not in {spec.source} (joints: {', '.join(spec.joints)})")
        if j.id in out.get(j.bus, []):
            raise UsageError(f"joint {w!r} named twice")
        out.setdefault(j.bus, []).append(j.id)
    return out


def apply_robot(args: argparse.Namespace) -> None:
    """Resolve joint names of ``args.ids`` with ``--robot``; refuse names without it. Sets ``args.robot_groups``."""
    words: list[int | str] = list(getattr(args, "ids", None) or []) if getattr(args, "robot_ids", False) else []
    robot = getattr(args, "robot", None)
    if robot is None:
        names = [w for w in words if isinstance(w, str)]
        if names:
            raise UsageError(f"joint names ({', '.join(names)}) need --robot FILE")
        return
    given = [flag for name, flag in _CONNECTIONS.items() if getattr(args, name, None)]
    if given:
        raise UsageError(f"give one connection: --robot and {given[0]} conflict")
    spec = load_robot(robot)
    args.robot_spec = spec
    args.robot_groups = _groups(spec, words)
    sims = [b for b in args.robot_groups if spec.buses[b].interface == "sim"]
    if sims and is_terminal(sys.stderr):
        print(own_twin_notice(robot, spec, sims), file=sys.stderr)


def own_twin_notice(robot: str, spec: RobotSpec, sims: list[str]) -> str:
    """What a command on a robot file with ``sim`` buses says on a terminal: it simulates them itself."""
    what = "a twin" if spec.model is not None else "simulated motors"
    buses = ", ".join(sims)
    return (
        f"drempower: bus{'es' if len(sims) > 1 else ''} {buses} of {robot} simulated by this command: {what} of its "
        f"own, gone when it ends; to share one: drempower sim --robot {robot} (it prints the file to use)"
    )


def _joints_by_bus(spec: RobotSpec) -> str:
    return "; ".join(f"{b}: {', '.join(j.name for j in spec.joints_on(b))}" for b in spec.buses)


def _one(args: argparse.Namespace, bus: str, ids: list[int]) -> argparse.Namespace:
    part = copy.copy(args)
    part.robot_bus = bus
    spec: RobotSpec = args.robot_spec
    words = list(getattr(args, "ids", None) or []) if getattr(args, "robot_ids", False) else []
    chosen = [spec.joints[w] for w in words if isinstance(w, str)] if words and words != [0] else []
    if getattr(args, "robot_ids", False) and not words:  # no IDS: every joint of the bus, by name
        chosen = spec.joints_on(bus)
    part.robot_named = {j.id: j for j in chosen if j.bus == bus}
    if getattr(args, "robot_ids", False):
        part.ids = ids
    return part


def with_units(args: argparse.Namespace, rec: dict[str, Any], id: int) -> dict[str, Any]:
    """``rec`` with ``units`` (``joint`` or ``motor``) under ``--robot``; as it is without."""
    if getattr(args, "robot_spec", None) is None:
        return rec
    return {**rec, "units": "joint" if id in named_joints(args) else "motor"}


def named_joints(args: argparse.Namespace) -> dict[int, JointSpec]:
    """``{motor id: joint}`` of the joints this command's IDS named (those take joint units; a motor id
    takes motor units)."""
    named: dict[int, JointSpec] = getattr(args, "robot_named", None) or {}
    return named


_RPM = 2 * math.pi / 60
"""rad/s per r/min."""
_TO_MOTOR: dict[str, Callable[[Gearing, float], float]] = {
    "angle": lambda g, v: g.motor_angle(math.radians(v)),
    "step": lambda g, v: g.motor_step(math.radians(v)),
    "speed": lambda g, v: g.motor_speed(v * _RPM),
    "torque": lambda g, v: g.motor_torque(v),
}
"""Joint units of the command line (deg, r/min and Nm at the joint) to the motor's, by kind of value."""


def to_motor(args: argparse.Namespace, ids: Sequence[int], values: Sequence[float], kind: str) -> list[float]:
    """``values`` (one per motor of ``ids``) in motor units: a named joint's value is in joint units
    (deg at the joint for ``angle``/``step``, r/min at the joint for ``speed``, Nm at the joint for
    ``torque``), converted through its gear and offset; a motor id's stays as given."""
    named = named_joints(args)
    conv = _TO_MOTOR[kind]
    return [conv(Gearing(named[i]), v) if i in named else v for i, v in zip(ids, values, strict=True)]


def to_joint_angle(args: argparse.Namespace, id: int, angle: float) -> float:
    """A motor angle (deg) of motor ``id`` in the command line's units: deg at the joint for a named joint."""
    j = named_joints(args).get(id)
    return angle if j is None else math.degrees(Gearing(j).joint_state_angle(angle))


def joint_record(args: argparse.Namespace, rec: dict[str, Any]) -> dict[str, Any]:
    """A reading's record (``position_deg``, ``speed_rpm``, ``torque_nm``) in the command line's units:
    at the joint for a named joint (deg, r/min, Nm there), with ``units`` saying which."""
    j = named_joints(args).get(rec.get("id"))  # type: ignore[arg-type]
    if j is None:
        return {**rec, "units": "motor"} if getattr(args, "robot_spec", None) is not None else rec
    g = Gearing(j)
    out = dict(rec)
    if out.get("position_deg") is not None:
        out["position_deg"] = round(math.degrees(g.joint_state_angle(out["position_deg"])), 4)
    if out.get("speed_rpm") is not None:
        out["speed_rpm"] = out["speed_rpm"] / j.gear
    if out.get("torque_nm") is not None:
        out["torque_nm"] = out["torque_nm"] * j.gear
    return {**out, "units": "joint"}


def rate_scale(args: argparse.Namespace, ids: Sequence[int]) -> float:
    """The factor from a rate at the joints (r/min, (r/min)/s) to the motors': the smallest gear of the
    named joints among ``ids``, so that no joint turns faster than asked (1 for motor ids)."""
    named = named_joints(args)
    gears = [abs(named[i].gear) for i in ids if i in named]
    return min(gears) if gears and len(gears) == len(ids) else 1.0


@contextlib.contextmanager
def rates_at_joint(scale: float, options: Mapping[str, str]) -> Iterator[None]:
    """Name a refused rate in the units it was typed in: a rate given at the joints and multiplied by
    ``scale`` (:func:`rate_scale`) for the motors is refused with the value typed and the range at the
    joint, the motor's value and range said after it. ``options`` maps the library's field to the option
    (``param (accel)`` -> ``--accel``); other errors, and every error at ``scale`` 1, pass unchanged."""
    try:
        yield
    except FieldRangeError as exc:
        field = re.sub(r" \((joint|motor) [^)]*\)$", "", exc.field)  # a robot's per-joint field: the option's
        option = options.get(field)
        if scale == 1.0 or option is None or not isinstance(exc.value, (int, float)):
            raise
        raise UsageError(
            f"argument {option}: {exc.value / scale:g} at the joint is out of range: allowed "
            f"{exc.low / scale:g}..{exc.high / scale:g} at the joint ({exc.value:g} at the motor through the gear "
            f"{scale:g}, where the motor allows {exc.low:g}..{exc.high:g})"
        ) from None


_AT_JOINT: dict[str, tuple[str, Callable[[Gearing, float], float]]] = {
    "position": ("deg", lambda g, v: math.degrees(g.joint_state_angle(v))),
    "max_step": ("deg", lambda g, v: v / g.gear),
    "speed": ("r/min", lambda g, v: v / g.gear),
    "accel": ("(r/min)/s", lambda g, v: v / g.gear),
    "torque": ("Nm", lambda g, v: v * g.gear),
}
"""A soft limit's unit and the motor's value of it at the joint (deg, r/min, (r/min)/s, Nm there)."""


def joint_refusal(args: argparse.Namespace, exc: Exception) -> str:
    """The words of a refusal: a soft limit refused for a joint the command line named (whose value
    was typed at the joint) says the value and the limit at the joint, the motor's figures after them;
    every other refusal as it is."""
    spec: RobotSpec | None = getattr(args, "robot_spec", None)
    groups: dict[str, list[int]] = getattr(args, "robot_groups", None) or {}
    if not isinstance(exc, SoftLimitError) or spec is None or len(groups) != 1 or exc.limit not in _AT_JOINT:
        return str(exc)
    (bus,) = groups
    words = list(getattr(args, "ids", None) or []) if getattr(args, "robot_ids", False) else []
    named = {spec.joints[w].id: spec.joints[w] for w in words if isinstance(w, str) and w in spec.joints}
    if not words:  # no IDS: every joint of the bus, by name
        named = {j.id: j for j in spec.joints_on(bus)}
    j = named.get(exc.node)
    if j is None or j.bus != bus or not isinstance(exc.value, (int, float)):
        return str(exc)
    unit, at = _AT_JOINT[exc.limit]
    g = Gearing(j)
    lo, hi = sorted((at(g, exc.low), at(g, exc.high)))
    return (
        f"joint {j.name}: {exc.limit} {at(g, float(exc.value)):g} {unit} at the joint is beyond its soft limit "
        f"{lo:g}..{hi:g} {unit} at the joint (motor {exc.node}: {exc.value:g} {unit}, limit {exc.low:g}..{exc.high:g} "
        f"{unit}) (set by {exc.where})"
    )


def run_command(args: argparse.Namespace) -> int:
    """Run the command over the robot's buses (see the module docstring)."""
    groups: dict[str, list[int]] = args.robot_groups
    if getattr(args, "robot_whole", False):  # the command opens the robot's buses itself (record, bridge, dash)
        return int(args.func(args))
    if len(groups) == 1:
        ((bus, ids),) = groups.items()
        return int(args.func(_one(args, bus, ids)))
    if args.command == "stop":
        return _stop(args, groups)
    if args.command == "move":
        return _move(args, groups)
    if not getattr(args, "robot_ids", False) and args.command not in _PER_BUS:
        raise UsageError(
            f"{args.command} takes no joint names; with a robot of several buses, connect to one bus with its "
            "own connection options"
        )
    if args.command in _ONE_BUS:
        raise UsageError(f"{args.command} runs on one bus: name joints of one bus ({_joints_by_bus(args.robot_spec)})")
    worst = 0
    spec: RobotSpec = args.robot_spec
    for bus, ids in groups.items():
        names = {j.id: j.name for j in spec.joints_on(bus)}
        if not getattr(args, "json", False):
            shown = ", ".join(f"{names[i]}={i}" if i in names else str(i) for i in ids)
            print(f"bus {bus} ({shown}):", flush=True)
            worst = max(worst, args.func(_one(args, bus, ids)))
            continue
        out = io.StringIO()
        try:
            with contextlib.redirect_stdout(out):
                worst = max(worst, args.func(_one(args, bus, ids)))
        finally:  # each JSON line says which bus and joint it is about
            for line in out.getvalue().splitlines():
                rec = json.loads(line)
                if not isinstance(rec, dict):
                    sys.stdout.write(line + "\n")
                    continue
                joint = names.get(rec["id"]) if isinstance(rec.get("id"), int) else None
                extra: dict[str, Any] = {"bus": bus} | ({"joint": joint} if joint else {})
                sys.stdout.write(json_line(extra | rec) + "\n")
    return worst


def _open(args: argparse.Namespace) -> Any:
    from ..robot import open_robot

    return open_robot(args.robot_spec, timeout=args.timeout, retries=args.retries, stop_on_close=False)


def _names(args: argparse.Namespace, groups: dict[str, list[int]]) -> list[str]:
    spec: RobotSpec = args.robot_spec
    return [j.name for j in spec.joints.values() if j.id in groups.get(j.bus, [])]


def _stop(args: argparse.Namespace, groups: dict[str, list[int]]) -> int:
    from ._output import report, sent

    if not args.ids or args.ids == [0]:  # none named, or all: every motor of every bus
        groups = {b: [0] for b in groups}
    with _open(args) as robot:
        if all(ids == [0] for ids in groups.values()):
            robot.estop()
            text = f"emergency stop sent to every motor on buses {', '.join(groups)}"
        else:
            robot.estop(_names(args, groups))
            text = f"emergency stop sent to joints {', '.join(_names(args, groups))}"
    report(args, text, [{"bus": b, **r} for b, ids in groups.items() for r in sent(ids, "estop")])
    return 0


def _move(args: argparse.Namespace, groups: dict[str, list[int]]) -> int:
    from ..client import PositionMode
    from ..client.engine.session import DEFAULT_MOVE_TIMEOUT
    from ._motion import stop_commanded
    from ._position import _FIELDS, _MODES, _params

    def _move_fields(mode: PositionMode) -> dict[str, str]:
        return _FIELDS[mode] if mode is PositionMode.Q else {}

    names = _names(args, groups)
    order = [w for w in args.ids if isinstance(w, str)]
    names = order if sorted(order) == sorted(names) else names
    angles = list(args.values) * len(names) if len(args.values) == 1 else list(args.values)
    if len(angles) != len(names):
        raise UsageError(f"{len(names)} joints but {len(args.values)} angle values: give one for all or one each")
    mode = _MODES[args.mode]
    speed, param = _params(args, mode)
    spec: RobotSpec = args.robot_spec
    gears = {n: Gearing(spec.joints[n]) for n in names}  # deg at each joint, to its motor's deg
    kind = "step" if args.relative else "angle"
    motor = {n: _TO_MOTOR[kind](gears[n], a) for n, a in zip(names, angles, strict=True)}
    scale = min(abs(g.gear) for g in gears.values())
    if mode is not PositionMode.T:  # rates at the joints: no joint turns faster than asked
        speed, param = speed * scale, param * (scale if mode is PositionMode.Q else 1.0)
    with _open(args) as robot:
        try:
            with rates_at_joint(scale if mode is not PositionMode.T else 1.0, _move_fields(mode)):
                move = robot.set_angles(motor, speed, param, mode, relative=args.relative)
            records: list[dict[str, Any]] = [
                {"joint": n, "angle": a, "move_time_s": move.move_time, "start_skew_us": round(move.skew * 1e6, 1)}
                for n, a in zip(names, angles, strict=True)
            ]
            if args.wait:
                longest = DEFAULT_MOVE_TIMEOUT if move.move_time is None else 2 * move.move_time + 5
                final = robot.positions_done(names, args.wait_timeout or longest)
                for r in records:
                    at = gears[r["joint"]].joint_state_angle(final[r["joint"]].angle)
                    r["position_deg"] = round(math.degrees(at), 4)
        except KeyboardInterrupt:  # as a move on one bus: the motors it commanded go idle
            if args.stop_on_exit:
                for bus in robot.buses.values():
                    stop_commanded(bus, "interrupted")
            raise
    if args.json or args.wait:
        emit(args, tuple(records[0]), records)
    else:
        took = "" if move.move_time is None else f", about {move.move_time:g} s"
        print(
            f"joints {', '.join(names)}: moving on buses {', '.join(groups)} (mode {args.mode}{took}; "
            f"start frames {move.skew * 1e6:.0f} us apart)"
        )
    return 0
