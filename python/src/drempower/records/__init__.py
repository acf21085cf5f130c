"""Records of a bus: MCAP recording, reading every log format back, and a DBC of the protocol.

Needs the ``records`` extra (``pip install drempower[records]``) for MCAP and DBC
work; python-can's own log formats need nothing more. Nothing here is imported by
``import drempower``.
"""

from __future__ import annotations

from typing import Any

__all__ = ["Recorder", "LogRecord", "read_log", "decode_log", "write_dbc", "dbc_text", "missing_extra"]


def missing_extra(module: str) -> ImportError:
    """The error raised when an optional dependency of the ``records`` extra is not installed."""
    return ImportError(f"{module} is not installed: pip install 'drempower[records]'")


def __getattr__(name: str) -> Any:
    if name == "Recorder":
        from .recorder import Recorder

        return Recorder
    if name in ("LogRecord", "read_log", "decode_log"):
        from . import logs

        return getattr(logs, name)
    if name in ("write_dbc", "dbc_text"):
        from . import dbc

        return getattr(dbc, name)
    raise AttributeError(name)
