"""Record a bus to an MCAP file: raw frames both ways, joint states, parameter values and errors.

The file follows the ROS 2 MCAP profile (CDR messages, ``ros2msg`` schemas), so
``ros2 bag``, rosbags, Foxglove and PlotJuggler open it; see
:mod:`drempower.records.ros2_types` for the topics.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

from ..errors import DrEmpowerError
from . import missing_extra
from .ros2_types import DEFINITIONS, topic_type
from .sink import FrameSink, SinkStats

__all__ = ["Recorder", "RecorderStats"]

RecorderStats = SinkStats


class Recorder(FrameSink):
    """Write what passes on one or more buses to the MCAP file ``path``.

    ``attach(bus)`` records every frame an open :class:`~drempower.Bus` (or
    :class:`~drempower.AsyncBus`) sends and receives from then on. The frames are
    queued by the bus's threads and written by the recorder's own thread, so
    recording never slows the bus down; :meth:`close` writes what is queued and
    finishes the file. ``names`` maps motor ids to joint names (default
    ``motor_<id>``); ``channel`` names the bus in the headers' ``frame_id``.
    ``attach(bus, name=..., joints=...)`` records one bus of a robot: its raw
    frames on ``/can/<name>/tx`` and ``/can/<name>/rx``, its states under the joint
    names, at the joint (see :meth:`FrameSink.attach`).
    """

    what = "recorder"

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        names: Mapping[int, str] | None = None,
        channel: str = "can",
        compression: str = "zstd",
    ) -> None:
        try:
            from mcap.writer import CompressionType
            from mcap_ros2.writer import Writer
        except ImportError:
            raise missing_extra("mcap-ros2-support") from None
        try:
            comp = CompressionType[compression.upper()]
        except KeyError:
            raise DrEmpowerError(f"compression={compression!r}: 'zstd', 'lz4' or 'none'") from None
        self.path = os.fspath(path)
        try:
            self._fh = open(self.path, "wb")  # noqa: SIM115 - closed in _finish()
        except OSError as exc:
            raise DrEmpowerError(f"cannot write {self.path}: {exc.strerror}") from None
        self._writer = Writer(self._fh, compression=comp)
        self._schemas = {t: self._writer.register_msgdef(t, d) for t, d in DEFINITIONS.items()}
        super().__init__(names, channel)

    def _emit(self, topic: str, ns: int, message: dict[str, Any]) -> None:
        self._writer.write_message(topic, self._schemas[topic_type(topic)], message, log_time=ns, publish_time=ns)

    def _finish(self) -> None:
        try:
            self._writer.finish()  # type: ignore[no-untyped-call]
        finally:
            self._fh.close()
