"""The command watchdog on scripted time: silence from a live controller holds, a gone one fires."""

from __future__ import annotations

import pytest

import drempower
from drempower.client.engine.effects import sleep
from drempower.client.engine.watchdog import Fired, Watchdog, stop_messages
from drempower.errors import ValidationError
from drempower.protocol import Velocity, WriteParam


def test_silence_from_a_live_controller_holds_the_last_command() -> None:
    dog = Watchdog(timeout=0.5)
    dog.register("page", [1, 2], now=0.0, liveness=True)
    assert dog.tick(60.0) == []  # a minute of silence: still alive, nothing done
    dog.alive("page", False)  # its socket closed
    assert dog.tick(60.1) == [Fired("page", 60.1, {1: "idle", 2: "idle"})]
    assert dog.tick(61.0) == []  # fires once


def test_a_controller_without_liveness_is_gone_after_its_timeout() -> None:
    dog = Watchdog(timeout=0.5, on_timeout={2: "hold"})
    dog.register("ros", [1, 2], now=10.0)
    assert dog.next_due() == 10.5
    dog.feed("ros", 10.4)
    assert dog.tick(10.8) == []  # 0.4 s since the last command
    assert dog.tick(10.91) == [Fired("ros", 10.91, {1: "idle", 2: "hold"})]
    dog.feed("ros", 11.0)  # it is back: armed again
    assert dog.tick(11.2) == [] and dog.tick(11.6) != []


def test_unregister_fires_and_errors_name_the_controller() -> None:
    dog = Watchdog()
    dog.register("a", [3], now=0.0, liveness=True)
    assert dog.unregister("a", 1.0) == Fired("a", 1.0, {3: "idle"})
    with pytest.raises(ValidationError, match="controller 'a' is not registered"):
        dog.feed("a", 2.0)
    with pytest.raises(ValidationError, match=r"on_timeout='coast': expected 'idle' or 'hold'"):
        dog.set_on_timeout(1, "coast")
    with pytest.raises(ValidationError, match=r"nodes=0 is out of range"):
        dog.register("b", [0], now=0.0)


def test_stop_messages_idle_or_hold_each_motor_once() -> None:
    fired = [Fired("a", 0, {1: "hold", 2: "idle"}), Fired("b", 0, {1: "idle", 3: "hold"})]
    assert stop_messages(fired) == [
        WriteParam.of(1, "axis0.requested_state", 1),
        WriteParam.of(2, "axis0.requested_state", 1),
        Velocity(3, 0.0),
    ]


@pytest.mark.parametrize(("action", "state", "speed"), [("idle", 1, None), ("hold", 8, 0.0)])
def test_a_vanished_controller_idles_or_holds_a_simulated_motor(action: str, state: int, speed: float | None) -> None:
    with drempower.open_bus("sim", motors=[1], clock="virtual", stop_on_close=False) as bus:
        sim = bus.transport.bus.motors[1]  # type: ignore[attr-defined]
        dog = Watchdog(timeout=0.2, on_timeout={1: action})
        dog.register("client", [1], now=bus.now())
        for _ in range(5):  # a controller streaming a speed every 50 ms
            bus.motor(1).set_speed(20)
            dog.feed("client", bus.now())
            bus.run(sleep(0.05))
            assert bus.send_many(stop_messages(dog.tick(bus.now()))) is None
        assert sim.speed == pytest.approx(20, abs=1)
        bus.run(sleep(0.3))  # the controller went silent
        fired = dog.tick(bus.now())
        assert [f.controller for f in fired] == ["client"]
        bus.send_many(stop_messages(fired))
        bus.run(sleep(0.5))
        assert sim.param("axis0.current_state") == state
        if speed is not None:
            assert sim.speed == pytest.approx(speed, abs=0.5)
