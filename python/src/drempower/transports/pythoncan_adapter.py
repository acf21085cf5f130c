"""The vendor USB-CAN adapter (0xAA serial framing) as a python-can interface: ``drempower_adapter``.

Registered through python-can's ``can.interface`` entry point, so any python-can
program reaches the motors through the adapter::

    python -m can.logger -i drempower_adapter -c /dev/ttyACM0 -f session.blf
    python -m can.viewer -i drempower_adapter -c /dev/ttyACM0
    can.Bus(interface="drempower_adapter", channel="/dev/ttyACM0")

The adapter's CAN bitrate is set with the vendor's configuration tool, so
``bitrate`` is refused rather than silently ignored.
"""

from __future__ import annotations

import time
from typing import Any

import can

from ..errors import DrEmpowerError
from ..protocol.ids import Frame
from .serial_adapter import AdapterTransport

__all__ = ["AdapterBus"]


class AdapterBus(can.BusABC):
    """python-can bus over the vendor USB-CAN adapter on serial port ``channel``.

    ``baudrate`` is the serial rate (the adapter is a USB CDC device, so it does
    not limit the speed); other keyword arguments go to the serial port.
    Timestamps are the host's clock when a frame was read (Unix s). A received
    message's ``channel`` is the channel name (the port, as given), as python-can's
    own interfaces name theirs (``can0``), so that log files name it in one word;
    the description is in ``channel_info``.
    """

    def __init__(self, channel: Any = None, *, bitrate: int | None = None, baudrate: int = 115200, **kwargs: Any):
        if not channel:
            raise can.CanInitializationError("drempower_adapter needs the serial port as channel, e.g. /dev/ttyACM0")
        if bitrate is not None:
            raise can.CanInitializationError(
                f"bitrate={bitrate}: the adapter's CAN bitrate is set with the vendor's configuration tool"
            )
        serial_kwargs = {k: v for k, v in kwargs.items() if k in ("write_timeout", "rtscts", "dsrdtr", "xonxoff")}
        try:
            self._transport = AdapterTransport(str(channel), baudrate, **serial_kwargs)
        except (DrEmpowerError, OSError) as exc:
            raise can.CanInitializationError(f"drempower_adapter {channel}: {exc}") from exc
        self.channel = str(channel)
        self.channel_info = f"DrEmpower USB-CAN adapter on {channel}"
        super().__init__(channel=channel, **kwargs)

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        try:
            frame = self._transport.recv(timeout)
        except DrEmpowerError as exc:
            raise can.CanOperationError(str(exc)) from exc
        if frame is None:
            return None, False
        arb, data, ext, rtr = frame
        msg = can.Message(
            timestamp=time.time(),
            arbitration_id=arb,
            is_extended_id=ext,
            is_remote_frame=rtr,
            data=data,
            dlc=len(data),
            channel=self.channel,
        )
        return msg, False

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        if msg.is_fd or msg.is_error_frame:
            raise can.CanOperationError("the adapter sends classic CAN data and remote frames only")
        frame = Frame(msg.arbitration_id, bytes(msg.data), msg.is_extended_id, msg.is_remote_frame)
        try:
            self._transport.send(frame)
        except DrEmpowerError as exc:
            raise can.CanOperationError(str(exc)) from exc

    def shutdown(self) -> None:
        super().shutdown()
        self._transport.close()

    @staticmethod
    def _detect_available_configs() -> list[Any]:
        return []
