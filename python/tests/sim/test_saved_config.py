"""A saved configuration that cannot be loaded: one clear error naming the file, never a traceback."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from drempower.cli import main
from drempower.sim import SimBus
from drempower.sim.params import SavedConfigError

from .helpers import read

GAIN = "axis0.controller.config.pos_gain"


def _saved(tmp_path: Path, **params: object) -> Path:
    path = tmp_path / "motor-1.json"
    path.write_text(json.dumps({"format": "drempower-sim-config", "parameters": params}))
    return path


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("{not json", "cannot be read"),
        ("[]", "is not a drempower-sim-config file"),
        (json.dumps({"format": "drempower-sim-config", "parameters": [1]}), "is not a drempower-sim-config file"),
        (json.dumps({"format": "drempower-sim-config", "parameters": {GAIN: "x"}}), f"{GAIN}: 'x' is not a number"),
        (json.dumps({"format": "drempower-sim-config", "parameters": {GAIN: 1e39}}), "is out of range"),
        (
            json.dumps({"format": "drempower-sim-config", "parameters": {"axis0.config.can_node_id": 0}}),
            "axis0.config.can_node_id=0: a motor id is 1..63",
        ),
        (
            json.dumps({"format": "drempower-sim-config", "parameters": {"axis0.config.can_node_id": 2.5}}),
            "is not a whole number",
        ),
        ('{"format": "drempower-sim-config", "parameters": {"axis0.config.can_node_id": NaN}}', "not a finite number"),
        (json.dumps({"format": "drempower-sim-config", "parameters": {GAIN: float("inf")}}), "not a finite number"),
    ],
)
def test_a_corrupt_saved_configuration_is_one_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], content: str, message: str
) -> None:
    path = tmp_path / "motor-1.json"
    path.write_bytes(content.encode())
    with pytest.raises(SavedConfigError) as info:
        SimBus([1], config_dir=tmp_path)
    assert str(path) in str(info.value) and message in str(info.value)
    assert main(["sim", "--ids", "1", "--config-dir", str(tmp_path), "--duration", "0.05"]) == 2  # a bad file: 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and str(path) in err and message in err
    assert "delete the file, or use another --config-dir" in err


def test_a_good_saved_configuration_loads(tmp_path: Path) -> None:
    _saved(tmp_path, **{GAIN: 25.0, "axis0.config.can_node_id": 1, "some.parameter.of.another.version": 3})
    bus = SimBus([1], config_dir=tmp_path)
    assert read(bus, 1, GAIN) == 25.0
