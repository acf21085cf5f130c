"""The error words of a simulated motor (axis0.error and its sub-words): how errors are raised and cleared."""

from __future__ import annotations

from collections.abc import Callable
from enum import IntFlag

from ..protocol.addresses import AXIS0_ENCODER_ERROR, AXIS0_ERROR, CAN_ERROR
from ..protocol.flags import ERROR_WORDS, CanError
from ..protocol.parameters import parameter
from . import behaviour as bh

__all__ = ["ERROR_ADDRESSES", "ErrorWords"]

ERROR_ADDRESSES = tuple(w.address for w in ERROR_WORDS)
"""The addresses of the error words (30001 axis, 33001 motor, ...)."""
_WORD_OF_FLAGS: dict[type[IntFlag], int] = {w.flags: w.address for w in ERROR_WORDS}


class ErrorWords:
    """The error words by parameter address, and whether set_zero_position cleared the sticky encoder errors.

    ``on_axis_error`` is called after each raise that leaves axis0.error non-zero (the axis then idles).
    """

    __slots__ = ("_on_axis_error", "sticky_cleared", "words")

    def __init__(self, on_axis_error: Callable[[], None]) -> None:
        self.words: dict[int, int] = dict.fromkeys(ERROR_ADDRESSES, 0)
        """Error words by parameter address."""
        self.sticky_cleared = True
        self._on_axis_error = on_axis_error

    @property
    def axis(self) -> int:
        """axis0.error (30001)."""
        return self.words[AXIS0_ERROR]

    def reset(self) -> None:
        """Power-up: every word 0, no sticky encoder error kept."""
        self.words = dict.fromkeys(ERROR_ADDRESSES, 0)
        self.sticky_cleared = True

    def raise_flags(self, word: int, flags: int, axis_flag: int | None = None) -> None:
        """Set error ``flags`` in ``word``; an error in a sub-word also sets its axis flag (or ``axis_flag``)."""
        words = self.words
        words[word] |= flags
        if word != AXIS0_ERROR:
            extra = bh.ERROR_WORD_AXIS_FLAG.get(word, 0) if axis_flag is None else axis_flag
            words[AXIS0_ERROR] |= extra
        if words[AXIS0_ERROR]:
            self._on_axis_error()

    def inject(self, flag: IntFlag, word: str | int | None = None) -> None:
        """Raise ``flag`` in ``word`` (name or address; default: the word of the flag's type)."""
        addr = _WORD_OF_FLAGS[type(flag)] if word is None else parameter(word).address
        if addr == AXIS0_ENCODER_ERROR and int(flag) & bh.STICKY_ENCODER_ERRORS:
            self.sticky_cleared = False
        self.raise_flags(addr, int(flag))

    def clear(self) -> int:
        """clear_errors: every word 0; returns the sticky encoder errors that stay (to raise again)."""
        sticky = 0 if self.sticky_cleared else self.words[AXIS0_ENCODER_ERROR] & bh.STICKY_ENCODER_ERRORS
        self.words = dict.fromkeys(ERROR_ADDRESSES, 0)
        return sticky

    def duplicate_id(self) -> None:
        """Another motor answered with this motor's id."""
        self.words[CAN_ERROR] |= CanError.DUPLICATE_CAN_IDS
