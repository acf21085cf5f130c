"""Sensor noise: the state frames a motor sends scatter by the standard deviations asked, repeatably
for a seed; the motor itself (its controller, its physics) stays exact; bad values are refused by name."""

from __future__ import annotations

import statistics

import pytest

from drempower.errors import ValidationError
from drempower.protocol import FastRead, PositionQ, ReadParam, State
from drempower.sim import SensorNoise, SimBus
from drempower.sim.noise import NOISE_LIMITS, parse_noise

from .helpers import Tap


def _states(bus: SimBus, seconds: float) -> list[State]:
    """The heartbeats (every 1 ms) of motor 1 over ``seconds`` s."""
    bus.motors[1].set_param("can.config.heartbeat_ms", 1)
    tap = Tap(bus)
    bus.advance(seconds)
    out = [r for r in tap.replies() if isinstance(r, State)]
    assert len(out) >= 0.9 * seconds * 1000
    return out


def test_the_readings_scatter_by_the_deviations_asked_around_the_truth() -> None:
    noise = SensorNoise(position=0.02, speed=0.5, torque=0.03)
    idle = SimBus([1], noise=noise, seed=3)  # an idle motor at rest: 0 deg, 0 r/min, 0 Nm exactly
    states = _states(idle, 2.0)
    for field, sd in (("position", 0.02), ("speed", 0.5), ("torque", 0.03)):
        values = [getattr(s, field) for s in states]
        assert statistics.fmean(values) == pytest.approx(0.0, abs=5 * sd / len(values) ** 0.5), field
        assert statistics.stdev(values) == pytest.approx(sd, rel=0.1), field  # 2000 samples: 2 % of sd
    # a motor holding at 45 deg, beside the same without noise: the noise is in the readings only
    noisy, exact = SimBus([1], noise=noise, seed=3), SimBus([1])
    for bus in (noisy, exact):
        bus.send(PositionQ(1, 45.0, 30.0, 100.0).encode())
        bus.advance(3.0)
    assert noisy.motors[1].position == pytest.approx(45.0, abs=0.05)
    read, truth = _states(noisy, 2.0), _states(exact, 2.0)
    pos = [a.position - b.position for a, b in zip(read, truth, strict=True)]
    assert statistics.fmean(pos) == pytest.approx(0.0, abs=0.003)
    assert statistics.stdev(pos) == pytest.approx(0.02, rel=0.1)
    assert noisy.motors[1].position == exact.motors[1].position  # the motors moved alike


def test_a_seed_repeats_the_noise_and_another_changes_it() -> None:
    def run(seed: int | None, bus_seed: int = 0) -> list[float]:
        bus = SimBus([1], noise=SensorNoise(position=0.01, seed=seed), seed=bus_seed)
        return [s.position for s in _states(bus, 0.2)]

    assert run(5) == run(5)
    assert run(5) != run(6)
    assert run(None, bus_seed=5) == run(None, bus_seed=5) != run(None, bus_seed=6)


def test_no_noise_leaves_the_frames_exact_and_other_replies_untouched() -> None:
    plain = SimBus([1])
    assert {s.position for s in _states(plain, 0.1)} == {0.0}
    assert SimBus([1], noise={"position": 0.0}).readings is None
    bus = SimBus([1], noise={"position": 0.5})
    tap = Tap(bus)
    bus.send(ReadParam.of(1, "axis0.encoder.pos_estimate").encode())
    bus.send(FastRead(1).encode())
    got = tap.replies()
    assert len(got) == 2
    assert got[0].value == 0.0  # type: ignore[union-attr] # a parameter read stays exact
    assert isinstance(got[1], State) and got[1].position != 0.0


@pytest.mark.parametrize(
    ("given", "words"),
    [
        ({"position": -0.01}, "noise position=-0.01: expected a standard deviation 0..1 deg"),
        ({"position": 2.0}, "noise position=2.0: expected a standard deviation 0..1 deg"),
        ({"speed": float("nan")}, "noise speed=nan: expected a standard deviation 0..10 r/min"),
        ({"torque": "0.1"}, "noise torque='0.1': expected a standard deviation 0..1 Nm"),
        ({"seed": 1.5}, "noise seed=1.5: expected a whole number"),
        ({"pos": 0.01}, "noise: unknown key 'pos' (position deg, speed r/min, torque Nm, seed)"),
    ],
)
def test_bad_noise_is_refused_naming_the_field_value_and_range(given: dict[str, object], words: str) -> None:
    with pytest.raises(ValidationError) as err:
        SimBus([1], noise=given)
    assert str(err.value) == words


def test_the_command_line_form() -> None:
    assert parse_noise("position=0.01,speed=0.2,torque=0.005") == SensorNoise(0.01, 0.2, 0.005)
    assert parse_noise("torque=1") == SensorNoise(torque=1.0)
    for text, words in (
        ("position=x", "noise position='x': expected a number"),
        ("pos=0.1", "noise 'pos=0.1': expected position=DEG, speed=RPM or torque=NM, comma separated"),
        ("speed=11", "noise speed=11.0: expected a standard deviation 0..10 r/min"),
    ):
        with pytest.raises(ValidationError, match="^" + words.replace("(", r"\(").replace(")", r"\)")):
            parse_noise(text)
    assert NOISE_LIMITS == {"position": 1.0, "speed": 10.0, "torque": 1.0}
