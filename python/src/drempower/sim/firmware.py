"""Firmware profiles: one knob for every reading of the vendor's document that a host can see.

spec/PROTOCOL.md marks these points [UNCERTAIN] or [INFERRED]; real firmware may take
any reading the document allows. A :class:`Firmware` picks one reading per point; the
defaults are the simulator's long-standing choices (docs/simulator.md says why).
``SimBus(..., firmware=Firmware(status_bits="kept"))``, ``open_bus("sim", status_bits="kept")``,
a robot file's sim bus (``status_bits = "kept"``) and ``drempower sim --status-bits kept``
select them; every knob is also a keyword of SimBus and of the sim transport.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from typing import Any, Literal

from ..errors import ValidationError
from ..protocol.addresses import AXIS0_CONFIG_CAN_NODE_ID
from ..protocol.limits import MAX_NODE, MIN_MOTOR
from .behaviour import BOOT_SECONDS
from .params import ParamStore

__all__ = [
    "DEFAULT",
    "Firmware",
    "KNOBS",
    "factory_firmware_id",
    "STATUS_BITS",
    "REPLY_TRIGGERS",
    "Q_TIME_ZERO",
    "firmware_from",
]

STATUS_BITS = ("zero", "kept")
REPLY_TRIGGERS = ("control+preset", "control", "all")
Q_TIME_ZERO = ("fastest", "ignore")

StatusBits = Literal["zero", "kept"]
ReplyTriggers = Literal["control+preset", "control", "all"]
QTimeZero = Literal["fastest", "ignore"]


@dataclass(frozen=True)
class Firmware:
    """One reading of every uncertain point of the document (PROTOCOL.md section in brackets).

    * ``status_bits`` [1.6]: bits 3-4 of a state frame's command: ``zero`` (0x01-0x07) or ``kept``
      from the command answered (0x19-0x1F for a fast read or a control frame, 0x09-0x0F for a preset;
      a heartbeat, which answers nothing, has them 0).
    * ``boot_s`` [3.3, 9]: seconds of silence after a reboot or power cycle.
    * ``reply_state`` [1.6 item 2]: what ``enable_reply_state`` answers: ``control+preset`` (0x19-0x1D
      and 0x0C), ``control`` (not the preset), ``all`` (also system commands 0x08 and writes 0x1F).
    * ``fast_read`` [1.6 item 1]: the fast read (address 0) is answered (firmware above 1.1).
    * ``q_time_zero`` [3.4.3]: a Q target-time preset with time 0: ``fastest`` (as fast as the limits
      allow) or ``ignore`` (the start does nothing).
    * ``heartbeat`` [1.6 item 3]: ``can.config.heartbeat_ms`` > 0 sends state frames; False: the value
      is stored, nothing is sent (firmware without the feature).
    * ``factory_id`` [3.8]: the node id of the factory configuration (``init_config``, ``erase_config``
      then reboot); None: the id the motor was created with.
    """

    status_bits: StatusBits = "zero"
    boot_s: float = BOOT_SECONDS
    reply_state: ReplyTriggers = "control+preset"
    fast_read: bool = True
    q_time_zero: QTimeZero = "fastest"
    heartbeat: bool = True
    factory_id: int | None = None

    def __post_init__(self) -> None:
        _choice("status_bits", self.status_bits, STATUS_BITS)
        _choice("reply_state", self.reply_state, REPLY_TRIGGERS)
        _choice("q_time_zero", self.q_time_zero, Q_TIME_ZERO)
        b = self.boot_s
        if isinstance(b, bool) or not isinstance(b, int | float) or not 0.0 <= b <= 60.0:
            raise ValidationError(f"boot_s={b!r}: seconds 0..60")
        for name in ("fast_read", "heartbeat"):
            v = getattr(self, name)
            if not isinstance(v, bool):
                raise ValidationError(f"{name}={v!r}: True or False")
        f = self.factory_id
        if f is not None and (isinstance(f, bool) or not isinstance(f, int) or not MIN_MOTOR <= f <= MAX_NODE):
            raise ValidationError(f"factory_id={f!r}: a motor id {MIN_MOTOR}..{MAX_NODE}, or None (its own id)")

    def spare_bits(self, answered: int) -> int:
        """Bits 3-4 (as 0..3) of a state frame answering command ``answered`` (0: a heartbeat)."""
        return (answered >> 3) & 3 if self.status_bits == "kept" else 0

    def replies_to(self, cmd: int) -> bool:
        """True when a motor with ``enable_reply_state`` on answers command ``cmd`` with a state frame."""
        if 0x19 <= cmd <= 0x1D:
            return True
        if cmd == 0x0C:
            return self.reply_state != "control"
        return self.reply_state == "all" and cmd in (0x08, 0x1F)

    def to_json(self) -> dict[str, Any]:
        """Every knob by name."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


def _choice(name: str, value: object, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise ValidationError(f"{name}={value!r}: one of {', '.join(map(repr, allowed))}")


DEFAULT = Firmware()
"""The profile of simulated motors given none. The test suite's second pass
(``pytest --sim-status-bits kept``) replaces it to run the core tests on the other reading."""

KNOBS: tuple[str, ...] = tuple(f.name for f in fields(Firmware))
"""The knob names: keywords of :class:`Firmware`, SimBus and the sim transport."""


def firmware_from(firmware: Firmware | Mapping[str, Any] | None, knobs: Mapping[str, Any]) -> Firmware:
    """A :class:`Firmware` from ``firmware`` (or the defaults) with ``knobs`` (None values skipped) applied."""
    if firmware is None:
        base = DEFAULT
    elif isinstance(firmware, Firmware):
        base = firmware
    elif isinstance(firmware, Mapping):
        extra = sorted(set(firmware) - set(KNOBS))
        if extra:
            raise ValidationError(f"firmware: unknown knob {extra[0]!r}: one of {', '.join(KNOBS)}")
        base = Firmware(**firmware)
    else:
        raise ValidationError(f"firmware={firmware!r}: a Firmware or a mapping of knobs")
    given = {k: v for k, v in knobs.items() if v is not None}
    return replace(base, **given) if given else base


def factory_firmware_id(params: ParamStore, ident: int, factory_id: int | None) -> None:
    """Give ``params`` (of a motor made as ``ident``) the factory node id ``factory_id``: the motor still
    boots as ``ident`` (as if that id had been saved), and ``init_config`` or ``erase_config`` and a reboot
    bring ``factory_id``. None or ``ident``: nothing changes."""
    if factory_id is None or factory_id == ident:
        return
    params.factory[AXIS0_CONFIG_CAN_NODE_ID] = factory_id
    if params.saved is None:
        params.saved = {AXIS0_CONFIG_CAN_NODE_ID: ident}
