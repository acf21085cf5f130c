"""Motion: trajectories (:class:`Trajectory`) and following them through the control cycle.

>>> from drempower.motion import Trajectory
>>> tr = Trajectory.from_waypoints([[0.0, 0.0], [1.0, -0.5]], max_speed=1.0, max_accel=4.0, joints=["a", "b"])
>>> round(tr.duration, 3)
1.25
"""

from typing import TYPE_CHECKING

from .._lazy import lazy_names
from .trajectory import Peaks, Sample, Trajectory

if TYPE_CHECKING:
    from .follow_sync import follow_bus

__all__ = ["Peaks", "Sample", "Trajectory", "follow_bus"]

__getattr__ = lazy_names(__name__, {"follow_sync": ("follow_bus",)})
