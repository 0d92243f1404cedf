"""Start the dynamixel_handler node with the installed parameter file.

    ros2 launch dynamixel_handler dynamixel_handler_launch.py
    ros2 launch dynamixel_handler dynamixel_handler_launch.py name_space:=arm device_name:=/dev/ttyUSB1 \
        params_file:=/path/to/my_robot.yaml

Arguments: ``name_space`` (default none: topics are /dynamixel/...; ``namespace`` is the same
argument under another name and wins when both are given), ``params_file`` (default the installed
config/config_dynamixel_handler.yaml), ``device_name`` (empty: keep the file's).
``launch_dynamixel_handler.py`` is this file under the original handler's name.
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

PACKAGE = "dynamixel_handler"
EXECUTABLE = "dynamixel_handler"
CONFIG = "config_dynamixel_handler.yaml"


def _handler(context):
    """The node; device_name overrides the file only when given (launch has no 'optional' parameter)."""
    parameters = [LaunchConfiguration("params_file")]
    device = LaunchConfiguration("device_name").perform(context)
    if device:
        parameters.append({"device_name": device})
    return [Node(package=PACKAGE, executable=EXECUTABLE, name="dynamixel_handler",
                 namespace=LaunchConfiguration("namespace"), parameters=parameters, output="screen",
                 emulate_tty=True)]


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription([
        DeclareLaunchArgument("name_space", default_value="",
                              description="namespace of the node and its topics (the original handler's name)"),
        DeclareLaunchArgument("namespace", default_value=LaunchConfiguration("name_space"),
                              description="the same as name_space"),
        DeclareLaunchArgument("params_file",
                              default_value=PathJoinSubstitution([FindPackageShare(PACKAGE), "config", CONFIG]),
                              description="parameter file of the node"),
        DeclareLaunchArgument("device_name", default_value="",
                              description="serial device, e.g. /dev/ttyUSB0 (empty: the one in params_file)"),
        OpaqueFunction(function=_handler),
    ])
