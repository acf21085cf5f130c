"""The bridge's log never blocks: a stderr nobody reads, a flood of one warning."""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import time

import pytest

from drempower.bridge.logs import RateLimit, StderrLines

from .conftest import free_port, session
from .test_bridge import _call

pytestmark = pytest.mark.timeout(60)


def _record(msg: str, *args: object) -> logging.LogRecord:
    return logging.LogRecord("drempower.bridge", logging.WARNING, __file__, 1, msg, args, None)


def test_one_line_per_kind_per_interval_with_a_count() -> None:
    now = [100.0]
    limit = RateLimit(1.0, clock=lambda: now[0])
    passed = [r for r in (_record("frames on %s refused: %s", "k", i) for i in range(500)) if limit.filter(r)]
    assert len(passed) == 1 and limit.held() == 499
    assert limit.filter(_record("%s: not a Float64MultiArray", "t"))  # another kind goes through
    now[0] += 0.5
    assert not limit.filter(_record("frames on %s refused: %s", "k", 0))
    now[0] += 0.6
    told = _record("frames on %s refused: %s", "k", 1)
    assert limit.filter(told)
    assert told.getMessage() == "frames on k refused: 1 (and 500 more like it in 1.1 s)"
    assert limit.held() == 0


def test_stderr_lines_never_block_and_count_what_they_drop() -> None:
    r, w = os.pipe()
    try:
        out = StderrLines(limit=50, fd=w).start()
        line = "x" * 4000
        t0 = time.monotonic()
        for _ in range(500):  # far beyond the pipe's 64 KiB and the queue's 50 lines
            out.line(line)
        assert time.monotonic() - t0 < 0.5
        assert not out.flush_for(0.2)  # nobody reads: it cannot be written, and nothing waits on it
        os.set_blocking(r, False)
        got = b""
        while not out.flush_for(0.01):
            try:
                got += os.read(r, 1 << 16)
            except BlockingIOError:
                pass
        try:
            got += os.read(r, 1 << 20)
        except BlockingIOError:
            pass
        text = got.decode()
        dropped = [int(ln.split()[1]) for ln in text.splitlines() if "log lines dropped" in ln]
        assert dropped and text.count(line) + sum(dropped) == 500
    finally:
        os.close(r)
        os.close(w)


def test_a_stderr_nobody_reads_holds_up_no_service_and_no_exit() -> None:
    endpoint, prefix = f"tcp/127.0.0.1:{free_port()}", f"log{free_port()}"
    argv = [sys.executable, "-m", "drempower", "bridge", "--sim", "1,2", "--listen", endpoint, "--prefix", prefix]
    argv += ["--connect", f"tcp/127.0.0.1:{free_port()}", "--json"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        assert proc.stdout is not None and proc.stderr is not None
        import json

        record = json.loads(proc.stdout.readline())
        assert b"joint_states on" in proc.stderr.readline()  # then nobody reads stderr
        with session(connect=[endpoint]) as peer:
            time.sleep(0.3)
            for i in range(3000):  # each a warning of about 150 bytes: 450 kB, seven pipes full
                peer.put(f"{prefix}/tx", b"\x01\x02\x03", attachment=f"no sequence number {i}".encode())
            time.sleep(0.5)
            t0 = time.monotonic()
            resp, _ = _call(peer, record["estop"], 1)
            assert resp.success is True and time.monotonic() - t0 < 2.0
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(10) == 128 + signal.SIGTERM
        err = proc.stderr.read().decode()
        refused = [ln for ln in err.splitlines() if "refused" in ln]
        assert 1 <= len(refused) <= 5, err[:2000]
        assert "more like it" in err or len(refused) == 1
        assert "Traceback" not in err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)
