"""Every field of every state group equals the servos' registers in the e-Manual's units.

The expected values are computed here from the raw registers of the virtual servos with the unit
factors of the ROBOTIS e-Manual written out below (not through the product's unit code), so a
wrong scale, offset, sign or address anywhere between the bus and the message shows up.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import pytest

from dynamixel_handler.ros.lean import RAW_ENV

from support.rig import BASE_PARAMS, FOUR_SERVOS, H54, PH54, XM430, XM540, Rig


@dataclass(frozen=True)
class Manual:
    """Unit factors of one model, from its e-Manual control table."""

    pos_deg: float          # degrees per position pulse
    pos_zero: int           # pulse of 0 deg (goal/present position, position limits, trajectory)
    vel_rpm: float          # rev/min per velocity LSB
    acc_rpm2: float         # rev/min^2 per acceleration LSB (NaN: no such item)
    cur_ma: float           # mA per current LSB
    pwm_full: float         # PWM value of 100 % (NaN: no PWM)


X_MANUAL = Manual(360 / 4096, 2048, 0.229, 214.577, 2.69, 885)          # XM430-W350 / XM540-W270
PH54_MANUAL = Manual(180 / 501923, 0, 0.01, 1.0, 1.0, 2009)              # PH54-200-S500-R
# H54-200-S500-R: velocity 0.00199234 rev/min; "58,000 rev/min^2" of the core motor per acceleration
# LSB, i.e. 58,000 * 0.00199234 rev/min^2 at the output; torque/current 16.11328 mA.
H54_MANUAL = Manual(180 / 250961, 0, 0.00199234, 58000 * 0.00199234, 16.11328, math.nan)
MANUALS = {XM430: X_MANUAL, XM540: X_MANUAL, PH54: PH54_MANUAL, H54: H54_MANUAL}

NAN = math.nan

# Register values (pulses) poked into each servo after start-up. Distinct per servo and item, with
# negative values where the item is signed. Items a model lacks are simply not in its dict.
POKES = {
    1: dict(  # XM430-W350: position mode, torque on, an input-voltage error (not in its shutdown mask)
        operating_mode=3, firmware_version=47, return_delay_time=37, drive_mode=0x09, secondary_id=7,
        homing_offset=-1234, moving_threshold=17, temperature_limit=77, max_voltage_limit=150,
        min_voltage_limit=97, pwm_limit=800, current_limit=1000, velocity_limit=180, max_position_limit=3900,
        min_position_limit=150, startup_configuration=0x03, shutdown=0x14, led=1,
        velocity_i_gain=1111, velocity_p_gain=222, position_d_gain=333, position_i_gain=44, position_p_gain=555,
        feedforward_2nd_gain=66, feedforward_1st_gain=77,
        goal_pwm=-300, goal_current=-250, goal_velocity=-77, profile_acceleration=33, profile_velocity=44,
        goal_position=3000, hardware_error_status=0x01),
    2: dict(  # XM540-W270: extended position mode, torque off, time-based profile (of 0, as in velocity units)
        operating_mode=4, torque_enable=0, return_delay_time=5, drive_mode=0x04, secondary_id=255,
        homing_offset=4096, moving_threshold=3, temperature_limit=60, max_voltage_limit=140, min_voltage_limit=100,
        pwm_limit=885, current_limit=2047, velocity_limit=100, max_position_limit=4095, min_position_limit=0,
        startup_configuration=0x02, shutdown=0x3F, led=0,
        velocity_i_gain=1920, velocity_p_gain=100, position_d_gain=0, position_i_gain=1, position_p_gain=800,
        feedforward_2nd_gain=2, feedforward_1st_gain=3,
        goal_pwm=885, goal_current=2047, goal_velocity=100, profile_acceleration=0, profile_velocity=0,
        goal_position=-70000, hardware_error_status=0),
    3: dict(  # PH54-200-S500-R: PWM mode, overheating error (its shutdown mask leaves bit 2 out)
        operating_mode=16, return_delay_time=11, drive_mode=0x08, secondary_id=9, homing_offset=-5000,
        moving_threshold=80, temperature_limit=70, max_voltage_limit=300, min_voltage_limit=160, pwm_limit=2000,
        current_limit=20000, acceleration_limit=9000, velocity_limit=2900, max_position_limit=400000,
        min_position_limit=-400000, startup_configuration=0x01, shutdown=0x3A,
        led_red=255, led_green=51, led_blue=0,
        velocity_i_gain=17, velocity_p_gain=601, position_d_gain=12, position_i_gain=3, position_p_gain=33,
        feedforward_2nd_gain=4, feedforward_1st_gain=5,
        goal_pwm=1000, goal_current=-800, goal_velocity=2500, profile_acceleration=500, profile_velocity=3000,
        goal_position=-131073, hardware_error_status=0x04),
    4: dict(  # H54-200-S500-R (old Pro): velocity mode, voltage and overheating errors
        operating_mode=1, firmware_version=26, return_delay_time=0, homing_offset=12345, moving_threshold=60,
        temperature_limit=75, max_voltage_limit=380, min_voltage_limit=170, acceleration_limit=10,
        current_limit=1200, velocity_limit=16000, max_position_limit=200000, min_position_limit=-200000,
        shutdown=0x3A, led_red=10, led_green=20, led_blue=30,
        velocity_i_gain=15, velocity_p_gain=400, position_p_gain=34,
        goal_current=300, goal_velocity=-5000, profile_acceleration=4, goal_position=-12345,
        hardware_error_status=0x05),
}
# Present values and other items the servo itself changes: pinned, so they hold still.
PINS = {
    1: dict(present_pwm=-123, present_current=-45, present_velocity=-12, present_position=1000,
            velocity_trajectory=-11, position_trajectory=1001, present_input_voltage=118, present_temperature=41,
            realtime_tick=12345, moving=1, moving_status=0x2B),
    2: dict(present_pwm=400, present_current=300, present_velocity=55, present_position=-9000,
            velocity_trajectory=56, position_trajectory=-9001, present_input_voltage=121, present_temperature=39,
            realtime_tick=32767, moving=0, moving_status=0x11),
    3: dict(present_pwm=-1500, present_current=-2500, present_velocity=-2200, present_position=-250000,
            velocity_trajectory=-2100, position_trajectory=-250100, present_input_voltage=241, present_temperature=44,
            realtime_tick=7, moving=1, moving_status=0x31),
    4: dict(present_position=123456, present_velocity=-3000, present_current=-20, present_input_voltage=239,
            present_temperature=45, moving=0),
}

POSITION = ("goal_position", "present_position", "position_trajectory", "max_position_limit", "min_position_limit")
VELOCITY = ("goal_velocity", "present_velocity", "velocity_trajectory", "profile_velocity", "velocity_limit",
            "moving_threshold")
ACCELERATION = ("profile_acceleration", "acceleration_limit")
CURRENT = ("goal_current", "present_current", "current_limit")
PWM = ("goal_pwm", "present_pwm", "pwm_limit")
MODE_NAMES = {0: "current", 1: "velocity", 3: "position", 4: "ex_position", 5: "cur_position", 16: "pwm"}
ERROR_BITS = {"input_voltage": 0, "motor_hall_sensor": 1, "overheating": 2, "motor_encoder": 3,
              "electrical_shock": 4, "overload": 5}
PROFILES = {0: "none", 1: "rectangular", 2: "triangular", 3: "trapezoidal"}


def physical(servo, item: str) -> tuple[float, float]:
    """(value, one LSB) of ``item`` of a virtual servo in the product's units, by the e-Manual;
    NaN where the model has no such item."""
    man = MANUALS[servo.model.number]
    if not servo.model.has(item):
        return NAN, 0.0
    raw = servo.read(item)
    if item in POSITION:
        return (raw - man.pos_zero) * man.pos_deg, man.pos_deg
    if item == "homing_offset":
        return raw * man.pos_deg, man.pos_deg
    if item in VELOCITY:
        return raw * man.vel_rpm * 6.0, man.vel_rpm * 6.0          # rev/min -> deg/s
    if item in ACCELERATION:
        return raw * man.acc_rpm2 * 360 / 3600, man.acc_rpm2 * 0.1  # rev/min^2 -> deg/s^2
    if item in CURRENT:
        return raw * man.cur_ma, man.cur_ma
    if item in PWM:
        return raw * 100.0 / man.pwm_full, 100.0 / man.pwm_full
    scale = {"present_input_voltage": 0.1, "max_voltage_limit": 0.1, "min_voltage_limit": 0.1,
             "present_temperature": 1.0, "temperature_limit": 1.0, "return_delay_time": 2.0,
             "bus_watchdog": 20.0, "realtime_tick": 0.001}[item]
    return raw * scale, scale


def register(servo, item: str, default: int = 0) -> int:
    return servo.read(item) if servo.model.has(item) else default


def assert_unit(actual: float, servo, item: str, what: str) -> None:
    expected, lsb = physical(servo, item)
    if math.isnan(expected):
        assert math.isnan(actual), f"{what}: {servo.model.name} has no {item}, expected NaN, got {actual}"
    else:
        assert abs(actual - expected) <= 0.5 * lsb + 1e-9, \
            f"{what}: {servo.model.name} {item}={servo.read(item)} pulses -> expected {expected}, got {actual}"


def check_status(msg, sim) -> None:
    assert list(msg.id_list) == [1, 2, 3, 4]
    for k, dxl_id in enumerate(msg.id_list):
        s = sim.servo(dxl_id)
        assert msg.torque[k] == (s.read("torque_enable") == 1), f"status.torque of ID {dxl_id}"
        assert msg.error[k] == (s.read("hardware_error_status") != 0), f"status.error of ID {dxl_id}"
        assert msg.ping[k] is True
        assert msg.mode[k] == MODE_NAMES[s.read("operating_mode")], f"status.mode of ID {dxl_id}"


def check_present(msg, sim) -> None:
    assert list(msg.id_list) == [1, 2, 3, 4]
    fields = {"pwm_percent": "present_pwm", "current_ma": "present_current", "velocity_deg_s": "present_velocity",
              "position_deg": "present_position", "vel_trajectory_deg_s": "velocity_trajectory",
              "pos_trajectory_deg": "position_trajectory", "input_voltage_v": "present_input_voltage",
              "temperature_degc": "present_temperature"}
    for field, item in fields.items():
        values = getattr(msg, field)
        assert len(values) == 4, f"present.{field}"
        for k, dxl_id in enumerate(msg.id_list):
            assert_unit(values[k], sim.servo(dxl_id), item, f"present.{field}[ID {dxl_id}]")


def check_goal(msg, sim) -> None:
    assert list(msg.id_list) == [1, 2, 3, 4]
    fields = {"pwm_percent": "goal_pwm", "current_ma": "goal_current", "velocity_deg_s": "goal_velocity",
              "position_deg": "goal_position", "profile_vel_deg_s": "profile_velocity",
              "profile_acc_deg_ss": "profile_acceleration"}
    for field, item in fields.items():
        for k, dxl_id in enumerate(msg.id_list):
            assert_unit(getattr(msg, field)[k], sim.servo(dxl_id), item, f"goal.{field}[ID {dxl_id}]")


def check_gain(msg, sim) -> None:
    assert list(msg.id_list) == [1, 2, 3, 4]
    for item in ("velocity_i_gain", "velocity_p_gain", "position_d_gain", "position_i_gain", "position_p_gain",
                 "feedforward_2nd_gain", "feedforward_1st_gain"):
        got = list(getattr(msg, f"{item}_pulse"))
        assert got == [register(sim.servo(i), item) for i in msg.id_list], f"gain.{item}_pulse"


def check_limit(msg, sim) -> None:
    assert list(msg.id_list) == [1, 2, 3, 4]
    fields = {"temperature_limit_degc": "temperature_limit", "max_voltage_limit_v": "max_voltage_limit",
              "min_voltage_limit_v": "min_voltage_limit", "pwm_limit_percent": "pwm_limit",
              "current_limit_ma": "current_limit", "acceleration_limit_deg_ss": "acceleration_limit",
              "velocity_limit_deg_s": "velocity_limit", "max_position_limit_deg": "max_position_limit",
              "min_position_limit_deg": "min_position_limit"}
    for field, item in fields.items():
        for k, dxl_id in enumerate(msg.id_list):
            assert_unit(getattr(msg, field)[k], sim.servo(dxl_id), item, f"limit.{field}[ID {dxl_id}]")


def check_error(msg, sim) -> None:
    assert list(msg.id_list) == [1, 2, 3, 4]
    for name, bit in ERROR_BITS.items():
        want = [bool(sim.servo(i).read("hardware_error_status") >> bit & 1) for i in msg.id_list]
        assert list(getattr(msg, name)) == want, f"error.{name}"


def check_extra(msg, sim) -> None:
    ids = list(msg.id_list)
    assert ids == [1, 2, 3, 4]
    servos = [sim.servo(i) for i in ids]
    assert list(msg.model) == ["X", "X", "P", "Pro"]
    assert list(msg.model_number) == [s.read("model_number") for s in servos] == [XM430, XM540, PH54, H54]
    assert list(msg.firmware_version) == [s.read("firmware_version") for s in servos]
    # integers a series lacks are 0 (the old Pro has no Protocol Type nor Secondary ID)
    # the old Pro (ID 4) has no Protocol Type register: it speaks Protocol 2.0 only
    assert list(msg.protocol_type[:3]) == [register(s, "protocol_type") for s in servos[:3]] == [2, 2, 2]
    assert msg.protocol_type[3] == 2
    assert list(msg.shadow_id) == [register(s, "secondary_id") for s in servos] == [7, 255, 9, 0]
    for k, s in enumerate(servos):
        for field, item in (("realtime_tick_s", "realtime_tick"), ("return_delay_time_us", "return_delay_time"),
                            ("homing_offset_deg", "homing_offset"), ("moving_threshold_deg_s", "moving_threshold"),
                            ("bus_watchdog_ms", "bus_watchdog")):
            assert_unit(getattr(msg, field)[k], s, item, f"extra.{field}[ID {ids[k]}]")
        assert msg.moving[k] == bool(register(s, "moving")), f"extra.moving[ID {ids[k]}]"
        assert msg.reboot[k] is False
        assert math.isnan(msg.pwm_slope_percent[k])  # none of these models has PWM Slope
        # Moving Status: bit 0 in position, bit 1 profile ongoing, bit 3 following error, bits 4-5 profile
        ms = register(s, "moving_status")
        assert msg.moving_status.in_position[k] == bool(ms & 0x01)
        assert msg.moving_status.profile_ongoing[k] == bool(ms & 0x02)
        assert msg.moving_status.following_error[k] == bool(ms & 0x08)
        assert msg.moving_status.velocity_profile[k] == PROFILES[ms >> 4 & 3]
        # Drive Mode: bit 0 reverse, bit 2 time-based profile, bit 3 torque on by goal update
        dm = register(s, "drive_mode")
        assert msg.drive_mode.reverse_mode[k] == bool(dm & 0x01)
        assert msg.drive_mode.profile_configuration[k] == ("time_based" if dm & 0x04 else "velocity_based")
        assert msg.drive_mode.torque_on_by_goal_update[k] == bool(dm & 0x08)
        # Startup Configuration: bit 0 startup torque on, bit 1 RAM restore
        sc = register(s, "startup_configuration")
        assert msg.restore_configuration.startup_torque_on[k] == bool(sc & 0x01)
        assert msg.restore_configuration.ram_restore[k] == bool(sc & 0x02)
        # Shutdown: the hardware-error bits that switch torque off
        sd = register(s, "shutdown")
        for name, bit in ERROR_BITS.items():
            assert getattr(msg.shutdown, f"{name}_error")[k] == bool(sd >> bit & 1), f"shutdown.{name}[ID {ids[k]}]"
    # LED: X has one on/off LED (shown as red 0/100 %), P and Pro an RGB LED of 0..255 each
    assert list(msg.led.red_percent[:2]) == [100.0, 0.0]
    assert all(math.isnan(v) for v in list(msg.led.green_percent[:2]) + list(msg.led.blue_percent[:2]))
    for k, s in enumerate(servos[2:], start=2):
        for colour in ("red", "green", "blue"):
            got = getattr(msg.led, f"{colour}_percent")[k]
            assert abs(got - s.read(f"led_{colour}") * 100 / 255) < 1e-9, f"led.{colour}[ID {ids[k]}]"


CHECKS = {"status": check_status, "present": check_present, "goal": check_goal, "gain": check_gain,
          "limit": check_limit, "error": check_error, "extra": check_extra}


@pytest.fixture(scope="module", params=["raw CDR", "rclpy objects"])
def bench(request):
    """Run twice: the node's own CDR encoding, and rclpy message objects (its fallback)."""
    env = {RAW_ENV: "0"} if request.param == "rclpy objects" else None
    ratios = ["pub_ratio/present.velocity_trajectory:=1", "pub_ratio/present.position_trajectory:=1",
              "pub_ratio/present.input_voltage:=1", "pub_ratio/present.temperature:=1",
              "pub_ratio/status:=2", "pub_ratio/goal:=2", "pub_ratio/gain:=3", "pub_ratio/limit:=3",
              "pub_ratio/error:=2", "pub_ratio/extra.dynamic_items:=2", "pub_ratio/extra.static_items:=3"]
    b = Rig(FOUR_SERVOS, *ratios, env=env, base=BASE_PARAMS, state_topics=True)
    try:
        if env:
            b.node_proc.wait_for("rclpy message objects")
        for dxl_id, values in POKES.items():
            servo = b.sim.servo(dxl_id)
            for name, value in values.items():
                servo.write(name, value)
            for name, value in PINS[dxl_id].items():
                servo.pin(name, value)
        # ten loops (one /dynamixel/states each) re-read every group at least three times; one more
        # message per topic after that carries only values read after the pokes
        b.wait_new(["states"], count=10)
        b.wait_new(["states", "debug", *(f"state/{g}" for g in CHECKS)], count=1)
        yield b
    finally:
        b.close()


def test_the_bench_really_differs_from_factory_defaults(bench):
    # the pokes landed and the servos did not undo them: the comparisons below are meaningful
    assert bench.sim.servo(3).read("goal_position") == -131073
    assert bench.sim.servo(1).read("torque_enable") == 1 and bench.sim.servo(2).read("torque_enable") == 0
    assert bench.sim.servo(4).read("present_position") == 123456


@pytest.mark.parametrize("group", list(CHECKS))
def test_state_topic_equals_registers_in_manual_units(bench, group):
    CHECKS[group](bench.topics[f"state/{group}"].last(), bench.sim)


@pytest.mark.parametrize("group", list(CHECKS))
def test_dxl_states_carries_the_same_values(bench, group):
    states = [m for m in bench.topics["states"].all() if len(getattr(m, group).id_list)]
    assert states, f"no /dynamixel/states with {group}"
    CHECKS[group](getattr(states[-1], group), bench.sim)
    assert states[-1].stamp.sec > 0


def test_debug_carries_status_and_present_and_goal_of_current_velocity_position(bench):
    msg = bench.topics["debug"].last()
    check_status(msg.status, bench.sim)
    for field, item in (("current_ma", "current"), ("velocity_deg_s", "velocity"), ("position_deg", "position")):
        element = getattr(msg, field)
        for k, dxl_id in enumerate(msg.status.id_list):
            servo = bench.sim.servo(dxl_id)
            assert_unit(element.present[k], servo, f"present_{item}", f"debug.{field}.present[ID {dxl_id}]")
            assert_unit(element.goal[k], servo, f"goal_{item}", f"debug.{field}.goal[ID {dxl_id}]")

