#!/usr/bin/env python3
"""Turn the golden vectors (spec/vectors/*.json) into a C table for test_vectors.c.

Usage: gen_vector_table.py OUT.c FILE.json...

Floats are written as hexadecimal literals of their binary32 value (what a C
caller passing the JSON number as a float would hold); a magnitude beyond the
binary32 range is written as an infinity, which the encoder must refuse. A
node id outside 0..255 cannot be held by the C type and is written as 255,
which must be refused as well. Only the standard library is used.
"""

from __future__ import annotations

import json
import math
import struct
import sys
from pathlib import Path

F32_MAX = 3.4028234663852886e38

# message name -> (C type, union member, field names)
MESSAGES = {
    "position_t": ("DRE_MSG_POSITION_T", "position_t", ("position", "bandwidth", "speed")),
    "position_q": ("DRE_MSG_POSITION_Q", "position_q", ("position", "speed", "accel")),
    "position_p": ("DRE_MSG_POSITION_P", "position_p", ("position", "speed_ff", "torque_ff")),
    "velocity": ("DRE_MSG_VELOCITY", "velocity", ("speed", "param", "mode")),
    "torque": ("DRE_MSG_TORQUE", "torque", ("torque", "param", "mode")),
    "preset": ("DRE_MSG_PRESET", "preset", ("p1", "p2", "p3")),
    "preset_t": ("DRE_MSG_PRESET_T", "position_t", ("position", "bandwidth", "speed")),
    "preset_q": ("DRE_MSG_PRESET_Q", "preset_q", ("position", "time", "accel")),
    "preset_p": ("DRE_MSG_PRESET_P", "position_p", ("position", "speed_ff", "torque_ff")),
    "preset_v": ("DRE_MSG_PRESET_V", "velocity", ("speed", "param", "mode")),
    "preset_c": ("DRE_MSG_PRESET_C", "torque", ("torque", "param", "mode")),
    "preset_d": ("DRE_MSG_PRESET_D", "preset_d", ("position", "speed", "torque_ff")),
    "system": ("DRE_MSG_SYSTEM", "system", ("op",)),
    "start": ("DRE_MSG_START", "start", ("kind", "relative")),
    "start_impedance": ("DRE_MSG_START_IMPEDANCE", "start_impedance", ("kp", "kd")),
    "read_param": ("DRE_MSG_READ_PARAM", "param", ("address", "dtype")),
    "fast_read": ("DRE_MSG_FAST_READ", None, ()),
    "write_param": ("DRE_MSG_WRITE_PARAM", "param", ("address", "dtype", "value")),
    "param_value": ("DRE_MSG_PARAM_VALUE", "param", ("address", "dtype", "value")),
    "state": ("DRE_MSG_STATE", "state", ("position", "speed", "torque", "trajectory_done", "error", "spare_bits")),
}

ENUMS = {
    ("velocity", "mode"): {"passthrough": "DRE_VEL_PASSTHROUGH", "ramp": "DRE_VEL_RAMP"},
    ("torque", "mode"): {"direct": "DRE_TORQUE_DIRECT", "ramp": "DRE_TORQUE_RAMP"},
    ("system", "op"): {
        name: f"DRE_SYS_{name.upper()}"
        for name in (
            "init_config",
            "save_config",
            "erase_config",
            "reboot",
            "clear_errors",
            "set_zero_position",
            "estop",
            "enter_dfu_mode",
        )
    },
    ("start", "kind"): {k: f"DRE_START_{k.upper()}" for k in "tqpvc"},
    ("param", "dtype"): {k: f"DRE_{k.upper()}" for k in ("f32", "u16", "s16", "u32", "s32")},
}


NO_MSG = "{DRE_MSG_NONE, 0, {.preset = {0.0f, 0.0f, 0.0f}}}"


def c_float(x: float) -> str:
    if math.isnan(x):
        return "NAN"
    if abs(x) > F32_MAX:
        return "-INFINITY" if x < 0 else "INFINITY"
    f = struct.unpack("<f", struct.pack("<f", x))[0]
    if f == 0.0:
        return "-0.0f" if math.copysign(1.0, f) < 0 else "0.0f"
    return f.hex() + "f"


def c_string(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def c_msg(message: str, node: int, fields: dict) -> str:
    ctype, member, names = MESSAGES[message]
    node_c = str(node) if 0 <= node <= 255 else "255"
    if member is None:
        return f"{{{ctype}, {node_c}, {{.preset = {{0.0f, 0.0f, 0.0f}}}}}}"
    parts = []
    for name in names:
        value = fields[name]
        enum = ENUMS.get((member, name))
        if enum is not None:
            parts.append(f".{name} = {enum[value]}")
        elif name == "value":
            is_float = fields["dtype"] == "f32"
            parts.append(f".value = {{.f32 = {c_float(value)}}}" if is_float else f".value = {{.i = INT64_C({value})}}")
        elif name == "address":
            if not 0 <= value <= 0xFFFFFFFF:
                raise SystemExit(f"address {value} does not fit the C field")
            parts.append(f".address = {value}u")
        elif isinstance(value, bool) or name == "spare_bits":
            parts.append(f".{name} = {int(value)}")
        else:
            parts.append(f".{name} = {c_float(value)}")
    return f"{{{ctype}, {node_c}, {{.{member} = {{{', '.join(parts)}}}}}}}"


def main(argv: list[str]) -> int:
    out_path, files = Path(argv[1]), [Path(p) for p in argv[2:]]
    rows = []
    for path in sorted(files):
        doc = json.loads(path.read_text(encoding="utf-8"))
        for v in doc["vectors"]:
            host = "1" if v["direction"] == "host" else "0"
            head = f"{c_string(path.name)}, {c_string(v['name'])}, {host}"
            if v.get("error") == "range":
                msg = c_msg(v["message"], v["node"], v["fields"])
                rows.append(f"    {{{head}, VEC_RANGE, {msg}, {msg}, 0, 0, {{0}}, {c_string(v['field'])}}},")
                continue
            data = bytes.fromhex(v["data"])
            arb = min(v["id"], 0xFFFF)
            data_c = "{" + ", ".join(f"0x{b:02X}" for b in data[:8]) + "}" if data else "{0}"
            if v.get("error") == "protocol":
                rows.append(f"    {{{head}, VEC_PROTOCOL, {NO_MSG}, {NO_MSG}, {arb}, {len(data)}, {data_c}, NULL}},")
                continue
            msg = c_msg(v["message"], v["node"], v["fields"])
            dec = v.get("decodes_as", {"message": v["message"], "fields": v["fields"]})
            expect = c_msg(dec["message"], v["node"], dec["fields"])
            rows.append(f"    {{{head}, VEC_VALID, {msg}, {expect}, {arb}, {len(data)}, {data_c}, NULL}},")
    text = "\n".join(
        [
            "/* Generated by gen_vector_table.py from the golden vectors. */",
            "#include <math.h>",
            "#include <stddef.h>",
            '#include "vectors.h"',
            "",
            "const vec_case vec_cases[] = {",
            *rows,
            "};",
            "const unsigned vec_count = sizeof vec_cases / sizeof vec_cases[0];",
            "",
        ]
    )
    out_path.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
