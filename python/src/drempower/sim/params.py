"""The parameter memory of a simulated motor: RAM, saved configuration, factory defaults.

Configuration parameters (every writable one except the runtime inputs listed in
:data:`RUNTIME`) live in RAM; ``save`` copies them to the saved configuration,
which survives a reboot and, with a ``path``, is kept as a JSON file (by
parameter name). The output-shaft configuration parameters are views of their
rotor-side twins (:data:`OUTPUT_VIEWS`): only the rotor value is stored.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

from ..errors import DrEmpowerError, SavedConfigError
from ..protocol.addresses import (
    AXIS0_CONFIG_CAN_NODE_ID,
    AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MAX,
    AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MIN,
    AXIS0_CONTROLLER_CONFIG_CONTROL_MODE,
    AXIS0_CONTROLLER_CONFIG_INPUT_MODE,
    AXIS0_CONTROLLER_CONFIG_TORQUE_RAMP_RATE,
    AXIS0_CONTROLLER_CONFIG_VEL_LIMIT,
    AXIS0_CONTROLLER_CONFIG_VEL_RAMP_RATE,
    AXIS0_CONTROLLER_INPUT_POS,
    AXIS0_CONTROLLER_INPUT_TORQUE,
    AXIS0_CONTROLLER_INPUT_VEL,
    AXIS0_CONTROLLER_POS_SETPOINT,
    AXIS0_CONTROLLER_TORQUE_SETPOINT,
    AXIS0_CONTROLLER_VEL_SETPOINT,
    AXIS0_ENCODER_POS_ESTIMATE,
    AXIS0_ENCODER_VEL_ESTIMATE,
    AXIS0_MOTOR_CONFIG_TORQUE_CONSTANT,
    AXIS0_MOTOR_CONFIG_TORQUE_LIM,
    AXIS0_MOTOR_CURRENT_CONTROL_FINAL_V_ALPHA,
    AXIS0_MOTOR_CURRENT_CONTROL_FINAL_V_BETA,
    AXIS0_MOTOR_CURRENT_CONTROL_IBUS,
    AXIS0_MOTOR_CURRENT_CONTROL_ID_SETPOINT,
    AXIS0_MOTOR_ERROR,
    AXIS0_OUTPUT_SHAFT_CIRCULAR_SETPOINT_MAX,
    AXIS0_OUTPUT_SHAFT_CIRCULAR_SETPOINT_MIN,
    AXIS0_OUTPUT_SHAFT_INPUT_POS,
    AXIS0_OUTPUT_SHAFT_INPUT_TORQUE,
    AXIS0_OUTPUT_SHAFT_INPUT_VEL,
    AXIS0_OUTPUT_SHAFT_POS_ESTIMATE,
    AXIS0_OUTPUT_SHAFT_POS_SETPOINT,
    AXIS0_OUTPUT_SHAFT_TORQUE_CONSTANT,
    AXIS0_OUTPUT_SHAFT_TORQUE_LIM,
    AXIS0_OUTPUT_SHAFT_TORQUE_RAMP_RATE,
    AXIS0_OUTPUT_SHAFT_TORQUE_SETPOINT,
    AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_ACCEL_LIMIT,
    AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_DECEL_LIMIT,
    AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_VEL_LIMIT,
    AXIS0_OUTPUT_SHAFT_VEL_ESTIMATE,
    AXIS0_OUTPUT_SHAFT_VEL_LIMIT,
    AXIS0_OUTPUT_SHAFT_VEL_RAMP_RATE,
    AXIS0_OUTPUT_SHAFT_VEL_SETPOINT,
    AXIS0_REQUESTED_STATE,
    AXIS0_TRAP_TRAJ_CONFIG_ACCEL_LIMIT,
    AXIS0_TRAP_TRAJ_CONFIG_DECEL_LIMIT,
    AXIS0_TRAP_TRAJ_CONFIG_VEL_LIMIT,
)
from ..protocol.limits import MAX_NODE, MIN_MOTOR
from ..protocol.parameters import DataType, Parameter, encode_value, parameter, parameters
from .defaults import FACTORY, READ_ONLY_CONSTANTS

__all__ = [
    "ANGLE",
    "SPEED",
    "TORQUE",
    "OUTPUT_VIEWS",
    "RUNTIME",
    "CONFIG",
    "ParamStore",
    "SavedConfigError",
    "view_factor",
]

ANGLE, SPEED, TORQUE = 0, 1, 2
"""Kinds of output view: degrees per rotor turn, r/min per rotor turn/s, output Nm per rotor Nm."""

OUTPUT_VIEWS: dict[int, tuple[int, int]] = {
    AXIS0_OUTPUT_SHAFT_INPUT_POS: (AXIS0_CONTROLLER_INPUT_POS, ANGLE),
    AXIS0_OUTPUT_SHAFT_INPUT_VEL: (AXIS0_CONTROLLER_INPUT_VEL, SPEED),
    AXIS0_OUTPUT_SHAFT_INPUT_TORQUE: (AXIS0_CONTROLLER_INPUT_TORQUE, TORQUE),
    AXIS0_OUTPUT_SHAFT_POS_SETPOINT: (AXIS0_CONTROLLER_POS_SETPOINT, ANGLE),
    AXIS0_OUTPUT_SHAFT_VEL_SETPOINT: (AXIS0_CONTROLLER_VEL_SETPOINT, SPEED),
    AXIS0_OUTPUT_SHAFT_TORQUE_SETPOINT: (AXIS0_CONTROLLER_TORQUE_SETPOINT, TORQUE),
    AXIS0_OUTPUT_SHAFT_POS_ESTIMATE: (AXIS0_ENCODER_POS_ESTIMATE, ANGLE),
    AXIS0_OUTPUT_SHAFT_VEL_ESTIMATE: (AXIS0_ENCODER_VEL_ESTIMATE, SPEED),
    AXIS0_OUTPUT_SHAFT_CIRCULAR_SETPOINT_MIN: (AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MIN, ANGLE),
    AXIS0_OUTPUT_SHAFT_CIRCULAR_SETPOINT_MAX: (AXIS0_CONFIG_EXTRA_SETTING_CIRCULAR_SETPOINT_MAX, ANGLE),
    AXIS0_OUTPUT_SHAFT_VEL_LIMIT: (AXIS0_CONTROLLER_CONFIG_VEL_LIMIT, SPEED),
    AXIS0_OUTPUT_SHAFT_TORQUE_LIM: (AXIS0_MOTOR_CONFIG_TORQUE_LIM, TORQUE),
    AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_VEL_LIMIT: (AXIS0_TRAP_TRAJ_CONFIG_VEL_LIMIT, SPEED),
    AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_ACCEL_LIMIT: (AXIS0_TRAP_TRAJ_CONFIG_ACCEL_LIMIT, SPEED),
    AXIS0_OUTPUT_SHAFT_TRAP_TRAJ_DECEL_LIMIT: (AXIS0_TRAP_TRAJ_CONFIG_DECEL_LIMIT, SPEED),
    AXIS0_OUTPUT_SHAFT_VEL_RAMP_RATE: (AXIS0_CONTROLLER_CONFIG_VEL_RAMP_RATE, SPEED),
    AXIS0_OUTPUT_SHAFT_TORQUE_RAMP_RATE: (AXIS0_CONTROLLER_CONFIG_TORQUE_RAMP_RATE, TORQUE),
    AXIS0_OUTPUT_SHAFT_TORQUE_CONSTANT: (AXIS0_MOTOR_CONFIG_TORQUE_CONSTANT, TORQUE),
}
"""Output-shaft parameter -> (rotor-side parameter, kind of conversion)."""

RUNTIME = frozenset(
    (
        AXIS0_REQUESTED_STATE,
        AXIS0_CONTROLLER_INPUT_POS,
        AXIS0_CONTROLLER_INPUT_VEL,
        AXIS0_CONTROLLER_INPUT_TORQUE,
        AXIS0_CONTROLLER_CONFIG_CONTROL_MODE,
        AXIS0_CONTROLLER_CONFIG_INPUT_MODE,
        AXIS0_MOTOR_ERROR,
        AXIS0_MOTOR_CURRENT_CONTROL_IBUS,
        AXIS0_MOTOR_CURRENT_CONTROL_FINAL_V_ALPHA,
        AXIS0_MOTOR_CURRENT_CONTROL_FINAL_V_BETA,
        AXIS0_MOTOR_CURRENT_CONTROL_ID_SETPOINT,
    )
)
"""Writable parameters that are commands or live values, not configuration (never saved)."""

CONFIG = frozenset(
    p.address for p in parameters() if p.writable and p.address not in RUNTIME and p.address not in OUTPUT_VIEWS
)
"""Addresses of the configuration: what save_config stores and init_config restores."""

_FORMAT = "drempower-sim-config"


def view_factor(kind: int, ratio: float) -> float:
    """Output-view value per rotor-side value for ``kind`` at gear ratio ``ratio``."""
    if kind == ANGLE:
        return 360.0 / ratio
    if kind == SPEED:
        return 60.0 / ratio
    return ratio


def _typed(p: Parameter, value: float) -> int | float:
    return float(value) if p.dtype is DataType.F32 else int(value)


class ParamStore:
    """RAM values by address, the saved configuration and the factory configuration of one motor.

    ``node_id`` is the factory node id; ``path`` (optional) the JSON file holding the
    saved configuration, loaded at construction when it exists.
    """

    __slots__ = ("factory", "path", "ram", "saved")

    def __init__(self, node_id: int, path: Path | None = None) -> None:
        factory = {a: _typed(parameter(a), 0) for a in CONFIG}
        for name, value in FACTORY.items():
            factory[parameter(name).address] = _typed(parameter(name), value)
        factory[AXIS0_CONFIG_CAN_NODE_ID] = node_id
        self.factory: dict[int, int | float] = factory
        self.path = path
        self.saved: dict[int, int | float] | None = self._load()
        self.ram: dict[int, int | float] = {p.address: _typed(p, 0) for p in parameters()}
        for name, value in READ_ONLY_CONSTANTS.items():
            self.ram[parameter(name).address] = value
        self.ram[3] = node_id
        self.boot()

    def boot(self) -> None:
        """Power-up: the configuration in RAM becomes the saved one (or the factory one)."""
        self.ram.update(self.factory)
        if self.saved is not None:
            self.ram.update(self.saved)

    def init(self) -> None:
        """init_config: the factory configuration into RAM (not saved)."""
        self.ram.update(self.factory)

    def save(self) -> None:
        """save_config: RAM configuration -> saved configuration (and the file)."""
        self.saved = {a: self.ram[a] for a in CONFIG}
        if self.path is not None:
            doc = {"format": _FORMAT, "parameters": {parameter(a).name: v for a, v in sorted(self.saved.items())}}
            tmp = self.path.with_suffix(".tmp")
            tmp.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
            os.replace(tmp, self.path)

    def erase(self) -> None:
        """erase_config: forget the saved configuration (RAM is untouched)."""
        self.saved = None
        if self.path is not None:
            self.path.unlink(missing_ok=True)

    def _load(self) -> dict[int, int | float] | None:
        if self.path is None or not self.path.exists():
            return None
        problems: list[str] = []
        try:
            doc = json.loads(self.path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, ValueError) as exc:
            raise SavedConfigError(self.path, [f"cannot be read: {exc}"]) from None
        values = doc.get("parameters") if isinstance(doc, dict) and doc.get("format") == _FORMAT else None
        if not isinstance(values, dict):
            raise SavedConfigError(self.path, [f"is not a {_FORMAT} file (an object with its parameters)"])
        saved = dict(self.factory)
        for name, value in values.items():
            try:
                p = parameter(name)
            except ValueError:
                continue  # a parameter of another version: ignored
            if p.address not in CONFIG:
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                problems.append(f"{name}: {value!r} is not a number")
                continue
            if not math.isfinite(value):
                problems.append(f"{name}: {value!r} is not a finite number")
                continue
            if p.dtype is not DataType.F32 and value != int(value):
                problems.append(f"{name}: {value!r} is not a whole number")
                continue
            try:
                encode_value(p.dtype, value, field=name)
            except DrEmpowerError as exc:
                problems.append(str(exc))
                continue
            saved[p.address] = _typed(p, value)
        node = saved[AXIS0_CONFIG_CAN_NODE_ID]
        if not MIN_MOTOR <= node <= MAX_NODE:
            problems.append(
                f"axis0.config.can_node_id={node}: a motor id is {MIN_MOTOR}..{MAX_NODE} (0 is the broadcast address)"
            )
        if problems:
            raise SavedConfigError(self.path, problems)
        return saved
