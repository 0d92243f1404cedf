"""``dynamixel_handler_setup``: set up Dynamixel servos from a terminal (what Dynamixel Wizard does,
over SSH on a headless robot). ROS-free: it imports no rclpy and works with no ROS running.

Verbs (``dynamixel_handler_setup --help``): scan, info, get, set, set-id, set-baud, set-mode,
assign-ids, reboot, factory-reset, backup, restore, monitor, plot, calibrate. Everything goes through the product's
bus layer (:class:`~dynamixel_handler.bus.DynamixelBus`, which locks the device while it is open)
and control tables (:mod:`dynamixel_handler.control_table`), so every model the handler knows is
known here too. Modules: ``cli`` (arguments, dispatch), ``port`` (open + lock), ``output``
(tables, plain text when piped, JSON), ``items`` (names and units), ``servo`` (one servo's reads
and checked writes), ``scan`` and ``protocol1`` (finding servos), ``verbs_*`` (the verbs),
``backup``, ``monitor`` and ``calibrate`` (with ``joints_file``, the file it writes).
"""
from __future__ import annotations

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """The command line entry point (exit code 0 done, 1 a servo or the bus failed, 2 bad arguments,
    130 interrupted)."""
    from .cli import main as run

    return run(argv)
