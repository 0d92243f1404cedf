"""The package's public names: what ``from dynamixel_handler import ...`` gives, and that importing
the package (or its ROS-free parts) stays cheap and never pulls in rclpy."""
from __future__ import annotations

import subprocess
import sys

import pytest

import dynamixel_handler


@pytest.mark.parametrize("name, module", [
    ("Handler", "core.handler"), ("Runner", "loop.runner"), ("Hooks", "loop.runner"), ("Commander", "commands"),
    ("DynamixelBus", "bus"), ("VirtualBus", "sim"), ("Settings", "settings"), ("ScanSettings", "settings"),
    ("validate", "config"), ("Config", "config"),
])
def test_a_public_name_is_the_object_of_its_module(name, module):
    import importlib
    assert getattr(dynamixel_handler, name) is getattr(importlib.import_module(f"dynamixel_handler.{module}"), name)


def test_every_listed_name_is_there_and_others_are_not():
    for name in dynamixel_handler.__all__:
        assert getattr(dynamixel_handler, name) is not None, name
    assert set(dynamixel_handler.__all__) <= set(dir(dynamixel_handler))
    with pytest.raises(AttributeError, match="no attribute 'Nothing'"):
        dynamixel_handler.Nothing  # noqa: B018


def _loaded_after(code: str) -> set[str]:
    out = subprocess.run([sys.executable, "-c", f"{code}\nimport sys\nprint(' '.join(sys.modules))"],
                         capture_output=True, text=True, timeout=60, check=True)
    return set(out.stdout.split())


def test_importing_the_package_imports_none_of_its_parts():
    loaded = _loaded_after("import dynamixel_handler")
    assert not {m for m in loaded if m.startswith("dynamixel_handler.")}
    assert not loaded & {"numpy", "dynamixel_sdk", "serial", "rclpy", "typing"}


def test_the_ros_free_parts_import_without_rclpy():
    loaded = _loaded_after("import dynamixel_handler.sim, dynamixel_handler.loop, dynamixel_handler.loop.runner\n"
                           "from dynamixel_handler import Commander, Handler, Settings, VirtualBus")
    assert "dynamixel_handler.loop" in loaded and "rclpy" not in loaded


def test_the_former_loop_module_names_still_import():
    from dynamixel_handler.core import handler
    from dynamixel_handler.loop import Handler, StepReport, mode_value
    assert (Handler, StepReport, mode_value) == (handler.Handler, handler.StepReport, handler.mode_value)
