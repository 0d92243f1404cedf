"""Run the baud rate unification tool once with the installed config_unify_baudrate.yaml.

    ros2 launch dynamixel_handler dynamixel_unify_baudrate_launch.py device_name:=/dev/ttyUSB0 \
        target_baudrate:=1000000

Arguments: ``params_file`` (default the installed config/config_unify_baudrate.yaml), and
``device_name`` / ``target_baudrate`` overriding the file when not empty. The tool exits when
done; its exit code says whether every servo answers at the target rate.
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

PACKAGE = "dynamixel_handler"
EXECUTABLE = "dynamixel_unify_baudrate"
CONFIG = "config_unify_baudrate.yaml"


def _tool(context):
    parameters = [LaunchConfiguration("params_file")]
    device = LaunchConfiguration("device_name").perform(context)
    target = LaunchConfiguration("target_baudrate").perform(context)
    if device:
        parameters.append({"device_name": device})
    if target:
        parameters.append({"target_baudrate": int(target)})
    return [Node(package=PACKAGE, executable=EXECUTABLE, name="dynamixel_unify_baudrate",
                 parameters=parameters, output="screen", emulate_tty=True)]


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription([
        DeclareLaunchArgument("params_file",
                              default_value=PathJoinSubstitution([FindPackageShare(PACKAGE), "config", CONFIG]),
                              description="parameter file of the tool"),
        DeclareLaunchArgument("device_name", default_value="",
                              description="serial device (empty: the one in params_file)"),
        DeclareLaunchArgument("target_baudrate", default_value="",
                              description="baud rate to set every servo to (empty: the one in params_file)"),
        OpaqueFunction(function=_tool),
    ])
