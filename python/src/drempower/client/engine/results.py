"""Typed results of motor queries."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from ...protocol.flags import ERROR_WORDS, decode_error_word
from .state import MotorState

__all__ = ["ErrorReport", "GpioMode", "MotorInfo", "ERROR_WORD_NAMES"]


@dataclass(frozen=True, slots=True)
class ErrorReport:
    """The seven error words of a motor (vendor ``dump_error``), decoded.

    ``words`` maps each error word's parameter name (``"axis0.error"``...) to
    its raw value; :attr:`flags` names the set flags of the non-zero words.
    True when any word is non-zero.
    """

    node: int
    words: dict[str, int]

    @property
    def flags(self) -> dict[str, list[str]]:
        """Flag names per non-zero error word, e.g. ``{"axis0.error": ["ESTOP_REQUESTED"]}``."""
        return {name: decode_error_word(name, v) for name, v in self.words.items() if v}

    def __bool__(self) -> bool:
        return any(self.words.values())

    def __str__(self) -> str:
        if not self:
            return f"motor {self.node}: no errors"
        parts = [f"{w}=0x{self.words[w]:X} {' '.join(names)}" for w, names in self.flags.items()]
        return f"motor {self.node}: " + "; ".join(parts)


ERROR_WORD_NAMES: tuple[str, ...] = tuple(w.name for w in ERROR_WORDS)
"""The error words in the order the vendor's dump_error reads them."""


@dataclass(frozen=True, slots=True)
class GpioMode:
    """What the two spare pins of an M-series motor do (vendor ``get_GPIO_mode``).

    ``mode`` is ``"tx_rx"`` (UART, ``param`` = baud rate), ``"step_dir"``
    (``param`` = steps per output turn) or ``"off"`` (neither enabled).
    """

    mode: Literal["tx_rx", "step_dir", "off"]
    enable_uart: bool
    enable_step_dir: bool
    param: float | None


@dataclass(frozen=True, slots=True)
class MotorInfo:
    """A motor found by :meth:`Bus.scan`: its id, state and (on request) versions."""

    id: int
    state: MotorState
    hw_version: int | None = None
    fw_version: int | None = None
