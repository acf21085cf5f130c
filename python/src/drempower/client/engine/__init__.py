"""The engine: everything the client knows and decides about a bus, with no I/O.

The bus session (:mod:`.session`) and its parts (requests matched to replies, the preset/start
sequencer, timers, what is known of each motor), the operations run on it (:mod:`.effects`,
:mod:`.ops`, :mod:`.batch`, :mod:`.backup`), the command builders (:mod:`.commands`) and the
safety gate (:mod:`.gate`). Nothing here reads a clock, starts a thread or touches a transport:
:mod:`drempower.client.driver` does, and :mod:`drempower.client.api` is the front end.
"""
