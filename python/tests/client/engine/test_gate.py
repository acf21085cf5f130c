"""The safety gate: motion to an idle motor is refused (unless enable=True), soft limits hold, and the
timed commands end by themselves; the same words from the threaded and the asyncio API, nothing sent."""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Iterator

import pytest

import drempower
from drempower.client.engine.effects import sleep
from drempower.errors import MotorIdleError, SoftLimitError
from drempower.protocol import ReadParam, decode_command
from drempower.protocol.flags import AxisError
from drempower.protocol.ids import Frame
from drempower.protocol.limits import MOTION_CMDS, START_SYS_CMDS
from drempower.sim import SimBus

IDLE_1 = (
    "motor 1 is idle (not in closed loop): enable it first (motor.enable(), drempower enable 1) or pass enable=True"
)


def _motion(frames: list[Frame]) -> list[Frame]:
    """The frames that move motors: motion commands, presets and starts."""
    return [
        f
        for f in frames
        if f.arbitration_id & 0x1F in MOTION_CMDS or (f.arbitration_id & 0x1F == 0x08 and f.data[0] in START_SYS_CMDS)
    ]


class Idle:
    """Simulated motors 1 and 2 left idle by a previous program, and every frame hosts send them."""

    def __init__(self) -> None:
        self.sim = SimBus(ids=[1, 2])
        with drempower.open_bus("sim", bus=self.sim, clock="virtual") as before:
            before.idle([1, 2])
        assert self.sim.motors[1].param("axis0.current_state") == 1
        self.frames: list[Frame] = []
        self.at: list[float] = []
        """The simulated time (s) each frame was sent at."""
        send = self.sim.send

        def recording(frame: Frame, origin: object = None) -> None:
            self.frames.append(frame)
            self.at.append(self.sim.now)
            send(frame, origin)  # type: ignore[arg-type]

        self.sim.send = recording  # type: ignore[method-assign]

    def open(self, **kw: object) -> drempower.Bus:
        return drempower.open_bus("sim", bus=self.sim, clock="virtual", stop_on_close=False, **kw)

    def open_async(self) -> drempower.AsyncBus:
        return drempower.open_bus_async("sim", bus=self.sim, clock="virtual", stop_on_close=False)

    def reads(self) -> list[object]:
        """The reads of axis0.current_state (the gate's)."""
        msgs = (decode_command(f.arbitration_id, f.data) for f in self.frames)
        return [m for m in msgs if isinstance(m, ReadParam) and m.address == 30002]


@pytest.fixture
def idle() -> Iterator[Idle]:
    yield Idle()


REFUSALS: list[tuple[str, Callable[[drempower.Bus], object]]] = [
    ("set_angle", lambda b: b.motor(1).set_angle(30, 10, 20, 1)),
    ("step_angle", lambda b: b.motor(1).step_angle(30, 10, 20, 1)),
    ("set_speed", lambda b: b.motor(1).set_speed(10)),
    ("set_torque", lambda b: b.motor(1).set_torque(0.1)),
    ("impedance_control", lambda b: b.motor(1).impedance_control(30, kp=1, kd=0.1)),
    ("set_angles", lambda b: b.set_angles([1], [30], 10, 20, 1)),
    ("step_angles", lambda b: b.step_angles([1], [30], 10, 20, 1)),
    ("set_speeds", lambda b: b.set_speeds([1], [10])),
    ("set_torques", lambda b: b.set_torques([1], [0.1])),
    ("impedance_controls", lambda b: b.impedance_controls([1], [30], kp=1, kd=0.1)),
    ("cycle", lambda b: b.cycle([b.motor(1).make_angle(30, 0, 50)])),
]


@pytest.mark.parametrize(("name", "call"), REFUSALS, ids=[n for n, _ in REFUSALS])
def test_every_motion_method_refuses_an_idle_motor(
    idle: Idle, name: str, call: Callable[[drempower.Bus], object]
) -> None:
    with idle.open() as bus:
        with pytest.raises(MotorIdleError) as info:
            call(bus)
        assert str(info.value) == IDLE_1
        assert info.value.nodes == (1,) and info.value.states == (1,)
    assert _motion(idle.frames) == []
    assert len(idle.reads()) == 1  # the one read of axis0.current_state
    assert idle.sim.motors[1].position == pytest.approx(0, abs=1e-6)


@pytest.mark.parametrize(("name", "call"), REFUSALS, ids=[n for n, _ in REFUSALS])
def test_the_asyncio_api_refuses_with_the_same_words(
    idle: Idle, name: str, call: Callable[[drempower.Bus], object]
) -> None:
    async def main() -> str:
        async with idle.open_async() as bus:
            with pytest.raises(MotorIdleError) as info:
                result = call(bus)  # type: ignore[arg-type]
                if asyncio.iscoroutine(result):
                    await result
            return str(info.value)

    assert asyncio.run(main()) == IDLE_1
    assert _motion(idle.frames) == []


def test_several_idle_motors_are_named_together(idle: Idle) -> None:
    with idle.open() as bus, pytest.raises(MotorIdleError) as info:
        bus.set_angles([1, 2], [10, 20], 10, 20, 1)
    assert str(info.value) == (
        "motors 1, 2 are idle (not in closed loop): enable them first (bus.enable([...]), drempower enable 1,2) "
        "or pass enable=True"
    )
    assert _motion(idle.frames) == []


def test_enable_true_enables_then_moves(idle: Idle) -> None:
    with idle.open() as bus:
        bus.motor(1).set_angle(30, 20, 50, 1, enable=True)
        done = bus.motor(1).wait_position_done(10)
    assert done.angle == pytest.approx(30, abs=0.5)
    assert idle.reads() == []  # enabling asked nothing: the motor is told


def test_enable_first_then_the_gate_lets_moves_through(idle: Idle) -> None:
    with idle.open() as bus:
        bus.enable([1, 2])
        assert bus.set_angles([1, 2], [10, -10], 20, 50, 1) is not None
        bus.positions_done([1, 2], 10)
    assert idle.reads() == []


def test_a_control_loop_pays_one_read_then_none(idle: Idle) -> None:
    with idle.open() as bus:
        bus.enable([1])
        bus.motor(1).idle()  # not known in closed loop now: the next cycle reads, and is refused
        with pytest.raises(MotorIdleError):
            bus.cycle([bus.motor(1).make_angle(0, 0, 50)])
        assert len(idle.reads()) == 1
        idle.frames.clear()
        bus.motor(1).enable()
        for i in range(200):
            bus.cycle([bus.motor(1).make_angle(i * 0.1, 0, 50)])
    assert idle.reads() == []


def test_an_unknown_motor_is_read_once_and_remembered() -> None:
    with drempower.open_bus("sim", motors=[1], clock="virtual", stop_on_close=False) as bus:  # closed loop at start
        frames: list[Frame] = []
        sim: SimBus = bus.transport.bus  # type: ignore[attr-defined]
        send = sim.send
        sim.send = lambda f, o=None: (frames.append(f), send(f, o))  # type: ignore[method-assign, func-returns-value]
        for i in range(50):
            bus.motor(1).set_angle(i, 0, 50)
        reads = [f for f in frames if f.arbitration_id & 0x1F == 0x1E and f.data[:2] != b"\0\0"]
        assert len(reads) == 1
        bus.motor(1).estop()  # an estop makes it unknown again
        bus.motor(1).clear_error()
        with pytest.raises(MotorIdleError, match="motor 1 is idle"):
            bus.motor(1).set_angle(0, 0, 50)


def test_a_state_frame_with_the_error_bit_makes_the_motor_unknown(idle: Idle) -> None:
    with idle.open() as bus:
        bus.enable([1])
        idle.sim.motors[1].inject_error(AxisError.MOTOR_FAILED)  # an axis error: the firmware leaves closed loop
        bus.motor(1).get_state()
        idle.frames.clear()
        with pytest.raises(MotorIdleError):
            bus.motor(1).set_speed(5)
    assert _motion(idle.frames) == []


# ------------------------------------------------------------------ soft limits


def test_soft_limits_from_the_api_refuse_before_any_frame(idle: Idle) -> None:
    with idle.open() as bus:
        bus.enable([1, 2])
        bus.set_limits(1, position=(-90, 90), speed=30, torque=2, accel=100, max_step=45)
        idle.frames.clear()
        m = bus.motor(1)
        cases: list[tuple[Callable[[], object], str]] = [
            (lambda: m.set_angle(120, 10, 20, 1), "motor 1: position 120 deg is beyond its soft limit -90..90 deg"),
            (lambda: m.set_speed(-40), "motor 1: speed -40 r/min is beyond its soft limit -30..30 r/min"),
            (lambda: m.set_torque(2.5), "motor 1: torque 2.5 Nm is beyond its soft limit -2..2 Nm"),
            (lambda: m.set_angle(10, 10, 200, 1), "motor 1: accel 200 (r/min)/s is beyond its soft limit"),
            (lambda: m.set_angle(60, 0, 50), "motor 1: max_step 60 deg is beyond its soft limit -45..45 deg"),
            (lambda: bus.set_speeds([2, 1], [10, 31]), "motor 1: speed 31 r/min"),
            (lambda: bus.cycle([m.make_torque(-3)]), "motor 1: torque -3 Nm"),
        ]
        for call, words in cases:
            with pytest.raises(SoftLimitError) as info:
                call()
            assert str(info.value).startswith(words)
            assert "(set by bus.set_limits(1, position=(-90, 90), speed=30, torque=2, accel=100, max_step=45))" in str(
                info.value
            )
        assert _motion(idle.frames) == []  # max_step had the position read, nothing else was sent
        m.set_angle(40, 0, 50)  # within every limit, 40 deg from 0
        with pytest.raises(SoftLimitError, match="max_step 80 deg"):
            m.set_angle(80, 0, 50)  # the motor is still at 0: it would go 80 deg
        bus.pass_time(1.0)
        m.set_angle(80, 0, 50)  # 40 deg from where the motor now is
        bus.pass_time(1.0)
        with pytest.raises(SoftLimitError, match="max_step -80 deg"):
            m.set_angle(0, 0, 50)
        bus.set_limits(1)  # no limits any more
        m.set_angle(0, 0, 50)


def test_a_relative_step_is_checked_against_the_position_range(idle: Idle) -> None:
    with idle.open() as bus:
        bus.enable([1])
        bus.set_limits(1, position=(-10, 10))
        with pytest.raises(SoftLimitError, match="motor 1: position 15 deg"):
            bus.motor(1).step_angle(15, 10, 20, 1)
        assert _motion(idle.frames) == []


def test_bad_limits_are_refused_naming_them(idle: Idle) -> None:
    with idle.open() as bus:
        with pytest.raises(drempower.ValidationError, match=r"position=\(5, -5\): low 5 is above high -5"):
            bus.set_limits(1, position=(5, -5))
        with pytest.raises(drempower.ValidationError, match=r"speed=-1: a limit is > 0"):
            bus.set_limits(1, speed=-1)
        with pytest.raises(drempower.ValidationError, match=r"id=0 is out of range"):
            bus.set_limits(0, speed=1)


# ------------------------------------------------------------------ timed commands


def test_a_timed_speed_ends_at_its_duration_on_virtual_time(idle: Idle) -> None:
    with idle.open() as bus:
        bus.motor(1).set_speed(30, duration=1.0, enable=True)
        bus.run(sleep(0.5))
        assert idle.sim.motors[1].speed == pytest.approx(30, abs=1)
        bus.run(sleep(1.0))
        assert idle.sim.motors[1].speed == pytest.approx(0, abs=1)
    speeds = [(t, f.data[:4]) for t, f in zip(idle.at, idle.frames, strict=True) if f.arbitration_id == 0x3C]
    assert [d for _, d in speeds] == [bytes.fromhex("0000f041"), bytes(4)]  # 30.0 r/min, then 0
    assert speeds[1][0] - speeds[0][0] == pytest.approx(1.0, abs=0.005)


def test_a_newer_command_cancels_the_pending_stop(idle: Idle) -> None:
    with idle.open() as bus:
        bus.enable([1, 2])
        bus.set_torques([1, 2], [0.2, 0.2], duration=0.5)
        bus.motor(1).set_speed(10)  # motor 1 was told something newer
        bus.run(sleep(1.0))
        sim = idle.sim.motors
        assert sim[1].speed == pytest.approx(10, abs=1)
    zero_torques = [f for f in idle.frames if f.arbitration_id & 0x1F == 0x1D and f.data[:4] == b"\0\0\0\0"]
    assert [f.arbitration_id >> 5 for f in zero_torques] == [2]


def test_a_bad_duration_is_refused(idle: Idle) -> None:
    with idle.open() as bus:
        bus.enable([1])
        idle.frames.clear()
        with pytest.raises(drempower.ValidationError, match=r"duration=-1: expected seconds > 0"):
            bus.motor(1).set_speed(10, duration=-1)
    assert idle.frames == []


def test_compat_refuses_with_the_same_words(idle: Idle) -> None:
    from drempower import compat

    with idle.open() as bus:
        compat.use_bus(bus)
        try:
            for call in (
                lambda: compat.set_angle(1, 30, 10, 20, 1),
                lambda: compat.set_speed(1, 10),
                lambda: compat.set_torques([1], [0.1]),
                lambda: compat.impedance_control(1, 30, 0, 0, 1, 0.1),
            ):
                with pytest.raises(MotorIdleError) as info:
                    call()
                assert str(info.value) == IDLE_1
            compat.set_mode(1, 2)  # the vendor's way to enable: then the gate lets it through
            compat.set_angle(1, 30, 20, 50, 1)
            compat.position_done(1)
        finally:
            compat._bus = None
    assert [f.arbitration_id for f in _motion(idle.frames)] == [0x3A]  # the one move, after set_mode


def test_closing_the_bus_sends_the_pending_stop(idle: Idle) -> None:
    with idle.open() as bus:  # stop_on_close=False: only the timed stop can end the speed
        bus.motor(1).set_speed(30, duration=60, enable=True)
        bus.run(sleep(0.5))
    assert idle.sim.motors[1].param("axis0.current_state") == 8  # still enabled: nothing idled it
    with drempower.open_bus("sim", bus=idle.sim, clock="virtual", stop_on_close=False) as later:
        later.run(sleep(1.0))
        assert idle.sim.motors[1].speed == pytest.approx(0, abs=1)
