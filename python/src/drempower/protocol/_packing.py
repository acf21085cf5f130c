"""Packing the fields of a frame: the struct layouts, the range checks of scaled fields with their error
words, and the frame builders the messages share (no I/O)."""

from __future__ import annotations

import struct
from typing import NoReturn

from ..errors import FieldRangeError, ValidationError
from .ids import MAX_NODE, Frame
from .limits import MOTOR_RANGE_TEXT, S16_MAX, S16_MIN
from .parameters import F32_MAX, DataType, encode_value

_FSS = struct.Struct("<fhh")
_FSU = struct.Struct("<fhH")
_SYS = struct.Struct("<IHH")
_SYS_KPKD = struct.Struct("<Ihh")
_RW = struct.Struct("<HH")
_PAD4 = b"\0\0\0\0"
_ZERO8 = bytes(8)
_S16_DETAIL = "s16 field scaled by 0.01"


_new_frame = tuple.__new__
_FSS_pack = _FSS.pack
_FSS_unpack = _FSS.unpack
_RW_unpack_from = _RW.unpack_from
_READ_pack = struct.Struct("<HH4x").pack
_SYS_pack = _SYS.pack
_FSU_pack = _FSU.pack
_PACK_ERRORS = (TypeError, ValueError, OverflowError, struct.error)


def _frame(arb: int, data: bytes) -> Frame:
    return _new_frame(Frame, (arb, data, False, False))


_FAST_READS = tuple(_frame((node << 5) | 0x1E, _ZERO8) for node in range(MAX_NODE + 1))
"""The fast-read frame of every node (frames are immutable, so one of each serves every encode)."""


def _node(node: int) -> int:
    if node.__class__ is int and 0 <= node <= MAX_NODE:
        return node
    raise FieldRangeError("node", node, 0, MAX_NODE, MOTOR_RANGE_TEXT)


def _s16(value: float, field: str) -> int:
    """value -> raw s16 (value x 100, rounded to nearest); raise when it does not fit."""
    try:
        raw = round(value * 100)
    except (TypeError, ValueError, OverflowError):
        raw = None
    if raw is not None and -32768 <= raw <= 32767:
        return raw
    raise FieldRangeError(field, value, S16_MIN, S16_MAX, _S16_DETAIL)


def _f32(value: float, field: str) -> float:
    try:
        if -F32_MAX <= value <= F32_MAX:
            return value
    except TypeError:
        pass
    raise FieldRangeError(field, value, -F32_MAX, F32_MAX, "finite float32; NaN and infinity cannot be sent")


def check_s16(value: float, field: str) -> float:
    """``value`` if an s16 field scaled by 0.01 holds it once rounded; else a FieldRangeError for ``field``."""
    _s16(value, field)
    return float(value)


def check_f32(value: float, field: str) -> float:
    """``value`` if a float32 field holds it (finite, in range); else a FieldRangeError for ``field``."""
    return float(_f32(value, field))


def _diagnose(node: int, *checks: tuple[str, float, str]) -> NoReturn:
    """Raise the precise error for a message whose fast encode path failed."""
    _node(node)
    for kind, value, field in checks:
        if kind == "f":
            _f32(value, field)
        else:
            _s16(value, field)
    raise ValidationError(f"cannot encode fields {[c[2] for c in checks]}")  # pragma: no cover


def _fss(node: int, cmd: int, a: float, fa: str, b: float, fb: str, c: float, fc: str) -> Frame:
    """Frame with data ``f32 a, s16 b x100, s16 c x100``; the fast path validates through struct."""
    try:
        if node.__class__ is int and 0 <= node <= MAX_NODE and -F32_MAX <= a <= F32_MAX:
            return _new_frame(Frame, ((node << 5) | cmd, _FSS_pack(a, round(b * 100), round(c * 100)), False, False))
    except _PACK_ERRORS:
        pass
    _diagnose(node, ("f", a, fa), ("s", b, fb), ("s", c, fc))


def _fsu(node: int, cmd: int, a: float, fa: str, b: float, fb: str, mode: int) -> Frame:
    """Frame with data ``f32 a, s16 b x100, u16 mode`` (V and C commands)."""
    try:
        if node.__class__ is int and 0 <= node <= MAX_NODE and -F32_MAX <= a <= F32_MAX:
            return _new_frame(Frame, ((node << 5) | cmd, _FSU_pack(a, round(b * 100), mode), False, False))
    except _PACK_ERRORS:
        pass
    _diagnose(node, ("f", a, fa), ("s", b, fb))


_RW_PACK = (
    struct.Struct("<HHf").pack,
    struct.Struct("<HHH2x").pack,
    struct.Struct("<HHh2x").pack,
    struct.Struct("<HHI").pack,
    struct.Struct("<HHi").pack,
)


def _rw(node: int, cmd: int, address: int, dtype: int, value: int | float) -> Frame:
    """Frame with data ``u16 address, u16 dtype, value`` (writes and read replies)."""
    try:
        if node.__class__ is int and 0 <= node <= MAX_NODE and address.__class__ is int and 1 <= address <= 0xFFFF:
            if dtype == 0:
                if -F32_MAX <= value <= F32_MAX:
                    return _new_frame(Frame, ((node << 5) | cmd, _RW_PACK[0](address, 0, value), False, False))
            elif value.__class__ is int and 0 < dtype <= 4:
                return _new_frame(Frame, ((node << 5) | cmd, _RW_PACK[dtype](address, dtype, value), False, False))
    except _PACK_ERRORS:
        pass
    # slow path: precise errors, and values such as 2.0 or True for integer types
    dt = _dtype(dtype)
    return _frame((_node(node) << 5) | cmd, _RW.pack(_address(address), dt) + encode_value(dt, value, "value"))


def _address(address: int) -> int:
    if address.__class__ is int and 1 <= address <= 0xFFFF:
        return address
    raise FieldRangeError("address", address, 1, 0xFFFF, "u16; address 0 is the fast read")


def _dtype(dtype: int) -> DataType:
    if dtype.__class__ is DataType:
        return dtype
    try:
        return DataType(dtype)
    except ValueError:
        raise FieldRangeError("dtype", dtype, 0, 4, "0 f32, 1 u16, 2 s16, 3 u32, 4 s32") from None
