"""Parameter registry and typed parameter values.

The table itself lives in ``spec/parameters.csv`` and is generated into
``_parameter_table.py`` by ``tools/generate.py``. Look a parameter up with
:func:`parameter` by name (``"axis0.output_shaft.pos_estimate"``) or address
(``38007``). Bools travel as u32 (0/1).
"""

from __future__ import annotations

import math
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from enum import Enum, IntEnum

from ..errors import DomainError, FieldRangeError, ProtocolError, ValidationError
from .addresses import (
    AXIS0_CONTROLLER_CONFIG_CONTROL_MODE,
    AXIS0_CONTROLLER_CONFIG_INPUT_MODE,
    AXIS0_REQUESTED_STATE,
    AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE,
)
from .enums import AxisState, ControlMode, InputMode, TrajMode

__all__ = [
    "DataType",
    "Access",
    "Parameter",
    "parameter",
    "parameters",
    "find_parameter",
    "encode_value",
    "decode_value",
    "F32_MAX",
    "DomainError",
]

F32_MAX = 3.4028234663852886e38


class DataType(IntEnum):
    """The ``data_type`` code of read/write frames."""

    F32 = 0
    U16 = 1
    S16 = 2
    U32 = 3
    S32 = 4

    @property
    def size(self) -> int:
        """Bytes the value occupies in the frame (at offset 4)."""
        return 2 if self in (DataType.U16, DataType.S16) else 4


class Access(str, Enum):
    """Whether a parameter may be written."""

    RO = "ro"
    RW = "rw"


@dataclass(frozen=True, slots=True)
class Parameter:
    """One entry of the parameter table.

    The domain (from ``spec/parameters.csv``): ``minimum``/``maximum`` bound the
    value (inclusive; None: the type's range), ``allowed`` lists the only values
    it takes (empty: any). A ``hard`` domain is never left; a soft one may be
    left with ``force=True`` (an expert's choice). ``inferred`` marks a domain
    the vendor does not document. The wire range of the type always applies.
    """

    name: str
    address: int
    dtype: DataType
    access: Access
    user_settable: bool
    unit: str
    series: str
    is_bool: bool
    description: str
    minimum: float | None = None
    maximum: float | None = None
    allowed: tuple[float, ...] = ()
    hard: bool = False
    inferred: bool = False

    @property
    def writable(self) -> bool:
        return self.access is Access.RW

    @property
    def choices(self) -> type[IntEnum] | None:
        """The enum of the values this parameter takes, for the modes and states with a fixed set."""
        return _CHOICES.get(self.address)

    @property
    def has_domain(self) -> bool:
        """Whether the parameter takes less than every value of its type."""
        return self.minimum is not None or self.maximum is not None or bool(self.allowed)

    def domain_text(self) -> str:
        """The domain in words, e.g. ``1..63 (hard)`` or ``>= 0 (soft, inferred)``."""
        if not self.has_domain:
            return f"any {self.dtype.name.lower()} value"
        if self.allowed:
            text = "one of " + ", ".join(f"{v:g}" for v in self.allowed)
        elif self.minimum is not None and self.maximum is not None:
            text = f"{self.minimum:g}..{self.maximum:g}"
        elif self.minimum is not None:
            text = f">= {self.minimum:g}"
        else:
            text = f"<= {self.maximum:g}"
        kind = "hard" if self.hard else "soft"
        return f"{text} ({kind}{', inferred' if self.inferred else ''})"

    def in_domain(self, value: float) -> bool:
        """Whether ``value`` lies in the domain (NaN lies in none)."""
        if self.allowed:
            return value in self.allowed
        if self.minimum is not None and not value >= self.minimum:
            return False
        return self.maximum is None or value <= self.maximum

    def check(self, value: object, force: bool = False) -> int | float:
        """``value`` as this parameter sends it, or :class:`ValidationError` naming parameter, value and domain.

        Checks, in order: a number (bools are 0/1), the wire range of the type,
        the fixed set of a mode or state, and the domain; ``force`` lets a value
        outside a soft domain through (never outside a hard one or the wire range).
        """
        if isinstance(value, bool):
            value = int(value)
        if not isinstance(value, (int, float)):
            raise ValidationError(f"{self.name}={value!r}: expected a number")
        if self.is_bool and value not in (0, 1):
            raise DomainError(self, value)
        encode_value(self.dtype, value, field=self.name)
        choices = _CHOICES.get(self.address)
        if choices is not None and value not in set(choices):
            low, high = min(choices), max(choices)
            names = ", ".join(f"{int(c)} {c.name}" for c in choices)
            raise FieldRangeError(self.name, value, low, high, f"{choices.__name__}: {names}")
        if self.has_domain and not (force and not self.hard):
            sent = _F32.unpack(_F32.pack(value))[0] if self.dtype is DataType.F32 else value
            if not self.in_domain(sent):  # the value as the frame carries it (as the C check sees it)
                raise DomainError(self, value)
        return float(value) if self.dtype is DataType.F32 else int(value)

    def encode(self, value: int | float | bool, force: bool = False) -> bytes:
        """Encode ``value`` in this parameter's type (4 bytes, little-endian, zero padded), after :meth:`check`."""
        return encode_value(self.dtype, self.check(value, force), field=self.name)


_CHOICES: dict[int, type[IntEnum]] = {
    AXIS0_REQUESTED_STATE: AxisState,
    AXIS0_CONTROLLER_CONFIG_CONTROL_MODE: ControlMode,
    AXIS0_CONTROLLER_CONFIG_INPUT_MODE: InputMode,
    AXIS0_TRAP_TRAJ_CONFIG_TRAJ_MODE: TrajMode,
}
"""Parameters whose values form a fixed set (PROTOCOL.md section 5)."""


_INT_RANGES: dict[DataType, tuple[int, int, str]] = {
    DataType.U16: (0, 0xFFFF, "<H"),
    DataType.S16: (-0x8000, 0x7FFF, "<h"),
    DataType.U32: (0, 0xFFFFFFFF, "<I"),
    DataType.S32: (-0x80000000, 0x7FFFFFFF, "<i"),
}
_F32 = struct.Struct("<f")
_INT_STRUCTS = {dt: struct.Struct(fmt) for dt, (_, _, fmt) in _INT_RANGES.items()}


def encode_value(dtype: DataType, value: int | float | bool, field: str = "value") -> bytes:
    """Encode a parameter value of type ``dtype`` into the 4 value bytes of a frame.

    Integers must be whole and in range; floats must be finite and fit binary32.
    Nothing is clipped or wrapped: out-of-range input raises :class:`FieldRangeError`.
    """
    if isinstance(value, bool):
        value = int(value)
    if not isinstance(value, (int, float)):
        raise ValidationError(f"{field}={value!r}: expected a number")
    if dtype is DataType.F32:
        v = float(value)
        if not math.isfinite(v):
            raise ValidationError(f"{field}={value!r}: NaN and infinity cannot be sent")
        if abs(v) > F32_MAX:
            raise FieldRangeError(field, value, -F32_MAX, F32_MAX, "float32")
        return _F32.pack(v)
    try:
        lo, hi, _ = _INT_RANGES[dtype]
    except KeyError:
        raise ValidationError(f"{field}: unknown data type {dtype!r}") from None
    if isinstance(value, float):
        if not math.isfinite(value) or value != int(value):
            raise ValidationError(f"{field}={value!r}: {dtype.name.lower()} needs a whole number")
        value = int(value)
    if not lo <= value <= hi:
        raise FieldRangeError(field, value, lo, hi, dtype.name.lower())
    return _INT_STRUCTS[dtype].pack(value).ljust(4, b"\0")


def decode_value(dtype: int, raw: bytes) -> int | float:
    """Decode the value bytes (offset 4 of a frame) as ``dtype``."""
    try:
        unpack = _UNPACKERS[dtype]
    except (IndexError, TypeError):
        raise ProtocolError(f"unknown data type code {dtype}") from None
    return unpack(raw)[0]  # type: ignore[no-any-return]


_UNPACKERS = (
    _F32.unpack_from,
    _INT_STRUCTS[DataType.U16].unpack_from,
    _INT_STRUCTS[DataType.S16].unpack_from,
    _INT_STRUCTS[DataType.U32].unpack_from,
    _INT_STRUCTS[DataType.S32].unpack_from,
)


class _Registry:
    __slots__ = ("_all", "by_address", "by_name")

    def __init__(self, table: tuple[Parameter, ...]) -> None:
        self._all = table
        self.by_name = {p.name: p for p in table}
        self.by_address = {p.address: p for p in table}


_registry: _Registry | None = None


def _reg() -> _Registry:
    global _registry
    if _registry is None:
        from ._parameter_table import PARAMETER_TABLE

        _registry = _Registry(PARAMETER_TABLE)
    return _registry


def parameters() -> Iterator[Parameter]:
    """Every parameter, by address."""
    return iter(_reg()._all)


def _normalise(name: str) -> str:
    name = name.strip()
    # The vendor library accepts axis1.x etc. and rewrites to axis0 (single-axis motors).
    axis, dot, rest = name.partition(".")
    if axis.startswith("axis") and dot and axis[4:].isascii() and axis[4:].isdigit():
        name = "axis0." + rest
    return name


def find_parameter(key: str | int) -> Parameter | None:
    """Look a parameter up by name or address; None when unknown."""
    reg = _reg()
    if isinstance(key, int) and not isinstance(key, bool):
        return reg.by_address.get(key)
    if isinstance(key, str):
        k = key.strip()
        if k.isascii() and k.isdigit():
            return reg.by_address.get(int(k))
        return reg.by_name.get(_normalise(k))
    return None


def parameter(key: str | int | Parameter) -> Parameter:
    """Look a parameter up by name or address; raise :class:`ValidationError` when unknown."""
    if isinstance(key, Parameter):
        return key
    p = find_parameter(key)
    if p is None:
        hint = ""
        if isinstance(key, str):
            import difflib

            close = difflib.get_close_matches(_normalise(key), _reg().by_name, n=3)
            if close:
                hint = "; did you mean " + ", ".join(close) + "?"
        raise ValidationError(f"unknown parameter {key!r}{hint}")
    return p
