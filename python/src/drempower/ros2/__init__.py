"""ROS 2 files of a robot file: its URDF, and a colcon package to bring it up with ros2_control and MoveIt."""
