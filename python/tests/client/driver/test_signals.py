"""The stop-on-close signal handlers: installed once, chained, never over an ignored signal or off the main thread."""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Iterator
from types import FrameType

import pytest

from drempower.client import Bus
from drempower.client.driver import signals as sig
from drempower.protocol import DataType, WriteParam
from drempower.protocol.ids import SysCmd
from drempower.protocol.messages import SystemCommand

from ..scripted import FakeMotors, ScriptedTransport

pytestmark = [
    pytest.mark.skipif(not hasattr(signal, "SIGHUP"), reason="POSIX signals"),
    pytest.mark.usefixtures("_restore_handlers"),
]

IDLE = WriteParam(1, 30003, DataType.U32, 1).encode()


def test_sigterm_closes_the_bus_then_calls_the_previous_handler() -> None:
    calls: list[int] = []

    def own(signum: int, frame: FrameType | None) -> None:
        calls.append(signum)

    signal.signal(signal.SIGTERM, own)
    t = ScriptedTransport(FakeMotors([1]))
    bus = Bus(t, timeout=0.5)
    bus.motor(1).set_speed(30)
    os.kill(os.getpid(), signal.SIGTERM)
    assert calls == [signal.SIGTERM]  # the program's own handler still runs
    assert bus.closed and t.sent[-1] == IDLE  # after the motor was set idle


def test_a_close_after_a_failed_handed_over_close_still_closes(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    t = ScriptedTransport(FakeMotors([1]))
    bus = Bus(t, timeout=0.5)
    bus.motor(1).set_speed(30)
    core = bus._core
    real = core.session.stop_frames
    calls: list[int] = []

    def fails_once() -> list[tuple[int, bytes, bool, bool]]:
        calls.append(1)
        if len(calls) == 1:
            raise RuntimeError("no stop frames this time")
        return real()

    monkeypatch.setattr(core.session, "stop_frames", fails_once)
    with core._lock:  # what a signal handler that interrupted this thread's own bus work finds
        core.close(lock_timeout=0.2)
        assert not bus.closed  # handed to a thread (which fails before it would wait for the lock)
    bus.close()
    assert bus.closed and t.sent[-1] == IDLE and len(calls) == 2
    assert "stopping" in caplog.text and "no stop frames this time" in caplog.text


def test_an_estop_handed_over_after_the_close_goes_out_before_it() -> None:
    # The stop handler closes, then calls the program's own handler, which sends an estop: both handed over.
    estop = SystemCommand(0, SysCmd.ESTOP).encode()
    for _ in range(20):
        t = ScriptedTransport(FakeMotors([1]))
        bus = Bus(t, timeout=0.5)
        bus.motor(1).set_speed(30)
        core = bus._core
        with core._lock:  # what a signal handler that interrupted this thread's own bus work finds
            core.close(lock_timeout=0.2)
            core.estop([0])
        bus.close()
        assert bus.closed and estop in t.sent and t.sent.index(estop) < t.sent.index(IDLE)


_AT_EXIT = """
import os, signal, sys, time
sys.path.insert(0, sys.argv[1])
from scripted import FakeMotors, ScriptedTransport
from drempower.client import Bus
from drempower.protocol import DataType, WriteParam

IDLE = WriteParam(1, 30003, DataType.U32, 1).encode()
t = ScriptedTransport(FakeMotors([1]))
plain_send, signalled = t.send, []

def send(frame):
    if frame == IDLE and not signalled:  # SIGTERM in the middle of the exit-time close's stop frame
        signalled.append(1)
        os.kill(os.getpid(), signal.SIGTERM)
    if frame == IDLE:
        time.sleep(0.3)  # a slow device: the exit must wait for the close the handler handed over
    plain_send(frame)
    if frame == IDLE:
        os.write(1, b"idle written\\n")

t.send = send
bus = Bus(t, timeout=0.5)
bus.motor(1).set_speed(30)
# the script ends with the bus open: the exit closes it
"""


def test_sigterm_during_the_exit_time_close_still_stops_the_motors() -> None:
    import subprocess
    import sys
    from pathlib import Path

    here = str(Path(__file__).parent.parent)  # tests/client, where scripted.py is
    run = subprocess.run([sys.executable, "-c", _AT_EXIT, here], capture_output=True, text=True, timeout=30)
    assert run.stdout.splitlines() == ["idle written"], run.stderr


def test_without_a_previous_handler_the_process_exits_128_plus_n() -> None:
    signal.signal(signal.SIGHUP, signal.SIG_DFL)
    t = ScriptedTransport(FakeMotors([1]))
    bus = Bus(t, timeout=0.5)
    bus.motor(1).set_speed(30)
    with pytest.raises(SystemExit) as info:
        os.kill(os.getpid(), signal.SIGHUP)
    assert info.value.code == 128 + signal.SIGHUP and bus.closed and t.sent[-1] == IDLE


def test_an_ignored_signal_stays_ignored_and_stop_on_close_false_installs_nothing() -> None:
    signal.signal(signal.SIGHUP, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    with Bus(ScriptedTransport(), stop_on_close=False):
        assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    with Bus(ScriptedTransport()):
        assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
        assert signal.getsignal(signal.SIGTERM) is sig._stop_and_chain


def test_a_bus_opened_in_another_thread_installs_nothing() -> None:
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    done = threading.Event()

    def open_one() -> None:
        with Bus(ScriptedTransport()):
            done.set()

    th = threading.Thread(target=open_one)
    th.start()
    th.join(5)
    assert done.is_set() and signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def test_a_second_signal_during_the_stopping_does_not_interrupt_it(monkeypatch: pytest.MonkeyPatch) -> None:
    """SIGTERM arriving while the first one's handler closes the buses: the close runs to its end."""
    calls: list[str] = []

    def stopper() -> None:
        calls.append("close begins")
        sig._stop_and_chain(signal.SIGTERM, None)  # the repeated signal, delivered inside the close
        calls.append("close ends")

    monkeypatch.setattr(sig, "_stoppers", [stopper])
    monkeypatch.setattr(sig, "_previous", {})
    with pytest.raises(SystemExit) as info:
        sig._stop_and_chain(signal.SIGTERM, None)
    assert info.value.code == 128 + signal.SIGTERM
    assert calls == ["close begins", "close ends"]


@pytest.fixture
def handlers_kept() -> Iterator[None]:
    """Put the test process's own SIGINT, SIGTERM and SIGHUP handlers back, whatever the test left."""
    saved = {s: signal.getsignal(s) for s in (signal.SIGINT, *sig.TERMINATING_SIGNALS)}
    yield
    for number, handler in saved.items():
        signal.signal(number, handler)


@pytest.mark.parametrize("second", [signal.SIGINT, signal.SIGTERM])
def test_a_late_second_signal_after_the_block_is_absorbed_when_the_block_ends_the_program(
    handlers_kept: None, second: signal.Signals
) -> None:
    """The command's stop finished and the block exited; a second signal arriving now (a busy machine delays it)
    must not reach the handlers the block replaced (the default action would kill the process while it reports
    with -signal instead of 128 + the first): it only marks the exit hurried."""
    reached: list[int] = []
    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, lambda signum, _frame: reached.append(signum))
    with pytest.raises(KeyboardInterrupt), sig.signals_interrupt(until_exit=True):
        signal.raise_signal(signal.SIGINT)
    signal.raise_signal(second)
    assert reached == [] and sig.hurried()


def test_without_until_exit_the_handlers_come_back_after_a_signal(handlers_kept: None) -> None:
    """As a library block, the program gets its own handlers back, whether or not a signal ended the block."""
    before = signal.getsignal(signal.SIGINT)
    with pytest.raises(KeyboardInterrupt), sig.signals_interrupt():
        signal.raise_signal(signal.SIGINT)
    assert signal.getsignal(signal.SIGINT) is before and not sig.hurried()
    with sig.signals_interrupt(until_exit=True):  # no signal: the handlers come back here too
        pass
    assert signal.getsignal(signal.SIGINT) is before


_SIGTERM_AT = """
def trace(frame, event, arg):
    frame.f_trace_opcodes = True
    if event == "opcode":
        count[0] += 1
        if count[0] == at:
            sent[0] = time.monotonic()
            signal.pthread_kill(threading.main_thread().ident, signal.SIGTERM)
    return trace
"""

_EVERY_INSTRUCTION = (
    """
import signal, sys, threading, time
from drempower.client.driver.signals import SignalLatch
"""
    + _SIGTERM_AT
    + """
at = 1
while True:
    latch = SignalLatch()
    latch.install()
    count, sent = [0], [0.0]
    sys.settrace(trace)
    try:
        got = latch.wait(0.4)
    finally:
        sys.settrace(None)
    late = time.monotonic() - sent[0]
    got = got or latch.wait(0)  # a signal after the wait's last look is the next wait's
    if count[0] < at:
        print(at - 1)
        break
    assert got and latch.signum == signal.SIGTERM and late < 0.3, (at, got, late)
    latch.close()
    at += 1
"""
)


def test_a_signal_at_any_instruction_of_the_latch_wait_ends_it() -> None:
    # A handler that set a threading.Event could run while the main thread held that event's lock inside wait()
    # and wait for itself forever: `drempower bridge` then ignored SIGTERM. Deliver SIGTERM at every instruction.
    import subprocess
    import sys

    run = subprocess.run([sys.executable, "-c", _EVERY_INSTRUCTION], capture_output=True, text=True, timeout=30)
    assert run.returncode == 0, run.stderr
    assert int(run.stdout) >= 5  # the wait has that many instructions, each one tried


_PASS_TIME = (
    """
import signal, sys, threading, time
import drempower
from drempower.protocol.enums import AxisState
"""
    + _SIGTERM_AT
    + """
for at in range(1, 151):
    bus = drempower.open_bus("sim", motors=[1])
    bus.motor(1).set_speed(30, enable=True)
    count, sent, code = [0], [0.0], None
    sys.settrace(trace)
    try:
        bus.pass_time(0.5)
    except SystemExit as exc:
        code = exc.code
    finally:
        sys.settrace(None)
    late = time.monotonic() - sent[0]
    assert count[0] >= at and code == 143 and late < 0.3 and bus.closed, (at, count[0], code, late)
    assert bus.transport.bus.motors[1].state == AxisState.IDLE, at
print(at)
"""
)


def test_sigterm_at_any_instruction_of_pass_time_stops_the_motors_and_exits() -> None:
    # pass_time slept on an event that the close sets: SIGTERM arriving while the main thread held that event's
    # lock made the stopping handler wait for itself forever, the motors still turning.
    import subprocess
    import sys

    run = subprocess.run([sys.executable, "-c", _PASS_TIME], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["150"]


_SEND = """
import os, signal, sys, threading, time
import drempower
from drempower.sim import SimBus, attach_adapter_pty, attach_python_can
from drempower.protocol.enums import AxisState
from drempower.protocol.flags import AxisError
from drempower.protocol.addresses import AXIS0_ERROR

def python_only(frame):
    # Not in a Condition's __enter__ or __exit__: a signal at the entry of __exit__ leaves its lock held (a with
    # statement is not safe against asynchronous exceptions) and python-can's virtual bus then takes no frame.
    # Not under a finalizer (__del__, weakref.finalize, a WeakSet's callback as the collector frees a thread):
    # Python ignores the SystemExit raised there.
    if frame.f_code.co_filename.endswith("threading.py") and frame.f_code.co_name in ("__enter__", "__exit__"):
        return False
    while frame is not None:
        if frame.f_code.co_name == "__del__" or frame.f_code.co_filename.endswith(("weakref.py", "_weakrefset.py")):
            return False
        frame = frame.f_back
    return True

def trace(frame, event, arg):
    # SIGTERM at the entry of a function, where a handler runs (CPython looks for signals there)
    if event == "call" and python_only(frame):
        count[0] += 1
        if count[0] == at:
            sent[0] = time.monotonic()
            signal.pthread_kill(threading.main_thread().ident, signal.SIGTERM)

sim = SimBus(ids=[1])
channel = f"sigterm-{os.getpid()}"
estop = sys.argv[2] == "estop"
link = attach_adapter_pty(sim) if sys.argv[1] == "adapter" else attach_python_can(sim, channel=channel)
at = 0
while True:
    at += 1
    options = {"timeout": 1.0, "stop_on_close": not estop}
    if sys.argv[1] == "adapter":
        bus = drempower.open_bus("adapter", link.path, **options)
    else:
        bus = drempower.open_bus("virtual", channel, **options)
    if estop:  # the program's own handler: an emergency stop, then the exit
        signal.signal(signal.SIGTERM, lambda signum, frame: (bus.estop(), sys.exit(128 + signum)))
    sim.motors[1].errors[AXIS0_ERROR] = 0
    motor = bus.motor(1)
    motor.set_speed(30, enable=True)
    count, sent, code = [0], [0.0], None
    sys.settrace(trace)
    try:
        for _ in range(3):
            motor.set_speed(30)
    except SystemExit as exc:
        code = exc.code
    finally:
        sys.settrace(None)
    if count[0] < at:
        bus.close()
        break
    late = time.monotonic() - sent[0]
    bus.close()  # as the end of a with block or the exit does: waits for the close a handler handed over
    m, end = sim.motors[1], time.monotonic() + 1.0
    while not (m.state == AxisState.IDLE and (not estop or m.errors[AXIS0_ERROR] & AxisError.ESTOP_REQUESTED)):
        assert time.monotonic() < end, (at, m.state, hex(m.errors[AXIS0_ERROR]))  # the frames are in the sim's hands
        time.sleep(0.002)
    assert code == 143 and late < 0.5, (at, code, late)
print(at - 1)
link.close()
"""


@pytest.mark.parametrize(("link", "stop"), [("adapter", "close"), ("virtual", "close"), ("adapter", "estop")])
def test_sigterm_at_any_function_entry_of_a_send_stops_the_motor(link: str, stop: str) -> None:
    # The handler closed the bus at once: when it had interrupted its own thread inside a transport's send, the
    # stop frames waited for that send's write lock forever (the process ignored SIGTERM, the motor turned on).
    # "estop": the program's own handler sends an emergency stop and exits; the close after it waits for it.
    import subprocess
    import sys

    run = subprocess.run([sys.executable, "-c", _SEND, link, stop], capture_output=True, text=True, timeout=90)
    assert run.returncode == 0, run.stderr
    assert int(run.stdout) >= 50  # positions tried: each function entered while the speeds were sent


def test_the_latch_keeps_the_first_signal_leaves_ignored_ones_and_puts_handlers_back() -> None:
    def own(signum: int, frame: FrameType | None) -> None:
        raise AssertionError("replaced while the latch is installed")

    signal.signal(signal.SIGTERM, own)
    signal.signal(signal.SIGHUP, signal.SIG_IGN)
    with sig.SignalLatch() as latch:
        assert not latch.wait(0.01) and latch.signum is None
        assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN  # nohup's choice stays
        os.kill(os.getpid(), signal.SIGTERM)
        os.kill(os.getpid(), signal.SIGINT)
        assert latch.wait(0) and latch.wait(5.0) and latch.signum == signal.SIGTERM
    assert signal.getsignal(signal.SIGTERM) is own and signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_latch_off_the_main_thread_installs_nothing() -> None:
    before = signal.getsignal(signal.SIGTERM)
    seen: list[bool] = []

    def other() -> None:
        with sig.SignalLatch() as latch:
            seen.append(latch.wait(0.01))

    thread = threading.Thread(target=other)
    thread.start()
    thread.join()
    assert seen == [False] and signal.getsignal(signal.SIGTERM) is before
