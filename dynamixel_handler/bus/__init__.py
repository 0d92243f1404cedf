"""The serial bus layer: the only part of the product that talks to ``dynamixel_sdk``.

``DynamixelBus`` opens the adapter and executes instructions given as values (:mod:`.ops`:
pings, reads and writes of single servos and groups, sync/bulk, plain and fast), each giving a
``Result``; it scans, retries per ``dyn_comm/*`` and keeps counters.
Packets are built and parsed by :mod:`..protocol.host`, which works around the defects of
``dynamixel_sdk`` 4.1.0 listed in :mod:`.core`. ``ServoBus`` (:mod:`.api`) is the interface the
handler uses, which ``DynamixelBus`` and the dummy-servo bus both implement. ROS-free.
"""
from . import ops
from .api import ServoBus, dummy_ids
from .core import DynamixelBus
from .errors import BusError
from .group_read import GroupRead
from .port import DYNAMIXEL_BAUDRATES, LINE_BAUDRATES
from .result import Failure, Result
from .stats import BusStats
from .writes import PreparedWrite

__all__ = ["BusError", "BusStats", "DynamixelBus", "DYNAMIXEL_BAUDRATES", "Failure", "GroupRead", "LINE_BAUDRATES",
           "PreparedWrite", "Result", "ServoBus", "dummy_ids", "ops"]
