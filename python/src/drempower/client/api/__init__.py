"""The front end: :class:`Bus` and :class:`Motor` and their asyncio twins.

:mod:`.bus_async` is written by hand (``AsyncBus``, ``AsyncMotor``, ``open_bus_async``);
:mod:`.bus_sync` is generated from it by ``tools/gen_sync.py`` (``Bus``, ``Motor``, ``open_bus``).
What both share without I/O is in :mod:`.busbase` and :mod:`.motorbase`; what differs by nature
in :mod:`.flavours`; timed commands in :mod:`.timed`.
"""
