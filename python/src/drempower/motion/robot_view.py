"""What the motion routines use of a robot, as a protocol: the robot layer sits above motion and hands
itself to them (``robot.follow``, ``robot.identify``, ``robot.tune``, ``robot.teach``), so motion names
only this, never the robot's classes."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    from ..robotfile import RobotSpec

__all__ = ["RobotView"]


class RobotView(Protocol):
    """A robot of either flavour (threaded or asyncio), as the routines see it: its file, its joints and
    buses by name, its twin when it has one. The calls return what the flavour returns (an awaitable on
    asyncio), hence ``Any``."""

    @property
    def spec(self) -> RobotSpec: ...

    @property
    def joints(self) -> Mapping[str, Any]: ...

    @property
    def buses(self) -> Mapping[str, Any]: ...

    @property
    def twin(self) -> Any: ...

    def joint(self, name: str) -> Any: ...

    def bus(self, name: str) -> Any: ...

    def joint_states(self, names: Sequence[str] | None = None) -> Any: ...

    def _each(self, work: Mapping[str, Callable[..., Any]]) -> Any: ...
