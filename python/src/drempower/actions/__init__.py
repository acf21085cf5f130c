"""What a person or a program can do to motors: one table, one validation, one way to run.

Each :class:`Action` names its operation (a call of the :class:`~drempower.AsyncMotor` /
:class:`~drempower.AsyncBus` API, which the threaded :class:`~drempower.Bus` shares), its
arguments with units and domains (motor ids from :mod:`drempower.protocol.limits`,
speeds and torques from the same place, parameters from ``spec/parameters.csv``), its
safety class and its help text. :func:`validate` turns loose arguments (numbers, or
the strings of a command line or a form) into typed ones with the same error words
everywhere (``field=value is out of range: allowed low..high (unit)``), and
:func:`run` / :func:`run_async` carry an action out on a bus::

    from drempower import actions
    actions.run(bus, "move", {"id": 1, "angle": 90})        # threaded bus
    await actions.run_async(abus, "speed", {"id": 1, "speed": 30, "duration": 2})

Motion actions pass the bus's safety gate (idle motors, soft limits; see
:mod:`drempower.client.engine.gate`). A new query is one operation plus one row::

    actions.register(actions.Action("volcur", "read", "supply voltage and current",
                                    (actions.MOTOR,), lambda bus, a: bus.motor(a["id"]).get_volcur()))

and front ends that list :func:`table` (the CLI's subcommands, the dashboard's controls)
offer it with no further change. A front end runs rows through one :class:`Service`
(:mod:`drempower.actions.service`: validate, gate, confirm, act, confirm the outcome, word it),
giving what is its own (where a motor key lives, read-only, a fence, limits, a log) as hooks.
"""

from __future__ import annotations

from .args import (
    ACCEL,
    ANGLE,
    BANDWIDTH,
    CRUISE,
    DURATION,
    ENABLE,
    FORCE,
    KD,
    KP,
    MOTOR,
    MOTOR_OR_ALL,
    PARAM,
    POSITION_ARGS,
    POSITION_MODE,
    SPEED,
    SPEED_FF,
    SPEED_MODE,
    SPEED_RAMP,
    SPEED_TFF,
    STEP,
    TFF,
    TORQUE,
    TORQUE_FF,
    TORQUE_MODE,
    TORQUE_RAMP,
    VALUE,
    VEL,
    VERIFY,
    Arg,
    bandwidth_range,
)
from .service import Checked, Motors, OneBus, Outcome, Policy, Service
from .settle import ENABLE_SETTLE, why_not_cleared, why_not_enabled
from .table import Action, Safety, get, register, table, unregister
from .validate import run, run_async, validate
from .words import describe, outcome, plain

__all__ = [
    "Checked",
    "Motors",
    "OneBus",
    "Outcome",
    "Policy",
    "Service",
    "ACCEL",
    "ANGLE",
    "Action",
    "Arg",
    "BANDWIDTH",
    "CRUISE",
    "DURATION",
    "ENABLE",
    "ENABLE_SETTLE",
    "FORCE",
    "KD",
    "KP",
    "MOTOR",
    "MOTOR_OR_ALL",
    "PARAM",
    "POSITION_ARGS",
    "POSITION_MODE",
    "SPEED",
    "SPEED_FF",
    "SPEED_MODE",
    "SPEED_RAMP",
    "SPEED_TFF",
    "STEP",
    "Safety",
    "TFF",
    "TORQUE",
    "TORQUE_FF",
    "TORQUE_MODE",
    "TORQUE_RAMP",
    "VALUE",
    "VEL",
    "VERIFY",
    "bandwidth_range",
    "describe",
    "get",
    "outcome",
    "plain",
    "register",
    "run",
    "run_async",
    "table",
    "unregister",
    "validate",
    "why_not_cleared",
    "why_not_enabled",
]
