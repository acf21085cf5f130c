"""``drempower bus-load``: bus load of a control loop, and the highest rate the bus allows."""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import Any

from ..protocol import FastRead, PositionT, State
from ..protocol.ids import Frame
from ..sim.timing import frame_bits
from ._connect import ascii_digits, bitrate, positive
from ._output import add_json_arg, json_line

GROUP = "bus"
"""Where ``drempower --help`` lists this module's subcommands."""

_MAX_BANDWIDTH = 300.0


def _count(text: str) -> int:
    if not (ascii_digits(text) and 1 <= int(text) <= 63):
        raise argparse.ArgumentTypeError(f"expected a number of motors 1..63, got {text!r}")
    return int(text)


def register(sub: Any) -> None:
    p = sub.add_parser(
        "bus-load",
        help="bus load of a control loop and the highest control rate for N motors",
        description=(
            "Each control cycle sends every motor a T-mode position command and collects its state: with "
            "--reply-state the motor answers the command itself, otherwise the host adds a fast read. "
            "Frame lengths are exact, bit stuffing included, for motors at 0 deg and at rest (long runs of "
            "equal bits: close to the most stuffing, so the figures err on the safe side)."
        ),
    )
    p.add_argument("--motors", type=_count, required=True, metavar="N", help="number of motors (1..63), ids 1..N")
    p.add_argument("--rate", type=positive, required=True, metavar="HZ", help="control cycles per second")
    p.add_argument("--bitrate", type=bitrate, default=1_000_000, metavar="B", help="CAN bitrate, bit/s (default 1M)")
    p.add_argument("--reply-state", action="store_true", help="motors answer each command with their state")
    add_json_arg(p)
    p.set_defaults(func=run)


@dataclass(frozen=True, slots=True)
class Load:
    """The frames of one control cycle and what they cost on the bus."""

    motors: int
    rate: float
    bitrate: int
    reply_state: bool
    frames: int
    bits: int

    @property
    def load(self) -> float:
        """Fraction of the bus's time the cycles take at ``rate``."""
        return self.bits * self.rate / self.bitrate

    @property
    def max_rate(self) -> float:
        """Cycles per second that fill the bus completely."""
        return self.bitrate / self.bits

    def record(self) -> dict[str, Any]:
        return {
            "motors": self.motors,
            "rate_hz": self.rate,
            "bitrate": self.bitrate,
            "reply_state": self.reply_state,
            "frames_per_cycle": self.frames,
            "bits_per_cycle": self.bits,
            "load_percent": round(100 * self.load, 2),
            "max_rate_hz": round(self.max_rate, 1),
        }


def cycle_frames(motors: int, rate: float, reply_state: bool) -> list[Frame]:
    """The frames of one control cycle: command (and fast read) and state reply per motor."""
    bandwidth = min(rate / 2, _MAX_BANDWIDTH)
    frames = []
    for node in range(1, motors + 1):
        frames.append(PositionT(node, 0.0, bandwidth).encode())
        if not reply_state:
            frames.append(FastRead(node).encode())
        frames.append(State(node, 0.0, 0.0, 0.0, True, False).encode())
    return frames


def bus_load(motors: int, rate: float, bitrate: int, reply_state: bool) -> Load:
    frames = cycle_frames(motors, rate, reply_state)
    bits = sum(frame_bits(f.arbitration_id, f.data) for f in frames)
    return Load(motors, rate, bitrate, reply_state, len(frames), bits)


def run(args: argparse.Namespace) -> int:
    result = bus_load(args.motors, args.rate, args.bitrate, args.reply_state)
    if args.json:
        print(json_line(result.record()))
        return 0
    per_motor = "a state reply" if args.reply_state else "a fast read and a state reply"
    motors = f"{args.motors} motor{'s' if args.motors > 1 else ''}"
    print(f"{motors}, {args.rate:g} Hz, {args.bitrate} bit/s: per cycle and motor a T position command, {per_motor}")
    print(
        f"per cycle: {result.frames} frames, {result.bits} bits = {result.bits / args.bitrate * 1e6:.0f} us of bus time"
    )
    over = " (over 100 %: the bus cannot carry this)" if result.load > 1 else ""
    print(f"bus load: {100 * result.load:.1f} %{over}")
    best = result.max_rate
    print(f"highest control rate: {best:.0f} Hz (bus full); {0.7 * best:.0f} Hz keeps the load under 70 %")
    return 0
