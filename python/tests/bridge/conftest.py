"""Zenoh sessions on 127.0.0.1 with explicit endpoints, and a bridge over simulated motors."""

from __future__ import annotations

import socket
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import pytest

zenoh = pytest.importorskip("zenoh")
pytest.importorskip("rosbags")

from drempower.bridge.server import Bridge, BridgeOptions  # noqa: E402
from drempower.transports.sim import SimTransport  # noqa: E402
from drempower.transports.zenoh_config import open_session  # noqa: E402


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def session(listen: list[str] | None = None, connect: list[str] | None = None) -> Any:
    """A peer session: no scouting of any kind, only the endpoints given."""
    return open_session(connect or [], listen or [], scout=False, gossip=False)


def wait_for(cond: Callable[[], bool], limit: float = 5.0, step: float = 0.01) -> float:
    """Poll ``cond`` until true; returns the seconds it took, fails after ``limit``."""
    t0 = time.monotonic()
    while not cond():
        if time.monotonic() - t0 > limit:
            raise AssertionError(f"condition not met within {limit} s")
        time.sleep(step)
    return time.monotonic() - t0


@dataclass
class Served:
    bridge: Bridge
    sim: SimTransport
    endpoint: str
    prefix: str


@pytest.fixture
def served(request: pytest.FixtureRequest) -> Iterator[Served]:
    """Bridge over simulated motors 1 and 2, listening on a free loopback port."""
    opts: dict[str, Any] = getattr(request, "param", {})
    sim = SimTransport([1, 2])
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sess = session(listen=[endpoint])
    prefix = f"test{free_port()}"
    bridge = Bridge(sim, sess, BridgeOptions({"motor_1": 1, "motor_2": 2}, prefix=prefix, **opts))
    try:
        yield Served(bridge, sim, endpoint, prefix)
    finally:
        bridge.close()
        sess.close()
        sim.close()
