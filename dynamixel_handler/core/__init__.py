"""The handler's rooms, one job each; ``dynamixel_handler.loop.Handler`` composes them."""
