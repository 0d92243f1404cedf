"""The real dynamixel_sdk as the tests' host, with a reply wait that suits the virtual bus."""
from __future__ import annotations

from dynamixel_sdk import PortHandler

#: the least time [ms] the test host waits for a reply. The SDK's own wait (two 16 ms latency
#: periods plus the wire time) is meant for a USB adapter; here the replies come from the simulator's
#: thread in the test process, which a loaded machine can hold back longer than that.
MIN_REPLY_WAIT_MS = 250.0


class PatientPort(PortHandler):
    """The SDK's PortHandler, waiting at least ``MIN_REPLY_WAIT_MS`` for a reply. A reply the
    simulator never sends still ends in COMM_RX_TIMEOUT, only later."""

    def setPacketTimeout(self, packet_length):
        super().setPacketTimeout(packet_length)
        self.packet_timeout = max(self.packet_timeout, MIN_REPLY_WAIT_MS)
