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


REFUSED = [
    ("id_1: {shutdown: {overload_error: false, electrical_shock_error: false, overheating_error: false}}",
     "servos.id_1: ID 1 (XM430-W350) shutdown = 0 clears protection bits 0x34"),
    ("id_3: {shutdown: {overload_error: false, overheating_error: false}}",
     "servos.id_3: ID 3 (AX-12A) shutdown = 0 clears protection bits 0x24"),
    ("id_1: {temperature_limit_degc: 100.0}",
     "servos.id_1: ID 1 (XM430-W350) temperature_limit = 100 degC (raw 100) lowers a protection beyond its factory "
     "value (80 degC (raw 80))"),
    ("id_2: {drive_mode: {reverse_mode: true}}",
     "servos.id_2: ID 2 (XM430-W350) drive_mode bit 0 reverses the direction it turns"),
    ("id_1: {min_position_limit_deg: 90.0, max_position_limit_deg: -90.0}",
     "servos.id_1: ID 1 (XM430-W350) min_position_limit"),
    ("id_3: {min_position_limit_deg: 99.0, max_position_limit_deg: -99.0}",
     "servos.id_3: ID 3 (AX-12A) min_position_limit"),
    ("id_\u00b2: {position_p_gain_pulse: 640}", "servos.id_\u00b2: neither id_<N> nor a joint name"),
    ("id_\u0662: {position_p_gain_pulse: 640}", "servos.id_\u0662: neither id_<N> nor a joint name"),
    ("id_1: {position_p_gain_pulse: 1.0e+308}", "servos.id_1.position_p_gain_pulse = 1e+308: beyond any register"),
]


@pytest.mark.parametrize("entry, line", REFUSED, ids=[f"refused{k}" for k in range(len(REFUSED))])
def test_a_refused_entry_is_one_line_exit_code_2_and_nothing_written_not_even_torque_off(bus, tmp_path, entry, line):
    for dxl_id in (X1, X2, AX):
        servo(bus, dxl_id).write("torque_enable", 1)  # servos holding a load when the node starts
    bus.sim.clear_log()
    node = run_node(bus, tmp_path, entry + "\n")
    assert node.wait_exit(30) == 2, node.output
    fatal = [x for x in node.output.splitlines() if "bad parameter" in x]
    assert len(fatal) == 1 and line in fatal[0], node.output
    if "(XM430-W350)" in line or "(AX-12A)" in line:  # found after the scan: the line says nothing was written
        assert fatal[0].endswith("nothing was written") or "nothing was written; give" in fatal[0], fatal[0]
    if "protection" in line or "reverses" in line:
        assert "give 'force: true' in the entry to write it anyway" in fatal[0]
    assert "Traceback" not in node.output
    assert not [e for e in bus.sim.log if e.instruction in WRITES], [e for e in bus.sim.log if e.instruction in WRITES]
    assert [servo(bus, i).read("torque_enable") for i in (X1, X2, AX)] == [1, 1, 1]


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
