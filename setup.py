"""ament_python package of the dynamixel_handler node (the messages live in dynamixel_handler_msgs/)."""
from glob import glob

from setuptools import find_packages, setup

PACKAGE = "dynamixel_handler"

setup(
    name=PACKAGE,
    version="1.2.0",
    packages=find_packages(include=[PACKAGE, f"{PACKAGE}.*"]),
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", glob("config/*.yaml")),
        (f"share/{PACKAGE}/launch", glob("launch/*.py") + glob("launch/*.xml")),
    ],
    install_requires=["setuptools"],  # runtime deps: see requirements.txt (numpy, pyserial, dynamixel-sdk)
    zip_safe=True,
    maintainer="dynamixel_handler developers",
    maintainer_email="dev@dynamixel-handler.example.com",
    description="Drive Dynamixel servos (every Protocol 2.0 model) with ROS 2 topics in physical units.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            f"dynamixel_handler = {PACKAGE}.ros.node:main",
            f"dynamixel_handler_lifecycle = {PACKAGE}.ros.lifecycle_node:main",
            f"dynamixel_handler_sim = {PACKAGE}.sim.cli:main",
            f"dynamixel_unify_baudrate = {PACKAGE}.ros.unify_baudrate:main",
            # the terminal set-up tool; `ros2 run dynamixel_handler setup` is the same program
            f"dynamixel_handler_setup = {PACKAGE}.setup_tool:main",
            f"setup = {PACKAGE}.setup_tool:main",
            # the original handler's executable names, for launch files written for it
            f"dynamixel_handler_node = {PACKAGE}.ros.node:main",
            f"dynamixel_unify_baudrate_node = {PACKAGE}.ros.unify_baudrate:main",
        ],
    },
)
