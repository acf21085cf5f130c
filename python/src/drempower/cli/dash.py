"""``drempower dash``: serve the browser dashboard for the motors of one bus or of a robot's buses."""

from __future__ import annotations

import argparse
import ipaddress
import json
import signal
import webbrowser
from typing import Any

from ..errors import DrEmpowerError
from ._connect import add_connection_args, open_from_args, positive
from ._motion import add_watchdog_arg
from ._usage import UsageError

DEFAULT_HOST = "127.0.0.1"
DEFAULT_SIM = [1, 2, 3]


def register(sub: Any) -> None:
    p = sub.add_parser(
        "dash",
        help="browser dashboard: scan, plot, drive, configure, tune and stop motors (default: 3 simulated motors)",
        description=(
            "Serve a dashboard to a browser and print its URL on the first line. With no connection option "
            f"it serves simulated motors {','.join(map(str, DEFAULT_SIM))}. Binding beyond {DEFAULT_HOST} "
            "(--host) needs the token that the printed URL carries. When the last browser goes away (or its "
            "heartbeat stops for 0.5 s) the motors the dashboard moved are idled; Ctrl-C, SIGTERM and SIGHUP "
            "idle them, and the command then exits with 128 + the signal number. With --watchdog MS the motors "
            "also stop by themselves when the dashboard is killed. Control actions are logged on stderr. With "
            "--robot FILE it serves every bus of the robot: motor cards, plots and control by joint; ESTOP stops "
            "every bus."
        ),
    )
    p.add_argument(
        "--host", default=DEFAULT_HOST, help=f"address to bind (default {DEFAULT_HOST}; others need the token)"
    )
    p.add_argument("--port", type=int, default=8811, help="TCP port (default 8811; 0 picks a free one)")
    p.add_argument("--json", action="store_true", help='print {"url": ...} as the first line')
    p.add_argument("--open", action="store_true", help="also open the URL in a browser")
    p.add_argument("--read-only", action="store_true", help="serve watching only: no control, no parameter writes")
    p.add_argument(
        "--keep-running",
        action="store_true",
        help="leave the motors moving when the last browser goes away (signals still idle them)",
    )
    p.add_argument(
        "--poll-rate",
        type=positive,
        default=50.0,
        metavar="HZ",
        help="fast reads per second per motor (default 50), within a polling budget of 30 %% of the bus",
    )
    p.add_argument(
        "--shadow",
        action="store_true",
        help="with --robot FILE naming a [model]: run the robot's twin beside it (fed the same commands); the 3D "
        "view draws it as a second, translucent arm, and a divergence is shown on the page and logged, and acts "
        "as the file's on_divergence says (needs the physics extra)",
    )
    add_watchdog_arg(p)
    add_connection_args(p)
    for group in p._action_groups:  # the dashboard's own default connection, not python-can's
        if group.title and group.title.startswith("connection"):
            group.title = f"connection (one of; default: simulated motors {','.join(map(str, DEFAULT_SIM))})"
    p.set_defaults(func=run, robot_whole=True)  # --robot: one dashboard over every bus


def run(args: argparse.Namespace) -> int:
    try:
        from ..dash import logline
        from ..dash.hub import Hub
        from ..dash.server import Dashboard, new_token
    except ImportError as exc:  # pragma: no cover - depends on the installed extras
        raise DrEmpowerError(f"the dashboard needs the dash extra: pip install 'drempower[dash]' ({exc})") from None
    import asyncio

    logline.to_stderr()

    if not 0 <= args.port <= 65535:
        raise UsageError(f"--port {args.port}: expected 0..65535")
    try:
        ipaddress.ip_address(args.host)
    except ValueError:
        if args.host != "localhost":
            raise UsageError(f"--host {args.host!r}: expected an IP address such as 127.0.0.1 or ::1") from None
    spec = getattr(args, "robot_spec", None)
    if spec is None and not (args.sim or args.serial or args.uart or args.interface):
        args.sim = DEFAULT_SIM
    token = None if args.host == DEFAULT_HOST else new_token()
    if args.shadow and (spec is None or spec.model is None):
        where = "a robot file" if spec is None else f"{spec.source}: a [model]"
        raise UsageError(f"--shadow needs {where}: the shadow is the robot's twin (--robot FILE with [model])")
    bus: Any
    if spec is not None:
        from ..robot import open_robot

        bus = open_robot(spec, timeout=args.timeout, stop_on_close=False)
    else:
        bus = open_from_args(args, quiet=True)
    shadow = None
    try:
        if args.shadow:
            try:
                shadow = bus.shadow(on_event=None)
            except ImportError as exc:
                raise DrEmpowerError(
                    f"--shadow needs the physics extra: pip install 'drempower[physics]' ({exc})"
                ) from None
        hub = Hub(bus, read_only=args.read_only, poll_hz=args.poll_rate, watchdog_ms=args.watchdog)
        dash = Dashboard(hub, token=token, keep_running=args.keep_running, shadow=shadow)
        try:

            def ready(url: str) -> None:
                print(json.dumps({"url": url}) if args.json else url, flush=True)
                if args.open:
                    webbrowser.open(url)

            async def main() -> None:
                await dash.serve(args.host, args.port, ready)

            try:
                asyncio.run(main())
            except OSError as exc:
                raise DrEmpowerError(f"cannot serve on {args.host} port {args.port}: {exc.strerror or exc}") from None
        finally:
            hub.close()
    finally:
        if shadow is not None:
            shadow.close()
        bus.close()
    how = f" ({signal.Signals(dash.signal).name})" if dash.signal else ""
    logline.write(f"drempower dash: stopped{how}")
    logline.flush(0.5)  # a stderr nobody reads does not hold up the exit
    return 128 + dash.signal if dash.signal else 0
