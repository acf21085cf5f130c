"""``drempower play FILE``: follow a trajectory file (CSV, JSON, MCAP) with a robot's joints or a bus's motors."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from ..errors import DrEmpowerError, ValidationError
from ..motion.plan import MODES, FollowError, Lane, Units, make_plan, model_ranges, robot_lanes, robot_limits
from ..motion.trajectory import Trajectory
from ._connect import add_connection_args, parse_ids, positive
from ._output import add_json_arg, clean, json_line, render_table
from ._usage import UsageError

GROUP = "motion"
"""Where ``drempower --help`` lists this module's subcommands."""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "play",
        help="follow a trajectory file (CSV, JSON, MCAP) through the control cycle",
        description=(
            "Follow a trajectory: a CSV file (a 't' column in s and one column per joint), JSON, or the "
            "JointState topic of an MCAP recording. With --robot the columns are joints (rad); otherwise "
            "they are motor ids (deg), or --ids gives the motors column by column. Every point is checked "
            "against the joints' limits before anything moves. Ctrl-C or SIGTERM holds the joints where "
            "they are. Example: drempower play path.csv --robot arm.toml --dry-run"
        ),
    )
    p.add_argument("file", metavar="FILE", nargs="?", help="the trajectory: .csv, .json or .mcap (or --excite)")
    p.add_argument(
        "--excite",
        type=positive,
        metavar="S",
        help="with --robot, instead of FILE: a safe excitation of S s for a recording to fit the twin to "
        "(a multi-sine per joint around where it is, within its limits; see docs/twin.md)",
    )
    p.add_argument(
        "--amplitude",
        type=positive,
        default=0.3,
        metavar="RAD",
        help="--excite: each joint's largest excursion from where it starts (rad, default 0.3)",
    )
    p.add_argument("--ids", type=parse_ids, help="without --robot: the motors of the file's columns, in order")
    p.add_argument("--rate", type=positive, default=200.0, metavar="HZ", help="control cycles per s (default 200)")
    p.add_argument("--speed", type=positive, default=1.0, metavar="X", help="time scale: 2 = twice as fast")
    p.add_argument(
        "--mode", type=str.lower, choices=MODES, default="position", help="position (T, default), impedance or p"
    )
    p.add_argument(
        "--max-error", type=positive, metavar="E", help="stop when a tracking error exceeds E (rad; deg for motors)"
    )
    p.add_argument("--kp", type=float, default=20.0, help="impedance: the motors' stiffness, Nm/rad (default 20)")
    p.add_argument("--kd", type=float, default=1.0, help="impedance: the motors' damping, Nm s/rad (default 1)")
    p.add_argument(
        "--feedforward",
        choices=("gravity", "inverse"),
        help="with --robot and a model, impedance or p mode: torques from the model (gravity, or inverse dynamics)",
    )
    p.add_argument("--topic", default="/joint_states", help="MCAP: the JointState topic (default /joint_states)")
    p.add_argument(
        "--dry-run", action="store_true", help="check and print the duration and the limits met; send nothing"
    )
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run, robot_whole=True)


def _load(args: argparse.Namespace) -> Trajectory:
    """The file's trajectory, or the excitation asked (a file that cannot be used raises ValidationError: one line,
    exit 2)."""
    if args.excite is not None:
        return _excitation(args, None)
    tr = Trajectory.load(args.file, topic=args.topic)
    return tr.scaled(args.speed) if args.speed != 1.0 else tr


def _bus_columns(args: argparse.Namespace, tr: Trajectory) -> list[int]:
    if args.ids is not None:
        if len(args.ids) != len(tr.joints):
            raise UsageError(f"--ids: {len(args.ids)} motors for the file's {len(tr.joints)} columns")
        return list(args.ids)
    try:
        return [int(c) for c in tr.joints]
    except ValueError:
        raise UsageError(
            f"the file's columns ({', '.join(tr.joints)}) are joint names: give --robot FILE, or --ids"
        ) from None


def _summary(args: argparse.Namespace, tr: Trajectory, limits: dict[str, dict[str, Any]], unit: str) -> None:
    peaks = tr.peaks(min(0.001, 1.0 / args.rate))
    rows = []
    for j, name in enumerate(tr.joints):
        lim = limits.get(name, {})
        met = ", ".join(
            f"{k} {v[0]:g}..{v[1]:g}" if k == "position" else f"{k} {v:g}" for k, v in lim.items() if k != "source"
        )
        rows.append(
            {
                "joint": name,
                "low": peaks.low[j],
                "high": peaks.high[j],
                "peak_speed": peaks.speed[j],
                "peak_accel": peaks.accel[j],
                "limits": met or "-",
                "source": lim.get("source", "-"),
            }
        )
    what = args.file or f"excitation of {args.excite:g} s"
    head = {"file": what, "duration_s": tr.duration, "rate_hz": args.rate, "mode": args.mode, "unit": unit}
    if args.json:
        sys.stdout.write(json_line({**head, "joints": rows}) + "\n")
        return
    print(clean(f"{what}: {len(tr.joints)} joints, {tr.duration:.3f} s at {args.rate:g} Hz, mode {args.mode}"))
    titles = ("joint", f"low/{unit}", f"high/{unit}", f"speed/{unit}/s", f"accel/{unit}/s^2", "limits", "from")
    for line in render_table(titles, [list(r.values()) for r in rows], digits=3):
        print(clean(line))


def _report(args: argparse.Namespace, report: Any, unit: str) -> None:
    if args.json:
        sys.stdout.write(json_line(report.as_dict()) + "\n")
        return
    worst = max(report.max_error.values())
    print(
        f"followed in {report.duration:.3f} s: {report.cycles} cycles at {report.rate:.1f} Hz, {report.late} late; "
        f"largest tracking error {worst:.4g} {unit}"
    )
    rows = [[n, e] for n, e in report.max_error.items()]
    for line in render_table(("joint", f"max_error/{unit}"), rows, digits=4):
        print(clean(line))


def _excitation(args: argparse.Namespace, centre: dict[str, float] | None) -> Trajectory:
    """The excitation of every joint of the robot around ``centre`` (rad; None: 0), within its limits."""
    spec = args.robot_spec
    ranges = _model_ranges(spec)
    limits = robot_limits(spec, list(spec.joints), ranges)
    try:
        tr = Trajectory.excitation(
            list(spec.joints), args.excite, centre=centre or 0.0, amplitude=args.amplitude, limits=limits
        )
        return tr.scaled(args.speed) if args.speed != 1.0 else tr
    except ValidationError as exc:
        raise UsageError(f"--excite: {exc}") from None


def _model_ranges(spec: Any) -> Any:
    if spec.model is None:
        return None
    try:
        import mujoco

        return model_ranges(mujoco.MjModel.from_xml_path(spec.model.file))
    except ImportError:
        return None  # no physics extra: the file's limits only
    except Exception as exc:  # MuJoCo's parser errors have no common type
        raise DrEmpowerError(f"model {spec.model.file}: {exc}") from None


def run(args: argparse.Namespace) -> int:
    spec = getattr(args, "robot_spec", None)
    if (args.file is None) == (args.excite is None):
        raise UsageError("give a trajectory FILE or --excite S (not both)")
    if args.excite is not None and spec is None:
        raise UsageError("--excite needs --robot FILE (the joints and their limits)")
    tr = _load(args)
    options = {"rate": args.rate, "mode": args.mode, "max_error": args.max_error, "kp": args.kp, "kd": args.kd}
    try:
        if spec is not None:
            return _run_robot(args, spec, tr, options)
        return _run_bus(args, tr, options)
    except FollowError as exc:
        _report(args, exc.report, "rad" if spec is not None else "deg")
        raise


def _dry_plan(tr: Trajectory, lanes: list[Lane], limits: dict[str, dict[str, Any]], options: dict[str, Any]) -> None:
    plan = make_plan(tr, lanes, limits=limits, bandwidth=None, torques=None, timeout=None, **options)
    for _ in plan.commands:  # every cycle's commands made and checked as following would (none kept)
        pass


def _run_robot(args: argparse.Namespace, spec: Any, tr: Trajectory, options: dict[str, Any]) -> int:
    if args.ids is not None:
        raise UsageError("--ids: not with --robot (the file's columns are joints)")
    unknown = [c for c in tr.joints if c not in spec.joints]
    if unknown:  # the same words with and without --dry-run, before anything is opened
        raise ValidationError(
            f"{args.file}: column {unknown[0]!r} is no joint of {spec.source} (joints: {', '.join(spec.joints)})"
        )
    if args.dry_run:
        ranges = _model_ranges(spec)
        limits = robot_limits(spec, tr.joints, ranges)
        lanes = robot_lanes(spec, tr.joints, lambda b: spec.buses[b].options.get("bitrate"), lambda b: {})
        _dry_plan(tr, lanes, limits, options)
        _summary(args, tr, limits, "rad")
        return 0
    from ..robot import open_robot

    with open_robot(spec, timeout=args.timeout, stop_on_close=False) as robot:
        if args.excite is not None:  # around where the joints are: nothing moved yet
            at = {n: s.position for n, s in robot.joint_states().items()}
            tr = _excitation(args, at)
        report = robot.follow(tr, feedforward=args.feedforward, **options)
    _report(args, report, "rad")
    return 0


def _run_bus(args: argparse.Namespace, tr: Trajectory, options: dict[str, Any]) -> int:
    if args.feedforward is not None:
        raise UsageError("--feedforward needs --robot FILE with a [model]")
    ids = _bus_columns(args, tr)
    if args.dry_run:
        lane = Lane(
            "bus", list(tr.joints), ids, [Units(deg=True)] * len(ids), list(range(len(ids))), ["hold"] * len(ids)
        )
        lane.bitrate = args.bitrate
        _dry_plan(tr, [lane], {}, options)
        _summary(args, tr, {}, "deg")
        return 0
    from ..motion.follow_sync import follow_bus
    from ._connect import open_from_args

    with open_from_args(args) as bus:
        report = follow_bus(bus, ids, tr, **options)
    _report(args, report, "deg")
    return 0
