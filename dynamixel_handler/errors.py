"""Exceptions shared across the ROS-free core (the bus layer has its own ``bus.BusError``)."""
from __future__ import annotations


class ConfigError(ValueError):
    """A parameter value the node cannot start with; the message says which and why."""


class StartupError(RuntimeError):
    """Start-up cannot go on; the message says what, why and what to do."""


class Interrupted(StartupError):
    """Start-up stopped because the node was asked to exit (SIGINT/SIGTERM): not a failure."""


__all__ = ["ConfigError", "Interrupted", "StartupError"]
