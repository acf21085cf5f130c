"""Firmware profiles: what ``drempower doctor`` measured on real motors, as the client uses it.

A profile is a JSON object (``drempower doctor --write-profile FILE`` writes one)::

    {"profile": 1, "status_bits": "kept",
     "motors": {"1": {"status_bits": "kept", "firmware": "...", "boot_s": 0.41}}}

``status_bits`` (``auto``, ``zero`` or ``kept``, spec/PROTOCOL.md section 1.6) is what the
client assumes of a motor not listed; each listed motor's own value overrides it. Other
keys of a motor are what doctor measured, kept for reports; the client does not use them.
``open_bus(..., profile=FILE_OR_DICT)`` and ``--profile FILE`` on the command line apply it.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ...errors import ConfigError
from ...protocol.limits import MAX_NODE
from ..engine.status_bits import STATUS_BITS, StatusBits, StatusBitsSetting

__all__ = ["PROFILE_VERSION", "FirmwareProfile", "load_profile", "apply_profile"]

PROFILE_VERSION = 1
"""The ``profile`` key of the files this version writes and reads."""


@dataclass(frozen=True)
class FirmwareProfile:
    """``status_bits`` for motors not in ``motors``; ``motors``: id -> what doctor measured of it."""

    status_bits: StatusBitsSetting = "auto"
    motors: Mapping[int, Mapping[str, Any]] = field(default_factory=dict)
    source: str = "<profile>"

    def status_bits_of(self, node: int) -> StatusBitsSetting:
        """What the client assumes of ``node``'s state frames."""
        m = self.motors.get(node)
        bits = m.get("status_bits") if m is not None else None
        return bits if bits in ("zero", "kept") else self.status_bits

    def to_json(self) -> dict[str, Any]:
        """The JSON object of this profile."""
        return {
            "profile": PROFILE_VERSION,
            "status_bits": self.status_bits,
            "motors": {str(k): dict(v) for k, v in sorted(self.motors.items())},
        }


def _bits(value: object, where: str) -> StatusBitsSetting:
    if value not in STATUS_BITS:
        raise ConfigError(f"{where}: status_bits={value!r}: one of {', '.join(map(repr, STATUS_BITS))}")
    return value


def load_profile(src: str | os.PathLike[str] | Mapping[str, Any] | FirmwareProfile) -> FirmwareProfile:
    """A profile from a file, a JSON-like mapping or a profile; a bad one raises ConfigError naming the key."""
    if isinstance(src, FirmwareProfile):
        return src
    where = "profile"
    if isinstance(src, Mapping):
        data: Any = src
    else:
        import json  # here: importing drempower loads no json

        where = os.fspath(src)
        try:
            with open(where, encoding="utf-8") as f:
                data = json.load(f)
        except OSError as exc:
            raise ConfigError(f"{where}: cannot read the profile ({exc.strerror or exc})") from None
        except ValueError as exc:
            raise ConfigError(f"{where}: not a JSON profile ({exc})") from None
    if not isinstance(data, Mapping):
        raise ConfigError(f"{where}: a profile is a JSON object, got {type(data).__name__}")
    version = data.get("profile", PROFILE_VERSION)
    if version != PROFILE_VERSION:
        raise ConfigError(f"{where}: profile={version!r}: this version reads profile {PROFILE_VERSION}")
    extra = sorted(set(data) - {"profile", "status_bits", "motors"})
    if extra:
        raise ConfigError(f"{where}: unknown key {extra[0]!r}: a profile has profile, status_bits, motors")
    bits = _bits(data.get("status_bits", "auto"), where)
    motors: dict[int, Mapping[str, Any]] = {}
    raw = data.get("motors", {})
    if not isinstance(raw, Mapping):
        raise ConfigError(f"{where}: motors={raw!r}: a table of motor id -> measurements")
    for key, entry in raw.items():
        try:
            node = int(key)
        except (TypeError, ValueError):
            node = -1
        if not 1 <= node <= MAX_NODE:
            raise ConfigError(f"{where}: motors: key {key!r}: a motor id 1..{MAX_NODE}")
        if not isinstance(entry, Mapping):
            raise ConfigError(f"{where}: motors.{key}: a table of measurements, got {entry!r}")
        if "status_bits" in entry and entry["status_bits"] is not None:
            _bits(entry["status_bits"], f"{where}: motors.{key}")
        motors[node] = dict(entry)
    return FirmwareProfile(bits, motors, where)


def apply_profile(bits: StatusBits, profile: FirmwareProfile) -> None:
    """Make a bus's section-1.6 decisions (``bits``) follow ``profile``."""
    bits.default = profile.status_bits
    for node in profile.motors:
        setting = profile.status_bits_of(node)
        if setting != "auto":
            bits.known[node] = setting
