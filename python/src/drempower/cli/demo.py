"""``drempower demo``: the README's main job."""

from __future__ import annotations

import argparse
from typing import Any

from ..protocol import (
    FastRead,
    PresetQ,
    Start,
    StartKind,
    State,
    decode_command,
    decode_reply,
    describe,
    encode_aa,
)


def register(sub: Any) -> None:
    p = sub.add_parser("demo", help="show a synchronised three-motor move frame by frame")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    ids, targets = [1, 2, 3], [90.0, -45.0, 180.0]
    print("A synchronised Q move of motors 1-3 (presets, then one broadcast start):")
    frames = [PresetQ(i, t, time=2.0, accel=20.0).encode() for i, t in zip(ids, targets, strict=True)]
    frames.append(Start(0, StartKind.Q).encode())
    frames += [FastRead(i).encode() for i in ids]
    for f in frames:
        print(f"  {f.arbitration_id:03X}#{f.data.hex().upper()}  {describe(decode_command(f.arbitration_id, f.data))}")
    print("What the motors answer to the fast reads:")
    for i, t in zip(ids, targets, strict=True):
        f = State(i, t, 0.0, 0.05, True, False).encode()
        print(f"  {f.arbitration_id:03X}#{f.data.hex().upper()}  {describe(decode_reply(f.arbitration_id, f.data))}")
    print("On the vendor USB-CAN adapter the first preset travels as:", encode_aa(frames[0]).hex(" ").upper())
    return 0
