"""A CAN watchdog left armed (a ``--watchdog`` command killed with SIGKILL) is noticed by the next command."""

from __future__ import annotations

from drempower.sim import SimBus

from .conftest import Cli

_TIMEOUT = "can.config.timeout_ms"


def test_enable_and_motion_commands_warn_of_a_leftover_watchdog(cli: Cli, sim: SimBus) -> None:
    r = cli("enable", "1", "--sim", "1")
    assert r.code == 0 and "warning" not in r.err  # none armed: nothing said
    assert cli("set", "2", _TIMEOUT, "150", "--sim", "2").code == 0  # what a killed --watchdog 150 leaves
    r = cli("enable", "1,2", "--sim", "1,2")  # then idles 150 ms after its last frame (here, while it checks)
    assert "drempower: warning: motor 2 has can.config.timeout_ms = 150: it goes idle 150 ms after" in r.err
    assert "`drempower set 2 can.config.timeout_ms 0 --sim 1,2`" in r.err and "motor 1 has" not in r.err
    r = cli("speed", "2", "5", "--duration", "0.05", "--sim", "2")
    assert "motor 2 has can.config.timeout_ms = 150" in r.err, r.err
    assert sim.motors[2].param(_TIMEOUT) == 150  # reported, never changed: it may be deliberate
    r = cli("speed", "2", "5", "--duration", "0.05", "--watchdog", "300", "--sim", "2")
    assert "motor 2 has can.config.timeout_ms" not in r.err  # the command's own watchdog is no leftover
