"""``drempower replay`` passes the safety gate: a log's own enables need ``--enable``, and its commands
are held to the bus's soft limits (checked whole before the first is sent, then each as it goes)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from drempower.protocol import Velocity, WriteParam
from drempower.protocol.enums import AxisState
from drempower.protocol.ids import Frame
from drempower.sim import SimBus

from ..cli.conftest import Cli

VEL = "axis0.output_shaft.input_vel"


def _line(t: float, f: Frame) -> str:
    return f"({t:.6f}) can0 {f.arbitration_id:03X}#{f.data.hex().upper()} T\n"


def _log(path: Path, speed: float = 200.0) -> Path:
    path.write_text(
        _line(0.0, WriteParam.of(1, "axis0.requested_state", 8).encode())
        + _line(0.01, Velocity(1, speed).encode())
        + _line(0.2, Velocity(1, 0.0).encode())
    )
    return path


def test_a_log_that_enables_a_motor_itself_needs_enable(cli: Cli, sim: SimBus, tmp_path: Path) -> None:
    log = _log(tmp_path / "run.log", 20.0)
    assert cli("idle", "1", "--sim", "1").code == 0
    r = cli("replay", str(log), "--sim", "1")
    assert r.code == 1 and "the log enables motors 1 itself; replay with --enable to let it" in r.err, r.err
    assert sim.motors[1].state == AxisState.IDLE and sim.motors[1].param(VEL) == 0
    r = cli("replay", str(log), "--enable", "--sim", "1")
    assert r.code == 0 and "3 frames replayed" in r.err, r.err


def test_a_log_beyond_the_soft_limits_is_refused_before_it_starts(
    cli: Cli, sim: SimBus, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from drempower.cli import replay

    opened = replay.open_from_args

    def limited(*args: Any, **kw: Any) -> Any:
        bus = opened(*args, **kw)
        bus.set_limits(1, speed=9.55, where="joint 'j1' limits")
        return bus

    monkeypatch.setattr(replay, "open_from_args", limited)
    r = cli("replay", str(_log(tmp_path / "fast.log")), "--enable", "--sim", "1")
    assert r.code == 2 and "motor 1: speed 200 r/min is beyond its soft limit -9.55..9.55 r/min" in r.err, r.err
    assert sim.motors[1].param(VEL) == 0 and abs(sim.motors[1].speed) < 1
