"""The Zenoh bridge: a bus for remote drempower clients and for ROS 2 over rmw_zenoh.

Needs the ``bridge`` extra (``eclipse-zenoh``, ``rosbags``); nothing here is
imported by the rest of the package unless the bridge or a ``zenoh`` bus is used.
"""

from ..transports.zenoh_wire import DEFAULT_PREFIX

__all__ = ["DEFAULT_PREFIX"]
