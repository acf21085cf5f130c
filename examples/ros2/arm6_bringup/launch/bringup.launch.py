"""Bring up arm6 in ros2_control on drempower's bridge: robot_state_publisher, ros2_control_node
(TopicBasedSystem on the bridge's joint topics) and the controllers' spawners.

The bus side is drempower's bridge, on the machine with the bus (or the twin):

    export RMW_IMPLEMENTATION=rmw_zenoh_cpp
    drempower bridge --robot arm6.toml

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
    share = Path(get_package_share_directory("arm6_bringup"))
    urdf = (share / "urdf" / "arm6.urdf").read_text()
    controllers = str(share / "config" / "controllers.yaml")
    robot_file = LaunchConfiguration("robot_file")
    return LaunchDescription(
        [
            DeclareLaunchArgument("bridge", default_value="false", description="start drempower bridge too"),
            DeclareLaunchArgument(
                "robot_file",
                default_value=str(share / "robot" / "arm6.toml"),
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
                parameters=[{"robot_description": urdf}],
                output="screen",
            ),
            Node(
                package="controller_manager",
                executable="ros2_control_node",
                parameters=[controllers],
                output="screen",
            ),
            Node(package="controller_manager", executable="spawner", arguments=["joint_state_broadcaster"]),
            Node(package="controller_manager", executable="spawner", arguments=["arm_controller"]),
        ]
    )
