"""A pseudo-terminal that behaves like one G-series motor's UART (11-byte frames, PROTOCOL.md 4.1).

Only the motor wired to the UART is reachable: frames from the host go to that
motor alone (not onto the CAN bus), and its answers, and its heartbeats, come
back as 11-byte frames. Bytes that do not line up with a frame are skipped until
a header does (:class:`~drempower.protocol.framing.Uart11Decoder`). The bus's
faults apply as on CAN: ``drop_rate`` and ``corrupt_rate`` to frames both ways,
``reply_delay`` (and jitter) to every frame of the motor, ``serial_garbage``
before frames sent. The UART's own timing (about 1 ms per frame at 115200
baud) is not modelled.
"""

from __future__ import annotations

from ..errors import ValidationError
from ..protocol.framing import Uart11Decoder, encode_uart11
from ..protocol.ids import Frame
from .bus import SimBus
from .pty_link import PtyLink

__all__ = ["UartPty", "attach_uart_pty"]


class UartPty(PtyLink):
    """The UART of motor ``ident`` (the id it was created with) on a pty; ``path`` is the port to open."""

    def __init__(self, bus: SimBus, ident: int) -> None:
        if ident not in bus.motors:
            raise ValidationError(f"ident={ident!r}: no simulated motor {ident} (motors: {sorted(bus.motors)})")
        super().__init__(f"drempower-sim-uart-{ident}")
        self.sim = bus
        self.ident = ident
        self.decoder = Uart11Decoder()
        """Decodes what the host sends; its ``dropped`` counts garbage bytes."""
        bus.add_uart_tap(ident, self._reply)
        self._start()

    def _reply(self, frame: Frame) -> None:
        """A frame of the motor: through the faults, then out."""
        self.sim.uart_reply(frame, self._out)

    def _out(self, frame: Frame) -> None:
        f = self.sim.faults
        head = b""
        if f.serial_garbage > 0 and self.sim.rng.random() < f.serial_garbage:
            head = self.sim.rng.randbytes(self.sim.rng.randint(1, 8))
        self.write(head + encode_uart11(frame.arbitration_id, frame.data))

    def received(self, data: bytes) -> None:
        for frame in self.decoder.feed(data):
            with self.sim.lock:
                for answer in self.sim.uart_request(self.ident, frame):
                    self._reply(answer)

    def close(self) -> None:
        self.sim.remove_uart_tap(self.ident, self._reply)
        super().close()


def attach_uart_pty(bus: SimBus, ident: int) -> UartPty:
    """Open a pty that behaves like the UART of motor ``ident`` on ``bus``; connect a client to ``.path``."""
    return UartPty(bus, ident)
