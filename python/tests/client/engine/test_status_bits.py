"""Status frames whatever bits 3-4 hold (spec/PROTOCOL.md section 1.6).

A scripted motor on python-can's ``virtual`` bus keeps bits 3-4 of the command it answers
(0x19-0x1F for a fast read or a control frame, 0x09-0x0F for a preset); another host on the
same channel sends commands that look like state frames.
"""

from __future__ import annotations

import itertools
import struct
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import can
import pytest

import drempower
from drempower.client.api.profile import load_profile
from drempower.client.engine.status_bits import StatusBits, is_valid_write
from drempower.errors import ConfigError
from drempower.protocol import PositionP, PositionT
from drempower.sim import SimBus

_channels = itertools.count()


class ScriptedMotor:
    """Motor ``node`` on a python-can virtual channel. ``keep``: bits 3-4 of the answered command are kept.

    Answers a fast read, a control frame and a preset (when ``reply_state``) with its state; a read of
    any other address with ``values.get(address, 0)`` in the requested type. ``before_state`` is called
    with the state frame about to go out (a test sends another host's frame there)."""

    def __init__(self, channel: str, node: int, keep: bool, position: float = 12.5) -> None:
        self.node = node
        self.keep = keep
        self.position = position
        self.reply_state = True
        self.values: dict[int, int] = {30001: 0, 30002: 8, 30003: 8, 31214: 1}
        self.before_state: Callable[[], None] | None = None
        self.sent: list[int] = []
        self._bus = can.Bus(interface="virtual", channel=channel, receive_own_messages=False)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(5)
        self._bus.shutdown()

    def _send(self, cmd: int, data: bytes) -> None:
        self._bus.send(can.Message(arbitration_id=(self.node << 5) | cmd, data=data, is_extended_id=False))

    def _state(self, answered: int) -> None:
        cmd = (answered & 0x18 if self.keep else 0) | 0x01 | 0x02  # T set, E clear
        if self.before_state is not None:
            self.before_state()
        self.sent.append(cmd)
        self._send(cmd, struct.pack("<fhh", self.position, 150, -25))

    def _run(self) -> None:
        while not self._stop.is_set():
            msg = self._bus.recv(0.02)
            if msg is None or msg.arbitration_id >> 5 not in (0, self.node) or msg.dlc != 8:
                continue
            cmd, data = msg.arbitration_id & 0x1F, bytes(msg.data)
            if cmd == 0x1E:
                address, dtype = struct.unpack_from("<HH", data)
                if address == 0:
                    self._state(cmd)
                else:
                    value = self.values.get(address, 0)
                    raw = struct.pack("<f", value) if dtype == 0 else struct.pack("<I", value & 0xFFFFFFFF)
                    self._send(0x1E, data[:4] + raw)
            elif cmd == 0x1F:
                address, dtype = struct.unpack_from("<HH", data)
                self.values[address] = struct.unpack_from("<I", data, 4)[0]
                self.reply_state = bool(self.values.get(31214, 0))
            elif cmd in (0x0C, 0x19, 0x1A, 0x1B, 0x1C, 0x1D):
                if cmd in (0x19, 0x1B):
                    self.position = struct.unpack_from("<f", data)[0]
                if self.reply_state:
                    self._state(cmd)


@contextmanager
def scripted(keep: bool, node: int = 1, **options: object) -> Iterator[tuple[drempower.Bus, ScriptedMotor, can.BusABC]]:
    """A client bus, the scripted motor ``node`` and another host, all on one virtual channel."""
    channel = f"drempower-status-bits-{next(_channels)}"
    motor = ScriptedMotor(channel, node, keep)
    other = can.Bus(interface="virtual", channel=channel, receive_own_messages=False)
    options.setdefault("timeout", 0.5)
    try:
        with drempower.open_bus("virtual", channel, stop_on_close=False, **options) as bus:  # type: ignore[arg-type]
            yield bus, motor, other
    finally:
        other.shutdown()
        motor.close()


def _send_raw(host: can.BusABC, text: str) -> None:
    arb, data = text.split("#")
    host.send(can.Message(arbitration_id=int(arb, 16), data=bytes.fromhex(data), is_extended_id=False))


def test_fast_read_answered_with_bits_kept() -> None:
    """The issue's case: a fast read answered with 0x1B (bits 3-4 kept, T set) is the motor's state."""
    with scripted(keep=True) as (bus, motor, _):
        st = bus.motor(1).get_state()
        assert motor.sent == [0x1B]
        assert (st.angle, st.speed, st.torque, st.trajectory_done, st.error) == (12.5, 1.5, -0.25, True, False)
        assert bus._session.inbox.bits.of(1) == "kept"


def test_control_cycle_and_preset_reply_with_bits_kept() -> None:
    """A control cycle with reply-state on gets 0x1B for a P frame; the motor's state follows its command."""
    with scripted(keep=True) as (bus, motor, _):
        states = bus.cycle([PositionP(1, 30.0)], reply_state=True)
        assert states[1].angle == 30.0 and states[1].trajectory_done
        assert motor.sent[-1] == 0x1B
        states = bus.cycle([PositionT(1, -4.0, bandwidth=20.0)], reply_state=True)
        assert states[1].angle == -4.0 and motor.sent[-1] == 0x1B
        assert bus.stats["foreign"] == 0


@pytest.mark.parametrize("keep", [False, True], ids=["zero", "kept"])
def test_other_hosts_write_just_before_the_status_frame(keep: bool) -> None:
    """Another host's write of enable_reply_state to motor 2 (05F#EE79030001000000) goes out just
    before motor 2's status frame: motor 2's state is the status frame's, the write counts as foreign."""
    with scripted(keep=keep, node=2) as (bus, motor, other):
        motor.before_state = lambda: _send_raw(other, "05F#EE79030001000000")
        st = bus.motor(2).get_state()
        assert motor.sent == [0x1B if keep else 0x03]
        assert (st.angle, st.speed, st.torque) == (12.5, 1.5, -0.25)
        assert bus._session.known.states[2] == st
        assert bus.stats["foreign"] == 1
        assert bus._session.other_hosts


def test_other_hosts_t_command_under_zero_bits_is_never_a_state() -> None:
    """Under firmware that sends bits 3-4 as 0, another host's T command to motor 1 (0x039) is never
    motor 1's state: not before the first exchange, not while a fast read waits, not after."""
    t_frame = PositionT(1, 99.0, bandwidth=10.0).encode()
    text = f"{t_frame.arbitration_id:03X}#{t_frame.data.hex()}"
    with scripted(keep=False, profile={"status_bits": "zero"}) as (bus, motor, other):
        motor.reply_state = False  # the motor takes the T command silently (its next state shows it)
        _send_raw(other, text)  # before anything: no wait, the profile says zero
        motor.before_state = lambda: _send_raw(other, text)  # while the fast read waits
        st = bus.motor(1).get_state()
        assert motor.sent == [0x03] and st.angle == motor.position == 99.0  # the motor's own frame
        assert bus._session.known.states[1] == st  # the T frame changed nothing
        motor.before_state = None
        _send_raw(other, text)  # after: the motor is at 99 again, nothing reads its frame as a state
        assert bus.motor(1).get_state().angle == 99.0
        assert bus.stats["foreign"] == 3
    with scripted(keep=False) as (bus, motor, other):  # no profile: learned from the first answer
        motor.reply_state = False
        assert bus.motor(1).get_state().angle == 12.5
        motor.before_state = lambda: (_send_raw(other, text), setattr(motor, "position", 5.0))
        st = bus.motor(1).get_state()
        assert st.angle == 5.0 and bus.stats["foreign"] == 1


def test_rule_table() -> None:
    """Rules 2 and 3 of section 1.6 on their own, every case."""
    write = bytes.fromhex("EE79030001000000")
    t_like = struct.pack("<fhh", 90.0, 0, 1000)
    bits = StatusBits()
    assert is_valid_write(write) and not is_valid_write(bytes(8)) and not is_valid_write(struct.pack("<fhh", 1, 0, 0))
    assert not bits.is_state(1, 0x1F, write, waited=True, other_hosts=False)  # a write, never a state
    assert not bits.is_state(1, 0x19, t_like, waited=False, other_hosts=False)  # unknown, no wait
    assert bits.is_state(1, 0x19, t_like, waited=True, other_hosts=True)  # unknown, waited: learns kept
    assert bits.of(1) == "kept"
    assert bits.is_state(1, 0x1B, t_like, waited=False, other_hosts=False)  # kept, no other host
    assert not bits.is_state(1, 0x1B, t_like, waited=False, other_hosts=True)  # kept, another host heard
    bits.saw(1, 0x03)
    assert not bits.is_state(1, 0x19, t_like, waited=True, other_hosts=False)  # zero: a command
    bits.saw(1, 0x0B)
    assert bits.of(1) == "kept"
    with pytest.raises(drempower.ValidationError, match="status_bits='some'"):
        StatusBits("some")  # type: ignore[arg-type]


def test_profile_errors_name_the_key(tmp_path: object) -> None:
    with pytest.raises(ConfigError, match="status_bits='odd'"):
        load_profile({"status_bits": "odd"})
    with pytest.raises(ConfigError, match="motors: key '99'"):
        load_profile({"motors": {"99": {}}})
    with pytest.raises(ConfigError, match="unknown key 'bits'"):
        load_profile({"bits": "zero"})
    p = load_profile({"status_bits": "zero", "motors": {"2": {"status_bits": "kept"}}})
    assert (p.status_bits_of(1), p.status_bits_of(2)) == ("zero", "kept")


@pytest.mark.parametrize("firmware", ["zero", "kept"])
def test_simulator_profiles_with_and_without_a_client_profile(firmware: str) -> None:
    """The simulator's frames under each status-bits profile are states for a client that learns (auto) or
    is told the right reading; a client told the wrong reading of kept-bits firmware gets no state."""
    for told in ("auto", firmware):
        sim = SimBus([1], status_bits=firmware)
        with drempower.open_bus("sim", bus=sim, clock="virtual", profile={"status_bits": told}) as bus:
            assert bus.motor(1).get_state().node == 1
            assert bus._session.inbox.bits.of(1) == firmware
    if firmware == "kept":
        with (
            drempower.open_bus(
                "sim", bus=SimBus([1], status_bits="kept"), clock="virtual", profile={"status_bits": "zero"}
            ) as bus,
            pytest.raises(drempower.TimeoutError, match="fast read"),
        ):
            bus.motor(1).get_state()


async def test_open_bus_async_takes_a_profile() -> None:
    sim = SimBus([1], status_bits="kept")
    async with drempower.open_bus_async("sim", bus=sim, clock="virtual", profile={"status_bits": "kept"}) as bus:
        assert bus._session.inbox.bits.default == "kept"
        assert (await bus.motor(1).get_state()).node == 1
    with pytest.raises(ConfigError, match="status_bits='x'"):
        drempower.open_bus_async("sim", profile={"status_bits": "x"})
