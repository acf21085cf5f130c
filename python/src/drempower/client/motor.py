"""Motor handles: the vendor library's functions as methods of one motor.

:class:`Motor` is generated (``api_sync.py``) from :class:`~drempower.client.aio.AsyncMotor`;
:class:`MotorBase` holds what both share without I/O.
"""

from __future__ import annotations

from .api_sync import Motor
from .motorbase import MotorBase

__all__ = ["Motor", "MotorBase"]
