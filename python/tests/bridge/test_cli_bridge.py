"""``drempower bridge`` as a process: serves, answers remote clients, stops on signals."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from drempower import open_bus

from .conftest import free_port

pytestmark = pytest.mark.timeout(60)


def _start(*extra: str) -> tuple[subprocess.Popen[str], str, str]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    prefix = f"cli{free_port()}"
    argv = [sys.executable, "-m", "drempower", "bridge", "--sim", "1,2", "--listen", endpoint]
    argv += ["--connect", f"tcp/127.0.0.1:{free_port()}", "--prefix", prefix, *extra]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stderr is not None
    line = proc.stderr.readline()
    assert "joint_states on 0/robot1/joint_states/sensor_msgs::msg::dds_::JointState_/RIHS01_" in line or (
        "joint_states on 0/joint_states/" in line
    ), line
    return proc, endpoint, prefix


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP, signal.SIGINT])
def test_bridge_serves_and_stops_on_signals(sig: signal.Signals) -> None:
    proc, endpoint, prefix = _start("--namespace", "/robot1")
    try:
        with open_bus("zenoh", prefix, connect=endpoint, gossip=False) as bus:
            assert bus.motor(2).get_state().node == 2
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=20)
        assert proc.returncode == 128 + sig, err  # as every command ended by a signal (docs/cli.md)
        assert "stopped" in err
        assert "Traceback" not in err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)


def test_json_says_where_everything_is() -> None:
    import json

    proc, _, prefix = _start("--json", "--namespace", "robot1")
    try:
        assert proc.stdout is not None
        record = json.loads(proc.stdout.readline())
        assert record["prefix"] == prefix
        assert record["node"] == "/robot1/drempower_bridge"
        assert record["joints"] == {"motor_1": 1, "motor_2": 2}
        assert record["joint_states"].startswith("0/robot1/joint_states/sensor_msgs::msg::dds_::JointState_/RIHS01_")
        assert record["estop"].startswith("0/robot1/estop/std_srvs::srv::dds_::Trigger_/RIHS01_eeff2cd6")
        assert record["position_commands"].startswith("0/robot1/position_commands/std_msgs::msg::dds_::")
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=20)
    assert proc.returncode == 128 + signal.SIGTERM


def test_usage_errors_exit_2() -> None:
    run = subprocess.run(
        [sys.executable, "-m", "drempower", "bridge", "--sim", "1", "--rate", "5000", "--connect", "tcp/127.0.0.1:1"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert run.returncode == 2
    assert "rate=5000.0: 0 < rate <= 1000 Hz" in run.stderr
    assert "Traceback" not in run.stderr
    t0 = time.monotonic()
    run = subprocess.run(
        [sys.executable, "-m", "drempower", "bridge", "-i", "virtual", "-c", "x", "--connect", "tcp/127.0.0.1:1"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert run.returncode == 2 and "--ids" in run.stderr
    run = subprocess.run(
        [sys.executable, "-m", "drempower", "bridge", "--sim", "1,2", "--ids", "2,5", "--connect", "tcp/127.0.0.1:1"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert run.returncode == 2 and "--ids: motors 5 are not simulated (--sim 1,2)" in run.stderr
    assert time.monotonic() - t0 < 30


def test_endpoints_are_checked() -> None:
    run = subprocess.run(
        [sys.executable, "-m", "drempower", "bridge", "--sim", "1", "--listen", "bogus"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert run.returncode == 2
    assert "argument --listen: 'bogus': a Zenoh endpoint is <protocol>/<address>" in run.stderr
    assert "Traceback" not in run.stderr


def test_a_basic_install_is_told_the_extra() -> None:
    hide = "import sys; sys.modules['zenoh'] = None; from drempower.cli import main; sys.exit(main(sys.argv[1:]))"
    run = subprocess.run(
        [sys.executable, "-c", hide, "bridge", "--sim", "1", "--connect", "tcp/127.0.0.1:1"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert run.returncode == 2, run.stderr
    assert run.stderr.count("\n") == 1 and "pip install 'drempower[bridge]'" in run.stderr, run.stderr
    assert "Traceback" not in run.stderr


def _json_start(*extra: str) -> tuple[subprocess.Popen[str], dict[str, Any]]:
    argv = [sys.executable, "-m", "drempower", "bridge", "--sim", "1,2", "--json", "--prefix", f"cli{free_port()}"]
    proc = subprocess.Popen([*argv, *extra], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    line = proc.stdout.readline()
    if not line:
        proc.wait(10)
        pytest.fail(f"the bridge did not start: {proc.stderr.read() if proc.stderr else ''}")
    return proc, json.loads(line)


def _end(proc: subprocess.Popen[str]) -> str:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=20)
    assert proc.returncode == 128 + signal.SIGTERM, err
    return err


def test_gossip_scouting_off_and_a_zenoh_config_file(tmp_path: Path) -> None:
    listen = f"tcp/127.0.0.1:{free_port()}"
    nowhere = f"tcp/127.0.0.1:{free_port()}"
    proc, record = _json_start("--connect", nowhere)
    _end(proc)
    assert record["zenoh"] == {
        "mode": "peer",
        "connect": [nowhere],
        "listen": [],
        "multicast_scouting": False,
        "gossip_scouting": True,
    }
    proc, record = _json_start("--connect", nowhere, "--no-gossip")
    _end(proc)
    assert record["zenoh"]["gossip_scouting"] is False
    conf = tmp_path / "session.json5"
    conf.write_text(
        "// as rmw_zenoh users write one\n"
        f'{{ mode: "peer", connect: {{ endpoints: [] }}, listen: {{ endpoints: ["{listen}"] }},\n'
        "  scouting: { multicast: { enabled: false }, gossip: { enabled: false } }, }\n"
    )
    proc, record = _json_start("--zenoh-config", str(conf))
    try:
        assert record["zenoh"]["listen"] == [listen] and record["zenoh"]["gossip_scouting"] is False
        with open_bus("zenoh", record["prefix"], connect=listen, gossip=False) as bus:  # served where the file says
            assert bus.motor(1).get_state().node == 1
    finally:
        _end(proc)


def test_a_bad_zenoh_config_file_is_a_usage_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.json5"
    bad.write_text("{ listen: { endpoints: 5 } }")
    for path in (bad, tmp_path / "missing.json5"):
        run = subprocess.run(
            [sys.executable, "-m", "drempower", "bridge", "--sim", "1", "--zenoh-config", str(path)],
            capture_output=True,
            text=True,
            timeout=30,
        )
        assert run.returncode == 2, run.stderr
        assert f"error: --zenoh-config: Zenoh configuration {str(path)!r}: " in run.stderr
        assert "Traceback" not in run.stderr and " at /" not in run.stderr
