"""``drempower bridge --watchdog``: a SIGKILLed bridge leaves no motor driving; a clean exit puts the timeout back."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Iterator

import pytest

import drempower
from drempower.protocol.enums import AxisState

from .conftest import free_port, wait_for

pytestmark = pytest.mark.timeout(90)

WATCHDOG = "can.config.timeout_ms"


@pytest.fixture
def sim_port() -> Iterator[int]:
    """An external ``drempower sim`` on socketcand (it outlives a killed bridge, as motors do)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "drempower", "sim", "--ids", "1,2", "--socketcand-port", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    assert proc.stdout is not None
    text = ""
    try:
        while "Ctrl-C stops" not in text:
            line = proc.stdout.readline()
            if not line:
                pytest.fail(f"the simulator did not start: {text}")
            text += line
        found = re.search(r"socketcand: \S+ port (\d+)", text)
        assert found, text
        yield int(found.group(1))
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)


def _link(port: int) -> list[str]:
    return ["-i", "socketcand", "-c", "can0", "-o", "host=127.0.0.1", "-o", f"port={port}"]


def _direct(port: int) -> drempower.Bus:
    return drempower.open_bus("socketcand", "can0", host="127.0.0.1", port=port, timeout=2, stop_on_close=False)


def _bridge(port: int, *extra: str) -> tuple[subprocess.Popen[str], str, str]:
    endpoint, prefix = f"tcp/127.0.0.1:{free_port()}", f"wd{free_port()}"
    argv = [sys.executable, "-m", "drempower", "bridge", *_link(port), "--ids", "1,2", "--listen", endpoint]
    argv += ["--connect", f"tcp/127.0.0.1:{free_port()}", "--prefix", prefix, "--timeout", "1", *extra]
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    assert proc.stderr is not None
    line = proc.stderr.readline()
    assert "joint_states on" in line, line + (proc.stderr.read() if proc.poll() is not None else "")
    return proc, endpoint, prefix


def test_a_killed_bridge_leaves_its_motors_idle_with_the_watchdog(sim_port: int) -> None:
    proc, endpoint, prefix = _bridge(sim_port, "--watchdog", "1000")  # a loaded machine may pause the stream
    try:
        with _direct(sim_port) as bus:
            assert bus.motor(1).read_property(WATCHDOG) == 1000
            assert bus.motor(2).read_property(WATCHDOG) == 1000
        # a remote client drives motor 1 and stays: the bridge goes, the client's keep-alives go nowhere
        remote = drempower.open_bus("zenoh", prefix, connect=endpoint, gossip=False, stop_on_close=False)
        remote.motor(1).set_mode(2)
        remote.motor(1).set_speed(30.0)
        with remote, _direct(sim_port) as bus:
            wait_for(lambda: abs(bus.motor(1).get_state().speed) > 1.0)
            time.sleep(0.5)  # the bridge's state stream keeps the watchdog fed
            assert bus.motor(1).get_state().speed > 1.0
            os.kill(proc.pid, signal.SIGKILL)
            proc.wait(10)
            killed = time.monotonic()
            state = bus.motor(1).get_state()  # one read: it feeds the watchdog, so read rarely
            while state.speed > 1.0 and time.monotonic() - killed < 8.0:
                time.sleep(1.5)  # longer than the watchdog: a read of ours must not feed it
                state = bus.motor(1).get_state()
            assert abs(state.speed) < 1.0, state
            assert bus.motor(1).read_property("axis0.current_state") == AxisState.IDLE
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)


def test_a_clean_exit_puts_the_timeout_back(sim_port: int) -> None:
    with _direct(sim_port) as bus:
        bus.motor(2).write_property(WATCHDOG, 5000, verify=True)
    proc, _, _ = _bridge(sim_port, "--watchdog", "300")
    with _direct(sim_port) as bus:
        assert [bus.motor(i).read_property(WATCHDOG) for i in (1, 2)] == [300, 300]
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=20)
    assert proc.returncode == 128 + signal.SIGTERM, err
    with _direct(sim_port) as bus:
        assert [bus.motor(i).read_property(WATCHDOG) for i in (1, 2)] == [0, 5000]


def test_a_watchdog_the_state_stream_cannot_feed_is_refused() -> None:
    run = subprocess.run(
        [sys.executable, "-m", "drempower", "bridge", "--sim", "1", "--rate", "10", "--watchdog", "200"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert run.returncode == 2
    assert "--watchdog 200: the state stream (--rate 10) talks to each motor every 100 ms" in run.stderr
    assert "Traceback" not in run.stderr
