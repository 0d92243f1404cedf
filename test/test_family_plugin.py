"""A servo family that does not exist, added from outside the package: the "Z" family of
``support/z_family.py`` (its data, one behaviour object, its model's control table), installed as a
package would install it (a module and a ``*.dist-info`` whose ``entry_points.txt`` names it in the
group ``dynamixel_handler.families``) on the path of the node and of the simulator only, and driven
through the real node on the virtual bus: found at start-up by its name, its states published, a
goal in degrees reached, an error decoded by its own behaviour; the plug-ins that clash with a
built-in family or are malformed are refused with one line each, and the rest goes on.
"""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from dynamixel_handler_msgs.msg import DxlCommandsAll, DynamixelGoal

from support.rig import Rig
from support.z_family import NAME, NUMBER

ENTRY_POINTS = """[dynamixel_handler.families]
z = z_family:PLUGIN
same_name = z_family:SAME_NAME
same_number = z_family:SAME_NUMBER
not_a_plugin = z_family:NOT_A_PLUGIN
"""
PARAMS = ("init/used_servo_series.Z:=true", "pub_ratio/status:=3", "pub_ratio/error:=3")


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    root = tmp_path_factory.mktemp("family-plugin")
    shutil.copy(Path(__file__).parent / "support" / "z_family.py", root / "z_family.py")
    info = root / "z_family-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: z-family\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(ENTRY_POINTS)
    env = {"PYTHONPATH": os.pathsep.join([str(root), *filter(None, [os.environ.get("PYTHONPATH")])])}
    r = Rig({1: NUMBER}, *PARAMS, env=env, sim_env=env)
    yield r
    assert r.close() == 0


def test_found_at_start_up_by_its_name_and_driven_without_topics_of_its_own(rig):
    assert f"ID 1: {NAME}" in rig.output, rig.output
    rig.wait(lambda: rig.state_of("status", "torque", 1) is True, what="torque on in the status")  # pub_ratio 3
    names = [name for name, _ in rig.node.get_topic_names_and_types()]
    assert not any(n.startswith(("/dynamixel/commands/z", "/dynamixel/command/z/")) for n in names), names


def test_the_clashing_and_malformed_plug_ins_are_refused_with_one_line_each(rig):
    for name, why in (("same_name", "its name 'X' is the name of family X"),
                      ("same_number", "model number 1020 is taken"),
                      ("not_a_plugin", "it names a ServoFamily, not a FamilyPlugin")):
        lines = [line for line in rig.output.splitlines() if f"plug-in '{name}'" in line]
        assert len(lines) == 1 and why in lines[0], rig.output
        assert any(f"plug-in '{name}'" in line and why in line for line in rig.sim.lines), rig.sim.lines


def test_a_goal_in_degrees_is_reached(rig):
    msg = DxlCommandsAll()
    msg.goal = DynamixelGoal(id_list=[1], position_deg=[45.0], profile_vel_deg_s=[300.0])
    rig.publish("/dynamixel/commands/all", msg)
    rig.wait(lambda: abs(rig.debug_of(1)["position"] - 45.0) < 0.5, timeout=20, what="ID 1 at 45 deg")
    assert rig.state_of("goal", "position_deg", 1) == pytest.approx(45.0, abs=0.1)


def test_an_error_is_decoded_by_its_own_behaviour(rig):
    # bit 0: overload on a Z servo (on an X servo it would be input voltage)
    assert rig.sim.command("hwerr 1 0x01") == "ok"
    rig.wait(lambda: rig.state_of("error", "overload", 1) is True, what="overload in the error state")
    rig.wait(lambda: rig.state_of("status", "error", 1) is True, what="the error flag in the status")
    assert rig.state_of("error", "input_voltage", 1) is False
    assert rig.state_of("error", "overheating", 1) is False
