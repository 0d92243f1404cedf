"""control_msgs: the development package built from dev/control_msgs has the type hashes (RIHS01)
of ROS 2's control_msgs (the reference interface files), so MoveIt and ros2_control clients of a
ROS install talk to the node's follow_joint_trajectory action; and the node runs without it."""
from __future__ import annotations

import json
import math
import os
import shutil
from pathlib import Path

from ament_index_python.packages import get_package_share_directory
from rosidl_adapter.action import convert_action_to_idl
from rosidl_adapter.msg import convert_msg_to_idl
from rosidl_generator_type_description import generate_type_hash
from sensor_msgs.msg import JointState

from support.rig import Rig, X

ROOT = Path(__file__).resolve().parents[1]
#: the reference interface files (control_msgs 5.8.0, jazzy), where this machine has them; their
#: hashes are also written down below, so the check runs without them
REFERENCE = Path(os.environ.get("CONTROL_MSGS_REFERENCE", ROOT.parent / "shared" / "spec" / "control_msgs"))
EXPECTED = {
    "control_msgs/msg/JointTolerance": "RIHS01_c254f9cece0f3b733017b6990fd46d1326e25242d6b8844398c97d9a88e7d648",
    "control_msgs/msg/JointComponentTolerance": "RIHS01_739ea7566931944d33830fa10f1bf5e7a7fbdc3172bce7a7eaac642bd6e3ffa4",
    "control_msgs/action/FollowJointTrajectory": "RIHS01_738ebcb7a2d7cfa42f9f1001cc99ce3a4383d1cfe508015d9be8485e4b1c66f6",
    "control_msgs/action/FollowJointTrajectory_Goal": "RIHS01_8a9060704b269608f5a340934cc26e66869dd14bdac29e2e7fd9ec8b9882d205",
    "control_msgs/action/FollowJointTrajectory_Result": "RIHS01_8002e99ed2c14c6faa522f2a93c26d744c5982f254f9e98ff9c6f19789bdb220",
    "control_msgs/action/FollowJointTrajectory_Feedback": "RIHS01_3fd0aaecf71725121ae1ff7f01098a5e0da581e672be18a6b2c286cb43d96b49",
    "control_msgs/action/FollowJointTrajectory_SendGoal": "RIHS01_b13789dddc325a7a962825c45e28c77d37237ec129dd0c34dc5994562938c57f",
    "control_msgs/action/FollowJointTrajectory_GetResult": "RIHS01_e3ceb38e3e1867c8dc0f46014df26e90eb93422f27e9e97f936e07f94be4bc8b",
    "control_msgs/action/FollowJointTrajectory_FeedbackMessage": "RIHS01_80398fcb9674a79081a9906e2ccf0c804dd7cb15e22e362e606ee87186beab71",
}
FILES = {"msg": ["JointTolerance.msg", "JointComponentTolerance.msg"], "action": ["FollowJointTrajectory.action"]}
DEPS = ["builtin_interfaces", "action_msgs", "unique_identifier_msgs", "service_msgs", "std_msgs", "trajectory_msgs",
        "geometry_msgs"]


def _hashes(package_dir: Path, work: Path) -> dict[str, dict[str, str]]:
    """Type name -> {type name: RIHS01} for every interface of ``package_dir`` (rosidl's own pipeline)."""
    idl_dir = work / "idl"
    tuples = []
    for kind, names in FILES.items():
        for name in names:
            convert = convert_msg_to_idl if kind == "msg" else convert_action_to_idl
            convert(package_dir, "control_msgs", Path(kind) / name, idl_dir / kind)
            tuples.append(f"{idl_dir}:{kind}/{Path(name).stem}.idl")
    args = {"package_name": "control_msgs", "output_dir": str(work / "out"), "idl_tuples": tuples,
            "include_paths": [f"{d}:{get_package_share_directory(d)}" for d in DEPS]}
    (work / "args.json").write_text(json.dumps(args))
    generate_type_hash(str(work / "args.json"))
    out = {}
    for kind, names in FILES.items():
        for name in names:
            doc = json.loads((work / "out" / kind / f"{Path(name).stem}.json").read_text())
            out[f"{kind}/{name}"] = {h["type_name"]: h["hash_string"] for h in doc["type_hashes"]}
    return out


def test_the_development_control_msgs_has_the_type_hashes_of_the_reference(tmp_path):
    built = _hashes(ROOT / "dev" / "control_msgs", tmp_path / "dev_work")
    every = {name: h for hashes in built.values() for name, h in hashes.items()}
    assert {name: every[name] for name in EXPECTED} == EXPECTED
    if REFERENCE.is_dir():  # and straight from the reference files
        ref_dir = tmp_path / "ref"
        for kind, names in FILES.items():
            (ref_dir / kind).mkdir(parents=True)
            for name in names:
                shutil.copy(REFERENCE / name, ref_dir / kind / name)
        assert _hashes(ref_dir, tmp_path / "ref_work") == built
    # the package the node imports is the one built from dev/control_msgs, with the same hashes
    installed = json.loads((Path(get_package_share_directory("control_msgs")) / "action" /
                            "FollowJointTrajectory.json").read_text())
    assert {h["type_name"]: h["hash_string"] for h in installed["type_hashes"]} == built["action/FollowJointTrajectory.action"]


def test_the_node_runs_without_control_msgs():
    # a Python (and library) path without the development control_msgs: one info line, no action
    hidden = {k: os.pathsep.join(p for p in os.environ.get(k, "").split(os.pathsep) if "control_msgs" not in p)
              for k in ("PYTHONPATH", "AMENT_PREFIX_PATH", "LD_LIBRARY_PATH")}
    rig = Rig({1: X}, "joint_state.use:=true", "joint_state.names:=[pan]", "joint_state.ids:=[1]", env=hidden)
    try:
        line = rig.wait_log("control_msgs is not available")
        assert "no follow_joint_trajectory action" in line and "[INFO]" in line
        assert rig.output.count("control_msgs is not available") == 1
        rig.publish("/joint_commands", JointState(name=["pan"], position=[0.25]))
        servo = rig.sim.servo(1)

        def pan() -> float:
            return math.radians((servo.read("present_position") - servo.model.position_zero_pulse)
                                * servo.model.position_deg_per_pulse)
        rig.wait(lambda: abs(pan() - 0.25) < 0.01, what="pan moved by joint_commands")
        with rig._lock:
            topics = [n for n, _ in rig.node.get_topic_names_and_types()]
        assert not any("follow_joint_trajectory" in n for n in topics)
        assert "/dynamixel_handler/joint_trajectory" in topics
    finally:
        assert rig.close() == 0
