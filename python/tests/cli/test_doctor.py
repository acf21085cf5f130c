"""``drempower doctor`` against each simulated firmware profile: it reports exactly the profile's knobs."""

from __future__ import annotations

import itertools
import json
from pathlib import Path
from typing import Any

import pytest

import drempower
from drempower.cli import main
from drempower.client.api.profile import load_profile
from drempower.sim import SimBus, firmware
from drempower.sim.firmware import Firmware

_channels = itertools.count()

# Every knob doctor can measure, in every reading, spread over three profiles (factory_id: not measurable).
PROFILES = [
    Firmware(),
    Firmware(status_bits="kept", boot_s=0.55, reply_state="control", q_time_zero="ignore", heartbeat=False),
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
def test_doctor_reports_the_profile(fw: Firmware, capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    prof = tmp_path / "fw.json"
    code, lines, err = _doctor(
        capsys, "1,2", "--sim", "1,2", *_knob_options(fw), "--yes", "--reboot", "--write-profile", str(prof)
    )
    assert code == 0, err
    assert "can move a joint" in err  # the moving probes were listed first
    motors, bus = lines[:-1], lines[-1]
    assert [m["id"] for m in motors] == [1, 2] and bus["bus"] is True and bus["other_hosts"] is False
    want = fw.to_json()
    for m in motors:
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
