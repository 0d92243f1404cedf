"""The pan-tilt example under ros2_control: dynamixel_handler on the bus, the URDF's topic-based
hardware interface talking to it, and joint_state_broadcaster + joint_trajectory_controller.

    ros2 launch examples/robot/pan_tilt_launch.py device_name:=/dev/ttyUSB0
    ros2 launch examples/robot/pan_tilt_launch.py use_ros2_control:=false   # the handler's own action only

Needs (from the ROS distribution): ros2_control, ros2_controllers, topic_based_hardware_interfaces
(joint_state_topic_hardware_interface), robot_state_publisher. The handler's joint_states and
joint_commands are remapped to /dynamixel/joint_states and /dynamixel/joint_commands, the topics
pan_tilt.urdf names; /joint_states is then joint_state_broadcaster's (or, with
use_ros2_control:=false, the handler's own).
"""
from pathlib import Path

from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

from launch import LaunchDescription

HERE = Path(__file__).resolve().parent


def _nodes(context):
    device = LaunchConfiguration("device_name").perform(context)
    with_control = LaunchConfiguration("use_ros2_control").perform(context).lower() in ("true", "1")
    urdf = (HERE / "pan_tilt.urdf").read_text()
    config = Path(FindPackageShare("dynamixel_handler").perform(context)) / "config" / "config_dynamixel_handler.yaml"
    remaps = [("joint_states", "/dynamixel/joint_states"), ("joint_commands", "/dynamixel/joint_commands")]
    nodes = [
        Node(package="dynamixel_handler", executable="dynamixel_handler", name="dynamixel_handler", output="screen",
             parameters=[str(config), str(HERE / "handler.yaml"), {"device_name": device}],
             remappings=remaps if with_control else []),
        Node(package="robot_state_publisher", executable="robot_state_publisher",
             parameters=[{"robot_description": urdf}]),
    ]
    if with_control:
        nodes.append(Node(package="controller_manager", executable="ros2_control_node", output="screen",
                          parameters=[{"robot_description": urdf}, str(HERE / "controllers.yaml")]))
        for controller in ("joint_state_broadcaster", "joint_trajectory_controller"):
            nodes.append(Node(package="controller_manager", executable="spawner", arguments=[controller]))
    return nodes


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription([
        DeclareLaunchArgument("device_name", default_value="/dev/ttyUSB0",
                              description="the adapter: a tty, a /dev/serial/by-id link or serial:<USB serial number>"),
        DeclareLaunchArgument("use_ros2_control", default_value="true",
                              description="false: no ros2_control; the handler's follow_joint_trajectory serves MoveIt"),
        OpaqueFunction(function=_nodes),
    ])
