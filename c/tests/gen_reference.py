#!/usr/bin/env python3
"""Reference outputs of the Python core, as a C table for the differential tests.

Usage: gen_reference.py OUT.c PYTHON_SRC_DIR

* Serial streams (random frames, garbage, cut frames; fixed seeds) and what
  the Python stream decoders make of them: frames, dropped bytes, pending bytes.
* Error words: flag names the Python core gives for chosen values.
* The parameter registry: name, address, type and flags of every parameter,
  and the range of values of those with a fixed set (modes and states).
* Writes the Python client accepts or refuses: values at and beyond each
  writable parameter's domain (``spec/parameters.csv``), with and without force.
"""

from __future__ import annotations

import random
import sys
from pathlib import Path

sys.path.insert(0, sys.argv[2])

from drempower.errors import ValidationError
from drempower.protocol.flags import ERROR_WORDS, decode_error_word
from drempower.protocol.framing import FD_LENGTHS, AADecoder, Uart11Decoder, encode_aa, encode_uart11
from drempower.protocol.ids import Frame
from drempower.protocol.parameters import DataType, Parameter, parameters


def c_bytes(data: bytes) -> str:
    return "{" + ", ".join(f"0x{b:02X}" for b in data) + "}" if data else "{0}"


def noise(rng: random.Random, n: int) -> bytes:
    """Garbage biased towards header bytes and small values, so false starts are common."""
    pool = [0x08, 0xAA, 0x00, 0x01, 0x02, 0x06, 0x07, 0x08, 0x1F]
    return bytes(rng.choice(pool) if rng.random() < 0.6 else rng.randrange(256) for _ in range(n))


def uart11_stream(rng: random.Random) -> bytes:
    out = bytearray()
    for _ in range(rng.randrange(1, 12)):
        frame = encode_uart11(rng.randrange(0x800), bytes(rng.randrange(256) for _ in range(8)))
        r = rng.random()
        if r < 0.6:
            out += frame
        elif r < 0.8:
            out += frame[: rng.randrange(1, 11)]
        else:
            out += noise(rng, rng.randrange(1, 6))
    return bytes(out)


def aa_stream(rng: random.Random) -> bytes:
    out = bytearray()
    for _ in range(rng.randrange(1, 10)):
        ext = rng.random() < 0.25
        kind = rng.choice(("data", "data", "remote", "fd"))
        arb = rng.randrange(0x20000000 if ext else 0x800)
        if kind == "fd":
            n = rng.choice(sorted(FD_LENGTHS))
            frame = bytes((0xAA, int(ext), rng.choice((2, 6)), n)) + arb.to_bytes(4, "big")
            frame += bytes(rng.randrange(256) for _ in range(n))
        else:
            data = bytes(rng.randrange(256) for _ in range(rng.randrange(9)))
            frame = encode_aa(Frame(arb, data, ext, kind == "remote"))
        r = rng.random()
        if r < 0.6:
            out += frame
        elif r < 0.8:
            out += frame[: rng.randrange(1, len(frame))]
        else:
            out += noise(rng, rng.randrange(1, 10))
    return bytes(out)


def run(decoder: Uart11Decoder | AADecoder, stream: bytes, rng: random.Random) -> list[Frame]:
    """Feed byte by byte, as the C side does. (Fed larger chunks, the Python decoders also
    use the bytes that follow a frame in the same chunk to reject a frame that lost bytes.)"""
    frames: list[Frame] = []
    for i in range(len(stream)):
        frames += decoder.feed(stream[i : i + 1])
    return frames


def streams(rows: list[str], defs: list[str]) -> None:
    for index in range(120):
        rng = random.Random(index)
        aa = index % 2 == 1
        stream = aa_stream(rng) if aa else uart11_stream(rng)
        dec: Uart11Decoder | AADecoder = AADecoder() if aa else Uart11Decoder()
        frames = run(dec, stream, rng)
        frame_rows = [
            f"{{{f.arbitration_id}u, {int(f.is_extended)}, {int(f.is_remote)}, {len(f.data)}, {c_bytes(f.data)}}}"
            for f in frames
        ]
        defs.append(f"static const uint8_t stream{index}[] = {c_bytes(stream)};")
        defs.append(f"static const ref_frame frames{index}[] = {{{', '.join(frame_rows) or '{0}'}}};")
        fd = dec.fd_frames if isinstance(dec, AADecoder) else 0
        rows.append(
            f"    {{{int(aa)}, stream{index}, {len(stream)}, frames{index}, {len(frames)}, "
            f"{dec.dropped}u, {dec.pending}, {fd}u}},"
        )


def probes(p: Parameter) -> list[float]:
    """Values at, inside and just beyond the domain, and a few that fit every type."""
    values: set[float] = {0, 1, -1, 2, 64, 1000, 1e6}
    for v in (p.minimum, p.maximum, *p.allowed):
        if v is not None:
            values |= {v, v - 1, v + 1, v - 0.5, v + 0.5}
    if p.dtype is DataType.F32:
        values |= {-1e30, 1e30}
        return sorted(values)
    return sorted(int(v) for v in values if v == int(v) and (p.dtype is not DataType.U32 or v >= 0))


def write_rows() -> list[str]:
    rows = []
    for p in parameters():
        if not p.writable:
            continue
        for v in probes(p):
            for force in (0, 1):
                try:
                    p.check(v, bool(force))
                    ok = 1
                except ValidationError:
                    ok = 0
                f, i = (f"{float(v)!r}f", "0") if p.dtype is DataType.F32 else ("0.0f", f"INT64_C({int(v)})")
                rows.append(f"    {{{p.address}u, {int(p.dtype)}u, {f}, {i}, {force}, {ok}}},")
    return rows


def main() -> int:
    out = Path(sys.argv[1])
    stream_rows: list[str] = []
    defs: list[str] = []
    streams(stream_rows, defs)

    rng = random.Random(7)
    error_rows = []
    for word in ERROR_WORDS:
        values = [0, 0xFFFFFFFF] + [1 << b for b in range(32)] + [rng.randrange(1 << 32) for _ in range(8)]
        for v in values:
            text = "|".join(decode_error_word(word.address, v))
            error_rows.append(f'    {{{word.address}u, 0x{v:08X}u, "{text}"}},')

    param_rows = []
    for p in parameters():
        flags = ["0u"]
        if p.writable:
            flags.append("DRE_PF_RW")
        if p.user_settable:
            flags.append("DRE_PF_USER")
        if p.is_bool:
            flags.append("DRE_PF_BOOL")
        if p.series:
            flags.append(f"DRE_PF_SERIES_{p.series}")
        choices = sorted(int(c) for c in p.choices) if p.choices is not None else []
        if choices and choices != list(range(choices[0], choices[-1] + 1)):
            raise SystemExit(f"{p.name}: the values {choices} are no range; the C table holds ranges")
        lo, hi = (choices[0], choices[-1]) if choices else (0, 0)
        param_rows.append(
            f'    {{"{p.name}", "{p.unit}", {p.address}u, {int(p.dtype)}, {" | ".join(flags)}, '
            f"{int(bool(choices))}, {lo}u, {hi}u}},"
        )

    text = "\n".join(
        [
            "/* Generated by gen_reference.py from the Python core. */",
            "#include <stddef.h>",
            '#include "reference.h"',
            "",
            *defs,
            "",
            "const ref_stream ref_streams[] = {",
            *stream_rows,
            "};",
            "const unsigned ref_stream_count = sizeof ref_streams / sizeof ref_streams[0];",
            "",
            "const ref_error ref_errors[] = {",
            *error_rows,
            "};",
            "const unsigned ref_error_count = sizeof ref_errors / sizeof ref_errors[0];",
            "",
            "const ref_param ref_params[] = {",
            *param_rows,
            "};",
            "const unsigned ref_param_count = sizeof ref_params / sizeof ref_params[0];",
            "",
            "const ref_write ref_writes[] = {",
            *write_rows(),
            "};",
            "const unsigned ref_write_count = sizeof ref_writes / sizeof ref_writes[0];",
            "",
        ]
    )
    out.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
