"""``drempower sim``: run simulated motors that other programs connect to."""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
import threading
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any, TextIO

from ..client.driver.signals import exit_code
from ..errors import DrEmpowerError, SavedConfigError, ValidationError
from ..sim import (
    Faults,
    SimBus,
    SimRunner,
    attach_adapter_pty,
    attach_python_can,
    attach_socketcand,
    attach_uart_pty,
)
from ..sim.bus import DEFAULT_HOST_QUEUE, parse_host_queue
from ..sim.noise import SensorNoise, parse_noise
from ._connect import ascii_float, bitrate, can_option, parse_ids, positive
from ._output import clean, json_line
from ._sim_firmware import add_firmware_options, firmware_changes, firmware_of
from ._sim_robot import serve_robot
from ._usage import UsageError

GROUP = "simulator"
"""Where ``drempower --help`` lists this module's subcommands."""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "sim",
        help="run simulated motors behind a virtual USB-CAN adapter, a motor UART, socketcand or python-can",
        description=(
            "Simulated DrEmpower motors that behave like the firmware, reachable from other programs. "
            "With no attachment option: the USB-CAN adapter pty and a socketcand server on a free port. "
            "Prints where to connect, then runs until Ctrl-C (or --duration)."
        ),
    )
    p.add_argument("--ids", type=parse_ids, metavar="IDS", help="motor ids, e.g. 1,2,3 (default 1)")
    p.add_argument(
        "--robot", dest="robot_file", metavar="FILE", help="one simulated bus per bus of this robot file (TOML)"
    )
    p.add_argument("--adapter-pty", action="store_true", help="a pty that behaves like the USB-CAN adapter")
    p.add_argument("--uart-pty", type=int, metavar="ID", help="a pty that behaves like motor ID's UART")
    p.add_argument("--socketcand-port", type=int, metavar="PORT", help="serve socketcand on 127.0.0.1 (0: free port)")
    p.add_argument("--python-can", metavar="CHANNEL", help="attach to this python-can channel")
    p.add_argument(
        "--python-can-interface",
        default="virtual",
        metavar="NAME",
        help="python-can interface of --python-can (default virtual, in-process only; e.g. socketcan for vcan0)",
    )
    p.add_argument(
        "--python-can-option",
        metavar="KEY=VALUE",
        action="append",
        type=can_option,
        default=[],
        help="extra python-can bus option of --python-can, repeatable: --python-can-option host=127.0.0.1 "
        "--python-can-option port=29536 (socketcand)",
    )
    p.add_argument("--bitrate", type=bitrate, help="simulate bus timing at this bit rate, e.g. 1M (default instant)")
    p.add_argument(
        "--host-queue",
        type=_host_queue,
        default=DEFAULT_HOST_QUEUE,
        metavar="MODEL",
        help="transmit queue of each host with --bitrate: fifo, or priority:N mailboxes arbitrating by id "
        f"like bxCAN (default {DEFAULT_HOST_QUEUE})",
    )
    p.add_argument("--time-scale", type=positive, default=1.0, help="simulated seconds per second (default 1)")
    p.add_argument("--config-dir", metavar="DIR", help="keep each motor's saved configuration in DIR")
    p.add_argument("--duration", type=positive, metavar="S", help="stop after S seconds of wall time")
    add_firmware_options(p)
    f = p.add_argument_group("faults")
    f.add_argument("--drop-rate", type=_rate, default=0.0, metavar="P", help="probability that a frame is lost")
    f.add_argument("--corrupt-rate", type=_rate, default=0.0, metavar="P", help="probability of one flipped bit")
    f.add_argument("--reply-delay", type=float, default=0.0, metavar="S", help="seconds before every motor frame")
    f.add_argument(
        "--serial-garbage", type=_rate, default=0.0, metavar="P", help="probability of garbage before a pty frame"
    )
    f.add_argument(
        "--noise",
        type=_noise,
        metavar="KEY=SD,...",
        help="sensor noise on every state frame: standard deviations position=DEG (0..1), speed=RPM (0..10), "
        "torque=NM (0..1), e.g. position=0.01,speed=0.2 (seeded by --seed)",
    )
    f.add_argument("--seed", type=int, default=0, help="seed of the fault and noise generators (default 0)")
    p.add_argument(
        "--json",
        action="store_true",
        help="one JSON object per line: the motors, each attachment, running, and the summary when stopped",
    )
    p.set_defaults(func=run)


def _host_queue(text: str) -> str:
    try:
        parse_host_queue(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc).split(": ", 1)[1]) from None
    return text


def _noise(text: str) -> SensorNoise:
    try:
        return parse_noise(text)
    except ValidationError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _rate(text: str) -> float:
    try:
        value = ascii_float(text)
    except ValueError:
        value = -1.0
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"expected a probability 0..1, got {text!r}")
    return value


def _check_config_dir(folder: str) -> None:
    """Make ``folder`` and check that files can be written there, or say what to do instead."""
    try:
        Path(folder).mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise DrEmpowerError(
            f"sim --config-dir {folder}: cannot write there ({exc.strerror or exc}): give a directory you can "
            f"write, e.g. --config-dir {Path.home() / '.local/share/drempower-sim'}"
        ) from None


@contextmanager
def _explained(option: str, advice: str) -> Iterator[None]:
    """Turn the failure of an attachment into one line naming ``option`` and what to do (``advice``)."""
    import can

    try:
        yield
    except TypeError as exc:  # python-can's bus class refused its arguments: a missing or unknown option
        missing = re.search(r"missing \d+ required (?:positional |keyword-only )?arguments?: (.*)", str(exc))
        if missing:
            names = re.findall(r"'(\w+)'", missing[1])
            given = " ".join(f"--python-can-option {n}=..." for n in names)
            raise DrEmpowerError(f"sim {option}: the interface needs {' and '.join(names)}: give {given}") from None
        raise DrEmpowerError(f"sim {option}: {exc}: check the --python-can-option names") from None
    except (OSError, can.CanError, ImportError, ValueError) as exc:
        why = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise DrEmpowerError(f"sim {option}: {why}: {advice}") from None


def _python_can_advice(interface: str, channel: str) -> str:
    if interface == "socketcan":
        return (
            f"is there a CAN interface {channel}? A virtual one: sudo modprobe vcan && "
            f"sudo ip link add dev {channel} type vcan && sudo ip link set up {channel} (Linux only)"
        )
    return f"check that python-can's {interface} interface is installed and channel {channel} exists"


def run(args: argparse.Namespace, out: TextIO | None = None, stop: threading.Event | None = None) -> int:
    """Run the simulator; ``stop`` (set by the caller) ends it early, as Ctrl-C does."""
    ended = 0
    stream = out or sys.stdout

    def show(record: dict[str, Any], *lines: str) -> None:
        text = [json_line(record)] if getattr(args, "json", False) else lines
        for line in text:
            print(clean(line), file=stream, flush=True)

    if getattr(args, "robot_file", None):
        return serve_robot(args, show, stop)
    args.ids = args.ids or [1]
    if args.uart_pty is not None and args.uart_pty not in args.ids:
        raise UsageError(f"--uart-pty {args.uart_pty} is not one of --ids")
    options = dict(getattr(args, "python_can_option", None) or [])
    if options and not args.python_can:
        raise UsageError("--python-can-option needs --python-can CHANNEL")
    faults = Faults(
        drop_rate=args.drop_rate,
        corrupt_rate=args.corrupt_rate,
        reply_delay=args.reply_delay,
        serial_garbage=args.serial_garbage,
    )
    if args.config_dir is not None:
        _check_config_dir(args.config_dir)
    try:
        bus = SimBus(
            args.ids,
            bitrate=args.bitrate,
            host_queue=args.host_queue,
            faults=faults,
            seed=args.seed,
            config_dir=args.config_dir,
            firmware=firmware_of(args),
            noise=getattr(args, "noise", None),
        )
    except SavedConfigError as exc:  # a file in --config-dir that cannot be used: the user's to fix (exit 2)
        raise ValidationError(str(exc)) from None
    default = not (args.adapter_pty or args.uart_pty is not None or args.socketcand_port is not None or args.python_can)
    ids = ",".join(map(str, args.ids))
    timing = f"{args.bitrate} bit/s, host queue {args.host_queue}" if args.bitrate else "instant delivery"
    with ExitStack() as stack:
        stack.enter_context(SimRunner(bus, args.time_scale))
        show(
            {"motors": list(args.ids), "bitrate": args.bitrate, "time_scale": args.time_scale},
            f"drempower sim: motors {ids} ({timing}, time x{args.time_scale:g})",
        )
        changed = firmware_changes(bus.firmware)
        if changed:
            knobs = ", ".join(f"{k}={v}" for k, v in changed.items())
            show({"firmware": changed}, f"firmware profile: {knobs}")
        if args.adapter_pty or default:
            path = stack.enter_context(attach_adapter_pty(bus)).path
            show(
                {"attachment": "adapter", "path": path},
                f"USB-CAN adapter (0xAA frames and slcan): {path}",
                f"    drempower state {ids} --serial {path}",
                f"    can.Bus(interface='slcan', channel='{path}', sleep_after_open=0)",
            )
        if args.uart_pty is not None:
            path = stack.enter_context(attach_uart_pty(bus, args.uart_pty)).path
            show(
                {"attachment": "uart", "id": args.uart_pty, "path": path},
                f"UART of motor {args.uart_pty} (11-byte frames): {path}",
                f"    drempower state {args.uart_pty} --uart {path}",
            )
        if args.socketcand_port is not None or default:
            port = args.socketcand_port or 0
            busy = f"port {port} is taken: give another with --socketcand-port, or 0 for a free one"
            with _explained(f"--socketcand-port {port}", busy):
                server = stack.enter_context(attach_socketcand(bus, port))
            ids = ",".join(str(i) for i in bus.motors)
            show(
                {"attachment": "socketcand", "host": server.host, "port": server.port, "channel": server.channel},
                f"socketcand: {server.host} port {server.port}, bus {server.channel}",
                f"    drempower state {ids} -i socketcand -c can0 -o host={server.host} -o port={server.port}",
                f"    can.Bus(interface='socketcand', host='{server.host}', port={server.port}, channel='can0')",
            )
        if args.python_can:
            how = f"--python-can {args.python_can} --python-can-interface {args.python_can_interface}"
            with _explained(how, _python_can_advice(args.python_can_interface, args.python_can)):
                stack.enter_context(attach_python_can(bus, args.python_can, args.python_can_interface, **options))
            extra = "".join(f", {k}={v}" for k, v in options.items())
            record = {"attachment": "python-can", "interface": args.python_can_interface, "channel": args.python_can}
            show(
                {**record, "options": options} if options else record,
                f"python-can: interface {args.python_can_interface}, channel {args.python_can}{extra}",
            )
        show({"running": True}, "running; Ctrl-C stops")
        stream.flush()
        try:
            (stop or threading.Event()).wait(args.duration)
        except KeyboardInterrupt as exc:  # Ctrl-C, SIGTERM, SIGHUP: stop, then exit 128 + n
            ended = exit_code(exc)
    s = bus.stats
    load = f", bus load {s.utilisation:.1%}" if args.bitrate else ""
    show(
        {
            "stopped": True,
            "simulated_s": round(s.elapsed, 3),
            "frames": s.frames,
            "bus_load": round(s.utilisation, 4) if args.bitrate else None,
        },
        f"drempower sim: stopped after {s.elapsed:.1f} s simulated, {s.frames} frames{load}",
    )
    return ended
