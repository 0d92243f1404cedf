"""Declare the node's parameters (typed, with descriptions) and read them into a Config.

The node is created with ``automatically_declare_parameters_from_overrides=True`` so that every
name in the user's YAML is visible here: names we do not know get one error line (and are
ignored), other spellings of the original handler's YAML files (``config.ALIASES``) are read as the
parameter they name, values of the wrong type or range stop start-up with one clear message.
"""
from __future__ import annotations

import difflib
import sys
from typing import Any, cast

import rcl_interfaces.msg
from rcl_interfaces.msg import ParameterDescriptor, ParameterType
from rclpy.node import Node
from rclpy.parameter import Parameter

from ..config import (
    ALIASES,
    BOOL,
    FLOAT,
    FLOAT_ARRAY,
    INT,
    INT_ARRAY,
    SCHEMA,
    SCHEMA_BY_NAME,
    STR,
    STR_ARRAY,
    TOLERATED_PREFIXES,
    Config,
    ConfigError,
    coerce,
    validate,
)
from ..joints import is_joint_parameter
from ..logs import ECHO_MAX, cut, cut_path
from ..servo.settings import is_servo_parameter
from .params_file import Totals, read_problem
from .servo_params import declare_servo_block

_ROS_TYPES = {
    BOOL: ParameterType.PARAMETER_BOOL, INT: ParameterType.PARAMETER_INTEGER,
    FLOAT: ParameterType.PARAMETER_DOUBLE, STR: ParameterType.PARAMETER_STRING,
    INT_ARRAY: ParameterType.PARAMETER_INTEGER_ARRAY, FLOAT_ARRAY: ParameterType.PARAMETER_DOUBLE_ARRAY,
    STR_ARRAY: ParameterType.PARAMETER_STRING_ARRAY,
}
_ROS_OWN = {"use_sim_time", "start_type_description_service"}


def declare_and_load(node: Node) -> Config:
    """Declare every parameter of SCHEMA on ``node`` and return the validated values."""
    given: dict[str, Any] = {name: cast(Parameter, p).value for name, p in node.get_parameters_by_prefix("").items()}
    for path, why in files_that_set_nothing(sys.argv):
        node.get_logger().warning(f"params file {cut_path(path)} sets nothing: {why}")
    _apply_command_line(node, given)
    for name in sorted(set(given) & set(ALIASES)):  # the original handler's other spellings
        value = given.pop(name)
        node.undeclare_parameter(name)
        for target in ALIASES[name]:
            given.setdefault(target, value)
    block = _blocks(given)
    _report_unknown(node, given)
    values: dict[str, Any] = {}
    for param in SCHEMA:
        if param.name in given:
            value = _coerced(param, given[param.name])  # ConfigError names the parameter and the type
            if node.has_parameter(param.name):  # not when it came under another spelling (ALIASES)
                node.undeclare_parameter(param.name)
        else:
            value = param.default
        values[param.name] = value
        descriptor = ParameterDescriptor(name=param.name, type=_ROS_TYPES[param.type],
                                         description=param.description, read_only=True)
        node.declare_parameter(param.name, list(value) if isinstance(value, list) else value,
                               descriptor, ignore_override=True)
    config = validate({**values, **block})
    declare_servo_block(node, {k: v for k, v in block.items() if is_servo_parameter(k)}, config.settings.servos)
    return config


def _blocks(given: dict[str, Any]) -> dict[str, Any]:
    """The servos block (``servos.<name>.<item>``) and the joints block (``joints.<name>.<key>``),
    taken out of ``given``: names of their own, not in ``SCHEMA``."""
    names = [name for name in sorted(given) if is_servo_parameter(name) or is_joint_parameter(name)]
    return {name: given.pop(name) for name in names}


#: the 64-bit range of a ROS integer parameter
_INT64 = range(-(1 << 63), 1 << 63)
#: unknown names given a line each; the others are counted in one more line
_UNKNOWN_SHOWN = 20


def _coerced(param: Any, value: Any) -> Any:
    """``value`` in ``param``'s type (config.coerce), an integer also within ROS's 64-bit range
    (``1e20`` for an int would otherwise fail inside rclpy); ConfigError with the value cut short."""
    try:
        got = coerce(param, value)
    except ConfigError as err:
        if len(str(err)) <= 2 * ECHO_MAX:
            raise
        raise ConfigError(f"parameter '{param.name}' must be {param.type}, got {cut(repr(value))} "
                          f"({type(value).__name__})") from None
    for item in got if isinstance(got, list) else [got]:
        if type(item) is int and item not in _INT64:
            raise ConfigError(f"parameter '{param.name}' must be {param.type}, got {cut(value)}: beyond the range of a "
                              "ROS integer (-2^63 .. 2^63-1)")
    return got


def _report_unknown(node: Node, given: dict[str, Any]) -> None:
    """One error line for each name that is no parameter of the handler (ignored), the first
    ``_UNKNOWN_SHOWN`` of them; one line counts the rest."""
    unknown = [name for name in sorted(given) if not (
        name in SCHEMA_BY_NAME or name in _ROS_OWN or name.startswith(TOLERATED_PREFIXES))]
    for name in unknown[:_UNKNOWN_SHOWN]:
        hint = difflib.get_close_matches(name, SCHEMA_BY_NAME, n=1) if len(name) <= ECHO_MAX else []
        node.get_logger().error(
            f"unknown parameter '{cut(name)}' ignored" + (f": did you mean '{hint[0]}'?" if hint else ""))
    if len(unknown) > _UNKNOWN_SHOWN:
        node.get_logger().error(f"{len(unknown) - _UNKNOWN_SHOWN} more unknown parameters ignored")


def _command_line_parameters(argv: list[str]) -> dict[str, str]:
    """``-p name:=value`` / ``--param name:=value`` of the ROS arguments in ``argv`` (last one wins)."""
    out: dict[str, str] = {}
    ros = False
    for k, arg in enumerate(argv):
        if arg == "--ros-args":
            ros = True
        elif arg == "--":
            ros = False
        elif ros and arg in ("-p", "--param") and k + 1 < len(argv) and ":=" in argv[k + 1]:
            name, value = argv[k + 1].split(":=", 1)
            out[name.rsplit(":", 1)[-1]] = value  # "node:name:=value" is for the node named "node"
    return out


def check_arguments(argv: list[str]) -> str | None:
    """What is wrong with the ROS arguments before rcl reads them (rcl says only "Couldn't parse"
    and logs a line of its own): a params file that is missing or is not YAML (file and line), the
    files given together over the limits of their sum, a ``-p name:=`` without a value. None if
    nothing is found."""
    ros = False
    totals = Totals()
    for k, arg in enumerate(argv):
        if arg in ("--ros-args", "--"):
            ros = arg == "--ros-args"
            continue
        problem = None
        if ros and arg == "--params-file" and k + 1 < len(argv):
            problem = _params_file_problem(argv[k + 1], totals)
        elif ros and arg in ("-p", "--param") and k + 1 < len(argv):
            problem = _rule_problem(arg, argv[k + 1])
        if problem is not None:
            return problem
    return None


def _params_file_problem(path: str, totals: Totals) -> str | None:
    """Why a params file is refused: too large, too deep or too many entries (on the text, before
    any parsing), alone or added to the files before it (``totals``), or not YAML (file and line);
    None if it is not."""
    import yaml
    problem, text = read_problem(path)
    if problem is None:
        problem = totals.add(text)
    if problem is not None:
        return problem
    try:
        _load_yaml(text)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""
        problem = getattr(err, "problem", None) or str(err).splitlines()[0]
        return f"params file {cut_path(path)}: not valid YAML: {where}{cut(problem)}"
    return None


def _load_yaml(text: str) -> Any:
    """``text`` as YAML with the safe loader (libyaml's when there is one: a large file in a
    fraction of the time)."""
    import yaml
    return yaml.load(text, Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))


def files_that_set_nothing(argv: list[str]) -> list[tuple[str, str]]:
    """The ``--params-file`` files of the ROS arguments that set no parameter of any node (empty, a
    YAML scalar or list, or mappings without a ``ros__parameters`` entry), each with why."""
    import yaml
    out = []
    ros = False
    for k, arg in enumerate(argv):
        if arg in ("--ros-args", "--"):
            ros = arg == "--ros-args"
        elif ros and arg == "--params-file" and k + 1 < len(argv):
            problem, text = read_problem(argv[k + 1])
            if problem is not None:
                continue  # check_arguments has stopped start-up for these
            try:
                data = _load_yaml(text)
            except yaml.YAMLError:
                continue
            why = _why_nothing(data)
            if why is not None:
                out.append((argv[k + 1], why))
    return out


def _why_nothing(data: Any) -> str | None:
    if data is None:
        return "it is empty"
    if not isinstance(data, dict):
        kind = "list" if isinstance(data, list) else "scalar"
        return (f"it is a YAML {kind} ({cut(data, 40)}), not a mapping of node names to ros__parameters "
                "(see config/config_dynamixel_handler.yaml)")
    if not _has_parameters(data):
        return "no node in it has a non-empty 'ros__parameters' mapping (see config/config_dynamixel_handler.yaml)"
    return None


def _has_parameters(data: dict, depth: int = 0) -> bool:
    """A non-empty ``ros__parameters`` mapping anywhere under node names and namespaces."""
    section = data.get("ros__parameters")
    if isinstance(section, dict) and section:
        return True
    return depth < 8 and any(isinstance(v, dict) and _has_parameters(v, depth + 1)
                             for k, v in data.items() if k != "ros__parameters")


def _rule_problem(flag: str, rule: str) -> str | None:
    """What is wrong with a ``-p name:=value`` (no ``:=``, no value), or None."""
    name, sep, value = rule.partition(":=")
    if not sep:
        return f"{flag} {cut(rule)}: not of the form name:=value"
    if value == "":
        return f"{flag} {cut(rule)}: no value given (for an empty string: {name}:=''), or leave it out"
    return None


def _apply_command_line(node: Node, given: dict[str, Any]) -> None:
    """A ``-p name:=value`` of the command line always wins. ROS loses some without a word: one
    whose type differs from the value a ``--params-file`` gives (``-p loop_rate:=50.0`` against
    ``loop_rate: 100``), and one that a later params file for ``/**`` overrides when several are
    given (as ``scripts/run.sh`` does). Such a value is applied here, in the parameter's own type;
    one that cannot be (``-p baudrate:=fast``) stops start-up with a line naming it and why."""
    from rclpy.parameter import get_parameter_value
    for name, text in _command_line_parameters(sys.argv).items():
        wanted = Parameter.from_parameter_msg(rcl_interfaces.msg.Parameter(name=name, value=get_parameter_value(text)))
        value = _plain(wanted.value)
        if name in given and _same(value, _plain(given.get(name))):
            continue
        param = SCHEMA_BY_NAME.get(name)
        if param is not None:
            try:
                coerce(param, value)
            except ConfigError as err:
                raise ConfigError(f"the command-line value -p {name}:={cut(text)} cannot be applied: {err}") from None
        if name in given:
            node.get_logger().info(f"parameter '{name}': the command-line value {cut(text)} applied (ROS had kept "
                                   f"{cut(repr(given[name]))} from a parameter file)")
        given[name] = value


def _plain(value: Any) -> Any:
    """Sequences (tuples, arrays) as lists, so that values compare as the user sees them."""
    return list(value) if isinstance(value, (list, tuple)) or hasattr(value, "tolist") else value


def _same(value: Any, got: Any) -> bool:
    """The command-line value is what ROS kept (an int given for a float parameter included)."""
    return bool(value == got or (type(value) is int and type(got) is float and float(value) == got))


def describe(config: Config, width: int = 120) -> list[str]:
    """Lines for the start-up log: the essentials, then every parameter that differs from its default."""
    essentials = ("device_name", "baudrate", "latency_timer", "loop_rate")
    series = "/".join(config.settings.scan.used_series)
    lines = [", ".join(f"{n}={config[n]}" for n in essentials) + f", series={series}"]
    others = [p for p in SCHEMA if p.name not in essentials]
    changed = [p for p in others if config[p.name] != p.default]
    lines.append(f"{len(others) - len(changed)} other parameters at their defaults, {len(changed)} set:"
                 if changed else f"all other {len(others)} parameters at their defaults")
    lines += [f"  {p.name}: {config[p.name]!r} (default {p.default!r})"[:width] for p in changed]
    return lines


__all__ = ["ConfigError", "check_arguments", "declare_and_load", "describe"]
