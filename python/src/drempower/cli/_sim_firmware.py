"""The firmware profile options of ``drempower sim`` (:mod:`drempower.sim.firmware`)."""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from typing import Any

from ..errors import ValidationError
from ..sim.firmware import KNOBS, Q_TIME_ZERO, REPLY_TRIGGERS, STATUS_BITS, Firmware, firmware_from
from ._connect import ascii_float

__all__ = ["add_firmware_options", "firmware_changes", "firmware_of"]


def _seconds(text: str) -> float:
    try:
        value = ascii_float(text)
    except ValueError:
        value = -1.0
    if not 0.0 <= value <= 60.0:
        raise argparse.ArgumentTypeError(f"expected seconds 0..60, got {text!r}")
    return value


def _motor_id(text: str) -> int:
    if not text.isdigit() or not 1 <= int(text) <= 63:
        raise argparse.ArgumentTypeError(f"expected a motor id 1..63, got {text!r}")
    return int(text)


def add_firmware_options(p: argparse.ArgumentParser) -> None:
    """The knobs of :class:`~drempower.sim.firmware.Firmware` as options (default: the simulator's defaults)."""
    d = Firmware()
    g = p.add_argument_group(
        "firmware profile", "the reading of the vendor's document the firmware takes (docs/simulator.md)"
    )
    g.add_argument(
        "--status-bits",
        choices=STATUS_BITS,
        help=f"bits 3-4 of state frames: zero (0x01-0x07) or kept from the command answered (default {d.status_bits})",
    )
    g.add_argument("--boot-s", type=_seconds, metavar="S", help=f"silence after a reboot (default {d.boot_s:g} s)")
    g.add_argument(
        "--reply-state-triggers",
        dest="reply_state",
        choices=REPLY_TRIGGERS,
        help=f"what enable_reply_state answers (default {d.reply_state})",
    )
    g.add_argument(
        "--no-fast-read", dest="fast_read", action="store_const", const=False, help="firmware 1.1: no fast read"
    )
    g.add_argument(
        "--q-time-zero", choices=Q_TIME_ZERO, help=f"a Q target-time preset with time 0 (default {d.q_time_zero})"
    )
    g.add_argument(
        "--no-heartbeat", dest="heartbeat", action="store_const", const=False, help="heartbeat_ms sends nothing"
    )
    g.add_argument(
        "--factory-id", type=_motor_id, metavar="ID", help="node id of the factory configuration (default: --ids)"
    )


def firmware_of(args: argparse.Namespace, file_options: Mapping[str, Any] | None = None) -> Firmware:
    """The profile the options give; a robot file's bus knobs (``file_options``) first, the options win."""
    try:
        base = firmware_from({k: v for k, v in (file_options or {}).items() if k in KNOBS}, {})
        return firmware_from(base, {k: getattr(args, k, None) for k in KNOBS})
    except (TypeError, ValueError) as exc:
        raise ValidationError(f"firmware profile: {exc}") from None


def firmware_changes(fw: Firmware) -> dict[str, Any]:
    """The knobs of ``fw`` that differ from the simulator's defaults."""
    base = Firmware().to_json()
    return {k: v for k, v in fw.to_json().items() if base[k] != v}
