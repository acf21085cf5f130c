"""``drempower ros2 package``: every file of the package parses and names the robot file's joints; the arm's
package shipped under examples/ is what the command writes today."""

from __future__ import annotations

import ast
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

pytest.importorskip("mujoco")
yaml = pytest.importorskip("yaml")
yourdfpy = pytest.importorskip("yourdfpy")

from drempower.cli import main  # noqa: E402
from drempower.robotfile import load_robot  # noqa: E402

REPO = Path(__file__).resolve().parents[3]
ROBOTS = REPO / "examples" / "robots"
SHIPPED = REPO / "examples" / "ros2" / "arm6_bringup"
REGENERATE = "drempower ros2 package arm6_bringup --robot examples/robots/arm6.toml -o examples/ros2/arm6_bringup"


def _generate(name: str, robot: Path, out: Path) -> dict[str, bytes]:
    assert main(["ros2", "package", name, "--robot", str(robot), "-o", str(out)]) == 0
    return {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}


def _parse(path: str, data: bytes) -> object:
    """The file parsed by the parser its kind has; an error if it does not parse."""
    if path.endswith((".xml", ".urdf", ".srdf")):
        return ET.fromstring(data)
    if path.endswith((".yaml", ".rviz")):
        return yaml.safe_load(data)
    if path.endswith(".py"):
        return ast.parse(data)
    if path.endswith(".toml"):
        import tomllib

        return tomllib.loads(data.decode())
    return data.decode()


@pytest.mark.parametrize(("name", "robot"), [("arm6_bringup", "arm6.toml"), ("pendulum_bringup", "pendulum.toml")])
def test_every_file_parses_and_names_every_joint(name: str, robot: str, tmp_path: Path) -> None:
    files = _generate(name, ROBOTS / robot, tmp_path)
    spec = load_robot(ROBOTS / robot)
    joints = list(spec.joints)
    model = Path(spec.model.file).stem if spec.model else ""
    assert {
        "package.xml",
        "CMakeLists.txt",
        "README.md",
        f"urdf/{model}.urdf",
        "config/controllers.yaml",
        f"config/{model}.srdf",
        "config/joint_limits.yaml",
        "config/kinematics.yaml",
        "config/moveit_controllers.yaml",
        "config/ompl_planning.yaml",
        "config/pilz_cartesian_limits.yaml",
        "config/moveit.rviz",
        "launch/bringup.launch.py",
        "launch/moveit.launch.py",
        f"robot/{robot}",
        f"robot/{model}.xml",
    } == set(files)
    parsed = {path: _parse(path, data) for path, data in files.items()}

    pkg = parsed["package.xml"]
    assert isinstance(pkg, ET.Element) and pkg.get("format") == "3" and pkg.findtext("name") == name
    assert pkg.findtext("buildtool_depend") == "ament_cmake"
    deps = {e.text for e in pkg.iter("exec_depend")}
    assert {
        "joint_state_topic_hardware_interface",
        "rmw_zenoh_cpp",
        "controller_manager",
        "moveit_ros_move_group",
    } <= deps
    cmake = files["CMakeLists.txt"].decode()
    assert f"project({name})" in cmake and "find_package(ament_cmake REQUIRED)" in cmake
    assert "install(DIRECTORY config launch robot urdf" in cmake and "ament_package()" in cmake

    controllers = parsed["config/controllers.yaml"]
    assert isinstance(controllers, dict)
    cm = controllers["controller_manager"]["ros__parameters"]
    assert cm["joint_state_broadcaster"]["type"] == "joint_state_broadcaster/JointStateBroadcaster"
    assert cm["arm_controller"]["type"] == "joint_trajectory_controller/JointTrajectoryController"
    assert controllers["arm_controller"]["ros__parameters"]["joints"] == joints

    urdf = yourdfpy.URDF.load(str(tmp_path / f"urdf/{model}.urdf"), load_meshes=False)
    srdf = parsed[f"config/{model}.srdf"]
    assert isinstance(srdf, ET.Element)
    chain = srdf.find("group/chain")
    assert chain is not None and srdf.find("group").get("name") == "arm"  # type: ignore[union-attr]
    # the chain's joints, from its tip back to its base in the URDF, are every joint of the robot file
    by_child = {j.child: j for j in urdf.robot.joints}
    link, moving = chain.get("tip_link"), []
    while link != chain.get("base_link"):
        joint = by_child[link]
        if joint.type != "fixed":
            moving.append(joint.name)
        link = joint.parent
    assert moving[::-1] == joints
    for pair in srdf.iter("disable_collisions"):
        assert {pair.get("link1"), pair.get("link2")} <= set(urdf.link_map)

    limits = parsed["config/joint_limits.yaml"]
    assert isinstance(limits, dict) and list(limits["joint_limits"]) == joints
    for j in joints:
        assert limits["joint_limits"][j]["max_velocity"] == pytest.approx(urdf.joint_map[j].limit.velocity)
    kin = parsed["config/kinematics.yaml"]
    assert isinstance(kin, dict) and kin["arm"]["kinematics_solver"] == "kdl_kinematics_plugin/KDLKinematicsPlugin"
    moveit = parsed["config/moveit_controllers.yaml"]
    assert isinstance(moveit, dict)
    mc = moveit["moveit_simple_controller_manager"]
    assert mc["controller_names"] == ["arm_controller"] and mc["arm_controller"]["joints"] == joints
    assert mc["arm_controller"]["action_ns"] == "follow_joint_trajectory"
    ompl = parsed["config/ompl_planning.yaml"]
    assert isinstance(ompl, dict) and ompl["planning_plugins"] == ["ompl_interface/OMPLPlanner"]
    pilz = parsed["config/pilz_cartesian_limits.yaml"]
    assert isinstance(pilz, dict) and set(pilz["cartesian_limits"]) >= {"max_trans_vel", "max_rot_vel"}

    launch = files["launch/bringup.launch.py"].decode()
    strings = {n.value for n in ast.walk(ast.parse(launch)) if isinstance(n, ast.Constant)}
    assert {
        "robot_state_publisher",
        "ros2_control_node",
        "spawner",
        "joint_state_broadcaster",
        "arm_controller",
    } <= strings
    assert {"drempower", "bridge", "--robot"} <= strings  # the bridge as a process (bridge:=true)
    assert f"drempower bridge --robot {robot}" in launch  # and its command line in the docstring
    moveit_launch = files["launch/moveit.launch.py"].decode()
    assert "MoveItConfigsBuilder" in moveit_launch and f"config/{model}.srdf" in moveit_launch
    readme = files["README.md"].decode()
    for word in (
        "ros-jazzy-rmw-zenoh-cpp",
        "ros-jazzy-joint-state-topic-hardware-interface",
        "rmw_zenohd",
        "colcon build",
    ):
        assert word in readme
    # the robot file copied into the package opens with its model beside it
    copied = load_robot(tmp_path / "robot" / robot)
    assert copied.model is not None and Path(copied.model.file).exists() and list(copied.joints) == joints


def test_the_shipped_arm_package_is_what_the_command_writes(tmp_path: Path) -> None:
    want = _generate("arm6_bringup", ROBOTS / "arm6.toml", tmp_path)
    have = {str(p.relative_to(SHIPPED)): p.read_bytes() for p in sorted(SHIPPED.rglob("*")) if p.is_file()}
    stale = sorted(p for p in set(want) | set(have) if want.get(p) != have.get(p))
    assert not stale, f"examples/ros2/arm6_bringup is stale ({', '.join(stale)}): run {REGENERATE}"


def test_the_first_plugin_is_built_from_source(tmp_path: Path) -> None:
    assert (
        main(
            [
                "ros2",
                "package",
                "arm6_bringup",
                "--robot",
                str(ROBOTS / "arm6.toml"),
                "-o",
                str(tmp_path),
                "--plugin",
                "topic_based_ros2_control/TopicBasedSystem",
            ]
        )
        == 0
    )
    urdf = ET.parse(tmp_path / "urdf" / "arm6.urdf").getroot()
    assert urdf.findtext("ros2_control/hardware/plugin") == "topic_based_ros2_control/TopicBasedSystem"
    deps = {e.text for e in ET.parse(tmp_path / "package.xml").getroot().iter("exec_depend")}
    assert "topic_based_ros2_control" in deps and "joint_state_topic_hardware_interface" not in deps
    readme = (tmp_path / "README.md").read_text()
    assert "PickNikRobotics/topic_based_ros2_control" in readme and "ros-jazzy-joint-state" not in readme


def test_json_says_what_was_written(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    for argv in (["ros2", "package", "p", "--json"], ["ros2", "--json", "package", "p"]):
        assert main([*argv, "--robot", str(ROBOTS / "pendulum.toml"), "-o", str(tmp_path / argv[1])]) == 0
        out = json.loads(capsys.readouterr().out)
        assert out["output"] == str(tmp_path / argv[1]) and "urdf/pendulum.urdf" in out["files"]


def test_a_bad_name_is_refused_with_nothing_written(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["ros2", "package", "Arm-6", "--robot", str(ROBOTS / "arm6.toml"), "-o", str(tmp_path / "p")]) == 2
    assert "package name 'Arm-6'" in capsys.readouterr().err
    assert not (tmp_path / "p").exists()
