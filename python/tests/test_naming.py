"""The naming rule: motor_<id>, a robot file's name, <bus>/motor_<id> where buses collide."""

from __future__ import annotations

import pytest

from drempower.errors import FieldRangeError
from drempower.naming import motor_name, motor_names


def test_a_motor_is_motor_id_unless_named() -> None:
    assert motor_name(1) == "motor_1"
    assert motor_name(7, named="elbow") == "elbow"
    assert motor_name(3, "left") == "left/motor_3"
    with pytest.raises(FieldRangeError, match="id=0 is out of range"):
        motor_name(0)


def test_the_bus_is_named_only_where_buses_collide() -> None:
    names = motor_names([("left", 1), ("right", 1), ("right", 2), ("left", 3)], {("left", 3): "hip"})
    assert names == {
        ("left", 1): "left/motor_1",
        ("right", 1): "right/motor_1",
        ("right", 2): "motor_2",
        ("left", 3): "hip",
    }
