"""``drempower doctor``: measure what real motors do where the vendor's document is uncertain.

For each motor: firmware and hardware versions, the command values of the state frames
answering a fast read, a control frame and a preset (``status_ids``), whether the fast
read, reply-state triggers and heartbeat work, and with ``--reboot`` the boot time. Each
finding names its section of spec/PROTOCOL.md. Probes that can move a joint run only with
``--yes`` and are listed first; ``--yes --factory-id`` also measures the factory node id, which
replaces the configuration for a moment (:mod:`._factory_id` backs it up, restores and
verifies it). ``--json`` output attached to an issue is the report the project asks for
(docs/cli.md).
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
from typing import Any

from ..client.api.profile import FirmwareProfile
from ..client.engine.effects import sleep
from ..errors import DrEmpowerError, TimeoutError
from ..protocol import FastRead, PositionP, PresetQ, ReadParam, Start
from ..protocol.addresses import FW_VERSION
from ..protocol.ids import Frame, StartKind
from ..protocol.parameters import DataType
from . import _factory_id
from ._connect import add_connection_args, add_ids_arg, open_from_args
from ._output import add_json_arg, clean, json_line
from ._usage import UsageError

GROUP = "bus"
"""Where ``drempower --help`` lists this module's subcommands."""

REPLY_STATE = "axis0.config.extra_setting.enable_reply_state"
HEARTBEAT = "can.config.heartbeat_ms"
HEARTBEAT_PROBE_MS = 100
"""The heartbeat period doctor sets (in RAM, put back afterwards) to see whether heartbeats come."""
Q_STEP_DEG = 2.0
"""How far the Q-time-0 probe moves a joint in closed loop (and back), with --yes."""
REBOOT_LIMIT_S = 10.0
"""Longest wait for a rebooted motor to answer again."""
MOVING = (
    f"a Q preset {Q_STEP_DEG:g} deg away with time 0, and its start (the reply to a preset; what a Q time of 0 does)",
    "a P command back to where the joint was (the reply to a control frame; it ends any other motion)",
)


def register(sub: Any) -> None:
    p = sub.add_parser(
        "doctor",
        help="measure what the motors' firmware does where the protocol document is uncertain",
        description=(
            "Probe each motor for the readings spec/PROTOCOL.md marks uncertain: versions, the command values "
            "of its state frames, fast read, reply-state triggers, heartbeat, boot time (--reboot), Q time 0 "
            "(--yes). Attach the --json output to an issue to report a firmware."
        ),
    )
    add_ids_arg(p, optional=True)
    p.add_argument("--reboot", action="store_true", help="reboot each motor and measure its boot time")
    p.add_argument("--yes", action="store_true", help="also run the probes that can move a joint (listed first)")
    p.add_argument(
        "--factory-id",
        action="store_true",
        help="with --yes: measure the factory node id (init_config, then the configuration restored and verified)",
    )
    p.add_argument("--write-profile", metavar="FILE", help="save what the client uses (open_bus(profile=FILE))")
    add_json_arg(p)
    add_connection_args(p)
    p.set_defaults(func=run)


class _Capture:
    """Every frame the bus receives."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.frames: list[Frame] = []

    def __call__(self, frame: Frame, tx: bool) -> None:
        if not tx:
            with self.lock:
                self.frames.append(frame)

    def since(self, mark: int) -> list[Frame]:
        with self.lock:
            return self.frames[mark:]

    def mark(self) -> int:
        with self.lock:
            return len(self.frames)

    def states_of(self, node: int, since: int) -> list[int]:
        """The command values of the frames with bit 0 set from ``node`` since mark ``since``."""
        with self.lock:
            got = self.frames[since:]
        return [f.arbitration_id & 0x1F for f in got if f.arbitration_id >> 5 == node and f.arbitration_id & 1]


def _wait(bus: Any, seconds: float) -> None:
    """Let ``seconds`` pass on the bus's clock (simulated time on a virtual-clock simulator)."""
    bus.run(sleep(seconds))


def _finding(section: str, item: str, text: str) -> dict[str, str]:
    return {"section": section, "item": item, "text": text}


def _hex(cmd: int) -> str:
    return f"0x{cmd:02x}"


def _bits_of(ids: list[int]) -> str | None:
    if not ids:
        return None
    if all(c < 0x08 for c in ids):
        return "zero"
    return "kept" if all(c & 0x18 for c in ids) else "mixed"


def _probe(bus: Any, cap: _Capture, node: int, args: argparse.Namespace) -> dict[str, Any] | None:
    """Measure motor ``node``; None when it answers nothing."""
    motor = bus.motor(node)
    timeout = bus.timeout
    findings: list[dict[str, str]] = []
    knobs: dict[str, Any] = dict.fromkeys(
        ("status_bits", "boot_s", "reply_state", "fast_read", "q_time_zero", "heartbeat", "factory_id")
    )
    status_ids: list[str] = []
    seen: list[int] = []

    def versions() -> tuple[int | None, int | None]:
        out: list[int | None] = []
        for name in ("fw_version", "hw_version"):
            try:
                out.append(int(motor.read_property(name)))
            except TimeoutError:
                out.append(None)
        return out[0], out[1]

    # fast read [1.6 item 1]
    mark = cap.mark()
    try:
        motor.get_state()
        knobs["fast_read"] = True
    except TimeoutError:
        knobs["fast_read"] = False
    fast = cap.states_of(node, mark)
    firmware, hardware = versions()
    if firmware is None and hardware is None and not fast:
        return None
    if fast:
        seen.append(fast[0])
        status_ids.append(_hex(fast[0]))
        knobs["fast_read"] = True
        findings.append(_finding("1.6", "fast_read", f"a fast read is answered with command {_hex(fast[0])}"))
    else:
        findings.append(_finding("1.6", "fast_read", "no answer to a fast read (firmware 1.1 or older?)"))

    # reply-state triggers [1.6 item 2]: a write (a frame that triggers no reply by the document's list)
    reply_before = motor.read_property(REPLY_STATE)
    mark = cap.mark()
    motor.write_property(REPLY_STATE, 1)
    _wait(bus, timeout)
    write_reply = cap.states_of(node, mark)
    if write_reply:
        knobs["reply_state"] = "all"
        findings.append(_finding("1.6", "reply_state", "a write is answered with a state frame (reply-state on)"))

    # heartbeat [1.6 item 3]: heartbeat_ms in RAM for a moment
    hb_before = motor.read_property(HEARTBEAT)
    mark = cap.mark()
    motor.write_property(HEARTBEAT, HEARTBEAT_PROBE_MS)
    _wait(bus, HEARTBEAT_PROBE_MS / 1000 * 4.5)
    motor.write_property(HEARTBEAT, hb_before)
    beats = len(cap.states_of(node, mark)) - (2 if write_reply else 0)
    knobs["heartbeat"] = beats >= 2
    findings.append(
        _finding(
            "1.6",
            "heartbeat",
            f"{max(beats, 0)} state frames in {HEARTBEAT_PROBE_MS * 4.5:g} ms with heartbeat_ms = {HEARTBEAT_PROBE_MS}"
            + ("" if knobs["heartbeat"] else ": no heartbeat"),
        )
    )

    if args.yes:
        _moving_probes(bus, cap, node, knobs, findings, seen, status_ids, bool(write_reply))
    else:
        findings.append(
            _finding("1.6", "reply_state", "control and preset replies not probed (they can move a joint: --yes)")
        )
        findings.append(_finding("3.4.3", "q_time_zero", "not probed (it moves the joint: --yes)"))
    motor.write_property(REPLY_STATE, reply_before)

    bits = _bits_of(seen)
    knobs["status_bits"] = bits if bits in ("zero", "kept") else None
    if bits is not None:
        findings.append(
            _finding("1.6", "status_bits", f"bits 3-4 of the state frames: {bits} ({', '.join(status_ids)})")
        )

    boot_s = None
    if args.reboot:
        boot_s = _reboot(bus, node, bool(knobs["fast_read"]))
        knobs["boot_s"] = None if boot_s is None else round(boot_s, 3)
        text = f"answers again {boot_s:.3f} s after a reboot" if boot_s is not None else "no answer after a reboot"
        findings.append(_finding("3.3", "boot_s", text))
    else:
        findings.append(_finding("3.3", "boot_s", "not measured (--reboot)"))
    failed = False
    if args.factory_id and not knobs["fast_read"]:
        findings.append(_finding("3.8", "factory_id", "not measured: backing the configuration up needs the fast read"))
    elif args.factory_id:
        res = _factory_id.probe_factory_id(
            bus,
            node,
            mark=cap.mark,
            count_replies=lambda n, since: _factory_id.count_replies(cap.since(since), n),
            wait=lambda s: _wait(bus, s),
            reboot_limit_s=REBOOT_LIMIT_S,
        )
        knobs["factory_id"] = res.factory_id
        findings += [_finding("3.8", "factory_id", line) for line in res.steps]
        failed = not res.ok
    else:
        findings.append(
            _finding(
                "3.8",
                "factory_id",
                "not measured: only init_config shows it, and that replaces the configuration "
                "(--yes --factory-id measures it, then restores and verifies the configuration)",
            )
        )
    record: dict[str, Any] = {
        "id": node,
        "firmware": firmware,
        "hardware": hardware,
        "status_ids": status_ids,
    }
    if boot_s is not None:
        record["boot_s"] = round(boot_s, 3)
    record["knobs"] = knobs
    record["findings"] = findings
    if failed:
        record["failed"] = True
    return record


def _moving_probes(
    bus: Any,
    cap: _Capture,
    node: int,
    knobs: dict[str, Any],
    findings: list[dict[str, str]],
    seen: list[int],
    status_ids: list[str],
    write_replies: bool,
) -> None:
    """The preset, Q-time-0 and control probes (reply-state is on): a Q preset away with time 0 and its
    start, then a P command back to where the joint was."""
    timeout = bus.timeout
    motor = bus.motor(node)

    def angle_now() -> float:
        if knobs["fast_read"]:
            return float(motor.get_state().angle)
        return float(motor.read_property("axis0.output_shaft.pos_estimate"))

    angle = angle_now()
    closed_loop = int(motor.read_property("axis0.current_state")) == 8
    mark = cap.mark()
    bus.send_many([PresetQ(node, angle + Q_STEP_DEG, 0.0, 300.0), Start(node, StartKind.Q)])  # started at once
    _wait(bus, max(0.5, timeout))
    preset = cap.states_of(node, mark)
    moved = angle_now()
    mark = cap.mark()
    bus.send(PositionP(node, angle))  # back where it was
    _wait(bus, max(0.5, timeout))
    control = cap.states_of(node, mark)
    for got in (control, preset):
        if got:
            seen.append(got[0])
            status_ids.append(_hex(got[0]))
    if knobs["reply_state"] is None:
        knobs["reply_state"] = "control+preset" if control and preset else "control" if control else None
    findings.append(
        _finding(
            "1.6",
            "reply_state",
            f"reply-state answers: control {'yes' if control else 'no'}, preset {'yes' if preset else 'no'}, "
            f"write {'yes' if write_replies else 'no'}",
        )
    )
    if not closed_loop:
        findings.append(_finding("3.4.3", "q_time_zero", "not measured: the axis is not in closed loop"))
        return
    knobs["q_time_zero"] = "fastest" if abs(moved - angle) > Q_STEP_DEG / 2 else "ignore"
    findings.append(
        _finding(
            "3.4.3",
            "q_time_zero",
            f"a Q preset with time 0 {'moved' if knobs['q_time_zero'] == 'fastest' else 'did not move'} the joint "
            f"({angle:.2f} -> {moved:.2f} deg)",
        )
    )


def _reboot(bus: Any, node: int, fast_read: bool) -> float | None:
    """Reboot ``node`` and return how long (s) until it answers again."""
    poll = FastRead(node) if fast_read else ReadParam(node, FW_VERSION, DataType.U32)
    bus.motor(node).reboot()
    t0 = bus.now()
    while bus.now() - t0 < REBOOT_LIMIT_S:
        try:
            bus.request([poll], timeout=0.01)
        except TimeoutError:
            continue
        return float(bus.now() - t0)
    return None


def _find(bus: Any) -> list[int]:
    """The motors that answer a fast read, or else a read of their firmware version (firmware without the
    fast read)."""
    found = [m.id for m in bus.scan()]
    if found:
        return found
    reads = [ReadParam(i, FW_VERSION, DataType.U32) for i in range(1, 64)]
    return [r.node for r in bus.request(reads, missing_ok=True) if r is not None]


def _text(rec: dict[str, Any]) -> str:
    lines = [
        f"motor {rec['id']}: firmware {rec['firmware']}, hardware {rec['hardware']}, "
        f"status ids {', '.join(rec['status_ids']) or 'none'}"
        + (f", boot {rec['boot_s']:.3f} s" if "boot_s" in rec else "")
    ]
    lines += [f"  [{f['section']}] {f['item']}: {f['text']}" for f in rec["findings"]]
    return "\n".join(lines)


def _bus_findings(bus: Any, cap: _Capture, seconds: float) -> dict[str, Any]:
    stats = bus.stats
    load = None
    wire = getattr(bus._core.transport, "wire_bitrate", None)
    with cap.lock:
        n = len(cap.frames)
    if wire:
        load = round(n * 111 / (wire * seconds), 4)  # a standard frame of 8 bytes: about 111 bits
    return {
        "bus": True,
        "frames_received": n,
        "other_hosts": bool(bus._session.other_hosts),
        "foreign_frames": stats["foreign"],
        "malformed_frames": stats["malformed"],
        "load": load,
        "error_frames": None,
        "findings": [
            _finding(
                "4",
                "bus",
                ("another host was heard" if bus._session.other_hosts else "no other host heard")
                + f"; {stats['malformed']} malformed frames; error frames are not reported by this interface",
            )
        ],
    }


def run(args: argparse.Namespace) -> int:
    if args.factory_id and not args.yes:
        raise UsageError("--factory-id: needs --yes (it replaces the configuration, then restores it)")
    if args.yes:
        print(
            "drempower doctor: with --yes these probes can move a joint"
            + (" or change a motor's configuration:" if args.factory_id else ":"),
            file=sys.stderr,
        )
        for what in MOVING + ((_factory_id.WHAT,) if args.factory_id else ()):
            print(f"  - {what}", file=sys.stderr)
    records: list[dict[str, Any]] = []
    missing: list[int] = []
    with open_from_args(args) as bus:
        t0 = bus.now()
        cap = _Capture()
        bus.add_tap(cap)
        ids: list[int] = list(args.ids) or _find(bus)
        if not ids:
            raise DrEmpowerError(
                "no motor answered a scan of ids 1-63: check the connection, the bitrate and the power"
            )
        for node in ids:
            rec = _probe(bus, cap, node, args)
            if rec is None:
                missing.append(node)
            else:
                records.append(rec)
        summary = _bus_findings(bus, cap, max(bus.now() - t0, 1e-3))
    for rec in records:
        print(json_line(rec) if args.json else "\n".join(map(clean, _text(rec).split("\n"))))
    if args.json:
        print(json_line(summary))
    else:
        print(clean(f"bus: {summary['findings'][0]['text']}"))
    for node in missing:
        print(f"drempower: motor {node} answered nothing", file=sys.stderr)
    for rec in records:
        if rec.get("failed"):
            print(
                f"drempower: motor {rec['id']}: the factory-id probe failed; its findings say where the motor is "
                "and how to recover",
                file=sys.stderr,
            )
    if args.write_profile:
        _write_profile(args.write_profile, records)
    if not records:
        raise DrEmpowerError(f"no motor answered (motor {', '.join(map(str, missing))})")
    return 1 if missing or any(r.get("failed") for r in records) else 0


def _write_profile(path: str, records: list[dict[str, Any]]) -> None:
    bits = {r["knobs"]["status_bits"] for r in records}
    common = bits.pop() if len(bits) == 1 else None
    motors = {
        r["id"]: {k: v for k, v in {**r["knobs"], "firmware": r["firmware"], "hardware": r["hardware"]}.items()}
        for r in records
    }
    profile = FirmwareProfile(common if common in ("zero", "kept") else "auto", motors)
    try:
        with open(path, "w", encoding="utf-8") as f:
            json.dump(profile.to_json(), f, indent=1)
            f.write("\n")
    except OSError as exc:
        from ..errors import ValidationError

        raise ValidationError(f"--write-profile {path}: cannot write ({exc.strerror or exc})") from None
