"""``drempower sim --robot FILE``: one simulated bus per bus entry, reachable as the file describes it.

* ``virtual`` and other python-can interfaces (``socketcan`` on ``vcan0``...):
  the simulated motors are attached to that interface and channel;
* ``socketcand``: a server on the entry's ``host`` (loopback) and ``port`` (0 or none: a free one);
* ``adapter``, ``serial``, ``slcan`` and ``uart``: a pty behaving like the USB-CAN
  adapter (or the motor's UART); when the entry's ``channel`` names a path that does
  not exist, a symbolic link there points at the pty while the simulator runs;
* ``sim``: a USB-CAN adapter pty (a client's own ``sim`` bus needs no server).

When the file names a physics model, every bus's motors drive its joints: one
:class:`~drempower.sim.twin.Twin` behind all the buses.
"""

from __future__ import annotations

import argparse
import os
import threading
from collections.abc import Callable
from contextlib import ExitStack
from typing import Any

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
from ..sim.twin import TwinRunner, couple_robot
from ._sim_firmware import firmware_of
from ._usage import UsageError

__all__ = ["serve_robot"]

_PTY = frozenset(("adapter", "serial", "slcan", "uart", "sim"))
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


def _serve(stack: ExitStack, spec: RobotSpec, name: str, bus: SimBus) -> dict[str, Any]:
    """Attach ``bus`` as bus entry ``name`` describes; returns what a client connects to."""
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
    elif kind == "socketcand":
        server = stack.enter_context(
            attach_socketcand(bus, int(opts.get("port") or 0), str(opts.get("host", "127.0.0.1")))
        )
        where.update(host=server.host, port=server.port, channel=server.channel)
    else:
        channel = opts.get("channel")
        if channel is None:
            raise UsageError(f"[buses.{name}]: interface {kind!r} needs a channel to attach the simulator to")
        stack.enter_context(attach_python_can(bus, str(channel), kind))
        where["channel"] = channel
    return where


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
    buses = {
        name: SimBus(
            sorted(j.id for j in spec.joints_on(name)),
            bitrate=args.bitrate,
            faults=faults,
            seed=args.seed,
            config_dir=None if args.config_dir is None else os.path.join(args.config_dir, name),
            firmware=firmware_of(args, spec.buses[name].options),
        )
        for name in spec.buses
    }
    twin = couple_robot(spec, buses)
    if twin is not None:
        show(
            {"model": twin.source, "joints": twin.joints},
            f"physics: {os.path.basename(twin.source)} (MuJoCo), joints {', '.join(twin.joints)}",
        )
    with ExitStack() as stack:
        if twin is not None:  # one clock for every bus: the twin integrates all their motors' torques each step
            stack.enter_context(TwinRunner(buses.values(), args.time_scale))
        for name, bus in buses.items():
            if twin is None:
                stack.enter_context(SimRunner(bus, args.time_scale))
            where = _serve(stack, spec, name, bus)
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
        show({"running": True}, f"running {len(buses)} buses of {spec.source}; Ctrl-C stops")
        try:
            (stop or threading.Event()).wait(args.duration)
        except KeyboardInterrupt:
            pass
    frames = sum(b.stats.frames for b in buses.values())
    show({"stopped": True, "frames": frames}, f"drempower sim: stopped, {frames} frames on {len(buses)} buses")
    return 0
