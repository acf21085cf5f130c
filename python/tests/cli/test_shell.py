"""``drempower shell``: a Python console with the bus open, through a pty (tab completion) and through stdin."""

from __future__ import annotations

import os
import select
import subprocess
import sys
import time

import pytest

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="ptys")

_ENV = {**os.environ, "PYTHONUNBUFFERED": "1", "DREMPOWER_SIM_TIME_SCALE": "1", "TERM": "dumb"}


def _read_until(fd: int, text: str, timeout: float = 20.0) -> str:
    seen = b""
    end = time.monotonic() + timeout
    while text.encode() not in seen:
        left = end - time.monotonic()
        assert left > 0, f"no {text!r} in {seen.decode(errors='replace')!r}"
        if select.select([fd], [], [], left)[0]:
            try:
                chunk = os.read(fd, 4096)
            except OSError:  # the child closed the pty
                break
            if not chunk:
                break
            seen += chunk
    return seen.decode(errors="replace")


def test_shell_through_a_pty_completes_names_and_idles_on_ctrl_d() -> None:
    controller, terminal = os.openpty()
    p = subprocess.Popen(
        [sys.executable, "-m", "drempower", "shell", "--sim", "1,2"],
        stdin=terminal,
        stdout=terminal,
        stderr=terminal,
        env=_ENV,
        close_fds=True,
    )
    os.close(terminal)
    try:
        out = _read_until(controller, ">>> ")
        assert "m1, m2: its motors" in out and "--sim 1,2" in out
        os.write(controller, b"x = bus.moto\t1)\n")  # Tab completes bus.motor(
        os.write(controller, b"print('kind', type(x).__name__, x is not m2)\n")
        assert "kind Motor True" in _read_until(controller, "kind Motor True")
        os.write(controller, b"m2.set_speed(20); print('speed', 'sent')\n")
        # the prompt after this command, not one printed before it ran: Ctrl-D must come on an empty line
        out = _read_until(controller, "speed sent")
        if ">>> " not in out.split("speed sent", 1)[1]:  # its prompt may come in the same read
            _read_until(controller, ">>> ")
        os.write(controller, b"\x04")  # Ctrl-D on an empty line
        out = _read_until(controller, "set to idle")
        assert "shell ended: motor 2 set to idle" in out
        assert p.wait(20) == 0
    finally:
        if p.poll() is None:
            p.kill()
        os.close(controller)


def test_shell_reads_a_script_on_stdin() -> None:
    script = "print(sorted(k for k in dir() if k[0] == 'm'))\nprint(drempower.__name__, m3.get_state().angle)\n"
    r = subprocess.run(
        [sys.executable, "-m", "drempower", "shell", "3", "--sim", "3"],
        input=script,
        capture_output=True,
        text=True,
        timeout=30,
        env=_ENV,
    )
    assert r.returncode == 0, r.stderr
    assert "['m3']" in r.stdout and "drempower 0.0" in r.stdout and "Traceback" not in r.stderr
