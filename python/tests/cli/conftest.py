"""Fixtures of the command-line tests: run ``drempower`` in-process against the simulator."""

from __future__ import annotations

import json
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import pytest

from drempower.cli import main
from drempower.cli._connect import TIME_SCALE_ENV
from drempower.protocol import Frame
from drempower.sim import SimBus, SimRunner, attach_python_can
from drempower.sim.bus import Listener
from drempower.transports import sim as sim_transport

TIME_SCALE = 20.0
"""Simulated time runs this much faster than the wall clock in every test."""


@dataclass
class Result:
    code: int
    out: str
    err: str

    def records(self) -> list[dict[str, Any]]:
        """The JSON lines of stdout."""
        return [json.loads(line) for line in self.out.splitlines()]


Cli = Callable[..., Result]

SLOW_LINK = ("--timeout", "2")
"""For commands whose replies cross threads (python-can virtual, TCP, a pty): the default
0.1 s is right for a motor, but the simulator here shares the interpreter and CPU with
the client, and a stalled machine can hold a reply longer. Success returns at once."""


@pytest.fixture(autouse=True)
def _fast_simulator(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(TIME_SCALE_ENV, str(TIME_SCALE))


@pytest.fixture(autouse=True)
def _no_usb_adapters(monkeypatch: pytest.MonkeyPatch) -> None:
    """No USB-CAN adapter is plugged in, whatever this machine has: commands without a connection find none."""
    from serial.tools import list_ports

    monkeypatch.setattr(list_ports, "comports", lambda *a, **k: [])


@pytest.fixture
def cli(capsys: pytest.CaptureFixture[str]) -> Cli:
    """``cli("state", "1", "--sim", "1")``: run the command, return exit code and output.

    The code is the process's exit code: usage errors (argparse's, and those
    found afterwards) exit 2 through SystemExit.
    """

    def run(*argv: str) -> Result:
        try:
            code = main(list(argv))
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
        out, err = capsys.readouterr()
        return Result(code, out, err)

    return run


@pytest.fixture
def sim(monkeypatch: pytest.MonkeyPatch) -> Iterator[SimBus]:
    """Simulated motors 1, 2 and 3 that every ``--sim`` invocation of the test shares.

    Each command opens its own bus, as from a shell, but reaches these motors,
    so what one command does is there for the next.
    """
    bus = SimBus(ids=[1, 2, 3])
    real = sim_transport.SimTransport

    def shared(motors: object = (), **kwargs: object) -> sim_transport.SimTransport:
        return real(bus=bus, time_scale=0)

    monkeypatch.setattr(sim_transport, "SimTransport", shared)
    with SimRunner(bus, TIME_SCALE):
        yield bus


@pytest.fixture
def host_frames(sim: SimBus, monkeypatch: pytest.MonkeyPatch) -> list[Frame]:
    """Every frame the commands of the test send to the shared simulated motors, in order."""
    frames: list[Frame] = []
    send = sim.send

    def recording(frame: Frame, origin: Listener | None = None) -> None:
        frames.append(frame)
        send(frame, origin)

    monkeypatch.setattr(sim, "send", recording)
    return frames


@pytest.fixture
def virtual_channel() -> Iterator[str]:
    """Simulated motors 1 and 2 on a python-can virtual channel: commands and replies both travel on it."""
    channel = f"drempower-cli-{uuid.uuid4().hex}"
    bus = SimBus(ids=[1, 2])
    with SimRunner(bus, TIME_SCALE), attach_python_can(bus, channel):
        yield channel
