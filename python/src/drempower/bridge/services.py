"""The bridge's ROS 2 services ``estop``, ``clear_errors`` and ``enable`` (``std_srvs/srv/Trigger``).

An estop is answered at once, from Zenoh's callback; the others one at a time
in the order they arrived (:mod:`.order`), each in a thread of its own, and an
estop that arrives later fences the ones still waiting or running: they send
nothing more and say so. ``enable`` and ``clear_errors`` go through the command
service (:mod:`drempower.actions.service`): validated, sent, and successful only
once every joint served got there (closed loop; no error flag), else worded as
the dashboard and the CLI word it.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from functools import partial
from typing import Any

from .. import actions
from ..actions import settle
from ..errors import DrEmpowerError
from . import rmw, rosmsg
from .bus_face import BusFace
from .motors import ServedMotors
from .order import ServiceOrder

__all__ = ["FENCED", "SERVICES", "SERVICE_ROWS", "Services"]

_log = logging.getLogger("drempower.bridge")

SERVICES = ("estop", "clear_errors", "enable")
"""The services, in the order their entities are declared."""
SERVICE_ROWS = {"estop": "estop", "clear_errors": "clear", "enable": "enable"}
"""Each service's row of :mod:`drempower.actions`, run for every motor served."""
FENCED = "{service} not done: an estop called after it came first (call clear_errors, then enable)"
"""A service call an estop that arrived after it fenced off (see :mod:`.order`)."""


class Services:
    """The services of the joints ``names`` on ``faces`` (bus name -> face); ``on_estop()`` runs after each
    estop (the command topics forget what they drove)."""

    def __init__(self, faces: Mapping[str, BusFace], names: Sequence[str], on_estop: Callable[[], None]) -> None:
        self._faces = dict(faces)
        self._names = list(names)
        self._on_estop = on_estop
        self._motors = ServedMotors([(face.name, face.bus, face.joints) for face in self._faces.values()])
        self.order = ServiceOrder()
        """Tickets of the calls and the fence of the last estop (:mod:`.order`)."""

    def serve(self, query: Any, name: str) -> None:
        """Answer a call of service ``name``: an estop at once; the others one at a time in arrival order,
        each in a thread of its own (an enable waits for closed loop: Zenoh's callback, which an estop
        from the same link would wait behind, returns at once)."""
        if name == "estop":
            _reply(query, *self._srv_estop())
            return
        ticket = self.order.arrive()  # here: the order of arrival
        threading.Thread(
            target=self._serve_in_turn, args=(query, name, ticket), name=f"drempower bridge {name}", daemon=True
        ).start()

    def _serve_in_turn(self, query: Any, name: str, ticket: int) -> None:
        try:
            with self.order.turn(ticket):
                handler = self._srv_enable if name == "enable" else self._srv_clear_errors
                success, message = handler(ticket)
        except Exception as exc:  # a reply in every case: the caller waits for one
            success, message = False, f"{name} failed: {exc}"
        _reply(query, success, message)

    def estop(self) -> list[str]:
        """Emergency stop of every motor served on every bus at once; returns the failures (``"bus: error"``).

        The first bus is stopped from the calling thread, every other one from
        a thread of its own, so a bus whose device stopped taking data does not
        delay the others' stop. Every ``enable`` or ``clear_errors`` call that
        arrived before it sends nothing more (see :mod:`.order`).
        """
        self.order.arrive(estop=True)
        failures: list[str] = []

        def stop(face: BusFace) -> None:
            try:
                face.estop()
            except Exception as exc:
                failures.append(f"{face.name or face.prefix}: {exc}")

        faces = list(self._faces.values())
        others = [threading.Thread(target=stop, args=(f,), name="drempower bridge estop") for f in faces[1:]]
        for th in others:
            th.start()
        stop(faces[0])
        for th in others:
            th.join(5.0)
        self._on_estop()
        return failures

    def _srv_estop(self) -> tuple[bool, str]:
        failures = self.estop()
        if failures:
            return False, "estop failed: " + "; ".join(failures)
        return True, "estop sent to " + self._served()

    def _served(self) -> str:
        if len(self._faces) == 1 and "" in self._faces:
            return "motors " + ", ".join(map(str, self._faces[""].ids))
        return "joints " + ", ".join(self._names)

    def service(self, fenced: Callable[[], bool]) -> actions.Service:
        """The command service of one call, which ``fenced()`` (an estop that arrived after it) interrupts
        while it waits for the motors; each gets :data:`~drempower.actions.ENABLE_SETTLE` s, as read now."""
        policy = actions.Policy(log=_log.info, settle=settle.ENABLE_SETTLE, interrupted=fenced)
        return actions.Service(self._motors, policy)

    def _srv_clear_errors(self, ticket: int) -> tuple[bool, str]:
        """Clear the errors of every joint served, unless an estop that arrived later came first; success
        only once none reports an error (an encoder error stays until zeroed)."""
        return self._settled(ticket, "clear_errors", "errors cleared on ")

    def _srv_enable(self, ticket: int) -> tuple[bool, str]:
        """Closed loop for every joint served, on every bus (a bus that fails does not keep the others from
        it); success only once each reads closed loop (a motor with error flags ignores an enable)."""
        return self._settled(ticket, "enable", "closed loop on ")

    def _settled(self, ticket: int, service: str, done: str) -> tuple[bool, str]:
        """``service``'s row for every motor served through the command service, one at a time, each sent
        unless an estop that arrived later came first; then confirmed by the service for all together (its
        words: closed loop reached, errors cleared), the wait ended by such an estop; ``done`` + what is
        served on success."""
        row = SERVICE_ROWS[service]

        def stale() -> bool:
            return self.order.stale(ticket)

        through = self.service(stale)
        sent: list[actions.Checked] = []
        failures: list[str] = []
        for face, keys in zip(self._faces.values(), self._motors.served(), strict=True):
            try:
                for key in keys:
                    checked = through.check(row, {"id": key})
                    if not face.act_unless(stale, partial(through.act, f"ROS 2 {service}", checked)):
                        return False, FENCED.format(service=service)
                    sent.append(checked)
            except Exception as exc:  # a reply in every case: the caller waits for one
                failures.append(f"{face.name or face.prefix}: {exc}")
        try:
            through.confirm_all(sent)
        except DrEmpowerError as exc:  # which did not get there and why, in the service's words
            failures.append(str(exc))
        if stale():
            return False, FENCED.format(service=service)
        if failures:
            return False, f"{service} failed: " + "; ".join(failures)
        return True, done + self._served()


def _reply(query: Any, success: bool, message: str) -> None:
    """The ``std_srvs/srv/Trigger`` response to ``query``, with rmw_zenoh's attachment."""
    att = query.attachment.to_bytes() if query.attachment is not None else b""
    try:
        req = rmw.Attachment.decode(att)
    except ValueError:
        req = rmw.Attachment(0, 0, bytes(rmw.GID_SIZE))
    t = rosmsg.typestore().types
    payload = rosmsg.encode(
        t[rosmsg.TRIGGER + "_Response"](success=success, message=message), rosmsg.TRIGGER + "_Response"
    )
    reply = rmw.Attachment(req.sequence_number, time.time_ns(), req.gid).encode()
    try:
        query.reply(query.key_expr, payload, attachment=reply)
        query.drop()  # the reply is final
    except Exception as exc:  # the session closed meanwhile
        _log.warning("service reply not sent: %s", exc)
