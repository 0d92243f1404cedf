"""The loop's overlap of wire and work, and commands written between loops.

Running flat out, the node leaves each loop's last read on the wire while it publishes the previous
states and takes the next commands; at lower rates it writes the first command of a period at once
instead of at the next loop. These tests check what a user relies on meanwhile: a read in flight is
never mixed up with another transaction, values set after a read went out are never overwritten by
its older data, every command reaches the servos in order and the last one stays, and a command
between loops does not wait for the next loop.
"""
from __future__ import annotations

import struct
import time

import pytest

from dynamixel_handler.bus import DynamixelBus
from dynamixel_handler.bus.ops import Read
from dynamixel_handler.config import defaults, validate
from dynamixel_handler.core.handler import Handler
from dynamixel_handler.sim import VirtualBus
from dynamixel_handler_msgs.msg import DxlCommandsX

from support.rig import BASE_PARAMS, FAST_SYNC_READ, SYNC_READ, SYNC_WRITE, XM430, Rig

GOAL_POSITION, PRESENT_POSITION, OPERATING_MODE = 116, 132, 11  # X series (e-Manual)
X_DEG = 360 / 4096


def goals_written(entries, address: int = GOAL_POSITION) -> list[tuple[float, dict[int, int]]]:
    """(time, {id: value}) of every 4-byte sync write at ``address``, in wire order."""
    out = []
    for e in entries:
        if e.instruction != SYNC_WRITE or e.address != address:
            continue
        prm, length = e.params, e.length
        out.append((e.time, {prm[k]: struct.unpack_from("<i", prm, k + 1)[0] for k in range(4, len(prm), 1 + length)}))
    return out


# ============================================================================ the bus
@pytest.fixture
def timed_bus():
    """Four X servos on a virtual bus with wire timing (1 Mbps), and our bus opened on it: a 16 ms
    adapter and three retries, so a reply a busy host delays is still the reply these tests wait for
    (they judge the order of transactions, not the host's speed)."""
    sim = VirtualBus({i: XM430 for i in range(1, 5)}, baudrate=1_000_000)
    path = sim.start()
    bus = DynamixelBus(path, 1_000_000, latency_timer_ms=16.0, retry_num=3)
    bus.open()
    yield sim, bus
    bus.close()
    sim.close()


def test_a_read_left_on_the_wire_is_gathered_before_any_other_transaction(timed_bus):
    sim, bus = timed_bus
    for i in range(1, 5):
        sim.servo(i).write("goal_position", 1000 + i)
    read = bus.start_sync_read(GOAL_POSITION, 4, [1, 2, 3, 4], protocol=2)
    assert not read.done and bus.inflight_eta is not None and bus.inflight_eta > time.monotonic() - 0.001
    # a unicast read issued while the sync read is on the wire: it must get its own reply, and the
    # sync read must keep all four of its replies (the input flush before a packet would drop them)
    mode = bus.execute(Read(2, OPERATING_MODE, 1, protocol=2)).value
    assert read.done and bus.inflight_eta is None
    assert mode == bytes([3])
    assert {i: int.from_bytes(d, "little") for i, d in read.result().items()} == {i: 1000 + i for i in range(1, 5)}
    assert read.result() is read.result()  # gathered once
    names = [e.name for e in sim.log]
    assert names[-2:] == ["sync_read", "read"]
    assert bus.stats.timeouts == 0 and bus.stats.discarded_bytes == 0


def test_a_read_in_flight_with_a_silent_servo_still_returns_the_others(timed_bus):
    sim, bus = timed_bus
    sim.servo(3).silent = True
    read = bus.start_sync_read(PRESENT_POSITION, 4, [1, 2, 3, 4], protocol=2)
    assert sorted(read.result()) == [1, 2, 4]
    assert bus.inflight_eta is None


def test_host_values_set_after_a_read_went_out_are_not_overwritten_by_it(timed_bus):
    sim, bus = timed_bus
    config = validate({**defaults(), "device_name": sim.path, "init/servo_auto_search.max_id": 4,
                       "pub_ratio/goal": 1, "pub_ratio/status": 1})
    handler = Handler(bus, config)
    handler.start()
    report = handler.steps.begin_step()
    handler.steps.send_step(report)                  # reads the goal group: goal position 2048 everywhere
    assert bus.inflight_eta is not None        # the last read is still on the wire
    assert handler.core.write_item(1, "goal_position", 3000)
    handler.steps.finish_step(report)
    assert handler.table.value("goal_position", 1) == 3000  # newer than the read: kept
    assert handler.table.value("goal_position", 2) == 2048  # from the read
    assert sim.servo(1).read("goal_position") == 3000
    handler.step()                             # the next read sees the servo's register
    assert handler.table.value("goal_position", 1) == 3000


def test_goals_built_ahead_go_out_with_later_values_and_without_removed_servos(timed_bus):
    """Flat out, the node builds the goal packets while the previous read is on the wire; a value
    that comes after that still wins, a servo removed meanwhile is not written, nothing is lost."""
    sim, bus = timed_bus
    config = validate({**defaults(), "device_name": sim.path, "init/servo_auto_search.max_id": 4,
                       "pub_ratio/present.position": 1})
    handler = Handler(bus, config)
    handler.start()

    def overlapped(before: dict, after: dict | None = None, remove: int | None = None) -> list[dict[int, int]]:
        """One loop as the node runs it flat out; the goal positions that reached the wire."""
        report = handler.steps.begin_step()
        handler.steps.send_step(report)               # a read left on the wire
        following = handler.steps.begin_step()
        for item, values in before.items():
            handler.pending.put(item, values)
        handler.steps.encode_writes()                 # built while the read is on the wire
        assert handler.writes.writes_ready and bus.inflight_eta is not None
        for item, values in (after or {}).items():
            handler.pending.put(item, values)   # came later
        if remove is not None:  # as a remove_id command taken before the step's writes
            handler.core.remove_servo(remove)
        handler.steps.prepare(following)
        sim.clear_log()
        handler.steps.send_writes(following)
        handler.steps.send_writes(following)          # sent once only
        handler.steps.finish_step(report)
        bus.execute(Read(1, OPERATING_MODE, 1, protocol=2)).value          # answered only after the servos took the writes
        return [w for _, w in goals_written(sim.log)]

    # a servo removed after the packet was built is left out of it
    assert overlapped({"goal_position": {1: 1001, 2: 1002, 3: 1003, 4: 1004}},
                      remove=4) == [{1: 1001, 2: 1002, 3: 1003}]
    assert sim.servo(4).read("goal_position") != 1004
    # a later value of the same item wins, other items go in their own write
    assert overlapped({"goal_position": {1: 2001, 2: 2002, 3: 2003}, "goal_current": {2: 50}},
                      after={"goal_position": {1: 2111}}) == [{1: 2111, 2: 2002, 3: 2003}]
    current = [e for e in sim.log if e.instruction == SYNC_WRITE and e.address == 102]
    assert [e.ids for e in current] == [(2,)]
    assert [sim.servo(i).read("goal_position") for i in (1, 2, 3)] == [2111, 2002, 2003]
    assert sim.servo(2).read("goal_current") == 50

    # a loop that fails after taking the goals (its report dropped) loses none of them
    report = handler.steps.begin_step()
    handler.steps.send_step(report)
    handler.pending.put("goal_position", {2: 3002})
    handler.steps.encode_writes()
    assert handler.writes.writes_ready and not handler.pending
    handler.steps.finish_step(report)                 # the loop is given up here; the next one:
    sim.clear_log()
    handler.step()
    bus.execute(Read(1, OPERATING_MODE, 1, protocol=2)).value
    assert [w for _, w in goals_written(sim.log)] == [{2: 3002}]
    assert sim.servo(2).read("goal_position") == 3002 and not handler.writes.writes_ready


# ============================================================================ the node, flat out
def test_flat_out_every_command_reaches_the_wire_in_order_and_the_last_one_stays():
    """loop_rate 2000 on a timed 1 Mbps bus of 6 servos: every loop overruns its period, so each
    loop's read is left on the wire while the previous states go out and the next commands come in."""
    ids = list(range(1, 7))
    bench = Rig({i: XM430 for i in ids}, "loop_rate:=2000", "baudrate:=1000000", "method/fast_read:=true",
                "pub_ratio/present.current:=1", "pub_ratio/present.velocity:=1", "pub_ratio/present.position:=1",
                "pub_ratio/status:=50", "pub_ratio/goal:=50", "mode_change_interval_sec:=0.0",
                before_start=lambda sim: sim.set_baudrate(1_000_000), base=BASE_PARAMS, state_topics=True)
    try:
        bench.sim.baudrate = 1_000_000            # wire timing from now on (the scan ran untimed)
        pub = bench.node.create_publisher(DxlCommandsX, "/dynamixel/commands/x", 100)
        bench.wait(lambda: pub.get_subscription_count() > 0, what="the node subscribing")
        start = time.monotonic()
        sent: list[float] = []
        msg = DxlCommandsX()
        msg.position_control.id_list = ids
        seen = 0
        while len(sent) < 300 and time.monotonic() - start < 30:
            n = len(bench.topics["states"])
            if n == seen:                          # one command per state message, as a controller would
                time.sleep(0.0002)
                continue
            seen = n
            deg = 10.0 + 0.05 * len(sent)          # increasing: the wire order must follow
            sent.append(deg)
            msg.position_control.position_deg = [deg + 0.01 * i for i in ids]
            pub.publish(msg)
        assert len(sent) == 300, f"only {len(sent)} states in 30 s"
        last = {i: 2048 + round((sent[-1] + 0.01 * i) / X_DEG) for i in ids}
        bench.wait(lambda: all(bench.sim.servo(i).read("goal_position") == last[i] for i in ids), timeout=10,
                   what="the last command in every servo")
        writes = goals_written(bench.sim.log)
        for i in ids:
            values = [w[i] for _, w in writes if i in w]
            assert values == sorted(values), f"ID {i}: goals went out of order"
            assert len(values) > 0.5 * len(sent), f"ID {i}: {len(values)} goal writes for {len(sent)} commands"
        # states kept coming with every servo's present position, and their stamps only move forward
        states = [m for m in bench.topics["states"].since(start)]
        assert len(states) >= 300
        stamps = [m.stamp.sec + 1e-9 * m.stamp.nanosec for m in states]
        assert stamps == sorted(stamps)
        assert all(list(m.present.id_list) == ids and len(m.present.position_deg) == len(ids) for m in states)
        assert bench.node_proc.proc.poll() is None
    finally:
        code = bench.close()
    assert code == 0
    assert "Traceback" not in bench.output


# ============================================================================ between loops
def _second_goal_written(bench, pub, msg) -> tuple[float, list, list]:
    """Publish a goal of 40° to ID 1 after one of 30°, wait until it is on the wire; (when it was
    published, the goal writes, the bus log), both goals checked to be written in order."""
    msg.position_control.position_deg = [40.0]
    sent_at = time.monotonic()
    pub.publish(msg)
    bench.wait(lambda: bench.sim.servo(1).read("goal_position") == 2048 + round(40.0 / X_DEG), timeout=5,
               what="the second goal on the wire")
    log = list(bench.sim.log)
    writes = goals_written(log)
    assert [w[1] for _, w in writes] == [2048 + round(30.0 / X_DEG), 2048 + round(40.0 / X_DEG)]
    return sent_at, writes, log


def test_a_command_between_loops_is_written_at_once_and_a_second_waits_for_the_loop():
    """loop_rate 2: the first command of a period goes to the wire when it arrives, not at the next
    loop; a second one in the same period goes out with the next loop (at most one extra write)."""
    bench = Rig({1: XM430}, "loop_rate:=2", "pub_ratio/present.position:=1", "pub_ratio/status:=0",
                "pub_ratio/goal:=0", base=BASE_PARAMS, state_topics=True)
    try:
        pub = bench.node.create_publisher(DxlCommandsX, "/dynamixel/commands/x", 10)
        bench.wait(lambda: pub.get_subscription_count() > 0, what="the node subscribing")
        bench.wait_new(["debug"], 2, timeout=5)
        for _ in range(20):  # a loop just ran (about 0.5 s to the next) and read the servo, so the next reads it too
            bench.wait_new(["debug"], 1, timeout=5)
            if all(bench.debug[-1].status.ping):
                break
        time.sleep(0.05)
        bench.sim.clear_log()
        msg = DxlCommandsX()
        msg.position_control.id_list = [1]
        msg.position_control.position_deg = [30.0]
        pub.publish(msg)
        time.sleep(0.1)
        _, writes, log = _second_goal_written(bench, pub, msg)
        reads = [e.time for e in log if e.instruction in (SYNC_READ, FAST_SYNC_READ)]
        first, second = writes[0][0], writes[1][0]
        # the first went out on its own, well before the next loop's read; the second with that loop
        next_read = min(t for t in reads if t > first)
        assert next_read - first > 0.15, f"first goal {next_read - first:.3f} s before the next loop's read"
        assert first < second <= next_read + 0.01
        assert not [t for t in reads if first < t < second - 0.01], "the second goal waited more than one loop"
    finally:
        code = bench.close()
    assert code == 0


def test_a_command_during_a_read_goes_out_after_its_replies_and_the_next_one_still_at_once():
    """loop_rate 2, twelve servos at 57600 bps with wire timing (a read of ~40 ms): a command that
    arrives while the loop's read is on the wire is written as soon as the replies are in, and does
    not use up the period's one write between loops: a second command shortly after is written at
    once too, not with the next loop half a second later."""
    ids = list(range(1, 13))
    bench = Rig({i: XM430 for i in ids}, "loop_rate:=2", "pub_ratio/present.position:=1", "pub_ratio/status:=0",
                "pub_ratio/goal:=0", "pub_ratio/present.current:=0", "pub_ratio/present.velocity:=0",
                sim_kwargs={"wire_timing": True})
    try:
        pub = bench.node.create_publisher(DxlCommandsX, "/dynamixel/commands/x", 10)
        bench.wait(lambda: pub.get_subscription_count() > 0, what="the node subscribing")
        bench.wait_new(["states"], 2, timeout=10)
        msg = DxlCommandsX()
        msg.position_control.id_list = [1]
        bench.sim.clear_log()
        deadline = time.monotonic() + 5
        while not [e for e in list(bench.sim.log) if e.instruction == SYNC_READ] and time.monotonic() < deadline:
            time.sleep(0.0005)
        read_at = time.monotonic()
        msg.position_control.position_deg = [30.0]
        pub.publish(msg)                                 # while the read is on the wire
        bench.wait_new(["states"], 1, timeout=5)         # that loop is over
        time.sleep(0.05)
        second_at, writes, log = _second_goal_written(bench, pub, msg)
        reads = [e.time for e in log if e.instruction == SYNC_READ]
        assert writes[0][0] - read_at < 0.2, "the command from during the read waited for more than the read"
        assert writes[1][0] - second_at < 0.2, f"the second command waited {writes[1][0] - second_at:.3f} s"
        # no loop's read came between the second command and its write (on a busy host the test
        # may publish it only after the next loop began: that loop's read is not a wait)
        assert not [t for t in reads if second_at < t < writes[1][0]], "the second command waited for a loop"
    finally:
        code = bench.close()
    assert code == 0


def test_flat_out_survives_wire_faults_and_an_unplugged_adapter(tmp_path):
    """The overlapped loop meets CRC errors, noise, truncated replies and a device that vanishes with
    a read on the wire: it logs, keeps publishing, reconnects, and commands still reach the servos."""
    from dynamixel_handler_msgs.msg import DynamixelControlXPosition

    from support.rig import X540, P, Rig, X

    rig = Rig({1: X, 2: X540, 3: P}, "loop_rate:=2000", "pub_ratio/status:=5", "pub_ratio/error:=5",
              "verbose_ratio:=500", sim_kwargs={"link": str(tmp_path / "ttyDXL")})
    rig.sim.baudrate = 57600  # wire timing: every loop overruns its 0.5 ms period

    def still_publishing(n: int = 30) -> None:
        start = len(rig.debug)
        rig.wait(lambda: len(rig.debug) >= start + n, timeout=15, what="the loop still publishing")

    def command_lands(deg: float) -> None:
        rig.publish("/dynamixel/command/x/position_control",
                    DynamixelControlXPosition(id_list=[1, 2], position_deg=[deg, -deg]))
        rig.wait(lambda: rig.sim.servo(1).read("goal_position") == 2048 + round(deg / X_DEG)
                 and rig.sim.servo(2).read("goal_position") == 2048 - round(deg / X_DEG),
                 timeout=15, what=f"goal {deg} deg on the wire")

    try:
        still_publishing()
        rig.sim.crc_error_rate = 0.1
        still_publishing(60)
        command_lands(20.0)
        rig.sim.crc_error_rate = 0.0
        for _ in range(5):
            rig.sim.inject_garbage(40)
            rig.sim.truncate_next(2)
            time.sleep(0.05)
        still_publishing()
        command_lands(-30.0)
        mark = rig.mark()
        rig.sim.vanish()
        rig.wait_log("is gone", since=mark, timeout=10)
        time.sleep(0.3)
        rig.sim.reappear()
        rig.wait_log("reconnected", since=mark, timeout=10)
        rig.wait(lambda: all(rig.debug_of(i)["ping"] for i in (1, 2, 3)), timeout=10, what="every servo answering again")
        command_lands(45.0)
        still_publishing()
        assert rig.node_proc.proc.poll() is None
    finally:
        assert rig.close() == 0
    assert "Traceback" not in rig.output


def test_commands_reach_the_core_only_through_its_command_interface(timed_bus):
    """Commander is written against core.api.ServoAccess: given a view of the handler that offers
    nothing else, a control command still switches the mode and moves the servos, and bad IDs
    are refused with a line."""
    import logging

    from dynamixel_handler.commands import Commander
    from dynamixel_handler.core.api import ServoAccess

    sim, bus = timed_bus
    config = validate({**defaults(), "device_name": sim.path, "init/servo_auto_search.max_id": 4,
                       "mode_change_interval_sec": 0.0})
    handler = Handler(bus, config)
    handler.start()
    assert isinstance(handler, ServoAccess)
    allowed = {n for n in vars(ServoAccess) if not n.startswith("_")} | set(ServoAccess.__annotations__)

    class OnlyTheInterface:
        def __getattr__(self, name: str):
            if name not in allowed:
                raise AttributeError(f"Commander used {name}, which is not in ServoAccess")
            return getattr(handler, name)

    lines: list[str] = []
    handler.log = logging.getLogger("interface_test")
    handler.log.addHandler(type("H", (logging.Handler,), {"emit": lambda self, r: lines.append(r.getMessage())})())
    commander = Commander(OnlyTheInterface())  # type: ignore[arg-type]
    handler.attach(commander)  # by who builds it, as the node does
    commander.control("X", "extended_position_control", [1, 2, 77], {"position_deg": [90.0, -90.0, 0.0]})
    commander.status([3], {"mode": ["velocity"]})
    handler.step()
    assert sim.servo(1).read("operating_mode") == 4 and sim.servo(2).read("operating_mode") == 4
    assert sim.servo(1).read("goal_position") == 2048 + 1024 and sim.servo(2).read("goal_position") == 2048 - 1024
    assert sim.servo(3).read("operating_mode") == 1
    assert any("ID 77 is not handled" in line for line in lines), lines
