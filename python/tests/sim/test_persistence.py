"""RAM vs saved configuration: save, erase, init, reboot, the JSON file, zero and multi-turn position."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from drempower.protocol import PositionQ, PresetP, ReadParam, SysCmd, SystemCommand
from drempower.sim import SimBus
from drempower.sim.behaviour import BOOT_SECONDS

from .helpers import exchange, read, write

GAIN = "axis0.controller.config.pos_gain"


def _sys(bus: SimBus, node: int, *ops: SysCmd) -> None:
    for op in ops:
        exchange(bus, SystemCommand(node, op))
        if op is SysCmd.REBOOT:
            bus.advance(BOOT_SECONDS + 0.001)  # silent while it boots


def test_unsaved_writes_are_lost_on_reboot_and_saved_ones_kept() -> None:
    bus = SimBus([1])
    write(bus, 1, GAIN, 25.0)
    _sys(bus, 1, SysCmd.REBOOT)
    assert read(bus, 1, GAIN) == 40.0
    write(bus, 1, GAIN, 25.0)
    _sys(bus, 1, SysCmd.SAVE_CONFIG)
    write(bus, 1, GAIN, 30.0)
    _sys(bus, 1, SysCmd.REBOOT)
    assert read(bus, 1, GAIN) == 25.0


def test_init_config_restores_defaults_in_ram_only() -> None:
    bus = SimBus([1])
    write(bus, 1, GAIN, 25.0)
    _sys(bus, 1, SysCmd.SAVE_CONFIG, SysCmd.INIT_CONFIG)
    assert read(bus, 1, GAIN) == 40.0
    _sys(bus, 1, SysCmd.REBOOT)
    assert read(bus, 1, GAIN) == 25.0


def test_erase_config_forgets_the_saved_configuration(tmp_path: Path) -> None:
    bus = SimBus([1], config_dir=tmp_path)
    write(bus, 1, GAIN, 25.0)
    _sys(bus, 1, SysCmd.SAVE_CONFIG)
    assert (tmp_path / "motor-1.json").exists()
    _sys(bus, 1, SysCmd.ERASE_CONFIG)
    assert not (tmp_path / "motor-1.json").exists()
    assert read(bus, 1, GAIN) == 25.0  # RAM untouched
    _sys(bus, 1, SysCmd.REBOOT)
    assert read(bus, 1, GAIN) == 40.0


def test_saved_configuration_survives_in_its_file(tmp_path: Path) -> None:
    bus = SimBus([1, 2], config_dir=tmp_path)
    write(bus, 2, "axis0.config.can_node_id", 7)
    write(bus, 7, GAIN, 12.5)
    _sys(bus, 7, SysCmd.SAVE_CONFIG)
    doc = json.loads((tmp_path / "motor-2.json").read_text())
    assert doc["parameters"][GAIN] == 12.5
    assert doc["parameters"]["axis0.config.can_node_id"] == 7
    again = SimBus([1, 2], config_dir=tmp_path)  # a power cycle of the whole bus
    assert again.motors[2].node_id == 7
    assert read(again, 7, GAIN) == 12.5
    assert read(again, 1, GAIN) == 40.0


def test_set_id_then_save_then_reboot() -> None:
    bus = SimBus([1])
    write(bus, 1, "axis0.config.can_node_id", 5)
    _sys(bus, 5, SysCmd.SAVE_CONFIG, SysCmd.REBOOT)
    assert read(bus, 5, "axis0.config.can_node_id") == 5
    assert exchange(bus, ReadParam.of(1, 31001)) == []


def test_position_survives_reboot_with_multi_turn_and_restarts_at_zero_without() -> None:
    bus = SimBus([1])
    m = bus.motors[1]
    exchange(bus, PositionQ(1, 500.0, 100.0, 300.0))
    bus.advance(2.0)
    _sys(bus, 1, SysCmd.REBOOT)
    bus.advance(0.1)
    assert m.position == pytest.approx(500.0, abs=0.05)
    write(bus, 1, "axis0.config.extra_setting.enable_multi_circle", 0)
    _sys(bus, 1, SysCmd.SAVE_CONFIG, SysCmd.REBOOT)
    assert m.position == pytest.approx(0.0, abs=1e-9)


def test_set_zero_position_keeps_the_shaft_still_and_is_saved(tmp_path: Path) -> None:
    bus = SimBus([1], config_dir=tmp_path)
    m = bus.motors[1]
    exchange(bus, PositionQ(1, 123.0, 100.0, 300.0))
    bus.advance(2.0)
    _sys(bus, 1, SysCmd.SET_ZERO_POSITION)
    assert m.position == pytest.approx(0.0, abs=1e-6)
    bus.advance(0.5)
    assert m.position == pytest.approx(0.0, abs=0.05) and abs(m.speed) < 0.1
    exchange(bus, PositionQ(1, 10.0, 100.0, 300.0))
    bus.advance(1.0)
    assert m.position == pytest.approx(10.0, abs=0.05)
    _sys(bus, 1, SysCmd.SAVE_CONFIG)
    again = SimBus([1], config_dir=tmp_path)
    assert read(again, 1, "axis0.config.extra_setting.zero_offset_counts") == pytest.approx(
        123.0 / 360 * 10 * 32768, rel=1e-3
    )


def test_reboot_clears_errors_and_pending_presets() -> None:
    bus = SimBus([1])
    m = bus.motors[1]
    exchange(bus, PresetP(1, 30.0), SystemCommand(1, SysCmd.ESTOP), SystemCommand(1, SysCmd.REBOOT))
    bus.advance(BOOT_SECONDS + 0.001)
    assert m.axis_error == 0 and m.preset is None
    assert read(bus, 1, "axis0.current_state") == 8
