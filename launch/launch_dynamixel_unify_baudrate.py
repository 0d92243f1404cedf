"""The original handler's name for dynamixel_unify_baudrate_launch.py: the same arguments, the same tool.

    ros2 launch dynamixel_handler launch_dynamixel_unify_baudrate.py device_name:=/dev/ttyUSB0 target_baudrate:=1000000
"""
from launch import LaunchDescription
from launch.actions import IncludeLaunchDescription
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import PathJoinSubstitution, ThisLaunchFileDir

TARGET = "dynamixel_unify_baudrate_launch.py"


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription([
        IncludeLaunchDescription(PythonLaunchDescriptionSource(PathJoinSubstitution([ThisLaunchFileDir(), TARGET]))),
    ])
