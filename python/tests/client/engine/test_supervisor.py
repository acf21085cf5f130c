"""The health supervisor on the virtual clock: it warns before the firmware derates or trips, acts per joint,
catches stalls before the firmware's stall protection, names faults with their fix, at a bounded bus cost."""

from __future__ import annotations

from pathlib import Path

import pytest

import drempower
from drempower.client.engine.supervisor import FRAMES_PER_MOTOR, HealthEvent, HealthPolicy
from drempower.errors import ConfigError, ValidationError
from drempower.protocol import AxisState, ParamValue, State, decode_reply
from drempower.protocol.ids import Frame
from drempower.robotfile import load_robot
from drempower.sim import SimBus


def _sim(bus: drempower.Bus) -> SimBus:
    sim = bus.transport.bus  # type: ignore[attr-defined]
    assert isinstance(sim, SimBus)
    return sim


def _run(bus: drempower.Bus, policy: HealthPolicy, ids: list[int], seconds: float) -> list[tuple[HealthEvent, float]]:
    """Supervise for ``seconds`` at the policy's period; each event with the motor's winding temperature then."""
    sim = _sim(bus)
    watches = bus.watch_health(ids, policy)
    out = []
    for _ in range(round(seconds / policy.period)):
        for e in bus.supervise(watches):
            out.append((e, sim.motors[e.motor].thermal.winding))
        bus.pass_time(policy.period)
    return out


def test_it_warns_then_idles_or_only_warns_per_joint_before_the_firmware_derates() -> None:
    with drempower.open_bus("sim", motors=[1, 2], clock="virtual") as bus:
        sim = _sim(bus)
        for m in sim.motors.values():
            m.external_torque = -4.9  # a load held for minutes
            m.thermal.winding = 76.0
        events = _run(bus, HealthPolicy(joints={1: "idle"}), [1, 2], 200.0)
        kinds = {n: [(e.kind, e.action) for e, _ in events if e.motor == n] for n in (1, 2)}
        assert kinds[1][:2] == [("hot", "none"), ("overheat", "idle")]
        assert kinds[2][:2] == [("hot", "none"), ("overheat", "none")]
        for e, t in events:
            if e.kind == "hot":
                assert 80.0 <= t < 81.0  # at warn_c, one period late at most
            if e.kind == "overheat":
                assert 90.0 <= t < 91.0  # 5 K before the firmware's 95 degC derating
                assert "winding" in e.message and f"motor {e.motor}" in str(e)
        assert sim.motors[1].state == AxisState.IDLE  # released before it ever derated or tripped
        assert sim.motors[1].thermal.winding < 91.0
        assert sim.motors[1].errors[30001] == 0
        assert sim.motors[2].state == AxisState.CLOSED_LOOP_CONTROL  # "warn": left running, still heating
        assert sim.motors[2].thermal.winding > sim.motors[1].thermal.winding + 3.0


def test_hold_stops_the_motion_in_closed_loop() -> None:
    with drempower.open_bus("sim", motors=[1], clock="virtual") as bus:
        sim = _sim(bus)
        bus.motor(1).set_speed(30.0)
        sim.motors[1].thermal.winding = 92.0
        (event,) = [e for e, _ in _run(bus, HealthPolicy(on_overheat="hold"), [1], 2.0)]
        assert (event.kind, event.action) == ("overheat", "hold")
        assert sim.motors[1].state == AxisState.CLOSED_LOOP_CONTROL
        assert abs(sim.motors[1].speed) < 0.5


def test_a_stall_is_caught_and_acted_on_before_the_firmware_trips() -> None:
    """The shaft blocked, a far target: torque at its 12 Nm limit. The firmware's stall protection trips after
    2 s above 10 A; the supervisor (0.5 s, period 0.1 s) idles the joint first."""
    with drempower.open_bus("sim", motors=[1], clock="virtual") as bus:
        sim = _sim(bus)
        sim.motors[1].locked = True
        bus.motor(1).set_angle(90.0, 0.0, 20.0, 0)
        events = _run(bus, HealthPolicy(period=0.1, stall_s=0.5, on_stall="idle"), [1], 3.0)
        (stall,) = [e for e, _ in events if e.kind == "stall"]
        assert stall.action == "idle" and "12.00 Nm" in stall.message
        assert 0.5 <= stall.at <= 0.8
        assert sim.motors[1].state == AxisState.IDLE
        assert sim.motors[1].errors[33001] == 0  # no STALL_LIMIT_VIOLATION: the firmware never had to trip


def test_a_fault_names_the_motor_the_error_and_its_fix() -> None:
    with drempower.open_bus("sim", motors=[1, 2], clock="virtual") as bus:
        sim = _sim(bus)
        sim.motors[2].thermal.board = 100.5  # beyond the upper limit: the firmware trips
        bus.pass_time(0.02)
        events = [e for e, _ in _run(bus, HealthPolicy(), [1, 2], 1.0)]
    faults = [e for e in events if e.kind == "fault"]
    assert {e.motor for e in faults} == {2}
    (fet,) = [e for e in faults if "fet_thermistor" in e.message]
    assert fet.level == "error" and "OVER_TEMP" in fet.message and fet.fix
    assert str(fet).startswith("motor 2: axis0.fet_thermistor.error OVER_TEMP") and "Fix:" in str(fet)


def test_one_step_costs_twelve_frames_per_motor() -> None:
    with drempower.open_bus("sim", motors=[1, 2, 3], clock="virtual") as bus:
        frames: list[Frame] = []
        watches = bus.watch_health([1, 2, 3])
        bus.supervise(watches)  # the first step also reads each motor's limits
        _sim(bus).add_listener(frames.append)
        bus.supervise(watches)
        bus.supervise(watches)
    replies = [decode_reply(f.arbitration_id, f.data) for f in frames]
    assert len(replies) == 2 * 3 * FRAMES_PER_MOTOR // 2  # one reply per request: half the frames
    assert sum(isinstance(r, State) for r in replies) == 6
    assert sum(isinstance(r, ParamValue) for r in replies) == 30
    assert FRAMES_PER_MOTOR == 12


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"period": 0.0}, "period"),
        ({"on_overheat": "shutdown"}, "on_overheat"),
        ({"stall_fraction": 1.5}, "stall_fraction"),
        ({"joints": {1: "cool"}}, "on_overheat of motor 1"),
    ],
)
def test_a_bad_policy_is_refused_naming_the_field(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(ValidationError, match=field):
        HealthPolicy(**kwargs)  # type: ignore[arg-type]


def _robot(tmp_path: Path, health: str, joint_extra: str = "") -> Path:
    p = tmp_path / "robot.toml"
    p.write_text(
        '[buses.can0]\ninterface = "sim"\n'
        f'[joints.a]\nbus = "can0"\nid = 1\n{joint_extra}\n'
        '[joints.b]\nbus = "can0"\nid = 2\n'
        f"{health}\n"
    )
    return p


def test_the_robot_file_opts_in_and_sets_the_action_per_joint(tmp_path: Path) -> None:
    path = _robot(tmp_path, '[health]\nperiod = 1.0\non_overheat = "hold"', 'on_overheat = "idle"')
    with drempower.open_robot(path, sim={"clock": "virtual"}) as robot:
        policy = robot.health_policy()
        assert policy is not None
        assert policy.overheat_action(1) == "idle" and policy.overheat_action(2) == "hold"
        sim = robot.bus("can0").transport.bus  # type: ignore[attr-defined]
        for m in sim.motors.values():
            m.thermal.winding = 92.0
        events = robot.supervise()
        assert {(e.joint, e.kind, e.action) for e in events} == {("a", "overheat", "idle"), ("b", "overheat", "hold")}
        assert sim.motors[1].state == AxisState.IDLE
        assert sim.motors[2].state == AxisState.CLOSED_LOOP_CONTROL
    with drempower.open_robot(_robot(tmp_path, ""), sim={"clock": "virtual"}) as robot:
        assert robot.health_policy() is None
        with pytest.raises(ValidationError, match=r"no \[health\] section"):
            robot.supervise()


@pytest.mark.parametrize(
    ("health", "joint", "message"),
    [
        ("[health]\nperiod = 0.01", "", r"\[health\]: period=0.01: expected 0.05..60.0"),
        ('[health]\non_overheat = "off"', "", r"on_overheat='off': expected one of 'warn', 'hold', 'idle'"),
        ("[health]\ncolour = 1", "", r"unknown key 'colour'"),
        ("", 'on_overheat = "melt"', r"\[joints.a\]: on_overheat='melt'"),
    ],
)
def test_a_bad_health_section_names_the_file_the_key_and_the_range(
    tmp_path: Path, health: str, joint: str, message: str
) -> None:
    with pytest.raises(ConfigError, match=message):
        load_robot(_robot(tmp_path, health, joint))
