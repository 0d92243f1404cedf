"""Hardware safety and parity with the original C++ handler, through the real node on the virtual
bus: what a servo does must never surprise its owner. Register values, reboot counts and writes
are read from the simulator, never from the node.

X scales from the e-Manual: 4096 pulses a turn, 0 deg at 2048, 0.229 rpm (1.374 deg/s) per
velocity LSB, 214.577 rev/min^2 (21.4577 deg/s^2) per profile acceleration LSB.
"""
from __future__ import annotations

import signal
import time

from dynamixel_handler.sim import VirtualBus
from dynamixel_handler_msgs.msg import (
    DynamixelControlPPosition,
    DynamixelControlXCurrent,
    DynamixelControlXExtendedPosition,
    DynamixelControlXPosition,
    DynamixelControlXVelocity,
    DynamixelLimit,
    DynamixelShortcut,
    DynamixelStatus,
)

from support.rig import PRO, X540, P, Rig, X
from support.ros import NodeProcess, node_command

X_DEG, X_ZERO, X_TURN = 360.0 / 4096, 2048, 4096
X_DEG_S = 1.374
X_DEG_SS = 21.4577
OVERLOAD = 0x20
TEMPERATURE_LIMIT_X = 31  # e-Manual address (X, EEPROM)
XL430 = 1060  # XL430-W250: no current sensor


def x_pos(deg: float) -> int:
    return X_ZERO + round(deg / X_DEG)


def reg(rig: Rig, dxl_id: int, item: str) -> int:
    return rig.sim.servo(dxl_id).read(item)


def wait_reg(rig: Rig, dxl_id: int, item: str, value: int, timeout: float = 10.0) -> None:
    rig.wait(lambda: reg(rig, dxl_id, item) == value, timeout=timeout,
             what=f"ID {dxl_id} {item} == {value} (holds {reg(rig, dxl_id, item)})")


def velocity(rig: Rig, dxl_id: int, deg_s: float) -> None:
    rig.publish("/dynamixel/command/x/velocity_control", DynamixelControlXVelocity(id_list=[dxl_id], velocity_deg_s=[deg_s]))
    wait_reg(rig, dxl_id, "operating_mode", 1)
    wait_reg(rig, dxl_id, "goal_velocity", round(deg_s / X_DEG_S))


def reboots(rig: Rig) -> list[int]:
    return [i for e in rig.sim.log if e.name == "reboot" for i in e.ids]


# ------------------------------------------------------------------------------ 1. error clear
def test_clear_error_reboots_only_the_servos_in_error():
    rig = Rig({1: X, 2: X540, 3: X}, "clear_error_interval_sec:=0.0", "pub_ratio/error:=2", "pub_ratio/status:=2")
    try:
        profile = reg(rig, 1, "profile_velocity")
        assert profile > 0
        rig.sim.set_hardware_error(2, OVERLOAD)
        rig.wait(lambda: rig.debug_of(2)["error"], what="ID 2 error published")
        rig.sim.clear_log()
        rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="CE", id_list=[254]))  # every servo
        wait_reg(rig, 2, "hardware_error_status", 0)
        # status.error on a healthy servo: nothing to clear, no reboot, torque left as it is
        rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="TOFF", id_list=[3]))
        wait_reg(rig, 3, "torque_enable", 0)
        rig.publish("/dynamixel/command/status", DynamixelStatus(id_list=[1, 3], error=[DynamixelStatus.CLEAR_KEEP_ROT] * 2))
        rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="clear_error", id_list=[1]))
        rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[3], position_deg=[10.0]))
        wait_reg(rig, 3, "goal_position", x_pos(10.0))  # the commands after them were handled
        assert reboots(rig) == [2]
        assert reg(rig, 3, "torque_enable") == 0
        assert reg(rig, 1, "profile_velocity") == profile  # RAM untouched: no reboot
        rig.wait_log("ID 2: hardware error cleared")
        assert rig.output.count("hardware error cleared") == 1
    finally:
        assert rig.close() == 0


# ------------------------------------------------------------------------------ 2. mode change deferred
def test_a_mode_change_too_soon_is_deferred_with_its_goal_and_the_latest_wins():
    # an interval long enough that the next commands arrive within it on a loaded host too
    rig = Rig({1: X}, "mode_change_interval_sec:=4.0")
    try:
        rig.publish("/dynamixel/command/x/position_control",
                    DynamixelControlXPosition(id_list=[1], position_deg=[0.0], profile_vel_deg_s=[200.0]))
        profile = round(200.0 / X_DEG_S)
        wait_reg(rig, 1, "profile_velocity", profile)
        velocity(rig, 1, 30.0)  # the first change: at once
        assert reg(rig, 1, "profile_velocity") == profile  # written back after the mode write reset it
        mark = rig.mark()
        rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[1], position_deg=[45.0]))
        rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[1], position_deg=[60.0]))
        rig.wait_log("ID 1", "mode_change_interval_sec=4s ago: applied in", since=mark)
        assert reg(rig, 1, "operating_mode") == 1  # not yet
        wait_reg(rig, 1, "operating_mode", 3, timeout=15)
        wait_reg(rig, 1, "goal_position", x_pos(60.0))  # the latest request, with its goal
        rig.wait(lambda: abs(rig.debug_of(1)["position"] - 60.0) < 0.5, timeout=15, what="ID 1 at 60 deg")
        assert reg(rig, 1, "torque_enable") == 1
        assert reg(rig, 1, "profile_velocity") == profile
        assert rig.log_since(mark).count("operating mode -> position") == 1
    finally:
        assert rig.close() == 0


# ------------------------------------------------------------------------------ 3. watchdog modes
def test_the_bus_watchdog_is_armed_only_in_velocity_current_and_pwm_modes():
    rig = Rig({1: X, 2: X540}, "default/bus_watchdog:=100.0", "mode_change_interval_sec:=0.0")
    try:
        time.sleep(0.2)  # the loop ran: arming happens at its first steps
        assert [reg(rig, i, "bus_watchdog") for i in (1, 2)] == [0, 0]  # position mode
        velocity(rig, 1, 20.0)
        wait_reg(rig, 1, "bus_watchdog", 5)
        rig.publish("/dynamixel/command/x/current_control", DynamixelControlXCurrent(id_list=[2], current_ma=[0.0]))
        wait_reg(rig, 2, "operating_mode", 0)
        wait_reg(rig, 2, "bus_watchdog", 5)
        rig.publish("/dynamixel/command/x/extended_position_control",
                    DynamixelControlXExtendedPosition(id_list=[1], position_deg=[30.0]))
        wait_reg(rig, 1, "operating_mode", 4)
        wait_reg(rig, 1, "bus_watchdog", 0)
        wait_reg(rig, 1, "goal_position", x_pos(30.0))
    finally:
        assert rig.close() == 0


# ------------------------------------------------------------------------------ 4. shutdown
def test_shutdown_without_torque_off_stops_a_moving_position_servo_where_it_is():
    rig = Rig({1: X, 2: X540}, "term/torque_auto_disable:=false", "mode_change_interval_sec:=0.0")
    try:
        velocity(rig, 2, 40.0)
        rig.publish("/dynamixel/command/x/position_control",
                    DynamixelControlXPosition(id_list=[1], position_deg=[170.0], profile_vel_deg_s=[10.0]))
        rig.wait(lambda: reg(rig, 1, "present_position") > x_pos(3.0), what="ID 1 on its way")
    finally:
        at_term = reg(rig, 1, "present_position")
        code = rig.node_proc.stop(signal.SIGTERM)
        rig.close()
    assert code == 0
    stopped = [reg(rig, i, "present_position") for i in (1, 2)]
    time.sleep(0.5)
    assert [reg(rig, i, "present_position") for i in (1, 2)] == stopped  # both hold where they stopped
    # far from the goal it was heading for: stopped within the shutdown's time (at 10 deg/s, 2 s at most
    # on a loaded host) of where it was when the signal came
    assert stopped[0] < min(at_term + round(20.0 / X_DEG), x_pos(90.0)), (at_term, stopped[0])
    assert [reg(rig, i, "torque_enable") for i in (1, 2)] == [1, 1]  # and keep holding
    assert reg(rig, 1, "goal_position") == stopped[0]
    assert reg(rig, 2, "goal_velocity") == 0


# ------------------------------------------------------------------------------ 5, 6. EEPROM writes
def test_an_eeprom_write_brings_torque_back_safely_and_spares_the_eeprom():
    rig = Rig({1: X})
    try:
        velocity(rig, 1, 60.0)
        rig.wait(lambda: reg(rig, 1, "present_velocity") > 0, what="ID 1 turning")
        # the limit topic's first message (its value already so: nothing written), acknowledged, so
        # that the burst below reaches the node within one EEPROM write interval
        rig.publish("/dynamixel/command/limit", DynamixelLimit(id_list=[1], temperature_limit_degc=[
            float(reg(rig, 1, "temperature_limit"))]))
        rig.sim.clear_log()
        for degc in (70.0, 71.0, 70.0, 71.0, 72.0):  # a burst of alternating values
            rig.publish("/dynamixel/command/limit", DynamixelLimit(id_list=[1], temperature_limit_degc=[degc]))
        wait_reg(rig, 1, "temperature_limit", 72, timeout=5)
        rig.publish("/dynamixel/command/limit", DynamixelLimit(id_list=[1], temperature_limit_degc=[72.0]))  # the same
        time.sleep(1.5)
        writes = [e for e in rig.sim.log if e.name in ("write", "sync_write", "bulk_write") and e.address == TEMPERATURE_LIMIT_X]
        assert 1 <= len(writes) <= 2, writes  # the first at once, the latest one after the interval
        # torque came back on without resuming the old velocity goal: the servo holds
        assert reg(rig, 1, "torque_enable") == 1
        assert reg(rig, 1, "goal_velocity") == 0
        rig.wait(lambda: reg(rig, 1, "present_velocity") == 0, what="ID 1 stopped")
    finally:
        assert rig.close() == 0


# ------------------------------------------------------------------------------ 7. rotation alone
def test_rotation_without_position_means_whole_turns_from_zero():
    rig = Rig({1: X}, "mode_change_interval_sec:=0.0")
    try:
        rig.publish("/dynamixel/command/x/extended_position_control",
                    DynamixelControlXExtendedPosition(id_list=[1], position_deg=[90.0]))
        wait_reg(rig, 1, "goal_position", x_pos(90.0))
        rig.publish("/dynamixel/command/x/extended_position_control",
                    DynamixelControlXExtendedPosition(id_list=[1], rotation=[1.0]))
        wait_reg(rig, 1, "goal_position", x_pos(360.0))
        rig.publish("/dynamixel/command/x/extended_position_control",
                    DynamixelControlXExtendedPosition(id_list=[1], rotation=[-2.0]))
        wait_reg(rig, 1, "goal_position", x_pos(-720.0))
    finally:
        assert rig.close() == 0


# ------------------------------------------------------------------------------ 9. expected count
def test_more_servos_than_expected_ends_start_up():
    with VirtualBus(servos={1: X, 2: X, 3: X540}) as sim:
        proc = NodeProcess(node_command(f"device_name:={sim.path}", "latency_timer:=1", "init/servo_auto_search.max_id:=5",
                                        "init/expected_servo_num:=2", "verbose_ratio:=0"))
        code = proc.wait_exit(30)
        assert code == 1, proc.output
        assert "handling 3 servo(s) [1, 2, 3]" in proc.output and "init/expected_servo_num is 2" in proc.output
        assert all(sim.servo(i).read("torque_enable") == 0 for i in (1, 2, 3))


# ------------------------------------------------------------------------------ 10. no-response removal
def test_no_response_removal_counts_unanswered_reads_not_loops():
    rig = Rig({1: X, 2: X540}, "no_response_id_auto_remove_count:=5")
    try:
        rig.sim.set_silent(2)
        rig.wait(lambda: not rig.debug_of(2)["ping"], what="ID 2 ping false")
        time.sleep(0.1)  # ten loops, but two or three reads of ID 2
        rig.sim.set_silent(2, False)
        rig.wait(lambda: rig.debug_of(2)["ping"], what="ID 2 answering again")
        assert list(rig.debug[-1].status.id_list) == [1, 2]
        assert "removed" not in rig.output
        rig.sim.set_silent(2)  # for good: five unanswered requests later it goes
        rig.node_proc.wait_for("ID 2: no response 5 times in a row: removed", timeout=15)
    finally:
        assert rig.close() == 0


# ------------------------------------------------------------------------------ 11, 12. tripped watchdog
def test_a_tripped_watchdog_is_published_negative_and_cleared_without_servo_auto_stop():
    rig = Rig({1: X}, "term/servo_auto_stop:=false", "loop_rate:=10", "pub_ratio/extra.dynamic_items:=1",
              "pub_ratio/status:=1")
    try:
        rig.sim.servo(1).write("bus_watchdog", 1)  # 20 ms, set behind the handler's back: trips between loops
        rig.node_proc.wait_for("ID 1: bus watchdog tripped", timeout=10)
        rig.wait(lambda: any(len(m.extra.id_list) and m.extra.bus_watchdog_ms[0] < 0 for m in list(rig.states)),
                 what="the trip published as a negative bus_watchdog_ms")
        assert all(m.extra.bus_watchdog_ms[0] in (-20.0, 0.0, 20.0) for m in list(rig.states) if len(m.extra.id_list))
        wait_reg(rig, 1, "bus_watchdog", 0)  # cleared, and not armed again (servo_auto_stop false)
        rig.publish("/dynamixel/command/x/position_control", DynamixelControlXPosition(id_list=[1], position_deg=[25.0]))
        wait_reg(rig, 1, "goal_position", x_pos(25.0))  # the servo takes goals again
    finally:
        assert rig.close() == 0


# ------------------------------------------------------------------------------ 14. add_id set-up
def test_add_id_sets_a_servo_up_as_start_up_does():
    # a 16 ms adapter: on a busy host a late reply is not one of the 3 silences that remove a servo
    rig = Rig({1: X, 2: X540}, "no_response_id_auto_remove_count:=3", "latency_timer:=16")
    try:
        assert reg(rig, 2, "return_delay_time") == 0 and reg(rig, 2, "torque_enable") == 1
        rig.sim.set_silent(2)
        rig.node_proc.wait_for("ID 2: no response 3 times in a row: removed", timeout=15)
        # meanwhile the servo was power-cycled and reconfigured elsewhere, and is in error
        servo = rig.sim.servo(2)
        servo.write("torque_enable", 0)
        servo.write("return_delay_time", 250)
        servo.write("profile_velocity", 0)
        rig.sim.set_hardware_error(2, OVERLOAD)
        rig.sim.set_silent(2, False)
        rig.publish("/dynamixel/shortcut", DynamixelShortcut(command="ADID", id_list=[2]))
        wait_reg(rig, 2, "hardware_error_status", 0)  # init/hardware_error_auto_clean
        wait_reg(rig, 2, "return_delay_time", 0)       # default/return_delay_time
        wait_reg(rig, 2, "torque_enable", 1)           # init/torque_auto_enable
        assert reg(rig, 2, "profile_velocity") > 0      # default/profile_vel
        rig.wait(lambda: list(rig.debug[-1].status.id_list) == [1, 2], what="ID 2 handled again")
    finally:
        assert rig.close() == 0


# ------------------------------------------------------------------------------ 16. dummies per series
def test_dummy_servos_of_each_series():
    rig = Rig({1: X}, "init/dummy_servo_list:=[3, 4, 5]", "init/dummy_servo_series:=[X, P, Pro]",
              "pub_ratio/extra.static_items:=2", expect=4)
    try:
        rig.wait(lambda: rig.group("extra") is not None and len(rig.group("extra").id_list) == 4, what="extra states")
        extra = rig.group("extra")
        assert list(extra.id_list) == [1, 3, 4, 5]
        assert list(extra.model_number) == [X, X, P, PRO]
        assert list(extra.model) == ["X", "X", "P", "Pro"]
        rig.publish("/dynamixel/command/p/position_control", DynamixelControlPPosition(id_list=[4], position_deg=[20.0]))
        rig.wait(lambda: abs(rig.debug_of(4)["position"] - 20.0) < 0.5, timeout=15, what="the P dummy at 20 deg")
    finally:
        assert rig.close() == 0


# ------------------------------------------------------------------------------ 17. profile ranges
def test_x_profiles_are_clamped_to_their_register_range_not_the_velocity_limit():
    rig = Rig({1: X})
    try:
        limit = reg(rig, 1, "velocity_limit")
        fast = (limit + 100) * X_DEG_S  # above Velocity Limit, within the register's 0..32767
        mark = rig.mark()
        rig.publish("/dynamixel/command/x/position_control",
                    DynamixelControlXPosition(id_list=[1], position_deg=[5.0], profile_vel_deg_s=[fast],
                                              profile_acc_deg_ss=[1e9]))
        wait_reg(rig, 1, "profile_velocity", limit + 100)
        wait_reg(rig, 1, "profile_acceleration", 32767)
        line = rig.wait_log("ID 1", "'profile_acc_deg_ss'", "clamped", since=mark)
        assert "x/position_control" not in line or "ID 1" in line
        assert rig.log_since(mark).count("clamped") == 1
    finally:
        assert rig.close() == 0


# ------------------------------------------------------------------------------ 18. no current modes
def test_a_model_without_current_sensor_refuses_current_modes():
    rig = Rig({1: XL430}, "mode_change_interval_sec:=0.0")
    try:
        mark = rig.mark()
        rig.publish("/dynamixel/command/x/current_control", DynamixelControlXCurrent(id_list=[1], current_ma=[50.0]))
        rig.wait_log("ID 1 (XL430-W250) has no current sensor, so no 'current' mode: ignored", since=mark)
        velocity(rig, 1, 10.0)  # the next command is handled
        assert reg(rig, 1, "operating_mode") == 1
    finally:
        assert rig.close() == 0
