"""The handler's life on the bus: start-up, one loop step, shutdown. ROS-free.

``Handler`` is composed of rooms with one job each (``dynamixel_handler/core``):

    state        HandlerState: the bus, the parameters, the servo table, each room's bookkeeping;
                 StepReport: what one loop step did
    servo_io     one servo at a time: read/write an item, its mode, torque on without a jump
    pacing       while bus watchdogs are armed: reads cut, mode changes spread over loops; a stop drops the rest
    read_plan    pub ratios -> the items due -> sync reads per control-table layout; replies stored
    write_batch  pending values -> one sync write per item, built ahead and sent in one go
    deferred     EEPROM writes spared and coalesced, mode changes asked for too soon, queued operations
    watchdog     the bus watchdog time from the loop period; arming, clearing, trips
    recovery     reboot, a vanished device reopened, silent servos marked and removed
    startup      scan, expected count, the set-up every servo gets (also add_id)
    requests     what commands may ask, checked: goals, a mode change, an error clear, a watchdog
    step         one loop step in four phases (prepare, send, complete, finish), read logs
    group_io     one item of many servos in one sync write or read per layout
    shutdown     the servos left as term/* say

``Handler.step()`` runs queued operations (torque, mode, reboot...), writes pending values in
grouped sync writes, reads what the ratios ask for this loop, and returns a ``StepReport`` that
says which groups were read. The ROS layer turns the table into messages.
"""
from __future__ import annotations

from .control_table import OPERATING_MODES
from .core.deferred import EEPROM_WRITE_INTERVAL_S
from .core.recovery import REBOOT_WAIT_S, RECONNECT_INTERVAL_S
from .core.requests import Requests
from .core.shutdown import Shutdown
from .core.state import StepReport
from .core.step import RECHECK_LOOPS, Step
from .core.watchdog import WATCHDOG_MAX_MS, WATCHDOG_MODES, WATCHDOG_TRIPPED
from .errors import Interrupted, StartupError


class Handler(Requests, Step, Shutdown):
    """Owns the servos of one bus: ``start()``, then ``step()`` (or its phases) every loop, then
    ``shutdown()``. Commands reach it as operations queued for the loop thread (``queue``) and as
    pending writes (``pending``)."""


def mode_value(name: str) -> int:
    return OPERATING_MODES[name]


__all__ = ["EEPROM_WRITE_INTERVAL_S", "Handler", "Interrupted", "RECHECK_LOOPS", "RECONNECT_INTERVAL_S", "REBOOT_WAIT_S",
           "StartupError", "StepReport", "WATCHDOG_MAX_MS", "WATCHDOG_MODES", "WATCHDOG_TRIPPED", "mode_value"]
