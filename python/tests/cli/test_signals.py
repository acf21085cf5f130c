"""Every way a process ends stops what it started: real signals to real ``drempower`` processes.

An external ``drempower sim`` serves the motors on its USB-CAN adapter pty, so
what a killed command left behind can be read afterwards by the next command.
"""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import textwrap
import time
from collections.abc import Iterator
from typing import Any

import pytest

import drempower
from drempower.protocol.addresses import AXIS0_CURRENT_STATE
from drempower.protocol.enums import AxisState

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="ptys and POSIX signals")

_ENV = {**os.environ, "PYTHONUNBUFFERED": "1"}


def _drempower(*argv: str) -> list[str]:
    return [sys.executable, "-m", "drempower", *argv]


@pytest.fixture
def pty() -> Iterator[str]:
    """The adapter pty of an external simulator with motors 1 and 2."""
    yield from _serve("1,2")


@pytest.fixture
def pty6() -> Iterator[str]:
    """The adapter pty of an external simulator with motors 1 to 6."""
    yield from _serve("1-6")


def _serve(ids: str) -> Iterator[str]:
    sim = subprocess.Popen(
        _drempower("sim", "--ids", ids, "--adapter-pty", "--json"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_ENV,
    )
    try:
        assert sim.stdout is not None
        path = None
        for line in sim.stdout:
            rec = json.loads(line)
            path = rec.get("path", path)
            if rec.get("running"):
                break
        assert path, sim.stderr.read() if sim.stderr else ""
        yield path
    finally:
        sim.send_signal(signal.SIGTERM)
        try:
            code = sim.wait(20)
        except subprocess.TimeoutExpired:
            sim.kill()
            raise
        assert code == 128 + signal.SIGTERM  # the simulator itself ends as Ctrl-C ends it


def _run(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(_drempower(*argv), capture_output=True, text=True, timeout=30, env=_ENV)


def _state(path: str, node: int = 1) -> dict[str, Any]:
    r = _run("state", str(node), "--serial", path, "--timeout", "1", "--json")
    assert r.returncode == 0, r.stderr
    rec: dict[str, Any] = json.loads(r.stdout)
    return rec


def _start(*argv: str) -> subprocess.Popen[str]:
    """Start a command and wait until it printed its first line (the motors are moving then)."""
    p = subprocess.Popen(_drempower(*argv), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_ENV)
    assert p.stdout is not None
    line = p.stdout.readline()
    assert line, p.stderr.read() if p.stderr else ""
    return p


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_a_signal_idles_the_motors_of_a_running_command(pty: str, sig: signal.Signals) -> None:
    p = _start("speed", "1,2", "60", "--duration", "60", "--serial", pty, "--timeout", "1")
    time.sleep(0.3)
    assert p.poll() is None
    p.send_signal(sig)
    _, err = p.communicate(timeout=20)
    assert p.returncode == 128 + sig, err
    assert "motors 1, 2 set to idle; motor 1 still coasting at" in err and "Traceback" not in err
    for node in (1, 2):
        assert _state(pty, node)["state"] == "idle"


def test_torque_duration_says_the_motor_still_coasts(pty: str) -> None:
    r = _run("torque", "1", "0.5", "--duration", "0.5", "--serial", pty, "--timeout", "1")
    assert r.returncode == 0, r.stderr
    assert "after 0.5 s: motor 1 set to idle; motor 1 still coasting at" in r.stderr
    speed = float(r.stderr.split("coasting at ")[1].split()[0])
    assert abs(speed) > 1


def test_sigterm_restores_the_watchdog_it_armed(pty: str) -> None:
    p = _start("speed", "1", "30", "--duration", "60", "--watchdog", "300", "--serial", pty, "--timeout", "1")
    time.sleep(1.0)  # longer than the watchdog: the command keeps feeding it
    assert p.poll() is None
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=20)
    assert p.returncode == 128 + signal.SIGTERM, err
    r = _run("get", "1", "can.config.timeout_ms", "--serial", pty, "--timeout", "1", "--json")
    assert r.returncode == 0 and json.loads(r.stdout)["value"] == 0, r.stdout + r.stderr
    assert _state(pty)["state"] == "idle"


def test_after_sigkill_the_watchdog_idles_the_motor(pty: str) -> None:
    p = _start("speed", "1", "30", "--duration", "60", "--watchdog", "200", "--serial", pty, "--timeout", "1")
    time.sleep(0.6)
    assert p.poll() is None
    p.kill()
    p.communicate(timeout=20)
    time.sleep(0.5)
    st = _state(pty)
    assert st["state"] == "idle" and "WATCHDOG" in json.dumps(st).upper()


_API_SCRIPT = textwrap.dedent(
    """
    import signal, sys, time
    import drempower
    {prelude}
    bus = drempower.open_bus("adapter", sys.argv[1], timeout=1, stop_on_close={stop})
    for i in (1, 2):
        bus.motor(i).set_mode(2)  # closed loop, even after a test before idled it
    bus.set_speeds([1, 2], [40, 40])
    print("moving", flush=True)
    time.sleep(60)
    """
)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP])
def test_api_stop_on_close_idles_the_motors_on_a_signal(pty: str, sig: signal.Signals) -> None:
    script = _API_SCRIPT.format(prelude="", stop="True")
    p = subprocess.Popen(
        [sys.executable, "-c", script, pty], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_ENV
    )
    assert p.stdout is not None and p.stdout.readline() == "moving\n"
    p.send_signal(sig)
    _, err = p.communicate(timeout=20)
    assert p.returncode == 128 + sig, err
    assert _state(pty, 1)["state"] == "idle" and _state(pty, 2)["state"] == "idle"


def test_api_chains_to_the_programs_own_handler_and_keeps_stop_on_close_false(pty: str) -> None:
    prelude = "signal.signal(signal.SIGTERM, lambda n, f: (print('own handler', flush=True), sys.exit(7)))"
    script = _API_SCRIPT.format(prelude=prelude, stop="True")
    p = subprocess.Popen(
        [sys.executable, "-c", script, pty], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_ENV
    )
    assert p.stdout is not None and p.stdout.readline() == "moving\n"
    p.send_signal(signal.SIGTERM)
    out, err = p.communicate(timeout=20)
    assert p.returncode == 7 and out == "own handler\n", err
    assert _state(pty, 1)["state"] == "idle"
    # stop_on_close=False: the motors are left as they are
    script = _API_SCRIPT.format(prelude="", stop="False")
    p = subprocess.Popen(
        [sys.executable, "-c", script, pty], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_ENV
    )
    assert p.stdout is not None and p.stdout.readline() == "moving\n"
    p.send_signal(signal.SIGTERM)
    p.communicate(timeout=20)
    assert p.returncode == -signal.SIGTERM
    assert _state(pty, 1)["state"] == "closed_loop"


_TWO_SIGNALS = [
    (signal.SIGINT, signal.SIGTERM),
    (signal.SIGINT, signal.SIGINT),
    (signal.SIGTERM, signal.SIGINT),
    (signal.SIGTERM, signal.SIGHUP),
]


@pytest.mark.timeout(480)  # 20 commands started: about 15 s on an idle machine, much longer on a busy one
def test_a_second_signal_never_cuts_the_stop_short(pty6: str) -> None:
    """Two signals within 0.5 ms, 20 times: every time, all six motors end idle (7 of 70 runs left some turning)."""
    rng = random.Random(23)
    ids = range(1, 7)
    for run in range(20):
        with drempower.open_bus("adapter", pty6, timeout=1, stop_on_close=False) as bus:
            for i in ids:
                bus.motor(i).clear_error()
                bus.motor(i).set_mode(2)
        first, second = _TWO_SIGNALS[run % len(_TWO_SIGNALS)]
        p = _start("speed", "1,2,3,4,5,6", "30", "--duration", "8", "--serial", pty6, "--timeout", "1")
        time.sleep(rng.uniform(0.0, 0.1))
        p.send_signal(first)
        time.sleep(rng.choice([0.0, 0.0002, 0.0005]))
        p.send_signal(second)
        _, err = p.communicate(timeout=20)
        assert p.returncode in (128 + first, 128 + second), f"run {run}: {err}"  # both may be pending at once
        assert "set to idle" in err and "Traceback" not in err, f"run {run}: {err}"
        with drempower.open_bus("adapter", pty6, timeout=1, stop_on_close=False) as bus:
            states = {i: int(bus.motor(i).read_property(AXIS0_CURRENT_STATE)) for i in ids}
        assert states == dict.fromkeys(ids, AxisState.IDLE), f"run {run} ({first.name}+{second.name}): {states}"
