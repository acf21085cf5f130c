"""``drempower ros2``: ROS 2 files of a robot file: its URDF (``urdf``), a colcon bringup package (``package``)."""

from __future__ import annotations

import argparse
import os
import sys
from typing import Any

from ..errors import DrEmpowerError
from ._output import add_json_arg, json_line
from ._usage import UsageError

GROUP = "logs and tools"


def register(sub: Any) -> None:
    p = sub.add_parser(
        "ros2",
        help="write a URDF of a robot file, or a ROS 2 package bringing it up with ros2_control and MoveIt",
        description=(
            "Write ROS 2 files from a robot file and its model (MJCF or URDF, read by MuJoCo): the URDF with "
            "the joints' limits and a <ros2_control> block for topic_based_ros2_control on the bridge's topics, "
            "or a colcon package with that URDF, the controllers, a bringup launch file and a MoveIt "
            "configuration (docs/ros2_control.md)."
        ),
    )
    p.add_argument(
        "--json", dest="ros2_json", action="store_true", help="one JSON object of what was written (as WHAT's --json)"
    )
    what = p.add_subparsers(dest="ros2_command", metavar="WHAT")
    what.required = True
    u = what.add_parser("urdf", help="write the URDF of the robot file's model")
    u.add_argument("--robot", required=True, metavar="FILE", help="the robot file (its [model] names the model)")
    u.add_argument("-o", "--output", metavar="FILE.urdf", help="write to FILE (default: standard output)")
    u.add_argument("--name", help="the URDF's robot name (default: the model's)")
    u.add_argument(
        "--mesh-uri",
        metavar="PREFIX",
        help="prefix of the mesh files' names in the URDF (default: the folder of --output's meshes/ as file://); "
        "the meshes are written to meshes/ beside --output",
    )
    _plugin_arg(u)
    add_json_arg(u)
    u.set_defaults(func=run_urdf, robot_whole=True)  # the robot file is read whole, once: no bus is opened
    k = what.add_parser("package", help="write a colcon package: URDF, controllers, bringup launch, MoveIt")
    k.add_argument("name", metavar="NAME", help="the package's name, e.g. arm6_bringup")
    k.add_argument("--robot", required=True, metavar="FILE", help="the robot file (its [model] names the model)")
    k.add_argument("-o", "--output", required=True, metavar="DIR", help="the package's folder (created)")
    _plugin_arg(k)
    add_json_arg(k)
    k.set_defaults(func=run_package, robot_whole=True)


def _plugin_arg(p: argparse.ArgumentParser) -> None:
    from ..ros2 import DEFAULT_PLUGIN, PLUGINS

    p.add_argument(
        "--plugin",
        choices=list(PLUGINS),
        default=DEFAULT_PLUGIN,
        help="the ros2_control hardware plugin on the bridge's joint topics (default: %(default)s, released for "
        "Jazzy; topic_based_ros2_control/TopicBasedSystem is the same interface by its first name, built from "
        "source on Jazzy)",
    )


def _write(path: str, data: bytes) -> None:
    try:
        os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
        with open(path, "wb") as fh:
            fh.write(data)
    except OSError as exc:
        raise DrEmpowerError(f"cannot write {path}: {exc.strerror or exc}") from None


def _physics() -> None:
    """MuJoCo reads the model: without the physics extra, say so in one line before anything is read."""
    from ..sim.twin import require_mujoco

    require_mujoco()


def run_urdf(args: argparse.Namespace) -> int:
    args.json = args.json or args.ros2_json
    _physics()
    from ..robotfile import load_robot
    from ..ros2.urdf import robot_urdf

    if args.json and args.output is None:
        raise UsageError("--json needs -o FILE (without it the URDF itself goes to standard output)")
    spec = load_robot(args.robot)
    where = os.path.dirname(os.path.abspath(args.output)) if args.output else os.getcwd()
    prefix = args.mesh_uri if args.mesh_uri is not None else "file://" + os.path.join(where, "meshes") + "/"
    urdf = robot_urdf(spec, name=args.name, mesh_uri=lambda f: prefix + f, plugin=args.plugin)
    for warning in urdf.warnings:
        print(f"drempower ros2 urdf: {warning}", file=sys.stderr)
    written = []
    for fname, data in urdf.meshes.items():
        written.append(os.path.join(where, "meshes", fname))
        _write(written[-1], data)
    if args.output is None:
        sys.stdout.write(urdf.text)
        return 0
    _write(args.output, urdf.text.encode())
    if args.json:
        print(json_line({"output": args.output, "meshes": written, "joints": [j.name for j in urdf.joints]}))
    else:
        print(f"wrote {args.output}: {len(urdf.links)} links, joints {', '.join(j.name for j in urdf.joints)}")
    return 0


def run_package(args: argparse.Namespace) -> int:
    args.json = args.json or args.ros2_json
    _physics()
    from ..robotfile import load_robot
    from ..ros2.package import check_package_name, package_files, remove_stale

    check_package_name(args.name)
    spec = load_robot(args.robot)
    files = package_files(args.name, spec, plugin=args.plugin)
    remove_stale(args.output, files)
    for path, data in sorted(files.items()):
        _write(os.path.join(args.output, path), data)
    if args.json:
        print(json_line({"output": args.output, "files": sorted(files)}))
    else:
        print(f"wrote {args.output}: {', '.join(sorted(files))}")
    return 0
