"""``dynamixel_unify_baudrate``: set every servo of a bus to one baud rate, then exit.

Run it once on a robot whose servos were configured at different baud rates::

    dynamixel_unify_baudrate --ros-args --params-file config/config_unify_baudrate.yaml \\
        -p device_name:=/dev/ttyUSB0 -p target_baudrate:=1000000

Parameters: ``device_name target_baudrate latency_timer min_id max_id min_search_baudrate
max_search_baudrate``. Exit code 0 when every servo found answers at the target rate, 1 when
the device cannot be used or a servo could not be moved, 2 for a bad parameter (one line says
which and why). The work itself is :func:`dynamixel_handler.tools.baudrate.unify_baudrate`; this is its ROS face
(the only module outside the node's that imports rclpy, so it lives in ``ros/``).
"""
from __future__ import annotations

import difflib
import sys

import rclpy
from rcl_interfaces.msg import ParameterDescriptor, ParameterType
from rclpy.logging import get_logger
from rclpy.node import Node

from ..bus import BusError, DynamixelBus
from ..tools.baudrate import TOOL_PARAMS, search_rates, unify_baudrate, validate_tool_params
from .params import check_arguments

NODE_NAME = "dynamixel_unify_baudrate"
EXIT_OK, EXIT_FAILED, EXIT_BAD_PARAMETER, EXIT_INTERRUPTED = 0, 1, 2, 130
_ROS_TYPES = {int: ParameterType.PARAMETER_INTEGER, str: ParameterType.PARAMETER_STRING}
_ROS_OWN = {"use_sim_time", "start_type_description_service"}


class _Log:
    """logging.Logger-like face of the node's logger, for the ROS-free bus and tool code."""

    def __init__(self, ros_logger) -> None:
        self._log = ros_logger

    def debug(self, msg: str) -> None:
        self._log.debug(msg)

    def info(self, msg: str) -> None:
        self._log.info(msg)

    def warning(self, msg: str) -> None:
        self._log.warning(msg)

    def error(self, msg: str) -> None:
        self._log.error(msg)


class UnifyBaudrateNode(Node):
    """Reads and checks the parameters; :meth:`run` does the unification once."""

    def __init__(self) -> None:
        super().__init__(NODE_NAME, automatically_declare_parameters_from_overrides=True)
        self.log = _Log(self.get_logger())
        given = {name: self.get_parameter(name).value for name in self.get_parameters_by_prefix("") if name not in _ROS_OWN}
        for name in sorted(set(given) - set(TOOL_PARAMS)):
            hint = difflib.get_close_matches(name, TOOL_PARAMS, n=1)
            self.log.warning(f"unknown parameter '{name}' ignored" + (f": did you mean '{hint[0]}'?" if hint else ""))
        self.params = validate_tool_params({k: v for k, v in given.items() if k in TOOL_PARAMS})
        for name, (typ, _, description) in TOOL_PARAMS.items():
            if self.has_parameter(name):
                self.undeclare_parameter(name)
            self.declare_parameter(name, getattr(self.params, name), ParameterDescriptor(
                name=name, type=_ROS_TYPES[typ], description=description, read_only=True), ignore_override=True)

    def run(self) -> int:
        p = self.params
        rates = search_rates(p.min_search_baudrate, p.max_search_baudrate)
        ids = range(p.min_id, p.max_id + 1)
        self.log.info(f"unifying the baud rate of IDs {p.min_id}..{p.max_id} on {p.device_name} "
                      f"to {p.target_baudrate} bps; searching {', '.join(map(str, rates))} bps")
        bus = DynamixelBus(p.device_name, p.target_baudrate, float(p.latency_timer), logger=self.log)
        try:
            bus.open()
        except BusError as err:
            self.log.error(str(err))
            return EXIT_FAILED
        try:
            report = unify_baudrate(bus, p.target_baudrate, ids, rates, self.log)
        finally:
            bus.close()
        lines = report.summary()
        for line in lines:  # one log line each: every line carries severity and the node's name
            (self.log.info if report.ok else self.log.error)(line)
        return EXIT_OK if report.ok else EXIT_FAILED


def main(args: list[str] | None = None) -> int:
    """Console entry point; returns the process exit code."""
    problem = check_arguments(sys.argv if args is None else args)
    if problem is not None:  # a hostile or broken params file: one line, before rcl reads it
        get_logger(NODE_NAME).fatal(f"bad ROS arguments: {problem}")
        return EXIT_BAD_PARAMETER
    try:
        rclpy.init(args=args)
    except Exception as exc:  # malformed --ros-args: rcl says why
        get_logger(NODE_NAME).fatal(f"cannot start: {str(exc).splitlines()[0].split(', at ')[0]}")
        return EXIT_BAD_PARAMETER
    node = None
    code = EXIT_FAILED
    try:
        node = UnifyBaudrateNode()
        code = node.run()
    except ValueError as err:
        logger = node.get_logger() if node is not None else get_logger(NODE_NAME)
        logger.error(str(err))
        code = EXIT_BAD_PARAMETER
    except KeyboardInterrupt:
        (node.get_logger() if node is not None else get_logger(NODE_NAME)).warning(
            "interrupted: servos may be left at different baud rates; run it again")
        code = EXIT_INTERRUPTED
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return code


if __name__ == "__main__":
    sys.exit(main())
