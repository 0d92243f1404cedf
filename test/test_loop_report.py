"""The loop's statistics line (the original handler's text and levels), what it says while the
device is gone, and a slow bus: the loop reports the rate it can reach, and the bus watchdog
follows the measured loop instead of tripping on every servo."""
from __future__ import annotations

import re

from support.rig import Rig, X

LINE = re.compile(r"\[(INFO|WARN|ERROR)\].*time=\d+\.\d\dms/loop\(\d+\.\d\dms/read\), success= *(\d+)%\(full= *(\d+)%\)$")


def _lines(rig: Rig, mark: int = 0) -> list[re.Match]:
    return [m for m in map(LINE.search, rig.node_proc.lines[mark:]) if m]


def test_statistics_line_levels_and_device_gone(tmp_path):
    link = str(tmp_path / "ttyDXL")
    rig = Rig({1: X, 2: X, 3: X}, "verbose_ratio:=20", "dyn_comm/retry_num:=0", sim_kwargs={"link": link})
    try:
        # every servo answering: a line at 100 % is INFO (on a busy host a late reply can make a
        # window 99 %, a WARN: wait for a full one rather than take the first)
        rig.wait(lambda: any(m.group(2) == "100" and m.group(3) == "100" for m in _lines(rig)),
                 what="a statistics line at 100 %", timeout=30)
        assert all(m.group(1) == "INFO" for m in _lines(rig) if m.group(2) == "100" and m.group(3) == "100"), \
            [m.group(0) for m in _lines(rig)]

        # two servos of three silent: every read misses them (full 0 %) -> ERROR
        rig.sim.set_silent(2, True)
        rig.sim.set_silent(3, True)
        mark = rig.mark()
        rig.wait(lambda: any(m.group(1) == "ERROR" and int(m.group(3)) < 80 for m in _lines(rig, mark)),
                 what="an ERROR statistics line with full < 80 %")
        rig.sim.set_silent(2, False)
        rig.sim.set_silent(3, False)

        rig.sim.vanish()
        mark = rig.mark()
        line = rig.wait_log("time=", "device", "gone since", "s ago", since=mark, timeout=20)
        assert "[ERROR]" in line and "success=" not in line, line
        rig.sim.reappear()
        rig.node_proc.wait_for("is back: reconnected", timeout=10)
    finally:
        assert rig.close() == 0


def test_the_statistics_line_comes_every_10_s_even_with_verbose_ratio_0():
    rig = Rig({1: X}, "verbose_ratio:=0")  # the original handler never prints it with 0
    try:
        rig.wait(lambda: len(rig.debug) > 5, what="some loops")
        mark = rig.mark()
        line = rig.wait_log("time=", "ms/loop", "success=", since=mark, timeout=15)
        assert LINE.search(line) and "[INFO]" in line, line
    finally:
        assert rig.close() == 0


def test_a_slow_bus_warns_once_with_the_rate_it_reaches_and_its_watchdog_follows_the_loop():
    ids = {i: X for i in range(1, 9)}
    # a 16 ms adapter (the factory setting): a reply a busy host delays is not taken for silence
    rig = Rig(ids, "baudrate:=9600", "loop_rate:=100", "default/bus_watchdog:=100.0", "latency_timer:=16",
              "pub_ratio/present.current:=1", "pub_ratio/present.velocity:=1",
              sim_kwargs={"wire_timing": True, "baudrate": 9600})
    try:
        # velocity mode: the bus watchdog is armed
        from dynamixel_handler_msgs.msg import DynamixelControlXVelocity
        rig.publish("/dynamixel/command/x/velocity_control",
                    DynamixelControlXVelocity(id_list=list(ids), velocity_deg_s=[10.0] * len(ids)))
        line = rig.wait_log("loop_rate 100 Hz cannot be held", "loops/s", "bps", timeout=30)
        assert "9600 bps" in line and "8 servo(s)" in line, line
        rig.wait(lambda: all(rig.sim.servo(i).read("operating_mode") == 1 for i in ids), timeout=30,
                 what="velocity mode")
        # the watchdog covers three loops of the slow bus, far above the 100 ms asked for
        rig.wait(lambda: all(rig.sim.servo(i).read("bus_watchdog") * 20 > 3 * 100 for i in ids), timeout=30,
                 what="bus watchdogs longer than three slow loops")
        rig.fresh_states(count=10, timeout=60)
        assert all(rig.sim.servo(i).read("bus_watchdog") > 0 for i in ids)  # none tripped (-1)
        # nor during the burst of 8 mode changes (each servo armed once the burst is done)
        assert "bus watchdog tripped" not in rig.output and "had tripped" not in rig.output
        assert rig.output.count("cannot be held") == 1
    finally:
        assert rig.close() == 0
