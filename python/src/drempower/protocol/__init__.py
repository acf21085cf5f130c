"""The DrEmpower CAN protocol, pure: bytes in, typed messages out (no I/O, threads or clocks).

>>> from drempower.protocol import PositionQ, decode_command
>>> f = PositionQ(1, -150.0, speed=10.0, accel=5.0).encode()
>>> hex(f.arbitration_id), f.data.hex(" ")
('0x3a', '00 00 16 c3 e8 03 f4 01')
>>> decode_command(*f[:2])
PositionQ(node=1, position=-150.0, speed=10.0, accel=5.0)
"""

from .describe import decode_frame, describe, message_fields, message_name
from .enums import AxisState, ControlMode, EncoderMode, InputMode, MotorType, TorqueMode, TrajMode, VelocityMode
from .flags import (
    ERROR_WORDS,
    AxisError,
    CanError,
    ControllerError,
    EncoderError,
    ErrorWord,
    FetThermistorError,
    MotorError,
    MotorThermistorError,
    decode_error_word,
    flag_info,
)
from .framing import AADecoder, Uart11Decoder, encode_aa, encode_uart11
from .ids import BROADCAST, MAX_NODE, Cmd, Frame, StartKind, SysCmd, arbitration_id, split_arbitration_id
from .messages import (
    S16_MAX,
    S16_MIN,
    Command,
    FastRead,
    Message,
    ParamValue,
    PositionP,
    PositionQ,
    PositionT,
    Preset,
    PresetC,
    PresetD,
    PresetP,
    PresetQ,
    PresetT,
    PresetV,
    ReadParam,
    Reply,
    Start,
    StartImpedance,
    State,
    SystemCommand,
    Torque,
    Velocity,
    WriteParam,
    decode_command,
    decode_reply,
)
from .parameters import Access, DataType, Parameter, decode_value, encode_value, find_parameter, parameter, parameters

__all__ = [
    "AADecoder", "Access", "AxisError", "AxisState", "BROADCAST", "CanError", "Cmd", "Command",
    "ControlMode", "ControllerError", "DataType", "ERROR_WORDS", "EncoderError", "EncoderMode",
    "ErrorWord", "FastRead", "FetThermistorError", "Frame", "InputMode", "MAX_NODE", "Message",
    "MotorError", "MotorThermistorError", "MotorType", "ParamValue", "Parameter", "PositionP",
    "PositionQ", "PositionT", "Preset", "PresetC", "PresetD", "PresetP", "PresetQ", "PresetT",
    "PresetV", "ReadParam", "Reply", "S16_MAX", "S16_MIN", "Start", "StartImpedance", "StartKind",
    "State", "SysCmd", "SystemCommand", "Torque", "TorqueMode", "TrajMode", "Uart11Decoder",
    "Velocity", "VelocityMode", "WriteParam", "arbitration_id", "decode_command", "decode_error_word",
    "decode_frame", "decode_reply", "decode_value", "describe", "encode_aa", "encode_uart11",
    "find_parameter", "flag_info", "message_fields", "message_name", "parameter", "parameters",
    "split_arbitration_id",
]
