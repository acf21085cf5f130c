"""``drempower ros2 urdf``: the URDF's kinematics are MuJoCo's, read back by an independent URDF library (yourdfpy)."""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")
yourdfpy = pytest.importorskip("yourdfpy")
trimesh = pytest.importorskip("trimesh")

from drempower.cli import main  # noqa: E402
from drempower.robotfile import load_robot  # noqa: E402
from drempower.ros2.urdf import robot_urdf  # noqa: E402

ROBOTS = Path(__file__).resolve().parents[3] / "examples" / "robots"
TOL = 1e-3
"""m: the largest distance allowed between a link (or visual) in the URDF and in MuJoCo."""

# a model with what the examples lack: a body with two hinges whose anchors are off its origin, a slide
# joint, a passive joint, a mesh, a rotated body and a joint the robot file names by model_joint
ODD_MODEL = """
<mujoco model="odd">
  <compiler angle="radian"/>
  <asset>
    <mesh name="wedge" vertex="0 0 0  0.1 0 0  0 0.08 0  0 0 0.05" scale="1 1 2"/>
  </asset>
  <worldbody>
    <body name="base" pos="0.1 0.2 0.3" quat="0.9238795 0 0.3826834 0">
      <geom type="box" size="0.05 0.04 0.03" pos="0.01 0 0" mass="1"/>
      <body name="twist" pos="0 0 0.1" quat="0.8660254 0.5 0 0">
        <joint name="j_a" type="hinge" axis="0 0 1" pos="0.02 0 0" range="-2 2"/>
        <joint name="j_b" type="hinge" axis="1 1 0" pos="0 0.03 0.01" range="-1.5 1.5"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0.1" size="0.02" mass="0.3"/>
        <geom type="mesh" mesh="wedge" pos="0.05 0 0" euler="0.3 0.2 0.1" mass="0.1"/>
        <body name="slider" pos="0.2 0 0.1">
          <joint name="j_s" type="slide" axis="0 0 1" pos="0 0.01 0" range="-0.05 0.1"/>
          <geom type="sphere" size="0.03" pos="0 0.02 0" mass="0.2"/>
          <body name="tip" pos="0 0 0.05" euler="0 0.5 0">
            <joint name="free_spin" type="hinge" axis="0 1 0" pos="0.01 0 0"/>
            <geom type="cylinder" size="0.01 0.03" pos="0 0 0.03" mass="0.05"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
ODD_ROBOT = """
[model]
file = "odd.xml"
[buses.b]
interface = "sim"
[joints.first]
bus = "b"
id = 1
model_joint = "j_a"
limits = { position = [-1.0, 3.0] }
[joints.j_b]
bus = "b"
id = 2
[joints.j_s]
bus = "b"
id = 3
"""


def _write_urdf(robot: Path, tmp: Path) -> Path:
    out = tmp / "robot.urdf"
    assert main(["ros2", "urdf", "--robot", str(robot), "-o", str(out)]) == 0
    return out


def _mujoco(model_file: str) -> tuple[object, object]:
    m = mujoco.MjModel.from_xml_path(model_file)
    return m, mujoco.MjData(m)


def _pose(pos: np.ndarray, mat: np.ndarray) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = np.asarray(mat).reshape(3, 3)
    t[:3, 3] = pos
    return t


def _worst(robot: Path, tmp: Path, samples: int = 50) -> tuple[float, float, int]:
    """The largest position error (m) and orientation error (rad) of any link and visual between the URDF read
    by yourdfpy and MuJoCo, at ``samples`` random configurations within the joints' ranges; links compared."""
    spec = load_robot(robot)
    assert spec.model is not None
    path = _write_urdf(robot, tmp)
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False)
    m, d = _mujoco(spec.model.file)
    names = {(j.model_joint or j.name): j.name for j in spec.joints.values()}
    rng = np.random.default_rng(7)
    worst_pos, worst_rot, compared = 0.0, 0.0, 0
    for _ in range(samples):
        cfg = {}
        for jid in range(m.njnt):
            lo, hi = m.jnt_range[jid] if m.jnt_limited[jid] else (-math.pi, math.pi)
            q = float(rng.uniform(lo, hi))
            d.qpos[m.jnt_qposadr[jid]] = q
            jname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, jid)
            cfg[names.get(jname, jname)] = q
        # the URDF's limits are the file's narrowed by the model's: keep the sample inside them
        for name, joint in urdf.joint_map.items():
            if name in cfg and joint.limit is not None and joint.limit.lower is not None:
                cfg[name] = min(max(cfg[name], joint.limit.lower), joint.limit.upper)
                for jid in range(m.njnt):
                    if names.get(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, jid)) == name or (
                        mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, jid) == name
                    ):
                        d.qpos[m.jnt_qposadr[jid]] = cfg[name]
        mujoco.mj_kinematics(m, d)
        urdf.update_cfg(cfg)
        for b in range(1, m.nbody):
            link = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b)
            want = _pose(d.xpos[b], d.xmat[b])
            if m.body_jntnum[b]:  # the link's frame is at its last joint's anchor (its pos in the body)
                want[:3, 3] += want[:3, :3] @ m.jnt_pos[m.body_jntadr[b] + m.body_jntnum[b] - 1]
            got = urdf.get_transform(frame_to=link, frame_from="world")
            worst_pos = max(worst_pos, float(np.linalg.norm(got[:3, 3] - want[:3, 3])))
            worst_rot = max(worst_rot, float(np.linalg.norm(got[:3, :3] - want[:3, :3])))
            compared += 1
            # each geom's visual where MuJoCo has the geom (a capsule's cylinder, a mesh's vertices)
            visuals = {v.name: v for v in urdf.link_map[link].visuals}
            for g in range(m.ngeom):
                if m.geom_bodyid[g] != b:
                    continue
                vis = visuals[mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom {g}"]
                got_g = got @ (vis.origin if vis.origin is not None else np.eye(4))
                want_g = _pose(d.geom_xpos[g], d.geom_xmat[g])
                if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
                    fname = vis.geometry.mesh.filename.removeprefix("file://")
                    verts = np.asarray(trimesh.load(fname, force="mesh").vertices)
                    mid = m.geom_dataid[g]
                    want_v = np.asarray(m.mesh_vert[m.mesh_vertadr[mid] : m.mesh_vertadr[mid] + m.mesh_vertnum[mid]])
                    got_w = verts @ got_g[:3, :3].T + got_g[:3, 3]
                    want_w = want_v @ want_g[:3, :3].T + want_g[:3, 3]
                    # the STL lists each triangle's corners: every corner is one of MuJoCo's vertices
                    err = max(float(np.min(np.linalg.norm(want_w - p, axis=1))) for p in got_w)
                    worst_pos = max(worst_pos, err)
                else:
                    worst_pos = max(worst_pos, float(np.linalg.norm(got_g[:3, 3] - want_g[:3, 3])))
                    worst_rot = max(worst_rot, float(np.linalg.norm(got_g[:3, :3] - want_g[:3, :3])))
    return worst_pos, worst_rot, compared


@pytest.mark.parametrize("robot", ["arm6.toml", "pendulum.toml"])
def test_every_link_is_where_mujoco_puts_it(robot: str, tmp_path: Path) -> None:
    pos, rot, compared = _worst(ROBOTS / robot, tmp_path)
    print(f"{robot}: {compared} link poses, worst {pos * 1000:.2e} mm, {rot:.2e} rad")
    assert compared >= 50
    assert pos < TOL and rot < 1e-6


def test_a_urdf_model_keeps_its_links_and_visuals(tmp_path: Path) -> None:
    robot = tmp_path / "pendulum_urdf.toml"
    robot.write_text((ROBOTS / "pendulum.toml").read_text().replace('"pendulum.xml"', f'"{ROBOTS / "pendulum.urdf"}"'))
    pos, rot, compared = _worst(robot, tmp_path)
    print(f"pendulum.urdf: {compared} link poses, worst {pos * 1000:.2e} mm, {rot:.2e} rad")
    assert compared >= 50 and pos < TOL and rot < 1e-6
    root = ET.parse(tmp_path / "robot.urdf").getroot()
    assert [link.get("name") for link in root.iter("link")] == ["world", "stand", "arm"]
    arm = next(link for link in root.iter("link") if link.get("name") == "arm")
    cylinder = arm.find("visual/geometry/cylinder")  # MuJoCo's URDF import drops visuals unless told not to
    assert cylinder is not None and (cylinder.get("radius"), cylinder.get("length")) == ("0.012", "0.5")
    visual_origin = arm.find("visual/origin")
    assert visual_origin is not None and visual_origin.get("xyz") == "0 0 -0.25"


def test_anchors_several_joints_a_slide_and_a_mesh(tmp_path: Path) -> None:
    (tmp_path / "odd.xml").write_text(ODD_MODEL)
    (tmp_path / "odd.toml").write_text(ODD_ROBOT)
    pos, rot, compared = _worst(tmp_path / "odd.toml", tmp_path)
    print(f"odd model: {compared} link poses, worst {pos * 1000:.2e} mm, {rot:.2e} rad")
    assert compared >= 200
    assert pos < TOL and rot < 1e-6
    root = ET.parse(tmp_path / "robot.urdf").getroot()
    joints = {j.get("name"): j for j in root.iter("joint") if j.find("parent") is not None}
    assert joints["first"].get("type") == "revolute"  # the robot file's name, not the model's j_a
    limit = joints["first"].find("limit")
    assert limit is not None and (float(limit.get("lower", "")), float(limit.get("upper", ""))) == (-1.0, 2.0)
    assert joints["j_s"].get("type") == "prismatic"
    assert joints["free_spin"].get("type") == "continuous"  # passive: in the URDF, not in ros2_control
    assert {"twist__j_a", "twist"} <= {link.get("name") for link in root.iter("link")}
    assert os.path.exists(tmp_path / "meshes" / "wedge.stl")


def test_ros2_control_block_names_the_bridges_topics_and_interfaces(tmp_path: Path) -> None:
    robot = tmp_path / "arm.toml"
    robot.write_text(
        (ROBOTS / "arm6.toml").read_text().replace('file = "arm6.xml"', f'file = "{ROBOTS / "arm6.xml"}"')
        + '\n[ros2_control]\njoint_commands_topic = "/arm/cmd"\ncommand_interfaces = ["position", "velocity"]\n'
        + "[joints.elbow.limits]\nposition = [-1.0, 3.0]\nspeed = 2.0\ntorque = 5.0\n"
    )
    root = ET.fromstring(robot_urdf(load_robot(robot)).text)
    block = root.find("ros2_control")
    assert block is not None
    hw = block.find("hardware")
    assert hw is not None and hw.findtext("plugin") == "joint_state_topic_hardware_interface/JointStateTopicSystem"
    params = {p.get("name"): p.text for p in hw.iter("param")}
    assert params == {"joint_commands_topic": "/arm/cmd", "joint_states_topic": "/robot_joint_states"}
    joints = block.findall("joint")
    assert [j.get("name") for j in joints] == [
        "base_yaw",
        "shoulder",
        "elbow",
        "wrist_roll",
        "wrist_pitch",
        "flange_roll",
    ]
    for j in joints:
        assert [c.get("name") for c in j.findall("command_interface")] == ["position", "velocity"]
        assert [s.get("name") for s in j.findall("state_interface")] == ["position", "velocity", "effort"]
    elbow = next(j for j in root.findall("joint") if j.get("name") == "elbow").find("limit")
    assert elbow is not None
    # the file's -1..3 narrowed by the model's -2.5..2.5; speed and torque the file's
    assert [float(elbow.get(k, "")) for k in ("lower", "upper", "velocity", "effort")] == [-1.0, 2.5, 2.0, 5.0]
    shoulder = next(j for j in root.findall("joint") if j.get("name") == "shoulder").find("limit")
    assert shoulder is not None  # no file limits: the typical motor's through the 2:1 gear
    assert float(shoulder.get("effort", "")) == 24.0
    assert float(shoulder.get("velocity", "")) == pytest.approx(10 * math.pi / 2)


def test_bad_input_is_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    no_model = tmp_path / "bare.toml"
    no_model.write_text('[buses.b]\ninterface = "sim"\n[joints.a]\nbus = "b"\nid = 1\n')
    assert main(["ros2", "urdf", "--robot", str(no_model)]) == 2
    assert "no [model]" in capsys.readouterr().err
    (tmp_path / "ball.xml").write_text(
        '<mujoco><worldbody><body name="b"><joint name="a" type="ball"/><geom size="0.1"/></body></worldbody></mujoco>'
    )
    (tmp_path / "ball.toml").write_text(
        '[model]\nfile = "ball.xml"\n[buses.b]\ninterface = "sim"\n[joints.x]\nbus = "b"\nid = 1\nmodel_joint = "a"\n'
    )
    assert main(["ros2", "urdf", "--robot", str(tmp_path / "ball.toml")]) == 2
    err = capsys.readouterr().err
    assert "joint 'a' is a ball joint" in err and "Traceback" not in err
    (tmp_path / "far.toml").write_text(
        f'[model]\nfile = "{ROBOTS / "arm6.xml"}"\n[buses.b]\ninterface = "sim"\n'
        '[joints.elbow]\nbus = "b"\nid = 1\nlimits = { position = [2.6, 3.0] }\n'
    )
    assert main(["ros2", "urdf", "--robot", str(tmp_path / "far.toml")]) == 2
    assert "[joints.elbow]: limits.position=[2.6, 3.0] is outside the model's range" in capsys.readouterr().err
