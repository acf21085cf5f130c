"""The bridge's ROS 2 services ``estop``, ``clear_errors`` and ``enable`` (``std_srvs/srv/Trigger``).

An estop is answered at once, from Zenoh's callback; the others one at a time
in the order they arrived (:mod:`.order`), each in a thread of its own, and an
estop that arrives later fences the ones still waiting or running: they send
nothing more and say so. ``enable`` and ``clear_errors`` succeed only once every
joint served got there (closed loop; no error flag).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from .. import actions
from ..naming import motor_name
from . import rmw, rosmsg
from .bus_face import _FENCED, SERVICE_ROWS, BusFace
from .order import ServiceOrder

__all__ = ["SERVICES", "Services"]

_log = logging.getLogger("drempower.bridge")

SERVICES = ("estop", "clear_errors", "enable")
"""The services, in the order their entities are declared."""


class Services:
    """The services of the joints ``names`` on ``faces`` (bus name -> face); ``on_estop()`` runs after each
    estop (the command topics forget what they drove)."""

    def __init__(self, faces: Mapping[str, BusFace], names: Sequence[str], on_estop: Callable[[], None]) -> None:
        self._faces = dict(faces)
        self._names = list(names)
        self._on_estop = on_estop
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

    def _run_each(self, ticket: int, service: str) -> tuple[bool, str]:
        """The service's row of :mod:`drempower.actions` for every motor served, one at a time, until an
        estop that arrived later fences it."""
        row = SERVICE_ROWS[service]
        failures = []
        for face in self._faces.values():
            try:
                for i in face.ids:
                    if not face.run_unless(row, i, lambda: self.order.stale(ticket)):
                        return False, _FENCED.format(service=service)
            except Exception as exc:  # a reply in every case: the caller waits for one
                failures.append(f"{face.name or face.prefix}: {exc}")
        if failures:
            return False, f"{service} failed: " + "; ".join(failures)
        return True, ""

    def _srv_clear_errors(self, ticket: int) -> tuple[bool, str]:
        """Clear the errors of every joint served, unless an estop that arrived later came first; success
        only once none reports an error (an encoder error stays until zeroed)."""
        return self._settled(ticket, "clear_errors", actions.why_not_cleared, "errors cleared on ")

    def _srv_enable(self, ticket: int) -> tuple[bool, str]:
        """Closed loop for every joint served, on every bus (a bus that fails does not keep the others from
        it); success only once each reads closed loop (a motor with error flags ignores an enable)."""
        return self._settled(ticket, "enable", actions.why_not_enabled, "closed loop on ")

    def _settled(
        self, ticket: int, service: str, why_not: Callable[..., dict[int, str]], done: str
    ) -> tuple[bool, str]:
        """Run ``service``'s row for every joint served (:meth:`_run_each`), then check that each got where
        the row takes it (``why_not``: :func:`~drempower.actions.why_not_enabled` or ``why_not_cleared``),
        within :data:`~drempower.actions.ENABLE_SETTLE` s in all, unless an estop that arrived later comes
        first; ``done`` + what is served on success."""
        ok, message = self._run_each(ticket, service)
        if not ok:
            return ok, message
        failures = []
        deadline = time.monotonic() + actions.ENABLE_SETTLE

        def stale() -> bool:
            return self.order.stale(ticket)

        for face in self._faces.values():
            try:
                why = why_not(face.bus, face.ids, max(0.0, deadline - time.monotonic()), stale)
            except Exception as exc:  # a reply in every case: the caller waits for one
                failures.append(f"{face.name or face.prefix}: state not read: {exc}")
                continue
            for j in face.joints:
                if j.id in why:
                    who = f"motor {j.id}" if j.name == motor_name(j.id) else f"joint {j.name} (motor {j.id})"
                    failures.append(f"{who} {why[j.id]}")
        if stale():
            return False, _FENCED.format(service=service)
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
