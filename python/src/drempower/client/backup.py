"""Configuration backup and restore: every readable parameter of a motor to JSON and back."""

from __future__ import annotations

import datetime as _dt
import json
import os
import struct
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from ..errors import ValidationError
from ..protocol.ids import SysCmd
from ..protocol.messages import ParamValue, ReadParam, SystemCommand, WriteParam
from ..protocol.parameters import Access, DataType, Parameter, find_parameter, parameters
from .core import BusCore
from .effects import Op, Send, read_states, request

__all__ = ["ParamRecord", "ConfigBackup", "RestoreReport", "backup", "restore", "NOT_RESTORED", "LINK_PARAMETERS"]

FORMAT = "drempower-config-backup"
VERSION = 1

NOT_RESTORED = frozenset(
    {
        30003,  # axis0.requested_state: a command, not configuration
        32002,  # controller.input_pos/vel/torque: setpoints, writing them moves the motor
        32003,
        32004,
        33001,  # motor.error: an error word
        33201,  # current_control.*: live loop values
        33202,
        33203,
        33204,
        38001,  # output_shaft.input_pos/vel/torque: setpoints
        38002,
        38003,
    }
)
"""Writable parameters that are live values or commands, never restored."""

LINK_PARAMETERS = frozenset({31001, 21001, 10001})
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
    def from_json(cls, doc: dict[str, Any]) -> ConfigBackup:
        if doc.get("format") != FORMAT or doc.get("version") != VERSION:
            raise ValidationError(f"not a {FORMAT} version {VERSION} document")
        try:
            params = [ParamRecord(**p) for p in doc["parameters"]]
            return cls(int(doc["node"]), str(doc["created"]), params)
        except (KeyError, TypeError, ValueError) as exc:
            raise ValidationError(f"malformed backup: {exc}") from exc

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> ConfigBackup:
        """Read a backup written by :meth:`save`."""
        try:
            doc = json.loads(Path(path).read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise ValidationError(f"cannot read backup {os.fspath(path)!r}: {exc}") from exc
        return cls.from_json(doc)


@dataclass(slots=True)
class RestoreReport:
    """What :func:`restore` did.

    ``written``: (name, value before, value restored) for each parameter that
    differed and was written and verified; ``unchanged``: names already equal;
    ``skipped``: names not written (read-only, live values, link settings, or
    unread in the backup); ``failed``: (name, reason). ``saved`` tells whether
    save_config was sent.
    """

    written: list[tuple[str, int | float, int | float]] = field(default_factory=list)
    unchanged: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    failed: list[tuple[str, str]] = field(default_factory=list)
    saved: bool = False

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


def restore(
    core: BusCore,
    node: int,
    source: ConfigBackup | str | os.PathLike[str],
    timeout: float | None = None,
    *,
    include_link: bool = False,
    save: bool = False,
    dry_run: bool = False,
) -> Op[RestoreReport]:
    """Write the writable configuration in ``source`` (a backup or its JSON file) back to ``node``.

    Reads the current values first, writes only those that differ, then reads
    them back to verify. Read-only parameters, live values and commands
    (:data:`NOT_RESTORED`), and unless ``include_link`` the id and bitrates are
    skipped. ``save`` sends save_config when everything was restored;
    ``dry_run`` reports the differences without writing.
    """
    if not isinstance(source, ConfigBackup):
        source = ConfigBackup.load(source)
    report = RestoreReport()
    todo: list[tuple[Parameter, int | float]] = []
    for rec in source.parameters:
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
        todo.append((p, rec.value))
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
            try:
                WriteParam.of(node, p, want)
            except ValidationError as exc:
                report.failed.append((p.name, str(exc)))
                continue
            writes.append((p, now, want))
    if dry_run:
        report.written = [(p.name, old, new) for p, old, new in writes]
        return report
    yield Send([WriteParam.of(node, p, new) for p, _, new in writes])
    check = yield from request(_reads(node, [p for p, _, _ in writes]), timeout, missing_ok=True)
    for (p, old, new), reply in zip(writes, check, strict=True):
        got = _value(reply)
        if got is None:
            report.failed.append((p.name, "no answer when verifying the write"))
        elif not _same(p.dtype, new, got):
            report.failed.append((p.name, f"reads {got!r} after writing {new!r}"))
        else:
            report.written.append((p.name, old, new))
        if got is not None:
            core.learn(node, p.address, got)
    if save and report.ok:
        yield Send([SystemCommand(node, SysCmd.SAVE_CONFIG)])
        report.saved = True
    return report
