"""Read a launch file of the package the way `ros2 launch` does and give the nodes it starts.

The `launch` / `launch_ros` packages behind `ros2 launch` are not on PyPI, so this module reads
the files itself: it provides, under the same module and class names, the subset of their API and
XML syntax this package's launch files use (declared arguments with
defaults, `OpaqueFunction`, `IncludeLaunchDescription`, `LaunchConfiguration`,
`PathJoinSubstitution`, `FindPackageShare`, `ThisLaunchFileDir`; `<arg>`, `<node>` with `if` /
`unless`, `<param from>` / `<param name value>`, `<include>`; `$(var)`, `$(find-pkg-share)`,
`$(dirname)`, `$(eval)`). Anything else raises, so a file that needs more fails its test instead of
being read wrongly. Either way the result is the command line launch_ros builds for each node:
`<prefix>/lib/<package>/<executable> --ros-args -r __node:=<name> -r __ns:=/<namespace>
--params-file <file>...` (a dict of parameters goes through a parameter file, as launch_ros does).
"""
from __future__ import annotations

import importlib.util
import os
import re
import sys
import tempfile
import types
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import yaml
from ament_index_python.packages import get_package_prefix, get_package_share_directory


@dataclass
class NodeSpec:
    package: str
    executable: str
    name: str | None = None
    namespace: str = ""
    params: list = field(default_factory=list)  # parameter file paths and dicts, in order

    def command(self, param_dir: Path | None = None) -> list[str]:
        exe = Path(get_package_prefix(self.package)) / "lib" / self.package / self.executable
        if not exe.is_file():
            raise FileNotFoundError(f"executable '{self.executable}' not found in package '{self.package}'")
        cmd = [str(exe), "--ros-args"]
        if self.name:
            cmd += ["-r", f"__node:={self.name}"]
        if self.namespace:
            cmd += ["-r", f"__ns:={self.namespace if self.namespace.startswith('/') else '/' + self.namespace}"]
        for p in self.params:
            if isinstance(p, dict):
                handle = tempfile.NamedTemporaryFile("w", suffix=".yaml", prefix="launch_params_", dir=param_dir,
                                                     delete=False)
                yaml.safe_dump({"/**": {"ros__parameters": p}}, handle)
                handle.close()
                p = handle.name
            cmd += ["--params-file", str(p)]
        return cmd


# ====================================================================== the file readers
class _Context:
    def __init__(self, arguments: dict[str, str]) -> None:
        self.launch_configurations: dict[str, str] = dict(arguments)
        self.file_dir = ""
        self.nodes: list[NodeSpec] = []


def _perform(value, context: _Context) -> str:
    if isinstance(value, (list, tuple)):
        return "".join(_perform(v, context) for v in value)
    if hasattr(value, "perform"):
        return value.perform(context)
    return str(value)


class LaunchConfiguration:
    def __init__(self, name: str) -> None:
        self.name = name

    def perform(self, context: _Context) -> str:
        if self.name not in context.launch_configurations:
            raise KeyError(f"launch configuration '{self.name}' does not exist")
        return context.launch_configurations[self.name]


class PathJoinSubstitution:
    def __init__(self, parts) -> None:
        self.parts = parts

    def perform(self, context: _Context) -> str:
        return os.path.join(*[_perform(p, context) for p in self.parts])


class FindPackageShare:
    def __init__(self, package) -> None:
        self.package = package

    def perform(self, context: _Context) -> str:
        return get_package_share_directory(_perform(self.package, context))


class ThisLaunchFileDir:
    def perform(self, context: _Context) -> str:
        return context.file_dir


class LaunchDescription:
    def __init__(self, entities=None) -> None:
        self.entities = list(entities or [])

    def add_action(self, action) -> None:
        self.entities.append(action)

    def visit(self, context: _Context) -> None:
        for entity in self.entities:
            entity.visit(context)


class DeclareLaunchArgument:
    def __init__(self, name: str, default_value=None, description: str = "", **_) -> None:
        self.name, self.default_value = name, default_value

    def visit(self, context: _Context) -> None:
        if self.name not in context.launch_configurations:
            if self.default_value is None:
                raise ValueError(f"launch argument '{self.name}' has no value and no default")
            context.launch_configurations[self.name] = _perform(self.default_value, context)


class OpaqueFunction:
    def __init__(self, function) -> None:
        self.function = function

    def visit(self, context: _Context) -> None:
        for entity in self.function(context) or []:
            entity.visit(context)


class PythonLaunchDescriptionSource:
    def __init__(self, path) -> None:
        self.path = path


class IncludeLaunchDescription:
    def __init__(self, source, launch_arguments=None) -> None:
        self.source, self.launch_arguments = source, launch_arguments or []

    def visit(self, context: _Context) -> None:
        for name, value in (self.launch_arguments.items() if isinstance(self.launch_arguments, dict)
                            else self.launch_arguments):
            context.launch_configurations[_perform(name, context)] = _perform(value, context)
        _visit_file(_perform(self.source.path, context), context)


class Node:
    def __init__(self, package, executable, name=None, namespace="", parameters=None, output=None,
                 emulate_tty=False, **unknown) -> None:
        if unknown:
            raise NotImplementedError(f"Node arguments this reader does not know: {sorted(unknown)}")
        self.package, self.executable, self.name, self.namespace = package, executable, name, namespace
        self.parameters = parameters or []

    def visit(self, context: _Context) -> None:
        params = [p if isinstance(p, dict) else _perform(p, context) for p in self.parameters]
        context.nodes.append(NodeSpec(_perform(self.package, context), _perform(self.executable, context),
                                      _perform(self.name, context) if self.name else None,
                                      _perform(self.namespace, context), params))


def _stand_in_modules() -> dict[str, types.ModuleType]:
    """Modules named as the launch API's, holding the classes above."""
    names = {
        "launch": {"LaunchDescription": LaunchDescription},
        "launch.actions": {"DeclareLaunchArgument": DeclareLaunchArgument, "OpaqueFunction": OpaqueFunction,
                           "IncludeLaunchDescription": IncludeLaunchDescription},
        "launch.substitutions": {"LaunchConfiguration": LaunchConfiguration, "PathJoinSubstitution": PathJoinSubstitution,
                                 "ThisLaunchFileDir": ThisLaunchFileDir},
        "launch.launch_description_sources": {"PythonLaunchDescriptionSource": PythonLaunchDescriptionSource},
        "launch_ros": {}, "launch_ros.actions": {"Node": Node},
        "launch_ros.substitutions": {"FindPackageShare": FindPackageShare},
    }
    modules = {}
    for name, members in names.items():
        module = types.ModuleType(name)
        module.__dict__.update(members)
        modules[name] = module
    return modules


def _visit_python(path: str, context: _Context) -> None:
    saved = {name: sys.modules.get(name) for name in _stand_in_modules()}
    sys.modules.update(_stand_in_modules())
    try:
        spec = importlib.util.spec_from_file_location(f"launch_file_{Path(path).stem}", path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        description = module.generate_launch_description()
    finally:
        for name, module in saved.items():
            if module is None:
                sys.modules.pop(name, None)
            else:
                sys.modules[name] = module
    description.visit(context)


# ---------------------------------------------------------------------- XML
def _substitute(text: str, context: _Context) -> str:
    """Resolve $(...) substitutions, innermost first."""
    pattern = re.compile(r"\$\(([a-z-]+)((?:\s+(?:'(?:\\'|[^'])*'|[^\s()']+))*)\s*\)")
    while True:
        match = pattern.search(text)
        if match is None:
            return text
        kind, raw = match.group(1), match.group(2).strip()
        args = [a[1:-1].replace("\\'", "'") if a.startswith("'") else a
                for a in re.findall(r"'(?:\\'|[^'])*'|[^\s']+", raw)]
        if kind == "var":
            value = LaunchConfiguration(args[0]).perform(context)
        elif kind == "find-pkg-share":
            value = get_package_share_directory(args[0])
        elif kind == "dirname":
            value = context.file_dir
        elif kind == "eval":
            value = str(eval(_substitute(args[0], context), {"__builtins__": {}}))  # noqa: S307 (test input: the package's own files)
        else:
            raise NotImplementedError(f"substitution $({kind}) is not known to this reader")
        text = text[:match.start()] + value + text[match.end():]


def _condition(element: ET.Element, context: _Context) -> bool:
    def truth(value: str) -> bool:
        value = _substitute(value, context).strip().lower()
        if value not in ("true", "false", "1", "0"):
            raise ValueError(f"condition '{value}' is neither true nor false")
        return value in ("true", "1")
    if element.get("if") is not None and not truth(element.get("if")):
        return False
    return not (element.get("unless") is not None and truth(element.get("unless")))


def _visit_xml(path: str, context: _Context) -> None:
    root = ET.parse(path).getroot()
    if root.tag != "launch":
        raise ValueError(f"{path}: root element is <{root.tag}>, not <launch>")
    for element in root:
        if not _condition(element, context):
            continue
        if element.tag == "arg":
            name = element.get("name")
            if name not in context.launch_configurations:
                if element.get("default") is None:
                    raise ValueError(f"launch argument '{name}' has no value and no default")
                context.launch_configurations[name] = _substitute(element.get("default"), context)
        elif element.tag == "include":
            for arg in element.findall("arg"):
                context.launch_configurations[arg.get("name")] = _substitute(arg.get("value"), context)
            _visit_file(_substitute(element.get("file"), context), context)
        elif element.tag == "node":
            params: list = []
            for param in element:
                if param.tag != "param":
                    raise NotImplementedError(f"<node> child <{param.tag}> is not known to this reader")
                if param.get("from") is not None:
                    params.append(_substitute(param.get("from"), context))
                else:
                    params.append({param.get("name"): yaml.safe_load(_substitute(param.get("value"), context))})
            context.nodes.append(NodeSpec(element.get("pkg"), _substitute(element.get("exec"), context),
                                          element.get("name"), _substitute(element.get("namespace", ""), context),
                                          params))
        else:
            raise NotImplementedError(f"<{element.tag}> is not known to this reader")


def _visit_file(path: str, context: _Context) -> None:
    saved, context.file_dir = context.file_dir, str(Path(path).parent)
    try:
        if path.endswith(".py"):
            _visit_python(path, context)
        elif path.endswith(".xml"):
            _visit_xml(path, context)
        else:
            raise ValueError(f"{path}: not a launch file this reader knows")
    finally:
        context.file_dir = saved


def nodes(launch_file: str, **arguments: str) -> list[NodeSpec]:
    """The nodes the installed launch file ``launch_file`` of dynamixel_handler starts with ``arguments``."""
    path = os.path.join(get_package_share_directory("dynamixel_handler"), "launch", launch_file)
    context = _Context(arguments)
    _visit_file(path, context)
    return context.nodes
