"""Motor.health(): temperatures, effective current limit, derating and errors, in as few frames as possible."""

from __future__ import annotations

import pytest

import drempower
from drempower.errors import ValidationError
from drempower.protocol import ParamValue, decode_reply
from drempower.protocol.ids import Frame
from drempower.sim import SimBus


class _Answers:
    """The parameters the motors of a simulated bus answer reads of (one reply per read frame)."""

    def __init__(self, sim: SimBus) -> None:
        self.frames: list[Frame] = []
        sim.add_listener(self.frames.append)

    def reads(self) -> list[int]:
        out = []
        for f in self.frames:
            reply = decode_reply(f.arbitration_id, f.data)
            if isinstance(reply, ParamValue):
                out.append(reply.address)
        self.frames.clear()
        return out


def _sim(bus: drempower.Bus) -> SimBus:
    sim = bus.transport.bus  # type: ignore[attr-defined]
    assert isinstance(sim, SimBus)
    return sim


def test_a_cool_motor_reads_ambient_full_limit_no_derating_in_five_reads() -> None:
    with drempower.open_bus("sim", motors=[1], clock="virtual") as bus:
        frames = _Answers(_sim(bus))
        h = bus.motor(1).health()
        assert frames.reads() == [37002, 36002, 33003, 33110, 30001]
    assert h.id == 1
    assert h.motor_temp_c == pytest.approx(25.0)
    assert h.driver_temp_c == pytest.approx(25.0, abs=0.1)
    assert h.current_limit_a == pytest.approx(15.0)
    assert h.derating == 0.0
    assert h.errors == {}
    assert h.faults == []
    assert set(h.as_dict()) >= {"motor_temp_c", "driver_temp_c", "current_limit_a", "derating", "errors"}


def test_a_hot_motor_reports_its_derating() -> None:
    with drempower.open_bus("sim", motors=[1], clock="virtual") as bus:
        _sim(bus).motors[1].thermal.winding = 97.5
        h = bus.motor(1).health()
    assert h.motor_temp_c == pytest.approx(97.5, abs=0.01)
    assert h.current_limit_a == pytest.approx(7.5, abs=0.05)
    assert h.derating == pytest.approx(0.5, abs=0.005)
    assert h.errors == {}


def test_a_tripped_motor_names_the_error_and_its_fix_with_one_more_exchange() -> None:
    with drempower.open_bus("sim", motors=[1, 2], clock="virtual") as bus:
        sim = _sim(bus)
        sim.motors[2].thermal.winding = 101.0
        bus.pass_time(0.02)
        frames = _Answers(sim)
        got = bus.health([1, 2])
        reads = frames.reads()
    assert len(reads) == 2 * 5 + 7  # both motors in one exchange, then motor 2's seven error words
    assert got[1].errors == {}
    h = got[2]
    assert h.derating == 1.0
    assert h.errors["axis0.motor_thermistor.error"] == ["OVER_TEMP"]
    assert "OVER_TEMP" in h.errors["axis0.error"]
    (fault,) = [f for f in h.faults if f.word == "axis0.motor_thermistor.error"]
    text = str(fault)
    assert "motor 2" in text and "OVER_TEMP" in text and "cool" in text
    assert "motor_thermistor.OVER_TEMP" in h.as_dict()["errors"]


def test_bad_ids_are_refused_before_anything_is_sent() -> None:
    with drempower.open_bus("sim", motors=[1], clock="virtual") as bus:
        frames = _Answers(_sim(bus))
        with pytest.raises(ValidationError, match="id"):
            bus.health([1, 64])
        assert frames.reads() == []


async def test_the_asyncio_motor_reads_the_same() -> None:
    async with drempower.open_bus_async("sim", motors=[1], clock="virtual") as bus:
        bus.transport.bus.motors[1].thermal.board = 96.0  # type: ignore[attr-defined]
        h = await bus.motor(1).health()
    assert h.driver_temp_c == pytest.approx(96.0, abs=0.01)
    assert h.current_limit_a == pytest.approx(12.0, abs=0.05)
    assert h.derating == pytest.approx(0.2, abs=0.005)
