"""An slcan (Lawicel) adapter on a serial port, read line by line as the other serial transports are."""

from __future__ import annotations

import time
from typing import Any

from ..protocol.slcan import SlcanDecoder, encode_slcan
from .errors import TransportError, TransportOptionError
from .serialport import SerialFrameTransport

__all__ = ["SlcanTransport", "BITRATES", "SLEEP_AFTER_OPEN"]

BITRATES = {
    10_000: b"S0",
    20_000: b"S1",
    50_000: b"S2",
    100_000: b"S3",
    125_000: b"S4",
    250_000: b"S5",
    500_000: b"S6",
    750_000: b"S7",
    1_000_000: b"S8",
    83_300: b"S9",
}
"""The CAN bit rates (bit/s) an slcan adapter sets, and their commands."""
SLEEP_AFTER_OPEN = 2.0
"""Default wait (s) after opening the port before the first command, as python-can's slcan waits: some
adapters restart when their port is opened. ``sleep_after_open=0`` for those that do not."""
_CLOSE_WRITE_TIMEOUT = 0.25
"""Bound (s) of the close command written on closing (a device that stopped reading must not hold it)."""


class SlcanTransport(SerialFrameTransport):
    """An slcan adapter (CANable, CANtact, the vendor's adapter in standard mode...) on ``port``.

    ``port`` may end in ``@BAUD`` to give the serial rate (or ``tty_baudrate``;
    a USB adapter ignores it). Opening writes ``C`` (close the channel), the
    bit rate command when ``bitrate`` is given (one of :data:`BITRATES`), then
    ``O`` (open; ``L`` with ``listen_only``), after ``sleep_after_open`` s;
    closing writes ``C``. The adapter's answers are skipped; the decoder counts
    them (``decoder.answers``, ``decoder.refused``). ``write_timeout`` (s)
    bounds a send; other keyword arguments go to :func:`serial.serial_for_url`.
    The channel is opened exclusively, as the other serial transports are.
    """

    def __init__(
        self,
        port: str,
        bitrate: int | None = None,
        *,
        tty_baudrate: int = 115200,
        sleep_after_open: float = SLEEP_AFTER_OPEN,
        listen_only: bool = False,
        **serial_kwargs: Any,
    ) -> None:
        if "@" in port:
            port, _, rate = port.rpartition("@")
            if not rate.isdigit() or not rate.isascii():
                raise TransportOptionError(
                    f"cannot open slcan adapter on {port!r}: serial rate {rate!r} is not a number"
                )
            tty_baudrate = int(rate)
        if bitrate is not None and bitrate not in BITRATES:
            allowed = ", ".join(str(b) for b in sorted(BITRATES))
            raise TransportOptionError(
                f"cannot open slcan adapter on {port!r}: bitrate={bitrate!r}; slcan sets {allowed}"
            )
        if isinstance(sleep_after_open, bool) or not isinstance(sleep_after_open, int | float) or sleep_after_open < 0:
            raise TransportOptionError(
                f"cannot open slcan adapter on {port!r}: sleep_after_open={sleep_after_open!r} must be seconds >= 0"
            )
        super().__init__(port, tty_baudrate, SlcanDecoder(), encode_slcan, "slcan adapter", **serial_kwargs)
        self.wire_bitrate = bitrate
        if bitrate is not None:
            self.description += f", CAN {bitrate // 1000} kbit/s"
        try:
            time.sleep(sleep_after_open)
            with self._wlock:
                speed = b"" if bitrate is None else BITRATES[bitrate] + b"\r"
                self._write(b"C\r" + speed + (b"L\r" if listen_only else b"O\r"))
        except BaseException:
            super().close()
            raise

    def close(self) -> None:
        """Write the close command (bounded: a device that stopped reading does not hold it), then close the port."""
        if self._closing.is_set():
            return
        if self._wlock.acquire(timeout=_CLOSE_WRITE_TIMEOUT):
            try:
                self._write(b"C\r", _CLOSE_WRITE_TIMEOUT)
            except TransportError:
                pass
            finally:
                self._wlock.release()
        super().close()
