"""``drempower twin fit|check``: fit the twin's joints to recordings of the robot, and score a twin against one."""

from __future__ import annotations

import argparse
import math
import sys
import time
from typing import Any

from ..sim.twin_fit import MAX_REL_ERROR
from ._output import add_json_arg, clean, json_line, render_table
from ._usage import UsageError

GROUP = "simulator"
"""Where ``drempower --help`` lists this module's subcommands."""


def _names(text: str) -> list[str]:
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise argparse.ArgumentTypeError(f"{text!r}: expected joint names separated by commas")
    return names


def register(sub: Any) -> None:
    p = sub.add_parser(
        "twin",
        help="fit the twin to recordings of the robot (twin fit), score a twin against one (twin check)",
        description=(
            "Work with the robot's physics twin and recordings made by drempower record --robot FILE "
            "(the commands sent and the states received). See docs/twin.md."
        ),
    )
    p.add_argument(
        "--json", dest="twin_json", action="store_true", help="one JSON object of the result (as VERB's --json)"
    )
    verbs = p.add_subparsers(dest="verb", metavar="VERB", required=True)
    f = verbs.add_parser(
        "fit",
        help="fit every joint's armature, damping and frictionloss to recordings; write the fitted robot file",
        description=(
            "Replay the recorded commands on the twin (the whole MuJoCo model: gravity, coupling) and fit each "
            "joint's armature, damping and frictionloss (totals at the joint, the motor's share included) and the "
            "recording's transport delay by least squares (scipy, the fit extra) on the differences of position, "
            "speed and torque. --write OUT.toml writes a robot file whose twin uses them and the model copy "
            "OUT.xml beside it. A recording that does not excite a parameter is refused, before the fit (a joint that "
            "barely moves) or after it (a parameter whose uncertainty, its standard error and how far a 1 ms error of "
            "the recording's timing moves it, from the final Jacobian, exceeds --max-error): --fixed keeps such a "
            "parameter at the robot file's value. Example: drempower twin "
            "fit run.mcap --robot arm6.toml --write arm6.fitted.toml"
        ),
    )
    f.add_argument("recordings", nargs="+", metavar="RECORDING", help="MCAP files of drempower record --robot")
    f.add_argument("--robot", required=True, metavar="FILE", help="the robot file (with a [model])")
    f.add_argument(
        "--joints", type=_names, metavar="NAMES", help="the joints to fit, e.g. shoulder,elbow (default all)"
    )
    f.add_argument("--write", metavar="OUT.toml", help="write the fitted robot file there (and the model OUT.xml)")
    f.add_argument("--delay", type=float, metavar="S", help="the transport delay if known (s; default: fitted)")
    f.add_argument(
        "--fixed",
        type=_names,
        default=[],
        metavar="JOINT.PARAM,...",
        help="keep these at the robot file's values, e.g. flange_roll.damping",
    )
    f.add_argument(
        "--max-error",
        type=float,
        default=MAX_REL_ERROR,
        metavar="E",
        help=f"the largest relative uncertainty of a fitted parameter (default {MAX_REL_ERROR:g}: "
        f"{100 * MAX_REL_ERROR:g} %%)",
    )
    f.add_argument("--max-evaluations", type=int, default=40, metavar="N", help="least-squares steps (default 40)")
    add_json_arg(f)
    f.set_defaults(func=run_fit)
    c = verbs.add_parser(
        "check",
        help="replay a recording on the twin; RMS and largest error of position, speed and torque per joint",
        description=(
            "Replay the recorded commands on the robot file's twin from the recorded start state and compare it "
            "with the recorded states, per joint: RMS and largest error of position (deg), speed (deg/s) and "
            "torque (Nm). --plot OUT.html draws robot and twin (a self-contained page)."
        ),
    )
    c.add_argument("recording", metavar="RECORDING", help="an MCAP file of drempower record --robot")
    c.add_argument("--robot", required=True, metavar="FILE", help="the robot file (with a [model])")
    c.add_argument("--delay", type=float, metavar="S", help="the transport delay (s; default: the best of 0..30 ms)")
    c.add_argument("--plot", metavar="OUT.html", help="write a plot of robot against twin")
    add_json_arg(c)
    c.set_defaults(func=run_check)
    p.set_defaults(robot_whole=True)


def _load(args: argparse.Namespace, paths: list[str]) -> tuple[Any, list[Any]]:
    from ..sim.twin_replay import load_recording

    spec = args.robot_spec
    return spec, [load_recording(path, spec) for path in paths]


def run_fit(args: argparse.Namespace) -> int:
    args.json = args.json or args.twin_json
    from ..sim.twin_fit import fit_twin, write_fitted

    if args.write is not None and not args.write.endswith(".toml"):
        raise UsageError(f"--write {args.write}: expected a robot file name ending in .toml")
    if args.delay is not None and not 0 <= args.delay <= 0.1:
        raise UsageError(f"--delay {args.delay}: out of range: allowed 0..0.1 s")
    if not 0.001 <= args.max_error <= 1.0:
        raise UsageError(f"--max-error {args.max_error}: out of range: allowed 0.001..1 (a relative error)")
    if not 1 <= args.max_evaluations <= 1000:
        raise UsageError(f"--max-evaluations {args.max_evaluations}: out of range: allowed 1..1000")
    spec, recs = _load(args, args.recordings)
    if args.joints:
        unknown = [j for j in args.joints if j not in spec.joints]
        if unknown:
            raise UsageError(f"--joints: {unknown[0]!r} is not a joint of {spec.source} ({', '.join(spec.joints)})")
    started = time.monotonic()

    def progress(n: int, cost: float) -> None:
        if not args.json and sys.stderr.isatty():
            print(f"\rreplay {n}: cost {cost:.4g} ({time.monotonic() - started:.0f} s)", end="", file=sys.stderr)

    result = fit_twin(
        spec,
        recs,
        args.joints,
        delay=args.delay,
        fixed=args.fixed,
        max_evaluations=args.max_evaluations,
        max_rel_error=args.max_error,
        progress=progress,
    )
    if not args.json and sys.stderr.isatty():
        print(file=sys.stderr)
    out: dict[str, Any] = result.as_dict()
    if args.write is not None:
        robot, model = write_fitted(spec, result.joints, args.write)
        out["written"] = {"robot": str(robot), "model": str(model)}
    if args.json:
        sys.stdout.write(json_line(out) + "\n")
        return 0
    rows = [
        [
            j,
            v["armature"],
            result.nominal[j]["armature"],
            v["damping"],
            result.nominal[j]["damping"],
            v["frictionloss"],
            result.nominal[j]["frictionloss"],
            result.rms_deg[j],
            result.rms_deg_nominal[j],
        ]
        for j, v in result.joints.items()
    ]
    titles = (
        "joint",
        "armature",
        "(nominal)",
        "damping",
        "(nominal)",
        "frictionloss",
        "(nominal)",
        "rms/deg",
        "(nominal)",
    )
    for line in render_table(titles, rows, digits=4):
        print(clean(line))
    worst = max(((e, j, p) for j, row in result.uncertainty.items() for p, e in row.items()), default=None)
    if worst is not None:
        print(f"largest uncertainty {100 * worst[0]:.1f} % ({worst[1]}'s {worst[2]})")
    print(
        f"transport delay {1000 * result.delay:.1f} ms; {result.evaluations} replays in {result.seconds:.1f} s "
        f"({result.cpu_seconds:.1f} s of CPU)"
    )
    if args.write is not None:
        print(clean(f"wrote {out['written']['robot']} and {out['written']['model']}"))
    return 0


def run_check(args: argparse.Namespace) -> int:
    args.json = args.json or args.twin_json
    from ..sim.twin_fit import best_delay
    from ..sim.twin_replay import Replay, compare

    if args.delay is not None and not 0 <= args.delay <= 0.1:
        raise UsageError(f"--delay {args.delay}: out of range: allowed 0..0.1 s")
    if args.plot is not None and not args.plot.endswith(".html"):
        raise UsageError(f"--plot {args.plot}: expected a file name ending in .html")
    spec, (rec,) = _load(args, [args.recording])
    replay = Replay(spec, rec)
    trace = replay.run()
    delay = args.delay if args.delay is not None else best_delay([rec], [trace], replay.joints)
    joints = compare(rec, trace, replay.joints, delay)
    if args.plot is not None:
        from ..sim.twin_plot import write_plot

        write_plot(args.plot, rec, trace, replay.joints, delay, title=f"{args.recording} on {spec.source}")
    if args.json:
        sys.stdout.write(json_line({"joints": joints, "delay_s": delay, "recording": args.recording}) + "\n")
        return 0
    titles = ("joint", "rms/deg", "max/deg", "rms/deg/s", "max/deg/s", "rms/Nm", "max/Nm")
    keys = ("rms_deg", "max_deg", "rms_deg_s", "max_deg_s", "rms_nm", "max_nm")
    rows = [[j, *(r[k] for k in keys)] for j, r in joints.items()]
    for line in render_table(titles, rows, digits=4):
        print(clean(line))
    worst = max((r["rms_deg"] for r in joints.values() if not math.isnan(r["rms_deg"])), default=math.nan)
    print(f"largest RMS position error {worst:.4g} deg (transport delay {1000 * delay:.0f} ms)")
    if args.plot is not None:
        print(clean(f"wrote {args.plot}"))
    return 0
