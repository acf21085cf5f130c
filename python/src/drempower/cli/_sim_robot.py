"""``drempower sim --robot FILE``: one simulated bus per bus entry, reachable as the file describes it.

* ``virtual`` and other python-can interfaces (``socketcan`` on ``vcan0``...):
  the simulated motors are attached to that interface and channel;
* ``socketcand``: a server on the entry's ``host`` (loopback) and ``port`` (0 or none: a free one);
* ``adapter``, ``serial``, ``slcan`` and ``uart``: a pty behaving like the USB-CAN
  adapter (or the motor's UART); when the entry's ``channel`` names a path that does
  not exist, a symbolic link there points at the pty while the simulator runs;
* ``sim``: a socketcand server on 127.0.0.1 (a free port), so that several programs (a script, the
  CLI, the dashboard, the bridge) share the one simulated robot at the same time.

Each bus simulates its CAN timing at the entry's ``bitrate`` (or ``--bitrate``): the simulator and the
client take a bus entry's options by the same rules (an ``adapter`` entry's ``bitrate`` is refused by
both, in the same words). When a ``sim`` bus is served, a ready robot file is written (the same
joints, each ``sim`` bus as the socketcand bus it now is) and its path printed on one line: every
other program reaches the twin by joint name with ``--robot`` that file.

When the file names a physics model, every bus's motors drive its joints: one
:class:`~drempower.sim.twin.Twin` behind all the buses.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import tempfile
import threading
from collections.abc import Callable, Sequence
from contextlib import ExitStack
from typing import Any

from ..errors import ConfigError, ValidationError
from ..robot.config import RobotSpec, load_robot
from ..sim import (
    Faults,
    SimBus,
    SimRunner,
    attach_adapter_pty,
    attach_python_can,
    attach_socketcand,
    attach_uart_pty,
)
from ..sim.hand_link import twin_hand
from ..sim.noise import sensor_noise
from ..sim.twin import TwinRunner, couple_robot
from ..transports.factory import adapter_bitrate_refusal
from ._sim_firmware import firmware_of
from ._usage import UsageError

__all__ = ["serve_robot"]

_PTY = frozenset(("adapter", "serial", "slcan", "uart"))
_OWN = ("adapter_pty", "uart_pty", "socketcand_port", "python_can", "ids")


def _link(stack: ExitStack, channel: object, path: str) -> str | None:
    """Make ``channel`` (a path that does not exist) a symbolic link to ``path`` while the simulator runs."""
    if not isinstance(channel, str) or not channel or os.path.lexists(channel):
        return None
    try:
        os.symlink(path, channel)
    except OSError:
        return None
    stack.callback(os.unlink, channel)
    return channel


def _serve(
    stack: ExitStack, spec: RobotSpec, name: str, bus: SimBus, hand: Callable[[Sequence[str]], None] | None = None
) -> dict[str, Any]:
    """Attach ``bus`` as bus entry ``name`` describes; returns what a client connects to. ``hand``: the twin's
    hand from outside, taken by a socketcand server's ``< push ... >`` (:mod:`drempower.sim.hand_link`)."""
    entry = spec.buses[name]
    opts = dict(entry.options)
    kind = entry.interface
    where: dict[str, Any] = {"bus": name, "interface": kind, "motors": sorted(bus.motors)}
    if kind in _PTY:
        if kind == "uart":
            (ident,) = sorted(bus.motors) if len(bus.motors) == 1 else (None,)
            if ident is None:
                raise UsageError(f"[buses.{name}]: a uart bus carries one joint, not {len(bus.motors)}")
            path = stack.enter_context(attach_uart_pty(bus, ident)).path
        else:
            path = stack.enter_context(attach_adapter_pty(bus)).path
        where["path"] = path
        linked = _link(stack, opts.get("channel"), path)
        if linked is not None:
            where["link"] = linked
    elif kind in ("socketcand", "sim"):  # a sim bus: served where every program on this host reaches it
        port = int(opts.get("port") or 0) if kind == "socketcand" else 0
        host = str(opts.get("host", "127.0.0.1")) if kind == "socketcand" else "127.0.0.1"
        server = stack.enter_context(attach_socketcand(bus, port, host, hand=hand))
        where.update(host=server.host, port=server.port, channel=server.channel)
    else:
        channel = opts.get("channel")
        if channel is None:
            raise UsageError(f"[buses.{name}]: interface {kind!r} needs a channel to attach the simulator to")
        stack.enter_context(attach_python_can(bus, str(channel), kind))
        where["channel"] = channel
    return where


def _noise(args: argparse.Namespace, spec: RobotSpec, name: str) -> Any:
    """The sensor noise of bus ``name``: ``--noise``, else its entry's ``noise`` table (checked by the bus)."""
    given = getattr(args, "noise", None)
    if given is not None:
        return given
    try:
        return sensor_noise(spec.buses[name].options.get("noise"))
    except ValidationError as exc:
        raise ConfigError(f"{spec.source}: [buses.{name}]: {exc}") from None


def _bitrate(spec: RobotSpec, name: str, given: int | None) -> int | None:
    """The bit rate bus ``name`` is simulated at: ``--bitrate``, else its entry's ``bitrate`` (the client's
    rules: an ``adapter`` entry takes none)."""
    entry = spec.buses[name]
    own = entry.options.get("bitrate")
    if own is not None and entry.interface in ("adapter", "serial"):
        raise UsageError(f"{spec.source}: [buses.{name}]: {adapter_bitrate_refusal(entry.options.get('channel'), own)}")
    if own is not None and (isinstance(own, bool) or not isinstance(own, int) or own <= 0):
        raise UsageError(f"{spec.source}: [buses.{name}]: bitrate={own!r}: expected bit/s, e.g. 1000000")
    if given is not None and own is not None and given != own:
        raise UsageError(f"--bitrate {given}: [buses.{name}] of {spec.source} says bitrate = {own}")
    return given if given is not None else own


_HEADER = re.compile(r"^\s*\[\s*([^\]]+?)\s*\]\s*(#.*)?$")


def ready_text(text: str, spec: RobotSpec, served: dict[str, dict[str, Any]]) -> str:
    """The robot file ``text`` with each ``sim`` bus as the socketcand bus ``served`` says it now is, and the
    model's path absolute (the copy lives elsewhere)."""
    out: list[str] = []
    section: str | None = None
    for line in text.splitlines():
        m = _HEADER.match(line)
        if m is not None:
            section = m.group(1).replace('"', "").replace(" ", "")
            out.append(line)
            name = section.removeprefix("buses.") if section.startswith("buses.") else None
            if name in served and spec.buses[name].interface == "sim":
                w = served[name]
                out.append(
                    f'interface = "socketcand"\nhost = "{w["host"]}"\nport = {w["port"]}\nchannel = "{w["channel"]}"'
                )
                rate = spec.buses[name].options.get("bitrate")
                if rate is not None:
                    out.append(f"bitrate = {int(rate)}")
            continue
        name = section.removeprefix("buses.") if section and section.startswith("buses.") else None
        if name in served and spec.buses[name].interface == "sim":
            continue  # the sim bus's own keys: the socketcand bus above replaces them
        if section == "model" and line.split("=", 1)[0].strip() == "file" and spec.model is not None:
            out.append(f'file = "{spec.model.file}"')
            continue
        out.append(line)
    return "\n".join(out) + "\n"


def _ready_file(stack: ExitStack, spec: RobotSpec, served: dict[str, dict[str, Any]], path: str) -> str | None:
    """Write the robot file other programs use to reach the served ``sim`` buses (None: no sim bus);
    removed when the simulator stops."""
    if not any(spec.buses[n].interface == "sim" for n in served):
        return None
    with open(path, encoding="utf-8") as f:
        text = ready_text(f.read(), spec, served)
    folder = tempfile.mkdtemp(prefix="drempower-sim-")
    stack.callback(shutil.rmtree, folder, True)
    out = os.path.join(folder, os.path.basename(path))
    with open(out, "w", encoding="utf-8") as f:
        f.write(text)
    load_robot(out)  # the copy is a robot file the client takes
    return out


def serve_robot(args: argparse.Namespace, show: Callable[..., None], stop: threading.Event | None) -> int:
    """Run one simulated bus per bus entry of ``args.robot_file`` until ``stop``, Ctrl-C or ``--duration``."""
    given = [f"--{o.replace('_', '-')}" for o in _OWN if getattr(args, o, None) not in (None, False)]
    if given:
        raise UsageError(f"--robot gives the buses and motors; {given[0]} does not go with it")
    spec = load_robot(args.robot_file)
    faults = Faults(
        drop_rate=args.drop_rate,
        corrupt_rate=args.corrupt_rate,
        reply_delay=args.reply_delay,
        serial_garbage=args.serial_garbage,
    )
    rates = {name: _bitrate(spec, name, args.bitrate) for name in spec.buses}
    buses = {
        name: SimBus(
            sorted(j.id for j in spec.joints_on(name)),
            bitrate=rates[name],
            faults=faults,
            seed=args.seed,
            config_dir=None if args.config_dir is None else os.path.join(args.config_dir, name),
            firmware=firmware_of(args, spec.buses[name].options),
            thermal=spec.buses[name].options.get("thermal"),
            noise=_noise(args, spec, name),
            **spec.sim_thermal(name),
        )
        for name in spec.buses
    }
    twin = couple_robot(spec, buses)
    if twin is not None:
        show(
            {"model": twin.source, "joints": twin.joints},
            f"physics: {os.path.basename(twin.source)} (MuJoCo), joints {', '.join(twin.joints)}",
        )
    served: dict[str, dict[str, Any]] = {}
    with ExitStack() as stack:
        if twin is not None:  # one clock for every bus: the twin integrates all their motors' torques each step
            stack.enter_context(TwinRunner(buses.values(), args.time_scale))
        for name, bus in buses.items():
            if twin is None:
                stack.enter_context(SimRunner(bus, args.time_scale))
            where = _serve(stack, spec, name, bus, None if twin is None else twin_hand(twin))
            joints = ", ".join(f"{j.name}={j.id}" for j in spec.joints_on(name))
            reach = (
                where.get("link")
                or where.get("path")
                or (
                    f"{where['host']}:{where['port']}"
                    if "port" in where
                    else f"{where['interface']} {where['channel']}"
                )
            )
            show(where, f"bus {name} ({joints}): {reach}")
            served[name] = where
        ready = _ready_file(stack, spec, served, args.robot_file)
        if ready is not None:
            show(
                {"robot_file": ready},
                f"robot file for other programs (a script, drempower ... --robot, dash, bridge): {ready}",
            )
        show({"running": True}, f"running {len(buses)} buses of {spec.source}; Ctrl-C stops")
        try:
            (stop or threading.Event()).wait(args.duration)
        except KeyboardInterrupt:
            pass
    frames = sum(b.stats.frames for b in buses.values())
    show({"stopped": True, "frames": frames}, f"drempower sim: stopped, {frames} frames on {len(buses)} buses")
    return 0
