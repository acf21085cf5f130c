"""A ROS 2 action's entities on Zenoh, as rmw_zenoh maps them (:mod:`drempower.bridge.rosaction`).

:class:`ActionWire` declares the three services (``send_goal``, ``cancel_goal``,
``get_result``) and two topics (``feedback``, ``status``) of one
``FollowJointTrajectory`` action with their liveliness tokens, answers the
services through the handlers it is given, and encodes what goes out: replies,
results, the status array and feedback. It knows nothing of goals' execution.

The status topic is transient local as in ROS 2: its last message is kept for
subscribers that join later (a Zenoh advanced publisher with a cache of one, as
rmw_zenoh declares one for that durability).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from . import rmw, rosaction, rosmsg

__all__ = ["ActionWire", "Handler", "SERVICES", "STATUS_QOS"]

_log = logging.getLogger("drempower.bridge")

STATUS_QOS = ":1:,1:,:,:,,"
"""rmw_zenoh's compact QoS of the status topic: transient local, keep last 1."""

Handler = Callable[[Any, rmw.Attachment], "bytes | None"]
"""A service's handler: the query and its attachment -> the reply's payload (None: answered later)."""

SERVICES = ("send_goal", "cancel_goal", "get_result")
"""The action's services (the other roles are topics)."""
_T = rosaction.FOLLOW_JOINT_TRAJECTORY


class ActionWire:
    """The entities of action ``name`` (fully qualified) of node ``node_name`` in namespace ``ns`` on ``session``.

    The services are answered from :meth:`serve` on.
    """

    def __init__(
        self,
        session: Any,
        domain_id: int,
        ns: str,
        node_name: str,
        name: str,
    ) -> None:
        self.name = name
        self.types = rosaction.typestore().types
        self.keys: dict[str, str] = {}
        self._decls: list[Any] = []
        self._pubs: dict[str, Any] = {}
        self._gids: dict[str, bytes] = {}
        self._seq = {"feedback": 0, "status": 0}
        self._put_lock = threading.Lock()
        self._session = session
        zid = str(session.zid())
        try:
            for entity, role in enumerate(rosaction.ROLES, start=2000):
                typename = rosaction.role_type(_T, role)
                dds, h = rosmsg.dds_type_name(typename), rosmsg.ros_type_hash(typename)
                fq = f"{name}/_action/{role}"
                kind: rmw.EntityKind = "SS" if role in SERVICES else "MP"
                qos = STATUS_QOS if role == "status" else rmw.DEFAULT_QOS
                token = rmw.entity_token(domain_id, zid, 0, entity, kind, ns, node_name, fq, dds, h, qos)
                self._decls.append(session.liveliness().declare_token(token))
                key = self.keys[role] = rmw.topic_key(domain_id, fq, dds, h)
                self._gids[role] = rmw.make_gid(token)
                if role in SERVICES:
                    continue
                if role == "status":  # transient local: late subscribers get the last status
                    from zenoh import ext

                    pub = ext.declare_advanced_publisher(
                        session,
                        key,
                        cache=ext.CacheConfig(1),
                        sample_miss_detection=ext.MissDetectionConfig(heartbeat=None, sporadic_heartbeat=None),
                        publisher_detection=True,
                    )
                else:
                    pub = session.declare_publisher(key)
                self._decls.append(pub)
                self._pubs[role] = pub
        except BaseException:
            self.close()
            raise

    # ------------------------------------------------------------------ services

    def serve(self, handlers: Mapping[str, Handler]) -> None:
        """Answer the services (:data:`SERVICES`) through ``handlers`` from now on. A handler that raises
        is logged and left unanswered (the caller times out)."""
        for role in SERVICES:
            h = handlers[role]
            q = self._session.declare_queryable(self.keys[role], lambda q, h=h: self._serve(q, h), complete=True)
            self._decls.append(q)

    def _serve(self, query: Any, handler: Handler) -> None:
        att = query.attachment.to_bytes() if query.attachment is not None else b""
        try:
            req = rmw.Attachment.decode(att)
        except ValueError:
            req = rmw.Attachment(0, 0, bytes(rmw.GID_SIZE))
        try:
            payload = handler(query, req)
        except Exception as exc:  # a malformed request: logged, no reply (the caller times out)
            _log.warning("%s: request refused: %s", self.name, exc)
            return
        if payload is not None:
            self.reply(query, req, payload)

    def reply(self, query: Any, req: rmw.Attachment, payload: bytes) -> None:
        """Answer ``query`` (whose attachment was ``req``) with ``payload``."""
        back = rmw.Attachment(req.sequence_number, time.time_ns(), req.gid).encode()
        query.reply(query.key_expr, payload, attachment=back)

    def decode(self, query: Any, typename: str) -> Any:
        """The request of ``query`` as a ``typename`` message."""
        if query.payload is None:
            raise ValueError(f"no {typename} in the request")
        return rosmsg.decode(query.payload.to_bytes(), typename)

    def stamp(self, ns: int) -> Any:
        """``builtin_interfaces/msg/Time`` of ``ns`` (ns since the epoch)."""
        return self.types["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def goal_info(self, gid: bytes, accepted_at: int) -> Any:
        """``action_msgs/msg/GoalInfo`` of goal ``gid`` accepted at ``accepted_at`` (ns)."""
        T = self.types
        return T["action_msgs/msg/GoalInfo"](
            goal_id=T["unique_identifier_msgs/msg/UUID"](uuid=_uuid_array(gid)), stamp=self.stamp(accepted_at)
        )

    def send_goal_response(self, accepted: bool, at: int) -> bytes:
        """``SendGoal``'s response: ``accepted`` at ``at`` (ns)."""
        resp = self.types[_T + "_SendGoal_Response"](accepted=accepted, stamp=self.stamp(at))
        return rosmsg.encode(resp, _T + "_SendGoal_Response")

    def cancel_response(self, code: int, canceling: Sequence[tuple[bytes, int]]) -> bytes:
        """``CancelGoal``'s response: ``code`` and the goals (id, accepted at ns) now canceling."""
        resp = self.types[rosaction.CANCEL_GOAL + "_Response"](
            return_code=code, goals_canceling=[self.goal_info(g, at) for g, at in canceling]
        )
        return rosmsg.encode(resp, rosaction.CANCEL_GOAL + "_Response")

    def result(self, status: int, error_code: int, error_string: str) -> bytes:
        """``GetResult``'s response."""
        result = self.types[_T + "_Result"](error_code=error_code, error_string=error_string)
        return rosmsg.encode(
            self.types[_T + "_GetResult_Response"](status=status, result=result), _T + "_GetResult_Response"
        )

    # ------------------------------------------------------------------ topics

    def _put(self, role: str, payload: bytes) -> None:
        with self._put_lock:  # the executor's thread and Zenoh's callbacks both publish status
            self._seq[role] += 1
            att = rmw.Attachment(self._seq[role], time.time_ns(), self._gids[role]).encode()
            self._pubs[role].put(payload, attachment=att)

    def status(self, goals: Sequence[tuple[bytes, int, int]]) -> None:
        """Publish the status array of ``goals`` (id, accepted at ns, status)."""
        T = self.types
        array = [T["action_msgs/msg/GoalStatus"](goal_info=self.goal_info(g, at), status=st) for g, at, st in goals]
        self._put(
            "status", rosmsg.encode(T[rosaction.GOAL_STATUS_ARRAY](status_list=array), rosaction.GOAL_STATUS_ARRAY)
        )

    def feedback(self, gid: bytes, names: Sequence[str], desired: Sequence[float], actual: Sequence[float]) -> None:
        """Publish goal ``gid``'s feedback: joints ``names`` where they should be and are (rad)."""
        import numpy as np

        T = self.types
        zero = T["builtin_interfaces/msg/Duration"](sec=0, nanosec=0)

        def point(values: Sequence[float]) -> Any:
            empty = np.array([], dtype=np.float64)
            return T["trajectory_msgs/msg/JointTrajectoryPoint"](
                positions=np.array(values, dtype=np.float64),
                velocities=empty,
                accelerations=empty,
                effort=empty,
                time_from_start=zero,
            )

        def multi() -> Any:
            return T["trajectory_msgs/msg/MultiDOFJointTrajectoryPoint"](
                transforms=[], velocities=[], accelerations=[], time_from_start=zero
            )

        fb = T[_T + "_Feedback"](
            header=T["std_msgs/msg/Header"](stamp=self.stamp(time.time_ns()), frame_id=""),
            joint_names=list(names),
            desired=point(desired),
            actual=point(actual),
            error=point([d - a for d, a in zip(desired, actual, strict=True)]),
            multi_dof_joint_names=[],
            multi_dof_desired=multi(),
            multi_dof_actual=multi(),
            multi_dof_error=multi(),
        )
        msg = T[_T + "_FeedbackMessage"](
            goal_id=T["unique_identifier_msgs/msg/UUID"](uuid=_uuid_array(gid)), feedback=fb
        )
        self._put("feedback", rosmsg.encode(msg, _T + "_FeedbackMessage"))

    def close(self) -> None:
        """Undeclare every entity. Idempotent."""
        decls, self._decls = self._decls, []
        for d in reversed(decls):
            try:
                d.undeclare()
            except Exception as exc:
                _log.debug("undeclare: %s", exc)


def _uuid_array(gid: bytes) -> Any:
    import numpy as np

    return np.frombuffer(gid, dtype=np.uint8).copy()
