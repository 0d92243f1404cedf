"""The ``servos`` block gets the set-up tool's checks, through the real node on the virtual bus: a
value that lowers a protection (Shutdown bits off, a temperature limit beyond the factory's, the
direction reversed) only with ``force: true`` in the entry, min below max across the position
limits, hostile names and numbers refused with one line and exit code 2; a refusal writes nothing
(no torque off either: every servo keeps the torque it had).

Factory values (e-Manual): XM430-W350 Shutdown 52 (0x34: overload, electrical shock, overheating),
Temperature Limit 80 degC, positions 0..4095 with 2048 in the middle (0.088 deg a pulse); AX-12A
(Protocol 1.0) Alarm Shutdown 36 (0x24: overload, overheating), positions 0..1023 over 300 deg with
512 in the middle (853 is +99 deg, 171 is -99 deg).
"""
from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from dynamixel_handler.protocol import BULK_WRITE, FACTORY_RESET, REBOOT, REG_WRITE, SYNC_WRITE, WRITE

from support.rig import Rig, scan_params
from support.ros import NodeProcess, node_command

XM430, AX12A = 1020, 12
X1, X2, AX = 1, 2, 3
WRITES = (WRITE, REG_WRITE, SYNC_WRITE, BULK_WRITE, REBOOT, FACTORY_RESET)
PARAMS = ("baudrate:=1000000", "init/used_servo_series.AX:=true")


@pytest.fixture(scope="module")
def bus():
    r = Rig({X1: XM430, X2: XM430, AX: AX12A}, start_node=False, sim_kwargs={"baudrate": 1_000_000})
    yield r
    r.close()


def servo(bus: Rig, dxl_id: int):
    return bus.sim.servos_at(dxl_id)[0]


def run_node(bus: Rig, tmp_path: Path, block: str) -> NodeProcess:
    path = tmp_path / "servos.yaml"
    path.write_text("/**:\n  ros__parameters:\n    servos:\n" + textwrap.indent(textwrap.dedent(block), "      "),
                    encoding="utf-8")
    return NodeProcess(node_command(f"device_name:={bus.device}", *scan_params([X1, X2, AX], 3), *PARAMS)
                       + ["--params-file", str(path)])


#: (entry, the start of its line) refused when the parameters are read, before the scan
HOSTILE = [
    ("id_\u00b2: {position_p_gain_pulse: 640}", "servos.id_\u00b2: neither id_<N> nor a joint name"),
    ("id_\u0662: {position_p_gain_pulse: 640}", "servos.id_\u0662: neither id_<N> nor a joint name"),
    ("id_1: {position_p_gain_pulse: 1.0e+308}", "servos.id_1.position_p_gain_pulse = 1e+308: beyond any register"),
]
#: one file whose every entry is refused after the scan: each value's line
DANGERS = """\
id_1: {shutdown: {overload_error: false, electrical_shock_error: false, overheating_error: false},
       temperature_limit_degc: 100.0}
id_2: {drive_mode: {reverse_mode: true}, min_position_limit_deg: 90.0, max_position_limit_deg: -90.0}
id_3: {shutdown: {overload_error: false, overheating_error: false}, min_position_limit_deg: 99.0,
       max_position_limit_deg: -99.0}
"""
DANGER_LINES = [
    "servos.id_1: ID 1 (XM430-W350) shutdown = 0 clears protection bits 0x34",
    "servos.id_1: ID 1 (XM430-W350) temperature_limit = 100 degC (raw 100) lowers a protection beyond its factory "
    "value (80 degC (raw 80))",
    "servos.id_2: ID 2 (XM430-W350) drive_mode bit 0 reverses the direction it turns",
    "servos.id_2: ID 2 (XM430-W350) min_position_limit",
    "servos.id_3: ID 3 (AX-12A) shutdown = 0 clears protection bits 0x24",
    "servos.id_3: ID 3 (AX-12A) min_position_limit",
]


def refused_run(bus: Rig, tmp_path: Path, block: str) -> NodeProcess:
    """The node with ``block``, every servo holding its load: exit code 2, no write, torque kept."""
    for dxl_id in (X1, X2, AX):
        servo(bus, dxl_id).write("torque_enable", 1)  # servos holding a load when the node starts
    bus.sim.clear_log()
    node = run_node(bus, tmp_path, block)
    assert node.wait_exit(30) == 2, node.output
    assert "Traceback" not in node.output
    assert not [e for e in bus.sim.log if e.instruction in WRITES], [e for e in bus.sim.log if e.instruction in WRITES]
    assert [servo(bus, i).read("torque_enable") for i in (X1, X2, AX)] == [1, 1, 1]
    return node


@pytest.mark.parametrize("entry, line", HOSTILE, ids=["superscript", "arabic-indic", "1e308"])
def test_a_hostile_name_or_number_is_one_line_and_exit_code_2(bus, tmp_path, entry, line):
    node = refused_run(bus, tmp_path, entry + "\n")
    fatal = [x for x in node.output.splitlines() if "bad parameter" in x]
    assert len(fatal) == 1 and line in fatal[0], node.output


def test_one_lowered_protection_is_one_line_that_says_nothing_was_written_not_even_torque_off(bus, tmp_path):
    node = refused_run(bus, tmp_path, "id_2: {drive_mode: {reverse_mode: true}}\n")
    fatal = [x for x in node.output.splitlines() if "bad parameter" in x]
    assert len(fatal) == 1 and DANGER_LINES[2] in fatal[0], node.output
    assert fatal[0].endswith("give 'force: true' in the entry to write it anyway: nothing was written"), fatal[0]


def test_every_lowered_protection_and_inverted_limit_pair_is_a_line_and_nothing_is_written(bus, tmp_path):
    node = refused_run(bus, tmp_path, DANGERS)
    errors = [x for x in node.output.splitlines() if "[ERROR]" in x]
    for line in DANGER_LINES:
        assert sum(line in x for x in errors) == 1, (line, node.output)
    assert all("give 'force: true'" in x for x in errors if "protection" in x or "reverses" in x), errors
    assert not any("give 'force: true'" in x for x in errors if "min_position_limit" in x), errors  # never forcible
    fatal = [x for x in node.output.splitlines() if "bad parameter" in x]
    assert len(fatal) == 1 and "the servos block has 6 refused items (the lines above): nothing was written" in fatal[0]


def test_force_true_writes_what_lowers_a_protection_and_a_value_already_held_needs_no_force(bus, tmp_path):
    x2 = servo(bus, X2)
    before = {item: x2.read(item) for item in ("drive_mode", "shutdown", "torque_enable")}
    try:
        entry = "id_2: {force: true, drive_mode: {reverse_mode: true}, shutdown: {overload_error: false}}\n"
        node = run_node(bus, tmp_path, entry)
        node.wait_for("loop running", timeout=30)
        assert x2.read("drive_mode") & 1 == 1
        assert x2.read("shutdown") == 52 & ~0x20
        forced = [x for x in node.output.splitlines() if "(force: true)" in x]
        assert len(forced) == 2 and "drive_mode bit 0 reverses" in "".join(forced), node.output
        assert node.stop() == 0
        # the servo now holds them: the same entry without force is nothing lowered, so it starts
        node = run_node(bus, tmp_path, entry.replace("force: true, ", ""))
        node.wait_for("loop running", timeout=30)
        assert "servos.id_2 set:" in node.output and "bad parameter" not in node.output
        assert node.stop() == 0
    finally:
        for item, value in before.items():
            x2.write(item, value)
