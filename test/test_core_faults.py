"""A servo that stops answering mid-run: ping false, the others keep being read every loop, removal
after no_response_id_auto_remove_count loops, and back again with the shortcut add_id."""
from __future__ import annotations

import math

from test_core_states import assert_unit

from dynamixel_handler.core.handler import RECHECK_LOOPS
from dynamixel_handler_msgs.msg import DynamixelShortcut

from support.handler_bench import capture_log, handler_on_virtual_bus
from support.rig import BASE_PARAMS, FAST_SYNC_READ, FOUR_SERVOS, PING, READ, SYNC_READ, XM430, Rig
from support.servo_access import attached

REMOVE_AFTER = 10  # unanswered requests
SILENT_ID = 3      # the PH54


def _ids(msg) -> list[int]:
    return list(msg.status.id_list)


def _of(msg, dxl_id: int, field: str):
    k = _ids(msg).index(dxl_id)
    return msg.status.ping[k] if field == "ping" else getattr(msg, field).present[k]


def test_silent_servo_goes_ping_false_is_removed_after_the_count_and_comes_back_with_add_id():
    bench = Rig(FOUR_SERVOS, "pub_ratio/present.position:=1", "pub_ratio/status:=1",
                f"no_response_id_auto_remove_count:={REMOVE_AFTER}", base=BASE_PARAMS, state_topics=True)
    try:
        # ID 1 turns at a constant velocity, so its present position changes every loop
        x = bench.sim.servo(1)
        x.write("operating_mode", 1)
        x.write("goal_velocity", 100)
        debug = bench.topics["debug"]
        bench.wait(lambda: (m := debug.last()) is not None and m.velocity_deg_s.present[0] > 100, what="ID 1 turning")

        start = len(debug)
        bench.sim.set_silent(SILENT_ID, True)
        bench.wait(lambda: SILENT_ID not in _ids(debug.last()), timeout=15, what=f"ID {SILENT_ID} removed")
        bench.wait_new(["debug"], count=20)
        messages = debug.all()[start:]

        # ping false first, in the loop after it went silent, while the others stay true
        silent = [m for m in messages if SILENT_ID in _ids(m) and not _of(m, SILENT_ID, "ping")]
        assert silent, "no message with ping false before the removal"
        assert all(_of(m, i, "ping") for m in messages for i in (1, 2, 4))
        # removed after REMOVE_AFTER requests without reply: the failed read, then a ping every
        # RECHECK_LOOPS loops, so about (REMOVE_AFTER - 1) x RECHECK_LOOPS loops with ping false (one
        # message per loop, give or take a few lost in transit), not REMOVE_AFTER loops
        assert (REMOVE_AFTER - 4) * RECHECK_LOOPS <= len(silent) <= REMOVE_AFTER * RECHECK_LOOPS + 2, \
            f"{len(silent)} loops with ping false before the removal, want ~{(REMOVE_AFTER - 1) * RECHECK_LOOPS}"
        after = messages[messages.index(silent[0]):]
        assert all(_ids(m) == [1, 2, 4] for m in after[len(silent):])
        bench.node_proc.wait_for(f"ID {SILENT_ID}: no response (ping false)")
        bench.node_proc.wait_for(f"ID {SILENT_ID}: no response {REMOVE_AFTER} times in a row: removed")

        # the others kept being read every loop: ID 1's position changed from message to message
        positions = [_of(m, 1, "position_deg") for m in after]
        changed = sum(1 for a, b in zip(positions, positions[1:]) if a != b)
        assert changed >= len(positions) - 3, f"ID 1 position changed in {changed} of {len(positions) - 1} loops"
        assert not any(math.isnan(_of(m, 4, "position_deg")) for m in after)

        # ...and the silent servo did not hold up every loop: after the first failed read it is only
        # pinged now and then, never read again (reads of ID 1 vs instructions to ID 3)
        t_silent = next(e.time for e in reversed(bench.transactions())
                        if SILENT_ID in (e.ids or ()) and e.instruction != PING)  # its last (failed) read
        later = [e for e in bench.transactions() if e.time > t_silent]
        to_silent = [e for e in later if SILENT_ID in (e.ids or ())]
        reads_of_1 = [e for e in later if e.address == 132 and 1 in (e.ids or ())]
        assert all(e.instruction == PING for e in to_silent), [e.name for e in to_silent]
        assert len(to_silent) <= 1 + len(reads_of_1) // 5

        # it answers again and is handled again after the shortcut add_id
        bench.sim.set_silent(SILENT_ID, False)
        bench.publish("/dynamixel/shortcut", DynamixelShortcut(command="add_id", id_list=[SILENT_ID]))
        bench.wait(lambda: _ids(debug.last()) == [1, 2, 3, 4] and _of(debug.last(), SILENT_ID, "ping")
                   and not math.isnan(_of(debug.last(), SILENT_ID, "position_deg")),
                   timeout=10, what=f"ID {SILENT_ID} handled and read again")
        status = bench.topics["state/status"]
        bench.wait(lambda: (m := status.last()) is not None and list(m.id_list) == [1, 2, 3, 4] and all(m.ping),
                   what="/dynamixel/state/status with every ID and ping true")
        assert abs(_of(debug.last(), SILENT_ID, "position_deg")
                   - bench.sim.servo(SILENT_ID).read("present_position") * 180 / 501923) < 0.01
    finally:
        code = bench.close()
    assert code == 0


def test_a_short_silence_is_survived_without_removal():
    # no auto removal (the default): a servo silent for a while answers again and is read again
    bench = Rig({1: 1020, 4: 54024}, "pub_ratio/present.position:=1", "pub_ratio/status:=1", base=BASE_PARAMS, state_topics=True)
    try:
        debug = bench.topics["debug"]
        bench.sim.set_silent(4, True)
        bench.wait(lambda: not _of(debug.last(), 4, "ping"), what="ping false")
        bench.wait_new(["debug"], count=30)
        assert _ids(debug.last()) == [1, 4]  # never removed with the count at 0
        bench.sim.set_silent(4, False)
        bench.wait(lambda: _of(debug.last(), 4, "ping"), what="ping true again (re-pinged on its own)")
        bench.node_proc.wait_for("ID 4: answers again")
        bench.sim.servo(4).pin("present_position", 25096)
        bench.wait(lambda: abs(_of(debug.last(), 4, "position_deg") - 25096 * 180 / 250961) < 1e-6,
                   what="ID 4 read again")
    finally:
        code = bench.close()
    assert code == 0


def test_fast_read_reads_every_servo_and_the_old_pro_with_plain_sync_read():
    # method/fast_read: X and P answer Fast Sync Read; the old Pro "-R" firmware has no such
    # instruction, so it must be read with a plain Sync Read instead of going ping false
    # a 16 ms adapter: a reply a loaded host delays is still heard (this test is not about silences)
    b = Rig(FOUR_SERVOS, "method/fast_read:=true", "pub_ratio/status:=1", "pub_ratio/present.position:=1",
            "latency_timer:=16", base=BASE_PARAMS, state_topics=True)
    try:
        pins = {1: 1000, 2: 3000, 3: -250000, 4: 123456}
        for dxl_id, pulses in pins.items():
            b.sim.servo(dxl_id).pin("present_position", pulses)
        b.wait_new(["debug"], count=30)
        msg = b.topics["debug"].last()
        assert list(msg.status.ping) == [True] * 4
        for k, dxl_id in enumerate(msg.status.id_list):
            assert_unit(msg.position_deg.present[k], b.sim.servo(dxl_id), "present_position",
                        f"present position of ID {dxl_id}")
        recent = b.topics["debug"].all()[-20:]
        assert all(all(m.status.ping) for m in recent)
        assert "no response" not in b.output
        b.node_proc.wait_for("ID 4: no answer to Fast Sync Read, read with Sync Read from now on")
        reads = [e for e in b.transactions()[-200:] if e.instruction in (FAST_SYNC_READ, SYNC_READ)]
        # IDs 1 and 3 stay on the fast read: a plain one only completes a fast read that a late reply
        # (a loaded host) cut short, now and then, never from now on
        fast = [e for e in reads if (1 in e.ids or 3 in e.ids) and e.instruction == FAST_SYNC_READ]
        plain = [e for e in reads if (1 in e.ids or 3 in e.ids) and e.instruction == SYNC_READ]
        assert fast and len(plain) <= len(fast) // 10, (len(fast), len(plain))
        for dxl_id in (1, 2, 3):
            assert f"ID {dxl_id}: no answer to Fast Sync Read" not in b.output
        assert {e.instruction for e in reads if 4 in e.ids} == {SYNC_READ}
    finally:
        b.close()


def test_a_servo_that_breaks_the_fast_read_chain_costs_the_others_nothing_lasting():
    """In a Fast Sync Read the servos answer in a chain: one that stops answering silences those
    after it for that read. They must not be taken for firmware without Fast Sync Read (read with
    the slower plain Sync Read from then on); a servo that really lacks it is still found."""
    config = {"method/fast_read": True, "pub_ratio/present.position": 1}
    # patient: a reply a busy host delays is not taken for the silence this test makes
    with handler_on_virtual_bus({i: XM430 for i in range(1, 5)}, config, patient=True) as (sim, handler):

        def reads() -> dict[int, set[int]]:
            """Read instructions of the last loop that addressed each ID."""
            sim.clear_log()
            handler.step()
            out: dict[int, set[int]] = {}
            for e in sim.log:
                if e.instruction in (FAST_SYNC_READ, SYNC_READ):
                    for i in e.ids:
                        out.setdefault(i, set()).add(e.instruction)
            return out

        assert reads() == {i: {FAST_SYNC_READ} for i in range(1, 5)}
        sim.servo(1).silent = True       # first in the chain: nobody answers the fast read
        for _ in range(3):
            handler.step()
        assert list(handler.table.ping) == [False, True, True, True]
        assert reads() == {i: {FAST_SYNC_READ} for i in (2, 3, 4)}
        sim.servo(1).silent = False
        for _ in range(12):              # pinged now and then while silent: back within 10 loops
            handler.step()
        assert list(handler.table.ping) == [True, True, True, True]

        sim.truncate_next(1)             # one garbled fast reply: ID 3 and 4 cut off once
        for _ in range(3):
            handler.step()
        assert reads() == {i: {FAST_SYNC_READ} for i in range(1, 5)}

        sim.servo(3).write("firmware_version", 40)  # below 45: this X answers only a plain Sync Read
        for _ in range(4):
            handler.step()
        found = reads()
        assert found[3] == {SYNC_READ}
        assert found[1] == found[2] == found[4] == {FAST_SYNC_READ}
        assert list(handler.table.ping) == [True, True, True, True]


def test_the_tables_positions_follow_servos_added_and_removed():
    """The loop finds where a read's servos sit in the table through a kept lookup: it must follow
    every change of the set of servos (a removed servo is skipped, a new one shifts the others)."""
    from dynamixel_handler.control_table import model_by_number
    from dynamixel_handler.servo.table import ServoTable

    table, xm430 = ServoTable(), model_by_number(1020)
    for dxl_id in (2, 4, 6):
        table.add(dxl_id, xm430)
    assert table.positions((2, 4, 6)).tolist() == [0, 1, 2]
    assert table.positions((6, 2)).tolist() == [2, 0]
    table.add(3, xm430)
    assert table.positions((2, 4, 6)).tolist() == [0, 2, 3]
    table.remove(4)
    assert table.positions((2, 4, 6)).tolist() == [0, 2]
    assert table.snapshot().positions((3, 6)).tolist() == [1, 2]
    assert not table.positions((2, 4, 6)).flags.writeable


def test_at_a_low_loop_rate_a_servo_that_missed_a_read_is_pinged_again_within_a_tenth_of_a_second():
    """At 100 Hz and above a servo that stopped answering is pinged every 10 loops; at lower rates
    every 0.1 s worth of loops (at least every loop), so a glitch at 2 Hz costs one read, not 5 s."""
    for loop_rate, loops_to_answer in ((2, 1), (50, 5), (100, 10), (1000, 10)):
        config = {"loop_rate": loop_rate, "pub_ratio/present.position": 1}
        # patient: on a loaded host the answering servo's reply must not be taken for silence
        with handler_on_virtual_bus({1: XM430, 2: XM430}, config, patient=True) as (sim, handler):
            while handler.figures().loop_count % RECHECK_LOOPS != 1:  # just after a ping round at every rate
                handler.step()
            sim.servo(1).silent = True
            handler.step()                  # the read that finds it silent
            assert list(handler.table.ping) == [False, True]
            sim.servo(1).silent = False
            sim.clear_log()
            loops = 0
            while not handler.table.ping[0] and loops < 2 * RECHECK_LOOPS:
                handler.step()
                loops += 1
            pings = [e for e in sim.log if e.instruction == PING and 1 in e.ids]
            assert handler.table.ping[0] and len(pings) == 1, (loop_rate, loops, len(pings))
            assert loops <= loops_to_answer, f"loop_rate {loop_rate}: answered after {loops} loops"
            handler.step()                  # and read with the others again
            reads = [e for e in sim.log if e.instruction in (SYNC_READ, FAST_SYNC_READ)]
            assert 1 in reads[-1].ids


def test_a_mode_change_or_eeprom_write_whose_torque_read_gets_no_answer_still_switches_the_torque_off_first():
    """The servo refuses an operating mode or EEPROM write while its torque is on. A torque read
    lost to a busy host must not be taken for torque off: the torque goes off all the same, the
    value is written, and the torque comes back as last read (on), holding where the servo is. A
    torque off whose reply is lost is no reason to stop: the servo may have taken it."""
    from dynamixel_handler.commands import Commander

    cases = [  # (replies lost, the command, the register and the value it must reach)
        (1, lambda c: c.control("X", "velocity_control", [1], {"velocity_deg_s": [0.0]}), "operating_mode", 1),
        # the torque off's reply lost too: the servo took it all the same, so the mode write goes through
        (2, lambda c: c.control("X", "velocity_control", [1], {"velocity_deg_s": [0.0]}), "operating_mode", 1),
        (2, lambda c: c.limit([1], {"temperature_limit_degc": [70.0]}), "temperature_limit", 70),  # item + torque read
    ]
    for lost, command, register, value in cases:
        config = {"dyn_comm/retry_num": 0, "mode_change_interval_sec": 0.0}
        # a 16 ms adapter: only the cut replies are lost, not one a loaded host delays
        with handler_on_virtual_bus({1: XM430}, config, retry_num=0, latency_timer_ms=16.0) as (sim, handler):
            handler.step()
            servo = sim.servo(1)
            assert servo.read("torque_enable") == 1 and servo.read(register) != value
            lines = capture_log(handler, f"torque_read_lost_{register}")
            commander = attached(Commander(handler))
            commander.warn = lines.append
            sim.clear_log()
            sim.truncate_next(lost)  # the next replies arrive cut in half: the last of them is the torque read's
            command(commander)
            handler.step()
            handler.step()
            torque_address = servo.model.item("torque_enable").address
            assert [e for e in sim.log if e.instruction == READ and e.address == torque_address]
            assert servo.read(register) == value, lines
            assert servo.read("torque_enable") == 1
            assert not [line for line in lines if "failed" in line], lines


def test_a_mode_change_the_bus_misses_is_read_back_or_tried_again_and_its_goals_are_written():
    """A mode change whose replies are lost (the write landed: read back, taken) or whose servo does
    not hear the bus for a while (tried again every MODE_RETRY_S with the goals that came with it)
    ends with the servo in the new mode and the command's goal written, not dropped."""
    import time

    from dynamixel_handler.commands import Commander
    from dynamixel_handler.core.requests import MODE_RETRY_S

    goal = round(30.0 / (0.229 * 6.0))  # 30 deg/s in X velocity units
    config = {"dyn_comm/retry_num": 0, "mode_change_interval_sec": 0.0}
    def commander_of(handler, name: str) -> tuple[Commander, list[str]]:
        """A commander whose warnings, and the handler's log lines, go to a list."""
        handler.step()
        lines = capture_log(handler, name)
        commander = attached(Commander(handler))
        commander.warn = lines.append
        return commander, lines

    with handler_on_virtual_bus({1: XM430}, config, retry_num=0, latency_timer_ms=16.0) as (sim, handler):
        servo = sim.servo(1)
        commander, lines = commander_of(handler, "mode_write_reply_lost")
        # the torque read's, the torque off's and the mode write's replies cut in half: all three landed
        sim.truncate_next(3)
        commander.control("X", "velocity_control", [1], {"velocity_deg_s": [30.0]})
        handler.step()
        handler.step()
        assert servo.read("operating_mode") == 1, lines
        assert servo.read("goal_velocity") == goal, lines
        assert servo.read("torque_enable") == 1
        assert not [line for line in lines if "failed" in line], lines

    with handler_on_virtual_bus({1: XM430}, config, retry_num=0) as (sim, handler):
        servo = sim.servo(1)
        commander, lines = commander_of(handler, "mode_change_unheard")
        sim.set_silent(1, True)
        commander.control("X", "velocity_control", [1], {"velocity_deg_s": [30.0]})
        handler.step()
        assert servo.read("operating_mode") == 3  # not heard: still in position mode
        assert any("mode change to 'velocity' failed" in line and "tried again" in line for line in lines), lines
        sim.set_silent(1, False)
        end = time.monotonic() + 5.0
        while time.monotonic() < end and servo.read("goal_velocity") != goal:
            time.sleep(MODE_RETRY_S / 5)
            handler.step()
        assert servo.read("operating_mode") == 1, lines
        assert servo.read("goal_velocity") == goal, lines
        assert servo.read("torque_enable") == 1
