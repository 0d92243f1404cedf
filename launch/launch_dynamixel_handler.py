"""The original handler's name for dynamixel_handler_launch.py: the same arguments, the same node.

    ros2 launch dynamixel_handler launch_dynamixel_handler.py name_space:=arm
"""
from launch import LaunchDescription
from launch.actions import IncludeLaunchDescription
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import PathJoinSubstitution, ThisLaunchFileDir

TARGET = "dynamixel_handler_launch.py"


def generate_launch_description() -> LaunchDescription:
    return LaunchDescription([
        IncludeLaunchDescription(PythonLaunchDescriptionSource(PathJoinSubstitution([ThisLaunchFileDir(), TARGET]))),
    ])
