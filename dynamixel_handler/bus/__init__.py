"""The serial bus layer: the only part of the product that talks to ``dynamixel_sdk``.

``DynamixelBus`` opens the adapter, pings/scans, reads and writes single servos and
groups (sync/bulk, plain and fast), retries per ``dyn_comm/*`` and keeps counters.
Packets are built and parsed by :mod:`.protocol`, which works around the defects of
``dynamixel_sdk`` 4.1.0 listed in :mod:`.core`. ROS-free.
"""
from .core import BusStats, DynamixelBus, GroupRead, PreparedWrite
from .errors import BusError
from .port import DYNAMIXEL_BAUDRATES

__all__ = ["BusError", "BusStats", "DynamixelBus", "DYNAMIXEL_BAUDRATES", "GroupRead", "PreparedWrite"]
