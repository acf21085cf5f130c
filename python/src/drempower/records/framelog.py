"""Write frames to a log whose format follows the file's extension (python-can's, or MCAP)."""

from __future__ import annotations

import os
from pathlib import Path
from types import TracebackType
from typing import Any

from ..errors import DrEmpowerError
from ..protocol.ids import Frame

__all__ = ["FrameLog"]


class FrameLog:
    """A log file for frames: ``.mcap`` through :class:`~drempower.records.Recorder`, else ``can.Logger``
    (``.asc .blf .csv .db .log .mf4 .trc .txt``, optionally ``.gz``). ``channel`` names the bus."""

    def __init__(self, path: str | os.PathLike[str], channel: str = "can0") -> None:
        self.path = os.fspath(path)
        self.channel = channel
        self._recorder: Any = None
        self._logger: Any = None
        if Path(self.path).suffix.lower() == ".mcap":
            from .recorder import Recorder

            self._recorder = Recorder(self.path, channel=channel)
            return
        import can

        try:
            self._logger = can.Logger(self.path)
        except (ValueError, NotImplementedError, ImportError) as exc:  # unknown format, or .mf4 without asammdf
            raise DrEmpowerError(f"--log {self.path}: {exc}") from None
        except OSError as exc:
            raise DrEmpowerError(f"cannot write {self.path}: {exc.strerror}") from None

    def write(self, frame: Frame, timestamp: float, tx: bool = False) -> None:
        """Log ``frame`` seen at ``timestamp`` (Unix s); ``tx`` when this host sent it."""
        if self._recorder is not None:
            self._recorder.record(frame, tx, timestamp)
            return
        import can

        arb, data, ext, rtr = frame
        self._logger(
            can.Message(
                timestamp=timestamp,
                arbitration_id=arb,
                data=data,
                is_extended_id=ext,
                is_remote_frame=rtr,
                dlc=len(data),
                is_rx=not tx,
                channel=self.channel,
            )
        )

    def close(self) -> None:
        if self._recorder is not None:
            self._recorder.close()
        if self._logger is not None:
            self._logger.stop()

    def __enter__(self) -> FrameLog:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
