"""dynamixel_handler: drive a bus of ROBOTIS Dynamixel servos (X, P, Pro) through ROS 2 topics,
or from plain Python::

    from dynamixel_handler import Commander, DynamixelBus, Handler, Runner, ScanSettings, Settings

    bus = DynamixelBus("/dev/ttyUSB0", baudrate=1_000_000)
    handler = Handler(bus, Settings(scan=ScanSettings(min_id=1, max_id=4, expected=4)))
    ...                                   # see examples/plain_python.py

The package is layered so that only ``ros/`` imports rclpy and only ``bus`` imports
``dynamixel_sdk``; ``control_table`` holds facts, ``units`` converts, ``sim`` is a virtual bus.
The names below are imported when first used, so ``import dynamixel_handler`` stays cheap and
``dynamixel_handler.sim`` and the rest never pull in rclpy.
"""
from __future__ import annotations

TYPE_CHECKING = False  # as typing.TYPE_CHECKING (mypy reads it so), without importing typing at run time
if TYPE_CHECKING:
    from typing import Any

    from .bus import BusError, DynamixelBus
    from .commands import Commander, CommandPaths
    from .config import Config, ConfigError, validate
    from .core.handler import Handler, StepReport
    from .loop.runner import Hooks, Runner
    from .servo.settings import ServoSetting
    from .settings import (
        BusSettings,
        ExternalPortSettings,
        LogSettings,
        LoopSettings,
        Method,
        ReadRatios,
        ScanSettings,
        Settings,
        StartValues,
        TermSettings,
        TrajectorySettings,
    )
    from .sim import VirtualBus

__version__ = "0.1.0"

#: name -> the module (relative to the package) it is imported from when first used
_LAZY = {
    "Handler": "core.handler", "StepReport": "core.handler", "Runner": "loop.runner", "Hooks": "loop.runner", "Commander": "commands",
    "CommandPaths": "commands",
    "DynamixelBus": "bus", "BusError": "bus", "VirtualBus": "sim",
    "Config": "config", "ConfigError": "config", "validate": "config", "ServoSetting": "servo.settings",
    **{name: "settings" for name in ("Settings", "BusSettings", "ScanSettings", "StartValues", "TermSettings",
                                     "LoopSettings", "ReadRatios", "Method", "LogSettings", "ExternalPortSettings",
                                     "TrajectorySettings")},
}

__all__ = [
    "BusError", "BusSettings", "CommandPaths", "Commander", "Config", "ConfigError", "DynamixelBus", "ExternalPortSettings",
    "Handler", "Hooks", "LogSettings", "LoopSettings", "Method", "ReadRatios", "Runner", "ScanSettings", "ServoSetting",
    "Settings", "StartValues", "StepReport", "TermSettings", "TrajectorySettings", "VirtualBus", "validate",
]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'dynamixel_handler' has no attribute '{name}'")
    import importlib  # here: the package's own import stays as light as it can be

    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value  # looked up once
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
