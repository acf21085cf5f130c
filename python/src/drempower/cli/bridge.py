"""``drempower bridge``: serve a bus on Zenoh, to remote drempower clients and to ROS 2 (rmw_zenoh)."""

from __future__ import annotations

import argparse
import logging
import os
import sys
from contextlib import ExitStack
from typing import Any

from ..client.driver.signals import SignalLatch
from ..transports.zenoh_config import check_endpoint
from ._connect import add_connection_args, connection_kwargs, parse_ids, positive, sim_time_scale
from ._motion import add_watchdog_arg, arm_watchdog, restore_watchdog
from ._output import add_json_arg, json_line
from ._ros2_control import add_ros2_control_args, start_ros2_control
from ._usage import UsageError


def _endpoint(text: str) -> str:
    try:
        return check_endpoint(text, "endpoint")
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("endpoint ")) from exc


def register(sub: Any) -> None:
    p = sub.add_parser(
        "bridge",
        help="serve a bus on Zenoh: joint_states and commands for ROS 2 (rmw_zenoh), remote buses for drempower",
        description=(
            "Serve one bus on Zenoh until Ctrl-C, SIGTERM or SIGHUP, then idle every motor it or its clients "
            "set moving. ROS 2 nodes using rmw_zenoh_cpp see /joint_states (sensor_msgs/JointState), "
            "/position_commands, /velocity_commands, /effort_commands (std_msgs/Float64MultiArray) and the "
            "std_srvs/Trigger services /estop, /clear_errors and /enable; drempower clients open it with "
            "open_bus('zenoh', PREFIX, connect=ENDPOINT) or `-i zenoh -c PREFIX -o connect=ENDPOINT`. "
            "With --robot FILE it serves every bus of the robot: the joint names, gears and offsets come from the "
            "file (joint_states at the joint), and each bus is a remote bus under PREFIX/BUS."
        ),
    )
    p.add_argument(
        "--ids",
        type=parse_ids,
        metavar="IDS",
        help="motors served, e.g. 1,2,3 (default: --sim's ids; not with --robot)",
    )
    p.add_argument(
        "--connect",
        action="append",
        type=_endpoint,
        metavar="ENDPOINT",
        help="Zenoh endpoint to connect to, repeatable (default tcp/localhost:7447, rmw_zenoh's router)",
    )
    p.add_argument(
        "--listen",
        action="append",
        type=_endpoint,
        default=[],
        metavar="ENDPOINT",
        help="Zenoh endpoint to listen on, repeatable",
    )
    p.add_argument(
        "--scout", action="store_const", const=True, help="turn on Zenoh multicast scouting (off by default)"
    )
    p.add_argument(
        "--no-gossip",
        dest="gossip",
        action="store_const",
        const=False,
        help="turn off Zenoh gossip scouting (peers learnt through the router; on by default, as in rmw_zenoh)",
    )
    p.add_argument(
        "--zenoh-config",
        metavar="FILE",
        help="Zenoh session configuration (JSON5, as rmw_zenoh's ZENOH_SESSION_CONFIG_URI); "
        "--connect, --listen, --scout and --no-gossip override it",
    )
    p.add_argument("--namespace", default="", help="ROS 2 namespace of the topics and services (default none)")
    p.add_argument("--domain-id", type=int, help="ROS 2 domain id (default $ROS_DOMAIN_ID or 0)")
    p.add_argument("--prefix", default="drempower", help="Zenoh key prefix of the drempower face (default drempower)")
    p.add_argument("--rate", type=positive, default=100.0, help="joint_states messages per second (default 100)")
    p.add_argument(
        "--command-timeout",
        type=positive,
        default=0.2,
        metavar="S",
        help="idle the motors when streamed commands stop for S seconds (default 0.2)",
    )
    p.add_argument(
        "--bandwidth",
        type=positive,
        default=20.0,
        help="T-mode filter bandwidth of position commands, 1/s (default 20)",
    )
    add_watchdog_arg(p)
    add_ros2_control_args(p)
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run, robot_whole=True)


def _domain_id(args: argparse.Namespace) -> int:
    if args.domain_id is not None:
        return int(args.domain_id)
    env = os.environ.get("ROS_DOMAIN_ID", "").strip()
    if not env:
        return 0
    if not env.isdigit():
        raise UsageError(f"ROS_DOMAIN_ID={env!r}: an integer 0..232")
    return int(env)


_BUS_ONLY = ("timeout", "retries", "stop_on_close", "start")
"""Robot-file bus options of the client Bus, not of the transport the bridge opens."""


def _bus_kwargs(args: argparse.Namespace) -> dict[str, tuple[dict[str, Any], str]]:
    """The ``open_transport`` arguments of each bus served and what it is (``""``: the one bus of the options)."""
    spec = getattr(args, "robot_spec", None)
    if spec is None:
        return {"": connection_kwargs(args)}
    out: dict[str, tuple[dict[str, Any], str]] = {}
    for name in spec.buses:
        kw = {k: v for k, v in spec.open_options(name).items() if k not in _BUS_ONLY}
        scale = sim_time_scale(args)
        if kw["interface"] == "sim" and scale is not None:
            kw["time_scale"] = scale
        out[name] = (kw, f"bus {name} ({kw['interface']})")
    return out


def _prefixes(bridge: Any) -> str:
    faces = list(bridge.faces.values())
    if len(faces) == 1 and not faces[0].name:
        return f"prefix {faces[0].prefix}"
    return "prefixes " + ", ".join(f"{f.prefix} (bus {f.name})" for f in faces)


def _watchdog_fits(args: argparse.Namespace) -> None:
    """A --watchdog the state stream keeps fed: at least three of its periods (it reads every motor each)."""
    if args.watchdog and args.watchdog < 3000.0 / args.rate:
        raise UsageError(
            f"--watchdog {args.watchdog}: the state stream (--rate {args.rate:g}) talks to each motor every "
            f"{1000.0 / args.rate:g} ms; the watchdog needs at least 3 of those ({3000.0 / args.rate:g} ms): "
            "raise --rate or the watchdog"
        )


def run(args: argparse.Namespace) -> int:
    try:
        import rosbags  # noqa: F401
        import zenoh  # noqa: F401

        from ..bridge.server import Bridge, BridgeOptions, motor_joints
    except ImportError as exc:
        print(f"drempower bridge: needs the bridge extra: pip install 'drempower[bridge]' ({exc})", file=sys.stderr)
        return 2
    from ..logline import StderrLines
    from ..transports import open_transport
    from ..transports.zenoh_config import open_config, session_config, settings

    _watchdog_fits(args)
    try:
        conf = session_config(
            args.connect, args.listen, scout=args.scout, gossip=args.gossip, config_file=args.zenoh_config
        )
    except ValueError as exc:
        raise UsageError(f"--zenoh-config: {exc}") from None

    spec = getattr(args, "robot_spec", None)
    joints: dict[str, Any]
    if spec is not None:
        if args.ids:
            raise UsageError("--ids: not with --robot (the bridge serves every joint of the robot file)")
        joints = dict(spec.joints)
    else:
        ids = args.ids or args.sim
        if not ids:
            raise UsageError("--ids: which motors to serve, e.g. --ids 1,2,3")
        if args.sim and args.ids and not set(args.ids) <= set(args.sim):
            missing = ",".join(str(i) for i in args.ids if i not in args.sim)
            raise UsageError(f"--ids: motors {missing} are not simulated (--sim {','.join(map(str, args.sim))})")
        joints = motor_joints(ids)
    try:
        options = BridgeOptions(
            joints,
            prefix=args.prefix,
            namespace=args.namespace,
            domain_id=_domain_id(args),
            rate=args.rate,
            command_timeout=args.command_timeout,
            bandwidth=args.bandwidth,
            timeout=args.timeout,
            robot=spec,
        )
    except ValueError as exc:
        raise UsageError(str(exc)) from exc
    buses = _bus_kwargs(args)
    status = 0
    latch = SignalLatch()
    # Lines go to stderr from a thread of their own: a stderr nobody reads never holds up a Zenoh callback,
    # a service (estop included) or the way out.
    err = StderrLines().start()
    log = logging.getLogger("drempower")
    log.addHandler(err)
    propagate, log.propagate = log.propagate, False
    try:
        with ExitStack() as stack:
            transports: dict[str, Any] = {}
            for name, (kw, _) in buses.items():
                transports[name] = open_transport(**kw)
                stack.callback(transports[name].close)
            session = open_config(conf)
            stack.callback(session.close)
            how = "; ".join(h for _, h in buses.values())
            bridge = Bridge(transports if spec is not None else transports[""], session, options)
            armed: list[tuple[Any, dict[int, int]]] = []
            ros2: Any = None
            try:
                ros2 = start_ros2_control(bridge, args, spec)
                # After the bridge's bus (whose SIGTERM handler would close it at once): the way out below idles
                # the motors, then puts their CAN timeout back on the still open bus.
                latch.install()
                for face in bridge.faces.values():
                    armed.append((face.bus, arm_watchdog(face.bus, face.ids, args.watchdog) if args.watchdog else {}))
                if args.json:
                    record = {
                        "bus": how,
                        "joints": {
                            n: j
                            if isinstance(j, int)
                            else {"bus": j.bus, "id": j.id, "gear": j.gear, "offset": j.offset}
                            for n, j in options.joints.items()
                        },
                        "prefix": options.prefix,
                        **({"buses": {f.name: f.prefix for f in bridge.faces.values()}} if spec else {}),
                        "node": f"{bridge.namespace.rstrip('/')}/{options.node_name}",
                        "joint_states": bridge.joint_states_key,
                        **bridge.command_keys,
                        **bridge.service_keys,
                        **ros2.keys(),
                        "zenoh": settings(conf),
                        **({"watchdog_ms": args.watchdog} if args.watchdog else {}),
                    }
                    print(json_line(record), flush=True)
                err.line(
                    f"drempower bridge: {how}; joints {', '.join(options.joints)}; "
                    f"joint_states on {bridge.joint_states_key}; drempower {_prefixes(bridge)}"
                )
                while not latch.wait(0.2):
                    if bridge.failure is not None:
                        err.line(f"drempower bridge: the bus stopped: {bridge.failure}")
                        status = 1
                        break
            finally:
                if ros2 is not None:
                    ros2.close()  # a running goal is cancelled: the joints hold
                bridge.stop()  # the motors it or its clients drove go idle; then their CAN timeout is put back
                for bus, before in armed:
                    restore_watchdog(bus, before)
                bridge.close()
        held = sorted(j.name for j in (spec.joints.values() if spec is not None else ()) if j.on_timeout == "hold")
        err.line(
            "drempower bridge: stopped; motors it drove are idle"
            + (f" (joints {', '.join(held)} hold: their on_timeout)" if held else "")
        )
    finally:
        latch.close()
        log.removeHandler(err)
        log.propagate = propagate
        err.flush_for(1.0)
    return 128 + latch.signum if latch.signum is not None else status
