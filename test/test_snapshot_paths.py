"""``dynamixel/save_servo_settings`` given the bus's own device or a 5,000-character path as
``servos_snapshot.path`` (a start parameter: a node each, so that no other node answers the same
service meanwhile): refused in one short answer naming it, nothing written, the loop going on."""
from __future__ import annotations

import os
from pathlib import Path

import pytest
from std_srvs.srv import Trigger

from support.rig import Rig

XM430 = 1020


@pytest.mark.parametrize("case", ["the bus", "a long missing folder"])
def test_the_bus_device_and_a_hostile_path_are_refused_in_one_short_answer(tmp_path, case):
    r = Rig({1: XM430}, start_node=False)
    try:
        device = os.path.realpath(r.device)
        path = device if case == "the bus" else str(tmp_path) + ("/" + "d" * 200) * 25 + "/x.yaml"
        r.start_node(f"servos_snapshot.path:={path}")
        client = r.node.create_client(Trigger, "/dynamixel/save_servo_settings")
        assert client.wait_for_service(timeout_sec=10)
        future = client.call_async(Trigger.Request())
        r.wait(future.done, timeout=20, what="save_servo_settings answered")
        answer = future.result()
        assert not answer.success
        if case == "the bus":
            assert answer.message == f"not saved: servos_snapshot.path {device} is the bus's own device"
        else:
            # 5,000 characters: longer than a path can be; named cut, with its length
            assert answer.message.startswith(f"not saved: servos_snapshot.path {str(tmp_path)[:20]}"), answer.message
            assert "characters)" in answer.message and len(answer.message) < 600, answer.message
        mark = len(r.states)
        r.wait(lambda: len(r.states) > mark + 5, what="states after the refusal")
    finally:
        assert r.close() == 0
    if case == "the bus":
        assert not Path(path).is_file()
