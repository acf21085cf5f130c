"""``drempower calibrate`` and ``drempower dfu`` against the simulator: confirmation, progress, the result
with decoded errors, Ctrl-C, and the frames sent."""

from __future__ import annotations

import pytest

from drempower.cli import _confirm, calibrate
from drempower.protocol import AxisState, Frame
from drempower.sim import SimBus
from drempower.sim.defaults import MotorModel

from .conftest import Cli


def _requested_states(frames: list[Frame], node: int) -> list[int]:
    """Values written to axis0.requested_state (30003 = 0x7533) of ``node``."""
    return [
        int.from_bytes(f.data[4:8], "little")
        for f in frames
        if f.arbitration_id == (node << 5) | 0x1F and f.data[:2] == b"\x33\x75"
    ]


def test_full_calibration_with_progress_and_result(cli: Cli, sim: SimBus, host_frames: list[Frame]) -> None:
    r = cli("calibrate", "1", "--yes", "--sim", "1")
    assert r.code == 0, r.err
    assert r.err.splitlines() == [
        "motor 1: motor calibration (phase resistance and inductance; the motor beeps)...",
        "motor 1: encoder offset calibration (the shaft turns slowly, forward and back)...",
    ]
    assert r.out.startswith("motor 1: calibration done in ")
    assert "(motor calibrated: yes, encoder offset calibrated: yes)" in r.out
    assert "`drempower save 1 --sim 1` keeps it" in r.out and "`drempower enable 1 --sim 1` to use it" in r.out
    assert _requested_states(host_frames, 1) == [AxisState.FULL_CALIBRATION_SEQUENCE]
    assert sim.motors[1].state is AxisState.IDLE


def test_only_the_encoder_phase_json_and_save(cli: Cli, sim: SimBus, host_frames: list[Frame]) -> None:
    (rec,) = cli("calibrate", "2", "--only", "encoder", "--save", "--yes", "--json", "--sim", "2").records()
    assert rec["ok"] is True and rec["sequence"] == "encoder" and rec["saved"] is True and rec["errors"] == []
    assert _requested_states(host_frames, 2) == [AxisState.ENCODER_OFFSET_CALIBRATION]
    assert any(f.arbitration_id == (2 << 5) | 0x08 and f.data[0] == 0x01 for f in host_frames)  # save_config


def test_low_supply_fails_with_decoded_errors(cli: Cli, sim: SimBus) -> None:
    sim.motors[1].model = MotorModel(vbus=9.0)
    r = cli("calibrate", "1", "--yes", "--sim", "1")
    assert r.code == 1
    assert r.out.startswith("motor 1: calibration failed after ")
    assert "axis0.motor.error: PHASE_RESISTANCE_OUT_OF_RANGE" in r.out
    assert "axis0.error: DC_BUS_UNDER_VOLTAGE" in r.out and "what to do:" in r.out
    assert "encoder offset calibration" not in r.err  # the sequence stopped at the motor phase
    cli("clear", "1", "--sim", "1")
    r = cli("calibrate", "1", "--only", "motor", "--yes", "--json", "--sim", "1")
    (rec,) = r.records()
    assert r.code == 1 and rec["ok"] is False and rec["saved"] is False
    assert {(e["word"], e["flag"]) for e in rec["errors"]} == {
        ("axis0.error", "MOTOR_FAILED"),
        ("axis0.error", "DC_BUS_UNDER_VOLTAGE"),
        ("axis0.motor.error", "PHASE_RESISTANCE_OUT_OF_RANGE"),
    }


def test_refused_while_the_motor_reports_errors(cli: Cli, sim: SimBus, host_frames: list[Frame]) -> None:
    cli("stop", "1", "--sim", "1")
    r = cli("calibrate", "1", "--yes", "--sim", "1")
    assert r.code == 1 and "`drempower clear 1 --sim 1` first" in r.err
    assert _requested_states(host_frames, 1) == []


def test_confirmation(cli: Cli, sim: SimBus, host_frames: list[Frame], monkeypatch: pytest.MonkeyPatch) -> None:
    r = cli("calibrate", "1", "--sim", "1")  # no terminal, no --yes
    assert r.code == 2 and "needs confirmation: give --yes (no terminal to ask on)" in r.err
    monkeypatch.setattr(_confirm, "is_terminal", lambda stream: True)
    asked: list[str] = []
    monkeypatch.setattr("builtins.input", lambda prompt: asked.append(prompt) or "n")
    r = cli("calibrate", "1", "--sim", "1")
    assert r.code == 1 and "cancelled; nothing was sent" in r.err
    assert "the shaft will turn, so it must be free and unloaded" in asked[0]
    assert host_frames == []
    monkeypatch.setattr("builtins.input", lambda prompt: "y")
    assert cli("calibrate", "1", "--only", "motor", "--sim", "1").code == 0


def test_ctrl_c_sets_the_motor_idle(
    cli: Cli, sim: SimBus, host_frames: list[Frame], monkeypatch: pytest.MonkeyPatch
) -> None:
    def interrupt(seconds: float) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(calibrate.time, "sleep", interrupt)
    r = cli("calibrate", "1", "--yes", "--sim", "1")
    assert r.code == 130 and "drempower: motor 1 set to idle" in r.err
    assert _requested_states(host_frames, 1) == [AxisState.FULL_CALIBRATION_SEQUENCE, AxisState.IDLE]
    assert sim.motors[1].state is AxisState.IDLE


def test_dfu_sends_enter_dfu_mode_and_says_what_next(cli: Cli, sim: SimBus, host_frames: list[Frame]) -> None:
    r = cli("dfu", "2", "--yes", "--sim", "2")
    assert r.code == 0
    assert host_frames[-1] == Frame(0x048, bytes.fromhex("0700000000000000"))  # sys 0x07 to motor 2
    assert "firmware-update mode requested" in r.out and "vendor's updater" in r.out
    assert "`drempower calibrate 2 --sim 2`" in r.out  # with the connection options, ready to paste
    assert sim.motors[2].in_dfu  # silent from now on, as the message says
    assert cli("state", "2", "--sim", "2", "--timeout", "0.2").code == 1
    (rec,) = cli("dfu", "3", "--yes", "--json", "--sim", "3").records()
    assert rec == {"id": 3, "broadcast": False, "command": "enter_dfu_mode", "sent": True}


def test_dfu_next_step_carries_the_connection_options(cli: Cli, sim: SimBus) -> None:
    r = cli("dfu", "1", "--yes", "--sim", "1", "--timeout", "0.3", "--retries", "2")
    assert r.code == 0
    assert "`drempower calibrate 1 --sim 1 --timeout 0.3 --retries 2`" in r.out, r.out


@pytest.mark.parametrize("target", ["0", "all"])
def test_dfu_refuses_broadcast(cli: Cli, sim: SimBus, host_frames: list[Frame], target: str) -> None:
    r = cli("dfu", target, "--yes", "--sim", "1")
    assert r.code == 2 and "is broadcast: firmware-update mode is entered one motor at a time" in r.err
    assert host_frames == []


def test_dfu_needs_confirmation_and_an_answering_motor(cli: Cli, sim: SimBus, host_frames: list[Frame]) -> None:
    assert cli("dfu", "1", "--sim", "1").code == 2 and host_frames == []
    r = cli("dfu", "5", "--yes", "--sim", "1", "--timeout", "0.2")
    assert r.code == 1 and "motor 5: no answer" in r.err
    assert not any(f.data[:1] == b"\x07" for f in host_frames)


def test_max_time_gives_up_and_sets_the_motor_idle(cli: Cli, sim: SimBus, host_frames: list[Frame]) -> None:
    r = cli("calibrate", "3", "--yes", "--max-time", "0.05", "--sim", "3")
    assert r.code == 1 and "calibration still running after 0.05 s" in r.err and "it was set idle" in r.err
    assert _requested_states(host_frames, 3) == [AxisState.FULL_CALIBRATION_SEQUENCE, AxisState.IDLE]
    assert sim.motors[3].state is AxisState.IDLE


def test_a_running_clock_on_a_terminal(cli: Cli, sim: SimBus, monkeypatch: pytest.MonkeyPatch) -> None:
    from drempower.cli import _output

    monkeypatch.setattr(_output, "is_terminal", lambda stream: True)
    r = cli("calibrate", "1", "--only", "motor", "--yes", "--sim", "1")
    assert r.code == 0 and "\r\x1b[K  0 s" in r.err
