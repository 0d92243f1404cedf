"""dynamixel_handler: drive a bus of ROBOTIS Dynamixel servos (X, P, Pro) through ROS 2 topics.

The package is layered so that only ``ros/`` imports rclpy and only ``bus`` imports
``dynamixel_sdk``; ``control_table`` holds facts, ``units`` converts, ``sim`` is a virtual bus.
"""

__version__ = "0.1.0"
