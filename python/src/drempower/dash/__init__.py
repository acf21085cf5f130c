"""The browser dashboard (``drempower dash``): watch, drive, configure, tune and stop motors.

Needs the ``dash`` extra (aiohttp). The page and its plotting library (uPlot)
ship in this package: no network is needed.
"""

from __future__ import annotations

__all__ = ["Dashboard", "Hub"]

from .hub import Hub
from .server import Dashboard
