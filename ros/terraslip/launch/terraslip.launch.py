"""terraslip as a ROS 2 node: `ros2 launch terraslip terraslip.launch.py`.

Arguments (name:=value): topics (the topics file), params (the learned
parameters file), odom_frame, base_frame, publish_tf. Everything else is a
ROS parameter of the node (see `terraslip node --help`).
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare


def generate_launch_description():
    arg = LaunchConfiguration
    return LaunchDescription([
        DeclareLaunchArgument(
            "topics",
            default_value=PathJoinSubstitution([FindPackageShare("terraslip"), "config", "husky.toml"]),
            description="topics file: which topic is the wheels, pose, heading, IMU"),
        DeclareLaunchArgument(
            "params", default_value="/var/lib/terraslip/terraslip.json",
            description="the node's learned parameters file (recalled at start, saved at the end)"),
        DeclareLaunchArgument("odom_frame", default_value="odom"),
        DeclareLaunchArgument("base_frame", default_value="base_link"),
        DeclareLaunchArgument("publish_tf", default_value="true"),
        Node(
            package="terraslip",
            executable="node",
            name="terraslip",
            arguments=["--topics", arg("topics"), "--params", arg("params")],
            parameters=[{
                "odom_frame": arg("odom_frame"),
                "base_frame": arg("base_frame"),
                "publish_tf": arg("publish_tf"),
            }],
            output="screen",
            # SIGINT, then SIGTERM after 10 s: the node saves its parameters.
            sigterm_timeout="10",
        ),
    ])
