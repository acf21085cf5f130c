"""An in-memory transport whose replies come from a Python function (for unit tests)."""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable, Iterable

from drempower.protocol import (
    DataType,
    FastRead,
    ParamValue,
    ReadParam,
    State,
    WriteParam,
    decode_command,
    parameter,
)
from drempower.protocol.ids import Frame
from drempower.transports import Transport

Responder = Callable[[Frame], Iterable[Frame]]


class ScriptedTransport(Transport):
    """Records every frame sent; ``respond(frame)`` returns the frames that come back.

    With ``virtual`` the bus runs on this transport's clock (as on the simulator's virtual clock):
    a wait of the client lets that much scripted time pass at once, or until a frame is injected.
    """

    description = "scripted"

    def __init__(self, respond: Responder | None = None, *, virtual: bool = False) -> None:
        self.respond = respond or (lambda f: ())
        self.sent: list[Frame] = []
        self._q: queue.Queue[Frame | None] = queue.Queue()
        self._lock = threading.Lock()
        self.closed = False
        self.virtual_clock = virtual
        self.time = 1000.0
        """The scripted clock (s), when ``virtual`` (like :func:`time.monotonic`, it does not start at 0)."""

    def clock(self) -> ScriptedTransport | None:
        """This transport itself when ``virtual`` (its scripted clock), else None."""
        return self if self.virtual_clock else None

    def now(self) -> float:
        return self.time

    def advance(self, seconds: float, until: Callable[[], bool] | None = None) -> bool:
        """Let ``seconds`` pass, unless a frame is waiting already."""
        if not self._q.empty() or (until is not None and until()):
            return True
        self.time += seconds
        return False

    def read_nowait(self) -> list[Frame]:
        out: list[Frame] = []
        while True:
            try:
                f = self._q.get_nowait()
            except queue.Empty:
                return out
            if f is None:
                self._q.put(None)
                return out
            out.append(f)

    def send(self, frame: Frame) -> None:
        with self._lock:
            self.sent.append(frame)
        for reply in self.respond(frame):
            self._q.put(reply)

    def inject(self, frame: Frame) -> None:
        """Make ``frame`` arrive as if a motor sent it."""
        self._q.put(frame)

    def recv(self, timeout: float | None = None) -> Frame | None:
        if self.closed:
            return None
        try:
            return self._q.get(timeout=timeout)
        except queue.Empty:
            return None

    def close(self) -> None:
        self.closed = True
        self._q.put(None)

    def commands(self) -> list[object]:
        return [decode_command(f.arbitration_id, f.data) for f in self.sent]


class FakeMotors:
    """Answers fast reads and parameter reads for a few motor ids; remembers writes.

    ``silent`` ids never answer; ``positions`` sets what fast reads report.
    """

    def __init__(self, ids: Iterable[int], silent: Iterable[int] = ()) -> None:
        self.ids = set(ids)
        self.silent = set(silent)
        self.params: dict[int, dict[int, int | float]] = {i: {35104: 1, 31214: 0, 31001: i, 30002: 8} for i in self.ids}
        self.positions: dict[int, float] = dict.fromkeys(self.ids, 0.0)
        self.done: dict[int, bool] = dict.fromkeys(self.ids, True)
        self.error: dict[int, bool] = dict.fromkeys(self.ids, False)

    def __call__(self, frame: Frame) -> list[Frame]:
        cmd = decode_command(frame.arbitration_id, frame.data)
        nodes = sorted(self.ids) if cmd.node == 0 else [cmd.node]
        out: list[Frame] = []
        for n in nodes:
            if n not in self.ids or n in self.silent:
                continue
            if isinstance(cmd, FastRead):
                out.append(State(n, self.positions[n], 0.0, 0.0, self.done[n], self.error[n]).encode())
            elif isinstance(cmd, ReadParam):
                p = parameter(cmd.address)
                default: int | float = 0.0 if p.dtype is DataType.F32 else 0
                value = self.params[n].get(cmd.address, default)
                out.append(ParamValue(n, cmd.address, cmd.dtype, value).encode())
            elif isinstance(cmd, WriteParam):
                self.params[n][cmd.address] = cmd.value
                if cmd.address == 31001:
                    self._renumber(n, int(cmd.value))
        return out

    def _renumber(self, old: int, new: int) -> None:
        for d in (self.params, self.positions, self.done, self.error):
            d[new] = d.pop(old)  # type: ignore[attr-defined]
        self.ids.discard(old)
        self.ids.add(new)
