"""Waiting, on the bus's own clock, for what a row asked of the motors to show in their state."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from ..errors import DrEmpowerError
from ..naming import state_name
from ..protocol.addresses import AXIS0_CURRENT_STATE
from ..protocol.enums import AxisState
from ..protocol.messages import FastRead, ReadParam
from ..protocol.parameters import DataType

ENABLE_SETTLE = 0.3
"""How long (s) :func:`why_not_enabled` and :func:`why_not_cleared` give motors to get there."""
_ASK_EVERY = 0.02
"""How often (s) the motors are asked again."""
_SILENT = "did not answer the read of its state: is it on the bus?"


def _settle(
    bus: Any,
    nodes: Sequence[int],
    ask: Callable[[int], Any],
    reached: Callable[[Any], bool],
    within: float,
    stop: Callable[[], bool] | None,
) -> dict[int, Any]:
    """Ask every motor of ``nodes`` (``ask(node)``: the message, one exchange for all) again every 20 ms
    until each answer is ``reached``, ``within`` s at most or until ``stop()``; returns the last answer
    (None: none came) of each motor that did not get there."""
    waiting = list(nodes)
    deadline = bus.now() + within  # the bus's clock: simulated time on a virtual clock
    while True:
        answers = dict(zip(waiting, bus.request([ask(n) for n in waiting], missing_ok=True), strict=True))
        waiting = [n for n in waiting if answers[n] is None or not reached(answers[n])]
        if not waiting or bus.now() >= deadline or (stop is not None and stop()):
            return {n: answers[n] for n in waiting}
        bus.pass_time(_ASK_EVERY)


def why_not_enabled(
    bus: Any, nodes: Sequence[int], within: float = ENABLE_SETTLE, stop: Callable[[], bool] | None = None
) -> dict[int, str]:
    """After row ``enable`` for motors ``nodes`` on a threaded ``bus``: ``{}`` once each reads closed loop
    (their states read in one exchange, again every 20 ms, ``within`` s at most), else for each that did
    not, why not, in the words the front ends put after its name: ``"did not enter closed loop (state
    idle): its error flags are set: clear errors first, then enable again"``. ``stop()`` true ends the
    wait early. A front end that reports an enable as done asks this first: a sent enable is no closed
    loop (a motor with error flags ignores it)."""
    left = _settle(
        bus,
        nodes,
        lambda n: ReadParam(n, AXIS0_CURRENT_STATE, DataType.U32),
        lambda r: int(r.value) == AxisState.CLOSED_LOOP_CONTROL,
        within,
        stop,
    )
    why: dict[int, str] = {}
    for n, r in left.items():
        if r is None:
            why[n] = _SILENT
            continue
        try:
            flags = "its error flags are set: clear errors first" if bus.motor(n).get_state().error else None
        except DrEmpowerError:
            flags = None
        fix = flags or "see its errors"
        why[n] = f"did not enter closed loop (state {state_name(int(r.value))}): {fix}, then enable again"
    return why


def why_not_cleared(
    bus: Any, nodes: Sequence[int], within: float = ENABLE_SETTLE, stop: Callable[[], bool] | None = None
) -> dict[int, str]:
    """After row ``clear`` for motors ``nodes``: ``{}`` once no state frame of theirs has the error bit
    (read as :func:`why_not_enabled` reads), else for each that still has it, in the same kind of words:
    ``"errors remain after clearing: see its errors (an encoder error needs zeroing first)"``."""
    left = _settle(bus, nodes, FastRead, lambda st: not st.error, within, stop)
    return {
        n: _SILENT
        if st is None
        else "errors remain after clearing: see its errors (an encoder error needs zeroing first)"
        for n, st in left.items()
    }
