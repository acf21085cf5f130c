"""identify on twin joints whose inertia, damping and friction loss we set: each recovered within 10 %,
for three settings (a horizontal joint, gravity off; and a joint loaded by gravity)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

import drempower
from drempower.client.engine.effects import sleep
from drempower.errors import ValidationError
from drempower.motion.routines_sync import identify

pytest.importorskip("mujoco", reason="the twin needs MuJoCo")

from ..sim.twin.conftest import PENDULUM_GAINS, model_copy, robot_file

_G = 9.81
_ROD = 2.0 * 0.25 * 0.25 + 0.0416667
"""The pendulum arm's inertia about its axis (kg m^2): m d^2 + I_centre."""


def _pendulum(tmp: Path, armature: float, damping: float, friction: float, gravity: bool) -> Path:
    def edit(root: ET.Element) -> None:
        j = next(root.iter("joint"))
        j.set("armature", str(armature))
        j.set("damping", str(damping))
        j.set("frictionloss", str(friction))
        if not gravity:
            option = root.find("option")
            assert option is not None
            option.set("gravity", "0 0 0")

    model = model_copy(tmp, "pendulum.xml", edit)
    # friction "model": only the model's terms act, so the values set are the whole truth
    return robot_file(tmp, model, {"swing": {"id": 1, "friction": "model", "sim_params": PENDULUM_GAINS}})


@pytest.mark.parametrize(
    ("armature", "damping", "friction", "gravity"),
    [(0.0, 0.05, 0.1, False), (0.02, 0.2, 0.3, False), (0.01, 0.1, 0.2, True)],
)
def test_identify_recovers_what_the_model_sets(
    tmp_path: Path, armature: float, damping: float, friction: float, gravity: bool
) -> None:
    path = _pendulum(tmp_path, armature, damping, friction, gravity)
    with drempower.open_robot(path, sim={"clock": "virtual"}) as robot:
        got = identify(robot, "swing")
        robot.bus("can0").run(sleep(1.0))
        back = robot.joint_states()["swing"].position
    inertia = _ROD + armature
    weight = 2.0 * _G * 0.25 if gravity else 0.0
    print(
        f"set J={inertia:.4f} b={damping} c={friction} G={weight:.3f}; identified J={got.inertia:.4f} "
        f"b={got.viscous:.4f} c={got.coulomb:.4f} G={got.gravity:.3f} fit={got.fit:.4f} ({got.samples} samples)"
    )
    assert got.inertia == pytest.approx(inertia, rel=0.10)
    assert got.viscous == pytest.approx(damping, rel=0.10)
    assert got.coulomb == pytest.approx(friction, rel=0.10)
    if gravity:
        assert got.gravity == pytest.approx(weight, rel=0.10)
    else:
        assert got.gravity < 0.05
    assert got.fit > 0.95
    assert abs(back) < 0.1  # the joint is back near where it started (it hangs at 0)


def test_identify_refuses_an_excitation_beyond_the_limits(tmp_path: Path) -> None:
    path = _pendulum(tmp_path, 0.0, 0.05, 0.1, False)
    with drempower.open_robot(path, sim={"clock": "virtual"}) as robot:
        sent = []
        robot.bus("can0").add_tap(lambda f, tx: sent.append(f) if tx else None)
        with pytest.raises(ValidationError, match=r"leaves its limits -0.2..0.2 rad"):
            identify(robot, "swing", limits={"position": (-0.2, 0.2)})
        assert len(sent) == 1  # the one state read that says where the joint is; no motion command


def test_drempower_identify_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from drempower.cli import main

    model = model_copy(tmp_path, "pendulum.xml", lambda root: None)
    path = robot_file(
        tmp_path, model, {"swing": {"id": 1, "friction": "model", "sim_params": PENDULUM_GAINS}}, clock="virtual"
    )
    assert main(["identify", "swing", "--robot", str(path), "--yes", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"joint", "inertia", "viscous", "coulomb", "gravity", "fit"}
    assert out["inertia"] == pytest.approx(_ROD, rel=0.1) and out["gravity"] == pytest.approx(2 * _G * 0.25, rel=0.1)
    assert out["fit"] > 0.95
    assert main(["identify", "elbow", "--robot", str(path), "--yes"]) == 2
    assert "joint 'elbow': no such joint" in capsys.readouterr().err
    assert main(["identify", "swing", "--robot", str(path)]) == 2  # no terminal to ask on: --yes needed
    assert "needs confirmation" in capsys.readouterr().err
