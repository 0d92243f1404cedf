"""Test-wide settings: DDS discovery stays on this machine, on a domain of this test run's own."""
import atexit
import fcntl
import gc
import os
import sys
import tempfile

# Before anything imports rclpy: loopback-only discovery and a domain no other run shares.
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"


def _claim_domain() -> str:
    """A ROS domain ID that no other test run on this machine holds (a lock file per domain, held
    for the life of this process), so concurrent runs never see each other's topics."""
    start = os.getpid() % 100
    for k in range(100):
        domain = 1 + (start + k) % 100
        handle = open(os.path.join(tempfile.gettempdir(), f"dynamixel_handler_test_domain_{domain}.lock"), "w")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            continue
        atexit.register(handle.close)  # the lock is held until this process exits, then closed quietly
        return str(domain)
    return str(1 + start)


os.environ["ROS_DOMAIN_ID"] = _claim_domain()

# The virtual bus answers from a thread of this process, within a 1 ms adapter's reply wait (about
# 4 ms at 2 Mbps) while the rig's listener decodes the node's messages in another. Python lets a
# thread that wants the interpreter lock wait 5 ms for a busy one by default: the node process
# shortens it (ros/process.py), and so does the test process.
sys.setswitchinterval(0.0002)

# A full collection (generation 2) of this process's heap held every thread for 0.2-0.7 s on a busy
# 2-core host (a worker's heap reaches hundreds of thousands of objects), the virtual bus's serving
# thread included: the node saw every servo go silent for that long ("no response (ping false)"),
# and a reply missed its 1 ms adapter's wait. So no full collection runs by itself while a test's
# bus serves: they run between modules (``pytest_runtest_teardown``), the young generations as usual,
# and what the imports made is frozen out of every collection once the tests are collected.
gc.set_threshold(gc.get_threshold()[0], gc.get_threshold()[1], 1_000_000_000)


# ---------------------------------------------------------------- markers
# `scripts/test.sh -m "not slow"` is the inner loop (under two minutes); `-m sim` the
# ROS-free virtual-bus and bus-layer tests; `-m ros` everything that runs a node or rclpy.
import pytest  # noqa: E402

#: modules whose tests start node or tool processes many times or run for seconds each: about
#: 8 s or more of a worker's time in all (``--durations``); the rest is the two-minute inner loop
SLOW_MODULES = frozenset({
    "test_loop_report", "test_load", "test_pipeline", "test_ros_cli", "test_examples", "test_fuzz_commands",
    "test_wire_faults", "test_multi_bus", "test_signals", "test_hostile_input", "test_diagnostics",
    "test_launch_files", "test_services", "test_lifecycle", "test_safety", "test_unify_baudrate",
    "test_node_params", "test_core_startup", "test_compat_params",
    # the set-up tool's process runs, the docs run as written
    "test_setup_tool", "test_setup_tool_safety", "test_setup_tool_restore", "test_setup_tool_reach",
    "test_setup_tool_protocol1", "test_setup_tool_calibrate", "test_setup_tool_node", "test_docs_run",
    # node suites of many starts or many seconds
    "test_parity", "test_watchdog_pacing", "test_floods", "test_model_y", "test_servo_block",
    "test_servo_block_checks", "test_snapshot_service", "test_snapshot_paths", "test_fast_paths_publish",
    "test_fast_paths_commands", "test_commands_topics", "test_commands_bad_input", "test_commands_status",
    "test_core_faults", "test_joint_commands", "test_core_ratios", "test_services_load", "test_params_file_limits",
    "test_e_stop", "test_e_stop_rigs", "test_reboot_service", "test_manifest", "test_joints_node",
    "test_joints_calibration_node", "test_item_services", "test_family_plugin",
})
#: ROS-free modules outside test/sim that drive the bus layer or the virtual bus
SIM_MODULES = frozenset({"test_bus_sim", "test_bus_wire", "test_bus_protocol"})
_ROS_NAMES = ("rclpy", "Rig", "NodeProcess", "TopicClient")


#: the modules that take longest (a minute or more of a worker's time): collected first, so that the
#: workers (a file each at a time, ``--dist loadfile``) do not end with one of them alone on one
LONG_FIRST = ("test_setup_tool_safety", "test_setup_tool_restore", "test_setup_tool_reach", "test_commands_topics",
              "test_docs_run", "test_setup_tool", "test_loop_report", "test_parity", "test_setup_tool_protocol1",
              "test_watchdog_pacing", "test_floods", "test_load", "test_servo_block_checks", "test_setup_tool_node",
              "test_setup_tool_calibrate")


def _first(item) -> int:
    name = item.path.stem
    return LONG_FIRST.index(name) if name in LONG_FIRST else len(LONG_FIRST)


def pytest_collection_modifyitems(config, items):
    items.sort(key=_first)  # stable: each module's tests keep their order
    for item in items:
        module = getattr(item, "module", None)
        name = module.__name__.rsplit(".", 1)[-1] if module else ""
        # the command suites run on both message paths; the rclpy-objects run is the slow repeat
        if name in SLOW_MODULES or "[rclpy objects]" in item.nodeid:
            item.add_marker(pytest.mark.slow)
        if "sim" in item.path.parts or name in SIM_MODULES:
            item.add_marker(pytest.mark.sim)
        if module is not None and any(n in vars(module) for n in _ROS_NAMES):
            item.add_marker(pytest.mark.ros)


def pytest_collection_finish(session):
    gc.collect()
    gc.freeze()  # the modules, tables and test items: never scanned again


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_teardown(item, nextitem):
    yield
    if nextitem is None or getattr(nextitem, "module", None) is not getattr(item, "module", None):  # its rigs closed
        gc.collect()
