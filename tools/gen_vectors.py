#!/usr/bin/env python3
"""Write the golden vectors in ``spec/vectors/`` (format: spec/vectors/README.md).

The bytes are packed here with plain ``struct`` calls, independently of the
drempower package that the vectors check. The worked examples of the protocol
document and PROTOCOL.md section 1.7 are literal bytes, as printed.

Usage::

    python3 tools/gen_vectors.py          # write the files
    python3 tools/gen_vectors.py --check  # exit 1 if a file is stale
"""

from __future__ import annotations

import argparse
import json
import struct
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "spec" / "vectors"

V = dict[str, Any]


def f32(x: float) -> float:
    """x rounded to binary32 (so that JSON holds a value exactly representable in f32)."""
    return float(struct.unpack("<f", struct.pack("<f", x))[0])


def s16(x: float) -> int:
    raw = round(x * 100)
    assert -32768 <= raw <= 32767, x
    return raw


def hexs(b: bytes) -> str:
    assert len(b) == 8, b
    return b.hex().upper()


def vec(
    name: str, direction: str, message: str, node: int, fields: dict[str, Any], cmd: int, data: bytes, **extra: Any
) -> V:
    v: V = {"name": name}
    if "source" in extra:
        v["source"] = extra.pop("source")
    v.update(direction=direction, message=message, node=node, fields=fields, id=(node << 5) | cmd, data=hexs(data))
    v.update(extra)
    return v


def fss(a: float, b: float, c: float) -> bytes:
    return struct.pack("<fhh", a, s16(b), s16(c))


# ----------------------------------------------------------------------------- documented examples


def lit(h: str) -> bytes:
    return bytes.fromhex(h)


def doc_examples() -> list[V]:
    d = "protocol doc"
    p = "PROTOCOL.md 1.7"
    return [
        vec(
            "T mode: node 1 to 90 deg, bandwidth 10",
            "host",
            "position_t",
            1,
            {"position": 90.0, "bandwidth": 10.0, "speed": 0.0},
            0x19,
            lit("0000B4420000E803"),
            source=f"{d} 2.1; {p}",
        ),
        vec(
            "Q mode: node 1 to -150 deg, 10 r/min, 5 (r/min)/s",
            "host",
            "position_q",
            1,
            {"position": -150.0, "speed": 10.0, "accel": 5.0},
            0x1A,
            lit("000016C3E803F401"),
            source=f"{d} 2.1; {p}",
        ),
        vec(
            "P mode: node 2 to 45 deg, speed ff 5 r/min, torque ff 0.5 Nm",
            "host",
            "position_p",
            2,
            {"position": 45.0, "speed_ff": 5.0, "torque_ff": 0.5},
            0x1B,
            lit("00003442F4013200"),
            source=p,
        ),
        vec(
            "V passthrough: node 1 at 20 r/min, torque ff 1.5 Nm",
            "host",
            "velocity",
            1,
            {"speed": 20.0, "param": 1.5, "mode": "passthrough"},
            0x1C,
            lit("0000A04196000100"),
            source=f"{d} 2.2; {p}",
        ),
        vec(
            "V ramp: node 1 to 20 r/min at 5 (r/min)/s",
            "host",
            "velocity",
            1,
            {"speed": 20.0, "param": 5.0, "mode": "ramp"},
            0x1C,
            lit("0000A041F4010200"),
            source=f"{d} 2.2; {p}",
        ),
        vec(
            "C direct: node 1, 0.5 Nm",
            "host",
            "torque",
            1,
            {"torque": 0.5, "param": 0.0, "mode": "direct"},
            0x1D,
            lit("0000003F00000100"),
            source=p,
        ),
        vec(
            "C ramp: node 1, 0.5 Nm at 2 Nm/s",
            "host",
            "torque",
            1,
            {"torque": 0.5, "param": 2.0, "mode": "ramp"},
            0x1D,
            lit("0000003FC8000600"),
            source=p,
        ),
        vec(
            "estop node 3", "host", "system", 3, {"op": "estop"}, 0x08, lit("0600000000000000"), source=f"{d} 1.1; {p}"
        ),
        vec(
            "set_mode(1, 2): write axis0.requested_state = 8",
            "host",
            "write_param",
            1,
            {"address": 30003, "dtype": "u32", "value": 8},
            0x1F,
            lit("3375030008000000"),
            source=p,
        ),
        vec(
            "set_id 1 -> 5: write axis0.config.can_node_id = 5",
            "host",
            "write_param",
            1,
            {"address": 31001, "dtype": "u32", "value": 5},
            0x1F,
            lit("1979030005000000"),
            source=f"{d} 2.3; {p}",
        ),
        vec(
            "read vbus_voltage from node 1",
            "host",
            "read_param",
            1,
            {"address": 1, "dtype": "f32"},
            0x1E,
            lit("0100000000000000"),
            source=p,
        ),
        vec(
            "read axis0.output_shaft.pos_estimate from node 4",
            "host",
            "read_param",
            4,
            {"address": 38007, "dtype": "f32"},
            0x1E,
            lit("7794000000000000"),
            source=f"{d} 1.2 note 5; {p}",
        ),
        vec(
            "reply: axis0.output_shaft.pos_estimate of node 4 = -92.469 deg",
            "motor",
            "param_value",
            4,
            {"address": 38007, "dtype": "f32", "value": f32(-92.46917724609375)},
            0x1E,
            lit("7794000038F0B8C2"),
            source=f"{d} 1.2 note 5; {p}",
        ),
        vec(
            "fast read node 1 (get_state)",
            "host",
            "fast_read",
            1,
            {},
            0x1E,
            lit("0000000000000000"),
            source=f"{d} 1.2 note 7; {p}",
        ),
        vec(
            "real-time state frame example (the document reuses the read-reply bytes; values are meaningless)",
            "motor",
            "state",
            4,
            {
                "position": struct.unpack("<f", lit("77940000"))[0],
                "speed": -40.40,
                "torque": -156.88,
                "trajectory_done": False,
                "error": False,
                "spare_bits": 0,
            },
            0x01,
            lit("7794000038F0B8C2"),
            source=f"{d} 1.2 note 6; PROTOCOL.md 7.2 item 8",
        ),
        vec(
            "set_angles([1,2],[90,-90],10,20,1): preset node 1 (T = 2.0 s, accel 20)",
            "host",
            "preset_q",
            1,
            {"position": 90.0, "time": 2.0, "accel": 20.0},
            0x0C,
            lit("0000B442C800D007"),
            source=p,
            decodes_as={"message": "preset", "fields": {"p1": 90.0, "p2": 2.0, "p3": 20.0}},
        ),
        vec(
            "set_angles([1,2],[90,-90],10,20,1): preset node 2",
            "host",
            "preset_q",
            2,
            {"position": -90.0, "time": 2.0, "accel": 20.0},
            0x0C,
            lit("0000B4C2C800D007"),
            source=p,
            decodes_as={"message": "preset", "fields": {"p1": -90.0, "p2": 2.0, "p3": 20.0}},
        ),
        vec(
            "set_angles: broadcast Q start, absolute",
            "host",
            "start",
            0,
            {"kind": "q", "relative": False},
            0x08,
            lit("1100000000000000"),
            source=p,
        ),
        vec(
            "step_angles: broadcast Q start, relative",
            "host",
            "start",
            0,
            {"kind": "q", "relative": True},
            0x08,
            lit("1100000001000000"),
            source=p,
        ),
        vec(
            "impedance_control(1,180,0,0,0.5,0.2): preset",
            "host",
            "preset_d",
            1,
            {"position": 180.0, "speed": 0.0, "torque_ff": 0.0},
            0x0C,
            lit("0000344300000000"),
            source=p,
            decodes_as={"message": "preset", "fields": {"p1": 180.0, "p2": 0.0, "p3": 0.0}},
        ),
        vec(
            "impedance_control(1,180,0,0,0.5,0.2): broadcast start kp 0.5 kd 0.2",
            "host",
            "start_impedance",
            0,
            {"kp": 0.5, "kd": 0.2},
            0x08,
            lit("1500000032001400"),
            source=p,
        ),
        vec(
            "set_speeds([1],[10],0,1): V preset, passthrough (mode code 100)",
            "host",
            "preset_v",
            1,
            {"speed": 10.0, "param": 0.0, "mode": "passthrough"},
            0x0C,
            lit("0000204100006400"),
            source=p,
            decodes_as={"message": "preset", "fields": {"p1": 10.0, "p2": 0.0, "p3": 1.0}},
        ),
        vec(
            "set_speeds: broadcast V start",
            "host",
            "start",
            0,
            {"kind": "v", "relative": False},
            0x08,
            lit("1300000000000000"),
            source=p,
        ),
        vec(
            "set_torques([1],[3],10,0): C preset, ramp 10 Nm/s (mode code 600)",
            "host",
            "preset_c",
            1,
            {"torque": 3.0, "param": 10.0, "mode": "ramp"},
            0x0C,
            lit("00004040E8035802"),
            source=p,
            decodes_as={"message": "preset", "fields": {"p1": 3.0, "p2": 10.0, "p3": 6.0}},
        ),
        vec(
            "set_torques: broadcast C start",
            "host",
            "start",
            0,
            {"kind": "c", "relative": False},
            0x08,
            lit("1400000000000000"),
            source=p,
        ),
    ]


# ----------------------------------------------------------------------------- systematic coverage

NODES = (0, 1, 63)


def motion() -> list[V]:
    out: list[V] = []
    for node in NODES:
        out.append(
            vec(
                f"T node {node}: -720.5 deg, bw 25, speed 0",
                "host",
                "position_t",
                node,
                {"position": -720.5, "bandwidth": 25.0, "speed": 0.0},
                0x19,
                fss(-720.5, 0, 25),
            )
        )
        out.append(
            vec(
                f"Q node {node}: 3600 deg, 327.67 r/min, 327.67 (r/min)/s (s16 maximum)",
                "host",
                "position_q",
                node,
                {"position": 3600.0, "speed": 327.67, "accel": 327.67},
                0x1A,
                fss(3600, 327.67, 327.67),
            )
        )
        out.append(
            vec(
                f"P node {node}: -0.25 deg, -327.68 r/min, -327.68 Nm (s16 minimum)",
                "host",
                "position_p",
                node,
                {"position": -0.25, "speed_ff": -327.68, "torque_ff": -327.68},
                0x1B,
                fss(-0.25, -327.68, -327.68),
            )
        )
        out.append(
            vec(
                f"V node {node}: -1000.5 r/min passthrough, ff -0.01 Nm",
                "host",
                "velocity",
                node,
                {"speed": -1000.5, "param": -0.01, "mode": "passthrough"},
                0x1C,
                struct.pack("<fhH", -1000.5, -1, 1),
            )
        )
        out.append(
            vec(
                f"C node {node}: -12.75 Nm ramp 0.01 Nm/s",
                "host",
                "torque",
                node,
                {"torque": -12.75, "param": 0.01, "mode": "ramp"},
                0x1D,
                struct.pack("<fhH", -12.75, 1, 6),
            )
        )
    big = f32(1.0e30)
    tiny = f32(1.0e-30)
    out += [
        vec(
            "T: large f32 position",
            "host",
            "position_t",
            5,
            {"position": big, "bandwidth": 0.01, "speed": 0.0},
            0x19,
            fss(big, 0, 0.01),
        ),
        vec(
            "T: tiny f32 position, ignored speed field carried",
            "host",
            "position_t",
            5,
            {"position": tiny, "bandwidth": 300.0, "speed": 12.34},
            0x19,
            fss(tiny, 12.34, 300),
        ),
        vec(
            "T: negative zero position",
            "host",
            "position_t",
            7,
            {"position": -0.0, "bandwidth": 1.0, "speed": 0.0},
            0x19,
            fss(-0.0, 0, 1),
        ),
        vec(
            "Q: rounding to nearest, 0.29 and 1.15 (truncation would give 0.28 and 1.14)",
            "host",
            "position_q",
            1,
            {"position": 10.0, "speed": 0.29, "accel": 1.15},
            0x1A,
            struct.pack("<fhh", 10.0, 29, 115),
        ),
        vec(
            "Q: inputs 0.574 and 1.156 round to 0.57 and 1.16",
            "host",
            "position_q",
            1,
            {"position": 10.0, "speed": 0.574, "accel": 1.156},
            0x1A,
            struct.pack("<fhh", 10.0, 57, 116),
            decodes_as={"message": "position_q", "fields": {"position": 10.0, "speed": 0.57, "accel": 1.16}},
        ),
        vec(
            "Q: exact ties x100 round to even, 0.125 -> 12 and 0.375 -> 38",
            "host",
            "position_q",
            1,
            {"position": 10.0, "speed": 0.125, "accel": 0.375},
            0x1A,
            struct.pack("<fhh", 10.0, 12, 38),
            decodes_as={"message": "position_q", "fields": {"position": 10.0, "speed": 0.12, "accel": 0.38}},
        ),
        vec(
            "P: negative exact ties round to even, -0.125 -> -12 and -0.375 -> -38",
            "host",
            "position_p",
            2,
            {"position": 0.0, "speed_ff": -0.125, "torque_ff": -0.375},
            0x1B,
            struct.pack("<fhh", 0.0, -12, -38),
            decodes_as={"message": "position_p", "fields": {"position": 0.0, "speed_ff": -0.12, "torque_ff": -0.38}},
        ),
        vec(
            "T: exact ties round to even, speed 0.625 -> 62 and bandwidth 1.125 -> 112",
            "host",
            "position_t",
            3,
            {"position": 1.0, "bandwidth": 1.125, "speed": 0.625},
            0x19,
            struct.pack("<fhh", 1.0, 62, 112),
            decodes_as={"message": "position_t", "fields": {"position": 1.0, "bandwidth": 1.12, "speed": 0.62}},
        ),
        vec(
            "V ramp: negative target, ramp 300 (r/min)/s",
            "host",
            "velocity",
            9,
            {"speed": -30.0, "param": 300.0, "mode": "ramp"},
            0x1C,
            struct.pack("<fhH", -30.0, 30000, 2),
        ),
        vec(
            "C direct: zero torque",
            "host",
            "torque",
            9,
            {"torque": 0.0, "param": 0.0, "mode": "direct"},
            0x1D,
            struct.pack("<fhH", 0.0, 0, 1),
        ),
    ]
    return out


def presets() -> list[V]:
    out: list[V] = []

    def pre(name: str, node: int, message: str, fields: dict[str, Any], p1: float, p2: float, p3: float) -> V:
        return vec(
            name,
            "host",
            message,
            node,
            fields,
            0x0C,
            fss(p1, p2, p3),
            decodes_as={"message": "preset", "fields": {"p1": p1, "p2": p2, "p3": p3}},
        )

    for node in NODES:
        out.append(
            pre(
                f"T preset node {node}",
                node,
                "preset_t",
                {"position": 45.5, "bandwidth": 50.0, "speed": 0.0},
                45.5,
                0.0,
                50.0,
            )
        )
        out.append(
            pre(
                f"Q preset node {node}: time 327.67 s",
                node,
                "preset_q",
                {"position": -3600.0, "time": 327.67, "accel": 0.01},
                -3600.0,
                327.67,
                0.01,
            )
        )
        out.append(
            pre(
                f"P preset node {node}",
                node,
                "preset_p",
                {"position": 1.5, "speed_ff": -2.5, "torque_ff": 0.75},
                1.5,
                -2.5,
                0.75,
            )
        )
        out.append(
            pre(
                f"V preset node {node}: ramp (mode code 200)",
                node,
                "preset_v",
                {"speed": -60.0, "param": 120.0, "mode": "ramp"},
                -60.0,
                120.0,
                2.0,
            )
        )
        out.append(
            pre(
                f"C preset node {node}: direct (mode code 100)",
                node,
                "preset_c",
                {"torque": -0.5, "param": 0.0, "mode": "direct"},
                -0.5,
                0.0,
                1.0,
            )
        )
        out.append(
            pre(
                f"D preset node {node}",
                node,
                "preset_d",
                {"position": -90.0, "speed": 5.0, "torque_ff": -1.25},
                -90.0,
                5.0,
                -1.25,
            )
        )
    out.append(
        vec(
            "generic preset, s16 extremes",
            "host",
            "preset",
            12,
            {"p1": 1.0, "p2": -327.68, "p3": 327.67},
            0x0C,
            fss(1.0, -327.68, 327.67),
        )
    )
    out.append(
        vec("generic preset, zeros", "host", "preset", 63, {"p1": 0.0, "p2": 0.0, "p3": 0.0}, 0x0C, fss(0.0, 0, 0))
    )
    return out


SYS_OPS = {
    "init_config": 0x00,
    "save_config": 0x01,
    "erase_config": 0x02,
    "reboot": 0x03,
    "clear_errors": 0x04,
    "set_zero_position": 0x05,
    "estop": 0x06,
    "enter_dfu_mode": 0x07,
}


def system() -> list[V]:
    out: list[V] = []
    for op, num in SYS_OPS.items():
        for node in NODES:
            out.append(
                vec(
                    f"system {op} node {node}", "host", "system", node, {"op": op}, 0x08, struct.pack("<IHH", num, 0, 0)
                )
            )
    for kind, num in (("t", 0x10), ("q", 0x11), ("p", 0x12)):
        for rel in (False, True):
            for node in (0, 5):
                out.append(
                    vec(
                        f"start {kind} {'relative' if rel else 'absolute'} node {node}",
                        "host",
                        "start",
                        node,
                        {"kind": kind, "relative": rel},
                        0x08,
                        struct.pack("<IHH", num, int(rel), 0),
                    )
                )
    for kind, num in (("v", 0x13), ("c", 0x14)):
        for node in (0, 5):
            out.append(
                vec(
                    f"start {kind} node {node}",
                    "host",
                    "start",
                    node,
                    {"kind": kind, "relative": False},
                    0x08,
                    struct.pack("<IHH", num, 0, 0),
                )
            )
    for kp, kd in ((0.5, 0.2), (327.67, 0.0), (0.0, 327.67), (10.0, 1.0), (0.01, 0.01)):
        out.append(
            vec(
                f"start impedance kp {kp} kd {kd}",
                "host",
                "start_impedance",
                0,
                {"kp": kp, "kd": kd},
                0x08,
                struct.pack("<Ihh", 0x15, s16(kp), s16(kd)),
            )
        )
    out.append(
        vec(
            "start impedance to node 63",
            "host",
            "start_impedance",
            63,
            {"kp": 1.0, "kd": 0.1},
            0x08,
            struct.pack("<Ihh", 0x15, 100, 10),
        )
    )
    return out


_PACK = {"f32": "<f", "u16": "<H", "s16": "<h", "u32": "<I", "s32": "<i"}
_CODE = {"f32": 0, "u16": 1, "s16": 2, "u32": 3, "s32": 4}


def rw(address: int, dtype: str, value: float | int) -> bytes:
    return struct.pack("<HH", address, _CODE[dtype]) + struct.pack(_PACK[dtype], value).ljust(4, b"\0")


def parameters() -> list[V]:
    out: list[V] = []
    values: dict[str, list[float | int]] = {
        "f32": [0.0, -1.5, f32(3.14159), f32(-3.4028234663852886e38), f32(3.4028234663852886e38), f32(1e-38)],
        "u16": [0, 1, 65535, 0x1234],
        "s16": [0, -1, -32768, 32767],
        "u32": [0, 1, 0xFFFFFFFF, 0x324B550A],
        "s32": [0, -1, -2147483648, 2147483647, -123456],
    }
    addrs = {"f32": 38012, "u16": 10008, "s16": 33108, "u32": 31214, "s32": 31206}
    for dtype, vals in values.items():
        addr = addrs[dtype]
        out.append(
            vec(
                f"read {addr} as {dtype} from node 2",
                "host",
                "read_param",
                2,
                {"address": addr, "dtype": dtype},
                0x1E,
                rw(addr, dtype, 0)[:4] + bytes(4),
            )
        )
        for value in vals:
            out.append(
                vec(
                    f"write {addr} {dtype} = {value!r} to node 2",
                    "host",
                    "write_param",
                    2,
                    {"address": addr, "dtype": dtype, "value": value},
                    0x1F,
                    rw(addr, dtype, value),
                )
            )
            out.append(
                vec(
                    f"reply {addr} {dtype} = {value!r} from node 2",
                    "motor",
                    "param_value",
                    2,
                    {"address": addr, "dtype": dtype, "value": value},
                    0x1E,
                    rw(addr, dtype, value),
                )
            )
    out.append(
        vec(
            "doc example: write u32 0x324B550A",
            "host",
            "write_param",
            1,
            {"address": 21001, "dtype": "u32", "value": 0x324B550A},
            0x1F,
            lit("095203000A554B32"),
            source="protocol doc 1.2 note 5",
        )
    )
    out.append(
        vec(
            "write bool enable_reply_state = 1 as u32",
            "host",
            "write_param",
            1,
            {"address": 31214, "dtype": "u32", "value": 1},
            0x1F,
            rw(31214, "u32", 1),
        )
    )
    out.append(
        vec(
            "write highest address 65535",
            "host",
            "write_param",
            1,
            {"address": 65535, "dtype": "u32", "value": 7},
            0x1F,
            rw(65535, "u32", 7),
        )
    )
    for node in NODES:
        out.append(vec(f"fast read node {node}", "host", "fast_read", node, {}, 0x1E, bytes(8)))
        out.append(
            vec(
                f"read can_node_id from node {node}",
                "host",
                "read_param",
                node,
                {"address": 31001, "dtype": "u32"},
                0x1E,
                rw(31001, "u32", 0),
            )
        )
    return out


def state() -> list[V]:
    out: list[V] = []
    for t in (False, True):
        for e in (False, True):
            for node in NODES:
                cmd = 1 | (2 if t else 0) | (4 if e else 0)
                out.append(
                    vec(
                        f"state node {node} T={int(t)} E={int(e)}",
                        "motor",
                        "state",
                        node,
                        {
                            "position": -92.5,
                            "speed": 12.34,
                            "torque": -0.56,
                            "trajectory_done": t,
                            "error": e,
                            "spare_bits": 0,
                        },
                        cmd,
                        fss(-92.5, 12.34, -0.56),
                    )
                )
    for spare in (1, 2, 3):
        cmd = (spare << 3) | 1 | 2
        out.append(
            vec(
                f"state with spare bits {spare} (bits 3-4 set; still a state frame)",
                "motor",
                "state",
                1,
                {
                    "position": 0.0,
                    "speed": 0.0,
                    "torque": 0.0,
                    "trajectory_done": True,
                    "error": False,
                    "spare_bits": spare,
                },
                cmd,
                fss(0, 0, 0),
            )
        )
    out.append(
        vec(
            "state s16 extremes",
            "motor",
            "state",
            63,
            {
                "position": f32(720000.0),
                "speed": -327.68,
                "torque": 327.67,
                "trajectory_done": False,
                "error": True,
                "spare_bits": 3,
            },
            0x1D,
            fss(720000.0, -327.68, 327.67),
        )
    )
    return out


def invalid() -> list[V]:
    enc: list[V] = []

    def bad(name: str, message: str, node: int, fields: dict[str, Any], field: str) -> None:
        enc.append(
            {
                "name": name,
                "direction": "host",
                "message": message,
                "node": node,
                "fields": fields,
                "error": "range",
                "field": field,
            }
        )

    bad("Q speed above 327.67", "position_q", 1, {"position": 0.0, "speed": 327.68, "accel": 1.0}, "speed")
    bad("Q accel below -327.68", "position_q", 1, {"position": 0.0, "speed": 1.0, "accel": -327.69}, "accel")
    bad("P torque ff 400", "position_p", 1, {"position": 0.0, "speed_ff": 0.0, "torque_ff": 400.0}, "torque_ff")
    bad("T bandwidth 1000", "position_t", 1, {"position": 0.0, "bandwidth": 1000.0, "speed": 0.0}, "bandwidth")
    bad("node 64", "position_t", 64, {"position": 0.0, "bandwidth": 1.0, "speed": 0.0}, "node")
    bad("node -1", "fast_read", -1, {}, "node")
    bad("Q preset time 400 s", "preset_q", 1, {"position": 0.0, "time": 400.0, "accel": 1.0}, "time")
    bad("impedance kp 1000", "start_impedance", 0, {"kp": 1000.0, "kd": 0.0}, "kp")
    bad("impedance kd -500", "start_impedance", 0, {"kp": 1.0, "kd": -500.0}, "kd")
    bad("V param 327.68", "velocity", 1, {"speed": 1.0, "param": 327.68, "mode": "ramp"}, "param")
    bad("u16 write 65536", "write_param", 1, {"address": 10008, "dtype": "u16", "value": 65536}, "value")
    bad("s16 write -32769", "write_param", 1, {"address": 33108, "dtype": "s16", "value": -32769}, "value")
    bad("u32 write -1", "write_param", 1, {"address": 31214, "dtype": "u32", "value": -1}, "value")
    bad("s32 write 2^31", "write_param", 1, {"address": 31206, "dtype": "s32", "value": 2147483648}, "value")
    bad("f32 write 1e39", "write_param", 1, {"address": 38012, "dtype": "f32", "value": 1e39}, "value")
    bad("read address 0 is the fast read", "read_param", 1, {"address": 0, "dtype": "f32"}, "address")
    bad("write address 65536", "write_param", 1, {"address": 65536, "dtype": "u32", "value": 0}, "address")

    dec: list[V] = []

    def baddec(name: str, direction: str, arb: int, data: str) -> None:
        dec.append({"name": name, "direction": direction, "id": arb, "data": data, "error": "protocol"})

    baddec("7 data bytes", "host", 0x039, "0000B4420000E8")
    baddec("9 data bytes", "host", 0x039, "0000B4420000E80300")
    baddec("empty frame", "motor", 0x021, "")
    baddec("unknown host command 0x00", "host", 0x020, "0000000000000000")
    baddec("unknown host command 0x10", "host", 0x030, "0000000000000000")
    baddec("unknown system sub-command 0x09", "host", 0x028, "0900000000000000")
    baddec("unknown system sub-command 0x16", "host", 0x028, "1600000000000000")
    baddec("start relative flag 2", "host", 0x008, "1100000002000000")
    baddec("velocity mode 3", "host", 0x03C, "0000A04100000300")
    baddec("torque mode 2", "host", 0x03D, "0000003F00000200")
    baddec("read with data type 5", "host", 0x03E, "0100050000000000")
    baddec("write with data type 9", "host", 0x03F, "1979090005000000")
    baddec("write to address 0", "host", 0x03F, "0000030005000000")
    baddec("fast read with data type 3", "host", 0x03E, "0000030000000000")
    baddec("reply with data type 7", "motor", 0x03E, "7794070038F0B8C2")
    baddec("reply with even command 0x1C", "motor", 0x03C, "0000000000000000")
    baddec("reply with command 0x08", "motor", 0x028, "0000000000000000")
    baddec("id above 11 bits", "host", 0x800, "0000000000000000")
    return enc + dec


def serial() -> list[V]:
    """Frames in both serial framings: the 11-byte UART frame and the adapter's 16-byte 0xAA frame."""
    out: list[V] = []
    cases = [
        ("T example, node 1", 0x039, lit("0000B4420000E803"), "protocol doc 2.1"),
        ("Q example, node 1", 0x03A, lit("000016C3E803F401"), "protocol doc 2.1"),
        ("V feed-forward example, node 1", 0x03C, lit("0000A04196000100"), "protocol doc 2.2"),
        ("V ramp example, node 1", 0x03C, lit("0000A041F4010200"), "protocol doc 2.2"),
        ("set_id example, node 1", 0x03F, lit("1979030005000000"), "protocol doc 2.3"),
        ("estop example, node 3", 0x068, lit("0600000000000000"), "protocol doc 1.1"),
        ("read reply example, node 4", 0x09E, lit("7794000038F0B8C2"), "protocol doc 1.2"),
        ("highest id", 0x7FF, bytes(range(0xF8, 0x100)), ""),
        ("id 0", 0x000, bytes(8), ""),
    ]
    for name, arb, data, source in cases:
        v: V = {"name": name}
        if source:
            v["source"] = source
        v.update(
            id=arb,
            data=hexs(data),
            uart11=(bytes((0x08, arb >> 8, arb & 0xFF)) + data).hex().upper(),
            aa=(bytes((0xAA, 0, 0, 8)) + arb.to_bytes(4, "big") + data).hex().upper(),
        )
        out.append(v)
    return out


FILES = {
    "doc_examples.json": (
        "Worked examples of the vendor's CAN protocol document and PROTOCOL.md 1.7, bytes as printed.",
        doc_examples,
    ),
    "motion.json": ("T, Q, P, V and C commands: signs, s16 extremes, rounding, broadcast and node 63.", motion),
    "presets.json": ("Every preset kind and the generic preset form.", presets),
    "system.json": ("Every system sub-command, start commands with absolute/relative flag, impedance Kp/Kd.", system),
    "parameters.json": ("Parameter reads, writes and read replies in all five data types; fast read.", parameters),
    "state.json": ("State replies with every T/E flag combination and spare bits 3-4.", state),
    "invalid.json": ("Inputs that must be refused: out-of-range fields and malformed frames.", invalid),
    "serial/framings.json": (
        "CAN frames in the motor UART's 11-byte framing and the USB-CAN adapter's 0xAA framing "
        "(fields: id, data, uart11, aa; hex).",
        serial,
    ),
}


def render(description: str, vectors: list[V]) -> str:
    lines = [json.dumps(v, ensure_ascii=False) for v in vectors]
    body = ",\n    ".join(lines)
    return f'{{\n  "description": {json.dumps(description)},\n  "vectors": [\n    {body}\n  ]\n}}\n'


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true", help="exit 1 if a file is stale")
    args = ap.parse_args(argv)
    stale = []
    for name, (desc, make) in FILES.items():
        text = render(desc, make())
        path = OUT / name
        if path.exists() and path.read_text(encoding="utf-8") == text:
            continue
        if args.check:
            stale.append(name)
        else:
            path.write_text(text, encoding="utf-8")
            print(f"wrote spec/vectors/{name}")
    if stale:
        print("stale vectors (run python3 tools/gen_vectors.py): " + ", ".join(stale), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
