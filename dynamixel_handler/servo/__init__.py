"""A servo's state, ROS-free: the table of handled servos and what was read, its health and error
state, its settings of the ``servos`` block, their targets against its model and a snapshot of them."""
