"""A colcon package that brings a robot file up in ROS 2 Jazzy: ros2_control on the bridge's topics, and MoveIt.

:func:`package_files` returns every file of the package by its path in the package; the
robot file and its model are copied under ``robot/`` so that the package's launch file can
start ``drempower bridge`` on them.
"""

from __future__ import annotations

import json
import os
import re
import shutil
from collections.abc import Mapping
from typing import Any

from ..errors import ConfigError
from ..robotfile import RobotSpec
from .urdf import DEFAULT_PLUGIN, PLUGINS, Urdf, robot_urdf

__all__ = ["GROUP", "CONTROLLER", "check_package_name", "package_files", "write_package"]

GROUP = "arm"
"""The MoveIt planning group: every joint of the robot file."""
CONTROLLER = "arm_controller"
"""The joint_trajectory_controller's name, and MoveIt's controller."""
DEFAULT_ACCEL = 5.0
"""rad/s^2 of a joint whose robot file gives no ``limits.accel`` (MoveIt's time parameterisation needs one)."""
_NAME = re.compile(r"^[a-z][a-z0-9_]*$")


def check_package_name(name: str) -> str:
    """``name`` if it is a valid ROS 2 package name (REP 144), else a ConfigError saying what is allowed."""
    if not _NAME.match(name) or "__" in name or name.endswith("_"):
        raise ConfigError(
            f"package name {name!r}: a ROS 2 package name is lower case letters, digits and single underscores, "
            "starting with a letter (e.g. arm6_bringup)"
        )
    return name


def _yaml(value: Any, indent: int = 0) -> str:
    """``value`` (dicts, lists, scalars) as block YAML; strings quoted as JSON, which YAML reads."""
    pad = "  " * indent
    if isinstance(value, Mapping):
        out = []
        for k, v in value.items():
            if isinstance(v, Mapping) and v:
                out.append(f"{pad}{k}:\n{_yaml(v, indent + 1)}")
            else:
                out.append(f"{pad}{k}: {_scalar(v)}")
        return "\n".join(out)
    raise TypeError(value)


def _scalar(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(float(v)) if isinstance(v, float) else str(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_scalar(x) for x in v) + "]"
    if isinstance(v, Mapping) and not v:
        return "{}"
    raise TypeError(v)


def package_files(
    name: str, spec: RobotSpec, *, interfaces: list[str] | None = None, plugin: str = DEFAULT_PLUGIN
) -> dict[str, bytes]:
    """Every file of the package ``name`` for the robot file ``spec`` (path in the package -> content)."""
    check_package_name(name)
    urdf = robot_urdf(spec, mesh_uri=lambda f: f"package://{name}/meshes/{f}", interfaces=interfaces, plugin=plugin)
    robot = urdf.name
    joints = [j.name for j in urdf.joints]
    if not joints:
        raise ConfigError(f"{spec.source}: no joints: a ros2_control package needs at least one")
    assert spec.model is not None  # robot_urdf refuses a file without one
    robot_file = os.path.basename(spec.source)
    model_file = os.path.basename(spec.model.file)
    bridge = f"drempower bridge --robot {robot_file}"
    files: dict[str, bytes] = {}

    def text(path: str, content: str) -> None:
        files[path] = content.encode()

    text(f"urdf/{robot}.urdf", urdf.text)
    for fname, data in urdf.meshes.items():
        files[f"meshes/{fname}"] = data
    with open(spec.source, "rb") as fh:
        files[f"robot/{robot_file}"] = fh.read()
    with open(spec.model.file, "rb") as fh:
        files[f"robot/{model_file}"] = fh.read()
    dirs = ["config", "launch", "robot", "urdf"] + (["meshes"] if urdf.meshes else [])
    text("package.xml", _package_xml(name, robot, PLUGINS[plugin]))
    text("CMakeLists.txt", _cmake(name, dirs))
    text("config/controllers.yaml", _controllers(joints, urdf))
    text(f"config/{robot}.srdf", _srdf(robot, urdf))
    text("config/joint_limits.yaml", _joint_limits(spec, urdf))
    text(
        "config/kinematics.yaml",
        _yaml(
            {
                GROUP: {
                    "kinematics_solver": "kdl_kinematics_plugin/KDLKinematicsPlugin",
                    "kinematics_solver_search_resolution": 0.005,
                    "kinematics_solver_timeout": 0.05,
                }
            }
        )
        + "\n",
    )
    text("config/moveit_controllers.yaml", _moveit_controllers(joints))
    text("config/ompl_planning.yaml", _OMPL)
    text("config/pilz_cartesian_limits.yaml", _PILZ)
    text("config/moveit.rviz", _rviz())
    text("launch/bringup.launch.py", _bringup(name, robot, robot_file, bridge))
    text("launch/moveit.launch.py", _moveit_launch(name, robot))
    text("README.md", _readme(name, robot, robot_file, model_file, joints, bridge, urdf, plugin))
    return files


def write_package(directory: str, files: Mapping[str, bytes]) -> list[str]:
    """Write ``files`` under ``directory`` (created; a file there already is replaced); the paths written."""
    written = []
    for path, data in sorted(files.items()):
        full = os.path.join(directory, path)
        os.makedirs(os.path.dirname(full), exist_ok=True)
        with open(full, "wb") as fh:
            fh.write(data)
        written.append(full)
    return written


def remove_stale(directory: str, files: Mapping[str, bytes]) -> None:
    """Remove the generated folders of ``directory`` that ``files`` does not fill (an old package's meshes)."""
    for sub in ("meshes",):
        if not any(p.startswith(sub + "/") for p in files) and os.path.isdir(os.path.join(directory, sub)):
            shutil.rmtree(os.path.join(directory, sub))


def _package_xml(name: str, robot: str, hardware: str) -> str:
    deps = [
        "robot_state_publisher",
        "controller_manager",
        "joint_state_broadcaster",
        "joint_trajectory_controller",
        hardware,
        "rmw_zenoh_cpp",
        "xacro",
        "moveit_configs_utils",
        "moveit_ros_move_group",
        "moveit_planners_ompl",
        "moveit_kinematics",
        "moveit_simple_controller_manager",
        "moveit_ros_visualization",
        "rviz2",
    ]
    exec_deps = "\n".join(f"  <exec_depend>{d}</exec_depend>" for d in deps)
    return f"""<?xml version="1.0"?>
<?xml-model href="http://download.ros.org/schema/package_format3.xsd" schematypens="http://www.w3.org/2001/XMLSchema"?>
<package format="3">
  <name>{name}</name>
  <version>0.1.0</version>
  <description>ros2_control and MoveIt bringup of {robot} on drempower's bridge</description>
  <maintainer email="maintainer@example.com">maintainer</maintainer>
  <license>Apache-2.0</license>

  <buildtool_depend>ament_cmake</buildtool_depend>

{exec_deps}

  <export>
    <build_type>ament_cmake</build_type>
  </export>
</package>
"""


def _cmake(name: str, dirs: list[str]) -> str:
    return f"""cmake_minimum_required(VERSION 3.8)
project({name})

find_package(ament_cmake REQUIRED)

install(DIRECTORY {" ".join(dirs)}
  DESTINATION share/${{PROJECT_NAME}}
)

ament_package()
"""


def _controllers(joints: list[str], urdf: Urdf) -> str:
    ifaces = list(urdf.joints[0].interfaces)
    return (
        "# controller_manager's controllers: the joints' states, and trajectories on the bridge's TopicBasedSystem\n"
        + _yaml(
            {
                "controller_manager": {
                    "ros__parameters": {
                        "update_rate": 100,
                        "joint_state_broadcaster": {"type": "joint_state_broadcaster/JointStateBroadcaster"},
                        CONTROLLER: {"type": "joint_trajectory_controller/JointTrajectoryController"},
                    }
                },
                CONTROLLER: {
                    "ros__parameters": {
                        "joints": joints,
                        "command_interfaces": ifaces,
                        "state_interfaces": ["position", "velocity"],
                        "allow_partial_joints_goal": True,
                    }
                },
            }
        )
        + "\n"
    )


def _srdf(robot: str, urdf: Urdf) -> str:
    base, tip = urdf.chain[0], urdf.chain[-1]
    lines = [
        '<?xml version="1.0"?>',
        f"<!-- MoveIt's semantic description of {robot}: one planning group with every joint of the robot file. -->",
        f'<robot name="{robot}">',
        f'  <group name="{GROUP}">',
        f'    <chain base_link="{base}" tip_link="{tip}"/>',
        "  </group>",
    ]
    if all((j.lower is None or j.lower <= 0.0) and (j.upper is None or j.upper >= 0.0) for j in urdf.joints):
        lines.append(f'  <group_state name="zero" group="{GROUP}">')
        lines.extend(f'    <joint name="{j.name}" value="0"/>' for j in urdf.joints)
        lines.append("  </group_state>")
    for a, b in urdf.adjacent:
        lines.append(f'  <disable_collisions link1="{a}" link2="{b}" reason="Adjacent"/>')
    for a, b in urdf.colliding:
        lines.append(f'  <disable_collisions link1="{a}" link2="{b}" reason="Default"/>')
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


def _joint_limits(spec: RobotSpec, urdf: Urdf) -> str:
    by_name = spec.joints
    limits: dict[str, Any] = {}
    for j in urdf.joints:
        accel = by_name[j.name].limits.get("accel")
        limits[j.name] = {
            "has_velocity_limits": True,
            "max_velocity": float(j.velocity),
            "has_acceleration_limits": True,
            "max_acceleration": float(accel if accel is not None else DEFAULT_ACCEL),
        }
    return (
        "# MoveIt's joint limits: velocity from the URDF (the robot file's limits.speed, else the typical motor's);\n"
        f"# acceleration the robot file's limits.accel, else {DEFAULT_ACCEL} rad/s^2. Plans start at a tenth of both.\n"
        + _yaml(
            {"default_velocity_scaling_factor": 0.1, "default_acceleration_scaling_factor": 0.1, "joint_limits": limits}
        )
        + "\n"
    )


_OMPL = """# MoveIt's OMPL pipeline (Jazzy's plugin and adapters); moveit_configs_utils adds OMPL's planner defaults
planning_plugins:
  - ompl_interface/OMPLPlanner
start_state_max_bounds_error: 0.1
request_adapters:
  - default_planning_request_adapters/ResolveConstraintFrames
  - default_planning_request_adapters/ValidateWorkspaceBounds
  - default_planning_request_adapters/CheckStartStateBounds
  - default_planning_request_adapters/CheckStartStateCollision
response_adapters:
  - default_planning_response_adapters/AddTimeOptimalParameterization
  - default_planning_response_adapters/ValidateSolution
  - default_planning_response_adapters/DisplayMotionPath
"""
_PILZ = """# Cartesian limits of MoveIt's Pilz planner (m/s, m/s^2, rad/s), which moveit_configs_utils loads
cartesian_limits:
  max_trans_vel: 0.5
  max_trans_acc: 1.0
  max_trans_dec: -1.0
  max_rot_vel: 1.57
"""


def _moveit_controllers(joints: list[str]) -> str:
    return (
        "# MoveIt sends its trajectories to joint_trajectory_controller's action\n"
        + _yaml(
            {
                "moveit_controller_manager": "moveit_simple_controller_manager/MoveItSimpleControllerManager",
                "moveit_simple_controller_manager": {
                    "controller_names": [CONTROLLER],
                    CONTROLLER: {
                        "type": "FollowJointTrajectory",
                        "action_ns": "follow_joint_trajectory",
                        "default": True,
                        "joints": joints,
                    },
                },
            }
        )
        + "\n"
    )


def _rviz() -> str:
    return (
        _yaml(
            {
                "Panels": {},
                "Visualization Manager": {
                    "Class": "",
                    "Global Options": {"Fixed Frame": "world"},
                    "Displays": {},
                },
            }
        )
        .replace("Panels: {}", "Panels:\n  - Class: rviz_common/Displays\n    Name: Displays")
        .replace(
            "  Displays: {}",
            "  Displays:\n"
            "    - Class: rviz_default_plugins/Grid\n"
            "      Name: Grid\n"
            "      Enabled: true\n"
            "    - Class: moveit_rviz_plugin/MotionPlanning\n"
            "      Name: MotionPlanning\n"
            "      Enabled: true\n"
            '      Robot Description: "robot_description"\n'
            "      Planning Request:\n"
            f'        Planning Group: "{GROUP}"\n'
            "        Interactive Marker Size: 0.1",
        )
        + "\n"
    )


def _bringup(name: str, robot: str, robot_file: str, bridge: str) -> str:
    return f'''"""Bring up {robot} in ros2_control on drempower's bridge: robot_state_publisher, ros2_control_node
(TopicBasedSystem on the bridge's joint topics) and the controllers' spawners.

The bus side is drempower's bridge, on the machine with the bus (or the twin):

    export RMW_IMPLEMENTATION=rmw_zenoh_cpp
    {bridge}

bridge:=true starts that command from this launch file, on the package's copy of the robot file
(robot_file:=PATH for another), with the drempower on the PATH.
"""

from pathlib import Path

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description():
    share = Path(get_package_share_directory("{name}"))
    urdf = (share / "urdf" / "{robot}.urdf").read_text()
    controllers = str(share / "config" / "controllers.yaml")
    robot_file = LaunchConfiguration("robot_file")
    return LaunchDescription(
        [
            DeclareLaunchArgument("bridge", default_value="false", description="start drempower bridge too"),
            DeclareLaunchArgument(
                "robot_file",
                default_value=str(share / "robot" / "{robot_file}"),
                description="the robot file the bridge opens",
            ),
            ExecuteProcess(
                cmd=["drempower", "bridge", "--robot", robot_file],
                output="screen",
                condition=IfCondition(LaunchConfiguration("bridge")),
            ),
            Node(
                package="robot_state_publisher",
                executable="robot_state_publisher",
                parameters=[{{"robot_description": urdf}}],
                output="screen",
            ),
            Node(
                package="controller_manager",
                executable="ros2_control_node",
                parameters=[controllers],
                output="screen",
            ),
            Node(package="controller_manager", executable="spawner", arguments=["joint_state_broadcaster"]),
            Node(package="controller_manager", executable="spawner", arguments=["{CONTROLLER}"]),
        ]
    )
'''


def _moveit_launch(name: str, robot: str) -> str:
    return f'''"""MoveIt's move_group for {robot}, and RViz with its MotionPlanning panel (rviz:=false without).

Start launch/bringup.launch.py first: MoveIt sends its plans to {CONTROLLER}'s action.
"""

from pathlib import Path

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from moveit_configs_utils import MoveItConfigsBuilder


def generate_launch_description():
    share = Path(get_package_share_directory("{name}"))
    config = (
        MoveItConfigsBuilder("{robot}", package_name="{name}")
        .robot_description(file_path="urdf/{robot}.urdf")
        .robot_description_semantic(file_path="config/{robot}.srdf")
        .robot_description_kinematics(file_path="config/kinematics.yaml")
        .joint_limits(file_path="config/joint_limits.yaml")
        .trajectory_execution(file_path="config/moveit_controllers.yaml")
        .planning_pipelines(pipelines=["ompl"])
        .to_moveit_configs()
    )
    return LaunchDescription(
        [
            DeclareLaunchArgument("rviz", default_value="true", description="start RViz with MotionPlanning"),
            Node(
                package="moveit_ros_move_group",
                executable="move_group",
                parameters=[config.to_dict()],
                output="screen",
            ),
            Node(
                package="rviz2",
                executable="rviz2",
                arguments=["-d", str(share / "config" / "moveit.rviz")],
                parameters=[
                    config.robot_description,
                    config.robot_description_semantic,
                    config.robot_description_kinematics,
                    config.planning_pipelines,
                    config.joint_limits,
                ],
                condition=IfCondition(LaunchConfiguration("rviz")),
                output="screen",
            ),
        ]
    )
'''


def _readme(
    name: str, robot: str, robot_file: str, model_file: str, joints: list[str], bridge: str, urdf: Urdf, plugin: str
) -> str:
    hardware = PLUGINS[plugin]
    if hardware == "topic_based_ros2_control":
        apt_hw = ""
        source = f"""
`{plugin}` has no Jazzy release: build it in the workspace from source
(github.com/PickNikRobotics/topic_based_ros2_control, `git clone` into `~/ws/src`
before `colcon build`), or write the package again with its successor
(`--plugin joint_state_topic_hardware_interface/JointStateTopicSystem`,
released for Jazzy).
"""
    else:
        apt_hw = " ros-jazzy-joint-state-topic-hardware-interface"
        source = f"""
`{plugin}` is ros-controls' successor of `topic_based_ros2_control`'s
`TopicBasedSystem`: the same topics and parameters, released for Jazzy.
"""
    tree = "\n".join(
        [
            f"{name}/",
            "  package.xml, CMakeLists.txt",
            f"  urdf/{robot}.urdf              the model's links, joints, limits and the <ros2_control> block",
            *(["  meshes/                       the model's meshes (binary STL)"] if urdf.meshes else []),
            f"  robot/{robot_file}, robot/{model_file}   the robot file and its model, for the bridge",
            "  config/controllers.yaml       joint_state_broadcaster and arm_controller (joint_trajectory_controller)",
            f"  config/{robot}.srdf, kinematics.yaml, joint_limits.yaml, moveit_controllers.yaml, moveit.rviz,",
            "    ompl_planning.yaml, pilz_cartesian_limits.yaml   MoveIt's configuration",
            "  launch/bringup.launch.py      robot_state_publisher, ros2_control_node, the spawners (bridge:=true)",
            "  launch/moveit.launch.py       move_group and RViz",
        ]
    )
    return f"""# {name}: {robot} in ROS 2 Jazzy through drempower's bridge

Written by `drempower ros2 package {name} --robot {robot_file}`; write it again
after changing the robot file or its model. The joints: {", ".join(joints)}.

```
{tree}
```

## Install (Ubuntu 24.04, ROS 2 Jazzy)

With ROS 2 Jazzy installed from its apt repository (docs.ros.org, "Ubuntu (deb packages)"):

```sh
sudo apt install ros-jazzy-rmw-zenoh-cpp{apt_hw} \\
    ros-jazzy-ros2-control ros-jazzy-ros2-controllers ros-jazzy-xacro \\
    ros-jazzy-moveit python3-colcon-common-extensions
mkdir -p ~/ws/src && cp -r {name} ~/ws/src/
cd ~/ws && source /opt/ros/jazzy/setup.bash && colcon build --packages-select {name}
```
{source}
drempower runs the bridge, on this machine or on the one with the bus, from a clone of
its repository in a venv of its own (no ROS needed there):

```sh
python3 -m venv ~/drempower-venv && ~/drempower-venv/bin/pip install './python[bridge,physics]'
export PATH=~/drempower-venv/bin:$PATH     # drempower on the PATH
```

## Run

Every terminal first:

```sh
source /opt/ros/jazzy/setup.bash && source ~/ws/install/setup.bash
export RMW_IMPLEMENTATION=rmw_zenoh_cpp
```

```sh
ros2 run rmw_zenoh_cpp rmw_zenohd                   # 1: the Zenoh router (tcp/[::]:7447)
drempower bridge --robot ~/ws/src/{name}/robot/{robot_file}   # 2: the bus (drempower's venv)
ros2 service call /enable std_srvs/srv/Trigger      # 3: closed loop before commanding
ros2 launch {name} bringup.launch.py                # 4: ros2_control
ros2 launch {name} moveit.launch.py                 # 5: MoveIt and RViz
```

The bridge (2) opens the robot file with its model beside it; for the
example arm that is the twin: simulated motors on MuJoCo, inside the bridge.
It connects to the router on localhost:7447 (`--connect tcp/HOST:7447` for a
router elsewhere). `bringup.launch.py bridge:=true` starts it instead, with
drempower on the PATH. In RViz, drag the MotionPlanning marker, then "Plan &
Execute": MoveIt sends the trajectory to `arm_controller`'s action, and
`arm_controller` its commands to the bridge on `/robot_joint_commands`.
A robot on its own bus: change the robot file's `[buses]` and write the package
again (`drempower ros2 package {name} --robot FILE -o DIR`).
"""
