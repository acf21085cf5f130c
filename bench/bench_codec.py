#!/usr/bin/env python3
"""Protocol codec throughput: frames per second for encode, decode and the pair.

Run: ``python3 bench/bench_codec.py [--seconds S]``. Prints figures; asserts nothing.
The mix is what a control loop and its replies look like: T/Q/P/V/C commands,
presets and starts, parameter reads and writes, fast reads and state replies.
"""

from __future__ import annotations

import argparse
import platform
import struct
import sys
import timeit
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python" / "src"))

from drempower.protocol import (
    AADecoder,
    DataType,
    FastRead,
    ParamValue,
    PositionP,
    PositionQ,
    PositionT,
    PresetQ,
    ReadParam,
    Start,
    StartKind,
    State,
    Torque,
    TorqueMode,
    Uart11Decoder,
    Velocity,
    VelocityMode,
    WriteParam,
    decode_command,
    decode_reply,
    encode_aa,
    encode_uart11,
)

COMMANDS = [
    PositionT(1, 90.0, 10.0),
    PositionQ(2, -150.0, 10.0, 5.0),
    PositionP(3, 45.0, 5.0, 0.5),
    Velocity(4, 20.0, 1.5, VelocityMode.PASSTHROUGH),
    Torque(5, 0.5, 2.0, TorqueMode.RAMP),
    PresetQ(6, 90.0, 2.0, 20.0),
    Start(0, StartKind.Q),
    ReadParam(7, 38007, DataType.F32),
    WriteParam(8, 31214, DataType.U32, 1),
    FastRead(9),
]
REPLIES = [
    State(1, 90.0, 1.5, -0.25, True, False),
    State(2, -150.0, 10.0, 0.5, False, False),
    ParamValue(7, 38007, DataType.F32, -92.5),
    State(9, 12.0, 0.0, 0.0, True, True),
]


def bench(label: str, fn: Callable[[], object], n_items: int, seconds: float, repeat: int = 5) -> float:
    """Best of ``repeat`` timed runs (the least disturbed by other load), in frames per second."""
    timer = timeit.Timer(fn)
    loops, _ = timer.autorange()
    loops = max(1, int(loops * seconds / repeat / 0.2))
    best = min(timer.repeat(repeat=repeat, number=loops)) / loops
    rate = n_items / best
    print(f"  {label:<42} {rate / 1e3:9.0f} k frames/s  {1e6 / rate:7.3f} us/frame")
    return rate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seconds", type=float, default=1.0, help="time per measurement (default 1)")
    args = ap.parse_args()
    s = args.seconds
    print(f"drempower codec benchmark: Python {platform.python_version()} ({platform.python_implementation()})")
    print("figures are the best of 5 runs; the reference line shows how fast this machine runs plain Python")
    ref = struct.Struct("<fhh")
    bench("reference: struct.pack + tuple (no validation)", lambda: (0x3A, ref.pack(-150.0, 1000, 500)), 1, s)
    cmd_frames = [(c.encode().arbitration_id, c.encode().data) for c in COMMANDS]
    rep_frames = [(r.encode().arbitration_id, r.encode().data) for r in REPLIES]

    def enc_cmds() -> None:
        for c in COMMANDS:
            c.encode()

    def dec_cmds() -> None:
        for a, d in cmd_frames:
            decode_command(a, d)

    def enc_reps() -> None:
        for r in REPLIES:
            r.encode()

    def dec_reps() -> None:
        for a, d in rep_frames:
            decode_reply(a, d)

    def pair_cmds() -> None:
        for c in COMMANDS:
            f = c.encode()
            decode_command(f.arbitration_id, f.data)

    def pair_reps() -> None:
        for r in REPLIES:
            f = r.encode()
            decode_reply(f.arbitration_id, f.data)

    print("messages (encode -> Frame, decode <- id + 8 bytes):")
    bench("encode, command mix (10 kinds)", enc_cmds, len(COMMANDS), s)
    bench("decode, command mix", dec_cmds, len(COMMANDS), s)
    bench("encode, reply mix (state, param value)", enc_reps, len(REPLIES), s)
    bench("decode, reply mix", dec_reps, len(REPLIES), s)
    r1 = bench("encode + decode pair, command mix", pair_cmds, len(COMMANDS), s)
    r2 = bench("encode + decode pair, reply mix", pair_reps, len(REPLIES), s)
    print(f"  => encode+decode pair: {1e6 / r1:.3f} us (commands), {1e6 / r2:.3f} us (replies)")

    aa_stream = b"".join(encode_aa((a, d)) for a, d in rep_frames) * 64
    u11_stream = b"".join(encode_uart11(a, d) for a, d in rep_frames) * 64
    n = 64 * len(rep_frames)
    print("serial stream decoders (64 x reply mix per feed):")
    bench("0xAA adapter frames", lambda: AADecoder().feed(aa_stream), n, s)
    bench("11-byte UART frames", lambda: Uart11Decoder().feed(u11_stream), n, s)


if __name__ == "__main__":
    main()
