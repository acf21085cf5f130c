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
    Frame,
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


def bench(fn: Callable[[], object], n_items: int, seconds: float, repeat: int = 5) -> float:
    """Best of ``repeat`` timed runs (the least disturbed by other load), in seconds per item."""
    timer = timeit.Timer(fn)
    loops, _ = timer.autorange()
    loops = max(1, int(loops * seconds / repeat / 0.2))
    return min(timer.repeat(repeat=repeat, number=loops)) / loops / n_items


def show(label: str, cost: float, floor: float) -> None:
    """One figure beside its floor: us per frame, frames per second, and the ratio."""
    rate = 1e-3 / cost
    print(
        f"  {label:<40} {cost * 1e6:7.3f} us/frame {rate:7.0f} k/s   floor {floor * 1e6:6.3f} us ({cost / floor:4.1f}x)"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seconds", type=float, default=1.0, help="time per measurement (default 1)")
    args = ap.parse_args()
    s = args.seconds
    print(f"drempower codec benchmark: Python {platform.python_version()} ({platform.python_implementation()})")
    print("figures are the best of 5 runs; each floor is the same work in plain Python without validation or types")
    cmd_frames = [(c.encode().arbitration_id, c.encode().data) for c in COMMANDS]
    rep_frames = [(r.encode().arbitration_id, r.encode().data) for r in REPLIES]
    fss = struct.Struct("<fhh")
    pack, unpack = fss.pack, fss.unpack
    values = [(c.node, 0x1A, -150.0, 10.0, 5.0) for c in COMMANDS]
    raw = [(a, d) for a, d in cmd_frames]

    def floor_enc() -> None:
        for node, cmd, a, b, c in values:
            ((node << 5) | cmd, pack(a, round(b * 100), round(c * 100)))

    def floor_dec() -> None:
        for a, d in raw:
            p, v, t = unpack(d)
            (a >> 5, p, v / 100, t / 100)

    def floor_pair() -> None:
        for node, cmd, a, b, c in values:
            f = ((node << 5) | cmd, pack(a, round(b * 100), round(c * 100)))
            p, v, t = unpack(f[1])
            (f[0] >> 5, p, v / 100, t / 100)

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

    n = len(COMMANDS)
    f_enc = bench(floor_enc, n, s)
    f_dec = bench(floor_dec, n, s)
    f_pair = bench(floor_pair, n, s)
    print("messages (encode -> Frame, decode <- id + 8 bytes), one frame each; floor: struct + plain tuple:")
    show("encode, command mix (10 kinds)", bench(enc_cmds, n, s), f_enc)
    show("decode, command mix", bench(dec_cmds, n, s), f_dec)
    show("encode, reply mix (state, param value)", bench(enc_reps, len(REPLIES), s), f_enc)
    show("decode, reply mix", bench(dec_reps, len(REPLIES), s), f_dec)
    p1 = bench(pair_cmds, n, s)
    p2 = bench(pair_reps, len(REPLIES), s)
    show("encode + decode, command mix", p1, f_pair)
    show("encode + decode, reply mix", p2, f_pair)
    print(
        f"  => one frame encoded and decoded (the pair): {p1 * 1e6:.3f} us (commands), {p2 * 1e6:.3f} us (replies);"
        f" floor {f_pair * 1e6:.3f} us"
    )

    reps = 64
    aa_one = [encode_aa((a, d)) for a, d in rep_frames]
    u11_one = [encode_uart11(a, d) for a, d in rep_frames]
    aa_stream = b"".join(aa_one) * reps
    u11_stream = b"".join(u11_one) * reps
    n = reps * len(rep_frames)
    frame_new = tuple.__new__

    def floor_aa(stream: bytes, size: int = 16) -> None:
        # what any decoder must do: cut each frame, build its id, data and Frame (no checks, no resynchronising)
        for i in range(0, len(stream), size):
            frame_new(Frame, ((stream[i + 6] << 8) | stream[i + 7], stream[i + 8 : i + size], False, False))

    def floor_u11(stream: bytes) -> None:
        for i in range(0, len(stream), 11):
            frame_new(Frame, ((stream[i + 1] << 8) | stream[i + 2], stream[i + 3 : i + 11], False, False))

    aa_dec, u11_dec = AADecoder(), Uart11Decoder()

    def aa_each() -> None:
        for chunk in aa_one:
            aa_dec.feed(chunk)

    def u11_each() -> None:
        for chunk in u11_one:
            u11_dec.feed(chunk)

    def floor_aa_each() -> None:
        for chunk in aa_one:
            floor_aa(chunk)

    def floor_u11_each() -> None:
        for chunk in u11_one:
            floor_u11(chunk)

    print("serial stream decoders (bytes -> Frame, validated and resynchronising); floor: cut + Frame, no checks:")
    show(
        "0xAA adapter, 64 x reply mix per feed",
        bench(lambda: AADecoder().feed(aa_stream), n, s),
        bench(lambda: floor_aa(aa_stream), n, s),
    )
    show("0xAA adapter, one frame per feed", bench(aa_each, len(aa_one), s), bench(floor_aa_each, len(aa_one), s))
    show(
        "11-byte UART, 64 x reply mix per feed",
        bench(lambda: Uart11Decoder().feed(u11_stream), n, s),
        bench(lambda: floor_u11(u11_stream), n, s),
    )
    show(
        "11-byte UART, one frame per feed",
        bench(u11_each, len(u11_one), s),
        bench(floor_u11_each, len(u11_one), s),
    )
    print(f"  encode_aa {bench(lambda: [encode_aa(f) for f in rep_frames], len(rep_frames), s) * 1e6:.3f} us/frame")


if __name__ == "__main__":
    main()
