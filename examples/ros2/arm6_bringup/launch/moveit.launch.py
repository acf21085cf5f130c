"""MoveIt's move_group for arm6, and RViz with its MotionPlanning panel (rviz:=false without).

Start launch/bringup.launch.py first: MoveIt sends its plans to arm_controller's action.
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
    share = Path(get_package_share_directory("arm6_bringup"))
    config = (
        MoveItConfigsBuilder("arm6", package_name="arm6_bringup")
        .robot_description(file_path="urdf/arm6.urdf")
        .robot_description_semantic(file_path="config/arm6.srdf")
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
