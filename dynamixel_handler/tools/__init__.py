"""Stand-alone tools for a Dynamixel bus (baud rate unification). The logic is ROS-free
(:mod:`.baudrate`); :mod:`.unify_baudrate` is its ROS node."""
