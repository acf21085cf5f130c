"""``drempower doctor`` against each simulated firmware profile: it reports exactly the profile's knobs."""

from __future__ import annotations

import itertools
import json
from pathlib import Path
from typing import Any, ClassVar

import pytest

import drempower
from drempower.cli import main
from drempower.client.api.profile import load_profile
from drempower.protocol.addresses import AXIS0_CONFIG_CAN_NODE_ID as NODE_ID
from drempower.protocol.addresses import AXIS0_CONTROLLER_CONFIG_VEL_LIMIT as VEL_LIMIT
from drempower.protocol.ids import SysCmd
from drempower.sim import SimBus, firmware
from drempower.sim import motor as sim_motor
from drempower.sim.firmware import Firmware
from drempower.transports import sim as sim_transport

_channels = itertools.count()
OWN_VEL_LIMIT = 123.0

# Every knob doctor can measure, in every reading, spread over three profiles. factory_id: None (the id
# each motor was made with), another id; without the fast read no backup, so it is not measured (None).
PROFILES = [
    Firmware(),
    Firmware(
        status_bits="kept", boot_s=0.55, reply_state="control", q_time_zero="ignore", heartbeat=False, factory_id=9
    ),
    Firmware(status_bits="zero", boot_s=1.2, reply_state="all", fast_read=False, heartbeat=True),
]


def _doctor(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, list[dict[str, Any]], str]:
    code = main(["doctor", *argv, "--json"])
    out, err = capsys.readouterr()
    return code, [json.loads(line) for line in out.splitlines()], err


def _knob_options(fw: Firmware) -> list[str]:
    opts = ["-o", "clock=virtual"]
    for k, v in fw.to_json().items():
        if v is not None:
            opts += ["-o", f"{k}={str(v).lower() if isinstance(v, bool) else v}"]
    return opts


@pytest.mark.parametrize("fw", PROFILES, ids=["defaults", "kept", "zero-all-no-fast-read"])
def test_doctor_reports_the_profile(
    fw: Firmware, capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    prof = tmp_path / "fw.json"
    monkeypatch.chdir(tmp_path)  # where --factory-id keeps its backups until the motors are verified
    code, lines, err = _doctor(
        capsys,
        "1,2",
        "--sim",
        "1,2",
        *_knob_options(fw),
        "--yes",
        "--reboot",
        "--factory-id",
        "--write-profile",
        str(prof),
    )
    assert code == 0, err
    assert "can move a joint" in err  # the moving probes were listed first
    motors, bus = lines[:-1], lines[-1]
    assert [m["id"] for m in motors] == [1, 2] and bus["bus"] is True and bus["other_hosts"] is False
    for m in motors:
        want = fw.to_json()
        if fw.fast_read:  # measured: an id, the motor's own for None (the sim's word for "the id it was made with")
            want["factory_id"] = fw.factory_id or m["id"]
        assert {k: v for k, v in m["knobs"].items() if k != "boot_s"} == {
            k: v for k, v in want.items() if k != "boot_s"
        }
        assert m["knobs"]["boot_s"] == pytest.approx(fw.boot_s, abs=0.02)  # polled every 10 ms
        assert m["boot_s"] == m["knobs"]["boot_s"]
        assert m["firmware"] == 21 and m["hardware"] == 2
        ids = [int(x, 16) for x in m["status_ids"]]
        expected_count = (1 if fw.fast_read else 0) + 1 + (0 if fw.reply_state == "control" else 1)
        assert len(ids) == expected_count
        assert all((c & 0x18 != 0) == (fw.status_bits == "kept") for c in ids)
        sections = {f["item"]: f["section"] for f in m["findings"]}
        assert sections["status_bits"] == "1.6" and sections["boot_s"] == "3.3" and sections["q_time_zero"] == "3.4.3"
        assert sections["factory_id"] == "3.8"
        assert "failed" not in m
    assert list(tmp_path.glob("doctor-motor*-backup.json")) == []  # removed once each motor was verified
    saved = load_profile(prof)
    assert saved.status_bits == fw.status_bits
    assert saved.motors[1]["firmware"] == 21


def test_doctor_without_yes_or_reboot_moves_nothing(capsys: pytest.CaptureFixture[str]) -> None:
    code, lines, err = _doctor(capsys, "--sim", "1", "-o", "clock=virtual", "-o", "status_bits=kept")
    assert code == 0 and "can move a joint" not in err
    (m,) = lines[:-1]
    assert m["status_ids"] == ["0x1b"] and m["knobs"]["status_bits"] == "kept"
    assert "boot_s" not in m and m["knobs"]["q_time_zero"] is None
    assert any("--yes" in f["text"] for f in m["findings"])
    assert m["knobs"]["factory_id"] is None
    (fid,) = [f for f in m["findings"] if f["item"] == "factory_id"]
    assert fid["section"] == "3.8" and "not measured" in fid["text"] and "--yes --factory-id" in fid["text"]


def test_doctor_text_output(capsys: pytest.CaptureFixture[str]) -> None:
    bits = firmware.DEFAULT.status_bits  # zero, or kept in the second pass of make test
    assert main(["doctor", "--sim", "3", "-o", "clock=virtual"]) == 0
    out = capsys.readouterr().out
    fast = "0x03" if bits == "zero" else "0x1b"
    assert out.startswith(f"motor 3: firmware 21, hardware 2, status ids {fast}\n")
    assert f"[1.6] status_bits: bits 3-4 of the state frames: {bits} ({fast})" in out


def test_doctor_on_a_bus_with_no_motor_exits_1_in_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    channel = f"drempower-doctor-empty-{next(_channels)}"
    code = main(["doctor", "-i", "virtual", "-c", channel, "--timeout", "0.05"])
    out, err = capsys.readouterr()
    assert code == 1 and out == ""
    assert len(err.strip().splitlines()) == 1 and "no motor answered" in err


def test_doctor_motor_absent_exits_1(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["doctor", "7", "--sim", "1", "-o", "clock=virtual"])
    err = capsys.readouterr().err
    assert code == 1 and "no motor answered (motor 7)" in err


def test_written_profile_is_taken_by_open_bus(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """doctor --write-profile on kept-bits firmware, then a client told the profile: motor 1 keeps the bits."""
    prof = tmp_path / "p.json"
    assert (
        main(["doctor", "--sim", "1", "-o", "clock=virtual", "-o", "status_bits=kept", "--write-profile", str(prof)])
        == 0
    )
    capsys.readouterr()
    assert json.loads(prof.read_text())["status_bits"] == "kept"
    with drempower.open_bus("sim", bus=SimBus([1], status_bits="kept"), clock="virtual", profile=str(prof)) as bus:
        assert bus._session.inbox.bits.of(1) == "kept"
        assert bus.motor(1).get_state().node == 1


def test_sim_option_errors_name_the_knob(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["doctor", "--sim", "1", "-o", "status_bits=odd"])
    err = capsys.readouterr().err
    assert code in (1, 2) and "status_bits='odd'" in err and len(err.strip().splitlines()) == 1


def test_cli_profile_option(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """--profile FILE: a good one is taken (a state read works), a bad one exits 2 naming the key."""
    good, bad = tmp_path / "good.json", tmp_path / "bad.json"
    good.write_text(json.dumps({"profile": 1, "status_bits": firmware.DEFAULT.status_bits}))
    bad.write_text('{"profile": 1, "status_bits": "maybe"}')
    assert main(["state", "1", "--sim", "1", "--profile", str(good)]) == 0
    capsys.readouterr()
    assert main(["state", "1", "--sim", "1", "--profile", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "status_bits='maybe'" in err and len(err.strip().splitlines()) == 1


class _Recorded(SimBus):
    """A SimBus that remembers itself and gives every motor a configuration of its own (saved): a
    velocity limit of OWN_VEL_LIMIT, not the factory one."""

    made: ClassVar[list[SimBus]] = []

    def __init__(self, *a: Any, **kw: Any) -> None:
        super().__init__(*a, **kw)
        _Recorded.made.append(self)
        for m in self.motors.values():
            m.params.ram[VEL_LIMIT] = OWN_VEL_LIMIT
            m.params.save()


@pytest.fixture
def recorded(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> type[_Recorded]:
    monkeypatch.setattr(sim_transport, "SimBus", _Recorded)
    monkeypatch.setattr(_Recorded, "made", [])
    monkeypatch.chdir(tmp_path)
    return _Recorded


@pytest.mark.parametrize(("factory", "want"), [(None, 3), (3, 3), (12, 12)], ids=["none", "own-id", "other-id"])
def test_factory_id_probe_measures_and_puts_the_motor_back(
    factory: int | None, want: int, recorded: type[_Recorded], capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """--yes --factory-id reports the factory id exactly; the motor ends at its own id (3) with its own
    configuration (the velocity limit it was given, not the factory one), in RAM and saved."""
    opts = ["-o", "clock=virtual"] + ([] if factory is None else ["-o", f"factory_id={factory}"])
    code, lines, err = _doctor(capsys, "3", "--sim", "3,4", *opts, "--yes", "--factory-id")
    assert code == 0, err
    assert "--factory-id: init_config on each motor" in err  # listed before it ran
    (m,) = lines[:-1]
    assert m["knobs"]["factory_id"] == want
    steps = [f["text"] for f in m["findings"] if f["item"] == "factory_id"]
    assert f"after the boot it answers at id {want}: the factory id" in steps
    assert steps[-1].startswith("rebooted: answers at id 3, configuration as backed up")
    (sim,) = recorded.made
    motor = sim.motors[3]
    assert motor.node_id == 3 and not motor.booting
    assert motor.params.ram[VEL_LIMIT] == OWN_VEL_LIMIT != motor.params.factory[VEL_LIMIT]
    assert motor.params.saved is not None and motor.params.saved[VEL_LIMIT] == OWN_VEL_LIMIT
    assert motor.params.saved[NODE_ID] == 3
    assert sim.motors[4].node_id == 4  # the other motor untouched
    assert not (tmp_path / "doctor-motor3-backup.json").exists()


def test_factory_id_needs_yes(recorded: type[_Recorded], capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["doctor", "--sim", "1", "-o", "clock=virtual", "--factory-id"])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err  # reported as argparse reports its own errors
    assert (
        err.strip()
        .splitlines()[-1]
        .endswith("error: --factory-id: needs --yes (it replaces the configuration, then restores it)")
    )
    assert recorded.made == []  # refused before the bus was opened


def test_factory_id_motor_silent_after_init_reports_state_and_exits_1(
    recorded: type[_Recorded], capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A motor that stops answering once it took the factory configuration: exit 1, the steps done, the
    state (answers at no id) and how to recover, the backup kept for it."""
    init_config = sim_motor._SYSTEM[SysCmd.INIT_CONFIG]

    def then_silent(m: Any) -> None:  # the motor obeys init_config, then falls silent
        init_config(m)
        recorded.made[0].faults.silent.add(m.ident)

    monkeypatch.setitem(sim_motor._SYSTEM, SysCmd.INIT_CONFIG, then_silent)
    code, lines, err = _doctor(
        capsys, "1", "--sim", "1", "-o", "clock=virtual", "-o", "factory_id=5", "--yes", "--factory-id"
    )
    assert code == 1 and "motor 1: the factory-id probe failed" in err
    (m,) = lines[:-1]
    assert m["failed"] is True and m["knobs"]["factory_id"] is None
    steps = [f["text"] for f in m["findings"] if f["item"] == "factory_id"]
    backup = "doctor-motor1-backup.json"
    assert steps[0].startswith("backed up motor 1 (") and backup in steps[0]
    assert steps[-1].startswith("FAILED: motor 1 answers at no id 1-63")
    assert f"drempower restore ID ./{backup} --include-link --force --save" in steps[-1]
    assert (tmp_path / backup).exists()  # kept for the recovery
    (sim,) = recorded.made
    assert sim.motors[1].node_id == 5  # where it really is (silent): the finding did not claim otherwise


def test_factory_id_of_another_motor_reports_the_shared_id(
    recorded: type[_Recorded], capsys: pytest.CaptureFixture[str]
) -> None:
    """Motor 2 whose factory id is 1, with motor 1 on the bus: it takes id 1 and both answer there. The
    probe stops before writing anything to id 1, says so, and exits 1."""
    code, lines, _ = _doctor(
        capsys, "2", "--sim", "1,2", "-o", "clock=virtual", "-o", "factory_id=1", "--yes", "--factory-id"
    )
    assert code == 1
    (m,) = lines[:-1]
    last = [f["text"] for f in m["findings"] if f["item"] == "factory_id"][-1]
    assert last.startswith("FAILED: motor 2 answers at no free id; id 1 now answers twice")
    assert "disconnect motor 1" in last
    (sim,) = recorded.made
    assert sim.motors[1].params.ram[VEL_LIMIT] == OWN_VEL_LIMIT  # motor 1 was not written


def test_factory_id_probe_interrupted_says_where_the_motor_is(
    recorded: type[_Recorded], capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Ctrl-C once init_config was obeyed: no record is printed, so stderr says what was done and how to
    recover, and the backup is kept."""
    init_config = sim_motor._SYSTEM[SysCmd.INIT_CONFIG]

    def then_interrupt(m: Any) -> None:
        init_config(m)
        raise KeyboardInterrupt

    monkeypatch.setitem(sim_motor._SYSTEM, SysCmd.INIT_CONFIG, then_interrupt)
    code = main(["doctor", "1", "--sim", "1", "-o", "clock=virtual", "-o", "factory_id=5", "--yes", "--factory-id"])
    out, err = capsys.readouterr()
    assert code != 0 and out == ""
    assert "drempower: motor 1: factory-id probe interrupted (backed up motor 1 (" in err
    assert "recover: find the motor (`drempower scan`), then `drempower restore ID ./doctor-motor1-backup.json" in err
    assert (tmp_path / "doctor-motor1-backup.json").exists()
    assert recorded.made[0].motors[1].node_id == 5
