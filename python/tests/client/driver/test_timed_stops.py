"""Timed commands on the wall clock: their stops live on one thread of the bus (not one per command),
the latest command's stop is the one sent, and a command whose stop cannot be armed is not sent."""

from __future__ import annotations

import threading
import time

import pytest

import drempower
from drempower.errors import DrEmpowerError
from drempower.sim import SimBus


def _stop_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if "stop" in t.name and "timed" in t.name]


def test_many_timed_commands_share_one_stop_thread() -> None:
    sim = SimBus(ids=[1])
    with drempower.open_bus("sim", bus=sim, stop_on_close=False) as bus:
        bus.enable([1])
        before = threading.active_count()
        for k in range(300):
            bus.motor(1).set_speed(10 + k % 5, duration=0.3)
        assert threading.active_count() - before <= 1
        assert len([t for t in _stop_threads() if t.is_alive()]) >= 1
        assert bus._timed.pending() == {1}  # one stop: the latest command's
        deadline = time.monotonic() + 5.0
        while bus._timed.pending() and time.monotonic() < deadline:
            time.sleep(0.02)
        assert bus._timed.pending() == set()
        deadline = time.monotonic() + 5.0
        while abs(sim.motors[1].speed) > 0.5 and time.monotonic() < deadline:
            time.sleep(0.02)
        assert abs(sim.motors[1].speed) <= 0.5  # the stop was sent


def test_a_command_whose_stop_cannot_be_armed_is_not_sent(monkeypatch: pytest.MonkeyPatch) -> None:
    sim = SimBus(ids=[1])
    with drempower.open_bus("sim", bus=sim, stop_on_close=False) as bus:
        bus.enable([1])
        real = threading.Thread.start

        def refuse(self: threading.Thread) -> None:
            if "stop" in self.name:
                raise RuntimeError("can't start new thread")
            real(self)

        monkeypatch.setattr(threading.Thread, "start", refuse)
        with pytest.raises(DrEmpowerError, match="the timed stop could not be armed"):
            bus.motor(1).set_speed(50, duration=1.0)
        with pytest.raises(DrEmpowerError, match="the timed stop could not be armed"):
            bus.set_torques([1], [0.2], duration=1.0)
        time.sleep(0.2)
        assert sim.motors[1].param("axis0.output_shaft.input_vel") == 0
        assert abs(sim.motors[1].speed) < 0.5
