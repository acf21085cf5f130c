"""Another host on the same bus: its read requests look like replies of value 0."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import can
import pytest

import drempower
from drempower.client import Bus
from drempower.client.engine.session import ZERO_REPLY_GRACE
from drempower.protocol import DataType, ReadParam
from drempower.sim import SimBus

from ..links import TRANSPORTS, link


@pytest.fixture
def two_hosts() -> Iterator[tuple[SimBus, Bus, str]]:
    sim = SimBus(ids=[1])
    with link("virtual", sim, timeout=1.0) as bus:
        yield sim, bus, bus.transport.description.split()[-1]


def _other_host(channel: str, address: int, stop: threading.Event) -> None:
    """A second host that reads parameter ``address`` of motor 1 as fast as it can."""
    with can.Bus(interface="virtual", channel=channel) as other:
        f = ReadParam(1, address, DataType.F32).encode()
        msg = can.Message(arbitration_id=f.arbitration_id, data=f.data, is_extended_id=False)
        while not stop.is_set():
            other.send(msg)
            time.sleep(0.0005)


@pytest.mark.parametrize(("address", "n"), [(1, 100), (30001, 2)])  # vbus_voltage (24 V), axis0.error (0)
def test_reads_beside_a_host_polling_the_same_parameter(
    two_hosts: tuple[SimBus, Bus, str], address: int, n: int
) -> None:
    sim, bus, channel = two_hosts
    expected = sim.motors[1].param(address)
    bus._core.session.zero_reply_grace = 0.25  # the simulator shares this CPU: its replies can lag
    stop = threading.Event()
    other = threading.Thread(target=_other_host, args=(channel, address, stop))
    other.start()
    try:
        deadline = time.monotonic() + 5
        while not bus._core.session.other_hosts and time.monotonic() < deadline:
            time.sleep(0.01)
        assert bus._core.session.other_hosts
        values = [bus.motor(1).read_property(address) for _ in range(n)]
    finally:
        stop.set()
        other.join()
    assert values == [expected] * n


@pytest.mark.parametrize("kind", TRANSPORTS)
def test_no_transport_echoes_our_own_frames(kind: str) -> None:
    """Our own frames must not look like another host's: that would delay every reply of 0."""
    sim = SimBus(ids=[1])
    with link(kind, sim, timeout=2.0) as bus:
        m = bus.motor(1)
        m.set_angle(10, 60, 300, 1)
        m.write_property("axis0.output_shaft.vel_limit", 100.0)
        assert not m.dump_error()
        assert m.read_property("axis0.error") == 0
        assert not bus._core.session.other_hosts


def test_a_lone_reply_of_zero_is_taken_after_the_grace() -> None:
    sim = SimBus(ids=[1])
    with link("inprocess", sim, timeout=1.0) as bus:
        bus._core.session.other_hosts = True
        t0 = bus.now()  # the simulated clock
        assert bus.motor(1).read_property("axis0.error") == 0
        assert bus.now() - t0 == pytest.approx(ZERO_REPLY_GRACE)  # settled by the grace, not by the timeout
        assert bus.motor(1).read_property("vbus_voltage") == sim.motors[1].param("vbus_voltage")
        with pytest.raises(drempower.TimeoutError):
            sim.faults.silent.add(1)
            bus.motor(1).read_property("axis0.error", timeout=0.05)
