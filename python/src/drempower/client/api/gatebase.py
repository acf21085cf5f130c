"""The safety gate's face of a bus (see :mod:`drempower.client.engine.gate`): soft limits, the passage of
motion through the gate, and what a motion call notes once sent (the gate's targets, the timed stops)."""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from collections.abc import Iterable, Sequence

from ...errors import ValidationError
from ...protocol.limits import check_motor
from ...protocol.messages import Message, WriteParam
from ...protocol.parameters import parameter
from ..driver.bus_driver import BusDriver
from ..engine.effects import Op
from ..engine.gate import Intent, Limit, MotionGate, intents_of, param_kind
from ..engine.supervisor import HealthEvent, action_messages
from .timed import TimedStops

__all__ = ["GateBase"]


class GateBase(ABC):
    """A bus's soft limits and gate: the :class:`~drempower.client.engine.gate.MotionGate` ``_gate`` over the
    states and clock of the driver ``_core``, and the timed stops ``_timed`` (all made by the bus)."""

    _core: BusDriver
    _gate: MotionGate
    _timed: TimedStops

    @abstractmethod
    def known_motors(self) -> set[int]:
        """The motors the bus knows are attached."""

    def set_limits(
        self,
        id: int,
        *,
        position: tuple[float, float] | None = None,
        speed: float | None = None,
        torque: float | None = None,
        accel: float | None = None,
        max_step: float | None = None,
        where: str | None = None,
        replace: bool = True,
    ) -> None:
        """Set the soft limits of motor ``id`` (replacing its earlier ones; None: no such limit; with
        ``replace`` False, the limits not given here are kept, each with its own ``where``).

        ``position`` (low, high) deg, ``speed`` r/min, ``torque`` Nm, ``accel`` (r/min)/s (by
        magnitude) and ``max_step``, the largest step (deg) a single position command may make
        from the last known position. A motion command beyond one raises
        :class:`~drempower.errors.SoftLimitError` naming it and ``where`` it was set (default:
        this call), before any frame is sent.
        """
        check_motor(id, "id")
        given = {"position": position, "speed": speed, "torque": torque, "accel": accel, "max_step": max_step}
        if not replace:
            given = {k: v for k, v in given.items() if v is not None}
        if where is None:
            args = ", ".join(f"{k}={v!r}" for k, v in given.items() if v is not None)
            where = f"bus.set_limits({id}{', ' if args else ''}{args})"
        self._gate.set_limits(id, where, **given)

    def limits(self, id: int) -> dict[str, Limit]:
        """The soft limits of motor ``id`` (see :meth:`set_limits`): name ->
        :class:`~drempower.client.engine.gate.Limit`."""
        return dict(self._gate.limits(id))

    def _passage(
        self, intents: Sequence[Intent], enable: bool, timeout: float | None = None, *, closed_loop: bool = True
    ) -> Op[None] | None:
        """None when ``intents`` pass the gate as they are; else the operation that reads what it needs,
        enables (``enable``) or raises MotorIdleError / SoftLimitError (nothing sent). An intent for every
        motor (node 0) stands for one to each motor the bus knows. ``closed_loop`` False checks the limits
        only (the bridge's remote face: the motor itself ignores motion until enabled)."""
        if enable.__class__ is not bool:
            raise ValidationError(f"enable={enable!r}: expected True or False")
        if any(it.node == 0 for it in intents):
            intents = self._each_motor(intents)
        return self._gate.passage(intents, self._core.states, enable, timeout, self._core.now(), closed_loop)

    def _each_motor(self, intents: Sequence[Intent]) -> list[Intent]:
        """``intents`` with each one to every motor (node 0) replaced by one to each motor the bus knows;
        a ValidationError when it knows none (no motor's limits or state could answer for the command)."""
        known = sorted(self.known_motors())
        if not known:
            raise ValidationError(
                "a motion command to every motor (id 0) is refused: this bus knows no motor to check it "
                "against (address each motor by its id, or scan first)"
            )
        out: list[Intent] = []
        for it in intents:
            out.extend([dataclasses.replace(it, node=n) for n in known] if it.node == 0 else [it])
        return out

    def check_path(self, motion: Iterable[Message]) -> None:
        """The soft limits of a path's commands, streamed in the order they will be sent (no I/O, nothing
        sent): each one's values, each position's step from the one before. The first one's step from
        where the motor is, and its axis state, are :meth:`pass_gate`'s."""
        self._gate.check_path(motion)

    def check_limits(self, motion: Sequence[Message]) -> None:
        """The soft limits that ``motion``'s own values meet (speed, torque, acceleration, absolute
        positions; no I/O, nothing sent): SoftLimitError for the first beyond one. For a whole program
        checked before its first command (a replayed log); each command still passes the gate as it goes."""
        intents = intents_of(motion)
        if any(it.node == 0 for it in intents) and self.known_motors():
            intents = self._each_motor(intents)
        self._gate.check_values(intents)

    def _param_gate(self, node: int, prop: str | int, value: float, force: bool) -> Op[None] | None:
        """The gate for writing ``value`` to parameter ``prop`` of motor ``node`` (0: every motor): the
        value checked against the parameter first (nothing sent), then, for a parameter that commands
        motion (:data:`~drempower.client.engine.gate.MOTION_PARAMETERS`), what a motion command passes."""
        WriteParam.of(node, prop, value, force=force)  # DomainError before any read of the gate
        nodes = sorted(self.known_motors()) if node == 0 else [node]
        intents = self._gate.param_intents(nodes, prop, value)
        if node == 0 and intents and not nodes:
            self._each_motor([Intent(0)])  # refuses
        return self._passage(intents, False) if intents else None

    def _param_sent(self, node: int, prop: str | int, value: float) -> None:
        """Note a parameter write sent: a motion parameter ends its motors' pending timed stops."""
        if param_kind(parameter(prop), value) is not None:
            self._timed.cancel(sorted(self.known_motors()) if node == 0 else [node])

    def _gate_op(self, msgs: Sequence[Message], enable: bool) -> Op[None] | None:
        """:meth:`_passage` of motion messages, with the fast path of motors known in closed loop."""
        if enable.__class__ is bool and self._gate.clear(msgs, self._core.states):
            return None
        return self._passage(intents_of(msgs), enable)

    def _sent(self, msgs: Sequence[Message], duration: float | None = None) -> None:
        """Note what a motion call sent (the gate learns targets; a pending timed stop of its motors ends);
        with ``duration`` (s), schedule the stop of the speeds/torques sent."""
        self._gate.note_sent(msgs)
        self._timed.commanded(msgs, duration)

    def health_acted(self, events: Sequence[HealthEvent]) -> None:
        """Note what a supervisor step's actions sent (:func:`~drempower.client.engine.supervisor.action_messages`):
        the safety gate then refuses motion to a joint it idled until it is enabled again."""
        acts = action_messages(events)
        if acts:
            self._sent(acts)

    def _moved(self, ids: Sequence[int]) -> None:
        """Note a synchronised move: it ends its motors' pending timed stops."""
        self._timed.cancel(ids)
