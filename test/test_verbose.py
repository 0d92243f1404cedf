"""verbose/* parameters: the log lines a user turns on to see what the handler reads."""
from __future__ import annotations

from support.rig import X540, Rig, X


def test_raw_reads_failures_and_hardware_errors_are_logged_when_asked():
    rig = Rig({1: X, 2: X540}, "verbose/read_present.raw:=true", "verbose/read_status.err:=true",
              "pub_ratio/error:=5", "pub_ratio/status:=5", "max_log_width:=1")
    try:
        rig.node_proc.wait_for(lambda s: "read present present_position: 1=" in s)
        rig.node_proc.wait_for(lambda s: s.strip().startswith("2="))  # one ID a line with max_log_width 1
        rig.sim.set_hardware_error(2, 0x04)
        rig.node_proc.wait_for("ID 2: hardware error overheating (0x04)")
        rig.sim.set_silent(1, True)
        rig.node_proc.wait_for("no answer from IDs [1]")
        rig.sim.set_silent(1, False)
    finally:
        assert rig.close() == 0
    assert rig.node_proc.output.count("ID 2: hardware error overheating") == 1  # once, not every read


def test_quiet_by_default():
    rig = Rig({1: X})
    try:
        rig.wait(lambda: len(rig.debug) > 20, what="some loops")
    finally:
        assert rig.close() == 0
    assert "read present" not in rig.node_proc.output
