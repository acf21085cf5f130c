"""The dashboard's Parameters Set and its Actions view's ``set`` row pass the safety gate: a parameter
that commands motion beyond the motor's soft limits is refused in the library's words, nothing written."""

from __future__ import annotations

import pytest

from drempower import open_bus
from drempower.dash import Hub
from drempower.errors import MotionParameterError, SoftLimitError
from drempower.sim import SimBus

VEL, POS = "axis0.output_shaft.input_vel", "axis0.output_shaft.input_pos"


def test_parameters_set_and_the_set_row_are_gated() -> None:
    sim = SimBus(ids=[1])
    with open_bus("sim", bus=sim, stop_on_close=False) as bus:
        bus.enable([1])
        bus.set_limits(1, position=(-90, 90), speed=30, torque=1)
        hub = Hub(bus, poll_hz=5)
        try:
            with pytest.raises(SoftLimitError, match="motor 1: speed 200 r/min is beyond its soft limit"):
                hub.do_write_param("page A", 1, VEL, 200)
            with pytest.raises(MotionParameterError, match=r"motor 1: writing axis0\.controller\.config\.control_mode"):
                hub.do_write_param("page A", 1, "axis0.controller.config.control_mode", 2)
            row = {"action": "set", "args": {"id": 1, "name": POS, "value": 170, "force": True}}
            with pytest.raises(SoftLimitError, match="motor 1: position 170 deg is beyond its soft limit"):
                hub.do_row("page A", row)
            assert sim.motors[1].param(VEL) == 0 and sim.motors[1].param(POS) == 0
            assert abs(sim.motors[1].speed) < 1
        finally:
            hub.close()
