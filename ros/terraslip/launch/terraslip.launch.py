"""terraslip as a ROS 2 node: `ros2 launch terraslip terraslip.launch.py`.

Arguments (name:=value): topics (the topics file), params (the learned
parameters file), odom_frame, base_frame, publish_tf. Everything else is a
ROS parameter of the node (see `terraslip node --help`).

Slip-compensated driving (between Nav2's controller_server and the drive
controller): compensate:=true, cmd_in (the desired twist, default
/cmd_vel_nav), cmd_out (the controller's input, default /cmd_vel),
cmd_in_stamped, cmd_out_stamped (TwistStamped), and the controller's
wheel_separation, wheel_separation_multiplier, max_speed, max_yaw_rate,
max_acceleration, max_yaw_acceleration (empty: the topics file's
separation, multiplier 1, no limit); thread_priority (the command
thread's SCHED_FIFO priority, empty: 50, 0: normal priority).
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

# The controller's settings passed on only when given (empty: default).
CONTROLLER = ["wheel_separation", "wheel_separation_multiplier", "max_speed", "max_yaw_rate",
              "max_acceleration", "max_yaw_acceleration"]


def node(context):
    get = lambda name: LaunchConfiguration(name).perform(context)  # noqa: E731
    truth = lambda name: get(name).lower() in ("true", "1", "yes")  # noqa: E731
    parameters = {
        "odom_frame": get("odom_frame"),
        "base_frame": get("base_frame"),
        "publish_tf": truth("publish_tf"),
        "compensate": truth("compensate"),
        "cmd_in_stamped": truth("cmd_in_stamped"),
        "cmd_out_stamped": truth("cmd_out_stamped"),
    }
    for name in CONTROLLER:
        if get(name):
            parameters[name] = float(get(name))
    if get("thread_priority"):
        parameters["thread_priority"] = int(get("thread_priority"))
    return [Node(
        package="terraslip",
        executable="node",
        name="terraslip",
        arguments=["--topics", get("topics"), "--params", get("params")],
        parameters=[parameters],
        remappings=[("cmd_vel_nav", get("cmd_in")), ("cmd_vel", get("cmd_out"))],
        output="screen",
        # SIGINT, then SIGTERM after 10 s: the node saves its parameters.
        sigterm_timeout="10",
    )]


def generate_launch_description():
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
        DeclareLaunchArgument(
            "compensate", default_value="false",
            description="answer each twist on cmd_in with the slip-compensated command on cmd_out"),
        DeclareLaunchArgument("cmd_in", default_value="/cmd_vel_nav"),
        DeclareLaunchArgument("cmd_out", default_value="/cmd_vel"),
        DeclareLaunchArgument("cmd_in_stamped", default_value="false"),
        DeclareLaunchArgument("cmd_out_stamped", default_value="false"),
        *[DeclareLaunchArgument(name, default_value="",
                                description="the drive controller's (empty: default)")
          for name in CONTROLLER],
        DeclareLaunchArgument("thread_priority", default_value="",
                              description="the command thread's SCHED_FIFO priority (empty: 50)"),
        OpaqueFunction(function=node),
    ])
