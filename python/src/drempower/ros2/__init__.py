"""ROS 2 files of a robot file: its URDF (:mod:`.urdf`), and a colcon package that brings it up with ros2_control
and MoveIt (:mod:`.package`)."""

__all__ = ["DEFAULT_PLUGIN", "PLUGINS"]

PLUGINS = {
    "joint_state_topic_hardware_interface/JointStateTopicSystem": "joint_state_topic_hardware_interface",
    "topic_based_ros2_control/TopicBasedSystem": "topic_based_ros2_control",
}
"""The ros2_control hardware plugins that speak the bridge's joint topics, and their ROS 2 packages:
ros-controls' ``JointStateTopicSystem`` (released for Jazzy, ``ros-jazzy-joint-state-topic-hardware-interface``)
and PickNik's ``TopicBasedSystem`` it grew from (the same topics and parameters; released for Humble, built from
source on Jazzy)."""
DEFAULT_PLUGIN = "joint_state_topic_hardware_interface/JointStateTopicSystem"
