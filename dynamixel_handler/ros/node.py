"""The dynamixel_handler node: parameters, then the handler, spun until SIGINT/SIGTERM."""
from __future__ import annotations

import os
import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from .params import ConfigError, declare_and_load, describe

NODE_NAME = "dynamixel_handler"


class DynamixelHandlerNode(Node):
    def __init__(self) -> None:
        super().__init__(NODE_NAME, automatically_declare_parameters_from_overrides=True)
        self.config = declare_and_load(self)
        log = self.get_logger()
        log.info("parameters:\n" + "\n".join(describe(self.config)))


def main(args: list[str] | None = None) -> int:
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    rclpy.init(args=args)
    node = None
    code = 0
    try:
        node = DynamixelHandlerNode()
        rclpy.spin(node)
    except ConfigError as err:
        rclpy.logging.get_logger(NODE_NAME).fatal(f"bad parameter: {err}")
        code = 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        if rclpy.ok():
            rclpy.try_shutdown()
    return code


if __name__ == "__main__":
    sys.exit(main())
