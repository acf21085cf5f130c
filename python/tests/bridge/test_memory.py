"""The bridge's memory stays flat under a 1000 Hz subscriber, clients coming and going, and made-up clients."""

from __future__ import annotations

import gc
import threading
import time
import tracemalloc
from typing import Any

import pytest

from drempower import open_bus
from drempower.bridge import bus_face
from drempower.protocol.messages import FastRead
from drempower.transports.zenoh_wire import encode_frames

from .conftest import Served, session, wait_for

pytestmark = pytest.mark.timeout(90)

RUN = 20.0
"""s of traffic measured."""
HEAP_LIMIT = 100_000
"""Bytes the Python heap may grow over RUN (a flat bridge shows tens of kB of noise; remembering every
made-up client grew it by 400 kB)."""


def _traffic(served: Served, peer: Any, stop: threading.Event) -> None:
    """Samples of made-up clients (one new client id each), and a real client with an estop now and then."""
    frame = encode_frames([FastRead(1).encode()])
    i = 0
    next_client = time.monotonic()
    while not stop.is_set():
        for _ in range(20):
            i += 1
            peer.put(f"{served.prefix}/tx", frame, attachment=f"ghost{i}:1".encode())
        if time.monotonic() >= next_client:
            with open_bus("zenoh", served.prefix, connect=served.endpoint, gossip=False) as bus:
                bus.motor(1).get_state()
                bus.estop()
            next_client = time.monotonic() + 2.0
        stop.wait(0.1)


@pytest.mark.parametrize("served", [{"rate": 1000.0}], indirect=True)
def test_memory_is_flat_over_a_bounded_run(served: Served, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(bus_face, "FORGET_AFTER", 1.0)  # made-up clients forgotten after 2 s (ten command timeouts)
    face = served.bridge._face
    got = [0]
    with session(connect=[served.endpoint]) as peer:
        sub = peer.declare_subscriber(served.bridge.joint_states_key, lambda _s: got.__setitem__(0, got[0] + 1))
        stop = threading.Event()
        feeder = threading.Thread(target=_traffic, args=(served, peer, stop))
        tracemalloc.start()  # before the traffic: what it frees later was traced too
        feeder.start()
        try:
            time.sleep(4.0)  # every kind of traffic has run and the made-up clients are forgotten as fast as they come
            gc.collect()
            heap0, n0 = tracemalloc.get_traced_memory()[0], got[0]
            time.sleep(RUN)
            gc.collect()
            growth = tracemalloc.get_traced_memory()[0] - heap0
        finally:
            tracemalloc.stop()
            stop.set()
            feeder.join(10)
            sub.undeclare()
    received = got[0] - n0
    print(f"heap growth {growth} B over {RUN:g} s; {received} joint_states; {len(face._heard)} clients remembered")
    assert received > 20 * RUN  # the stream ran the whole time
    assert growth < HEAP_LIMIT
    wait_for(lambda: len(face._heard) < 2000, limit=5.0)  # not every made-up client of the run
    assert len(face._stopped_at) <= 1
