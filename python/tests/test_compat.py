"""drempower.compat: the vendor library's functions over a bus opened once."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

import drempower
from drempower import compat


@pytest.fixture
def sim() -> Iterator[None]:
    compat.open("sim", motors=[1, 2], clock="virtual", timeout=1.0)
    yield
    compat.close()


def test_vendor_script_runs(sim: None) -> None:
    assert compat.set_angle(1, 90, 60, 300, 1) is True
    assert compat.position_done(1) is True
    angle, speed = compat.get_state(1)
    assert (angle, speed) == (pytest.approx(90, abs=0.05), pytest.approx(0, abs=0.5))
    assert compat.set_angles([1, 2], [10, 20], 60, 300, 1) is not None
    assert compat.positions_done([1, 2]) is True
    assert compat.get_state(2)[0] == pytest.approx(20, abs=0.05)
    compat.step_angle(1, 5, 60, 300, 1)
    compat.position_done(1)
    assert compat.get_state(1)[0] == pytest.approx(15, abs=0.05)
    volts, amps = compat.get_volcur(1)
    assert volts == round(volts, 1) and amps == round(amps, 2)
    assert compat.get_id(2) == 2
    compat.write_property(1, "axis0.output_shaft.vel_limit", 120)
    assert compat.read_property(1, "axis0.output_shaft.vel_limit") == 120
    compat.set_traj_mode(1, 2)
    assert compat.read_property(1, 35104) == 2
    assert compat.get_GPIO_mode(1) in ([0, 0], [1, 0], [0, 1])
    compat.estop(2)
    assert compat.dump_error(2).flags == {"axis0.error": ["ESTOP_REQUESTED"]}
    compat.clear_error(2)
    compat.set_mode(2, 2)
    assert not compat.dump_error(2)
    assert compat.set_speeds([1, 2], [10, 10]) is True
    assert compat.set_torques([1, 2], [0, 0]) is True
    assert compat.set_angle_range(1, -360, 360) is True
    compat.save_config(1)


def test_errors_raise_instead_of_printing(sim: None) -> None:
    with pytest.raises(drempower.ValidationError):
        compat.set_angle(1, 90, 0, 10, 1)  # the vendor prints "speed or accel <= 0" and returns None
    with pytest.raises(drempower.ValidationError):
        compat.set_angles([1, 2], [1], 10, 10, 1)  # the vendor silently does nothing
    with pytest.raises(drempower.TimeoutError):
        compat.get_state(9)


def test_no_bus_is_a_clear_error() -> None:
    compat.close()
    with pytest.raises(drempower.DrEmpowerError, match=r"compat\.open"):
        compat.get_state(1)
