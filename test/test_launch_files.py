"""The launch files: checked statically (the XML parsed, the Python compiled and its AST read), then
read as `ros2 launch` would (``launch_runner.py``: the `launch` packages have no PyPI wheels) and
the nodes they describe started on a virtual bus. The original handler's file and argument names
(``launch_dynamixel_handler.py``, ``name_space`` ...) work as ours do."""
from __future__ import annotations

import ast
import py_compile
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parent.parent
LAUNCH = ROOT / "launch"
SHARE = ROOT / "install" / "dynamixel_handler" / "share" / "dynamixel_handler"
LIB = ROOT / "install" / "dynamixel_handler" / "lib" / "dynamixel_handler"
PY_FILES = ["dynamixel_handler_launch.py", "dynamixel_unify_baudrate_launch.py"]
XML_FILE = "dynamixel_handler_launch.xml"
#: the original handler's launch and config file names
CPP_LAUNCH = ["launch_dynamixel_handler.py", "dynamixel_handler_launch.xml", "launch_dynamixel_unify_baudrate.py",
              "dynamixel_unify_baudrate_launch.xml"]
CPP_CONFIG = ["config_dynamixel_handler.yaml", "config_dynamixel_handler-fast.yaml",
              "config_dynamixel_unify_baudrate.yaml"]


def console_scripts() -> set[str]:
    """Executable names declared in setup.py's entry points."""
    text = (ROOT / "setup.py").read_text()
    return set(re.findall(r'f?"(\w+) = \{PACKAGE\}\.[\w.]+:\w+"', text))


def test_console_scripts_are_read_from_setup_py():
    assert {"dynamixel_handler", "dynamixel_unify_baudrate"} <= console_scripts()


# ---------------------------------------------------------------------- XML
def test_xml_launch_starts_the_handler_with_the_shipped_config():
    root = ET.parse(LAUNCH / XML_FILE).getroot()
    assert root.tag == "launch"
    args = {a.get("name"): a.get("default") for a in root.findall("arg")}
    assert set(args) == {"name_space", "namespace", "params_file", "device_name"}
    assert args["name_space"] == "" and args["namespace"] == "$(var name_space)" and args["device_name"] == ""
    share, config = re.fullmatch(r"\$\(find-pkg-share (\w+)\)/(.+)", args["params_file"]).groups()
    assert share == "dynamixel_handler" and (ROOT / config).is_file()
    nodes = root.findall("node")
    assert len(nodes) == 2
    for node in nodes:
        assert node.get("pkg") == "dynamixel_handler"
        assert node.get("exec") in console_scripts()
        assert node.get("namespace") == "$(var namespace)"
        assert node.get("output") == "screen"
        assert [p.get("from") for p in node.findall("param") if p.get("from")] == ["$(var params_file)"]
    # exactly one of the two runs: without device_name, or with it as an override after the file
    plain, override = (nodes if nodes[0].get("unless") else nodes[::-1])
    assert plain.get("unless") == override.get("if") and "$(var device_name)" in override.get("if")
    assert plain.get("if") is None and override.get("unless") is None
    named = [p for p in override.findall("param") if p.get("name")]
    assert [(p.get("name"), p.get("value")) for p in named] == [("device_name", "$(var device_name)")]


# ---------------------------------------------------------------------- Python
def _module(name: str, tmp: Path) -> ast.Module:
    path = LAUNCH / name
    # compiled outside the source tree: a launch/__pycache__ would be installed and change the build hash
    py_compile.compile(str(path), cfile=str(tmp / (name + "c")), doraise=True)
    return ast.parse(path.read_text(), filename=str(path))


def _constants(tree: ast.Module) -> dict[str, str]:
    return {t.id: node.value.value for node in tree.body if isinstance(node, ast.Assign)
            and isinstance(node.value, ast.Constant) for t in node.targets if isinstance(t, ast.Name)}


def _calls(tree: ast.Module, func: str) -> list[ast.Call]:
    return [n for n in ast.walk(tree) if isinstance(n, ast.Call)
            and getattr(n.func, "id", getattr(n.func, "attr", None)) == func]


def _value(node: ast.AST, constants: dict[str, str]):
    if isinstance(node, ast.Constant):
        return node.value
    if isinstance(node, ast.Name):
        return constants.get(node.id)
    return None


@pytest.mark.parametrize("name,executable,config,arguments", [
    ("dynamixel_handler_launch.py", "dynamixel_handler", "config_dynamixel_handler.yaml",
     {"name_space", "namespace", "params_file", "device_name"}),
    ("dynamixel_unify_baudrate_launch.py", "dynamixel_unify_baudrate", "config_unify_baudrate.yaml",
     {"params_file", "device_name", "target_baudrate"}),
])
def test_python_launch_compiles_and_names_installed_parts(name, executable, config, arguments, tmp_path):
    tree = _module(name, tmp_path)
    constants = _constants(tree)
    functions = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
    assert "generate_launch_description" in functions
    imported = {a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module
                and n.module.startswith(("launch", "launch_ros")) for a in n.names}
    assert {"LaunchDescription", "DeclareLaunchArgument", "Node"} <= imported
    declared = {_value(c.args[0], constants) for c in _calls(tree, "DeclareLaunchArgument")}
    assert declared == arguments
    nodes = _calls(tree, "Node")
    assert len(nodes) == 1
    kw = {k.arg: _value(k.value, constants) for k in nodes[0].keywords}
    assert kw["package"] == "dynamixel_handler" and kw["output"] == "screen"
    assert kw["executable"] == executable and executable in console_scripts()
    # the default params_file: <share of the package>/config/<config>
    joins = _calls(tree, "PathJoinSubstitution")
    parts = [[_value(e, constants) for e in j.args[0].elts] for j in joins]
    assert [None, "config", config] in parts
    assert (ROOT / "config" / config).is_file()
    package_shares = [_value(c.args[0], constants) for c in _calls(tree, "FindPackageShare")]
    assert package_shares == ["dynamixel_handler"]


# ---------------------------------------------------------------------- install space
needs_install = pytest.mark.skipif(not SHARE.is_dir(), reason="not built (scripts/setup.sh)")


@needs_install
def test_launch_and_config_files_are_installed_to_share():
    for name in PY_FILES + [XML_FILE] + CPP_LAUNCH:
        assert (SHARE / "launch" / name).is_file(), f"{name} not in {SHARE / 'launch'}: run scripts/setup.sh"
    for config in ["config_unify_baudrate.yaml"] + CPP_CONFIG:
        assert (SHARE / "config" / config).is_file()
    for executable in ("dynamixel_handler", "dynamixel_unify_baudrate", "dynamixel_handler_node",
                       "dynamixel_unify_baudrate_node"):
        assert (LIB / executable).is_file(), f"{executable} not installed: run scripts/setup.sh"


# ---------------------------------------------------------------------- read and run as `ros2 launch` does
@needs_install
@pytest.mark.parametrize("name", PY_FILES + [XML_FILE] + CPP_LAUNCH)
def test_every_launch_file_name_describes_an_installed_node_with_a_shipped_config(name, tmp_path):
    from support.launch_runner import nodes
    found = nodes(name, device_name="/dev/ttyUSB7")
    assert len(found) == 1, found
    cmd = found[0].command(tmp_path)
    assert Path(cmd[0]).is_file() and Path(cmd[0]).parent == LIB
    files = [Path(cmd[i + 1]) for i, a in enumerate(cmd) if a == "--params-file"]
    assert files[0].parent == SHARE / "config" and files[0].is_file()
    # device_name given: an override after the file
    assert yaml.safe_load(files[-1].read_text()) == {"/**": {"ros__parameters": {"device_name": "/dev/ttyUSB7"}}}


def _topic_namespaces(node, topic_end: str, node_namespace: str) -> set[str]:
    """The namespaces of the topics ``*<topic_end>`` that a node in ``node_namespace`` publishes.
    Only the launched node counts: the graph may still list a node of an earlier test, gone without
    saying goodbye, until its lease runs out."""
    return {name[: -len(topic_end)] for name, _ in node.get_topic_names_and_types() if name.endswith(topic_end)
            and any(info.node_namespace == node_namespace for info in node.get_publishers_info_by_topic(name))}


@needs_install
@pytest.mark.parametrize("name,arguments", [
    ("launch_dynamixel_handler.py", {"name_space": "robot1"}),
    ("dynamixel_handler_launch.xml", {"name_space": "robot1"}),
    ("dynamixel_handler_launch.py", {"namespace": "robot1"}),
])
def test_launched_handler_publishes_under_the_namespace_given(name, arguments, tmp_path):
    import rclpy
    from rclpy.node import Node as RosNode

    from dynamixel_handler.sim import VirtualBus
    from dynamixel_handler_msgs.msg import DxlStates

    from support.launch_runner import nodes
    from support.ros import PATIENT_SCAN, NodeProcess, spin_until

    with VirtualBus({1: 1020}) as sim:
        (spec,) = nodes(name, device_name=sim.path, **arguments)
        # the shipped file scans once; on a loaded machine one lost ping would end the start-up
        proc = NodeProcess(spec.command(tmp_path) + ["-p", PATIENT_SCAN])
        rclpy.init()
        try:
            node = RosNode("launch_test")
            from rclpy.executors import SingleThreadedExecutor
            executor = SingleThreadedExecutor()
            executor.add_node(node)
            got: list[DxlStates] = []
            node.create_subscription(DxlStates, "/robot1/dynamixel/states", got.append, 10)
            # a loop that reads neither status nor present (or whose read a loaded machine lost)
            # publishes them empty: wait for one that carries the servo
            assert spin_until(node, executor, lambda: any(list(m.status.id_list) == [1] or list(m.present.id_list) == [1]
                                                          for m in got), timeout=30), (len(got), proc.output)
            # the graph learns of the publisher on its own way, which can come after the first message
            assert spin_until(node, executor, lambda: _topic_namespaces(node, "/dynamixel/states", "/robot1")
                              == {"/robot1"}, timeout=15), _topic_namespaces(node, "/dynamixel/states", "/robot1")
            assert "[robot1.dynamixel_handler]" in proc.output
        finally:
            node.destroy_node()
            rclpy.try_shutdown()
            assert proc.stop() == 0, proc.output


@needs_install
@pytest.mark.parametrize("name", ["launch_dynamixel_unify_baudrate.py", "dynamixel_unify_baudrate_launch.xml"])
def test_launched_unify_tool_finds_the_servo_once(name, tmp_path):
    from dynamixel_handler.sim import VirtualBus

    from support.launch_runner import nodes
    from support.ros import NodeProcess

    with VirtualBus({1: 1020, 2: 1020}, check_baudrate=True) as sim:
        (spec,) = nodes(name, device_name=sim.path, target_baudrate="57600")
        proc = NodeProcess(spec.command(tmp_path))
        assert proc.wait_exit(timeout=120) == 0, proc.output
        assert "2 servo(s) found, 2 already at the target" in proc.output, proc.output
        assert "share" not in proc.output and "Traceback" not in proc.output


def test_package_xml_declares_what_rosdep_must_install_to_run_and_launch():
    root = ET.parse(ROOT / "package.xml").getroot()
    run = {e.text for e in root if e.tag in ("depend", "exec_depend")}
    assert {"rclpy", "launch", "launch_ros", "launch_xml", "ros2launch", "ament_index_python", "dynamixel_handler_msgs",
            "sensor_msgs", "diagnostic_msgs", "lifecycle_msgs", "action_msgs", "builtin_interfaces", "rcl_interfaces",
            "rosgraph_msgs", "python3-numpy", "python3-serial", "dynamixel_sdk"} <= run
