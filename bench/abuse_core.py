"""Core cases of the abuse benchmark: log floods, management-command floods, a bus watchdog time the
loop cannot keep, a vanished and returning adapter. Run by ``bench/abuse.py`` (``run(VirtualBus,
seconds)``) or on its own:

    source env.sh && python bench/abuse_core.py [--seconds 5]

Cases (the real node on the virtual bus, commands through the real topics from another process):
  crc30           5 servos, 30 % of the replies with a corrupted CRC
  mode_100hz      status commands switching IDs 1 and 2 between velocity and position at 100 Hz
                  (mode_change_interval_sec 1: deferred)
  eeprom_100hz    limit commands alternating ID 1's velocity limit at 100 Hz (EEPROM writes coalesced)
  membership_200  shortcut remove_id / add_id of ID 2 alternating at 200 Hz
  reboot_100hz    shortcut reboot of ID 1 at 100 Hz
  watchdog_20ms   extra bus_watchdog_ms 20 to ID 3 (velocity mode) and -5 to ID 4 at 2 Hz
  stats_2000      loop_rate 2000, verbose_ratio 300: statistics lines a second
  vanish          no_response_id_auto_remove_count 3; the adapter vanishes for 2 s and comes back
Per case: messages sent, loop rate and longest gap (from the virtual bus's log of the node's reads),
log lines a second (all, and the three most frequent causes), bus watchdog trips, RSS before/after,
CPU; for vanish the servos removed and the servos read after the adapter is back.
"""
from __future__ import annotations

import collections
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import abuse  # noqa: E402
from common import cpu_seconds  # noqa: E402

X = abuse.X
SERVOS = {1: X, 2: X, 3: X, 4: X, 5: X}
_MESSAGE = re.compile(r"^\[\w+\] \[[\d.]+\] \[[^\]]*\]: (.*)$")
_NUMBER = re.compile(r"\d+(?:\.\d+)?")


# ---------------------------------------------------------------------------- publisher processes
def publish(kind: str, rate: float, seconds: float) -> None:
    """Runs in a process of its own: one kind of command traffic at ``rate`` Hz; prints how many."""
    import rclpy
    from rclpy.node import Node

    from dynamixel_handler_msgs.msg import DynamixelExtra, DynamixelLimit, DynamixelShortcut, DynamixelStatus
    rclpy.init()
    node = Node(f"abuse_core_{kind}")
    topics = {"mode": ("/dynamixel/command/status", DynamixelStatus), "eeprom": ("/dynamixel/command/limit", DynamixelLimit),
              "membership": ("/dynamixel/shortcut", DynamixelShortcut), "reboot": ("/dynamixel/shortcut", DynamixelShortcut),
              "watchdog": ("/dynamixel/command/extra", DynamixelExtra)}
    topic, typ = topics[kind]
    pub = node.create_publisher(typ, topic, 100)
    end = time.monotonic() + 10
    while pub.get_subscription_count() == 0 and time.monotonic() < end:
        time.sleep(0.05)

    def message(k: int):
        if kind == "mode":
            return DynamixelStatus(id_list=[1, 2], mode=["velocity" if k % 2 else "position"] * 2)
        if kind == "eeprom":
            return DynamixelLimit(id_list=[1], velocity_limit_deg_s=[100.0 + 10 * (k % 2)])
        if kind == "membership":
            return DynamixelShortcut(command="remove_id" if k % 2 else "add_id", id_list=[2])
        if kind == "reboot":
            return DynamixelShortcut(command="reboot", id_list=[1])
        return DynamixelExtra(id_list=[3, 4], bus_watchdog_ms=[20.0, -5.0])
    print(abuse.paced(lambda k: pub.publish(message(k)), rate, seconds), flush=True)
    node.destroy_node()
    rclpy.shutdown()


def _publisher(kind: str, rate: float, seconds: float) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, __file__, "--publish", kind, str(rate), str(seconds)],
                            stdout=subprocess.PIPE, text=True, preexec_fn=abuse._die_with_parent)


# ---------------------------------------------------------------------------- figures
def _causes(lines: list[str], seconds: float, top: int = 3) -> str:
    """Log lines a second, all and per cause (the message with its numbers masked), the top ones."""
    counts: collections.Counter[str] = collections.Counter()
    for line in lines:
        m = _MESSAGE.match(line)
        counts[_NUMBER.sub("#", m.group(1) if m else line)[:48]] += 1
    head = f"log={len(lines) / seconds:6.1f} lines/s"
    return head + "".join(f" | {n / seconds:5.1f}/s '{cause}'" for cause, n in counts.most_common(top))


def _last_read(sim, since: float = 0.0) -> list[int]:
    """The IDs of the node's last read of the present position (after ``since``, monotonic)."""
    for e in reversed(sim.log):
        if e.time < since:
            break
        if e.name.endswith("sync_read") and e.address is not None and e.address <= abuse.PRESENT_POSITION < e.address + (e.length or 0):
            return sorted(e.ids)
    return []


def _trips(lines: list[str]) -> int:
    return sum("bus watchdog tripped" in line or "bus watchdog had tripped" in line for line in lines)


class Case:
    """One measured window of a running node: figures from its start to ``done``."""

    def __init__(self, node: abuse.Node) -> None:
        self.node = node
        self.rss = node.resources()
        self.cpu = cpu_seconds(node.proc.pid)
        self.mark = len(node.lines)
        self.t0 = time.monotonic()

    def done(self, name: str, sim, sent: int | None = None, extra: str = "") -> None:
        t1 = time.monotonic()
        node = self.node
        rate, gap = abuse.loop_figures(sim, self.t0, t1)
        lines = [line for _, line in node.lines[self.mark:]]
        cpu = 100 * (cpu_seconds(node.proc.pid) - self.cpu) / (t1 - self.t0)
        sent_s = f"sent={sent:6d} " if sent is not None else ""
        print(f"{name:15s} {sent_s}loop={rate:6.1f} Hz gap={gap:7.1f} ms trips={_trips(lines)} cpu={cpu:.0f}% "
              f"rss {self.rss[0]} -> {node.resources()[0]} MiB {extra}", flush=True)
        print(f"{'':15s} {_causes(lines, t1 - self.t0)}", flush=True)


def _with_publisher(name: str, node: abuse.Node, sim, kind: str, rate: float, seconds: float,
                    extra=lambda: "") -> None:
    proc = _publisher(kind, rate, seconds)
    time.sleep(1.5)  # the publisher finds the node
    case = Case(node)
    sent = int((proc.communicate(timeout=seconds + 60)[0] or "0").split()[-1])
    case.done(name, sim, sent, extra())


# ---------------------------------------------------------------------------- cases
def commands(VirtualBus, s: float) -> None:
    sim = VirtualBus(servos=SERVOS, wire_timing=False)
    node = abuse.Node(sim, "init/servo_auto_search.max_id:=5", "init/expected_servo_num:=5", "verbose_ratio:=300")
    node.wait_for("handled")
    time.sleep(2.0)
    abuse.velocity_mode([3, 4, 5])  # their bus watchdog is armed, so a stalled loop trips it
    time.sleep(1.0)

    case = Case(node)
    sim.crc_error_rate = 0.3
    time.sleep(s)
    sim.crc_error_rate = 0.0
    case.done("crc30", sim)
    time.sleep(2.0)

    _with_publisher("mode_100hz", node, sim, "mode", 100.0, s)
    time.sleep(2.0)
    _with_publisher("eeprom_100hz", node, sim, "eeprom", 100.0, s)
    time.sleep(2.0)
    _with_publisher("membership_200", node, sim, "membership", 200.0, s,
                    lambda: f"IDs read at the end: {_last_read(sim)}")
    time.sleep(2.0)
    _with_publisher("reboot_100hz", node, sim, "reboot", 100.0, s,
                    lambda: f"reboots of ID 1: {sum(e.name == 'reboot' for e in sim.log if e.ids == (1,))}")
    time.sleep(2.0)
    _with_publisher("watchdog_20ms", node, sim, "watchdog", 2.0, s,
                    lambda: f"watchdog ID 3 {sim.servo(3).read('bus_watchdog') * 20} ms, "
                            f"ID 4 {sim.servo(4).read('bus_watchdog') * 20} ms")
    code, exit_s = node.stop()
    print(f"{'exit':15s} rc={code} {exit_s:.2f} s", flush=True)
    sim.stop()


def stats_2000(VirtualBus, s: float) -> None:
    sim = VirtualBus(servos={1: X}, wire_timing=False)
    node = abuse.Node(sim, "init/servo_auto_search.max_id:=1", "loop_rate:=2000", "verbose_ratio:=300")
    node.wait_for("handled")
    time.sleep(2.0)
    case = Case(node)
    time.sleep(s)
    stats = sum("ms/loop(" in line for _, line in node.lines[case.mark:])
    case.done("stats_2000", sim, extra=f"statistics lines: {stats / (time.monotonic() - case.t0):.1f}/s")
    node.stop()
    sim.stop()


def vanish(VirtualBus, s: float) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        sim = VirtualBus(servos=SERVOS, wire_timing=False, link=str(Path(tmp) / "ttyDXL"))
        node = abuse.Node(sim, "init/servo_auto_search.max_id:=5", "init/expected_servo_num:=5", "verbose_ratio:=300",
                          "no_response_id_auto_remove_count:=3")
        node.wait_for("handled")
        time.sleep(2.0)
        case = Case(node)
        sim.vanish()
        time.sleep(2.0)
        sim.reappear()
        back = time.monotonic()
        time.sleep(max(3.0, s - 2.0))
        lines = [line for _, line in node.lines[case.mark:]]
        removed = sum("removed" in line for line in lines)
        case.done("vanish", sim, extra=f"'removed' lines {removed}, servos read after reappear {_last_read(sim, back)}"
                                       f" (back {time.monotonic() - back:.1f} s)")
        node.stop()
        sim.stop()


def run(VirtualBus, seconds: float) -> None:
    commands(VirtualBus, seconds)
    stats_2000(VirtualBus, seconds)
    vanish(VirtualBus, seconds)


def main() -> int:
    return abuse.door_main(__doc__, run, publish, 5.0)


if __name__ == "__main__":
    sys.exit(main())
