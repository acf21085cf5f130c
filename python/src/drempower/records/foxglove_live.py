"""Serve a bus live to Foxglove (foxglove-sdk's WebSocket server), optionally logging MCAP through the SDK.

Needs the ``foxglove`` extra (``pip install 'drempower[foxglove]'``). The topics
are those of a recording (:mod:`drempower.records.ros2_types`), as JSON
messages with JSON schemas: Foxglove's Plot panel takes
``/joint_states.position[0]``, the Raw Messages panel shows ``/can/rx``.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

from ..errors import DrEmpowerError
from .sink import FrameSink

__all__ = ["FoxgloveLive", "JSON_SCHEMAS"]

_STAMP = {
    "type": "object",
    "properties": {
        "stamp": {
            "type": "object",
            "properties": {"sec": {"type": "integer"}, "nanosec": {"type": "integer"}},
        },
        "frame_id": {"type": "string"},
    },
}
_NUMS = {"type": "array", "items": {"type": "number"}}


def _obj(**props: Any) -> dict[str, Any]:
    return {"type": "object", "properties": {"header": _STAMP, **props}}


_FRAME = _obj(
    id={"type": "integer"},
    is_rtr={"type": "boolean"},
    is_extended={"type": "boolean"},
    is_error={"type": "boolean"},
    dlc={"type": "integer"},
    data={"type": "array", "items": {"type": "integer"}},
)
JSON_SCHEMAS: dict[str, dict[str, Any]] = {
    "/can/tx": _FRAME,
    "/can/rx": _FRAME,
    "/joint_states": _obj(
        name={"type": "array", "items": {"type": "string"}}, position=_NUMS, velocity=_NUMS, effort=_NUMS
    ),
    "/drempower/parameters": _obj(
        node={"type": "integer"},
        address={"type": "integer"},
        name={"type": "string"},
        unit={"type": "string"},
        value={"type": "number"},
    ),
    "/drempower/errors": _obj(
        node={"type": "integer"}, source={"type": "string"}, code={"type": "integer"}, text={"type": "string"}
    ),
}
"""Topic -> JSON schema of its messages."""


class FoxgloveLive(FrameSink):
    """A Foxglove WebSocket server on ``host``:``port`` (0: a free port, see :attr:`port`) showing attached buses.

    With ``mcap``, the SDK also logs every message to that MCAP file (JSON
    messages; :class:`~drempower.records.Recorder` writes the ROS 2 form).
    """

    what = "Foxglove server"

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 8765,
        *,
        mcap: str | os.PathLike[str] | None = None,
        names: Mapping[int, str] | None = None,
        channel: str = "can",
    ) -> None:
        try:
            import foxglove
        except ImportError:
            raise ImportError("foxglove-sdk is not installed: pip install 'drempower[foxglove]'") from None
        if not isinstance(port, int) or not 0 <= port <= 65535:
            raise DrEmpowerError(f"port={port!r} is out of range: allowed 0..65535 (0: a free port)")
        self._foxglove = foxglove
        self._context = foxglove.Context()
        self._channels = {
            t: foxglove.Channel(t, schema=s, context=self._context, metadata={"source": "drempower"})
            for t, s in JSON_SCHEMAS.items()
        }
        self._mcap: Any = None
        if mcap is not None:
            try:
                self._mcap = foxglove.open_mcap(os.fspath(mcap), allow_overwrite=True, context=self._context)
            except Exception as exc:
                raise DrEmpowerError(f"cannot write {os.fspath(mcap)}: {exc}") from None
        try:
            self._server = foxglove.start_server(name="drempower", host=host, port=port, context=self._context)
        except Exception as exc:
            if self._mcap is not None:
                self._mcap.close()
            raise DrEmpowerError(f"cannot serve Foxglove on {host}:{port}: {exc}") from None
        self.host = host
        super().__init__(names, channel)

    @property
    def port(self) -> int:
        """The TCP port the server listens on."""
        return int(self._server.port)

    @property
    def url(self) -> str:
        """What to open in Foxglove (Open connection, Foxglove WebSocket)."""
        return f"ws://{self.host}:{self.port}"

    def _emit(self, topic: str, ns: int, message: dict[str, Any]) -> None:
        channel = self._channels.get(topic)
        if channel is None:  # a robot bus's raw frames: /can/<bus>/tx, /can/<bus>/rx
            schema = JSON_SCHEMAS["/can/rx"]
            channel = self._foxglove.Channel(
                topic, schema=schema, context=self._context, metadata={"source": "drempower"}
            )
            self._channels[topic] = channel
        channel.log(message, log_time=ns)

    def _finish(self) -> None:
        try:
            self._server.stop()
        finally:
            if self._mcap is not None:
                self._mcap.close()
