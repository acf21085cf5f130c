"""Records of a bus: MCAP recording, reading every log format back, and a DBC of the protocol.

MCAP needs the ``records`` extra (``pip install 'drempower[records]'``) and the
live Foxglove sink the ``foxglove`` extra; python-can's log formats and the DBC
need nothing more. Nothing here is imported by ``import drempower``.
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "Recorder",
    "FoxgloveLive",
    "LogRecord",
    "Decoded",
    "read_log",
    "decode_log",
    "write_dbc",
    "dbc_text",
    "missing_extra",
]


def missing_extra(module: str) -> ImportError:
    """The error raised when an optional dependency of the ``records`` extra is not installed."""
    return ImportError(f"{module} is not installed: pip install 'drempower[records]'")


def __getattr__(name: str) -> Any:
    if name == "Recorder":
        from .recorder import Recorder

        return Recorder
    if name == "FoxgloveLive":
        from .foxglove_live import FoxgloveLive

        return FoxgloveLive
    if name in ("LogRecord", "Decoded", "read_log", "decode_log"):
        from . import logs

        return getattr(logs, name)
    if name in ("write_dbc", "dbc_text"):
        from . import dbc

        return getattr(dbc, name)
    raise AttributeError(name)
