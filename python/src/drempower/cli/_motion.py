"""What the motion commands share: value lists, stopping on Ctrl-C, holding for a while."""

from __future__ import annotations

import argparse
import math
import re
import sys
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager

from ..client import Bus
from ..client.driver.signals import Terminated, hurried
from ..client.engine.stops import hold_frames
from ..errors import DrEmpowerError
from ._connect import add_ids_arg, ascii_float, ascii_int, open_from_args, positive
from ._output import clean, motors_text
from ._usage import UsageError

__all__ = [
    "add_duration_arg",
    "add_motion_args",
    "add_watchdog_arg",
    "arm_watchdog",
    "driving",
    "hold",
    "number_list",
    "per_motor",
    "restore_watchdog",
    "stop_commanded",
]

_UNSIGNED = r"(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_NEGATIVE_LIST = re.compile(rf"^-{_UNSIGNED}(?:,[-+]?{_UNSIGNED})*$")
"""Words such as ``-45`` or ``-45,90`` that argparse must take as values, not as options."""


def number_list(text: str) -> list[float]:
    """An argument type: ``"90,-45,180"`` -> ``[90.0, -45.0, 180.0]`` (finite numbers)."""
    try:
        values = [ascii_float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number or a comma-separated list of numbers") from None
    if not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"{text!r}: NaN and infinity cannot be sent")
    return values


def add_motion_args(parser: argparse.ArgumentParser, values: str, help: str) -> None:
    """IDS and a VALUES list, and ``--no-stop-on-exit``.

    Negative values such as ``-45,90`` are taken as values, not as options.
    """
    parser._negative_number_matcher = _NEGATIVE_LIST
    add_ids_arg(parser, many=False)
    parser.add_argument("values", type=number_list, metavar=values, help=help + "; one for all motors or one each")
    parser.add_argument(
        "--no-stop-on-exit",
        dest="stop_on_exit",
        action="store_false",
        help="on Ctrl-C, leave the motors as they are (default: set the motors commanded to idle)",
    )


def add_duration_arg(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--duration", type=positive, metavar="S", help="keep it up for S seconds, then set the motors idle"
    )


def per_motor(ids: Sequence[int], values: Sequence[float], what: str) -> list[float]:
    """One value per motor: a single value applies to all."""
    if len(values) == 1:
        return list(values) * len(ids)
    if len(values) != len(ids):
        raise UsageError(f"{len(ids)} motors but {len(values)} {what} values: give one for all or one each")
    return list(values)


COASTING_RPM = 0.5
"""Above this speed (r/min) an idle motor is reported as still coasting."""


def stop_commanded(bus: Bus, why: str) -> None:
    """Set every motor this bus commanded to idle (a robot file's joint that holds: speed 0), and say on stderr
    what each is doing then.

    Idle stops driving, not turning: a motor that still moves is reported as
    coasting at its speed (r/min), so nobody takes "idle" for "at rest".
    A second signal while this runs never cuts it short (see
    :func:`~drempower.client.driver.signals.signals_interrupt`): every motor still
    gets its idle frame, and only the reading of their motion is left out.
    """
    nodes = sorted(bus.commanded)
    held = sorted(n for n in nodes if n in bus.held_on_close)  # a robot file's joints that hold
    failed: list[str] = []
    for node in nodes:  # each motor its frame, whatever another one's send did
        try:
            if node in held:
                bus.send_frames(hold_frames([node]))
            else:
                bus.motor(node).set_mode(1)
        except DrEmpowerError as exc:
            failed.append(f"motor {node}: {exc}")
    if failed:
        raise DrEmpowerError("could not stop: " + "; ".join(failed))
    idled = [n for n in nodes if n not in held]
    if held:
        print(f"drempower: {why}: {motors_text(held)} held (speed 0: the robot file's on_timeout)", file=sys.stderr)
    if idled:
        motion = "" if hurried() else _motion_text(bus, idled)
        print(f"drempower: {why}: {motors_text(idled)} set to idle{motion}", file=sys.stderr)


def _motion_text(bus: Bus, nodes: Sequence[int]) -> str:
    """``"; motor 1 still coasting at 66 rpm, motor 2 at rest"`` from a fresh state of each motor."""
    if nodes == [0]:
        return ""
    parts = []
    for node in nodes:
        if hurried():  # a second signal: no more waiting for replies
            parts.append(f"motor {node}: motion not read")
            continue
        name = f"motor {node}"
        try:
            st = bus.motor(node).get_state()
        except DrEmpowerError:
            parts.append(f"{name}: motion unknown (no state)")
            continue
        if abs(st.speed) > COASTING_RPM:
            parts.append(f"{name} still coasting at {st.speed:.0f} rpm")
        else:
            parts.append(f"{name} at rest")
    return "; " + ", ".join(parts)


WATCHDOG_PARAMETER = "can.config.timeout_ms"
"""The motor's CAN timeout (ms, 0 = off): no frame for that long and it goes idle with damping."""
_U32_MAX = 0xFFFFFFFF
WATCHDOG_MIN_MS = 100
"""Shortest --watchdog (ms): a command may leave that long between frames (a request timeout, a poll)."""


def _watchdog_ms(text: str) -> int:
    try:
        value = ascii_int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected whole milliseconds {WATCHDOG_MIN_MS}..{_U32_MAX}, got {text!r}"
        ) from None
    if not WATCHDOG_MIN_MS <= value <= _U32_MAX:
        raise argparse.ArgumentTypeError(
            f"{value} is out of range: allowed {WATCHDOG_MIN_MS}..{_U32_MAX} ms (a shorter timeout would idle "
            "the motors between this command's own frames)"
        )
    return value


def add_watchdog_arg(parser: argparse.ArgumentParser) -> None:
    """``--watchdog MS``: arm the motors' CAN timeout while the command runs (see :func:`driving`)."""
    parser.add_argument(
        "--watchdog",
        type=_watchdog_ms,
        metavar="MS",
        help=(
            f"while the command runs, set {WATCHDOG_PARAMETER} to MS so that a motor goes idle MS ms "
            "after this program stops talking to it, even if it is killed (SIGKILL); "
            "the previous value is restored at the end"
        ),
    )


def arm_watchdog(bus: Bus, ids: Sequence[int], ms: int) -> dict[int, int]:
    """Set the CAN timeout of each motor to ``ms``; returns the previous value of each."""
    previous: dict[int, int] = {}
    try:
        for node in ids:
            m = bus.motor(node)
            previous[node] = int(m.read_property(WATCHDOG_PARAMETER))
            m.write_property(WATCHDOG_PARAMETER, ms, verify=True)
    except BaseException:
        restore_watchdog(bus, previous)
        raise
    return previous


def restore_watchdog(bus: Bus, previous: dict[int, int]) -> None:
    """Put back each motor's CAN timeout; a failure is reported on stderr, not raised."""
    for node, ms in previous.items():
        try:
            bus.motor(node).write_property(WATCHDOG_PARAMETER, ms, verify=True)
        except DrEmpowerError as exc:
            print(
                clean(f"drempower: motor {node}: could not restore {WATCHDOG_PARAMETER} to {ms}: {exc}"),
                file=sys.stderr,
            )


@contextmanager
def driving(args: argparse.Namespace) -> Iterator[Bus]:
    """The bus of a motion command.

    On Ctrl-C, SIGTERM or SIGHUP, and when the command fails (a move that
    missed its target, a timeout, a lost device), the motors it commanded go
    idle (unless --no-stop-on-exit). With ``--watchdog MS`` each motor's CAN
    timeout is armed before anything moves and restored when the command ends,
    however it ends (after the motors were stopped).
    """
    with open_from_args(args) as bus:
        watchdog: int | None = getattr(args, "watchdog", None)
        previous = arm_watchdog(bus, args.ids, watchdog) if watchdog else {}
        try:
            yield bus
        except KeyboardInterrupt as exc:  # Ctrl-C, SIGTERM or SIGHUP
            if args.stop_on_exit:
                stop_commanded(bus, f"terminated ({exc})" if isinstance(exc, Terminated) else "interrupted")
            raise
        except DrEmpowerError:  # the command failed: what it started must not go on unattended
            if args.stop_on_exit:
                try:
                    stop_commanded(bus, "the command failed")
                except DrEmpowerError as stop_error:
                    print(clean(f"drempower: could not stop the motors: {stop_error}"), file=sys.stderr)
            raise
        finally:
            restore_watchdog(bus, previous)


def hold(bus: Bus, seconds: float | None, ids: Sequence[int] = (), watchdog: int | None = None) -> None:
    """With ``--duration``: wait, then set the commanded motors idle.

    With a ``watchdog`` (ms) armed, each motor of ``ids`` gets a fast read
    every third of it meanwhile, so the timeout fires only when this program
    is gone.
    """
    if seconds is None:
        return
    if not watchdog:
        time.sleep(seconds)
    else:
        end = time.monotonic() + seconds
        step = watchdog / 3000.0
        while (left := end - time.monotonic()) > 0:
            time.sleep(min(step, left))
            for node in ids:
                try:
                    bus.motor(node).get_state()
                except DrEmpowerError:
                    pass  # one missed reply; the next read retries
    stop_commanded(bus, f"after {seconds:g} s")
