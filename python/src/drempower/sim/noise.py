"""Sensor noise on what the simulated motors report: their state frames.

A real motor's readings scatter around the truth (the encoder's resolution and its estimator, the
current sensing); the simulator's are exact. :class:`SensorNoise` adds zero-mean Gaussian noise of
a given standard deviation to the position (deg), speed (r/min) and torque (Nm) of every state frame
a motor sends (the replies to control commands and fast reads, and the heartbeats), drawn from a
generator of its own seeded by ``seed``, so a run is repeatable. The physics never sees it: the
motor's controller, the twin and ``SimMotor.position`` stay exact; parameter reads stay exact too.

Give it as ``SimBus(noise=SensorNoise(position=0.01, seed=1))``, ``noise={"position": 0.01}`` (an
``open_bus``/``open_robot(..., sim={...})`` option, or a sim bus entry's ``noise = {position = 0.01}``
in a robot file), or ``drempower sim [--robot FILE] --noise position=0.01,speed=0.2,torque=0.005``
(seeded by ``--seed``).
"""

from __future__ import annotations

import math
import random
from collections.abc import Mapping
from dataclasses import dataclass, fields

from ..errors import ProtocolError, ValidationError
from ..protocol.ids import Frame
from ..protocol.limits import S16_MAX, S16_MIN
from ..protocol.messages import State, decode_reply

__all__ = ["NOISE_LIMITS", "Readings", "SensorNoise", "parse_noise", "sensor_noise"]

NOISE_LIMITS = {"position": 1.0, "speed": 10.0, "torque": 1.0}
"""The largest standard deviation of each reading's noise: position deg, speed r/min, torque Nm."""
_UNITS = {"position": "deg", "speed": "r/min", "torque": "Nm"}


@dataclass(frozen=True)
class SensorNoise:
    """Standard deviations of the noise on the reported ``position`` (deg), ``speed`` (r/min) and
    ``torque`` (Nm), each 0 (none) up to :data:`NOISE_LIMITS`; ``seed`` of its generator (None: the
    bus's ``seed``). Raises :class:`ValidationError` naming the field, the value and the range."""

    position: float = 0.0
    speed: float = 0.0
    torque: float = 0.0
    seed: int | None = None

    def __post_init__(self) -> None:
        for name, top in NOISE_LIMITS.items():
            value = getattr(self, name)
            if (
                isinstance(value, bool)
                or not isinstance(value, int | float)
                or not math.isfinite(value)
                or not 0.0 <= value <= top
            ):
                raise ValidationError(
                    f"noise {name}={value!r}: expected a standard deviation 0..{top:g} {_UNITS[name]}"
                )
        if self.seed is not None and (isinstance(self.seed, bool) or not isinstance(self.seed, int)):
            raise ValidationError(f"noise seed={self.seed!r}: expected a whole number")

    @property
    def active(self) -> bool:
        """True when some reading gets noise."""
        return bool(self.position or self.speed or self.torque)


def sensor_noise(value: SensorNoise | Mapping[str, object] | None) -> SensorNoise | None:
    """``value`` as a :class:`SensorNoise` (a mapping by field name), or None when it adds none."""
    if value is None:
        return None
    if not isinstance(value, SensorNoise):
        if not isinstance(value, Mapping):
            raise ValidationError(f"noise={value!r}: expected a table of position, speed, torque and seed")
        known = {f.name for f in fields(SensorNoise)}
        unknown = sorted(str(k) for k in value if k not in known)
        if unknown:
            raise ValidationError(f"noise: unknown key {unknown[0]!r} (position deg, speed r/min, torque Nm, seed)")
        value = SensorNoise(**value)  # type: ignore[arg-type]
    return value if value.active else None


def parse_noise(text: str) -> SensorNoise:
    """``position=DEG[,speed=RPM][,torque=NM]`` (a command line's) as a :class:`SensorNoise`."""
    given: dict[str, float] = {}
    for part in text.split(","):
        key, sep, number = part.partition("=")
        key = key.strip()
        if not sep or key not in NOISE_LIMITS:
            raise ValidationError(
                f"noise {part.strip()!r}: expected position=DEG, speed=RPM or torque=NM, comma separated"
            )
        try:
            given[key] = float(number)
        except ValueError:
            raise ValidationError(f"noise {key}={number.strip()!r}: expected a number") from None
    return SensorNoise(given.get("position", 0.0), given.get("speed", 0.0), given.get("torque", 0.0))


class Readings:
    """What adds ``noise`` to the state frames of one bus's motors, from its own generator."""

    def __init__(self, noise: SensorNoise, seed: int = 0) -> None:
        self.noise = noise
        self.rng = random.Random(noise.seed if noise.seed is not None else seed)

    def report(self, frame: Frame) -> Frame:
        """``frame`` as reported: a state frame with noisy position, speed and torque; another as it is."""
        try:
            msg = decode_reply(frame.arbitration_id, frame.data)
        except ProtocolError:
            return frame
        if not isinstance(msg, State):
            return frame
        n, gauss = self.noise, self.rng.gauss
        position = msg.position + gauss(0.0, n.position) if n.position else msg.position
        speed = _s16(msg.speed + gauss(0.0, n.speed)) if n.speed else msg.speed
        torque = _s16(msg.torque + gauss(0.0, n.torque)) if n.torque else msg.torque
        noisy = State(msg.node, position, speed, torque, msg.trajectory_done, msg.error, msg.spare_bits).encode()
        return frame._replace(data=noisy.data)


def _s16(x: float) -> float:
    """A reading as the state frame's 16-bit field holds it: at its end when beyond (a sensor saturates)."""
    return min(max(x, S16_MIN), S16_MAX)
