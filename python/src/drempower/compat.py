"""The vendor library's functions, by name and signature, over a drempower bus.

A script written for the vendor's ``DrEmpower_can.py`` switches by changing
its import and adding one line of set-up::

    from drempower import compat as dr          # was: import DrEmpower_can as dr
    dr.open("adapter", "/dev/ttyACM0")          # or dr.use_bus(bus), dr.open("sim", motors=[1, 2])
    dr.set_angle(1, 90, 10, 20, 1)
    dr.position_done(1)

Differences from the vendor library (see docs/client.md):

* Nothing happens at import; the bus is opened by :func:`open` or given to :func:`use_bus`.
* Errors raise (:class:`~drempower.errors.ValidationError`, ``TimeoutError``,
  :class:`~drempower.transports.TransportError`) instead of printing and
  returning None/False; an invalid argument sends nothing, including in
  multi-motor calls (no half-sent batches).
* Values are rounded to the 0.01 step of the wire, not truncated.
* Replies are matched to their request (motor, parameter); ``enable_replay_state``
  needs no host setting, a state reply never disturbs a read.
* ``set_angles`` reads the motors' positions and ``traj_mode`` every time
  (no stale cache); ``step_angle`` and ``impedance_control`` start only their motor.
* ``position_done``/``positions_done`` wait until the move has happened (stale
  state frames do not end them), give up after a timeout (60 s by default) and
  raise ``MoveError`` when a motor reports an error or ends away from its
  target; ``dump_error`` returns the decoded
  flags per error word, not the sum of the words.
* ``set_mode`` refuses modes other than 1 and 2 instead of ignoring them;
  ``set_id`` checks that the motor answers at its new id before saving.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from .client.bus import Bus, open_bus
from .client.core import DEFAULT_MOVE_TIMEOUT
from .client.motor import Motor
from .client.results import ErrorReport
from .errors import DrEmpowerError

__all__ = [
    "use_bus",
    "open",
    "close",
    "current_bus",
    "set_angle",
    "set_angles",
    "step_angle",
    "step_angles",
    "set_speed",
    "set_speeds",
    "set_torque",
    "set_torques",
    "impedance_control",
    "estop",
    "set_id",
    "set_uart_baud_rate",
    "set_can_baud_rate",
    "set_mode",
    "set_zero_position",
    "set_GPIO_mode",
    "set_angle_range",
    "set_traj_mode",
    "write_property",
    "get_id",
    "get_state",
    "get_volcur",
    "get_GPIO_mode",
    "read_property",
    "clear_error",
    "dump_error",
    "save_config",
    "reboot",
    "position_done",
    "positions_done",
]

_bus: Bus | None = None


def use_bus(bus: Bus) -> Bus:
    """Make ``bus`` the one the functions of this module use; returns it."""
    global _bus
    _bus = bus
    return bus


def open(
    interface: str | None = None, channel: str | int | None = None, bitrate: int | None = None, **kwargs: Any
) -> Bus:
    """Open a bus with :func:`drempower.open_bus` arguments and use it (closing the previous one)."""
    close()
    return use_bus(open_bus(interface, channel, bitrate, **kwargs))


def close() -> None:
    """Close the bus in use, if any."""
    global _bus
    if _bus is not None:
        _bus.close()
        _bus = None


def current_bus() -> Bus:
    """The bus in use; raises if none was set up."""
    if _bus is None:
        raise DrEmpowerError("no bus: call drempower.compat.open(...) or drempower.compat.use_bus(bus) first")
    return _bus


def _m(id_num: int) -> Motor:
    return current_bus().motor(id_num)


# ---------------------------------------------------------------------- motion


def set_angle(id_num: int = 0, angle: float = 0, speed: float = 0, param: float = 0, mode: int = 0) -> bool:
    _m(id_num).set_angle(angle, speed, param, mode)
    return True


def set_angles(
    id_list: Sequence[int] = (1, 2, 3),
    angle_list: Sequence[float] = (150, 150, 150),
    speed: float = 10,
    param: float = 10,
    mode: int = 1,
) -> float | None:
    return current_bus().set_angles(id_list, angle_list, speed, param, mode)


def step_angle(id_num: int = 1, angle: float = 0, speed: float = 0, param: float = 0, mode: int = 0) -> float | None:
    return _m(id_num).step_angle(angle, speed, param, mode)


def step_angles(
    id_list: Sequence[int] = (1, 2, 3),
    angle_list: Sequence[float] = (150, 150, 150),
    speed: float = 10,
    param: float = 10,
    mode: int = 1,
) -> float | None:
    return current_bus().step_angles(id_list, angle_list, speed, param, mode)


def set_speed(id_num: int = 0, speed: float = 10, param: float = 0, mode: int = 1) -> bool:
    _m(id_num).set_speed(speed, param, mode)
    return True


def set_speeds(
    id_list: Sequence[int] = (1, 2, 3), speed_list: Sequence[float] = (10, 20, 30), param: float = 0, mode: int = 1
) -> bool:
    current_bus().set_speeds(id_list, speed_list, param, mode)
    return True


def set_torque(id_num: int = 0, torque: float = 0.1, param: float = 0, mode: int = 1) -> bool:
    _m(id_num).set_torque(torque, param, mode)
    return True


def set_torques(
    id_list: Sequence[int] = (1, 2, 3), torque_list: Sequence[float] = (3, 4, 5), param: float = 0, mode: int = 1
) -> bool:
    current_bus().set_torques(id_list, torque_list, param, mode)
    return True


def impedance_control(
    id_num: int = 0, pos: float = 0, vel: float = 0, tff: float = 0, kp: float = 0, kd: float = 0
) -> None:
    _m(id_num).impedance_control(pos, vel, tff, kp, kd)


def estop(id_num: int = 0) -> None:
    _m(id_num).estop()


# ---------------------------------------------------------------------- settings


def set_id(id_num: int = 0, new_id: int = 0) -> None:
    _m(id_num).set_id(new_id)


def set_uart_baud_rate(id_num: int = 0, baud_rate: int = 115200) -> None:
    _m(id_num).set_uart_baud_rate(baud_rate)


def set_can_baud_rate(id_num: int = 0, baud_rate: int = 500000) -> None:
    _m(id_num).set_can_baud_rate(baud_rate)


def set_mode(id_num: int = 0, mode: int = 2) -> None:
    _m(id_num).set_mode(mode)


def set_zero_position(id_num: int = 0) -> None:
    _m(id_num).set_zero_position()


def set_GPIO_mode(id_num: int = 0, mode: str = "tx_rx", param: float = 115200) -> None:
    _m(id_num).set_GPIO_mode(mode, param)


def set_angle_range(id_num: int = 0, angle_min: float = -360, angle_max: float = 360) -> bool:
    _m(id_num).set_angle_range(angle_min, angle_max)
    return True


def set_traj_mode(id_num: int = 0, mode: int = 1) -> None:
    _m(id_num).set_traj_mode(mode)


def write_property(id_num: int = 0, property: str | int = "", value: float = 0) -> None:
    _m(id_num).write_property(property, value)


# ---------------------------------------------------------------------- read-back


def get_id(id_num: int = 0) -> int:
    return _m(id_num).get_id()


def get_state(id_num: int = 0) -> list[float]:
    """``[angle deg, speed r/min]``, rounded to 0.01 as the vendor's."""
    st = _m(id_num).get_state()
    return [round(st.angle, 2), round(st.speed, 2)]


def get_volcur(id_num: int = 0) -> list[float]:
    """``[voltage V (0.1), current A (0.01)]``."""
    v, i = _m(id_num).get_volcur()
    return [round(v, 1), round(i, 2)]


def get_GPIO_mode(id_num: int = 0) -> list[int]:
    """``[enable_uart, enable_step_dir]``."""
    g = _m(id_num).get_GPIO_mode()
    return [int(g.enable_uart), int(g.enable_step_dir)]


def read_property(id_num: int = 0, property: str | int = "") -> int | float:
    return _m(id_num).read_property(property)


# ---------------------------------------------------------------------- utilities


def clear_error(id_num: int = 0) -> None:
    _m(id_num).clear_error()


def dump_error(id_num: int = 0) -> ErrorReport:
    """The decoded error words (true when any is set)."""
    return _m(id_num).dump_error()


def save_config(id_num: int = 0) -> None:
    _m(id_num).save_config()


def reboot(id_num: int = 0) -> None:
    _m(id_num).reboot()


def position_done(id_num: int = 0, timeout: float = DEFAULT_MOVE_TIMEOUT) -> bool:
    _m(id_num).wait_position_done(timeout)
    return True


def positions_done(id_list: Sequence[int] = (1, 2, 3), timeout: float = DEFAULT_MOVE_TIMEOUT) -> bool:
    current_bus().positions_done(id_list, timeout)
    return True
