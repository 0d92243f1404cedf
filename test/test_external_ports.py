"""External ports through /dynamixel/external_port/{write,read} on XH540 and P servos."""
from __future__ import annotations

import pytest

from dynamixel_handler_msgs.msg import DxlExternalPort

from support.rig import P, Rig, X

XH540 = 1100  # XH540-W270


@pytest.fixture(scope="module")
def rig():
    r = Rig({1: X, 2: XH540, 3: P}, "option/external_port.use:=true", "option/external_port.pub_ratio/data:=2",
            "option/external_port.pub_ratio/mode:=5")
    r.reads: list[DxlExternalPort] = []
    with r._lock:
        r.node.create_subscription(DxlExternalPort, "/dynamixel/external_port/read", r.reads.append, 50)
    yield r
    assert r.close() == 0


def _last_for(rig, dxl_id, port):
    for msg in reversed(rig.reads):
        pairs = list(zip(msg.id_list, msg.port))
        if (dxl_id, port) in pairs:
            k = pairs.index((dxl_id, port))
            return msg.mode[k], msg.data[k]
    return None


def test_modes_and_digital_output_reach_the_servo_and_are_read_back(rig):
    rig.publish("/dynamixel/external_port/write",
                DxlExternalPort(id_list=[2, 3, 3], port=[1, 2, 4], mode=["d_out", "a_in", "d_out"]))
    rig.wait(lambda: _last_for(rig, 2, 1) == ("d_out", 0) and _last_for(rig, 3, 4) == ("d_out", 0)
             and _last_for(rig, 3, 2) is not None, what="ports read back")
    assert rig.sim.servo(2).read("external_port_mode_1") == 1
    assert rig.sim.servo(3).read("external_port_mode_2") == 0
    assert rig.sim.servo(3).read("external_port_mode_4") == 1
    rig.publish("/dynamixel/external_port/write", DxlExternalPort(id_list=[2, 3], port=[1, 4], data=[1, 1]))
    rig.wait(lambda: _last_for(rig, 2, 1) == ("d_out", 1) and _last_for(rig, 3, 4) == ("d_out", 1), what="outputs on")
    assert rig.sim.servo(2).read("external_port_data_1") == 1
    mode, analog = _last_for(rig, 3, 2)
    assert mode == "a_in" and 0 <= analog <= 4095


def test_only_named_ports_are_read_and_unset_stops_reading(rig):
    # ports named in a write (here, whatever ran before): only they are read
    rig.publish("/dynamixel/external_port/write", DxlExternalPort(id_list=[2, 3], port=[1, 2], mode=["d_out", "a_in"]))
    rig.wait(lambda: _last_for(rig, 2, 1) is not None and _last_for(rig, 3, 2) is not None, what="the named ports read")
    named = {(i, p) for m in rig.reads[-5:] for i, p in zip(m.id_list, m.port)}
    assert (2, 2) not in named and (2, 3) not in named  # never named in a write
    rig.publish("/dynamixel/external_port/write", DxlExternalPort(id_list=[3], port=[2], mode=["unset"]))
    n = len(rig.reads)
    rig.wait(lambda: len(rig.reads) > n + 3, what="more readings")
    assert all((3, 2) not in zip(m.id_list, m.port) for m in rig.reads[n + 2:])


def test_models_without_ports_and_bad_values_are_refused_with_a_warning(rig):
    rig.publish("/dynamixel/external_port/write", DxlExternalPort(id_list=[1, 2, 2], port=[1, 4, 2], mode=["d_out", "d_out", "fast"]))
    rig.node_proc.wait_for("ID 1 port 1: XM430-W350 has no external ports: ignored")
    rig.node_proc.wait_for("ID 2 port 4: XH540-W270 has ports [1, 2, 3]: ignored")
    rig.node_proc.wait_for("ID 2 port 2: unknown mode 'fast'")
    rig.publish("/dynamixel/external_port/write", DxlExternalPort(id_list=[2], port=[1, 2]))
    rig.node_proc.wait_for("'port' has 2 values for 1 IDs: ignored")
    assert rig.sim.servo(2).read("external_port_mode_2") == 3  # unchanged default
