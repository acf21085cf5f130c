"""Errors raised by transports (defined in :mod:`drempower.errors`; this path keeps working)."""

from __future__ import annotations

from ..errors import TransportError, TransportOptionError

__all__ = ["TransportError", "TransportOptionError"]
