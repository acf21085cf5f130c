"""Configuration backup and restore: every readable parameter of a motor to JSON and back."""

from __future__ import annotations

import datetime as _dt
import json
import os
import struct
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from ...errors import BackupFileError, ValidationError
from ...protocol.addresses import (
    AXIS0_CONFIG_CAN_NODE_ID,
    AXIS0_CONTROLLER_INPUT_POS,
    AXIS0_CONTROLLER_INPUT_TORQUE,
    AXIS0_CONTROLLER_INPUT_VEL,
    AXIS0_MOTOR_CURRENT_CONTROL_FINAL_V_ALPHA,
    AXIS0_MOTOR_CURRENT_CONTROL_FINAL_V_BETA,
    AXIS0_MOTOR_CURRENT_CONTROL_IBUS,
    AXIS0_MOTOR_CURRENT_CONTROL_ID_SETPOINT,
    AXIS0_MOTOR_ERROR,
    AXIS0_OUTPUT_SHAFT_INPUT_POS,
    AXIS0_OUTPUT_SHAFT_INPUT_TORQUE,
    AXIS0_OUTPUT_SHAFT_INPUT_VEL,
    AXIS0_REQUESTED_STATE,
    CAN_CONFIG_BAUD_RATE,
    CONFIG_UART_BAUDRATE,
)
from ...protocol.ids import SysCmd
from ...protocol.limits import is_motor
from ...protocol.messages import ParamValue, ReadParam, SystemCommand, WriteParam
from ...protocol.parameters import Access, DataType, Parameter, encode_value, find_parameter, parameters
from .effects import Op, Send, read_states, request
from .session import BusSession

__all__ = [
    "BackupFileError",
    "ParamRecord",
    "ConfigBackup",
    "RestoreReport",
    "backup",
    "restore",
    "NOT_RESTORED",
    "LINK_PARAMETERS",
]

FORMAT = "drempower-config-backup"
VERSION = 1

NOT_RESTORED = frozenset(
    {
        AXIS0_REQUESTED_STATE,  # a command, not configuration
        AXIS0_CONTROLLER_INPUT_POS,  # setpoints: writing them moves the motor
        AXIS0_CONTROLLER_INPUT_VEL,
        AXIS0_CONTROLLER_INPUT_TORQUE,
        AXIS0_MOTOR_ERROR,  # an error word
        AXIS0_MOTOR_CURRENT_CONTROL_IBUS,  # current_control.*: live loop values
        AXIS0_MOTOR_CURRENT_CONTROL_FINAL_V_ALPHA,
        AXIS0_MOTOR_CURRENT_CONTROL_FINAL_V_BETA,
        AXIS0_MOTOR_CURRENT_CONTROL_ID_SETPOINT,
        AXIS0_OUTPUT_SHAFT_INPUT_POS,  # setpoints
        AXIS0_OUTPUT_SHAFT_INPUT_VEL,
        AXIS0_OUTPUT_SHAFT_INPUT_TORQUE,
    }
)
"""Writable parameters that are live values or commands, never restored."""

LINK_PARAMETERS = frozenset({AXIS0_CONFIG_CAN_NODE_ID, CAN_CONFIG_BAUD_RATE, CONFIG_UART_BAUDRATE})
"""Id and bitrates: restored only with ``include_link=True`` (they change how the motor is reached)."""

_F32 = struct.Struct("<f")


@dataclass(frozen=True, slots=True)
class ParamRecord:
    """One parameter in a backup: its name, address, type, unit, access and value (None if unread)."""

    name: str
    address: int
    type: str
    unit: str
    access: str
    value: int | float | None


@dataclass(slots=True)
class ConfigBackup:
    """Every readable parameter of one motor, as read at ``created`` (ISO 8601, UTC)."""

    node: int
    created: str
    parameters: list[ParamRecord]

    @property
    def failed(self) -> list[str]:
        """Names of the parameters that could not be read."""
        return [p.name for p in self.parameters if p.value is None]

    def values(self) -> dict[str, int | float]:
        """Parameter name -> value, for the parameters that were read."""
        return {p.name: p.value for p in self.parameters if p.value is not None}

    def to_json(self) -> dict[str, Any]:
        return {
            "format": FORMAT,
            "version": VERSION,
            "node": self.node,
            "created": self.created,
            "parameters": [asdict(p) for p in self.parameters],
        }

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the backup as JSON."""
        Path(path).write_text(json.dumps(self.to_json(), indent=1) + "\n", encoding="utf-8")

    @classmethod
    def from_json(cls, doc: object) -> ConfigBackup:
        """Check and convert a parsed backup document.

        Raises :class:`BackupFileError` listing every malformed record (a value
        that is no number, a fraction for an integer parameter, out of its
        type's range, ...) rather than stopping at the first.
        """
        if not isinstance(doc, dict):
            raise BackupFileError(f"not a {FORMAT} document: the top level is {_json_type(doc)}, not an object")
        if doc.get("format") != FORMAT or doc.get("version") != VERSION:
            raise BackupFileError(f"not a {FORMAT} version {VERSION} document")
        node = doc.get("node")
        if not is_motor(node):
            raise BackupFileError(f"node={node!r}: expected a motor id 1..63")
        created = doc.get("created")
        if not isinstance(created, str):
            raise BackupFileError(f"created={created!r}: expected a date (ISO 8601 text)")
        records = doc.get("parameters")
        if not isinstance(records, list):
            raise BackupFileError(f"parameters: expected a list of records, got {_json_type(records)}")
        params: list[ParamRecord] = []
        problems: list[tuple[str, str]] = []
        for i, raw in enumerate(records):
            rec, problem = _record(i, raw)
            if problem is not None:
                problems.append(problem)
            elif rec is not None:
                params.append(rec)
        if problems:
            raise BackupFileError("", problems)
        return cls(node, created, params)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> ConfigBackup:
        """Read a backup written by :meth:`save`; raises :class:`BackupFileError` naming every problem."""
        try:
            doc = json.loads(Path(path).read_text(encoding="utf-8"))
        except (OSError, ValueError, RecursionError) as exc:  # RecursionError: JSON nested too deeply
            raise BackupFileError(f"cannot read backup {os.fspath(path)!r}: {exc}") from exc
        try:
            return cls.from_json(doc)
        except BackupFileError as exc:
            reason = f"backup {os.fspath(path)!r}" + (f": {exc.reason}" if exc.reason else "")
            raise BackupFileError(reason, exc.problems) from None


def _json_type(value: object) -> str:
    """The JSON kind of ``value`` with its article: "an object", "a list", "a string"..."""
    kinds = {dict: "an object", list: "a list", str: "a string", bool: "a boolean", type(None): "null"}
    return kinds.get(type(value), "a number")


_RECORD_FIELDS = frozenset(("name", "address", "type", "unit", "access", "value"))


def _record(i: int, raw: object) -> tuple[ParamRecord | None, tuple[str, str] | None]:
    """One record of a backup document, or (None, (what, why))."""
    if not isinstance(raw, dict):
        return None, (f"record {i}", f"expected an object, got {_json_type(raw)}")
    name = raw.get("name")
    label: str = name if isinstance(name, str) else f"record {i}"
    if set(raw) != _RECORD_FIELDS:
        missing, extra = sorted(_RECORD_FIELDS - set(raw)), sorted(set(raw) - _RECORD_FIELDS)
        why = ", ".join(
            ([f"missing {', '.join(missing)}"] if missing else []) + ([f"unknown {', '.join(extra)}"] if extra else [])
        )
        return None, (label, why)
    address = raw["address"]
    if not isinstance(name, str) or address.__class__ is not int:
        return None, (label, f"name {name!r} and address {address!r}: expected text and a whole number")
    for key in ("type", "unit", "access"):
        if not isinstance(raw[key], str):
            return None, (name, f"{key}={raw[key]!r}: expected text")
    value = raw["value"]
    p = find_parameter(address)
    if p is None or p.name != name:  # from another version: restore reports it, writes the others
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float))):
            return None, (name, f"value {value!r} is {_json_type(value)}: expected a number")
        return ParamRecord(name, address, raw["type"], raw["unit"], raw["access"], value), None
    if raw["type"] != p.dtype.name.lower():
        return None, (name, f"type {raw['type']!r}: this parameter is {p.dtype.name.lower()}")
    if value is not None:
        problem = _value_problem(p, value)
        if problem is not None:
            return None, (name, problem)
    return ParamRecord(name, address, raw["type"], raw["unit"], raw["access"], value), None


def _value_problem(p: Parameter, value: object) -> str | None:
    """Why ``value`` cannot be a value of ``p`` (None when it can); null (unread) is allowed elsewhere."""
    kind = p.dtype.name.lower()
    if p.dtype is DataType.F32:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return f"value {value!r} is {_json_type(value)}: expected a number ({kind})"
    elif value.__class__ is not int:
        what = "a fraction" if isinstance(value, float) else _json_type(value)
        return f"value {value!r} is {what}: expected a whole number ({kind})"
    try:
        encode_value(p.dtype, value, field="value")
    except ValidationError as exc:
        return str(exc)
    return None


@dataclass(slots=True)
class RestoreReport:
    """What :func:`restore` did.

    ``written``: (name, value before, value restored) for each parameter that
    differed and was written and verified; ``unchanged``: names already equal;
    ``skipped``: names not written (read-only, live values, link settings, or
    unread in the backup); ``failed``: (name, reason). ``saved`` tells whether
    save_config was sent. ``node`` is the id the motor answers to afterwards
    (another one when ``include_link`` restored ``can_node_id``).
    """

    written: list[tuple[str, int | float, int | float]] = field(default_factory=list)
    unchanged: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    failed: list[tuple[str, str]] = field(default_factory=list)
    saved: bool = False
    node: int = 0

    @property
    def ok(self) -> bool:
        return not self.failed


def _reads(node: int, params: list[Parameter]) -> list[ReadParam]:
    return [ReadParam(node, p.address, p.dtype) for p in params]


def _value(reply: object) -> int | float | None:
    return reply.value if isinstance(reply, ParamValue) else None


def backup(node: int, timeout: float | None = None) -> Op[ConfigBackup]:
    """Read every parameter of ``node``; unreadable ones are kept with value None.

    Starts with a fast read, so a motor that does not answer fails at once.
    """
    yield from read_states([node], timeout)
    params = list(parameters())
    replies = yield from request(_reads(node, params), timeout, missing_ok=True)
    records = [
        ParamRecord(p.name, p.address, p.dtype.name.lower(), p.unit, p.access.value, _value(r))
        for p, r in zip(params, replies, strict=True)
    ]
    created = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    return ConfigBackup(node, created, records)


def _same(dtype: DataType, a: float, b: float) -> bool:
    if dtype is DataType.F32:
        return _F32.pack(a) == _F32.pack(b)
    return int(a) == int(b)


_NODE_ID = AXIS0_CONFIG_CAN_NODE_ID


def _plan(
    source: ConfigBackup, node: int, include_link: bool, force: bool, report: RestoreReport
) -> list[tuple[Parameter, int | float]]:
    """What to restore, every value checked before any frame; raises naming every problem."""
    if source.node != node and not force:
        raise BackupFileError(f"the backup is of motor {source.node}, not motor {node} (force=True restores it)")
    seen: dict[int, int] = {}
    for rec in source.parameters:
        seen[rec.address] = seen.get(rec.address, 0) + 1
    dups = sorted(a for a, n in seen.items() if n > 1)
    if dups and not force:
        names = ", ".join(f"{_name(a)} ({seen[a]} times)" for a in dups)
        raise BackupFileError(f"duplicated records: {names} (force=True restores the last of each)")
    last = {rec.address: rec for rec in source.parameters}  # with force, the last record of an address wins
    todo: list[tuple[Parameter, int | float]] = []
    problems: list[tuple[str, str]] = []
    for rec in last.values():
        p = find_parameter(rec.address)
        if p is None or p.name != rec.name:
            report.failed.append((rec.name, "unknown to this version of drempower"))
            continue
        if (
            rec.value is None
            or p.access is not Access.RW
            or p.address in NOT_RESTORED
            or (p.address in LINK_PARAMETERS and not include_link)
        ):
            report.skipped.append(p.name)
            continue
        try:
            WriteParam.of(node, p, rec.value, force=force)
        except ValidationError as exc:
            problems.append((p.name, str(exc)))
            continue
        todo.append((p, rec.value))
    if problems:
        raise BackupFileError("nothing written", problems)
    return todo


def _name(address: int) -> str:
    p = find_parameter(address)
    return p.name if p is not None else str(address)


def _write_verified(
    core: BusSession,
    node: int,
    writes: list[tuple[Parameter, int | float, int | float]],
    timeout: float | None,
    report: RestoreReport,
    verify_at: int | None = None,
) -> Op[bool]:
    """Write, then read back (at ``verify_at`` when the write moves the motor); True when all verified.

    A value that reads back different is written and read again (at the motor's new id when
    ``verify_at`` is given) up to the bus's ``retries`` times: a lost write gets no reply.
    """
    if not writes:
        return True
    yield Send([WriteParam(node, p.address, p.dtype, new) for p, _, new in writes])  # checked by _plan
    at = node if verify_at is None else verify_at
    if at != node:
        core.forget(node)
        core.forget(at)
    check = yield from request(_reads(at, [p for p, _, _ in writes]), timeout, missing_ok=True)
    for _ in range(core.retries):
        wrong = [
            i
            for i, ((p, _, new), r) in enumerate(zip(writes, check, strict=True))
            if (got := _value(r)) is not None and not _same(p.dtype, new, got)
        ]
        if not wrong:
            break
        yield Send([WriteParam(at, writes[i][0].address, writes[i][0].dtype, writes[i][2]) for i in wrong])
        again = yield from request(_reads(at, [writes[i][0] for i in wrong]), timeout, missing_ok=True)
        check = list(check)
        for i, r in zip(wrong, again, strict=True):
            check[i] = r
    ok = True
    for (p, old, new), reply in zip(writes, check, strict=True):
        got = _value(reply)
        if got is None:
            where = "" if at == node else f" at its new id {at}"
            report.failed.append((p.name, f"no answer{where} when verifying the write"))
            ok = False
        elif not _same(p.dtype, new, got):
            report.failed.append((p.name, f"reads {got!r} after writing {new!r}"))
            ok = False
        else:
            report.written.append((p.name, old, new))
        if got is not None:
            core.learn(at, p.address, got)
    return ok


def restore(
    core: BusSession,
    node: int,
    source: ConfigBackup | str | os.PathLike[str],
    timeout: float | None = None,
    *,
    include_link: bool = False,
    save: bool = False,
    dry_run: bool = False,
    force: bool = False,
) -> Op[RestoreReport]:
    """Write the writable configuration in ``source`` (a backup or its JSON file) back to ``node``.

    Reads the current values first, writes only those that differ, then reads
    them back to verify. Read-only parameters, live values and commands
    (:data:`NOT_RESTORED`), and unless ``include_link`` the id and bitrates are
    skipped. ``save`` sends save_config when everything was restored;
    ``dry_run`` reports the differences without writing.

    Every value is checked before the first frame: a value the parameter
    cannot take refuses the whole restore (:class:`BackupFileError`, one
    entry per parameter), and so does a backup of another motor id or one
    with duplicated records, unless ``force`` (which also lets values outside
    a soft domain through, never outside a hard one or the wire range). With ``include_link`` the bit
    rates are written only after every other parameter was verified, and
    ``can_node_id`` last of all: the motor answers to its new id at once, so
    that write is verified there, and ``save`` goes to the new id.
    """
    if not isinstance(source, ConfigBackup):
        source = ConfigBackup.load(source)
    report = RestoreReport(node=node)
    todo = _plan(source, node, include_link, force, report)
    yield from read_states([node], timeout)
    current = yield from request(_reads(node, [p for p, _ in todo]), timeout, missing_ok=True)
    writes: list[tuple[Parameter, int | float, int | float]] = []
    for (p, want), reply in zip(todo, current, strict=True):
        now = _value(reply)
        if now is None:
            report.failed.append((p.name, "no answer when reading the current value"))
        elif _same(p.dtype, want, now):
            report.unchanged.append(p.name)
        else:
            writes.append((p, now, want))
    if dry_run:
        report.written = [(p.name, old, new) for p, old, new in writes]
        return report
    # the link settings last, once everything else is verified: the id last of all, verified at the new id
    link = [w for w in writes if w[0].address in LINK_PARAMETERS]
    rest = [w for w in writes if w[0].address not in LINK_PARAMETERS]
    ok = yield from _write_verified(core, node, rest, timeout, report)
    if link and not (ok and report.ok):
        report.failed += [(p.name, "not written: the other parameters were not all restored") for p, _, _ in link]
        return report
    rates = [w for w in link if w[0].address != _NODE_ID]
    ok = yield from _write_verified(core, node, rates, timeout, report)
    ids = [w for w in link if w[0].address == _NODE_ID]
    if ids and ok:
        new_id = int(ids[0][2])
        (taken,) = yield from read_states([new_id], timeout, missing_ok=True)
        if taken is not None:  # two motors must never end up sharing an id
            report.failed.append((ids[0][0].name, f"not written: id {new_id} is already taken by another motor"))
        elif (yield from _write_verified(core, node, ids, timeout, report, verify_at=new_id)):
            report.node = new_id
    elif ids:
        report.failed.append((ids[0][0].name, "not written: the bit rates were not restored"))
    if save and report.ok:
        yield Send([SystemCommand(report.node, SysCmd.SAVE_CONFIG)])
        report.saved = True
    return report
