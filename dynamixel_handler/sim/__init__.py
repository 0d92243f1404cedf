"""A virtual Dynamixel bus: Protocol 2.0 and 1.0 servos served on a pseudo-terminal.

Tests, demos and users' CI open it with the real ``dynamixel_sdk`` like a USB adapter::

    from dynamixel_handler.sim import VirtualBus
    with VirtualBus(servos={1: 1020, 2: 1120}) as bus:   # XM430-W350, XM540-W270, as unboxed
        port = PortHandler(bus.path)
        port.openPort(); port.setBaudRate(57600)           # they answer only at their own baud rate
        ...
        bus.servo(1).read("present_position")

Two servos given one ID collide on the wire as on hardware (``collision``), and Protocol 1.0
servos (AX, RX, DX, EX and MX with its 1.0 firmware: ``protocol1``) can share the line.

Also runnable as a command: ``dynamixel_handler_sim`` (or ``python -m dynamixel_handler.sim``);
docs/virtual_bus.md describes what the servos do and every option.
"""

from .bus import LoggedInstruction, VirtualBus
from .servo import VirtualServo

DEFAULT_SERVOS = {1: 1020, 2: 1120, 3: 2020, 4: 54024}
"""The default bus: XM430-W350, XM540-W270, PH54-200-S500-R, H54-200-S500-R (old PRO)."""

__all__ = ["VirtualBus", "VirtualServo", "LoggedInstruction", "DEFAULT_SERVOS"]
