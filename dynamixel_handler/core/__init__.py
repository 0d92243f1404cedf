"""The handler's rooms, one job each; ``handler.Handler`` composes them."""
