"""The driver: runs the engine's session over a transport (the clock, the receive thread, the waits).

:mod:`.bus_driver` owns the transport and the session; :mod:`.receiver` feeds it what arrives; one
wait per flavour (:mod:`.wait_threaded`, :mod:`.wait_asyncio`, :mod:`.wait_virtual`, their shared
steps in :mod:`.wait_steps`); the buses still open at exit (:mod:`.open_buses`) and the termination
signals (:mod:`.signals`).
"""
