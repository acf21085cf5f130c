#!/usr/bin/env python3
"""Run one of the C examples against `drempower sim` and check what the library's tour printed.

    with_sim.py --drempower PATH --link socketcand|adapter [--need PROGRAM] [--skip WHY]
                [--absent] -- COMMAND ARG...

Starts the simulator with motors 1 and 2 and one attachment (a socketcand
server on 127.0.0.1 or the USB-CAN adapter pty), runs COMMAND with {host},
{port} and {pty} replaced by where the simulator listens, then stops the
simulator and checks the output of examples/tour: the reads, the verified
write, the synchronised move (its wait as long as the move must take, each
motor at its target), the estop (E flag, ESTOP_REQUESTED) and "tour: ok".
With --absent the simulator has motor 3 only: the tour's first read must end
in a timeout, the program must exit 1 within the time a timeout takes, and
nothing after it may run.
Exits 77 (ctest's skip) with a message when drempower or a --need program is
missing, 1 on a failed check, 0 when every check passed.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import select
import shutil
import signal
import subprocess
import sys
import time

SKIP = 77
IDS = (1, 2)
TARGETS = {1: 90.0, 2: -45.0}  # deg, as examples/tour/tour.c moves them
SPEED_DEG_S = 60.0 * 6.0  # 60 r/min
AT_TARGET = 1.0  # deg
START_S = 20.0
RUN_S = 30.0


def skip(why: str) -> int:
    print(f"SKIPPED: {why}")
    return SKIP


class JsonLines:
    """The simulator's --json lines, read straight from its pipe (select() sees no line a buffer holds)."""

    def __init__(self, proc: subprocess.Popen[bytes]) -> None:
        assert proc.stdout is not None
        self.fd = proc.stdout.fileno()
        self.buf = b""

    def until(self, key: str, deadline: float) -> list[dict[str, object]]:
        """The lines up to the one holding `key` (or the end of the output, or the deadline)."""
        out: list[dict[str, object]] = []
        while True:
            while b"\n" in self.buf:
                line, self.buf = self.buf.split(b"\n", 1)
                try:
                    obj = json.loads(line)
                except ValueError:
                    print(f"sim: {line.decode(errors='replace')}")
                    continue
                out.append(obj)
                if key in obj:
                    return out
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self.fd], [], [], left)[0]:
                return out
            chunk = os.read(self.fd, 4096)
            if not chunk:
                return out
            self.buf += chunk


def check_tour(text: str, code: int) -> list[str]:
    """What is wrong in the tour's output (empty when nothing is)."""
    bad: list[str] = []
    num = r"(-?\d+\.\d\d)"
    if code != 0:
        bad.append(f"the program exited {code}")
    for i in IDS:
        m = re.search(rf"^state {i}: position {num} deg, .* T=1 E=0$", text, re.M)
        if not m:
            bad.append(f"no state read of motor {i} (T=1 E=0)")
        m = re.search(rf"^volcur {i}: {num} V, {num} A$", text, re.M)
        if not m or not float(m.group(1)) > 0.0:
            bad.append(f"no supply voltage read of motor {i}")
        m = re.search(rf"^health {i}: motor {num} degC, driver {num} degC, limit {num} A, derating {num}, active 0$",
                      text, re.M)  # fmt: skip
        if not m or not 0.0 < float(m.group(1)) < 80.0 or float(m.group(4)) != 0.0:
            bad.append(f"no health reading of motor {i} (cool, no derating)")
        if not re.search(rf"^verified {i}: traj_mode 2 read back$", text, re.M):
            bad.append(f"no verified write of motor {i}")
        m = re.search(rf"^arrived {i}: position {num} deg", text, re.M)
        if not m or abs(float(m.group(1)) - TARGETS[i]) > AT_TARGET:
            bad.append(f"motor {i} not at {TARGETS[i]} deg after its move")
        if not re.search(rf"^estop {i}: .* E=1$", text, re.M):
            bad.append(f"motor {i} shows no error flag after the estop")
        if not re.search(rf"^errors {i}: axis .*ESTOP_REQUESTED", text, re.M):
            bad.append(f"motor {i}'s axis error word lacks ESTOP_REQUESTED")
    if not re.search(r"^move: 1 to 90\.00, 2 to -45\.00 deg", text, re.M):
        bad.append("no synchronised move")
    m = re.search(r"^wait: done after (\d+) ms$", text, re.M)
    shortest_ms = max(abs(t) for t in TARGETS.values()) / SPEED_DEG_S * 1000.0
    if not m:
        bad.append("no end of the wait for the move")
    elif not shortest_ms <= int(m.group(1)) <= 5000:
        bad.append(f"the wait ended after {m.group(1)} ms; the move takes at least {shortest_ms:.0f} ms")
    if not re.search(r"^tour: ok$", text, re.M):
        bad.append("no 'tour: ok'")
    return bad


def check_absent(text: str, code: int) -> list[str]:
    """What is wrong in the output of a tour whose motors do not answer."""
    bad: list[str] = []
    if code != 1:
        bad.append(f"the program exited {code}, not 1")
    if not re.search(r"^FAIL 1: get_state: timeout$", text, re.M):
        bad.append("no timeout of the first read")
    if re.search(r"^(state|verified|move|tour):? ", text, re.M):
        bad.append("the tour went on after the timeout")
    return bad


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--drempower", default="")
    ap.add_argument("--link", choices=("socketcand", "adapter"), required=True)
    ap.add_argument("--need", action="append", default=[], help="a program the command needs")
    ap.add_argument("--skip", default="", help="skip at once, saying why")
    ap.add_argument("--absent", action="store_true", help="motors 1 and 2 absent: the tour must time out")
    ap.add_argument("command", nargs="+")
    args = ap.parse_args()

    if args.skip:
        return skip(args.skip)
    if not args.drempower or not os.access(args.drempower, os.X_OK):
        return skip(
            f"no drempower command ({args.drempower or 'DRE_DREMPOWER not set'}): "
            "c/scripts/test.sh passes the virtual environment's (make test creates it)"
        )
    for prog in args.need:
        if not prog or prog.endswith("-NOTFOUND") or not (os.access(prog, os.X_OK) or shutil.which(prog)):
            return skip(f"{prog.removesuffix('-NOTFOUND') or 'a program'} not found")

    attach = ["--socketcand-port", "0"] if args.link == "socketcand" else ["--adapter-pty"]
    ids = "3" if args.absent else ",".join(str(i) for i in IDS)
    sim = subprocess.Popen(
        [args.drempower, "sim", "--ids", ids, *attach, "--json", "--duration", str(START_S + RUN_S + 10)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
    )
    lines = JsonLines(sim)
    try:
        where: dict[str, str] = {}
        for obj in lines.until("running", time.monotonic() + START_S):
            if obj.get("attachment") == "socketcand":
                where["host"], where["port"] = str(obj["host"]), str(obj["port"])
            elif obj.get("attachment") == "adapter":
                where["pty"] = str(obj["path"])
        if not where:
            print(f"the simulator did not start within {START_S:.0f} s (exit status {sim.poll()})")
            return 1
        if where.get("host", "127.0.0.1") != "127.0.0.1":
            print(f"the simulator's socketcand is not on 127.0.0.1: {where['host']}")
            return 1
        command = [a.format(**where) for a in args.command]
        print("$ " + " ".join(command), flush=True)
        t0 = time.monotonic()
        try:
            run = subprocess.run(command, capture_output=True, text=True, timeout=RUN_S)
        except subprocess.TimeoutExpired as exc:
            out = exc.stdout.decode() if isinstance(exc.stdout, bytes) else (exc.stdout or "")
            print(out)
            print(f"FAILED: the program did not end within {RUN_S:.0f} s")
            return 1
        print(run.stdout, end="")
        print(run.stderr, end="", file=sys.stderr)
        print(f"({time.monotonic() - t0:.2f} s)")
    finally:
        if sim.poll() is None:
            sim.send_signal(signal.SIGINT)
        summary = lines.until("stopped", time.monotonic() + 10.0)
        try:
            sim.wait(timeout=10.0)
        except subprocess.TimeoutExpired:
            sim.kill()
            sim.wait()
    frames = next((o.get("frames") for o in summary if "stopped" in o), None)
    print(f"simulator: {frames} frames on its bus")
    check = check_absent if args.absent else check_tour
    bad = check(run.stdout, run.returncode)
    if not isinstance(frames, int) or frames < (1 if args.absent else 20):
        bad.append(f"the simulator saw {frames} frames")
    for b in bad:
        print(f"FAILED: {b}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
