"""Robot files shared by the tests of the commands that take a whole robot (record, bridge)."""

from __future__ import annotations

GEARED_ROBOT = """
[buses.left]
interface = "sim"
[buses.right]
interface = "sim"
[joints.shoulder]
bus = "left"
id = 1
[joints.wrist]
bus = "left"
id = 2
gear = 2.0
[joints.elbow]
bus = "right"
id = 1
gear = -1.0
offset = 0.5
"""
"""Two simulated buses; a joint geared 2:1 and one reversed with an offset (rad)."""
